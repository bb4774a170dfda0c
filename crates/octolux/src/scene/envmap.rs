//! Environment map emitter (Mitsuba's `envmap`): a latitude-longitude radiance image at
//! infinity, evaluated for escaped rays and importance-sampled for next-event estimation and
//! photon emission (the photon pass of Pacanowski et al. §2 emits from every light, this one
//! included, through the disk of the scene's bounding sphere).
//!
//! Convention (Mitsuba 3's, checked against Mitsuba 3.9.1 in the tests): in the map's local
//! frame `+y` is up; a direction `d` has texture coordinates
//! `u = atan2(d.x, -d.z) / 2π` (wrapped into [0,1)) and `v = acos(d.y) / π`, so `u = 0` looks
//! along `-z`, `u = 1/4` along `+x`, and `v = 0` is the zenith (`+y`). Lookups are bilinear:
//! periodic and pixel-centred in `u` (pixel `i` sits at `u = (i + ½) / width`), and
//! vertex-centred in `v` (row `j` sits at `v = j / (height - 1)`, the first row at the zenith,
//! the last at the nadir). `to_world` maps local to world directions (a rotation, possibly
//! mirrored); radiance is `scale` times the interpolated pixel (W/(m² sr)).
//!
//! Sampling: [`LatLong`] splits the sphere into the cells between neighbouring lookup points
//! (`width` cells in φ, `height - 1` in θ) and picks one with probability proportional to the
//! exact integral of the bilinearly interpolated luminance times `sin θ` over it, i.e. the
//! luminance-weighted solid angle; inside the cell the direction is uniform in solid angle
//! (uniform in φ and in `cos θ`). The solid-angle density of a direction is therefore
//! `P(cell) / (Δφ (cos θ₀ − cos θ₁))`: bounded, and positive wherever the radiance is.
//! The cell is drawn by inverting the marginal CDF over rows, then the row's CDF
//! ([`Distribution2D`]); each search goes through its guide table, so that a sample of a
//! 2048x1024 map reads one or two cache lines of its row instead of a chain of eleven spread
//! over 16 KB (docs/lab/2026-12-04-light-tree-env-sampling.md: the hierarchical warp and the
//! alias table measured against it). On maps of at least 64 columns (`FAST_MIN_WIDTH`) no libm
//! function is called per sample or density: a direction's cell is guessed by polynomials and
//! settled against the stored borders, and a sample's `φ` rotates its column's border by a
//! small angle (docs/lab/2026-12-07-sky-sampling.md).

use crate::image::Image;
use crate::math::{acos_approx, atan2_approx, luminance, sin_cos_small, Color};
use crate::sampling::Distribution2D;
use glam::{DVec3, Mat3, Vec2, Vec3};
use std::f64::consts::PI as PI64;

/// A latitude-longitude table of radiance with its sampling distribution (local frame).
#[derive(Clone, Debug)]
pub struct LatLong {
    width: usize,
    /// Rows of lookup points (`>= 2`).
    height: usize,
    data: Vec<Color>,
    dist: Option<Distribution2D>,
    /// `cos θ` of the row boundaries `θ_j = j π / (height - 1)`, `j = 0..height`, computed
    /// once (the samples and densities read them instead of two `cos` per call).
    row_cos: Vec<f64>,
    /// `(sin φ_k, cos φ_k)` of the column boundaries `φ_k = 2π (k + ½) / width`, `k = 0..width`
    /// (cell `k` lies between boundaries `k` and `k + 1`); empty below [`FAST_MIN_WIDTH`].
    col_sc: Vec<[f64; 2]>,
    /// `∫ L dω` over the sphere (W/m² per unit... i.e. radiance times steradians), per channel.
    integral: Color,
}

/// Maps at least this wide find a direction's cell without `atan2` and `acos`, and sample
/// within a column without `sin`/`cos` ([`LatLong::cell_of`], [`LatLong::sample_direction`]):
/// a column is then at most 2π/64 wide, where the polynomials are exact to f64 rounding.
const FAST_MIN_WIDTH: usize = 64;

/// Texture coordinates `(u, v)` of a local direction (Mitsuba's convention, module docs).
#[inline]
pub fn direction_to_uv(d: Vec3) -> Vec2 {
    let mut u = d.x.atan2(-d.z) * (0.5 * std::f32::consts::FRAC_1_PI);
    u -= u.floor();
    let v = d.y.clamp(-1.0, 1.0).acos() * std::f32::consts::FRAC_1_PI;
    Vec2::new(if u < 1.0 { u } else { 0.0 }, v)
}

/// Local direction of texture coordinates `(u, v)` (inverse of [`direction_to_uv`]).
#[inline]
pub fn uv_to_direction(uv: Vec2) -> Vec3 {
    let (st, ct) = (uv.y * std::f32::consts::PI).sin_cos();
    let (sp, cp) = (uv.x * std::f32::consts::TAU).sin_cos();
    Vec3::new(st * sp, ct, -st * cp)
}

impl LatLong {
    /// Build from `width × height` pixels, row 0 at the zenith. A single row is treated as
    /// two equal rows (zenith and nadir). Non-finite or negative values are errors.
    pub fn new(width: usize, height: usize, pixels: &[Color]) -> Result<LatLong, String> {
        if width == 0 || height == 0 || pixels.len() != width * height {
            return Err(format!("an environment map needs width x height pixels, got {} for {width}x{height}", pixels.len()));
        }
        if let Some(p) = pixels.iter().find(|p| !p.is_finite() || p.min_element() < 0.0) {
            return Err(format!("environment map pixel {p} is negative or not finite"));
        }
        let (data, height) = if height == 1 { ([pixels, pixels].concat(), 2) } else { (pixels.to_vec(), height) };
        let (nx, ny) = (width, height - 1);
        let dphi = 2.0 * PI64 / nx as f64;
        let dtheta = PI64 / ny as f64;
        let mut weights = Vec::with_capacity(nx * ny);
        let mut integral = DVec3::ZERO;
        for j in 0..ny {
            let (t0, t1) = (j as f64 * dtheta, (j + 1) as f64 * dtheta);
            // ∫ over [t0, t1] of (1 - s) sin θ dθ and of s sin θ dθ, s = (θ - t0) / Δθ
            let whole = t0.cos() - t1.cos();
            let upper = (t1.sin() - t0.sin()) / dtheta - t1.cos();
            let lower = whole - upper;
            for i in 0..nx {
                let i1 = (i + 1) % nx;
                let a = (data[j * width + i] + data[j * width + i1]).as_dvec3() * 0.5;
                let b = (data[(j + 1) * width + i] + data[(j + 1) * width + i1]).as_dvec3() * 0.5;
                let cell = (a * lower + b * upper) * dphi;
                integral += cell;
                weights.push(luminance(cell.as_vec3()).max(0.0));
            }
        }
        // Luminance can vanish for positive colours only in pathological cases (it is a positive
        // combination); the channel mean keeps such cells reachable.
        for (w, k) in weights.iter_mut().zip(0..) {
            if *w == 0.0 {
                let (i, j) = (k % nx, k / nx);
                let i1 = (i + 1) % nx;
                let s = data[j * width + i] + data[j * width + i1] + data[(j + 1) * width + i] + data[(j + 1) * width + i1];
                *w = (s.x + s.y + s.z) * 1e-6;
            }
        }
        let dist = Distribution2D::new(&weights, nx, ny);
        let row_cos = (0..=ny).map(|j| (j as f64 * PI64 / ny as f64).cos()).collect();
        let col_sc = if nx >= FAST_MIN_WIDTH {
            (0..nx).map(|k| (2.0 * PI64 * (k as f64 + 0.5) / nx as f64).sin_cos()).map(|(s, c)| [s, c]).collect()
        } else {
            Vec::new()
        };
        Ok(LatLong { width, height, data, dist, row_cos, col_sc, integral: integral.as_vec3() })
    }

    /// Bilinear radiance lookup at texture coordinates `uv` (module docs).
    #[inline]
    pub fn eval_uv(&self, uv: Vec2) -> Color {
        let x = uv.x * self.width as f32 - 0.5;
        let x0 = x.floor();
        let fx = x - x0;
        let i0 = (x0 as i64).rem_euclid(self.width as i64) as usize;
        let i1 = (i0 + 1) % self.width;
        let y = (uv.y.clamp(0.0, 1.0) * (self.height - 1) as f32).min((self.height - 1) as f32);
        let j0 = (y.floor() as usize).min(self.height - 2);
        let fy = y - j0 as f32;
        let row0 = &self.data[j0 * self.width..];
        let row1 = &self.data[(j0 + 1) * self.width..];
        let top = row0[i0] * (1.0 - fx) + row0[i1] * fx;
        let bottom = row1[i0] * (1.0 - fx) + row1[i1] * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Radiance from local direction `d` (unit).
    #[inline]
    pub fn eval(&self, d: Vec3) -> Color {
        self.eval_uv(direction_to_uv(d))
    }

    /// `∫ L dω` over the sphere, per channel (exact for the bilinear lookup).
    pub fn integral(&self) -> Color {
        self.integral
    }

    /// Cell `(column, row)` of a local direction: the cell [`Self::sample_direction`] draws it
    /// in. Maps of at least [`FAST_MIN_WIDTH`] columns take a first guess from [`atan2_approx`]
    /// and [`acos_approx`] (within a fraction of a cell) and settle it against the stored
    /// borders (the boundary's side by the sign of a cross product, the row by `cos θ`); smaller
    /// ones compute the texture coordinates.
    #[inline]
    fn cell_of(&self, d: Vec3) -> (usize, usize) {
        let nx = self.width;
        let ny = self.height - 1;
        let by_uv = || {
            let uv = direction_to_uv(d);
            let x = uv.x * nx as f32 - 0.5;
            let ix = (x.floor() as i64).rem_euclid(nx as i64) as usize;
            let iy = ((uv.y * ny as f32) as usize).min(ny - 1);
            (ix, iy)
        };
        if self.col_sc.is_empty() {
            return by_uv();
        }
        // (sin φ, cos φ) times the distance from the axis
        let (a, b) = (d.x, -d.z);
        // φ / 2π in [-½, ½] times the columns, a whole turn added to keep the cast's argument
        // positive; no `%` (an integer division costs more than the rest of the guess)
        let t = atan2_approx(a, b) * (0.5 * std::f32::consts::FRAC_1_PI) * nx as f32 - 0.5 + nx as f32;
        let wrap = |i: usize| if i >= nx { i - nx } else { i };
        let mut ix = wrap((t as usize).min(2 * nx - 1));
        // sin(φ − φ_k) times the distance from the axis: ≥ 0 past boundary k
        let past = |k: usize| (a as f64) * self.col_sc[k][1] - (b as f64) * self.col_sc[k][0] >= 0.0;
        // one step settles any guess on maps narrower than 2π / 2e-5 columns; a few more are
        // allowed, then (a direction on the axis, where every border is passed; a map wider
        // still) the texture coordinates decide
        let mut steps = 0;
        while !past(ix) && steps < 4 {
            ix = wrap(ix + nx - 1);
            steps += 1;
        }
        while past(wrap(ix + 1)) && steps < 4 {
            ix = wrap(ix + 1);
            steps += 1;
        }
        if steps == 4 {
            return by_uv();
        }
        let y = d.y as f64;
        let mut iy = ((acos_approx(d.y) * (ny as f32 * std::f32::consts::FRAC_1_PI)) as usize).min(ny - 1);
        while iy > 0 && y > self.row_cos[iy] {
            iy -= 1;
        }
        while iy + 1 < ny && y < self.row_cos[iy + 1] {
            iy += 1;
        }
        (ix, iy)
    }

    /// Solid angle of the cells of row `iy`, i.e. `Δφ (cos θ₀ − cos θ₁)`.
    #[inline]
    fn cell_solid_angle(&self, iy: usize) -> f32 {
        ((2.0 * PI64 / self.width as f64) * (self.row_cos[iy] - self.row_cos[iy + 1])) as f32
    }

    /// Sample a local direction; returns it, its radiance and its solid-angle density.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Color, f32)> {
        let (d, pdf) = self.sample_direction(u)?;
        Some((d, self.eval(d), pdf))
    }

    /// [`Self::sample`] without the radiance lookup: the direction and its density.
    #[inline]
    pub fn sample_direction(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let dist = self.dist.as_ref()?;
        let (ix, iy, p, r) = dist.sample_cell(u)?;
        let nx = self.width as f64;
        let (sin_p, cos_p) = match self.col_sc.get(ix) {
            // φ = φ_ix + δ: the column's border rotated by the small angle δ
            Some(&[s0, c0]) => {
                let (s, c) = sin_cos_small(2.0 * PI64 * r.x as f64 / nx);
                (s0 * c + c0 * s, c0 * c - s0 * s)
            }
            None => (2.0 * PI64 * ((ix as f64 + 0.5 + r.x as f64) / nx)).sin_cos(),
        };
        let (c0, c1) = (self.row_cos[iy], self.row_cos[iy + 1]);
        let cos_t = c0 + (c1 - c0) * r.y as f64;
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let d = DVec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p).as_vec3();
        let pdf = p / self.cell_solid_angle(iy);
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        Some((d, pdf))
    }

    /// Solid-angle density with which [`Self::sample`] picks local direction `d`.
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        let Some(dist) = self.dist.as_ref() else { return 0.0 };
        let (ix, iy) = self.cell_of(d);
        let p = dist.pmf(ix, iy);
        if p > 0.0 {
            p / self.cell_solid_angle(iy)
        } else {
            0.0
        }
    }
}

/// A prepared environment map: table, scale and orientation.
#[derive(Clone, Debug)]
pub struct EnvMap {
    table: LatLong,
    scale: f32,
    to_world: Mat3,
    to_local: Mat3,
}

impl EnvMap {
    /// Prepare `image` (linear RGB, row 0 at the zenith) with radiance scale `scale` and an
    /// orthogonal `to_world` (columns: the local axes in world space).
    pub fn new(image: &Image, scale: f32, to_world: Mat3) -> Result<EnvMap, String> {
        check_frame(scale, &to_world)?;
        let table = LatLong::new(image.width as usize, image.height as usize, &image.data)?;
        Ok(EnvMap { table, scale, to_world, to_local: to_world.transpose() })
    }

    /// Radiance arriving from world direction `dir` (unit; a ray leaving the scene along `dir`).
    #[inline]
    pub fn eval(&self, dir: Vec3) -> Color {
        self.table.eval(self.to_local * dir) * self.scale
    }

    /// Sample a world direction towards the map; returns it, its radiance and its solid-angle pdf.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Color, f32)> {
        let (w, pdf) = self.sample_direction(u)?;
        Some((w, self.eval(w), pdf))
    }

    /// [`Self::sample`] without the radiance: the direction and its solid-angle pdf (`None` in
    /// the same cases).
    #[inline]
    pub fn sample_direction(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let (d, _) = self.table.sample_direction(u)?;
        // Pdf (and radiance) of the world direction itself, so that they agree exactly with
        // `eval` and `pdf` (the round trip through `to_world` moves directions by an ulp).
        let w = (self.to_world * d).normalize();
        let pdf = self.pdf(w);
        (pdf > 0.0).then_some((w, pdf))
    }

    /// Solid-angle density of [`Self::sample`] for world direction `dir`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        self.table.pdf(self.to_local * dir)
    }

    /// `∫ L dω` over the sphere, per channel.
    pub fn integral(&self) -> Color {
        self.table.integral() * self.scale
    }
}

/// Check a scale and an orthogonal frame (rotation, possibly mirrored).
pub fn check_frame(scale: f32, to_world: &Mat3) -> Result<(), String> {
    if !(scale.is_finite() && scale >= 0.0) {
        return Err(format!("scale {scale} must be finite and non-negative"));
    }
    let m = *to_world;
    let err = (m.transpose() * m - Mat3::IDENTITY).to_cols_array().iter().fold(0.0f32, |a, &b| a.max(b.abs()));
    if !(err < 1e-3) {
        return Err(format!("to_world {m} must be a rotation (possibly mirrored); its columns are not orthonormal"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;
    use crate::testing::{chi2_2d_piecewise as chi2_2d, Chi2Config};

    fn image(width: u32, height: u32, f: impl Fn(u32, u32) -> Color) -> Image {
        let data = (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
        Image { width, height, data }
    }

    /// A test map: distinct values per pixel, one very bright pixel, a black band.
    fn test_image() -> Image {
        image(8, 5, |x, y| {
            if y == 3 {
                Color::ZERO
            } else if (x, y) == (5, 1) {
                Color::new(50.0, 40.0, 10.0)
            } else {
                Color::new(x as f32 + 1.0, 10.0 * (y as f32 + 1.0), 100.0 + (x * y) as f32) * 0.01
            }
        })
    }

    #[test]
    fn uv_mapping_is_mitsubas_and_round_trips() {
        // u = 0 looks along -z, u = 1/4 along +x, v = 0 is +y.
        assert!((uv_to_direction(Vec2::new(0.0, 0.5)) - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        assert!((uv_to_direction(Vec2::new(0.25, 0.5)) - Vec3::X).length() < 1e-6);
        assert!((uv_to_direction(Vec2::new(0.5, 0.5)) - Vec3::Z).length() < 1e-6);
        assert!((uv_to_direction(Vec2::new(0.3, 0.0)) - Vec3::Y).length() < 1e-6);
        let mut s = Sampler::new(1, 0, 0);
        for _ in 0..1000 {
            let uv = Vec2::new(s.next_1d(), 0.01 + 0.98 * s.next_1d());
            let back = direction_to_uv(uv_to_direction(uv));
            assert!((back - uv).length() < 1e-4, "{uv} -> {back}");
        }
    }

    #[test]
    fn bilinear_lookup_is_periodic_and_pixel_centred_in_u_vertex_centred_in_v() {
        let img = image(8, 4, |x, y| Color::new(x as f32 + 1.0, 10.0 * (y as f32 + 1.0), 100.0 + (x * y) as f32));
        let t = LatLong::new(8, 4, &img.data).unwrap();
        // values dumped from Mitsuba 3.9.1 (scalar_rgb) for this very image
        let cases = [
            (Vec2::new(0.0, 0.5), Color::new(4.5, 25.0, 105.25)),
            (Vec2::new(0.0625, 0.5), Color::new(1.0, 25.0, 100.0)),
            (Vec2::new(0.125, 0.5), Color::new(1.5, 25.0, 100.75)),
            (Vec2::new(0.999, 0.5), Color::new(4.556, 25.0, 105.334)),
            (Vec2::new(0.0625, 1.0 / 3.0), Color::new(1.0, 20.0, 100.0)),
            (Vec2::new(0.25, 1.0), Color::new(2.5, 40.0, 104.5)),
            (Vec2::new(0.3, 0.2), Color::new(2.9, 16.0, 101.14)),
        ];
        for (uv, want) in cases {
            let got = t.eval_uv(uv);
            assert!((got - want).abs().max_element() < 2e-3 * want.max_element(), "{uv}: {got} vs {want}");
        }
    }

    #[test]
    fn integral_matches_quadrature() {
        let img = test_image();
        let t = LatLong::new(8, 5, &img.data).unwrap();
        // midpoint rule in (φ, θ)
        let (n_phi, n_theta) = (800, 400);
        let mut acc = DVec3::ZERO;
        for j in 0..n_theta {
            let theta = (j as f64 + 0.5) / n_theta as f64 * PI64;
            for i in 0..n_phi {
                let phi = (i as f64 + 0.5) / n_phi as f64 * 2.0 * PI64;
                let uv = Vec2::new((phi / (2.0 * PI64)) as f32, (theta / PI64) as f32);
                acc += t.eval_uv(uv).as_dvec3() * theta.sin();
            }
        }
        acc *= (2.0 * PI64 / n_phi as f64) * (PI64 / n_theta as f64);
        let got = t.integral().as_dvec3();
        assert!((got - acc).abs().max_element() < 1e-3 * acc.max_element(), "{got} vs {acc}");
    }

    /// Chi-square test of envmap sampling against its pdf, in coordinates aligned with the
    /// sampling cells (x = u shifted by half a pixel, y = θ/π) so that the pdf is smooth
    /// inside every test cell.
    #[test]
    fn sampling_matches_pdf_chi2() {
        let img = test_image();
        let rot = Mat3::from_rotation_y(0.7) * Mat3::from_rotation_x(-0.4);
        for to_world in [Mat3::IDENTITY, rot, rot * Mat3::from_diagonal(Vec3::new(-1.0, 1.0, 1.0))] {
            let env = EnvMap::new(&img, 2.0, to_world).unwrap();
            let w = 8.0f32;
            let to_xy = |d_world: Vec3| {
                let uv = direction_to_uv(env.to_local * d_world);
                let mut x = uv.x - 0.5 / w;
                x -= x.floor();
                Vec2::new(x, uv.y)
            };
            let from_xy = |p: Vec2| env.to_world * uv_to_direction(Vec2::new(p.x + 0.5 / w, p.y));
            let cfg = Chi2Config { bins_x: 32, bins_y: 16, samples: 300_000, ..Default::default() };
            let mut bad = None;
            let out = chi2_2d(
                &cfg,
                Vec2::ZERO,
                Vec2::ONE,
                |s| {
                    let (d, l, pdf) = env.sample(s.next_2d())?;
                    if (env.pdf(d) - pdf).abs() > 1e-3 * pdf || (env.eval(d) - l).abs().max_element() > 1e-4 * (1.0 + l.max_element()) {
                        bad = Some(format!("direction {d}: pdf {pdf} vs {}, radiance {l} vs {}", env.pdf(d), env.eval(d)));
                    }
                    Some(to_xy(d))
                },
                |p| {
                    let theta = p.y as f64 * PI64;
                    env.pdf(from_xy(p)) as f64 * 2.0 * PI64 * PI64 * theta.sin()
                },
            );
            assert!(bad.is_none(), "{bad:?}");
            assert!(out.passed, "{out:?}");
            assert!((out.pdf_integral - 1.0).abs() < 2e-3, "{}", out.pdf_integral);
        }
    }

    /// A map wide enough for the fast cell search ([`FAST_MIN_WIDTH`]): every direction's cell
    /// is the one its f64 angles give (except within 1e-5 rad of a border, where rounding
    /// decides), and every sampled direction lies in the cell that was drawn (except within
    /// 1e-5 of the cell's edge in the rescaled numbers), with the density of that cell.
    #[test]
    fn the_fast_cell_search_finds_the_cell_of_the_angles_and_of_the_sample() {
        let (w, h) = (256usize, 129usize);
        let pixels: Vec<Color> = (0..w * h).map(|k| Color::splat(1.0 + (k % 7) as f32)).collect();
        let t = LatLong::new(w, h, &pixels).unwrap();
        assert!(!t.col_sc.is_empty());
        let (nx, ny) = (w as f64, (h - 1) as f64);
        let mut s = Sampler::new(3, 0, 0);
        let (mut checked, mut border) = (0, 0);
        for k in 0..200_000 {
            // the axes and the poles, then random directions
            let d = match k {
                0 => Vec3::Y,
                1 => -Vec3::Y,
                2 => Vec3::X,
                3 => -Vec3::Z,
                _ => crate::sampling::square_to_uniform_sphere(s.next_2d()),
            };
            let (ix, iy) = t.cell_of(d);
            assert!(ix < w && iy < h - 1, "direction {d}: cell ({ix}, {iy})");
            let dd = d.as_dvec3().normalize();
            let phi = dd.x.atan2(-dd.z).rem_euclid(2.0 * PI64);
            let x = (phi / (2.0 * PI64) * nx - 0.5).rem_euclid(nx);
            let y = dd.y.clamp(-1.0, 1.0).acos() / PI64 * ny;
            let near = |v: f64, n: f64| (v - v.round()).abs() * 2.0 * PI64 / n < 1e-5;
            if near(x, nx) || near(y, ny) || dd.x.hypot(dd.z) < 1e-6 {
                border += 1;
                continue;
            }
            assert_eq!((ix, iy), (x.floor() as usize, (y.floor() as usize).min(h - 2)), "direction {d}");
            checked += 1;
        }
        assert!(checked > 199_000 && border < 1_000, "{checked} checked, {border} on borders");
        let dist = t.dist.as_ref().unwrap();
        for _ in 0..100_000 {
            let u = s.next_2d();
            let (ix, iy, p, r) = dist.sample_cell(u).unwrap();
            let (d, pdf) = t.sample_direction(u).unwrap();
            if r.min_element() < 1e-5 || r.max_element() > 1.0 - 1e-5 {
                continue;
            }
            assert_eq!(t.cell_of(d), (ix, iy), "u {u}, r {r}");
            assert_eq!(pdf, p / t.cell_solid_angle(iy));
            assert_eq!(pdf, t.pdf(d));
        }
    }

    /// A map wide enough for the rows' guide tables (256 cells per row): a chi² test of the
    /// sampled directions against the pdf, one test cell per map cell (x aligned with the cells,
    /// y = θ/π), and every sample's density equal to `pdf()`.
    #[test]
    fn sampling_a_wide_map_through_the_guide_tables_matches_pdf_chi2() {
        let (w, h) = (256u32, 33u32);
        let img = image(w, h, |x, y| {
            let (dx, dy) = (x as f32 - 170.0, y as f32 - 9.0);
            let sun = 500.0 * (-(dx * dx + dy * dy) / 3.0).exp();
            let sky = 0.2 + 0.1 * ((x as f32 * 0.13).sin() + (y as f32 * 0.4).cos());
            Color::new(sky + sun, sky + 0.9 * sun, 1.2 * sky + 0.8 * sun) * if y == 20 { 0.0 } else { 1.0 }
        });
        let env = EnvMap::new(&img, 1.0, Mat3::from_rotation_y(0.4)).unwrap();
        let to_xy = |d_world: Vec3| {
            let uv = direction_to_uv(env.to_local * d_world);
            let mut x = uv.x - 0.5 / w as f32;
            x -= x.floor();
            Vec2::new(x, uv.y)
        };
        let from_xy = |p: Vec2| env.to_world * uv_to_direction(Vec2::new(p.x + 0.5 / w as f32, p.y));
        let cfg = Chi2Config { bins_x: w as usize, bins_y: (h - 1) as usize, samples: 1_000_000, subdiv: 2, ..Default::default() };
        let mut bad = None;
        let out = chi2_2d(
            &cfg,
            Vec2::ZERO,
            Vec2::ONE,
            |s| {
                let (d, pdf) = env.sample_direction(s.next_2d())?;
                if pdf.to_bits() != env.pdf(d).to_bits() {
                    bad = Some(format!("direction {d}: pdf {pdf} vs {}", env.pdf(d)));
                }
                Some(to_xy(d))
            },
            |p| env.pdf(from_xy(p)) as f64 * 2.0 * PI64 * PI64 * (p.y as f64 * PI64).sin(),
        );
        assert!(bad.is_none(), "{bad:?}");
        assert!(out.passed, "{out:?}");
        assert!((out.pdf_integral - 1.0).abs() < 2e-3, "{}", out.pdf_integral);
    }

    #[test]
    fn estimator_of_the_integral_is_unbiased() {
        let img = test_image();
        let env = EnvMap::new(&img, 1.0, Mat3::IDENTITY).unwrap();
        let mut s = Sampler::new(5, 0, 0);
        let n = 400_000;
        let mut acc = DVec3::ZERO;
        for _ in 0..n {
            let (_, l, pdf) = env.sample(s.next_2d()).unwrap();
            // row 3 (v = 3/4) is black, so the cells on either side of it fade to black
            // but still carry radiance everywhere except exactly on that row
            assert!(pdf > 0.0 && l.min_element() >= 0.0);
            acc += (l / pdf).as_dvec3();
        }
        let mean = acc / n as f64;
        let want = env.integral().as_dvec3();
        assert!((mean - want).abs().max_element() < 0.01 * want.max_element(), "{mean} vs {want}");
    }

    #[test]
    fn uniform_map_is_the_constant_environment() {
        let c = Color::new(0.3, 0.6, 0.9);
        let img = image(16, 8, |_, _| c);
        let env = EnvMap::new(&img, 1.5, Mat3::from_rotation_z(0.3)).unwrap();
        let mut s = Sampler::new(2, 0, 0);
        for _ in 0..1000 {
            let d = crate::sampling::square_to_uniform_sphere(s.next_2d());
            assert!((env.eval(d) - c * 1.5).abs().max_element() < 1e-5);
            let (_, l, pdf) = env.sample(s.next_2d()).unwrap();
            assert!((l - c * 1.5).abs().max_element() < 1e-5);
            // luminance-weighted solid angle of a uniform map: uniform over the sphere
            assert!((pdf * 4.0 * std::f32::consts::PI - 1.0).abs() < 1e-3, "pdf {pdf}");
        }
        let want = c * 1.5 * 4.0 * std::f32::consts::PI;
        assert!((env.integral() - want).abs().max_element() < 1e-4 * want.max_element());
    }

    #[test]
    fn bad_maps_and_frames_are_rejected() {
        assert!(LatLong::new(0, 2, &[]).is_err());
        assert!(LatLong::new(2, 1, &[Color::ONE, Color::splat(f32::NAN)]).is_err());
        assert!(LatLong::new(2, 1, &[Color::ONE, -Color::ONE]).is_err());
        let one_row = LatLong::new(2, 1, &[Color::ONE, Color::ONE]).unwrap();
        assert_eq!(one_row.eval(Vec3::Y), Color::ONE);
        assert!(check_frame(1.0, &Mat3::from_diagonal(Vec3::new(2.0, 1.0, 1.0))).is_err());
        assert!(check_frame(-1.0, &Mat3::IDENTITY).is_err());
        let black = LatLong::new(2, 2, &[Color::ZERO; 4]).unwrap();
        assert!(black.sample(Vec2::splat(0.5)).is_none() && black.pdf(Vec3::Y) == 0.0);
    }
}
