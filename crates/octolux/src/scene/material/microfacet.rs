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
        let frame = VisibleFrame::new(self, v);
        frame.normal(frame.part_x(u.x), VisibleFrame::part_y(self.kind, u.y))
    }

    /// [`Microfacet::sample_visible`] from `v` at every point `(ux[i], uy[j])` of a tensor grid,
    /// into `out` row by row (`uy` outer, `ux` inner): the same bits, with what depends on one
    /// coordinate of `u` only computed once per coordinate (Beckmann's inversion of its slope
    /// distribution, GGX's square root and sine/cosine). For quadratures over the sample
    /// space, such as the rough plastic's tables at scene preparation.
    pub(crate) fn sample_visible_grid(&self, v: Vec3, ux: &[f32], uy: &[f32], out: &mut Vec<Vec3>) {
        let frame = VisibleFrame::new(self, v);
        let xs: Vec<[f32; 2]> = ux.iter().map(|&x| frame.part_x(x)).collect();
        out.clear();
        out.reserve(ux.len() * uy.len());
        for &y in uy {
            let py = VisibleFrame::part_y(self.kind, y);
            out.extend(xs.iter().map(|&px| frame.normal(px, py)));
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

/// What [`Microfacet::sample_visible`] computes from `v` alone: the stretched view direction
/// and, for GGX, its orthonormal frame (Heitz 2018), for Beckmann its azimuth. The sample is
/// `normal(part_x(u.x), part_y(u.y))`.
struct VisibleFrame {
    kind: MicrofacetKind,
    au: f32,
    av: f32,
    /// The view direction stretched by the roughness (unit).
    vs: Vec3,
    /// GGX: the frame's tangents `t1`, `t2`; Beckmann: `t1 = (sin φ, cos φ, 0)` of `vs`.
    t1: Vec3,
    t2: Vec3,
}

impl VisibleFrame {
    #[inline]
    fn new(m: &Microfacet, v: Vec3) -> VisibleFrame {
        let (au, av) = m.alphas();
        let vs = Vec3::new(au * v.x, av * v.y, v.z).normalize();
        match m.kind {
            MicrofacetKind::Ggx => {
                let lensq = vs.x * vs.x + vs.y * vs.y;
                let t1 = if lensq > 0.0 { Vec3::new(-vs.y, vs.x, 0.0) / lensq.sqrt() } else { Vec3::X };
                VisibleFrame { kind: m.kind, au, av, vs, t1, t2: vs.cross(t1) }
            }
            MicrofacetKind::Beckmann => {
                let sin2 = vs.x * vs.x + vs.y * vs.y;
                let (sin_phi, cos_phi) = if sin2 > 1e-12 {
                    let inv = 1.0 / sin2.sqrt();
                    ((vs.y * inv).clamp(-1.0, 1.0), (vs.x * inv).clamp(-1.0, 1.0))
                } else {
                    (0.0, 1.0)
                };
                VisibleFrame { kind: m.kind, au, av, vs, t1: Vec3::new(sin_phi, cos_phi, 0.0), t2: Vec3::ZERO }
            }
        }
    }

    /// The part of the sample that depends on `u.x` (and `v`): GGX `sqrt(u.x)`; Beckmann the
    /// slope along the azimuth of the `alpha = 1` distribution.
    #[inline]
    fn part_x(&self, ux: f32) -> [f32; 2] {
        match self.kind {
            MicrofacetKind::Ggx => [ux.sqrt(), 0.0],
            MicrofacetKind::Beckmann => [beckmann_visible_slope_x(self.vs.z, ux), 0.0],
        }
    }

    /// The part that depends on `u.y` only: GGX `sin, cos (2π u.y)`; Beckmann the slope across
    /// the azimuth of the `alpha = 1` distribution.
    #[inline]
    fn part_y(kind: MicrofacetKind, uy: f32) -> [f32; 2] {
        match kind {
            MicrofacetKind::Ggx => {
                let (sp, cp) = (2.0 * PI * uy).sin_cos();
                [sp, cp]
            }
            MicrofacetKind::Beckmann => [beckmann_visible_slope_y(uy), 0.0],
        }
    }

    /// The sampled micro-normal from the two parts.
    #[inline]
    fn normal(&self, px: [f32; 2], py: [f32; 2]) -> Vec3 {
        let (au, av) = (self.au, self.av);
        match self.kind {
            MicrofacetKind::Ggx => {
                let (r, sp, cp) = (px[0], py[0], py[1]);
                let (vh, t1, t2) = (self.vs, self.t1, self.t2);
                let p1 = r * cp;
                let s = 0.5 * (1.0 + vh.z);
                let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * sp);
                let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
                Vec3::new(au * nh.x, av * nh.y, nh.z.max(1e-6)).normalize()
            }
            MicrofacetKind::Beckmann => {
                // Rotate the slopes of the alpha = 1 distribution to the azimuth, unstretch.
                let (slope_x, slope_y) = (px[0], py[0]);
                let (sin_phi, cos_phi) = (self.t1.x, self.t1.y);
                let sx = (cos_phi * slope_x - sin_phi * slope_y) * au;
                let sy = (sin_phi * slope_x + cos_phi * slope_y) * av;
                Vec3::new(-sx, -sy, 1.0).normalize()
            }
        }
    }
}

/// Slope along the azimuth of visible normals of the Beckmann distribution with `alpha = 1`
/// seen at `cos θ_i` (Jakob 2014, as in Mitsuba 3), computed in f64.
fn beckmann_visible_slope_x(cos_theta_i: f32, ux: f32) -> f32 {
    const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;
    let c = (cos_theta_i as f64).clamp(1e-7, 1.0);
    let tan_theta_i = (1.0 - c * c).max(0.0).sqrt() / c;
    let cot_theta_i = 1.0 / tan_theta_i;
    // Search interval, parameterised in the erf() domain.
    let maxval = erf(cot_theta_i);
    let ux = (ux as f64).clamp(1e-6, 1.0 - 1e-6);
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
    erfinv(x) as f32
}

/// Slope across the azimuth of visible normals of the Beckmann distribution with
/// `alpha = 1`: a normal deviate (independent of the view direction).
fn beckmann_visible_slope_y(uy: f32) -> f32 {
    let uy = (uy as f64).clamp(1e-6, 1.0 - 1e-6);
    erfinv(2.0 * uy - 1.0) as f32
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
