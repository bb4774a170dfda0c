//! Materials (BSDFs) as a closed enum, evaluated in the local shading frame (normal = +z).
//!
//! Conventions (Mitsuba 3 compatible, so that renders agree with it):
//! - `wo` and `wi` point away from the surface, in the local shading frame.
//! - `eval` returns `f(wo, wi) · |cos θ_i|` for the non-delta lobes only.
//! - `pdf` is the solid-angle density with which `sample` generates `wi` among non-delta lobes
//!   (already multiplied by the probability of choosing that lobe).
//! - `sample` returns the weight `f · |cos θ_i| / pdf` (for delta lobes: the lobe's full weight
//!   divided by its selection probability).
//! - One-sided materials (diffuse, conductors, plastic) are black when `wo.z <= 0` or
//!   `wi.z <= 0`, as in Mitsuba 3; `TwoSided` mirrors the directions for the back side.
//!   Dielectrics are two-sided by nature (`eta` is inside/outside).

use crate::math::Color;
use glam::{Vec2, Vec3};

/// A linear-RGB bitmap (row 0 is the top of the image).
#[derive(Clone, Debug, Default)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub data: Vec<Color>,
}

/// A reflectance-like parameter: constant or a bitmap looked up by uv.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Const(Color),
    /// Index into `SceneDesc::images`; `uv_scale` multiplies the uvs (Mitsuba `to_uv` scale).
    Bitmap { image: u32, uv_scale: Vec2 },
}

/// Which kind of lobe a sample came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    Diffuse,
    Glossy,
    /// A Dirac lobe (mirror, smooth refraction): `eval`/`pdf` never see it, MIS skips it.
    Specular,
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

/// A material. Colours are linear RGB in [0,1] unless stated.
#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// Lambertian reflector (Mitsuba `diffuse`).
    Diffuse { reflectance: Texture },
    /// Smooth conductor, i.e. a mirror with Fresnel reflectance from complex IOR `eta + i k`
    /// (Mitsuba `conductor`; material "none" is `k = 0, eta = 0` meaning reflectance 1).
    Conductor { eta: Color, k: Color, specular_reflectance: Color },
    /// GGX rough conductor (Mitsuba `roughconductor`, isotropic, `alpha` = GGX roughness).
    RoughConductor { alpha: f32, eta: Color, k: Color, specular_reflectance: Color },
    /// Smooth dielectric interface (Mitsuba `dielectric`); `eta = int_ior / ext_ior`.
    Dielectric { eta: f32, specular_reflectance: Color, specular_transmittance: Color },
    /// Thin dielectric sheet (Mitsuba `thindielectric`): reflection + straight transmission.
    ThinDielectric { eta: f32, specular_reflectance: Color, specular_transmittance: Color },
    /// GGX rough plastic (Mitsuba `roughplastic`, `nonlinear = false`): a diffuse base under a
    /// rough dielectric coating of relative IOR `eta`.
    RoughPlastic { diffuse_reflectance: Texture, specular_reflectance: Color, alpha: f32, eta: f32 },
    /// Two-sided wrapper (Mitsuba `twosided`): `front` on the front side, `back` (the same
    /// material when one was given) seen from behind.
    TwoSided { front: Box<Material>, back: Box<Material> },
}

impl Image {
    /// Bilinear lookup with wrap-around (Mitsuba `bitmap` defaults: repeat, bilinear);
    /// `uv = (0,0)` is the bottom-left of the image as in Mitsuba.
    pub fn lookup(&self, uv: Vec2) -> Color {
        todo!("material helper: {uv}")
    }
}

impl Texture {
    #[inline]
    pub fn eval(&self, images: &[Image], uv: Vec2) -> Color {
        match self {
            Texture::Const(c) => *c,
            Texture::Bitmap { image, uv_scale } => images[*image as usize].lookup(uv * *uv_scale),
        }
    }
}

impl Material {
    /// `f(wo, wi) |cos θ_i|` of the non-delta lobes (local frame).
    pub fn eval(&self, images: &[Image], uv: Vec2, wo: Vec3, wi: Vec3) -> Color {
        todo!("material helper {images:?} {uv} {wo} {wi}")
    }
    /// Solid-angle pdf of `sample` producing `wi` through a non-delta lobe.
    pub fn pdf(&self, images: &[Image], uv: Vec2, wo: Vec3, wi: Vec3) -> f32 {
        todo!("material helper {images:?} {uv} {wo} {wi}")
    }
    /// Sample an incident direction. `u_lobe` picks the lobe, `u` the direction.
    pub fn sample(&self, images: &[Image], uv: Vec2, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        todo!("material helper {images:?} {uv} {wo} {u_lobe} {u}")
    }
    /// True when the material has at least one non-delta lobe (next-event estimation helps).
    pub fn has_smooth_lobe(&self) -> bool {
        todo!("material helper")
    }
    /// Check parameters; `n_images` is the number of bitmaps available.
    pub fn validate(&self, n_images: usize) -> Result<(), String> {
        todo!("material helper {n_images}")
    }
}
