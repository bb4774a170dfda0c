//! Rough conductor, Mitsuba 3's `roughconductor`: `F(wo·h) D(h) G(wo, wi, h) / (4 cos θ_o)`
//! (times `cos θ_i`, already folded in) with the conductor Fresnel factor of complex IOR
//! `eta + i k` per RGB channel, any [`Microfacet`] distribution (Beckmann or GGX,
//! anisotropic), sampled by visible normals. One-sided.

use super::fresnel::fresnel_conductor;
use super::microfacet::Microfacet;
use super::{BsdfSample, Lobe};
use crate::math::{reflect, Color};
use glam::{Vec2, Vec3};

/// `f(wo, wi) cos θ_i`.
#[inline]
pub(crate) fn eval(d: &Microfacet, eta: Color, k: Color, ks: Color, wo: Vec3, wi: Vec3) -> Color {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return Color::ZERO;
    }
    let h = (wo + wi).normalize();
    let dh = d.d(h);
    if dh == 0.0 {
        return Color::ZERO;
    }
    fresnel_conductor(wo.dot(h), eta, k) * ks * (dh * d.g(wo, wi, h) / (4.0 * wo.z))
}

/// Solid-angle density of [`sample`] producing `wi`.
#[inline]
pub(crate) fn pdf(d: &Microfacet, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    d.reflection_pdf(wo, wi)
}

/// Reflect `wo` about a visible micro-normal.
#[inline]
pub(crate) fn sample(d: &Microfacet, eta: Color, k: Color, ks: Color, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let m = d.sample_visible(wo, u);
    let wi = reflect(wo, m);
    if wi.z <= 0.0 {
        return None;
    }
    let pdf = d.d(m) * d.g1(wo, m) / (4.0 * wo.z);
    if !(pdf > 0.0) || !pdf.is_finite() {
        return None;
    }
    let weight = fresnel_conductor(wo.dot(m), eta, k) * ks * d.g1(wi, m);
    Some(BsdfSample { wi, weight, pdf, lobe: Lobe::Glossy, eta: 1.0 })
}
