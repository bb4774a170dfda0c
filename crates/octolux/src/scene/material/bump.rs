//! Mitsuba 3's shading-frame wrappers `bumpmap` (src/bsdfs/bumpmap.cpp) and `normalmap`
//! (src/bsdfs/normalmap.cpp): the nested BSDF is evaluated in a perturbed shading frame.
//!
//! The prepared scene applies the perturbation when it builds a [`crate::scene::SurfaceHit`]
//! (it has the hit's `dp/du`, `dp/dv` and normals, which a BSDF call does not see): the hit's
//! `frame` becomes the perturbed frame and `base_n` keeps the unperturbed shading normal.
//! The wrapper variants then evaluate their nested BSDF unchanged, and the integrators apply
//! Mitsuba's side check ([`crate::scene::SurfaceHit::same_side`]): a direction on different
//! sides of the perturbed and the unperturbed shading planes has no BSDF value and no
//! sample (`cos_theta(wo) · cos_theta(perturbed_wo) > 0` in Mitsuba).
//!
//! - `bumpmap`: `g = scale · ∇_uv h` (the height texture's luminance; Mitsuba's `eval_1_grad`
//!   is the exact derivative of the bilinear lookup, zero for a constant), then
//!   `dp/du' = dp/du + n (g_u - n·dp/du)`, `dp/dv' = dp/dv + n (g_v - n·dp/dv)`,
//!   `n' = normalize(dp/du' × dp/dv')`, flipped to the geometric normal's side.
//! - `normalmap`: `n' = normalize(2 rgb - 1)` in the unperturbed shading frame, whose tangent
//!   `s` is `dp/du` made orthogonal to `n` (Mitsuba's `initialize_sh_frame`): the map's red
//!   channel points along increasing `u`. No flip.
//! - In both, the perturbed tangent is `dp/du` made orthogonal to `n'`. (Mitsuba 3 mixes a
//!   local `n'` with the world `dp/du` there; this matters only for anisotropic nested BSDFs.)
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
    let st = uv * *uv_scale;
    let (w, h) = (im.width as usize, im.height as usize);
    if w == 0 || h == 0 || im.data.len() < w * h || !st.is_finite() {
        return Vec2::ZERO;
    }
    let x = st.x * w as f32 - 0.5;
    let y = st.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let ix0 = (x0 as i64).rem_euclid(w as i64) as usize;
    let iy0 = (y0 as i64).rem_euclid(h as i64) as usize;
    let ix1 = if ix0 + 1 == w { 0 } else { ix0 + 1 };
    let iy1 = if iy0 + 1 == h { 0 } else { iy0 + 1 };
    let at = |ix: usize, iy: usize| luminance(im.data[iy * w + ix]);
    let (v00, v10, v01, v11) = (at(ix0, iy0), at(ix1, iy0), at(ix0, iy1), at(ix1, iy1));
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

/// World-space normal of the bump-mapped frame, or `None` when it degenerates (the base
/// frame is then kept). `n` is the unperturbed shading normal, `ng` the geometric normal.
pub fn bump_normal(grad: Vec2, n: Vec3, ng: Vec3, dp_du: Vec3, dp_dv: Vec3) -> Option<Vec3> {
    let du = dp_du + n * (grad.x - n.dot(dp_du));
    let dv = dp_dv + n * (grad.y - n.dot(dp_dv));
    let m = du.cross(dv).normalize_or_zero();
    if m == Vec3::ZERO || !m.is_finite() {
        return None;
    }
    Some(if ng.dot(m) < 0.0 { -m } else { m })
}

/// World-space normal of a normal-mapped frame: `rgb` (the map's value, in [0,1]) decoded to
/// `2 rgb - 1` in the frame `base` (tangent along `dp/du`); `None` when it is zero.
pub fn normal_map_normal(rgb: Vec3, base: &Frame) -> Option<Vec3> {
    let local = (rgb * 2.0 - Vec3::ONE).normalize_or_zero();
    if local == Vec3::ZERO || !local.is_finite() {
        return None;
    }
    Some(base.to_world(local).normalize())
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
        let t = Texture::Bitmap { image: 0, uv_scale: Vec2::new(1.0, 2.0) };
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
        let (n, ng, du, dv) = (Vec3::Z, Vec3::Z, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 3.0, 0.0));
        // no gradient: the normal is unchanged
        assert!((bump_normal(Vec2::ZERO, n, ng, du, dv).unwrap() - n).length() < 1e-6);
        // height rising along u (slope g/|dp_du| = 1): the normal tilts towards -x by 45°
        let m = bump_normal(Vec2::new(2.0, 0.0), n, ng, du, dv).unwrap();
        assert!((m - Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-6, "{m}");
        // the flip towards the geometric normal
        let m = bump_normal(Vec2::ZERO, n, ng, du, -dv).unwrap();
        assert!((m - n).length() < 1e-6);
        // a normal map's (0.5, 0.5, 1) is the base normal; red points along dp/du
        let base = frame_along(n, du);
        assert!((normal_map_normal(Vec3::new(0.5, 0.5, 1.0), &base).unwrap() - n).length() < 1e-6);
        let m = normal_map_normal(Vec3::new(1.0, 0.5, 0.5), &base).unwrap();
        assert!((m - Vec3::X).length() < 1e-6, "{m}");
        assert!(normal_map_normal(Vec3::splat(0.5), &base).is_none());
    }
}
