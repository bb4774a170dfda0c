//! Rough dielectric interface, Mitsuba 3's `roughdielectric` (Walter et al. 2007, "Microfacet
//! models for refraction through rough surfaces", with visible-normal sampling): for the half
//! vector `m` of a reflection (`wo + wi`) or a refraction (`wo + η wi`, η the relative IOR seen
//! from `wo`'s side),
//! - reflection: `F D G / (4 |cos θ_o|)`,
//! - transmission: `|(1/η)² (1 - F) D G η² (wo·m)(wi·m) / (cos θ_o (wo·m + η wi·m)²)|`,
//!
//! (both already multiplied by `|cos θ_i|`; the `(1/η)²` is the radiance scaling across the
//! boundary, as in Mitsuba's `TransportMode::Radiance`), times `specular_reflectance` or
//! `specular_transmittance`. Sampling: a visible normal of the distribution seen from `wo`
//! (mirrored to the upper side), then reflection with probability `F`, else refraction.
//! Two-sided by nature (`eta` is interior / exterior).

use super::fresnel::{fresnel_dielectric, refract};
use super::microfacet::Microfacet;
use super::{BsdfSample, Lobe};
use crate::math::{reflect, Color};
use glam::{Vec2, Vec3};

/// `v` mirrored to the upper hemisphere when `sign < 0` (Mitsuba's `mulsign`).
#[inline]
fn mulsign(v: Vec3, sign: f32) -> Vec3 {
    if sign < 0.0 {
        -v
    } else {
        v
    }
}

/// The half vector of `(wo, wi)` in the upper hemisphere, whether the pair is a reflection,
/// and the relative IOR seen from `wo`'s side.
#[inline]
fn half_vector(eta: f32, wo: Vec3, wi: Vec3) -> (Vec3, bool, f32) {
    let reflect = wo.z * wi.z > 0.0;
    let eta_rel = if wo.z > 0.0 { eta } else { 1.0 / eta };
    let m = (wo + wi * if reflect { 1.0 } else { eta_rel }).normalize();
    (mulsign(m, m.z), reflect, eta_rel)
}

/// `f(wo, wi) |cos θ_i|` of a rough dielectric.
pub(crate) fn eval(d: &Microfacet, eta: f32, ks: Color, kt: Color, wo: Vec3, wi: Vec3) -> Color {
    if wo.z == 0.0 || wi.z == 0.0 {
        return Color::ZERO;
    }
    let (m, reflect, eta_rel) = half_vector(eta, wo, wi);
    if !m.is_finite() {
        return Color::ZERO;
    }
    let dm = d.d(m);
    let f = fresnel_dielectric(wo.dot(m), eta).0;
    let g = d.g(wo, wi, m);
    if reflect {
        ks * (f * dm * g / (4.0 * wo.z.abs()))
    } else {
        let scale = 1.0 / (eta_rel * eta_rel);
        let denom = wo.dot(m) + eta_rel * wi.dot(m);
        let v = (scale * (1.0 - f) * dm * g * eta_rel * eta_rel * wo.dot(m) * wi.dot(m) / (wo.z * denom * denom)).abs();
        if v.is_finite() {
            kt * v
        } else {
            Color::ZERO
        }
    }
}

/// Solid-angle density of [`sample`] producing `wi`.
pub(crate) fn pdf(d: &Microfacet, eta: f32, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z == 0.0 || wi.z == 0.0 {
        return 0.0;
    }
    let (m, reflect, eta_rel) = half_vector(eta, wo, wi);
    if !m.is_finite() || wo.dot(m) * wo.z <= 0.0 || wi.dot(m) * wi.z <= 0.0 {
        return 0.0;
    }
    let dwh_dwi = if reflect {
        1.0 / (4.0 * wi.dot(m))
    } else {
        let denom = wo.dot(m) + eta_rel * wi.dot(m);
        eta_rel * eta_rel * wi.dot(m) / (denom * denom)
    };
    let f = fresnel_dielectric(wo.dot(m), eta).0;
    let p = d.visible_pdf(mulsign(wo, wo.z), m) * if reflect { f } else { 1.0 - f } * dwh_dwi.abs();
    if p.is_finite() {
        p
    } else {
        0.0
    }
}

/// Sample a reflection or a refraction through a visible micro-normal.
pub(crate) fn sample(d: &Microfacet, eta: f32, ks: Color, kt: Color, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
    if wo.z == 0.0 {
        return None;
    }
    let m = d.sample_visible(mulsign(wo, wo.z), u);
    let (f, cos_t, eta_it, eta_ti) = fresnel_dielectric(wo.dot(m), eta);
    let (wi, weight, eta_s) =
        if u_lobe <= f { (reflect(wo, m), ks, 1.0) } else { (refract(wo, m, cos_t, eta_ti), kt * (eta_ti * eta_ti), eta_it) };
    let g1 = d.g1(wi, m);
    if g1 <= 0.0 || wi.z == 0.0 || (u_lobe <= f) != (wi.z * wo.z > 0.0) {
        return None;
    }
    let p = pdf(d, eta, wo, wi);
    if !(p > 0.0) || !p.is_finite() {
        return None;
    }
    Some(BsdfSample { wi, weight: weight * g1, pdf: p, lobe: Lobe::Glossy, eta: eta_s })
}
