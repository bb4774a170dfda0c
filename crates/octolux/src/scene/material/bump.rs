//! Mitsuba 3's shading-frame wrappers `bumpmap` and `normalmap` (src/bsdfs/bumpmap.cpp,
//! normalmap.cpp and their shared base in Mitsuba 3.7+): the nested BSDF is evaluated in a
//! perturbed shading frame.
//!
//! The prepared scene applies the perturbation when it builds a [`crate::scene::SurfaceHit`]
//! (it has the hit's `dp/du`, `dp/dv`, normals and the incident ray, which a BSDF call does
//! not see): the hit's `frame` becomes the perturbed frame, `base_n` keeps the unperturbed
//! shading normal and `terminator_alpha2` the shadowing parameter below. The wrapper variants
//! evaluate their nested BSDF unchanged, and the integrators multiply BSDF values and sample
//! weights by [`crate::scene::SurfaceHit::shading_factor`], which holds Mitsuba's two terms:
//! - the side check: zero for a direction on different sides of the perturbed and the
//!   unperturbed shading planes (`cos_theta(wo) · cos_theta(perturbed_wo) > 0`);
//! - the terminator shadowing of Conty Estevez et al. (Ray Tracing Gems, 2019), on by default
//!   in Mitsuba 3 (`use_shadowing_function`): `G = 2 / (1 + sqrt(1 + α² tan²θ_o))`, `θ_o`
//!   the direction's angle to the unperturbed normal, `α² = min(tan²θ_n / 8, 1)`, `θ_n` the
//!   angle between the two normals. (The pdf is unchanged, as in Mitsuba.)
//!
//! The perturbed normal `n`, in the unperturbed shading frame (tangent `s` along `dp/du`, as
//! Mitsuba's `initialize_sh_frame` builds it):
//! - `bumpmap`: `g = scale · ∇_uv h` (the height texture's luminance; Mitsuba's `eval_1_grad`
//!   is the exact derivative of the bilinear lookup, zero for a constant), then
//!   `dp/du' = dp/du + n₀ (g_u - n₀·dp/du)`, `dp/dv' = dp/dv + n₀ (g_v - n₀·dp/dv)`,
//!   `n = dp/du' × dp/dv'`, flipped to the geometric normal's side;
//! - `normalmap`: `n = 2 rgb - 1` (the map's red channel along increasing `u`).
//!
//! Then, as Mitsuba's `flip_invalid_normals` (default on, after Schüssler et al. 2017): when
//! the incident direction `wi` lies on different sides of the two planes, `n` becomes
//! `(-n_x, -n_y, n_z)`; `n` is normalised (`(0,0,1)` if it cannot be) and its frame's tangent
//! is the local x axis made orthogonal to `n`.
//!
//! The height and normal textures are data, not colours: Mitsuba's documentation asks for
//! `raw = true` bitmaps (or float images, which are never sRGB-decoded).

use super::Texture;
use crate::image::Image;
use crate::math::{luminance, Frame};
use glam::{Vec2, Vec3};

/// Gradient of the texture's luminance with respect to `uv` (per unit of uv): the exact
/// derivative of the bilinear, repeat-wrapped lookup of [`Image::lookup`], zero for constants.
pub fn luminance_gradient(t: &Texture, images: &[Image], uv: Vec2) -> Vec2 {
    let Texture::Bitmap { image, uv_scale, .. } = t else { return Vec2::ZERO };
    let Some(im) = images.get(*image as usize) else { return Vec2::ZERO };
    let Some(([i00, i10, i01, i11], fx, fy)) = im.bilinear_taps(uv * *uv_scale) else { return Vec2::ZERO };
    let (w, h) = (im.width, im.height);
    let at = |i: usize| luminance(im.data[i]);
    let (v00, v10, v01, v11) = (at(i00), at(i10), at(i01), at(i11));
    let du = ((v10 - v00) * (1.0 - fy) + (v11 - v01) * fy) * w as f32;
    let dv = ((v01 - v00) * (1.0 - fx) + (v11 - v10) * fx) * h as f32;
    let g = Vec2::new(du, dv) * *uv_scale;
    if g.is_finite() {
        g
    } else {
        Vec2::ZERO
    }
}

/// Unit `v` made orthogonal to unit `n`, or `None` when they are parallel (or `v` is 0).
#[inline]
fn tangent(n: Vec3, v: Vec3) -> Option<Vec3> {
    let s = (v - n * n.dot(v)).normalize_or_zero();
    (s != Vec3::ZERO && s.is_finite()).then_some(s)
}

/// Orthonormal frame around unit `n` whose tangent follows `dp_du` (any tangent when `dp_du`
/// is zero or parallel to `n`).
#[inline]
pub fn frame_along(n: Vec3, dp_du: Vec3) -> Frame {
    match tangent(n, dp_du) {
        Some(s) => Frame { s, t: n.cross(s), n },
        None => Frame::from_normal(n),
    }
}

/// The bump map's perturbed normal (not normalised) in the coordinates of `base`, the
/// unperturbed shading frame: `grad` is `scale · ∇_uv h`, `ng` the geometric normal.
pub fn bump_normal(grad: Vec2, base: &Frame, ng: Vec3, dp_du: Vec3, dp_dv: Vec3) -> Vec3 {
    let n = base.n;
    let du = dp_du + n * (grad.x - n.dot(dp_du));
    let dv = dp_dv + n * (grad.y - n.dot(dp_dv));
    let cr = du.cross(dv);
    base.to_local(if ng.dot(cr) < 0.0 { -cr } else { cr })
}

/// The normal map's perturbed normal (not normalised) in the unperturbed shading frame: the
/// map's value `rgb` in \[0,1\]³ decoded to `2 rgb - 1`.
#[inline]
pub fn normal_map_normal(rgb: Vec3) -> Vec3 {
    rgb * 2.0 - Vec3::ONE
}

/// `tan²θ` of a unit vector's angle to +z (Mitsuba's `Frame::tan_theta_2`).
#[inline]
fn tan2(cos: f32) -> f32 {
    let c2 = cos * cos;
    (1.0 - c2).max(0.0) / c2
}

/// The perturbed frame (world) and the terminator-shadowing `α²` for the perturbed normal
/// `n` (local to `base`, not normalised) seen from the unit direction `wi` (local to `base`,
/// pointing away from the surface): Mitsuba's `flip_invalid_normals`, normalisation and
/// Gram–Schmidt tangent (module docs).
pub fn perturbed_frame(n: Vec3, wi: Vec3, base: &Frame) -> (Frame, f32) {
    let mut n = n;
    if wi.z * wi.dot(n) <= 0.0 {
        n = Vec3::new(-n.x, -n.y, n.z);
    }
    let len2 = n.length_squared();
    let n = if len2 > 0.0 && len2.is_finite() { n / len2.sqrt() } else { Vec3::Z };
    let s = Vec3::X - n * n.x;
    let s = if s.length_squared() > 0.0 { s.normalize() } else { Vec3::Y };
    let local = Frame { s, t: n.cross(s), n };
    let world = Frame { s: base.to_world(local.s), t: base.to_world(local.t), n: base.to_world(local.n) };
    let alpha2 = (0.125 * tan2(n.z)).min(1.0);
    (world, if alpha2.is_finite() { alpha2 } else { 1.0 })
}

/// Conty Estevez et al.'s shadowing `G = 2 / (1 + sqrt(1 + α² tan²θ))` for a direction at
/// `cos θ` to the unperturbed normal (1 when `α² = 0`).
#[inline]
pub fn terminator_shadowing(alpha2: f32, cos: f32) -> f32 {
    if alpha2 <= 0.0 {
        return 1.0;
    }
    let g = 2.0 / (1.0 + (1.0 + alpha2 * tan2(cos)).sqrt());
    if g.is_finite() {
        g
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Color;

    #[test]
    fn gradient_is_the_derivative_of_the_bilinear_lookup() {
        // A 4x3 image of pseudo-random grey levels: central differences of `lookup` agree
        // with the analytic gradient away from texel-centre lines.
        let data: Vec<Color> = (0..12).map(|i| Color::splat(((i * 37 % 11) as f32) / 10.0)).collect();
        let images = vec![Image { width: 4, height: 3, data }];
        let t = Texture::bitmap(0, Vec2::new(1.0, 2.0));
        for uv in [Vec2::new(0.3, 0.4), Vec2::new(0.05, 0.9), Vec2::new(0.61, 0.1)] {
            let g = luminance_gradient(&t, &images, uv);
            let e = 1e-3;
            let f = |d: Vec2| luminance(t.eval(&images, uv + d));
            let fd = Vec2::new(f(Vec2::new(e, 0.0)) - f(Vec2::new(-e, 0.0)), f(Vec2::new(0.0, e)) - f(Vec2::new(0.0, -e))) / (2.0 * e);
            assert!((g - fd).abs().max_element() < 2e-2 * (1.0 + fd.abs().max_element()), "uv {uv}: {g} vs {fd}");
        }
        assert_eq!(luminance_gradient(&Texture::Const(Color::ONE), &images, Vec2::splat(0.3)), Vec2::ZERO);
    }

    #[test]
    fn frames_of_flat_and_tilted_maps() {
        let (n0, ng, du, dv) = (Vec3::Z, Vec3::Z, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 3.0, 0.0));
        let base = frame_along(n0, du);
        let up = Vec3::new(0.1, 0.2, 0.9).normalize();
        // no gradient: the normal is unchanged, and so is the frame
        let (f, a2) = perturbed_frame(bump_normal(Vec2::ZERO, &base, ng, du, dv), up, &base);
        assert!((f.n - n0).length() < 1e-6 && a2 == 0.0);
        // height rising along u (slope g/|dp_du| = 1): the normal tilts towards -x by 45°
        let (f, a2) = perturbed_frame(bump_normal(Vec2::new(2.0, 0.0), &base, ng, du, dv), up, &base);
        assert!((f.n - Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-6, "{:?}", f);
        assert!((a2 - 0.125).abs() < 1e-6, "tan²45° / 8: {a2}");
        // the flip towards the geometric normal
        let m = bump_normal(Vec2::ZERO, &base, ng, du, -dv);
        assert!(m.z > 0.0 && m.x == 0.0 && m.y == 0.0);
        // seen from a direction behind the tilted plane: Mitsuba's flip_invalid_normals
        let grazing = Vec3::new(0.9, 0.0, 0.3).normalize();
        let (f, _) = perturbed_frame(Vec3::new(-1.0, 0.0, 1.0), grazing, &base);
        assert!((f.n - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6, "{:?}", f);
        // a normal map's (0.5, 0.5, 1) is the base normal; red points along dp/du
        assert_eq!(normal_map_normal(Vec3::new(0.5, 0.5, 1.0)), Vec3::Z);
        let (f, _) = perturbed_frame(normal_map_normal(Vec3::new(1.0, 0.5, 0.6)), up, &base);
        assert!(f.n.x > 0.9 && f.n.y.abs() < 1e-6, "{:?}", f);
        // a zero normal falls back to the base normal
        let (f, a2) = perturbed_frame(Vec3::ZERO, up, &base);
        assert!((f.n - n0).length() < 1e-6 && a2 == 0.0);
        // frames are orthonormal and right-handed
        for (f, _) in [perturbed_frame(Vec3::new(0.3, -0.4, 0.8), up, &base), perturbed_frame(Vec3::new(1.0, 0.0, 0.0), up, &base)] {
            assert!((f.s.cross(f.t) - f.n).length() < 1e-5 && f.s.dot(f.n).abs() < 1e-5, "{f:?}");
        }
    }

    #[test]
    fn terminator_shadowing_is_one_without_tilt_and_falls_off_at_grazing_angles() {
        assert_eq!(terminator_shadowing(0.0, 0.1), 1.0);
        // α² = 0.125 (45° tilt): G(θ = 0) = 1, and at 60° G = 2 / (1 + sqrt(1 + 0.125 · 3))
        assert!((terminator_shadowing(0.125, 1.0) - 1.0).abs() < 1e-6);
        let g = terminator_shadowing(0.125, 0.5);
        assert!((g - 2.0 / (1.0 + 1.375f32.sqrt())).abs() < 1e-6, "{g}");
        assert!(terminator_shadowing(0.125, 0.01) < 0.2);
    }
}
