//! The prepared [`LightSet`]: the scene's lights (the description enum
//! [`super::desc::Light`]) plus what sampling them needs.
//!
//! Conventions: `LightSample::wi` points from the shading point towards the light;
//! `LightSample::pdf` is a solid-angle density that already includes the probability of
//! choosing the light at that point ([`LightSet::select_pmf_at`]); for delta lights (point,
//! spot, directional) `pdf` is just that selection probability and `delta` is true. Area lights emit from the front side of
//! their shape only (`dot(ng, w_out) > 0`), like Mitsuba's `area` emitter.
//!
//! Light selection for next-event estimation ([`LightSelection`]) is by default a light tree
//! ([`tree`]): the lights with a position (area, point, spot) are chosen by their importance at
//! the shading point, from their bounds of position, emission direction and intensity; the
//! lights at infinity (directional, environment) as a group with probability
//! `n / (n + 1)` for `n` of them (`1` without positioned lights, as pbrt-v4 does), among
//! themselves by power. `LightSelection::Power` chooses every light by its emitted power,
//! whatever the shading point (kept for comparison: it starves small lights that are close).
//! Photon emission is always proportional to each light's emitted power (mean over RGB). Powers:
//! - area: `π · L · A` (Lambertian emitter, one side);
//! - point: `4π · I`;
//! - spot: Mitsuba's falloff is linear in angle, full intensity inside the beam angle `b`,
//!   zero beyond the cutoff `c`; integrating `I(θ)` over the sphere gives
//!   `2π I (1 - (sin c - sin b) / (c - b))` (→ `2π I (1 - cos c)` when `b → c`);
//! - directional: `E · π R²`, the flux through the disk of the scene bounding sphere (radius
//!   `R`) facing the light;
//! - constant environment: `L · 4π · π R²` (for each direction, the flux through the disk of
//!   the bounding sphere perpendicular to it);
//! - environment map and sun-and-sky: `π R² ∫ L dω` (the same, with the emitter's integral).
//!
//! Environment lights (constant, maps, sun-and-sky) act as one emitter towards next-event
//! estimation: a direction sampled from any of them carries the radiance of all of them
//! ([`LightSet::env_le`]) with the mixture density [`LightSet::pdf_li_env`], which is also what
//! the path tracer's MIS uses when a ray escapes.
//!
//! Area lights are sampled uniformly by area (triangles through an area CDF), by one routine
//! ([`AreaGeometry::sample_point`]) for both next-event estimation and emission. A sphere seen from
//! outside is sampled uniformly inside the cone it subtends (its visible cap); from inside, or
//! when its normals are flipped, by area. `pdf_li_area` returns exactly the density of
//! `sample_li` (zero for points whose back faces the shading point, which `sample_li` never
//! returns). Triangle normals are the winding normals `(p1 - p0) × (p2 - p0)` (negated for
//! `flip_normals`); `area_le` and `pdf_li_area` use the `ng` the caller passes.
//!
//! Photon emission (`sample_emission`) returns `power` such that its mean over samples is the
//! total emitted power: area lights by area then cosine-weighted direction; point uniform;
//! spot uniform in the cutoff cone; directional and environment from a disk of the scene
//! bounding sphere, placed outside the sphere (maps and sun-and-sky: the direction
//! importance-sampled from the emitter).

use super::desc::{Geometry, Light, ShapeDesc};
use super::environment::Environment;
use super::envmap::EnvMap;
use super::sunsky::SunSky;
use crate::image::Image;
use crate::math::{Bounds3, Color, Frame};
use crate::sampling::ONE_MINUS_EPSILON;
use crate::sampling::{
    square_to_cosine_hemisphere, square_to_uniform_cone, square_to_uniform_disk_concentric, square_to_uniform_sphere,
    square_to_uniform_triangle, uniform_cone_pdf, Distribution1D, UNIFORM_SPHERE_PDF,
};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use tree::LightTree;

mod area;
pub mod tree;

pub use area::AreaGeometry;
use area::{light_bounds, light_power, not_positive, spot_falloff};

/// How next-event estimation chooses a light (module docs); spelled `"tree"` and `"power"` in
/// settings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LightSelection {
    /// The light tree: by importance at the shading point (the default).
    #[default]
    Tree,
    /// By emitted power alone, the same everywhere (photon emission's choice).
    Power,
}

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
    /// Power-proportional light-selection distribution (None when the scene has no light):
    /// photon emission, and next-event estimation under `LightSelection::Power`.
    select: Option<Distribution1D>,
    /// The tree over the lights with a position (`None` when none emits).
    tree: Option<LightTree>,
    /// The lights at infinity (directional, environment) that emit, chosen among themselves by
    /// power under `LightSelection::Tree`: their indices, the distribution, and per light its
    /// slot (`u32::MAX` for other lights).
    infinite_ids: Vec<u32>,
    infinite: Option<Distribution1D>,
    infinite_slot: Vec<u32>,
    /// Probability of choosing the lights at infinity under `LightSelection::Tree`.
    p_infinite: f32,
    /// Per light: prepared geometry for area lights (world triangles with an area CDF, or the
    /// sphere), `None` for others.
    area: Vec<Option<AreaGeometry>>,
    /// Scene bounding sphere (centre, radius), for distant and environment lights.
    scene_sphere: (Vec3, f32),
    /// Emitted power per light (W, RGB).
    power: Vec<Color>,
    /// Sum of the radiance of all constant environment lights.
    env_radiance: Color,
    /// Constant environment lights (indices), for `pdf_li_env`.
    env_lights: Vec<u32>,
    /// Prepared environment maps and skies: (light index, emitter).
    env_maps: Vec<(u32, Environment)>,
    /// Per light: index into `env_maps` (`u32::MAX` for other lights).
    env_map_of: Vec<u32>,
}

impl LightSet {
    /// Build from the non-area lights of a scene plus one area light per emitting shape
    /// (scenes without environment maps; see [`LightSet::with_images`]).
    pub fn new(lights: &[Light], shapes: &[ShapeDesc], bounds: Bounds3) -> LightSet {
        LightSet::with_images(lights, shapes, &[], bounds)
    }

    /// Build from the non-area lights of a scene plus one area light per emitting shape;
    /// `images` are the scene's images (environment maps refer to them by index). An
    /// environment emitter that cannot be prepared (missing image, invalid parameters) emits
    /// nothing: `SceneDesc::validate` rejects such scenes first.
    pub fn with_images(lights: &[Light], shapes: &[ShapeDesc], images: &[Image], bounds: Bounds3) -> LightSet {
        let mut all: Vec<Light> = lights.to_vec();
        for (i, s) in shapes.iter().enumerate() {
            if let Some(radiance) = s.emission {
                let already = all.iter().any(|l| matches!(l, Light::Area { shape, .. } if *shape as usize == i));
                if !already {
                    all.push(Light::Area { shape: i as u32, radiance });
                }
            }
        }
        let scene_sphere = {
            let (c, r) = if bounds.is_empty() { (Vec3::ZERO, 0.0) } else { bounds.bounding_sphere() };
            let c = if c.is_finite() { c } else { Vec3::ZERO };
            let r = if r.is_finite() && r > 0.0 { r } else { 1e-3 };
            (c, r)
        };
        let mut shape_light = vec![u32::MAX; shapes.len()];
        let mut area = Vec::with_capacity(all.len());
        let mut power = Vec::with_capacity(all.len());
        let mut env_radiance = Color::ZERO;
        let mut env_lights = Vec::new();
        let mut env_maps = Vec::new();
        let mut env_map_of = vec![u32::MAX; all.len()];
        for (li, l) in all.iter().enumerate() {
            let env = match l {
                Light::Envmap { image, scale, to_world } => images
                    .get(*image as usize)
                    .and_then(|img| EnvMap::new(img, *scale, *to_world).ok())
                    .map(|m| Environment::Map(Box::new(m))),
                Light::Sunsky(desc) => SunSky::new(desc).ok().map(|s| Environment::SunSky(Box::new(s))),
                _ => None,
            };
            if let Some(env) = env {
                env_map_of[li] = env_maps.len() as u32;
                env_maps.push((li as u32, env));
            }
            let geom = match l {
                Light::Area { shape, .. } => {
                    if let Some(slot) = shape_light.get_mut(*shape as usize) {
                        *slot = li as u32;
                    }
                    shapes.get(*shape as usize).and_then(AreaGeometry::new)
                }
                _ => None,
            };
            if let Light::Constant { radiance } = l {
                env_radiance += *radiance;
                env_lights.push(li as u32);
            }
            let env = env_map_of.get(li).and_then(|&m| env_maps.get(m as usize)).map(|(_, e)| e);
            power.push(light_power(l, geom.as_ref(), env, scene_sphere.1));
            area.push(geom);
        }
        let weights: Vec<f32> = power.iter().map(|p| (p.x + p.y + p.z) / 3.0).collect();
        let select = Distribution1D::new(&weights);
        let mut placed = Vec::new();
        let mut infinite_ids = Vec::new();
        let mut infinite_slot = vec![u32::MAX; all.len()];
        for (li, l) in all.iter().enumerate() {
            if !(weights[li] > 0.0) {
                continue;
            }
            match l {
                Light::Directional { .. } | Light::Constant { .. } | Light::Envmap { .. } | Light::Sunsky(_) => {
                    infinite_slot[li] = infinite_ids.len() as u32;
                    infinite_ids.push(li as u32);
                }
                _ => {
                    if let Some(b) = light_bounds(l, area[li].as_ref()) {
                        placed.push((li as u32, b));
                    }
                }
            }
        }
        let tree = LightTree::build(&placed, all.len());
        let infinite = Distribution1D::new(&infinite_ids.iter().map(|&l| weights[l as usize]).collect::<Vec<_>>());
        let p_infinite = match (&tree, &infinite) {
            (_, None) => 0.0,
            (None, Some(_)) => 1.0,
            (Some(_), Some(_)) => infinite_ids.len() as f32 / (infinite_ids.len() as f32 + 1.0),
        };
        LightSet {
            lights: all,
            shape_light,
            select,
            tree,
            infinite_ids,
            infinite,
            infinite_slot,
            p_infinite,
            area,
            scene_sphere,
            power,
            env_radiance,
            env_lights,
            env_maps,
            env_map_of,
        }
    }

    /// The same lights for a scene of `shapes` shapes, the ones past the last counted
    /// emitting nothing (as [`LightSet::with_images`] lists them for shapes added without
    /// emission: [`crate::scene::Scene::prepare_adding`]).
    pub(crate) fn cover_shapes(&mut self, shapes: usize) {
        self.shape_light.resize(shapes.max(self.shape_light.len()), u32::MAX);
    }

    /// The light tree, when some light with a position emits.
    pub fn tree(&self) -> Option<&LightTree> {
        self.tree.as_ref()
    }
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }
    /// True when some light emits a positive power (false for an empty set, or one whose lights
    /// all have zero radiance or zero area).
    pub fn emits(&self) -> bool {
        self.power.iter().any(|p| p.max_element() > 0.0)
    }
    /// Area light id of a shape, if it emits.
    #[inline]
    pub fn shape_light(&self, shape: u32) -> Option<u32> {
        self.shape_light.get(shape as usize).copied().filter(|&l| l != u32::MAX)
    }

    /// Probability that next-event estimation by `sel` at point `p` with normal `n`
    /// (`Vec3::ZERO`: none) selects light `l`.
    #[inline]
    pub fn select_pmf_at(&self, sel: LightSelection, l: u32, p: Vec3, n: Vec3) -> f32 {
        if sel == LightSelection::Power || self.lights.len() == 1 {
            return self.select_pmf(l);
        }
        match self.infinite_slot.get(l as usize) {
            None => 0.0,
            Some(&u32::MAX) => self.tree.as_ref().map_or(0.0, |t| (1.0 - self.p_infinite) * t.pmf(l, p, n)),
            Some(&slot) => self.infinite.as_ref().map_or(0.0, |d| self.p_infinite * d.pmf(slot as usize)),
        }
    }

    /// Pick a light for next-event estimation by `sel` at `p` with normal `n`: (index,
    /// probability, the same as [`Self::select_pmf_at`]'s).
    #[inline]
    fn pick_at(&self, sel: LightSelection, p: Vec3, n: Vec3, u: f32) -> Option<(usize, f32)> {
        if sel == LightSelection::Power || self.lights.len() == 1 {
            return self.pick(u);
        }
        if u < self.p_infinite {
            let d = self.infinite.as_ref()?;
            let (i, pm, _) = d.sample((u / self.p_infinite).min(ONE_MINUS_EPSILON));
            return (pm > 0.0).then(|| (self.infinite_ids[i] as usize, self.p_infinite * pm));
        }
        let tree = self.tree.as_ref()?;
        let (l, pm) = tree.sample(p, n, ((u - self.p_infinite) / (1.0 - self.p_infinite)).clamp(0.0, ONE_MINUS_EPSILON))?;
        Some((l as usize, (1.0 - self.p_infinite) * pm))
    }

    /// Probability that photon emission (and `LightSelection::Power`) selects light `l`.
    #[inline]
    pub fn select_pmf(&self, l: u32) -> f32 {
        match &self.select {
            None => 0.0,
            Some(_) if self.lights.len() == 1 => 1.0,
            Some(d) if (l as usize) < d.len() => d.pmf(l as usize),
            Some(_) => 0.0,
        }
    }

    /// Pick a light by power; returns the index and its probability (no work for one light).
    #[inline]
    fn pick(&self, u: f32) -> Option<(usize, f32)> {
        let d = self.select.as_ref()?;
        if self.lights.len() == 1 {
            return Some((0, 1.0));
        }
        let (i, p, _) = d.sample(u);
        if p > 0.0 {
            Some((i, p))
        } else {
            None
        }
    }

    /// Sample a light (chosen by `sel`) and a point on it as seen from `p` with normal `n`
    /// (`Vec3::ZERO`: none; the light tree's importance, [`tree`]).
    pub fn sample_li(&self, sel: LightSelection, p: Vec3, n: Vec3, u_select: f32, u: Vec2) -> Option<LightSample> {
        let (mut ls, env) = self.sample_li_deferred(sel, p, n, u_select, u)?;
        if env {
            ls.li = self.env_le(ls.wi);
        }
        Some(ls)
    }

    /// [`Self::sample_li`] that leaves the radiance of an environment sample to the caller:
    /// `(sample, true)` when `sample.li` is not filled in (zero) and is `self.env_le(sample.wi)`.
    /// The sky model's radiance costs six `exp` and an `asin`; a path tracer needs it only when
    /// the light sample is unoccluded, which indoors is the exception. Same samples, same
    /// values as `sample_li`.
    pub fn sample_li_deferred(&self, sel: LightSelection, p: Vec3, n: Vec3, u_select: f32, u: Vec2) -> Option<(LightSample, bool)> {
        let (l, psel) = self.pick_at(sel, p, n, u_select)?;
        if let Light::Constant { .. } | Light::Envmap { .. } | Light::Sunsky(_) = &self.lights[l] {
            // All environment lights act as one emitter (module docs): the sampled direction
            // carries the radiance of all of them and their mixture density.
            let (wi, own) = match &self.lights[l] {
                Light::Constant { .. } => (square_to_uniform_sphere(u), None),
                _ => {
                    let k = *self.env_map_of.get(l)? as usize;
                    let (wi, pdf) = self.env_maps.get(k)?.1.sample_direction(u)?;
                    (wi, Some((k, pdf)))
                }
            };
            let pdf = self.pdf_li_env_known(sel, wi, own);
            let keep = matches!(&self.lights[l], Light::Constant { .. }) || pdf > 0.0;
            return keep.then_some((LightSample { wi, dist: f32::INFINITY, li: Color::ZERO, pdf, delta: false }, true));
        }
        let ls = match &self.lights[l] {
            Light::Area { radiance, .. } => {
                let geom = self.area[l].as_ref()?;
                if let Some(one_minus_cos_max) = geom.visible_cone(p) {
                    // A sphere seen from outside: uniform in the cone it subtends.
                    let AreaGeometry::Sphere { center, radius, .. } = geom else { return None };
                    let dc = *center - p;
                    let d2 = dc.length_squared();
                    let x = u.y * one_minus_cos_max; // 1 - cos θ
                    let cos_t = 1.0 - x;
                    let sin2_t = x * (2.0 - x);
                    let phi = 2.0 * PI * u.x;
                    let d = d2.sqrt();
                    let local = crate::math::spherical_direction(sin2_t.max(0.0).sqrt(), cos_t, phi);
                    let wi = Frame::from_normal(dc / d).to_world(local).normalize();
                    let dist = d * cos_t - (radius * radius - d2 * sin2_t).max(0.0).sqrt();
                    if not_positive(dist) {
                        return None;
                    }
                    let pdf = psel / (2.0 * PI * one_minus_cos_max);
                    return Some((LightSample { wi, dist, li: *radiance, pdf, delta: false }, false));
                }
                let (q, ng) = geom.sample_point(u);
                let pdf_area = 1.0 / geom.area();
                let d = q - p;
                let dist2 = d.length_squared();
                if not_positive(dist2) {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                let cos_l = -ng.dot(wi);
                if not_positive(cos_l) {
                    return None;
                }
                let pdf = psel * pdf_area * dist2 / cos_l;
                if !pdf.is_finite() {
                    return None;
                }
                Some(LightSample { wi, dist, li: *radiance, pdf, delta: false })
            }
            Light::Point { position, intensity } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                if not_positive(dist2) {
                    return None;
                }
                let dist = dist2.sqrt();
                Some(LightSample { wi: d / dist, dist, li: *intensity / dist2, pdf: psel, delta: true })
            }
            Light::Spot { position, frame, intensity, cos_cutoff, cos_falloff_start } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                if not_positive(dist2) {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                let fall = spot_falloff(frame.n.dot(-wi), *cos_cutoff, *cos_falloff_start);
                if fall <= 0.0 {
                    return None;
                }
                Some(LightSample { wi, dist, li: *intensity * (fall / dist2), pdf: psel, delta: true })
            }
            Light::Directional { direction, irradiance } => {
                Some(LightSample { wi: -*direction, dist: f32::INFINITY, li: *irradiance, pdf: psel, delta: true })
            }
            Light::Constant { .. } | Light::Envmap { .. } | Light::Sunsky(_) => None,
        };
        ls.map(|ls| (ls, false))
    }

    /// Radiance emitted by area light `light` at a point with geometric normal `ng` towards
    /// direction `w_out` (unit, pointing away from the light).
    #[inline]
    pub fn area_le(&self, light: u32, ng: Vec3, w_out: Vec3) -> Color {
        match self.lights.get(light as usize) {
            Some(Light::Area { radiance, .. }) if ng.dot(w_out) > 0.0 => *radiance,
            _ => Color::ZERO,
        }
    }

    /// Solid-angle pdf (with selection by `sel`) that `sample_li` from `p` with normal `n`
    /// picks point `p_light` with normal `ng` on area light `light`.
    pub fn pdf_li_area(&self, sel: LightSelection, light: u32, p: Vec3, n: Vec3, p_light: Vec3, ng: Vec3) -> f32 {
        let l = light as usize;
        let Some(Some(geom)) = self.area.get(l) else { return 0.0 };
        let psel = self.select_pmf_at(sel, light, p, n);
        if psel == 0.0 {
            return 0.0;
        }
        let d = p_light - p;
        let dist2 = d.length_squared();
        if not_positive(dist2) {
            return 0.0;
        }
        let cos_l = -ng.dot(d) / dist2.sqrt();
        if not_positive(cos_l) {
            return 0.0;
        }
        if let Some(one_minus_cos_max) = geom.visible_cone(p) {
            return psel / (2.0 * PI * one_minus_cos_max);
        }
        let pdf_area = 1.0 / geom.area();
        psel * pdf_area * dist2 / cos_l
    }

    /// Radiance of environment lights along direction `dir` (a ray that escaped the scene).
    #[inline]
    pub fn env_le(&self, dir: Vec3) -> Color {
        let mut le = self.env_radiance;
        for (_, env) in &self.env_maps {
            le += env.eval(dir);
        }
        le
    }

    /// Solid-angle pdf (with selection by `sel`) that `sample_li` picks direction `dir` on
    /// environment lights (from any shading point: lights at infinity are chosen alike
    /// everywhere).
    #[inline]
    pub fn pdf_li_env(&self, sel: LightSelection, dir: Vec3) -> f32 {
        self.pdf_li_env_known(sel, dir, None)
    }

    /// [`Self::pdf_li_env`] given `(k, pdf)`: `env_maps[k]`'s own density of `dir`, as its
    /// `sample_direction` returned it with `dir` (the same value its `pdf` gives, not computed
    /// twice).
    #[inline]
    fn pdf_li_env_known(&self, sel: LightSelection, dir: Vec3, known: Option<(usize, f32)>) -> f32 {
        let pmf = |l: u32| self.select_pmf_at(sel, l, Vec3::ZERO, Vec3::ZERO);
        let mut pdf = self.env_lights.iter().map(|&l| pmf(l)).sum::<f32>() * UNIFORM_SPHERE_PDF;
        for (k, (l, env)) in self.env_maps.iter().enumerate() {
            let own = match known {
                Some((j, p)) if j == k => p,
                _ => env.pdf(dir),
            };
            pdf += pmf(*l) * own;
        }
        pdf
    }

    /// Emit a photon: light chosen by power, then position and direction.
    pub fn sample_emission(&self, u_select: f32, u_pos: Vec2, u_dir: Vec2) -> Option<Emission> {
        let (l, psel) = self.pick(u_select)?;
        let light = l as u32;
        let (center, radius) = self.scene_sphere;
        match &self.lights[l] {
            Light::Area { radiance, .. } => {
                let geom = self.area[l].as_ref()?;
                let (p, n) = geom.sample_point(u_pos);
                let area = geom.area();
                let dir = Frame::from_normal(n).to_world(square_to_cosine_hemisphere(u_dir));
                Some(Emission { p, dir, power: *radiance * (PI * area / psel), n, light })
            }
            Light::Point { position, intensity } => {
                let dir = square_to_uniform_sphere(u_dir);
                Some(Emission { p: *position, dir, power: *intensity * (4.0 * PI / psel), n: Vec3::ZERO, light })
            }
            Light::Spot { position, frame, intensity, cos_cutoff, cos_falloff_start } => {
                let local = square_to_uniform_cone(u_dir, *cos_cutoff);
                let fall = spot_falloff(local.z, *cos_cutoff, *cos_falloff_start);
                let dir = frame.to_world(local);
                let power = *intensity * (fall / (uniform_cone_pdf(*cos_cutoff) * psel));
                Some(Emission { p: *position, dir, power, n: Vec3::ZERO, light })
            }
            Light::Directional { direction, irradiance } => {
                let p = disk_origin(center, radius, *direction, u_pos);
                Some(Emission { p, dir: *direction, power: *irradiance * (PI * radius * radius / psel), n: Vec3::ZERO, light })
            }
            Light::Constant { radiance } => {
                let dir = square_to_uniform_sphere(u_dir);
                let p = disk_origin(center, radius, dir, u_pos);
                let power = *radiance * (PI * radius * radius / (UNIFORM_SPHERE_PDF * psel));
                Some(Emission { p, dir, power, n: Vec3::ZERO, light })
            }
            Light::Envmap { .. } | Light::Sunsky(_) => {
                let (_, env) = self.env_maps.get(*self.env_map_of.get(l)? as usize)?;
                // `wi` points towards the emitter; the photon travels the other way.
                let (wi, radiance, pdf) = env.sample(u_dir)?;
                let dir = -wi;
                let p = disk_origin(center, radius, dir, u_pos);
                let power = radiance * (PI * radius * radius / (pdf * psel));
                power.is_finite().then_some(Emission { p, dir, power, n: Vec3::ZERO, light })
            }
        }
    }

    /// Total emitted power of all lights (W).
    pub fn total_power(&self) -> Color {
        self.power.iter().copied().sum()
    }

    /// Emitted power of one light (W).
    pub fn light_power(&self, light: u32) -> Color {
        self.power.get(light as usize).copied().unwrap_or(Color::ZERO)
    }

    /// Scene bounding sphere (centre, radius) used by distant and environment lights.
    pub fn scene_sphere(&self) -> (Vec3, f32) {
        self.scene_sphere
    }
}

/// A point on the disk of radius `radius` perpendicular to `dir` through `center`, moved back
/// by `radius` along `-dir` so that rays starting there traverse the whole bounding sphere.
#[inline]
pub(crate) fn disk_origin(center: Vec3, radius: f32, dir: Vec3, u: Vec2) -> Vec3 {
    let f = Frame::from_normal(dir);
    let d = square_to_uniform_disk_concentric(u) * radius;
    center + f.s * d.x + f.t * d.y - dir * radius
}

#[cfg(test)]
mod selection_tests;
#[cfg(test)]
mod tests;
