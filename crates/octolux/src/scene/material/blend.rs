//! Mitsuba 3's `blendbsdf`: `f = (1 - w) f_0 + w f_1`, `w` the `weight` texture (a colour
//! texture is read through its luminance, like Mitsuba's `eval_1`), clamped to [0, 1].
//!
//! Sampling picks the second bsdf with probability `w` (Mitsuba's rule). A Dirac sample keeps
//! its child's weight (the blend factor cancels the selection probability); any other sample
//! gets the blend's own `pdf` and `eval / pdf`, so that MIS sees one consistent density
//! (Mitsuba returns the child's pdf instead — the same image in expectation).

use super::{luminance, BsdfSample, Lobe, Material, TexCoord, Texture};
use crate::image::Image;
use crate::math::Color;
use glam::{Vec2, Vec3};

/// The blend weight at `uv`.
#[inline]
pub(crate) fn weight(w: &Texture, images: &[Image], uv: TexCoord) -> f32 {
    let v = luminance(w.eval(images, uv));
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

#[inline]
pub(crate) fn eval(w: f32, a: &Material, b: &Material, images: &[Image], uv: TexCoord, wo: Vec3, wi: Vec3) -> Color {
    let mut f = Color::ZERO;
    if w < 1.0 {
        f += a.eval(images, uv, wo, wi) * (1.0 - w);
    }
    if w > 0.0 {
        f += b.eval(images, uv, wo, wi) * w;
    }
    f
}

#[inline]
pub(crate) fn pdf(w: f32, a: &Material, b: &Material, images: &[Image], uv: TexCoord, wo: Vec3, wi: Vec3) -> f32 {
    let mut p = 0.0;
    if w < 1.0 {
        p += a.pdf(images, uv, wo, wi) * (1.0 - w);
    }
    if w > 0.0 {
        p += b.pdf(images, uv, wo, wi) * w;
    }
    p
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn sample(
    w: f32,
    a: &Material,
    b: &Material,
    images: &[Image],
    uv: TexCoord,
    wo: Vec3,
    u_lobe: f32,
    u: Vec2,
) -> Option<BsdfSample> {
    let (child, u_child, p_child) = if u_lobe < w { (b, u_lobe / w, w) } else { (a, (u_lobe - w) / (1.0 - w), 1.0 - w) };
    let bs = child.sample(images, uv, wo, u_child.clamp(0.0, 1.0 - f32::EPSILON), u)?;
    if bs.lobe == Lobe::Specular {
        return Some(BsdfSample { pdf: bs.pdf * p_child, ..bs });
    }
    let p = pdf(w, a, b, images, uv, wo, bs.wi);
    if !(p > 0.0) || !p.is_finite() {
        return None;
    }
    Some(BsdfSample { weight: eval(w, a, b, images, uv, wo, bs.wi) / p, pdf: p, ..bs })
}
