//! Lights as a closed enum, and the prepared [`LightSet`] that samples them.
//!
//! Conventions: `LightSample::wi` points from the shading point towards the light;
//! `LightSample::pdf` is a solid-angle density that already includes the probability of
//! choosing the light (by power); for delta lights (point, spot, directional) `pdf` is just
//! that selection probability and `delta` is true. Area lights emit from the front side of
//! their shape only (`dot(ng, w_out) > 0`), like Mitsuba's `area` emitter.

use crate::math::{Color, Frame};
use glam::Vec3;

/// A light source as described by a scene.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Diffuse area emitter on shape `shape` (index into the scene's shapes) of radiance
    /// `radiance` (W/(m² sr)).
    Area { shape: u32, radiance: Color },
    /// Isotropic point light of intensity `intensity` (W/sr).
    Point { position: Vec3, intensity: Color },
    /// Spot light at `position` shining along `frame.n` (Mitsuba `spot`): full intensity
    /// inside `cos_falloff_start`, smooth falloff to zero at `cos_cutoff`.
    Spot { position: Vec3, frame: Frame, intensity: Color, cos_cutoff: f32, cos_falloff_start: f32 },
    /// Distant light travelling along `direction` (unit) with irradiance `irradiance` (W/m²)
    /// on a surface perpendicular to it.
    Directional { direction: Vec3, irradiance: Color },
    /// Constant environment of radiance `radiance` from every direction.
    Constant { radiance: Color },
}

use crate::math::Bounds3;
use crate::sampling::Distribution1D;
use crate::scene::ShapeDesc;
use glam::Vec2;

/// A sampled connection from a shading point to a light (next-event estimation).
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Distance to the sampled point (`f32::INFINITY` for directional and environment lights).
    pub dist: f32,
    /// Incident radiance arriving along `-wi` (for delta lights: intensity / distance² or
    /// irradiance), not yet divided by `pdf`.
    pub li: Color,
    /// Solid-angle density including the light-selection probability; for delta lights the
    /// selection probability only.
    pub pdf: f32,
    pub delta: bool,
}

/// An emitted photon (or light-path start).
#[derive(Clone, Copy, Debug)]
pub struct Emission {
    pub p: Vec3,
    /// Unit direction of travel.
    pub dir: Vec3,
    /// Flux carried by the path (W), already divided by all sampling densities, for one sample.
    pub power: Color,
    /// Geometric normal at the emission point (zero for point/directional/environment lights).
    pub n: Vec3,
    pub light: u32,
}

/// All lights of a prepared scene, with what sampling them needs.
#[derive(Clone, Debug)]
pub struct LightSet {
    pub lights: Vec<Light>,
    /// Light index per shape (`u32::MAX` for shapes that do not emit).
    shape_light: Vec<u32>,
    /// Power-proportional light-selection distribution (None when the scene has no light).
    select: Option<Distribution1D>,
    /// Per light: prepared geometry for area lights (world triangles with an area CDF, or the
    /// sphere), `None` for others.
    area: Vec<Option<AreaGeometry>>,
    /// Scene bounding sphere (centre, radius), for distant and environment lights.
    scene_sphere: (Vec3, f32),
}

/// Geometry of an area light prepared for sampling by area.
#[derive(Clone, Debug)]
pub enum AreaGeometry {
    Triangles { tris: Vec<[Vec3; 3]>, normals: Vec<Vec3>, cdf: Distribution1D, area: f32 },
    Sphere { center: Vec3, radius: f32, flip: bool },
}

impl LightSet {
    /// Build from the non-area lights of a scene plus one area light per emitting shape.
    pub fn new(lights: &[Light], shapes: &[ShapeDesc], bounds: Bounds3) -> LightSet {
        todo!("light helper {lights:?} {shapes:?} {bounds:?}")
    }
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }
    /// Area light id of a shape, if it emits.
    #[inline]
    pub fn shape_light(&self, shape: u32) -> Option<u32> {
        self.shape_light.get(shape as usize).copied().filter(|&l| l != u32::MAX)
    }
    /// Sample a light (by power) and a point on it as seen from `p`.
    pub fn sample_li(&self, p: Vec3, u_select: f32, u: Vec2) -> Option<LightSample> {
        todo!("light helper {p} {u_select} {u}")
    }
    /// Radiance emitted by area light `light` at a point with geometric normal `ng` towards
    /// direction `w_out` (unit, pointing away from the light).
    pub fn area_le(&self, light: u32, ng: Vec3, w_out: Vec3) -> Color {
        todo!("light helper {light} {ng} {w_out}")
    }
    /// Solid-angle pdf (with selection) that `sample_li` from `p` picks point `p_light` with
    /// normal `ng` on area light `light`.
    pub fn pdf_li_area(&self, light: u32, p: Vec3, p_light: Vec3, ng: Vec3) -> f32 {
        todo!("light helper {light} {p} {p_light} {ng}")
    }
    /// Radiance of environment lights along direction `dir` (a ray that escaped the scene).
    pub fn env_le(&self, dir: Vec3) -> Color {
        todo!("light helper {dir}")
    }
    /// Solid-angle pdf (with selection) that `sample_li` picks direction `dir` on environment lights.
    pub fn pdf_li_env(&self, dir: Vec3) -> f32 {
        todo!("light helper {dir}")
    }
    /// Emit a photon: light chosen by power, then position and direction.
    pub fn sample_emission(&self, u_select: f32, u_pos: Vec2, u_dir: Vec2) -> Option<Emission> {
        todo!("light helper {u_select} {u_pos} {u_dir}")
    }
    /// Total emitted power of all lights (W).
    pub fn total_power(&self) -> Color {
        todo!("light helper")
    }
}

impl Light {
    pub fn validate(&self) -> Result<(), String> {
        todo!("light helper")
    }
}
