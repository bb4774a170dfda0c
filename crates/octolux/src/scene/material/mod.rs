//! Materials (BSDFs) as a closed enum, evaluated in the local shading frame (normal = +z).
//!
//! Conventions (Mitsuba 3 compatible, so that renders agree with it):
//! - `wo` and `wi` point away from the surface, in the local shading frame.
//! - `eval` returns `f(wo, wi) · |cos θ_i|` for the non-delta lobes only.
//! - `pdf` is the solid-angle density with which `sample` generates `wi` among non-delta lobes
//!   (already multiplied by the probability of choosing that lobe).
//! - `sample` returns the weight `f · |cos θ_i| / pdf` (for delta lobes: the lobe's full weight
//!   divided by its selection probability).
//! - One-sided materials (diffuse, conductors, plastics, ward, phong) are black when
//!   `wo.z <= 0` or `wi.z <= 0`, as in Mitsuba; `TwoSided` mirrors the directions for the back
//!   side. Dielectrics are two-sided by nature (`eta` is inside/outside).
//! - A sample's `eta` is Mitsuba's `bs.eta`: `eta_t / eta_i` of the boundary crossed.
//! - Radiance transport: a refraction from side i into side t scales radiance by
//!   `(eta_i / eta_t)²` (Mitsuba's `TransportMode::Radiance`, factor `eta_ti²`); thin
//!   dielectrics do not scale.
//!
//! Each material follows the renderer that defines it — Mitsuba 3's `src/bsdfs/*.cpp`,
//! `render/fresnel.h`, `render/microfacet.h`, or Mitsuba 0.6 for `ward` and `phong` — and lives
//! in its room: [`fresnel`] (dielectric, conductor, thin-sheet and diffuse Fresnel),
//! [`microfacet`] (Beckmann and GGX, visible-normal sampling), [`conductor`], [`dielectric`]
//! (rough dielectric), [`plastic`] (smooth and rough, linear and nonlinear), [`ward`],
//! [`phong`], [`blend`], [`texture`], [`split`] (wide and narrow lobes, for caches), and the wrappers [`mask`] (opacity, null lobe) and
//! [`bump`] (`bumpmap`, `normalmap`: perturbed shading frames, applied by the prepared scene).
//! Smooth conductors and dielectrics are a few lines and stay here.

pub mod blend;
pub mod bump;
pub mod conductor;
pub mod dielectric;
pub mod fresnel;
pub mod mask;
pub mod microfacet;
pub mod phong;
pub mod plastic;
pub mod split;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_models;
#[cfg(test)]
mod tests_wrappers;
pub mod texture;
mod textures;
pub mod ward;

// The pieces stay reachable at their old paths (`material::fresnel_dielectric`, ...).
pub use fresnel::{fresnel_conductor, fresnel_conductor_1, fresnel_dielectric, refract, thin_dielectric_reflectance};
pub use microfacet::{Microfacet, MicrofacetKind, Roughness};
pub use split::{SplitEval, DIFFUSE_ALPHA};
pub use texture::{TexCoord, TexFilter, Texture};
pub use ward::WardVariant;

use crate::image::Image;
use crate::math::Color;
use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use phong::PhongLocal;
use plastic::PlasticLocal;
use std::f32::consts::FRAC_1_PI;
use ward::WardLocal;

/// Which kind of lobe a sample came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    Diffuse,
    Glossy,
    /// A Dirac lobe (mirror, smooth refraction): `eval`/`pdf` never see it, MIS skips it.
    Specular,
    /// The pass-through of a `mask` (Mitsuba's `BSDFFlags::Null`): `wi = -wo`, weight 1. A
    /// delta lobe too (see [`Lobe::is_delta`]), but no scattering: not a caustic's specular.
    Null,
}

impl Lobe {
    /// Dirac lobes (specular or null), which `eval`/`pdf` never see (Mitsuba's `Delta`).
    #[inline]
    pub fn is_delta(self) -> bool {
        matches!(self, Lobe::Specular | Lobe::Null)
    }
}

/// Result of `Material::sample`.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled direction, local shading frame.
    pub wi: Vec3,
    /// `f · |cos θ_i| / pdf`.
    pub weight: Color,
    /// Solid-angle density (for a Specular lobe: the discrete probability of that lobe).
    pub pdf: f32,
    pub lobe: Lobe,
    /// Relative index of refraction across the boundary when the sample is a refraction
    /// (`eta_transmitted / eta_incident`), 1 otherwise.
    pub eta: f32,
}

/// A material. Colours are linear RGB in \[0,1\] unless stated; `eta` of dielectric interfaces
/// is `int_ior / ext_ior`.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// Lambertian reflector (Mitsuba `diffuse`).
    Diffuse { reflectance: Texture },
    /// Smooth conductor, i.e. a mirror with Fresnel reflectance from complex IOR `eta + i k`
    /// (Mitsuba `conductor`; material "none" is `k = 0, eta = 0` meaning reflectance 1).
    Conductor { eta: Color, k: Color, specular_reflectance: Color },
    /// Rough conductor (Mitsuba `roughconductor`), Beckmann or GGX, possibly anisotropic,
    /// the roughness possibly textured.
    RoughConductor { distribution: Roughness, eta: Color, k: Color, specular_reflectance: Color },
    /// Smooth dielectric interface (Mitsuba `dielectric`).
    Dielectric { eta: f32, specular_reflectance: Color, specular_transmittance: Color },
    /// Thin dielectric sheet (Mitsuba `thindielectric`): reflection + straight transmission.
    ThinDielectric { eta: f32, specular_reflectance: Color, specular_transmittance: Color },
    /// Rough dielectric interface (Mitsuba `roughdielectric`), Beckmann or GGX.
    RoughDielectric { distribution: Roughness, eta: f32, specular_reflectance: Color, specular_transmittance: Color },
    /// Smooth plastic (Mitsuba `plastic`): a diffuse base under a smooth dielectric coating.
    Plastic { diffuse_reflectance: Texture, specular_reflectance: Color, eta: f32, nonlinear: bool },
    /// Rough plastic (Mitsuba `roughplastic`): a diffuse base under a rough dielectric coating
    /// (isotropic distribution only, like Mitsuba).
    RoughPlastic { diffuse_reflectance: Texture, specular_reflectance: Color, distribution: Microfacet, eta: f32, nonlinear: bool },
    /// Mitsuba 0.6's anisotropic Ward BRDF (`ward`).
    Ward { variant: WardVariant, alpha_u: f32, alpha_v: f32, diffuse_reflectance: Texture, specular_reflectance: Texture },
    /// Mitsuba 0.6's modified Phong BRDF (`phong`).
    Phong { exponent: f32, diffuse_reflectance: Texture, specular_reflectance: Texture },
    /// Two-sided wrapper (Mitsuba `twosided`): `front` on the front side, `back` (the same
    /// material when one was given) seen from behind.
    TwoSided { front: Box<Material>, back: Box<Material> },
    /// Linear blend (Mitsuba `blendbsdf`): `(1 - weight) first + weight second`.
    Blend { weight: Texture, first: Box<Material>, second: Box<Material> },
    /// Opacity mask (Mitsuba `mask`): `opacity` (luminance, clamped to \[0,1\]) of the nested
    /// BSDF, the rest a null pass-through lobe ([`mask`]).
    Mask { opacity: Texture, nested: Box<Material> },
    /// Bump map (Mitsuba `bumpmap`): `height` (luminance, uv units) times `scale` perturbs the
    /// shading frame ([`bump`]; applied when the scene builds the hit).
    BumpMap { height: Texture, scale: f32, nested: Box<Material> },
    /// Tangent-space normal map (Mitsuba `normalmap`): `normals` in \[0,1\]³ → `2 rgb - 1`
    /// ([`bump`]; applied when the scene builds the hit).
    NormalMap { normals: Texture, nested: Box<Material> },
}

pub(crate) fn check_color(c: Color, what: &str) -> Result<(), String> {
    if c.is_finite() && c.min_element() >= 0.0 {
        Ok(())
    } else {
        Err(format!("{what} {c} must be finite and non-negative"))
    }
}

fn check_ior(eta: f32, what: &str) -> Result<(), String> {
    if eta.is_finite() && eta > 0.0 {
        Ok(())
    } else {
        Err(format!("{what} {eta} must be finite and positive"))
    }
}

fn check_alpha(alpha: f32, what: &str) -> Result<(), String> {
    if alpha.is_finite() && alpha >= 0.0 {
        Ok(())
    } else {
        Err(format!("{what} {alpha} must be finite and non-negative"))
    }
}

/// A textured roughness: its constants checked as numbers, its bitmaps as textures.
fn check_roughness(r: &Roughness, n_images: usize) -> Result<(), String> {
    r.validate(n_images)?;
    if let Some(d) = r.constant() {
        check_distribution(&d)?;
    }
    Ok(())
}

fn check_distribution(d: &Microfacet) -> Result<(), String> {
    check_alpha(d.alpha_u, "roughness alpha_u")?;
    check_alpha(d.alpha_v, "roughness alpha_v")
}

/// Mean of the three channels (Mitsuba's `Texture::mean` of an RGB value).
#[inline]
pub(crate) fn channel_mean(c: Color) -> f32 {
    (c.x + c.y + c.z) * (1.0 / 3.0)
}

/// Luminance of a linear-RGB colour (Mitsuba 0.6's `Spectrum::getLuminance` in RGB mode).
#[inline]
pub(crate) fn luminance(c: Color) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// Mirror direction about +z.
#[inline]
pub(crate) fn reflect_z(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

/// Flip a local direction to the other side (+z ↔ -z).
#[inline]
fn flip_z(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

/// A sample from a lobe chosen by direction: its pdf and weight from `pdf` and `eval`.
#[inline]
fn sample_from(wi: Vec3, lobe: Lobe, pdf: f32, f: Color) -> Option<BsdfSample> {
    if wi.z <= 0.0 || !(pdf > 0.0) || !pdf.is_finite() {
        return None;
    }
    Some(BsdfSample { wi, weight: f / pdf, pdf, lobe, eta: 1.0 })
}

impl Material {
    /// The albedo `ρ` when the side of the surface that `wo` sees is purely Lambertian
    /// (`f = ρ/π`; zero from behind a one-sided diffuse), `None` for any other BSDF.
    pub fn lambertian_albedo(&self, images: &[Image], uv: impl Into<TexCoord>, wo: Vec3) -> Option<Color> {
        let uv: TexCoord = uv.into();
        match self {
            Material::Diffuse { reflectance } => Some(if wo.z > 0.0 { reflectance.eval(images, uv) } else { Color::ZERO }),
            Material::TwoSided { front, back } => {
                if wo.z > 0.0 {
                    front.lambertian_albedo(images, uv, wo)
                } else if wo.z < 0.0 {
                    back.lambertian_albedo(images, uv, flip_z(wo))
                } else {
                    Some(Color::ZERO)
                }
            }
            Material::Blend { weight, first, second } => {
                let w = blend::weight(weight, images, uv);
                Some(first.lambertian_albedo(images, uv, wo)? * (1.0 - w) + second.lambertian_albedo(images, uv, wo)? * w)
            }
            Material::Mask { opacity, nested } => Some(nested.lambertian_albedo(images, uv, wo)? * mask::opacity(opacity, images, uv)),
            Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => nested.lambertian_albedo(images, uv, wo),
            _ => None,
        }
    }

    /// `f(wo, wi) |cos θ_i|` of the non-delta lobes (local frame).
    pub fn eval(&self, images: &[Image], uv: impl Into<TexCoord>, wo: Vec3, wi: Vec3) -> Color {
        let uv: TexCoord = uv.into();
        match self {
            Material::Diffuse { reflectance } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    return Color::ZERO;
                }
                reflectance.eval(images, uv) * (wi.z * FRAC_1_PI)
            }
            Material::Conductor { .. } | Material::Dielectric { .. } | Material::ThinDielectric { .. } => Color::ZERO,
            Material::RoughConductor { distribution, eta, k, specular_reflectance } => {
                conductor::eval(&distribution.at(images, uv), *eta, *k, *specular_reflectance, wo, wi)
            }
            Material::RoughDielectric { distribution, eta, specular_reflectance, specular_transmittance } => {
                dielectric::eval(&distribution.at(images, uv), *eta, *specular_reflectance, *specular_transmittance, wo, wi)
            }
            Material::Plastic { diffuse_reflectance, eta, nonlinear, .. } => {
                plastic::smooth_eval(diffuse_reflectance.eval(images, uv), *eta, *nonlinear, wo, wi)
            }
            Material::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, eta, nonlinear } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    return Color::ZERO;
                }
                PlasticLocal::new(images, uv, diffuse_reflectance, *specular_reflectance, distribution, *eta, *nonlinear, wo).eval(
                    *specular_reflectance,
                    *eta,
                    wo,
                    wi,
                )
            }
            Material::Ward { variant, alpha_u, alpha_v, diffuse_reflectance, specular_reflectance } => {
                WardLocal::new(images, uv, *variant, *alpha_u, *alpha_v, diffuse_reflectance, specular_reflectance).eval(wo, wi)
            }
            Material::Phong { exponent, diffuse_reflectance, specular_reflectance } => {
                PhongLocal::new(images, uv, *exponent, diffuse_reflectance, specular_reflectance).eval(wo, wi)
            }
            Material::TwoSided { front, back } => {
                if wo.z > 0.0 {
                    front.eval(images, uv, wo, wi)
                } else if wo.z < 0.0 {
                    back.eval(images, uv, flip_z(wo), flip_z(wi))
                } else {
                    Color::ZERO
                }
            }
            Material::Blend { weight, first, second } => blend::eval(blend::weight(weight, images, uv), first, second, images, uv, wo, wi),
            Material::Mask { opacity, nested } => mask::eval(mask::opacity(opacity, images, uv), nested, images, uv, wo, wi),
            // The hit's frame is already the perturbed one (module `bump`).
            Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => nested.eval(images, uv, wo, wi),
        }
    }

    /// Solid-angle pdf of `sample` producing `wi` through a non-delta lobe.
    pub fn pdf(&self, images: &[Image], uv: impl Into<TexCoord>, wo: Vec3, wi: Vec3) -> f32 {
        let uv: TexCoord = uv.into();
        match self {
            Material::Diffuse { .. } => {
                if wo.z <= 0.0 {
                    return 0.0;
                }
                square_to_cosine_hemisphere_pdf(wi)
            }
            Material::Conductor { .. } | Material::Dielectric { .. } | Material::ThinDielectric { .. } => 0.0,
            Material::RoughConductor { distribution, .. } => conductor::pdf(&distribution.at(images, uv), wo, wi),
            Material::RoughDielectric { distribution, eta, .. } => dielectric::pdf(&distribution.at(images, uv), *eta, wo, wi),
            Material::Plastic { diffuse_reflectance, specular_reflectance, eta, .. } => {
                plastic::smooth_pdf(diffuse_reflectance.eval(images, uv), *specular_reflectance, *eta, wo, wi)
            }
            Material::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, eta, nonlinear } => {
                if wo.z <= 0.0 || wi.z <= 0.0 {
                    return 0.0;
                }
                PlasticLocal::new(images, uv, diffuse_reflectance, *specular_reflectance, distribution, *eta, *nonlinear, wo).pdf(wo, wi)
            }
            Material::Ward { variant, alpha_u, alpha_v, diffuse_reflectance, specular_reflectance } => {
                WardLocal::new(images, uv, *variant, *alpha_u, *alpha_v, diffuse_reflectance, specular_reflectance).pdf(wo, wi)
            }
            Material::Phong { exponent, diffuse_reflectance, specular_reflectance } => {
                PhongLocal::new(images, uv, *exponent, diffuse_reflectance, specular_reflectance).pdf(wo, wi)
            }
            Material::TwoSided { front, back } => {
                if wo.z > 0.0 {
                    front.pdf(images, uv, wo, wi)
                } else if wo.z < 0.0 {
                    back.pdf(images, uv, flip_z(wo), flip_z(wi))
                } else {
                    0.0
                }
            }
            Material::Blend { weight, first, second } => blend::pdf(blend::weight(weight, images, uv), first, second, images, uv, wo, wi),
            Material::Mask { opacity, nested } => mask::pdf(mask::opacity(opacity, images, uv), nested, images, uv, wo, wi),
            Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => nested.pdf(images, uv, wo, wi),
        }
    }

    /// Sample an incident direction. `u_lobe` picks the lobe, `u` the direction.
    pub fn sample(&self, images: &[Image], uv: impl Into<TexCoord>, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let uv: TexCoord = uv.into();
        match self {
            Material::Diffuse { reflectance } => {
                if wo.z <= 0.0 {
                    return None;
                }
                let wi = square_to_cosine_hemisphere(u);
                let pdf = square_to_cosine_hemisphere_pdf(wi);
                if pdf <= 0.0 {
                    return None;
                }
                Some(BsdfSample { wi, weight: reflectance.eval(images, uv), pdf, lobe: Lobe::Diffuse, eta: 1.0 })
            }
            Material::Conductor { eta, k, specular_reflectance } => {
                if wo.z <= 0.0 {
                    return None;
                }
                let weight = fresnel_conductor(wo.z, *eta, *k) * *specular_reflectance;
                Some(BsdfSample { wi: reflect_z(wo), weight, pdf: 1.0, lobe: Lobe::Specular, eta: 1.0 })
            }
            Material::RoughConductor { distribution, eta, k, specular_reflectance } => {
                conductor::sample(&distribution.at(images, uv), *eta, *k, *specular_reflectance, wo, u)
            }
            Material::Dielectric { eta, specular_reflectance, specular_transmittance } => {
                let (r, cos_t, eta_it, eta_ti) = fresnel_dielectric(wo.z, *eta);
                if u_lobe < r {
                    Some(BsdfSample { wi: reflect_z(wo), weight: *specular_reflectance, pdf: r, lobe: Lobe::Specular, eta: 1.0 })
                } else {
                    let wi = Vec3::new(-eta_ti * wo.x, -eta_ti * wo.y, cos_t);
                    let weight = *specular_transmittance * (eta_ti * eta_ti);
                    Some(BsdfSample { wi, weight, pdf: 1.0 - r, lobe: Lobe::Specular, eta: eta_it })
                }
            }
            Material::ThinDielectric { eta, specular_reflectance, specular_transmittance } => {
                let r = thin_dielectric_reflectance(wo.z.abs(), *eta);
                if u_lobe < r {
                    Some(BsdfSample { wi: reflect_z(wo), weight: *specular_reflectance, pdf: r, lobe: Lobe::Specular, eta: 1.0 })
                } else {
                    Some(BsdfSample { wi: -wo, weight: *specular_transmittance, pdf: 1.0 - r, lobe: Lobe::Specular, eta: 1.0 })
                }
            }
            Material::RoughDielectric { distribution, eta, specular_reflectance, specular_transmittance } => {
                dielectric::sample(&distribution.at(images, uv), *eta, *specular_reflectance, *specular_transmittance, wo, u_lobe, u)
            }
            Material::Plastic { diffuse_reflectance, specular_reflectance, eta, nonlinear } => {
                plastic::smooth_sample(diffuse_reflectance.eval(images, uv), *specular_reflectance, *eta, *nonlinear, wo, u_lobe, u)
            }
            Material::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, eta, nonlinear } => {
                if wo.z <= 0.0 {
                    return None;
                }
                let pl = PlasticLocal::new(images, uv, diffuse_reflectance, *specular_reflectance, distribution, *eta, *nonlinear, wo);
                let (wi, lobe) = pl.sample_direction(wo, u_lobe, u);
                if wi.z <= 0.0 {
                    return None;
                }
                sample_from(wi, lobe, pl.pdf(wo, wi), pl.eval(*specular_reflectance, *eta, wo, wi))
            }
            Material::Ward { variant, alpha_u, alpha_v, diffuse_reflectance, specular_reflectance } => {
                if wo.z <= 0.0 {
                    return None;
                }
                let w = WardLocal::new(images, uv, *variant, *alpha_u, *alpha_v, diffuse_reflectance, specular_reflectance);
                let (wi, specular) = w.sample_direction(wo, u_lobe, u);
                let lobe = if specular { Lobe::Glossy } else { Lobe::Diffuse };
                sample_from(wi, lobe, w.pdf(wo, wi), w.eval(wo, wi))
            }
            Material::Phong { exponent, diffuse_reflectance, specular_reflectance } => {
                if wo.z <= 0.0 {
                    return None;
                }
                let p = PhongLocal::new(images, uv, *exponent, diffuse_reflectance, specular_reflectance);
                let (wi, specular) = p.sample_direction(wo, u_lobe, u);
                let lobe = if specular { Lobe::Glossy } else { Lobe::Diffuse };
                sample_from(wi, lobe, p.pdf(wo, wi), p.eval(wo, wi))
            }
            Material::TwoSided { front, back } => {
                if wo.z > 0.0 {
                    front.sample(images, uv, wo, u_lobe, u)
                } else if wo.z < 0.0 {
                    back.sample(images, uv, flip_z(wo), u_lobe, u).map(|s| BsdfSample { wi: flip_z(s.wi), ..s })
                } else {
                    None
                }
            }
            Material::Blend { weight, first, second } => {
                blend::sample(blend::weight(weight, images, uv), first, second, images, uv, wo, u_lobe, u)
            }
            Material::Mask { opacity, nested } => mask::sample(mask::opacity(opacity, images, uv), nested, images, uv, wo, u_lobe, u),
            Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => nested.sample(images, uv, wo, u_lobe, u),
        }
    }

    /// The opacity at `uv` of a `mask` (1 for any other material, whose surface is all there).
    pub fn opacity(&self, images: &[Image], uv: impl Into<TexCoord>) -> f32 {
        match self {
            Material::Mask { opacity, .. } => mask::opacity(opacity, images, uv),
            _ => 1.0,
        }
    }

    /// True when the material has at least one non-delta lobe (next-event estimation helps).
    pub fn has_smooth_lobe(&self) -> bool {
        match self {
            Material::Diffuse { .. }
            | Material::RoughConductor { .. }
            | Material::RoughDielectric { .. }
            | Material::Plastic { .. }
            | Material::RoughPlastic { .. }
            | Material::Ward { .. }
            | Material::Phong { .. } => true,
            Material::Conductor { .. } | Material::Dielectric { .. } | Material::ThinDielectric { .. } => false,
            Material::TwoSided { front: a, back: b } | Material::Blend { first: a, second: b, .. } => {
                a.has_smooth_lobe() || b.has_smooth_lobe()
            }
            Material::Mask { nested, .. } | Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => {
                nested.has_smooth_lobe()
            }
        }
    }

    /// Check parameters; `n_images` is the number of bitmaps available.
    pub fn validate(&self, n_images: usize) -> Result<(), String> {
        match self {
            Material::Diffuse { reflectance } => reflectance.validate(n_images, "diffuse reflectance"),
            Material::Conductor { eta, k, specular_reflectance } => {
                check_color(*eta, "conductor eta")?;
                check_color(*k, "conductor k")?;
                check_color(*specular_reflectance, "specular reflectance")
            }
            Material::RoughConductor { distribution, eta, k, specular_reflectance } => {
                check_roughness(distribution, n_images)?;
                check_color(*eta, "conductor eta")?;
                check_color(*k, "conductor k")?;
                check_color(*specular_reflectance, "specular reflectance")
            }
            Material::Dielectric { eta, specular_reflectance, specular_transmittance }
            | Material::ThinDielectric { eta, specular_reflectance, specular_transmittance } => {
                check_ior(*eta, "relative index of refraction")?;
                check_color(*specular_reflectance, "specular reflectance")?;
                check_color(*specular_transmittance, "specular transmittance")
            }
            Material::RoughDielectric { distribution, eta, specular_reflectance, specular_transmittance } => {
                check_roughness(distribution, n_images)?;
                check_ior(*eta, "relative index of refraction")?;
                if *eta == 1.0 {
                    return Err("rough dielectric: the interior and exterior indices of refraction must differ".into());
                }
                check_color(*specular_reflectance, "specular reflectance")?;
                check_color(*specular_transmittance, "specular transmittance")
            }
            Material::Plastic { diffuse_reflectance, specular_reflectance, eta, .. } => {
                check_ior(*eta, "relative index of refraction")?;
                diffuse_reflectance.validate(n_images, "diffuse reflectance")?;
                check_color(*specular_reflectance, "specular reflectance")
            }
            Material::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, eta, .. } => {
                check_distribution(distribution)?;
                if !distribution.is_isotropic() {
                    return Err("rough plastic: anisotropic roughness is not supported (as in Mitsuba)".into());
                }
                check_ior(*eta, "relative index of refraction")?;
                if *eta == 1.0 {
                    return Err("rough plastic: the interior and exterior indices of refraction must differ".into());
                }
                diffuse_reflectance.validate(n_images, "diffuse reflectance")?;
                check_color(*specular_reflectance, "specular reflectance")
            }
            Material::Ward { alpha_u, alpha_v, diffuse_reflectance, specular_reflectance, .. } => {
                for (a, what) in [(*alpha_u, "ward alpha_u"), (*alpha_v, "ward alpha_v")] {
                    if !(a.is_finite() && a > 0.0) {
                        return Err(format!("{what} {a} must be finite and positive"));
                    }
                }
                diffuse_reflectance.validate(n_images, "diffuse reflectance")?;
                specular_reflectance.validate(n_images, "specular reflectance")
            }
            Material::Phong { exponent, diffuse_reflectance, specular_reflectance } => {
                if !(exponent.is_finite() && *exponent >= 0.0) {
                    return Err(format!("phong exponent {exponent} must be finite and non-negative"));
                }
                diffuse_reflectance.validate(n_images, "diffuse reflectance")?;
                specular_reflectance.validate(n_images, "specular reflectance")
            }
            Material::TwoSided { front, back } => {
                front.validate(n_images)?;
                back.validate(n_images)
            }
            Material::Blend { weight, first, second } => {
                weight.validate(n_images, "blend weight")?;
                first.validate(n_images)?;
                second.validate(n_images)
            }
            Material::Mask { opacity, nested } => {
                opacity.validate(n_images, "mask opacity")?;
                nested.validate(n_images)
            }
            Material::BumpMap { height, scale, nested } => {
                if !scale.is_finite() {
                    return Err(format!("bump map scale {scale} must be finite"));
                }
                height.validate(n_images, "bump map height")?;
                nested.validate(n_images)
            }
            Material::NormalMap { normals, nested } => {
                normals.validate(n_images, "normal map")?;
                nested.validate(n_images)
            }
        }
    }

    /// Mitsuba 0.6's `ensureEnergyConservation` (on by default) for `ward` and `phong`: when
    /// the per-channel maxima of the specular and diffuse reflectances sum above 1, both are
    /// scaled by `0.99 / max` (bitmaps through a scaled copy appended to `images`). Returns one
    /// message per material changed, saying by how much.
    pub fn ensure_energy_conservation(&mut self, images: &mut Vec<Image>) -> Vec<String> {
        match self {
            Material::Ward { diffuse_reflectance: kd, specular_reflectance: ks, .. }
            | Material::Phong { diffuse_reflectance: kd, specular_reflectance: ks, .. } => {
                let actual = (kd.max(images) + ks.max(images)).max_element();
                if actual > 1.0 {
                    let scale = 0.99 / actual;
                    *kd = kd.scaled(scale, images);
                    *ks = ks.scaled(scale, images);
                    return vec![format!(
                        "specular and diffuse reflectances sum to a per-channel maximum of {actual} > 1; both are scaled by {scale} \
                         (Mitsuba 0.6's ensureEnergyConservation)"
                    )];
                }
                Vec::new()
            }
            Material::TwoSided { front: a, back: b } | Material::Blend { first: a, second: b, .. } => {
                let mut v = a.ensure_energy_conservation(images);
                v.extend(b.ensure_energy_conservation(images));
                v
            }
            Material::Mask { nested, .. } | Material::BumpMap { nested, .. } | Material::NormalMap { nested, .. } => {
                nested.ensure_energy_conservation(images)
            }
            _ => Vec::new(),
        }
    }
}
