//! Fresnel equations (Mitsuba 3's `render/fresnel.h`): unpolarised dielectric reflectance with
//! the refracted cosine, conductors with a complex index of refraction per RGB channel, and a
//! thin dielectric sheet's reflectance with its inter-reflections.

use crate::math::Color;
use glam::Vec3;

/// Unpolarised dielectric Fresnel reflectance (Mitsuba's `fresnel`).
///
/// `cos_theta_i` is the cosine of the incident direction with the normal (negative when it
/// comes from inside), `eta` the relative IOR `eta_inside / eta_outside`. Returns
/// `(R, cos θ_t, eta_it, eta_ti)` where `cos θ_t` has the sign opposite to `cos θ_i` (the
/// refracted direction is on the other side), `eta_it = eta_t / eta_i` and `eta_ti = 1 / eta_it`.
/// Total internal reflection gives `R = 1`, `cos θ_t = 0`.
#[inline]
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let outside = cos_theta_i >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * eta_ti * eta_ti;
    let ci = cos_theta_i.abs();
    let ct = cos_theta_t_sqr.max(0.0).sqrt();
    let r = if eta == 1.0 {
        0.0
    } else if ci == 0.0 {
        1.0
    } else {
        let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
        let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    let cos_theta_t = if outside { -ct } else { ct };
    (r, cos_theta_t, eta_it, eta_ti)
}

/// Refract `w` (pointing away from the surface) through the microfacet normal `m`, given
/// the signed `cos θ_t` and `eta_ti` from [`fresnel_dielectric`] of `dot(w, m)`.
#[inline]
pub fn refract(w: Vec3, m: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    m * (w.dot(m) * eta_ti + cos_theta_t) - w * eta_ti
}

/// Unpolarised Fresnel reflectance of a conductor with complex IOR `eta + i k` for one
/// channel (Mitsuba's `fresnel_conductor`); `eta = k = 0` is material "none": exactly 1.
#[inline]
pub fn fresnel_conductor_1(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    if eta == 0.0 && k == 0.0 {
        return 1.0;
    }
    let c2 = cos_theta_i * cos_theta_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let temp1 = eta * eta - k * k - s2;
    let a2pb2 = (temp1 * temp1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2pb2 + temp1)).max(0.0).sqrt();
    let term1 = a2pb2 + c2;
    let term2 = 2.0 * cos_theta_i * a;
    let rs = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * c2 + s4;
    let term4 = term2 * s2;
    let rp = rs * (term3 - term4) / (term3 + term4);
    let r = 0.5 * (rs + rp);
    if r.is_finite() {
        r.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// [`fresnel_conductor_1`] per RGB channel.
#[inline]
pub fn fresnel_conductor(cos_theta_i: f32, eta: Color, k: Color) -> Color {
    Color::new(
        fresnel_conductor_1(cos_theta_i, eta.x, k.x),
        fresnel_conductor_1(cos_theta_i, eta.y, k.y),
        fresnel_conductor_1(cos_theta_i, eta.z, k.z),
    )
}

/// Reflectance of a thin dielectric sheet including inter-reflections:
/// `R' = R + T² R / (1 - R²)` with `R = F(|cos θ|, η)`, `T = 1 - R` (Mitsuba `thindielectric`).
#[inline]
pub fn thin_dielectric_reflectance(abs_cos_theta: f32, eta: f32) -> f32 {
    let r = fresnel_dielectric(abs_cos_theta, eta).0;
    if r < 1.0 {
        let t = 1.0 - r;
        r + t * t * r / (1.0 - r * r)
    } else {
        r
    }
}

/// Diffuse Fresnel reflectance `Fdr` of a dielectric boundary of relative IOR `eta`: the
/// fraction of uniform diffuse illumination it reflects (Mitsuba's
/// `fresnel_diffuse_reflectance`: the fit of Egan & Hilgeman 1973 for `eta < 1`, of d'Eon &
/// Irving 2011 otherwise).
#[inline]
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        let c = [0.919317f32, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, &k| acc * inv + k)
    }
}
