//! Microfacet normal distributions, Mitsuba 3's `MicrofacetDistribution`
//! (`include/mitsuba/render/microfacet.h`): Beckmann and GGX (Trowbridge–Reitz), anisotropic
//! roughness `(alpha_u, alpha_v)` along the shading frame's tangent and bitangent, Smith's
//! separable shadowing–masking, and sampling of the distribution of visible normals (Heitz &
//! d'Eon 2014) — Mitsuba's default `sample_visible = true`, the only mode here:
//! - GGX: Heitz 2018, "Sampling the GGX distribution of visible normals" (the same density as
//!   Mitsuba's concentric-disk variant of the routine);
//! - Beckmann: Jakob 2014, "An improved visible normal sampling routine for the Beckmann
//!   distribution" (numerical inversion in the erf domain, three Newton steps), and Mitsuba's
//!   rational approximation of Beckmann's `G1` (< 0.35% relative error).
//!
//! Roughness below `1e-4` is clamped to `1e-4`, like Mitsuba.

use super::texture::{TexCoord, Texture};
use crate::image::Image;
use crate::math::Color;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Which normal distribution (Mitsuba's `distribution` parameter: `beckmann`, `ggx`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MicrofacetKind {
    Beckmann,
    Ggx,
}

impl MicrofacetKind {
    /// Mitsuba's name of the distribution.
    pub fn name(self) -> &'static str {
        match self {
            MicrofacetKind::Beckmann => "beckmann",
            MicrofacetKind::Ggx => "ggx",
        }
    }
}

/// A microfacet distribution in the local shading frame (normal +z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub kind: MicrofacetKind,
    /// Roughness along the tangent (x) direction.
    pub alpha_u: f32,
    /// Roughness along the bitangent (y) direction.
    pub alpha_v: f32,
}

/// Smallest roughness (Mitsuba's clamp).
const MIN_ALPHA: f32 = 1e-4;

impl Microfacet {
    /// An isotropic distribution of roughness `alpha`.
    #[inline]
    pub fn isotropic(kind: MicrofacetKind, alpha: f32) -> Self {
        Microfacet { kind, alpha_u: alpha, alpha_v: alpha }
    }

    #[inline]
    pub fn is_isotropic(&self) -> bool {
        self.alpha_u == self.alpha_v
    }

    /// The roughness as used (clamped to at least `1e-4`).
    #[inline]
    fn alphas(&self) -> (f32, f32) {
        (self.alpha_u.max(MIN_ALPHA), self.alpha_v.max(MIN_ALPHA))
    }

    /// Normal distribution `D(m)` (density of micro-normals per projected area:
    /// `∫ D(m) cos θ_m dm = 1`); 0 below the horizon.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        let (au, av) = self.alphas();
        let cos2 = m.z * m.z;
        let (x, y) = (m.x / au, m.y / av);
        let r = match self.kind {
            MicrofacetKind::Beckmann => (-(x * x + y * y) / cos2).exp() / (PI * au * av * cos2 * cos2),
            MicrofacetKind::Ggx => {
                let t = x * x + y * y + cos2;
                1.0 / (PI * au * av * t * t)
            }
        };
        // Mitsuba: "prevent potential numerical issues in other stages of the model"
        if r * m.z > 1e-20 {
            r
        } else {
            0.0
        }
    }

    /// Smith's masking `G1(v, m)`, zero when `v` sees the back of `m` or of the macro-surface.
    #[inline]
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let (au, av) = self.alphas();
        let xy2 = (au * v.x) * (au * v.x) + (av * v.y) * (av * v.y);
        if xy2 == 0.0 {
            return 1.0;
        }
        let tan2 = xy2 / (v.z * v.z);
        match self.kind {
            MicrofacetKind::Beckmann => {
                let a = 1.0 / tan2.sqrt();
                if a >= 1.6 {
                    1.0
                } else {
                    let a2 = a * a;
                    (3.535 * a + 2.181 * a2) / (1.0 + 2.276 * a + 2.577 * a2)
                }
            }
            MicrofacetKind::Ggx => 2.0 / (1.0 + (1.0 + tan2).sqrt()),
        }
    }

    /// Smith's separable shadowing–masking `G1(wo, m) G1(wi, m)`.
    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3, m: Vec3) -> f32 {
        self.g1(wo, m) * self.g1(wi, m)
    }

    /// Sample a visible micro-normal as seen from `v` (`v.z > 0`; callers mirror `v` to the
    /// upper side first). Density [`Microfacet::visible_pdf`].
    #[inline]
    pub fn sample_visible(&self, v: Vec3, u: Vec2) -> Vec3 {
        let (au, av) = self.alphas();
        match self.kind {
            MicrofacetKind::Ggx => {
                let vh = Vec3::new(au * v.x, av * v.y, v.z).normalize();
                let lensq = vh.x * vh.x + vh.y * vh.y;
                let t1 = if lensq > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt() } else { Vec3::X };
                let t2 = vh.cross(t1);
                let r = u.x.sqrt();
                let (sp, cp) = (2.0 * PI * u.y).sin_cos();
                let p1 = r * cp;
                let s = 0.5 * (1.0 + vh.z);
                let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * sp);
                let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
                Vec3::new(au * nh.x, av * nh.y, nh.z.max(1e-6)).normalize()
            }
            MicrofacetKind::Beckmann => {
                // Stretch, sample the slopes of the alpha = 1 distribution, rotate, unstretch.
                let vs = Vec3::new(au * v.x, av * v.y, v.z).normalize();
                let sin2 = vs.x * vs.x + vs.y * vs.y;
                let (sin_phi, cos_phi) = if sin2 > 1e-12 {
                    let inv = 1.0 / sin2.sqrt();
                    ((vs.y * inv).clamp(-1.0, 1.0), (vs.x * inv).clamp(-1.0, 1.0))
                } else {
                    (0.0, 1.0)
                };
                let slope = beckmann_visible_slope_11(vs.z, u);
                let sx = (cos_phi * slope.x - sin_phi * slope.y) * au;
                let sy = (sin_phi * slope.x + cos_phi * slope.y) * av;
                Vec3::new(-sx, -sy, 1.0).normalize()
            }
        }
    }

    /// Density (solid angle of normals) of [`Microfacet::sample_visible`] from `v`:
    /// `D(m) G1(v, m) |v·m| / v.z`.
    #[inline]
    pub fn visible_pdf(&self, v: Vec3, m: Vec3) -> f32 {
        self.d(m) * self.g1(v, m) * v.dot(m).abs() / v.z
    }

    /// Density of sampling a visible normal then reflecting `wo` about it, for `wi` (both above
    /// the surface): `D(h) G1(wo, h) / (4 wo.z)` with `h` the half vector.
    #[inline]
    pub fn reflection_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let h = (wo + wi).normalize();
        if wo.dot(h) <= 0.0 || wi.dot(h) <= 0.0 {
            return 0.0;
        }
        self.d(h) * self.g1(wo, h) / (4.0 * wo.z)
    }
}

/// Slopes of visible normals of the Beckmann distribution with `alpha = 1` seen at
/// `cos θ_i` (Jakob 2014, as in Mitsuba 3), computed in f64.
fn beckmann_visible_slope_11(cos_theta_i: f32, u: Vec2) -> Vec2 {
    const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;
    let c = (cos_theta_i as f64).clamp(1e-7, 1.0);
    let tan_theta_i = (1.0 - c * c).max(0.0).sqrt() / c;
    let cot_theta_i = 1.0 / tan_theta_i;
    // Search interval, parameterised in the erf() domain.
    let maxval = erf(cot_theta_i);
    let ux = (u.x as f64).clamp(1e-6, 1.0 - 1e-6);
    let uy = (u.y as f64).clamp(1e-6, 1.0 - 1e-6);
    // Initial guess: the analytic solution for θ_i = π/2.
    let mut x = maxval - (maxval + 1.0) * erf((-ux.ln()).sqrt());
    // Normalisation of the CDF.
    let tail = if tan_theta_i == 0.0 { 0.0 } else { INV_SQRT_PI * tan_theta_i * (-cot_theta_i * cot_theta_i).exp() };
    let target = ux * (1.0 + maxval + tail);
    for _ in 0..3 {
        let slope = erfinv(x);
        let value = 1.0 + x + INV_SQRT_PI * tan_theta_i * (-slope * slope).exp() - target;
        let derivative = 1.0 - slope * tan_theta_i;
        x -= value / derivative;
    }
    x = x.clamp(-1.0 + 1e-12, 1.0 - 1e-12);
    Vec2::new(erfinv(x) as f32, erfinv(2.0 * uy - 1.0) as f32)
}

/// The error function (Numerical Recipes' Chebyshev fit of erfc, fractional error < 1.2e-7).
pub fn erf(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07 + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    if x >= 0.0 {
        1.0 - erfc
    } else {
        erfc - 1.0
    }
}

/// The inverse error function on (-1, 1): Giles' (2010) approximation refined by two Newton
/// steps on [`erf`], so that `erf(erfinv(y)) = y` to the precision of `erf`.
pub fn erfinv(y: f64) -> f64 {
    if y <= -1.0 {
        return f64::NEG_INFINITY;
    }
    if y >= 1.0 {
        return f64::INFINITY;
    }
    let mut w = -((1.0 - y) * (1.0 + y)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_36e-08;
        for c in [
            3.432_739_39e-07,
            -3.523_387_7e-06,
            -4.391_506_54e-06,
            0.000_218_580_87,
            -0.001_253_725_03,
            -0.004_177_681_64,
            0.246_640_727,
            1.501_409_41,
        ] {
            p = c + p * w;
        }
        p
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_257;
        for c in [
            0.000_100_950_558,
            0.001_349_343_22,
            -0.003_673_428_44,
            0.005_739_507_73,
            -0.007_622_461_3,
            0.009_438_870_47,
            1.001_674_06,
            2.832_976_82,
        ] {
            p = c + p * w;
        }
        p
    };
    let mut x = p * y;
    for _ in 0..2 {
        let d = std::f64::consts::FRAC_2_SQRT_PI * (-x * x).exp();
        if d > 1e-300 {
            x -= (erf(x) - y) / d;
        }
    }
    x
}

/// A microfacet distribution whose roughness may be textured: Mitsuba 3's `alpha` (or
/// `alpha_u`, `alpha_v`) textures of `roughconductor` and `roughdielectric`, read as a scalar
/// (a grey value as it is, a colour through its luminance, like Mitsuba's `eval_1`). A
/// constant roughness gives exactly the [`Microfacet`] it was made from.
#[derive(Clone, Debug, PartialEq)]
pub struct Roughness {
    pub kind: MicrofacetKind,
    pub alpha_u: Texture,
    pub alpha_v: Texture,
}

impl From<Microfacet> for Roughness {
    fn from(m: Microfacet) -> Roughness {
        Roughness { kind: m.kind, alpha_u: Texture::Const(Color::splat(m.alpha_u)), alpha_v: Texture::Const(Color::splat(m.alpha_v)) }
    }
}

/// A constant roughness equals the distribution it is made of.
impl PartialEq<Microfacet> for Roughness {
    fn eq(&self, other: &Microfacet) -> bool {
        self.constant().is_some_and(|d| d == *other)
    }
}

impl Roughness {
    /// The distribution at `uv`.
    #[inline]
    pub fn at(&self, images: &[Image], uv: TexCoord) -> Microfacet {
        Microfacet { kind: self.kind, alpha_u: self.alpha_u.eval_1(images, uv), alpha_v: self.alpha_v.eval_1(images, uv) }
    }

    /// The distribution when neither alpha is a bitmap.
    pub fn constant(&self) -> Option<Microfacet> {
        match (&self.alpha_u, &self.alpha_v) {
            (Texture::Const(u), Texture::Const(v)) => Some(self.at(&[], TexCoord::ZERO)).filter(|_| u.is_finite() && v.is_finite()),
            _ => None,
        }
    }

    /// Both alphas the same texture.
    pub fn is_isotropic(&self) -> bool {
        self.alpha_u == self.alpha_v
    }

    pub(crate) fn validate(&self, n_images: usize) -> Result<(), String> {
        self.alpha_u.validate(n_images, "roughness alpha_u")?;
        self.alpha_v.validate(n_images, "roughness alpha_v")
    }
}
