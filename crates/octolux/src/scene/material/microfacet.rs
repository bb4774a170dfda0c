//! Microfacet distributions (Mitsuba 3's `render/microfacet.h`): GGX (Trowbridge–Reitz) with
//! Smith's separable masking, sampled by visible normals (Heitz 2018, "Sampling the GGX
//! distribution of visible normals").

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Isotropic GGX (Trowbridge–Reitz) microfacet distribution in the local frame.
#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    pub alpha: f32,
}

impl Ggx {
    /// Mitsuba clamps the roughness to at least `1e-4`.
    #[inline]
    pub fn new(alpha: f32) -> Self {
        Ggx { alpha: alpha.max(1e-4) }
    }

    /// Normal distribution `D(m)` (density of micro-normals per projected area: `∫ D cos θ_m = 1`).
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        let t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
        let r = 1.0 / (PI * a2 * t * t);
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
        let xy2 = self.alpha * self.alpha * (v.x * v.x + v.y * v.y);
        if xy2 == 0.0 {
            return 1.0;
        }
        let tan2 = xy2 / (v.z * v.z);
        2.0 / (1.0 + (1.0 + tan2).sqrt())
    }

    /// Sample a visible micro-normal as seen from `v` (`v.z > 0`); density
    /// `D(m) G1(v, m) max(0, v·m) / v.z` (Heitz 2018).
    #[inline]
    pub fn sample_visible(&self, v: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        let vh = Vec3::new(a * v.x, a * v.y, v.z).normalize();
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let t1 = if lensq > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt() } else { Vec3::X };
        let t2 = vh.cross(t1);
        let r = u.x.sqrt();
        let (sp, cp) = (2.0 * PI * u.y).sin_cos();
        let p1 = r * cp;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * (r * sp);
        let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        Vec3::new(a * nh.x, a * nh.y, nh.z.max(1e-6)).normalize()
    }

    /// Density of `sample_visible`-then-reflect producing `wi` from `wo` (both above the
    /// surface): `D(h) G1(wo, h) / (4 wo.z)` with `h` the half vector.
    #[inline]
    pub fn reflection_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let h = (wo + wi).normalize();
        if wo.dot(h) <= 0.0 || wi.dot(h) <= 0.0 {
            return 0.0;
        }
        self.d(h) * self.g1(wo, h) / (4.0 * wo.z)
    }
}
