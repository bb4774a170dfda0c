//! Sun and sky emitter (Mitsuba 3's `sunsky`, RGB mode, default `complex_sun = false`): the
//! Hosek–Wilkie sky model (Hosek & Wilkie, "An analytic model for full spectral sky-dome
//! radiance", SIGGRAPH 2012) plus a sun disk of uniform radiance, both exactly as Mitsuba 3.9
//! evaluates them, at infinity like an environment map. Like every light, it feeds the photon
//! pass of Pacanowski et al. §2 (photons from the disk of the scene's bounding sphere).
//!
//! Local frame: `+z` is the zenith (Mitsuba 3's convention); `to_world` (orthogonal, possibly
//! mirrored) maps it to world space. Radiance for a local direction `d` with `d.z >= 0` (zero
//! below the horizon, and everywhere when the sun is below the horizon, as in Mitsuba 3.9):
//! - sky: `sky_scale · Y_n · L_c (1 + A e^{B / (cos θ + 0.01)}) (C + D e^{E γ} + F cos² γ
//!   + G χ(I, γ) + H √cos θ)`, `χ(I, γ) = (1 + cos² γ) / (1 + I² − 2 I cos γ)^{3/2}`, per RGB
//!   channel `c`; `θ` is the zenith angle of `d`, `γ` its angle to the sun; the nine parameters and
//!   `L_c` are the dataset's control points interpolated linearly in turbidity (levels 1..10) and
//!   in ground albedo (0 and 1, per channel), then by a quintic Bézier in
//!   `(2 η / π)^{1/3}` of the sun elevation `η`;
//! - sun, inside the cone of half-angle `α = sun_aperture / 2` around the sun direction:
//!   `sun_scale · E_c(T, η) · K · Y_n / (2π (1 − cos α))`, where `E_c` is the sun irradiance
//!   table (RGB, interpolated linearly in turbidity and in elevation over 2°, 5°, …, 89°),
//!   `K = 467.069280386` (Mitsuba's `SPEC_TO_RGB_SUN_CONV`) and `Y_n = 1 / 106.75…` (Mitsuba's
//!   `MI_CIE_Y_NORMALIZATION`). The sun's power does not depend on the aperture. As Mitsuba does
//!   in single precision, `1 − cos α` is evaluated in `f32` (this matters at the real 0.27° half
//!   aperture, where it shifts the sun's radiance by 0.2%).
//!
//! The tables come from the datasets of the Mitsuba 3 package (`tools/sunsky/extract.py`,
//! licence and layout in `crates/octolux/data/sunsky/README.md`).
//!
//! Sampling (ours, not Mitsuba's truncated Gaussian mixtures): with probability `p_sun` (the
//! sun's share of the emitted luminance) a direction uniform in the sun's cone, otherwise a
//! direction drawn from a latitude-longitude table of the sky ([`super::envmap::LatLong`],
//! 256 × 129 lookup points); the pdf is the mixture of both densities.

use super::envmap::LatLong;
use crate::math::{luminance, Color, Frame};
use glam::{DVec3, Mat3, Vec2, Vec3};
use std::f64::consts::PI;

/// The tables (little-endian f32): sky parameters, sky radiance, sun irradiance (RGB).
static DATA: &[u8] = include_bytes!("../../data/sunsky/sunsky_rgb.bin");
const SKY_PARAMS_LEN: usize = 10 * 2 * 6 * 3 * 9;
const SKY_RAD_LEN: usize = 10 * 2 * 6 * 3;
const SUN_LEN: usize = 10 * 30 * 3;
const _: () = assert!(DATA.len() == 4 * (SKY_PARAMS_LEN + SKY_RAD_LEN + SUN_LEN));

/// Mitsuba's `SPEC_TO_RGB_SUN_CONV`.
const SPEC_TO_RGB_SUN_CONV: f64 = 467.069280386;
/// Mitsuba's `MI_CIE_Y_NORMALIZATION`.
const CIE_Y_NORMALIZATION: f64 = 0.009367658735689113;
/// Mitsuba's default sun aperture (degrees): the sun's apparent diameter.
pub const SUN_APERTURE_DEG: f32 = 0.5358;
/// Resolution of the sky sampling table (lookup points in φ and θ).
const TABLE_W: usize = 256;
const TABLE_H: usize = 129;

#[inline]
fn data(i: usize) -> f64 {
    let b = &DATA[4 * i..4 * i + 4];
    f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64
}

/// Description of a sun-and-sky emitter (Mitsuba 3 `sunsky` parameters).
#[derive(Clone, Debug, PartialEq)]
pub struct SunSkyDesc {
    /// Unit direction towards the sun, world space.
    pub sun_direction: Vec3,
    /// Atmospheric turbidity in [1, 10].
    pub turbidity: f32,
    /// Ground albedo per RGB channel, in [0, 1].
    pub albedo: Color,
    pub sun_scale: f32,
    pub sky_scale: f32,
    /// Apparent diameter of the sun disk (degrees, in (0, 180)).
    pub sun_aperture_deg: f32,
    /// Orthogonal local-to-world map (local `+z` is the zenith).
    pub to_world: Mat3,
}

impl Default for SunSkyDesc {
    fn default() -> Self {
        SunSkyDesc {
            sun_direction: Vec3::Z,
            turbidity: 3.0,
            albedo: Color::splat(0.3),
            sun_scale: 1.0,
            sky_scale: 1.0,
            sun_aperture_deg: SUN_APERTURE_DEG,
            to_world: Mat3::IDENTITY,
        }
    }
}

impl SunSkyDesc {
    pub fn validate(&self) -> Result<(), String> {
        super::envmap::check_frame(1.0, &self.to_world)?;
        if !(self.sun_direction.is_finite() && (self.sun_direction.length() - 1.0).abs() < 1e-3) {
            return Err(format!("sun direction {} must be a unit vector", self.sun_direction));
        }
        if !(1.0..=10.0).contains(&self.turbidity) {
            return Err(format!("turbidity {} must lie in [1, 10]", self.turbidity));
        }
        if !(self.albedo.is_finite() && self.albedo.min_element() >= 0.0 && self.albedo.max_element() <= 1.0) {
            return Err(format!("albedo {} must lie in [0, 1]", self.albedo));
        }
        if !(self.sun_scale.is_finite() && self.sun_scale >= 0.0 && self.sky_scale.is_finite() && self.sky_scale >= 0.0) {
            return Err(format!("sun_scale {} and sky_scale {} must be finite and non-negative", self.sun_scale, self.sky_scale));
        }
        if !(self.sun_aperture_deg > 0.0 && self.sun_aperture_deg < 180.0) {
            return Err(format!("sun aperture {}° must lie in (0, 180)", self.sun_aperture_deg));
        }
        Ok(())
    }
}

/// Date, time and place for the solar position (Mitsuba's defaults: Tokyo, 2010-07-10 15:00).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolarTime {
    pub year: i32,
    pub month: i32,
    pub day: i32,
    pub hour: f32,
    pub minute: f32,
    pub second: f32,
    /// Degrees north.
    pub latitude: f32,
    /// Degrees east.
    pub longitude: f32,
    /// Hours east of UTC.
    pub timezone: f32,
}

impl Default for SolarTime {
    fn default() -> Self {
        SolarTime {
            year: 2010,
            month: 7,
            day: 10,
            hour: 15.0,
            minute: 0.0,
            second: 0.0,
            latitude: 35.6894,
            longitude: 139.6917,
            timezone: 9.0,
        }
    }
}

impl SolarTime {
    /// Direction of the sun in the emitter's local frame (`+z` zenith), by Blanco-Muriel et
    /// al., "Computing the Solar Vector" (Solar Energy 2001), in single precision as Mitsuba 3
    /// computes it (so the Julian date is rounded to a quarter day, as there).
    // The published constants, rounded to f32 as Mitsuba 3 rounds them.
    #[allow(clippy::excessive_precision)]
    pub fn sun_direction(&self) -> Vec3 {
        let dec_hours = self.hour - self.timezone + (self.minute + self.second / 60.0) / 60.0;
        let a1 = (self.month - 14) / 12;
        let a2 = (1461 * (self.year + 4800 + a1)) / 4 + (367 * (self.month - 2 - 12 * a1)) / 12 - (3 * ((self.year + 4900 + a1) / 100)) / 4
            + self.day
            - 32075;
        let julian = a2 as f32 - 0.5 + dec_hours / 24.0;
        let n = julian - 2451545.0;
        let omega = 2.1429f32 - 0.0010394594 * n;
        let mean_longitude = 4.8950630f32 + 0.017202791698 * n;
        let anomaly = 6.2400600f32 + 0.0172019699 * n;
        let ecl_longitude =
            mean_longitude + 0.03341607 * anomaly.sin() + 0.00034894 * (2.0 * anomaly).sin() - 0.0001134 - 0.0000203 * omega.sin();
        let ecl_obliquity = 0.4090928f32 - 6.2140e-9 * n + 0.0000396 * omega.cos();
        let sin_l = ecl_longitude.sin();
        let mut ra = (ecl_obliquity.cos() * sin_l).atan2(ecl_longitude.cos());
        if ra < 0.0 {
            ra += std::f32::consts::TAU;
        }
        let declination = (ecl_obliquity.sin() * sin_l).asin();
        let gmst = 6.6974243242f32 + 0.0657098283 * n + dec_hours;
        let lmst = (gmst * 15.0 + self.longitude).to_radians();
        let lat = self.latitude.to_radians();
        let hour_angle = lmst - ra;
        let mut zenith = (lat.cos() * hour_angle.cos() * declination.cos() + declination.sin() * lat.sin()).acos();
        let mut azimuth = (-hour_angle.sin()).atan2(declination.tan() * lat.cos() - lat.sin() * hour_angle.cos());
        if azimuth < 0.0 {
            azimuth += std::f32::consts::TAU;
        }
        zenith += (6371.01f64 / 149597890.0) as f32 * zenith.sin();
        let phi = azimuth - std::f32::consts::PI;
        Vec3::new(zenith.sin() * phi.cos(), zenith.sin() * phi.sin(), zenith.cos())
    }
}

/// A prepared sun-and-sky emitter.
#[derive(Clone, Debug)]
pub struct SunSky {
    to_world: Mat3,
    to_local: Mat3,
    /// Unit sun direction, local frame.
    sun: DVec3,
    /// A frame around [`Self::sun`] (in f32), for sampling the sun's cone.
    sun_frame: Frame,
    /// False when the sun is below the horizon (the emitter is then black, as in Mitsuba 3.9).
    active: bool,
    /// Per channel: the nine sky parameters and the sky radiance, interpolated.
    params: [[f64; 9]; 3],
    sky_radiance: [f64; 3],
    sky_scale: f64,
    /// Radiance of the sun disk (zero when `sun_scale` is 0).
    sun_radiance: Color,
    /// `cos α` in f32 (the test that decides whether a direction sees the sun).
    cos_half: f32,
    /// Solid-angle density of the uniform sun cone.
    cone_pdf: f32,
    /// Probability of sampling the sun rather than the sky table.
    p_sun: f32,
    table: LatLong,
}

/// Local direction (z-up) to the y-up frame of the sampling table, and back.
#[inline]
fn to_table(d: Vec3) -> Vec3 {
    Vec3::new(d.x, d.z, -d.y)
}
#[inline]
fn from_table(q: Vec3) -> Vec3 {
    Vec3::new(q.x, -q.z, q.y)
}

/// Angle between two unit vectors, accurate for nearly equal and nearly opposite ones.
#[inline]
fn unit_angle(a: DVec3, b: DVec3) -> f64 {
    if a.dot(b) < 0.0 {
        PI - 2.0 * ((a + b).length() * 0.5).min(1.0).asin()
    } else {
        2.0 * ((a - b).length() * 0.5).min(1.0).asin()
    }
}

/// Linear interpolation weights over turbidity levels 1..10: (lower index, fraction).
#[inline]
fn turbidity_lerp(t: f64) -> (usize, f64) {
    let x = (t - 1.0).clamp(0.0, 9.0);
    let i = (x.floor() as usize).min(8);
    (i, x - i as f64)
}

impl SunSky {
    pub fn new(desc: &SunSkyDesc) -> Result<SunSky, String> {
        SunSky::with_table(desc, TABLE_W, TABLE_H)
    }

    /// [`SunSky::new`] with a sky sampling table of `table_w × table_h` lookup points.
    fn with_table(desc: &SunSkyDesc, table_w: usize, table_h: usize) -> Result<SunSky, String> {
        desc.validate()?;
        let to_local = desc.to_world.transpose();
        let sun = (to_local * desc.sun_direction).as_dvec3().normalize();
        let active = sun.z >= 0.0;
        let eta = (PI / 2.0 - sun.z.clamp(-1.0, 1.0).acos()).max(0.0);
        let (ti, tf) = turbidity_lerp(desc.turbidity as f64);

        // Sky: turbidity, then albedo, then Bézier in elevation.
        let x = (2.0 * eta / PI).cbrt().min(1.0 - f32::EPSILON as f64);
        const BINOM: [f64; 6] = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
        let bezier: Vec<f64> = (0..6).map(|k| BINOM[k] * x.powi(k as i32) * (1.0 - x).powi(5 - k as i32)).collect();
        let mut params = [[0.0f64; 9]; 3];
        let mut sky_radiance = [0.0f64; 3];
        for c in 0..3 {
            let albedo = desc.albedo[c] as f64;
            for (k, &b) in bezier.iter().enumerate() {
                let w = |t: usize, a: usize| (if t == ti { 1.0 - tf } else { tf }) * (if a == 0 { 1.0 - albedo } else { albedo }) * b;
                for (t, a) in [(ti, 0), (ti, 1), (ti + 1, 0), (ti + 1, 1)] {
                    let wt = w(t, a);
                    if wt == 0.0 {
                        continue;
                    }
                    let base = ((t * 2 + a) * 6 + k) * 3 + c;
                    for (p, slot) in params[c].iter_mut().enumerate() {
                        *slot += wt * data(base * 9 + p);
                    }
                    sky_radiance[c] += wt * data(SKY_PARAMS_LEN + base);
                }
            }
        }

        // Sun: irradiance table, interpolated in turbidity and elevation.
        let half = 0.5f32 * desc.sun_aperture_deg.to_radians();
        let cos_half = half.cos();
        let one_minus_cos = (1.0f32 - cos_half) as f64;
        let idx = ((eta.to_degrees() - 2.0) / 3.0).clamp(0.0, 29.0);
        let (ei, ef) = ((idx.floor() as usize).min(28), idx - (idx.floor() as usize).min(28) as f64);
        let mut sun_rgb = DVec3::ZERO;
        for (t, wt) in [(ti, 1.0 - tf), (ti + 1, tf)] {
            for (e, we) in [(ei, 1.0 - ef), (ei + 1, ef)] {
                let base = SKY_PARAMS_LEN + SKY_RAD_LEN + (t * 30 + e) * 3;
                sun_rgb += DVec3::new(data(base), data(base + 1), data(base + 2)) * (wt * we);
            }
        }
        let sun_radiance = if desc.sun_scale > 0.0 && active {
            (sun_rgb * (desc.sun_scale as f64 * SPEC_TO_RGB_SUN_CONV * CIE_Y_NORMALIZATION / (2.0 * PI * one_minus_cos))).as_vec3()
        } else {
            Color::ZERO
        };

        let mut s = SunSky {
            to_world: desc.to_world,
            to_local,
            sun,
            sun_frame: Frame::from_normal(sun.as_vec3()),
            active,
            params,
            sky_radiance,
            sky_scale: desc.sky_scale as f64,
            sun_radiance,
            cos_half,
            cone_pdf: (1.0 / (2.0 * PI * (1.0 - cos_half as f64))) as f32,
            p_sun: 0.0,
            table: LatLong::new(1, 1, &[Color::ZERO])?,
        };
        // Sky sampling table (sky only, local frame through `to_table`).
        let mut pixels = Vec::with_capacity(table_w * table_h);
        for j in 0..table_h {
            for i in 0..table_w {
                let uv = Vec2::new((i as f32 + 0.5) / table_w as f32, j as f32 / (table_h - 1) as f32);
                pixels.push(s.sky_local(from_table(super::envmap::uv_to_direction(uv)).as_dvec3()));
            }
        }
        s.table = LatLong::new(table_w, table_h, &pixels)?;
        let sun_power = luminance(s.sun_radiance) as f64 * 2.0 * PI * one_minus_cos;
        let sky_power = luminance(s.table.integral()).max(0.0) as f64;
        s.p_sun = if sun_power + sky_power > 0.0 { (sun_power / (sun_power + sky_power)) as f32 } else { 0.0 };
        Ok(s)
    }

    /// Sky radiance for a unit local direction (without the sun).
    fn sky_local(&self, d: DVec3) -> Color {
        if !self.active || d.z < 0.0 || self.sky_scale <= 0.0 {
            return Color::ZERO;
        }
        let cos_t = d.z;
        let gamma = unit_angle(self.sun, d);
        // cos γ from the dot product, not `gamma.cos()`: the same to rounding, without a `cos`
        // per lookup (the sky is evaluated for every escaped ray and every light sample)
        let cos_g = self.sun.dot(d).clamp(-1.0, 1.0);
        let sqrt_cos_t = cos_t.max(0.0).sqrt();
        let mut out = [0.0f64; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let p = &self.params[c];
            let c1 = 1.0 + p[0] * (p[1] / (cos_t + 0.01)).exp();
            // x^1.5 as x·√x (a `pow` per channel was the largest single cost of the sky)
            let base = 1.0 + p[8] * p[8] - 2.0 * p[8] * cos_g;
            let chi = (1.0 + cos_g * cos_g) / (base * base.sqrt());
            let c2 = p[2] + p[3] * (p[4] * gamma).exp() + p[5] * cos_g * cos_g + p[6] * chi + p[7] * sqrt_cos_t;
            *o = self.sky_scale * c1 * c2 * self.sky_radiance[c] * CIE_Y_NORMALIZATION;
        }
        DVec3::from(out).as_vec3()
    }

    /// Whether a unit local direction sees the sun disk.
    #[inline]
    fn in_sun(&self, d: Vec3) -> bool {
        self.sun.as_vec3().dot(d) >= self.cos_half
    }

    /// Radiance arriving from world direction `dir` (unit; a ray leaving the scene along `dir`).
    pub fn eval(&self, dir: Vec3) -> Color {
        let d = (self.to_local * dir).normalize();
        if !self.active || d.z < 0.0 {
            return Color::ZERO;
        }
        let mut l = self.sky_local(d.as_dvec3());
        if self.in_sun(d) {
            l += self.sun_radiance;
        }
        l
    }

    /// Whether world direction `dir` (unit) sees the sun disk.
    pub fn sees_sun(&self, dir: Vec3) -> bool {
        let d = (self.to_local * dir).normalize();
        self.active && d.z >= 0.0 && self.in_sun(d)
    }

    /// Radiance of the sun disk (without the sky).
    pub fn sun_radiance(&self) -> Color {
        self.sun_radiance
    }

    /// Sample a world direction; returns it, its radiance and its solid-angle pdf.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Color, f32)> {
        let (dir, pdf) = self.sample_direction(u)?;
        Some((dir, self.eval(dir), pdf))
    }

    /// [`Self::sample`] without the radiance (the sky model's six `exp` and an `asin`): the
    /// direction and its solid-angle pdf (`None` in the same cases).
    pub fn sample_direction(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let local = if u.x < self.p_sun {
            let ux = (u.x / self.p_sun).min(1.0 - f32::EPSILON) as f64;
            let one_minus = 1.0 - self.cos_half as f64;
            let cos_t = 1.0 - ux * one_minus;
            let sin_t = (ux * one_minus * (2.0 - ux * one_minus)).max(0.0).sqrt();
            // φ in f32 (the direction is stored in f32 anyway): sincosf, not the f64 sincos
            let (sin_p, cos_p) = (std::f32::consts::TAU * u.y).sin_cos();
            let f = &self.sun_frame;
            let l = DVec3::new(sin_t * cos_p as f64, sin_t * sin_p as f64, cos_t);
            (f.s.as_dvec3() * l.x + f.t.as_dvec3() * l.y + self.sun * l.z).normalize().as_vec3()
        } else {
            let ux = ((u.x - self.p_sun) / (1.0 - self.p_sun)).clamp(0.0, 1.0 - f32::EPSILON);
            let (q, _) = self.table.sample_direction(Vec2::new(ux, u.y))?;
            from_table(q)
        };
        let dir = (self.to_world * local).normalize();
        let pdf = self.pdf(dir);
        (pdf > 0.0).then_some((dir, pdf))
    }

    /// Solid-angle density of [`Self::sample`] for world direction `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let d = (self.to_local * dir).normalize();
        let sky = (1.0 - self.p_sun) * self.table.pdf(to_table(d));
        let sun = if self.in_sun(d) { self.p_sun * self.cone_pdf } else { 0.0 };
        sky + sun
    }

    /// `∫ L dω` over the sphere, per channel (the sky from its sampling table).
    pub fn integral(&self) -> Color {
        let sun = self.sun_radiance * (2.0 * PI * (1.0 - self.cos_half as f64)) as f32;
        self.table.integral() + sun
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;
    use crate::testing::{chi2_2d_piecewise, direction_to_zphi, zphi_to_direction, Chi2Config};

    #[test]
    fn solar_position_matches_a_known_case() {
        // Tokyo, 2010-07-10 09:00 (Mitsuba's defaults with hour = 9): Mitsuba 3.9.1's brightest
        // direction on a 0.5° grid was (0.0920, -0.6157, 0.7826) (inside the 0.27° sun disk).
        let d = SolarTime { hour: 9.0, ..Default::default() }.sun_direction();
        assert!((d - Vec3::new(0.0920, -0.6157, 0.7826)).length() < 0.01, "{d}");
        assert!((d.length() - 1.0).abs() < 1e-5);
    }

    /// Sky part: chi-square in the coordinates of the sampling table (x = u shifted by half a
    /// pixel, y = θ/π), whose cells the test cells coincide with; sun part: chi-square in the
    /// sun's frame over its cone. The mixture of both is covered by the unbiasedness test.
    #[test]
    fn sampling_matches_pdf_chi2() {
        use super::super::envmap::{direction_to_uv, uv_to_direction};
        let base = SunSkyDesc {
            sun_direction: Vec3::new(0.3, 0.5, 0.4).normalize(),
            sun_aperture_deg: 12.0,
            to_world: Mat3::from_rotation_x(-0.3),
            ..Default::default()
        };
        let both = SunSky::new(&base).unwrap();
        assert!(both.p_sun > 0.05 && both.p_sun < 0.999, "{}", both.p_sun);

        let (w, h) = (32usize, 17usize);
        let sky = SunSky::with_table(&SunSkyDesc { sun_scale: 0.0, ..base.clone() }, w, h).unwrap();
        assert_eq!(sky.p_sun, 0.0);
        let to_xy = |dir: Vec3| {
            let uv = direction_to_uv(to_table(sky.to_local * dir));
            let mut x = uv.x - 0.5 / w as f32;
            x -= x.floor();
            Vec2::new(x, uv.y)
        };
        let from_xy = |p: Vec2| sky.to_world * from_table(uv_to_direction(Vec2::new(p.x + 0.5 / w as f32, p.y)));
        let cfg = Chi2Config { bins_x: w, bins_y: h - 1, samples: 300_000, ..Default::default() };
        let mut bad = None;
        let out = chi2_2d_piecewise(
            &cfg,
            Vec2::ZERO,
            Vec2::ONE,
            |smp| {
                let (d, l, pdf) = sky.sample(smp.next_2d())?;
                if (sky.pdf(d) - pdf).abs() > 1e-4 * pdf || (sky.eval(d) - l).abs().max_element() > 1e-6 {
                    bad = Some(format!("{d}: pdf {pdf} vs {}", sky.pdf(d)));
                }
                Some(to_xy(d))
            },
            |p| sky.pdf(from_xy(p)) as f64 * 2.0 * PI * PI * (p.y as f64 * PI).sin(),
        );
        assert!(bad.is_none(), "{bad:?}");
        assert!(out.passed, "{out:?}");

        let sun = SunSky::new(&SunSkyDesc { sky_scale: 0.0, ..base }).unwrap();
        assert_eq!(sun.p_sun, 1.0);
        let frame = Frame::from_normal(sun.to_world * sun.sun.as_vec3());
        let cfg = Chi2Config { bins_x: 10, bins_y: 20, samples: 200_000, ..Default::default() };
        let out = chi2_2d_piecewise(
            &cfg,
            Vec2::new(sun.cos_half, 0.0),
            Vec2::new(1.0, std::f32::consts::TAU),
            |smp| {
                let (d, _, _) = sun.sample(smp.next_2d())?;
                let zp = direction_to_zphi(frame.to_local(d));
                // rounding may put a sample an ulp outside the cone's edge
                Some(Vec2::new(zp.x.max(sun.cos_half), zp.y))
            },
            |zp| sun.pdf(frame.to_world(zphi_to_direction(zp))) as f64,
        );
        assert!(out.passed, "{out:?}");
    }

    #[test]
    fn estimator_of_the_integral_is_unbiased() {
        let desc = SunSkyDesc {
            sun_direction: Vec3::new(-0.2, 0.1, 0.6).normalize(),
            turbidity: 6.0,
            sun_aperture_deg: 3.0,
            ..Default::default()
        };
        let s = SunSky::new(&desc).unwrap();
        // reference: ∫ over the upper hemisphere by the midpoint rule, plus the sun disk
        let (n_phi, n_theta) = (720, 360);
        let mut sky = DVec3::ZERO;
        for j in 0..n_theta {
            let t = (j as f64 + 0.5) / n_theta as f64 * PI / 2.0;
            for i in 0..n_phi {
                let p = (i as f64 + 0.5) / n_phi as f64 * 2.0 * PI;
                let d = DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
                sky += s.sky_local(d).as_dvec3() * t.sin();
            }
        }
        sky *= (2.0 * PI / n_phi as f64) * (PI / 2.0 / n_theta as f64);
        let sun = s.sun_radiance().as_dvec3() * 2.0 * PI * (1.0 - s.cos_half as f64);
        let want = sky + sun;
        let mut smp = Sampler::new(9, 0, 0);
        let n = 400_000;
        let mut acc = DVec3::ZERO;
        for _ in 0..n {
            if let Some((_, l, pdf)) = s.sample(smp.next_2d()) {
                acc += (l / pdf).as_dvec3();
            }
        }
        let mean = acc / n as f64;
        assert!((mean - want).abs().max_element() < 0.01 * want.max_element(), "{mean} vs {want}");
        let table = s.integral().as_dvec3();
        assert!((table - want).abs().max_element() < 0.01 * want.max_element(), "{table} vs {want}");
    }

    #[test]
    fn sun_below_the_horizon_makes_everything_black() {
        let s = SunSky::new(&SunSkyDesc { sun_direction: Vec3::new(0.0, 0.6, -0.8), ..Default::default() }).unwrap();
        assert_eq!(s.eval(Vec3::Z), Color::ZERO);
        assert!(s.sample(Vec2::splat(0.3)).is_none());
        assert_eq!(s.integral(), Color::ZERO);
    }

    #[test]
    fn bad_descriptions_are_rejected() {
        let ok = SunSkyDesc::default();
        assert!(ok.validate().is_ok());
        assert!(SunSkyDesc { turbidity: 0.5, ..ok.clone() }.validate().is_err());
        assert!(SunSkyDesc { albedo: Color::splat(1.5), ..ok.clone() }.validate().is_err());
        assert!(SunSkyDesc { sun_aperture_deg: 0.0, ..ok.clone() }.validate().is_err());
        assert!(SunSkyDesc { sun_direction: Vec3::ZERO, ..ok.clone() }.validate().is_err());
        assert!(SunSkyDesc { sun_scale: -1.0, ..ok.clone() }.validate().is_err());
        assert!(SunSkyDesc { to_world: Mat3::from_diagonal(Vec3::splat(2.0)), ..ok }.validate().is_err());
    }
}
