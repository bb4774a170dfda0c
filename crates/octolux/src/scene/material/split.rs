//! A material's non-delta lobes split into *wide* and *narrow* ones, for integrators that end
//! paths in a radiance cache (`integrators::octree`, docs/guide/octree.md "Ending paths in the
//! cache"): a cache of incident light can stand in for the integral of a wide lobe, while a
//! narrow lobe (a glossy highlight) must keep sampling directions.
//!
//! Roughness is compared as a microfacet `alpha` (GGX or Beckmann, which have nearly the
//! same width for the same `alpha`): the geometric mean of the two alphas of an anisotropic
//! lobe, Ward's alphas as they are (Ward's lobe is Beckmann-shaped), and Phong's exponent `n`
//! as `sqrt(2 / (n + 2))`. A diffuse lobe has `alpha` [`DIFFUSE_ALPHA`].

use super::phong::PhongLocal;
use super::plastic::PlasticLocal;
use super::ward::WardLocal;
use super::{blend, flip_z, mask, Material, TexCoord};
use crate::image::Image;
use crate::math::Color;
use glam::Vec3;

/// The roughness a diffuse lobe counts as (wider than any microfacet lobe's).
pub const DIFFUSE_ALPHA: f32 = 1.0;

/// `eval`'s value split by lobe width: `wide` from the lobes whose `alpha` is at least the
/// threshold given, `narrow` from the others (`wide + narrow` is `eval`, up to rounding).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SplitEval {
    pub wide: Color,
    pub narrow: Color,
}

impl SplitEval {
    #[inline]
    fn by_width(f: Color, alpha: f32, min_alpha: f32) -> SplitEval {
        if alpha >= min_alpha {
            SplitEval { wide: f, narrow: Color::ZERO }
        } else {
            SplitEval { wide: Color::ZERO, narrow: f }
        }
    }

    #[inline]
    fn parts(glossy: Color, diffuse: Color, alpha: f32, min_alpha: f32) -> SplitEval {
        if alpha >= min_alpha {
            SplitEval { wide: glossy + diffuse, narrow: Color::ZERO }
        } else {
            SplitEval { wide: diffuse, narrow: glossy }
        }
    }
}

impl std::ops::Mul<f32> for SplitEval {
    type Output = SplitEval;
    #[inline]
    fn mul(self, k: f32) -> SplitEval {
        SplitEval { wide: self.wide * k, narrow: self.narrow * k }
    }
}

impl std::ops::Add for SplitEval {
    type Output = SplitEval;
    #[inline]
    fn add(self, o: SplitEval) -> SplitEval {
        SplitEval { wide: self.wide + o.wide, narrow: self.narrow + o.narrow }
    }
}

impl Material {
    /// The `alpha` of the narrowest glossy (non-delta, non-diffuse) lobe at `uv`;
    /// [`DIFFUSE_ALPHA`] when every non-delta lobe is diffuse, 0 when there is none (a mirror,
    /// smooth glass). The width a sampled glossy lobe gives a ray cone.
    pub fn glossy_alpha(&self, images: &[Image], uv: impl Into<TexCoord>) -> f32 {
        let uv: TexCoord = uv.into();
        let mean = |au: f32, av: f32| (au * av).sqrt();
        match self {
            Material::Diffuse { .. } | Material::Plastic { .. } => DIFFUSE_ALPHA,
            Material::Conductor { .. } | Material::Dielectric { .. } | Material::ThinDielectric { .. } => 0.0,
            Material::RoughConductor { distribution, .. } | Material::RoughDielectric { distribution, .. } => {
                let d = distribution.at(images, uv);
                mean(d.alpha_u, d.alpha_v)
            }
            Material::RoughPlastic { distribution, .. } => distribution.alpha_u,
            Material::Ward { alpha_u, alpha_v, .. } => mean(*alpha_u, *alpha_v),
            Material::Phong { exponent, .. } => (2.0 / (exponent + 2.0)).sqrt(),
            Material::TwoSided { front: a, back: b } | Material::Blend { first: a, second: b, .. } => {
                let (x, y) = (a.glossy_alpha(images, uv), b.glossy_alpha(images, uv));
                // the narrower of the two lobes that exist (0: no lobe)
                match (x > 0.0, y > 0.0) {
                    (true, true) => x.min(y),
                    (true, false) => x,
                    _ => y,
                }
            }
            Material::Mask { nested, .. } | Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => {
                nested.glossy_alpha(images, uv)
            }
        }
    }

    /// [`Material::eval`] split into the lobes at least `min_alpha` wide and the narrower ones
    /// (local frame, `f · |cos θ_i|`). With `min_alpha = 0` every non-delta lobe is wide.
    pub fn eval_split(&self, images: &[Image], uv: impl Into<TexCoord>, wo: Vec3, wi: Vec3, min_alpha: f32) -> SplitEval {
        let uv: TexCoord = uv.into();
        match self {
            Material::Diffuse { .. } | Material::Plastic { .. } => SplitEval { wide: self.eval(images, uv, wo, wi), narrow: Color::ZERO },
            Material::Conductor { .. } | Material::Dielectric { .. } | Material::ThinDielectric { .. } => SplitEval::default(),
            Material::RoughConductor { .. } | Material::RoughDielectric { .. } => {
                SplitEval::by_width(self.eval(images, uv, wo, wi), self.glossy_alpha(images, uv), min_alpha)
            }
            Material::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, eta, nonlinear } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    return SplitEval::default();
                }
                let pl = PlasticLocal::new(images, uv, diffuse_reflectance, *specular_reflectance, distribution, *eta, *nonlinear, wo);
                let (spec, diff) = pl.eval_parts(*specular_reflectance, *eta, wo, wi);
                SplitEval::parts(spec, diff, pl.alpha(), min_alpha)
            }
            Material::Ward { variant, alpha_u, alpha_v, diffuse_reflectance, specular_reflectance } => {
                let w = WardLocal::new(images, uv, *variant, *alpha_u, *alpha_v, diffuse_reflectance, specular_reflectance);
                let (spec, diff) = w.eval_parts(wo, wi);
                SplitEval::parts(spec, diff, w.alpha(), min_alpha)
            }
            Material::Phong { exponent, diffuse_reflectance, specular_reflectance } => {
                let p = PhongLocal::new(images, uv, *exponent, diffuse_reflectance, specular_reflectance);
                let (spec, diff) = p.eval_parts(wo, wi);
                SplitEval::parts(spec, diff, p.alpha(), min_alpha)
            }
            Material::TwoSided { front, back } => {
                if wo.z > 0.0 {
                    front.eval_split(images, uv, wo, wi, min_alpha)
                } else if wo.z < 0.0 {
                    back.eval_split(images, uv, flip_z(wo), flip_z(wi), min_alpha)
                } else {
                    SplitEval::default()
                }
            }
            Material::Blend { weight, first, second } => {
                let w = blend::weight(weight, images, uv);
                let mut f = SplitEval::default();
                if w < 1.0 {
                    f = f + first.eval_split(images, uv, wo, wi, min_alpha) * (1.0 - w);
                }
                if w > 0.0 {
                    f = f + second.eval_split(images, uv, wo, wi, min_alpha) * w;
                }
                f
            }
            Material::Mask { opacity, nested } => {
                let o = mask::opacity(opacity, images, uv);
                if o <= 0.0 {
                    return SplitEval::default();
                }
                nested.eval_split(images, uv, wo, wi, min_alpha) * o
            }
            Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => nested.eval_split(images, uv, wo, wi, min_alpha),
        }
    }

    /// Whether some non-delta lobe at `uv` is at least `min_alpha` wide (its light may come
    /// from a cache).
    pub fn has_wide_lobe(&self, images: &[Image], uv: impl Into<TexCoord>, min_alpha: f32) -> bool {
        let uv: TexCoord = uv.into();
        match self {
            Material::Diffuse { .. }
            | Material::Plastic { .. }
            | Material::RoughPlastic { .. }
            | Material::Ward { .. }
            | Material::Phong { .. } => true,
            Material::Conductor { .. } | Material::Dielectric { .. } | Material::ThinDielectric { .. } => false,
            Material::RoughConductor { .. } | Material::RoughDielectric { .. } => self.glossy_alpha(images, uv) >= min_alpha,
            Material::TwoSided { front: a, back: b } | Material::Blend { first: a, second: b, .. } => {
                a.has_wide_lobe(images, uv, min_alpha) || b.has_wide_lobe(images, uv, min_alpha)
            }
            Material::Mask { nested, .. } | Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => {
                nested.has_wide_lobe(images, uv, min_alpha)
            }
        }
    }

    /// Whether every lobe at `uv` is non-delta and at least `min_alpha` wide (all its light may
    /// come from a cache and a light sample).
    pub fn only_wide_lobes(&self, images: &[Image], uv: impl Into<TexCoord>, min_alpha: f32) -> bool {
        let uv: TexCoord = uv.into();
        match self {
            Material::Diffuse { .. } => true,
            Material::Plastic { .. } | Material::Conductor { .. } | Material::Dielectric { .. } | Material::ThinDielectric { .. } => false,
            Material::Mask { .. } => false,
            Material::RoughConductor { .. }
            | Material::RoughDielectric { .. }
            | Material::RoughPlastic { .. }
            | Material::Ward { .. }
            | Material::Phong { .. } => self.glossy_alpha(images, uv) >= min_alpha,
            Material::TwoSided { front: a, back: b } | Material::Blend { first: a, second: b, .. } => {
                a.only_wide_lobes(images, uv, min_alpha) && b.only_wide_lobes(images, uv, min_alpha)
            }
            Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => nested.only_wide_lobes(images, uv, min_alpha),
        }
    }
}
