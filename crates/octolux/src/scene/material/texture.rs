//! Textures: a reflectance-like parameter that is a constant or a bitmap looked up by uv
//! (Mitsuba's `bitmap` texture with its repeat wrap), and the texture coordinates a lookup
//! receives ([`TexCoord`]: uv and, at camera hits, its screen-space partials).
//!
//! Filters ([`TexFilter`]): `nearest` and `bilinear` as Mitsuba 3 and 0.6 define them, and
//! Mitsuba 0.6's `trilinear` MIP-mapping (0.6 is the only Mitsuba with it; its
//! `include/mitsuba/render/mipmap.h`): a pyramid of levels, each `max(1, ⌈n/2⌉)` texels along
//! each axis of the one before, down to 1x1, and a lookup whose fractional level is
//! `log2(r)`, `r` the major radius (largest singular value) of the uv Jacobian in texels of
//! level 0; below level 0 the lookup is bilinear on level 0, otherwise it blends bilinear
//! lookups of the two levels around it (past the last level: its single texel). 0.6 resamples
//! each level with a 2-lobe Lanczos filter; octolux averages with an area-weighted box
//! ([`crate::image::Image::downsampled`]), which keeps every level's mean exactly.
//!
//! Partials come only with camera rays (the render loop's ray differentials, scaled by
//! `1/sqrt(spp)` as 0.6's `SamplingIntegrator` scales them); every later vertex has zero
//! partials, i.e. a bilinear lookup on level 0, as in 0.6 where only camera rays carry
//! differentials. See `docs/guide/textures.md`.

use super::check_color;
use crate::image::Image;
use crate::math::Color;
use glam::Vec2;

/// Where a texture is looked up: `uv` and its partials with respect to one pixel step along
/// the film's x and y (already scaled by `1/sqrt(spp)`); zero partials mean "no footprint"
/// (bilinear on level 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexCoord {
    pub uv: Vec2,
    /// `∂uv/∂x`, per (scaled) pixel step along the film's x.
    pub duv_dx: Vec2,
    /// `∂uv/∂y`, per (scaled) pixel step along the film's y.
    pub duv_dy: Vec2,
}

impl TexCoord {
    pub const ZERO: TexCoord = TexCoord { uv: Vec2::ZERO, duv_dx: Vec2::ZERO, duv_dy: Vec2::ZERO };

    /// A point without footprint.
    #[inline]
    pub fn at(uv: Vec2) -> TexCoord {
        TexCoord { uv, ..TexCoord::ZERO }
    }
}

impl From<Vec2> for TexCoord {
    #[inline]
    fn from(uv: Vec2) -> TexCoord {
        TexCoord::at(uv)
    }
}

/// How a bitmap is filtered (Mitsuba's `filter_type`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TexFilter {
    /// The texel containing `uv`.
    Nearest,
    /// Bilinear interpolation of the four nearest texels (Mitsuba 3's default).
    #[default]
    Bilinear,
    /// Mitsuba 0.6's trilinear MIP-mapping: the levels below the base are `count` images
    /// stored contiguously from index `first` of the scene's images (level 1 at `first`).
    Trilinear { first: u32, count: u32 },
}

/// A reflectance-like parameter: constant or a bitmap looked up by uv.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Const(Color),
    /// Index into `SceneDesc::images`; `uv_scale` multiplies the uvs (Mitsuba `to_uv` scale).
    Bitmap {
        image: u32,
        uv_scale: Vec2,
        filter: TexFilter,
    },
}

impl Texture {
    /// A bilinear bitmap texture.
    pub fn bitmap(image: u32, uv_scale: Vec2) -> Texture {
        Texture::Bitmap { image, uv_scale, filter: TexFilter::Bilinear }
    }

    #[inline]
    pub fn eval(&self, images: &[Image], uv: impl Into<TexCoord>) -> Color {
        match self {
            Texture::Const(c) => *c,
            Texture::Bitmap { image, uv_scale, filter } => {
                let Some(im) = images.get(*image as usize) else { return Color::ZERO };
                let tc = uv.into();
                let uv = tc.uv * *uv_scale;
                match *filter {
                    TexFilter::Nearest => im.nearest(uv),
                    TexFilter::Bilinear => im.lookup(uv),
                    TexFilter::Trilinear { first, count } => {
                        let level = mip_level(im, tc.duv_dx * *uv_scale, tc.duv_dy * *uv_scale);
                        trilinear(images, im, first, count, level, uv)
                    }
                }
            }
        }
    }

    /// Whether [`Texture::eval`] reads the partials of its [`TexCoord`] (a MIP-mapped bitmap).
    #[inline]
    pub fn reads_partials(&self) -> bool {
        matches!(self, Texture::Bitmap { filter: TexFilter::Trilinear { .. }, .. })
    }

    /// Prefetch the texels [`Texture::eval`] at `uv` will read ([`Image::prefetch`]), for a
    /// lookup without footprint (zero partials: bilinear on level 0, as every lookup but the
    /// camera ray's). Nothing for constants, nearest lookups and footprints.
    #[inline]
    pub fn prefetch(&self, images: &[Image], tc: TexCoord) {
        if let Texture::Bitmap { image, uv_scale, filter } = self {
            let footprint = tc.duv_dx != Vec2::ZERO || tc.duv_dy != Vec2::ZERO;
            let bilinear = match filter {
                TexFilter::Nearest => false,
                TexFilter::Bilinear => true,
                TexFilter::Trilinear { .. } => !footprint,
            };
            if let (true, Some(im)) = (bilinear, images.get(*image as usize)) {
                im.prefetch(tc.uv * *uv_scale);
            }
        }
    }

    /// The texture read as a scalar (Mitsuba's `eval_1`): a grey value as it is, a colour
    /// through its luminance.
    #[inline]
    pub fn eval_1(&self, images: &[Image], uv: impl Into<TexCoord>) -> f32 {
        let c = self.eval(images, uv);
        if c.x == c.y && c.y == c.z {
            c.x
        } else {
            super::luminance(c)
        }
    }

    pub(crate) fn validate(&self, n_images: usize, what: &str) -> Result<(), String> {
        match self {
            Texture::Const(c) => check_color(*c, what),
            Texture::Bitmap { image, uv_scale, filter } => {
                if *image as usize >= n_images {
                    return Err(format!("{what}: bitmap {image} does not exist (the scene has {n_images} bitmaps)"));
                }
                if !uv_scale.is_finite() {
                    return Err(format!("{what}: uv scale {uv_scale} is not finite"));
                }
                if let TexFilter::Trilinear { first, count } = filter {
                    if *first as u64 + *count as u64 > n_images as u64 {
                        return Err(format!(
                            "{what}: MIP levels {first}..{} do not exist (the scene has {n_images} bitmaps)",
                            *first as u64 + *count as u64
                        ));
                    }
                }
                Ok(())
            }
        }
    }

    /// Per-channel maximum over the texture (Mitsuba's `Texture::getMaximum`).
    pub fn max(&self, images: &[Image]) -> Color {
        match self {
            Texture::Const(c) => *c,
            Texture::Bitmap { image, .. } => {
                images.get(*image as usize).map_or(Color::ZERO, |im| im.data.iter().fold(Color::ZERO, |m, &c| m.max(c)))
            }
        }
    }

    /// This texture times `scale`: a constant directly, a bitmap through a scaled copy
    /// appended to `images` (its MIP levels too, contiguously).
    pub fn scaled(&self, scale: f32, images: &mut Vec<Image>) -> Texture {
        let copy = |im: &Image| Image { width: im.width, height: im.height, data: im.data.iter().map(|&c| c * scale).collect() };
        match self {
            Texture::Const(c) => Texture::Const(*c * scale),
            Texture::Bitmap { image, uv_scale, filter } => {
                let Some(im) = images.get(*image as usize) else { return self.clone() };
                images.push(copy(im));
                let base = (images.len() - 1) as u32;
                let filter = match *filter {
                    TexFilter::Trilinear { first, count } => {
                        let start = images.len() as u32;
                        for l in first..first.saturating_add(count) {
                            let Some(level) = images.get(l as usize) else { return self.clone() };
                            images.push(copy(level));
                        }
                        TexFilter::Trilinear { first: start, count }
                    }
                    f => f,
                };
                Texture::Bitmap { image: base, uv_scale: *uv_scale, filter }
            }
        }
    }

    /// This texture with trilinear MIP-mapping: the pyramid of its bitmap is appended to
    /// `images` (a constant is returned unchanged).
    pub fn with_mipmaps(&self, images: &mut Vec<Image>) -> Texture {
        match self {
            Texture::Bitmap { image, uv_scale, .. } => {
                let Some(im) = images.get(*image as usize) else { return self.clone() };
                let levels = im.mip_pyramid();
                let first = images.len() as u32;
                let count = levels.len() as u32;
                images.extend(levels);
                Texture::Bitmap { image: *image, uv_scale: *uv_scale, filter: TexFilter::Trilinear { first, count } }
            }
            t => t.clone(),
        }
    }
}

/// Mitsuba 0.6's fractional MIP level of a lookup whose uv Jacobian has columns `d0 = ∂uv/∂x`
/// and `d1 = ∂uv/∂y`: `log2` of the major radius of the footprint ellipse in texels of level
/// 0 (a negative level means bilinear on level 0). Degenerate footprints (zero area) give a
/// negative level, as in 0.6.
pub fn mip_level(base: &Image, d0: Vec2, d1: Vec2) -> f32 {
    let (w, h) = (base.width as f32, base.height as f32);
    let (du0, dv0, du1, dv1) = (d0.x * w, d0.y * h, d1.x * w, d1.y * h);
    // The implicit ellipse A u² + B u v + C v² = F of 0.6 (`TMIPMap::eval`).
    let a = dv0 * dv0 + dv1 * dv1;
    let b = -2.0 * (du0 * dv0 + du1 * dv1);
    let c = du0 * du0 + du1 * du1;
    let f = a * c - b * b * 0.25;
    let root = (a - c).hypot(b);
    let a_prime = 0.5 * (a + c - root);
    let major = if a_prime > 0.0 && f > 0.0 { (f / a_prime).sqrt() } else { 0.0 };
    // 0.6's `Epsilon` (single precision) bounds the logarithm.
    let level = major.max(1e-4).log2();
    if level.is_finite() {
        level
    } else {
        -1.0
    }
}

/// Trilinear lookup at fractional `level` (0.6's `TMIPMap::eval`, `ETrilinear` branch).
fn trilinear(images: &[Image], base: &Image, first: u32, count: u32, level: f32, uv: Vec2) -> Color {
    let il = level.floor();
    if il < 0.0 {
        return base.lookup(uv);
    }
    let a = level - il;
    let at = |l: f32| -> Color {
        // Level l ≥ 1 is stored at first + l - 1; past the last level, its single texel.
        let last = count as f32;
        let l = l.min(last) as u32;
        let im = if l == 0 { Some(base) } else { images.get((first + l - 1) as usize) };
        im.map_or(Color::ZERO, |im| if l as f32 >= last && l > 0 { im.nearest(uv) } else { im.lookup(uv) })
    };
    at(il) * (1.0 - a) + at(il + 1.0) * a
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::BackendKind;
    use crate::scene::camera::{look_at, CameraDesc, FovAxis};
    use crate::scene::material::Material;
    use crate::scene::{FilmDesc, Geometry, PixelFilter, Scene, SceneDesc, ShapeDesc, TriMesh};
    use glam::{Mat4, Vec3};

    /// An `n`x`n` checkerboard of single black and white texels.
    fn checker(n: u32) -> Image {
        let data = (0..n * n).map(|i| if (i % n + i / n).is_multiple_of(2) { Color::ONE } else { Color::ZERO }).collect();
        Image { width: n, height: n, data }
    }

    fn mean(im: &Image) -> [f64; 3] {
        let mut m = [0.0f64; 3];
        for c in &im.data {
            m[0] += c.x as f64;
            m[1] += c.y as f64;
            m[2] += c.z as f64;
        }
        m.map(|v| v / im.data.len() as f64)
    }

    /// The path tracer gives a camera hit its uv partials only when the material reads them
    /// (`Material::reads_uv_partials`): that must be exactly the materials with a MIP-mapped
    /// texture, the only lookups that the partials change. Prefetching reads nothing.
    #[test]
    fn only_mip_mapped_textures_read_the_partials() {
        let mut images = vec![checker(16)];
        let bilinear = Texture::bitmap(0, Vec2::ONE);
        let mipmapped = bilinear.with_mipmaps(&mut images);
        assert!(!bilinear.reads_partials() && !Texture::Const(Color::ONE).reads_partials() && mipmapped.reads_partials());
        let tc = TexCoord { uv: Vec2::new(0.3, 0.7), duv_dx: Vec2::new(0.1, 0.0), duv_dy: Vec2::new(0.0, 0.1) };
        assert_eq!(bilinear.eval(&images, tc), bilinear.eval(&images, TexCoord::at(tc.uv)));
        assert_ne!(mipmapped.eval(&images, tc), mipmapped.eval(&images, TexCoord::at(tc.uv)));
        let diffuse = |t: &Texture| Box::new(Material::Diffuse { reflectance: t.clone() });
        assert!(!diffuse(&bilinear).reads_uv_partials() && diffuse(&mipmapped).reads_uv_partials());
        let two = |a: &Texture, b: &Texture| Material::TwoSided { front: diffuse(a), back: diffuse(b) };
        assert!(!two(&bilinear, &bilinear).reads_uv_partials() && two(&bilinear, &mipmapped).reads_uv_partials());
        let bump = |h: &Texture, t: &Texture| Material::BumpMap { height: h.clone(), scale: 1.0, nested: diffuse(t) };
        assert!(!bump(&bilinear, &bilinear).reads_uv_partials() && bump(&mipmapped, &bilinear).reads_uv_partials());
        let blend = |w: &Texture, t: &Texture| Material::Blend { weight: w.clone(), first: diffuse(&bilinear), second: diffuse(t) };
        assert!(!blend(&bilinear, &bilinear).reads_uv_partials() && blend(&mipmapped, &bilinear).reads_uv_partials());
        assert!(blend(&bilinear, &mipmapped).reads_uv_partials());
        // Prefetches of any lookup, an empty image and non-finite uvs included, are no-ops.
        let before = images[0].data.clone();
        for uv in [Vec2::new(0.3, 0.7), Vec2::new(-7.2, 1e9), Vec2::NAN] {
            two(&bilinear, &mipmapped).prefetch(&images, TexCoord { uv, ..tc });
            mipmapped.prefetch(&images, TexCoord::at(uv));
            Image::default().prefetch(uv);
        }
        assert_eq!(images[0].data, before);
    }

    #[test]
    fn pyramid_levels_halve_to_one_texel_and_keep_the_mean() {
        // Odd sizes (a classroom texture is 259x194): 0.6's sizes max(1, (n+1)/2).
        let (w, h) = (259u32, 194u32);
        let mut s = crate::sampling::Sampler::new(7, 0, 0);
        let data = (0..w * h).map(|_| Color::new(s.next_1d(), s.next_1d() * 0.5, s.next_1d() * s.next_1d())).collect();
        let im = Image { width: w, height: h, data };
        let levels = im.mip_pyramid();
        let sizes: Vec<(u32, u32)> = levels.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(130, 97), (65, 49), (33, 25), (17, 13), (9, 7), (5, 4), (3, 2), (2, 1), (1, 1)]);
        let m0 = mean(&im);
        for l in &levels {
            let m = mean(l);
            for k in 0..3 {
                assert!((m[k] - m0[k]).abs() < 1e-5, "level {}x{}: mean {m:?} vs {m0:?}", l.width, l.height);
            }
            assert!(l.data.iter().all(|c| c.min_element() >= 0.0 && c.max_element() <= 1.0), "a box filter stays in range");
        }
        // A one-texel checkerboard is grey from level 1 on, and at the top.
        let levels = checker(64).mip_pyramid();
        assert_eq!(levels.len(), 6);
        for l in &levels {
            assert!(l.data.iter().all(|c| (*c - Color::splat(0.5)).abs().max_element() < 1e-6), "{}x{}", l.width, l.height);
        }
        assert!(Image { width: 1, height: 1, data: vec![Color::ONE] }.mip_pyramid().is_empty());
        assert!(Image::default().mip_pyramid().is_empty());
    }

    #[test]
    fn mip_level_is_log2_of_the_major_radius_in_texels() {
        let im = checker(256);
        let t = 1.0 / 256.0;
        let near = |a: f32, b: f32| (a - b).abs() < 1e-4;
        assert!(near(mip_level(&im, Vec2::new(t, 0.0), Vec2::new(0.0, t)), 0.0));
        assert!(near(mip_level(&im, Vec2::new(4.0 * t, 0.0), Vec2::new(0.0, 4.0 * t)), 2.0));
        // Anisotropic: the major radius decides (blur rather than alias, as 0.6 prefers).
        assert!(near(mip_level(&im, Vec2::new(8.0 * t, 0.0), Vec2::new(0.0, t)), 3.0));
        assert!(near(mip_level(&im, Vec2::new(0.0, t), Vec2::new(8.0 * t, 0.0)), 3.0));
        // Invariant under a rotation of the footprint.
        let (s, c) = 0.7f32.sin_cos();
        let r = |v: Vec2| Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y);
        assert!(near(mip_level(&im, r(Vec2::new(8.0 * t, 0.0)), r(Vec2::new(0.0, 2.0 * t))), 3.0));
        // Texels of a non-square image count along their own axis.
        let wide = Image { width: 512, height: 128, data: vec![Color::ZERO; 512 * 128] };
        assert!(near(mip_level(&wide, Vec2::new(2.0 / 512.0, 0.0), Vec2::new(0.0, 2.0 / 128.0)), 1.0));
        // No footprint, or a degenerate one: below level 0 (bilinear).
        assert!(mip_level(&im, Vec2::ZERO, Vec2::ZERO) < 0.0);
        assert!(mip_level(&im, Vec2::new(8.0 * t, 0.0), Vec2::new(16.0 * t, 0.0)) < 0.0);
        assert!(mip_level(&im, Vec2::new(f32::NAN, 0.0), Vec2::new(0.0, t)) < 0.0);
        // Between levels the lookup blends: level 1.5 of a checker is grey, level -1 is level 0.
        let mut images = vec![im.clone()];
        let tex = Texture::bitmap(0, Vec2::ONE).with_mipmaps(&mut images);
        let uv = Vec2::new(0.5 + 0.5 * t, 0.5 + 0.5 * t);
        let at = |d: f32| tex.eval(&images, TexCoord { uv, duv_dx: Vec2::new(d, 0.0), duv_dy: Vec2::new(0.0, d) });
        assert_eq!(at(0.0), im.lookup(uv));
        assert!((at(2.0f32.powf(1.5) * t) - Color::splat(0.5)).abs().max_element() < 1e-6);
        assert!((at(10.0) - Color::splat(0.5)).abs().max_element() < 1e-6, "past the last level: the mean");
        // Level 0.5 blends the texel (white) with grey.
        assert!((at(2.0f32.sqrt() * t) - Color::splat(0.75)).abs().max_element() < 1e-5, "{}", at(2.0f32.sqrt() * t));
        assert!(tex.validate(images.len(), "t").is_ok() && tex.validate(2, "t").is_err());
        // Nearest: the texel containing uv.
        let n = Texture::Bitmap { image: 0, uv_scale: Vec2::ONE, filter: TexFilter::Nearest };
        assert_eq!(n.eval(&images, Vec2::new(0.1 * t, 0.9 * t)), Color::ONE);
        assert_eq!(n.eval(&images, Vec2::new(1.1 * t, 0.9 * t)), Color::ZERO);
        // Energy-conservation scaling scales the pyramid too.
        let scaled = tex.scaled(0.5, &mut images);
        assert!(
            (scaled.eval(&images, TexCoord { uv, duv_dx: Vec2::new(1.0, 0.0), duv_dy: Vec2::new(0.0, 1.0) }) - Color::splat(0.25))
                .abs()
                .max_element()
                < 1e-6
        );
    }

    /// A camera 200 units from a 200x200 quad carrying a 256x256 one-texel checker: a pixel
    /// covers about 8 texels. Trilinear lookups at the camera hits are grey; bilinear ones alias.
    #[test]
    fn a_far_fine_checker_is_grey_with_trilinear_and_aliases_with_bilinear() {
        let mut images = vec![checker(256)];
        let tri = Texture::bitmap(0, Vec2::ONE).with_mipmaps(&mut images);
        let quad = TriMesh::rectangle(&Mat4::from_scale(Vec3::splat(100.0)));
        let (w, h) = (24u32, 24u32);
        let fov = 40.0f32;
        let desc = SceneDesc {
            shapes: vec![ShapeDesc {
                name: "quad".into(),
                geometry: Geometry::Mesh(quad),
                material: 0,
                emission: None,
                flip_normals: false,
            }],
            materials: vec![Material::Diffuse { reflectance: tri.clone() }],
            images,
            camera: CameraDesc {
                to_world: look_at(Vec3::new(0.0, 0.0, 200.0), Vec3::ZERO, Vec3::Y),
                fov_deg: fov,
                fov_axis: FovAxis::X,
                near_clip: 0.0,
            },
            film: FilmDesc { width: w, height: h, filter: PixelFilter::Box, sample_border: false },
            ..Default::default()
        };
        let scene = Scene::prepare(desc, BackendKind::Bvh).unwrap();
        let bil = Texture::bitmap(0, Vec2::ONE);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for y in 0..h {
            for x in 0..w {
                let film = Vec2::new(x as f32 + 0.37, y as f32 + 0.61);
                let (o, d, tmin) = scene.camera.generate_ray(film);
                let mut hit = scene.intersect(&crate::math::Ray { o, d, tmin, tmax: f32::INFINITY }).expect("the quad fills the view");
                hit.set_ray_differential(&scene.camera.ray_differential(film, 1.0));
                let g = tri.eval(&scene.images, hit.uv);
                assert!((g - Color::splat(0.5)).abs().max_element() < 1e-5, "pixel {x},{y}: {g}");
                let b = bil.eval(&scene.images, hit.uv).x;
                (lo, hi) = (lo.min(b), hi.max(b));
                if (x, y) == (w / 2, h / 2) {
                    // Analytic footprint: one pixel spans 2·200·tan(20°)/24 world units, and
                    // uv runs 1/200 per unit; u along +x (film right), v along +y (film up).
                    let step = 2.0 * 200.0 * (fov.to_radians() * 0.5).tan() / w as f32 / 200.0;
                    let (dx, dy) = (hit.uv.duv_dx, hit.uv.duv_dy);
                    assert!((dx.x / step - 1.0).abs() < 1e-2 && dx.y.abs() < 1e-4 * step, "{dx} vs {step}");
                    assert!((-dy.y / step - 1.0).abs() < 1e-2 && dy.x.abs() < 1e-4 * step, "{dy} vs {step}");
                    // Scaled as Mitsuba 0.6 scales them at 16 spp: a quarter of the footprint.
                    let mut h4 = hit;
                    h4.set_ray_differential(&scene.camera.ray_differential(film, 0.25));
                    assert!((h4.uv.duv_dx.x / (0.25 * step) - 1.0).abs() < 1e-2, "{}", h4.uv.duv_dx);
                }
            }
        }
        assert!(lo < 0.2 && hi > 0.8, "bilinear lookups alias: {lo}..{hi}");
    }
}
