//! Mitsuba 3's `mask` (src/bsdfs/mask.cpp): an opacity-weighted blend of the nested BSDF and
//! a null (pass-through) lobe, for alpha cut-outs such as leaves.
//!
//! - `opacity` is a scalar texture: a colour texture is read through its luminance (Mitsuba's
//!   `eval_1` of an RGB bitmap), clamped to [0, 1]. Mitsuba 3's `bitmap` drops the alpha
//!   channel of an RGBA file, so the cut-out is a separate grey image, as in its documentation.
//! - `eval = opacity · f_nested`, `pdf = opacity · pdf_nested`.
//! - `sample`: with probability `1 - opacity` the null lobe — `wi = -wo`, weight 1, pdf
//!   `1 - opacity`, [`Lobe::Null`] — else the nested sample, unchanged except that its pdf
//!   is the mask's own `pdf` (Mitsuba keeps the nested pdf there: the same image in
//!   expectation; ours keeps `sample` consistent with `pdf` for MIS and the chi² tests).
//!
//! How the integrators treat the null lobe (docs/architecture.md): Mitsuba 3's `path` counts it
//! as a delta vertex (`BSDFFlags::Delta` includes `Null`: no MIS at the next emitter hit, the
//! depth grows by one, as for a mirror) and its shadow rays stop at masks whatever their
//! opacity; octolux's `path` does the same. The photon pass crosses the null lobe like a delta
//! bounce and stores no photon where the opacity is 0; the cache integrators' camera walk
//! resolves a mask stochastically (pass with probability `1 - opacity`, else the nested BSDF).

use super::{luminance, BsdfSample, Lobe, Material, TexCoord, Texture};
use crate::image::Image;
use crate::math::Color;
use glam::{Vec2, Vec3};

/// The opacity at `uv`, in [0, 1] (NaN reads as 0).
#[inline]
pub fn opacity(t: &Texture, images: &[Image], uv: impl Into<TexCoord>) -> f32 {
    let v = luminance(t.eval(images, uv));
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

#[inline]
pub(crate) fn eval(o: f32, nested: &Material, images: &[Image], uv: TexCoord, wo: Vec3, wi: Vec3) -> Color {
    if o <= 0.0 {
        return Color::ZERO;
    }
    nested.eval(images, uv, wo, wi) * o
}

#[inline]
pub(crate) fn pdf(o: f32, nested: &Material, images: &[Image], uv: TexCoord, wo: Vec3, wi: Vec3) -> f32 {
    if o <= 0.0 {
        return 0.0;
    }
    nested.pdf(images, uv, wo, wi) * o
}

/// The null lobe's sample: straight through, weight 1.
#[inline]
pub fn null_sample(wo: Vec3, prob: f32) -> BsdfSample {
    BsdfSample { wi: -wo, weight: Color::ONE, pdf: prob, lobe: Lobe::Null, eta: 1.0 }
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn sample(o: f32, nested: &Material, images: &[Image], uv: TexCoord, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
    if !(u_lobe < o) {
        return Some(null_sample(wo, 1.0 - o));
    }
    let bs = nested.sample(images, uv, wo, (u_lobe / o).min(1.0 - f32::EPSILON), u)?;
    // A delta sample keeps its (discrete) probability times the lobe choice; a smooth one
    // gets the mask's own density, its weight `f/pdf` being unchanged by the factor `o`.
    Some(BsdfSample { pdf: bs.pdf * o, ..bs })
}
