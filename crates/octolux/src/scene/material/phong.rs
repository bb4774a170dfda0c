//! Mitsuba 0.6's `phong` BRDF, the modified Phong model (Phong 1975; Lafortune & Willems 1994),
//! which Mitsuba 3 does not have: a Lambertian lobe `diffuseReflectance / π` plus
//! `specularReflectance · (n + 2) / (2π) · cos^n α`, `α` the angle between `wi` and the mirror
//! direction of `wo`, `n` the `exponent`. One-sided (black when `wo.z <= 0` or `wi.z <= 0`).
//!
//! Sampling as Mitsuba 0.6: the specular lobe with probability `s / (s + d)` (`s`, `d` the
//! luminances of the reflectances; for a bitmap the texel at `uv` stands in for Mitsuba's
//! texture average, a sampling heuristic only), then a direction around the mirror direction
//! with density `(n + 1) / (2π) · cos^n α`; the diffuse lobe by the cosine.
//!
//! Mitsuba's `ensureEnergyConservation` is applied at load time by
//! [`super::Material::ensure_energy_conservation`].

use super::{luminance, reflect_z, TexCoord, Texture};
use crate::image::Image;
use crate::math::{Color, Frame};
use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// A Phong BRDF evaluated at one surface point.
pub(crate) struct PhongLocal {
    exponent: f32,
    kd: Color,
    ks: Color,
    /// Probability of sampling the specular lobe.
    specular_weight: f32,
}

impl PhongLocal {
    #[inline]
    pub(crate) fn new(images: &[Image], uv: TexCoord, exponent: f32, diffuse: &Texture, specular: &Texture) -> PhongLocal {
        let kd = diffuse.eval(images, uv);
        let ks = specular.eval(images, uv);
        let (d, s) = (luminance(kd), luminance(ks));
        let specular_weight = if d + s > 0.0 { s / (d + s) } else { 0.5 };
        PhongLocal { exponent, kd, ks, specular_weight }
    }

    /// `f(wo, wi) cos θ_i`.
    #[inline]
    pub(crate) fn eval(&self, wo: Vec3, wi: Vec3) -> Color {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Color::ZERO;
        }
        let mut f = self.kd * FRAC_1_PI;
        let alpha = wi.dot(reflect_z(wo));
        if alpha > 0.0 {
            f += self.ks * ((self.exponent + 2.0) * (0.5 * FRAC_1_PI) * alpha.powf(self.exponent));
        }
        f * wi.z
    }

    /// [`PhongLocal::eval`]'s two lobes apart, `(specular, diffuse)` (each times `cos θ_i`), for
    /// the cache's split of the lobes (`split.rs`).
    #[inline]
    pub(crate) fn eval_parts(&self, wo: Vec3, wi: Vec3) -> (Color, Color) {
        let f = self.eval(wo, wi);
        let diff = if wo.z <= 0.0 || wi.z <= 0.0 { Color::ZERO } else { self.kd * (FRAC_1_PI * wi.z) };
        ((f - diff).max(Color::ZERO), diff)
    }

    /// The Beckmann roughness of the same width as the specular lobe: `sqrt(2 / (n + 2))`
    /// (Walter et al. 2007's correspondence of Phong exponents and Beckmann widths).
    #[inline]
    pub(crate) fn alpha(&self) -> f32 {
        (2.0 / (self.exponent + 2.0)).sqrt()
    }

    #[inline]
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let alpha = wi.dot(reflect_z(wo));
        let spec = if alpha > 0.0 { alpha.powf(self.exponent) * (self.exponent + 1.0) / (2.0 * PI) } else { 0.0 };
        self.specular_weight * spec + (1.0 - self.specular_weight) * square_to_cosine_hemisphere_pdf(wi)
    }

    /// A direction from the specular lobe (`u_lobe < weight`) or the diffuse one, and which.
    #[inline]
    pub(crate) fn sample_direction(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> (Vec3, bool) {
        if u_lobe < self.specular_weight {
            let n1 = self.exponent + 1.0;
            let cos_a = u.y.powf(1.0 / n1);
            let sin_a = (1.0 - u.y.powf(2.0 / n1)).max(0.0).sqrt();
            let (s, c) = (2.0 * PI * u.x).sin_cos();
            let local = Vec3::new(sin_a * c, sin_a * s, cos_a);
            (Frame::from_normal(reflect_z(wo)).to_world(local), true)
        } else {
            (square_to_cosine_hemisphere(u), false)
        }
    }
}
