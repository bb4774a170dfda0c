//! Lights as a closed enum, and the prepared [`LightSet`] that samples them.
//!
//! Conventions: `LightSample::wi` points from the shading point towards the light;
//! `LightSample::pdf` is a solid-angle density that already includes the probability of
//! choosing the light (by power); for delta lights (point, spot, directional) `pdf` is just
//! that selection probability and `delta` is true. Area lights emit from the front side of
//! their shape only (`dot(ng, w_out) > 0`), like Mitsuba's `area` emitter.
//!
//! Light selection (for next-event estimation and photon emission) is proportional to each
//! light's emitted power (mean over RGB). Powers:
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
//! Environment lights (constant and maps) act as one emitter towards next-event estimation:
//! a direction sampled from any of them carries the radiance of all of them ([`LightSet::env_le`])
//! with the mixture density [`LightSet::pdf_li_env`], which is also what the path tracer's MIS
//! uses when a ray escapes.
//!
//! Area lights are sampled uniformly by area (triangles through an area CDF). A sphere seen from
//! outside is sampled uniformly inside the cone it subtends (its visible cap); from inside, or
//! when its normals are flipped, by area. `pdf_li_area` returns exactly the density of
//! `sample_li` (zero for points whose back faces the shading point, which `sample_li` never
//! returns). Triangle normals are the winding normals `(p1 - p0) × (p2 - p0)` (negated for
//! `flip_normals`); `area_le` and `pdf_li_area` use the `ng` the caller passes.
//!
//! Photon emission (`sample_emission`) returns `power` such that its mean over samples is the
//! total emitted power: area lights by area then cosine-weighted direction; point uniform;
//! spot uniform in the cutoff cone; directional and environment from a disk of the scene
//! bounding sphere, placed outside the sphere (environment maps: direction importance-sampled
//! from the map).

use crate::math::{Color, Frame};
use crate::sampling::{
    square_to_cosine_hemisphere, square_to_uniform_cone, square_to_uniform_disk_concentric, square_to_uniform_sphere,
    square_to_uniform_triangle, uniform_cone_pdf, UNIFORM_SPHERE_PDF,
};
use crate::scene::Geometry;
use crate::envmap::EnvMap;
use crate::sunsky::{SunSky, SunSkyDesc};
use crate::material::Image;
use glam::{Mat3, Vec3};
use std::f32::consts::PI;

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
    /// Latitude-longitude environment map (Mitsuba `envmap`, see [`crate::envmap`]): image
    /// `image` (index into the scene's images, linear RGB) times `scale`, oriented by the
    /// orthogonal `to_world` (local `+y` is up).
    Envmap { image: u32, scale: f32, to_world: Mat3 },
    /// Sun and sky (Mitsuba 3 `sunsky`, see [`crate::sunsky`]).
    Sunsky(SunSkyDesc),
}

/// A prepared environment emitter other than the constant one.
#[derive(Clone, Debug)]
pub enum Environment {
    Map(EnvMap),
    SunSky(Box<SunSky>),
}

impl Environment {
    /// Radiance arriving from world direction `dir`.
    #[inline]
    pub fn eval(&self, dir: Vec3) -> Color {
        match self {
            Environment::Map(m) => m.eval(dir),
            Environment::SunSky(s) => s.eval(dir),
        }
    }
    /// Sample a direction towards the emitter: (direction, radiance, solid-angle pdf).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Color, f32)> {
        match self {
            Environment::Map(m) => m.sample(u),
            Environment::SunSky(s) => s.sample(u),
        }
    }
    /// Solid-angle density of `sample`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        match self {
            Environment::Map(m) => m.pdf(dir),
            Environment::SunSky(s) => s.pdf(dir),
        }
    }
    /// `∫ L dω` over the sphere.
    pub fn integral(&self) -> Color {
        match self {
            Environment::Map(m) => m.integral(),
            Environment::SunSky(s) => s.integral(),
        }
    }
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

/// Geometry of an area light prepared for sampling by area.
#[derive(Clone, Debug)]
pub enum AreaGeometry {
    Triangles { tris: Vec<[Vec3; 3]>, normals: Vec<Vec3>, cdf: Distribution1D, area: f32 },
    Sphere { center: Vec3, radius: f32, flip: bool },
}

impl LightSet {
    /// Build from the non-area lights of a scene plus one area light per emitting shape
    /// (scenes without environment maps; see [`LightSet::with_images`]).
    pub fn new(lights: &[Light], shapes: &[ShapeDesc], bounds: Bounds3) -> LightSet {
        LightSet::with_images(lights, shapes, &[], bounds)
    }

    /// Build from the non-area lights of a scene plus one area light per emitting shape;
    /// `images` are the scene's images (environment maps refer to them by index). An
    /// environment map whose image is missing or invalid emits nothing (`SceneDesc::validate`
    /// rejects such scenes first).
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
                Light::Envmap { image, scale, to_world } => {
                    images.get(*image as usize).and_then(|img| EnvMap::new(img, *scale, *to_world).ok()).map(Environment::Map)
                }
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
            let map = env_map_of.get(li).and_then(|&m| env_maps.get(m as usize)).map(|(_, m)| m);
            power.push(light_power(l, geom.as_ref(), map, scene_sphere.1));
            area.push(geom);
        }
        let weights: Vec<f32> = power.iter().map(|p| (p.x + p.y + p.z) / 3.0).collect();
        let select = Distribution1D::new(&weights);
        LightSet { lights: all, shape_light, select, area, scene_sphere, power, env_radiance, env_lights, env_maps, env_map_of }
    }
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }
    /// Area light id of a shape, if it emits.
    #[inline]
    pub fn shape_light(&self, shape: u32) -> Option<u32> {
        self.shape_light.get(shape as usize).copied().filter(|&l| l != u32::MAX)
    }

    /// Probability of selecting light `l`.
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

    /// Sample a light (by power) and a point on it as seen from `p`.
    pub fn sample_li(&self, p: Vec3, u_select: f32, u: Vec2) -> Option<LightSample> {
        let (l, psel) = self.pick(u_select)?;
        match &self.lights[l] {
            Light::Area { radiance, .. } => {
                let (q, ng, pdf_area) = match self.area[l].as_ref()? {
                    AreaGeometry::Triangles { tris, normals, cdf, area } => {
                        let (ti, ux) = if tris.len() == 1 {
                            (0, u.x)
                        } else {
                            let (ti, _, ux) = cdf.sample(u.x);
                            (ti, ux)
                        };
                        let b = square_to_uniform_triangle(Vec2::new(ux, u.y));
                        let [a, b1, c] = tris[ti];
                        (a * (1.0 - b.x - b.y) + b1 * b.x + c * b.y, normals[ti], 1.0 / *area)
                    }
                    AreaGeometry::Sphere { center, radius, flip } => {
                        let dc = *center - p;
                        let d2 = dc.length_squared();
                        let r2 = radius * radius;
                        if !*flip && d2 > r2 {
                            // Uniform in the cone subtended by the sphere.
                            let sin2_max = r2 / d2;
                            let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
                            let one_minus_cos_max = sin2_max / (1.0 + cos_max);
                            let x = u.y * one_minus_cos_max; // 1 - cos θ
                            let cos_t = 1.0 - x;
                            let sin2_t = x * (2.0 - x);
                            let phi = 2.0 * PI * u.x;
                            let d = d2.sqrt();
                            let local = crate::math::spherical_direction(sin2_t.max(0.0).sqrt(), cos_t, phi);
                            let wi = Frame::from_normal(dc / d).to_world(local).normalize();
                            let dist = d * cos_t - (r2 - d2 * sin2_t).max(0.0).sqrt();
                            if not_positive(dist) {
                                return None;
                            }
                            let pdf = psel / (2.0 * PI * one_minus_cos_max);
                            return Some(LightSample { wi, dist, li: *radiance, pdf, delta: false });
                        }
                        let n = square_to_uniform_sphere(u);
                        (*center + n * *radius, if *flip { -n } else { n }, 1.0 / (4.0 * PI * r2))
                    }
                };
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
            // All environment lights act as one emitter towards the path tracer, which adds
            // their radiance on escape with the pdf `pdf_li_env`: a sampled environment
            // direction carries the radiance and the mixture density of all of them.
            Light::Constant { .. } => {
                let wi = square_to_uniform_sphere(u);
                Some(LightSample { wi, dist: f32::INFINITY, li: self.env_le(wi), pdf: self.pdf_li_env(wi), delta: false })
            }
            Light::Envmap { .. } | Light::Sunsky(_) => {
                let (_, map) = self.env_maps.get(*self.env_map_of.get(l)? as usize)?;
                let (wi, _, _) = map.sample(u)?;
                let pdf = self.pdf_li_env(wi);
                (pdf > 0.0).then(|| LightSample { wi, dist: f32::INFINITY, li: self.env_le(wi), pdf, delta: false })
            }
        }
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

    /// Solid-angle pdf (with selection) that `sample_li` from `p` picks point `p_light` with
    /// normal `ng` on area light `light`.
    pub fn pdf_li_area(&self, light: u32, p: Vec3, p_light: Vec3, ng: Vec3) -> f32 {
        let l = light as usize;
        let Some(Some(geom)) = self.area.get(l) else { return 0.0 };
        let psel = self.select_pmf(light);
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
        let pdf_area = match geom {
            AreaGeometry::Triangles { area, .. } => 1.0 / *area,
            AreaGeometry::Sphere { center, radius, flip } => {
                let d2 = (*center - p).length_squared();
                let r2 = radius * radius;
                if !*flip && d2 > r2 {
                    let sin2_max = r2 / d2;
                    let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
                    return psel / (2.0 * PI * (sin2_max / (1.0 + cos_max)));
                }
                1.0 / (4.0 * PI * r2)
            }
        };
        psel * pdf_area * dist2 / cos_l
    }

    /// Radiance of environment lights along direction `dir` (a ray that escaped the scene).
    #[inline]
    pub fn env_le(&self, dir: Vec3) -> Color {
        let mut le = self.env_radiance;
        for (_, map) in &self.env_maps {
            le += map.eval(dir);
        }
        le
    }

    /// Solid-angle pdf (with selection) that `sample_li` picks direction `dir` on environment lights.
    #[inline]
    pub fn pdf_li_env(&self, dir: Vec3) -> f32 {
        let mut pdf = self.env_lights.iter().map(|&l| self.select_pmf(l)).sum::<f32>() * UNIFORM_SPHERE_PDF;
        for (l, map) in &self.env_maps {
            pdf += self.select_pmf(*l) * map.pdf(dir);
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
                let (p, n, area) = match self.area[l].as_ref()? {
                    AreaGeometry::Triangles { tris, normals, cdf, area } => {
                        let (ti, ux) = if tris.len() == 1 {
                            (0, u_pos.x)
                        } else {
                            let (ti, _, ux) = cdf.sample(u_pos.x);
                            (ti, ux)
                        };
                        let b = square_to_uniform_triangle(Vec2::new(ux, u_pos.y));
                        let [a, b1, c] = tris[ti];
                        (a * (1.0 - b.x - b.y) + b1 * b.x + c * b.y, normals[ti], *area)
                    }
                    AreaGeometry::Sphere { center, radius, flip } => {
                        let n = square_to_uniform_sphere(u_pos);
                        (*center + n * *radius, if *flip { -n } else { n }, 4.0 * PI * radius * radius)
                    }
                };
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
                let (_, map) = self.env_maps.get(*self.env_map_of.get(l)? as usize)?;
                // `wi` points towards the map; the photon travels the other way.
                let (wi, radiance, pdf) = map.sample(u_dir)?;
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
fn disk_origin(center: Vec3, radius: f32, dir: Vec3, u: Vec2) -> Vec3 {
    let f = Frame::from_normal(dir);
    let d = square_to_uniform_disk_concentric(u) * radius;
    center + f.s * d.x + f.t * d.y - dir * radius
}

/// Mitsuba's spot falloff: 1 inside the beam, linear in angle down to 0 at the cutoff.
#[inline]
fn spot_falloff(cos_theta: f32, cos_cutoff: f32, cos_falloff_start: f32) -> f32 {
    if cos_theta <= cos_cutoff {
        0.0
    } else if cos_theta >= cos_falloff_start {
        1.0
    } else {
        let c = cos_cutoff.clamp(-1.0, 1.0).acos();
        let b = cos_falloff_start.clamp(-1.0, 1.0).acos();
        if c > b {
            ((c - cos_theta.clamp(-1.0, 1.0).acos()) / (c - b)).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

/// Emitted power of a light (see the module documentation); `scene_radius` is the radius of
/// the scene bounding sphere.
fn light_power(l: &Light, geom: Option<&AreaGeometry>, map: Option<&Environment>, scene_radius: f32) -> Color {
    match l {
        Light::Area { radiance, .. } => {
            let area = match geom {
                Some(AreaGeometry::Triangles { area, .. }) => *area,
                Some(AreaGeometry::Sphere { radius, .. }) => 4.0 * PI * radius * radius,
                None => 0.0,
            };
            *radiance * (PI * area)
        }
        Light::Point { intensity, .. } => *intensity * (4.0 * PI),
        Light::Spot { intensity, cos_cutoff, cos_falloff_start, .. } => {
            let c = (cos_cutoff.clamp(-1.0, 1.0) as f64).acos();
            let b = (cos_falloff_start.clamp(-1.0, 1.0) as f64).acos().min(c);
            let f = if c - b > 1e-6 { 1.0 - (c.sin() - b.sin()) / (c - b) } else { 1.0 - c.cos() };
            *intensity * (2.0 * std::f64::consts::PI * f) as f32
        }
        Light::Directional { irradiance, .. } => *irradiance * (PI * scene_radius * scene_radius),
        Light::Constant { radiance } => *radiance * (4.0 * PI * PI * scene_radius * scene_radius),
        Light::Envmap { .. } | Light::Sunsky(_) => map.map_or(Color::ZERO, |m| m.integral() * (PI * scene_radius * scene_radius)),
    }
}

impl AreaGeometry {
    /// Prepare a shape for sampling by area; `None` when it has no area.
    pub fn new(shape: &ShapeDesc) -> Option<AreaGeometry> {
        match &shape.geometry {
            Geometry::Sphere { center, radius } => {
                if radius.is_finite() && *radius > 0.0 && center.is_finite() {
                    Some(AreaGeometry::Sphere { center: *center, radius: *radius, flip: shape.flip_normals })
                } else {
                    None
                }
            }
            Geometry::Mesh(m) => {
                let mut tris = Vec::with_capacity(m.indices.len());
                let mut normals = Vec::with_capacity(m.indices.len());
                let mut areas = Vec::with_capacity(m.indices.len());
                for t in &m.indices {
                    let (Some(&a), Some(&b), Some(&c)) =
                        (m.positions.get(t[0] as usize), m.positions.get(t[1] as usize), m.positions.get(t[2] as usize))
                    else {
                        continue;
                    };
                    let cr = (b - a).cross(c - a);
                    let len = cr.length();
                    if not_positive(len) || !len.is_finite() {
                        continue;
                    }
                    let n = cr / len;
                    tris.push([a, b, c]);
                    normals.push(if shape.flip_normals { -n } else { n });
                    areas.push(0.5 * len);
                }
                let cdf = Distribution1D::new(&areas)?;
                let area = cdf.total() as f32;
                Some(AreaGeometry::Triangles { tris, normals, cdf, area })
            }
        }
    }
}

impl Light {
    pub fn validate(&self) -> Result<(), String> {
        let color = |c: Color, what: &str| -> Result<(), String> {
            if c.is_finite() && c.min_element() >= 0.0 {
                Ok(())
            } else {
                Err(format!("{what} {c} must be finite and non-negative"))
            }
        };
        let point = |p: Vec3| -> Result<(), String> {
            if p.is_finite() {
                Ok(())
            } else {
                Err(format!("position {p} is not finite"))
            }
        };
        let unit = |d: Vec3, what: &str| -> Result<(), String> {
            if d.is_finite() && (d.length() - 1.0).abs() < 1e-3 {
                Ok(())
            } else {
                Err(format!("{what} {d} must be a unit vector"))
            }
        };
        match self {
            Light::Area { radiance, .. } => color(*radiance, "radiance"),
            Light::Point { position, intensity } => {
                point(*position)?;
                color(*intensity, "intensity")
            }
            Light::Spot { position, frame, intensity, cos_cutoff, cos_falloff_start } => {
                point(*position)?;
                unit(frame.n, "spot direction")?;
                unit(frame.s, "spot frame tangent")?;
                unit(frame.t, "spot frame bitangent")?;
                color(*intensity, "intensity")?;
                if !(cos_cutoff.is_finite() && (-1.0..1.0).contains(cos_cutoff)) {
                    return Err(format!("cosine of the cutoff angle {cos_cutoff} must lie in [-1, 1)"));
                }
                if !(cos_falloff_start.is_finite() && *cos_falloff_start >= *cos_cutoff && *cos_falloff_start <= 1.0) {
                    return Err(format!("cosine of the beam width {cos_falloff_start} must lie in [cos cutoff = {cos_cutoff}, 1]"));
                }
                Ok(())
            }
            Light::Directional { direction, irradiance } => {
                unit(*direction, "direction")?;
                color(*irradiance, "irradiance")
            }
            Light::Constant { radiance } => color(*radiance, "radiance"),
            Light::Envmap { scale, to_world, .. } => crate::envmap::check_frame(*scale, to_world),
            Light::Sunsky(desc) => desc.validate(),
        }
    }
}

/// False for NaN, zero and negative values.
#[inline]
fn not_positive(x: f32) -> bool {
    x.is_nan() || x <= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{square_to_cosine_hemisphere_pdf, Sampler};
    use crate::scene::TriMesh;
    use crate::testing::{chi2_2d, chi2_sphere, direction_to_zphi, zphi_to_direction, Chi2Config};

    /// Number of chi-square tests in this module (Šidák family size).
    const CHI2_TESTS: usize = 5;

    fn shape(geometry: Geometry, emission: Option<Color>, flip_normals: bool) -> ShapeDesc {
        ShapeDesc { name: "s".into(), geometry, material: 0, emission, flip_normals }
    }

    /// The rectangle [0,2]×[0,1] at height z, split into three triangles of areas 1, 1/4, 3/4
    /// whose winding normal is +z.
    fn split_rectangle(z: f32) -> TriMesh {
        TriMesh {
            positions: vec![
                Vec3::new(0.0, 0.0, z),
                Vec3::new(2.0, 0.0, z),
                Vec3::new(2.0, 1.0, z),
                Vec3::new(0.0, 1.0, z),
                Vec3::new(1.5, 1.0, z),
            ],
            indices: vec![[0, 1, 4], [1, 2, 4], [0, 4, 3]],
            ..Default::default()
        }
    }

    fn bounds_of(a: Vec3, b: Vec3) -> Bounds3 {
        let mut bb = Bounds3::EMPTY;
        bb.extend(a);
        bb.extend(b);
        bb
    }

    fn cfg() -> Chi2Config {
        Chi2Config { samples: 200_000, tests: CHI2_TESTS, bins_x: 32, bins_y: 32, ..Default::default() }
    }

    #[test]
    fn mesh_light_sampling_matches_pdf() {
        // flipped: the light at z = 1 faces down, towards the shading point at z = 0; a point
        // light takes part of the selection probability.
        let radiance = Color::new(2.0, 3.0, 4.0);
        let shapes = [shape(Geometry::Mesh(split_rectangle(1.0)), Some(radiance), true)];
        let point = Light::Point { position: Vec3::new(0.0, 0.0, 3.0), intensity: Color::splat(1.0) };
        let set = LightSet::new(&[point], &shapes, bounds_of(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0)));
        assert_eq!(set.lights.len(), 2);
        let l = set.shape_light(0).unwrap();
        assert_eq!(l, 1);
        let psel = set.select_pmf(l);
        let area_power = std::f32::consts::PI * 2.0 * 3.0; // mean radiance 3, area 2
        let point_power = 4.0 * std::f32::consts::PI;
        assert!((psel - area_power / (area_power + point_power)).abs() < 1e-5, "selection by power: {psel}");
        let p = Vec3::new(0.3, 0.8, 0.0);
        let ng = -Vec3::Z;
        let mut bad = None;
        let r = chi2_2d(
            &cfg(),
            Vec2::ZERO,
            Vec2::new(2.0, 1.0),
            |s| {
                let (us, u) = (s.next_1d(), s.next_2d());
                let ls = set.sample_li(p, us, u)?;
                if ls.delta {
                    return None;
                }
                let q = p + ls.wi * ls.dist;
                let pdf = set.pdf_li_area(l, p, q, ng);
                if (pdf - ls.pdf).abs() > 1e-3 * pdf || (q.z - 1.0).abs() > 1e-4 || ls.li != radiance {
                    bad = Some(format!("sample pdf {} vs pdf_li_area {pdf}, q {q}, li {}", ls.pdf, ls.li));
                }
                Some(Vec2::new(q.x, q.y))
            },
            |xy| {
                // density w.r.t. area on the plane: solid-angle pdf × cos / dist²
                let q = Vec3::new(xy.x, xy.y, 1.0);
                let d = q - p;
                let cos = d.z / d.length();
                (set.pdf_li_area(l, p, q, ng) * cos / d.length_squared()) as f64
            },
        );
        assert!(bad.is_none(), "{bad:?}");
        assert!(r.passed, "{r:?}");
        assert!((r.pdf_integral - psel as f64).abs() < 1e-3, "{} vs {psel}", r.pdf_integral);
        // behind the light: nothing (the light's back faces the point)
        let behind = Vec3::new(1.0, 0.5, 2.0);
        let mut s = Sampler::new(1, 2, 3);
        for _ in 0..1000 {
            if let Some(ls) = set.sample_li(behind, s.next_1d(), s.next_2d()) {
                assert!(ls.delta, "only the point light is visible from behind");
            }
        }
        assert_eq!(set.pdf_li_area(l, behind, Vec3::new(1.0, 0.5, 1.0), ng), 0.0);
        assert_eq!(set.area_le(l, ng, Vec3::Z), Color::ZERO);
        assert_eq!(set.area_le(l, ng, -Vec3::Z), radiance);
        assert_eq!(set.area_le(0, ng, -Vec3::Z), Color::ZERO, "light 0 is the point light");
    }

    /// Nearest intersection of a ray with a sphere (`None` when missed).
    fn hit_sphere(o: Vec3, d: Vec3, c: Vec3, r: f32) -> Option<Vec3> {
        let oc = (o - c).as_dvec3();
        let d64 = d.as_dvec3();
        let b = oc.dot(d64);
        let cc = oc.length_squared() - (r as f64) * (r as f64);
        let disc = b * b - cc;
        if disc < 0.0 {
            return None;
        }
        let t = if -b - disc.sqrt() > 0.0 { -b - disc.sqrt() } else { -b + disc.sqrt() };
        (t > 0.0).then(|| (oc + d64 * t).as_vec3() + c)
    }

    #[test]
    fn sphere_light_sampling_matches_pdf_outside_and_inside() {
        let (c, r) = (Vec3::new(0.5, -0.2, 2.0), 0.7);
        let radiance = Color::splat(1.5);
        // outside: uniform in the subtended cone
        let set = LightSet::new(&[], &[shape(Geometry::Sphere { center: c, radius: r }, Some(radiance), false)], bounds_of(c - r, c + r));
        let p = Vec3::new(0.1, 0.3, -0.5);
        let axis = (c - p).normalize();
        let frame = Frame::from_normal(axis);
        let cos_max = (1.0 - r * r / (c - p).length_squared()).sqrt();
        let mut bad = None;
        let out = chi2_2d(
            &cfg(),
            Vec2::new(cos_max, 0.0),
            Vec2::new(1.0, std::f32::consts::TAU),
            |s| {
                let ls = set.sample_li(p, s.next_1d(), s.next_2d())?;
                let q = p + ls.wi * ls.dist;
                let n = (q - c) / r;
                if ((q - c).length() - r).abs() > 1e-4 || n.dot(ls.wi) >= 0.0 {
                    bad = Some(format!("sampled point {q} is not on the near side of the sphere"));
                }
                if (set.pdf_li_area(0, p, q, n) - ls.pdf).abs() > 1e-3 * ls.pdf {
                    bad = Some(format!("pdf {} vs {}", ls.pdf, set.pdf_li_area(0, p, q, n)));
                }
                Some(direction_to_zphi(frame.to_local(ls.wi)))
            },
            |zp| {
                let d = frame.to_world(zphi_to_direction(zp));
                hit_sphere(p, d, c, r).map_or(0.0, |q| set.pdf_li_area(0, p, q, (q - c) / r) as f64)
            },
        );
        assert!(bad.is_none(), "{bad:?}");
        assert!(out.passed, "{out:?}");
        assert!((out.pdf_integral - 1.0).abs() < 1e-3);

        // inside a flipped sphere (emitting inwards): by area over the whole sphere
        let set = LightSet::new(&[], &[shape(Geometry::Sphere { center: c, radius: r }, Some(radiance), true)], bounds_of(c - r, c + r));
        let p = c + Vec3::new(0.2, -0.3, 0.25);
        let inside = chi2_2d(
            &cfg(),
            Vec2::new(-1.0, 0.0),
            Vec2::new(1.0, std::f32::consts::TAU),
            |s| {
                let ls = set.sample_li(p, s.next_1d(), s.next_2d())?;
                let q = p + ls.wi * ls.dist;
                Some(direction_to_zphi((q - c).normalize()))
            },
            |zp| {
                // density w.r.t. (cos θ, φ) of the point on the sphere: pdf_ω cos / d² · r²
                let n = zphi_to_direction(zp);
                let q = c + n * r;
                let d = q - p;
                let cos = (-n).dot(-d.normalize());
                (set.pdf_li_area(0, p, q, -n) * cos / d.length_squared() * r * r) as f64
            },
        );
        assert!(inside.passed, "{inside:?}");
        assert!((inside.pdf_integral - 1.0).abs() < 1e-3);

        // inside a sphere that emits outwards: its inner side is its back, nothing arrives
        let set = LightSet::new(&[], &[shape(Geometry::Sphere { center: c, radius: r }, Some(radiance), false)], bounds_of(c - r, c + r));
        let mut s = Sampler::new(4, 0, 0);
        assert!((0..1000).all(|_| set.sample_li(p, s.next_1d(), s.next_2d()).is_none()));
    }

    #[test]
    fn area_emission_is_cosine_weighted_and_carries_the_total_power() {
        let radiance = Color::new(1.0, 2.0, 0.5);
        let c = Vec3::new(0.0, 1.0, 0.0);
        let set =
            LightSet::new(&[], &[shape(Geometry::Sphere { center: c, radius: 0.5 }, Some(radiance), false)], bounds_of(c - 0.5, c + 0.5));
        let want = radiance * std::f32::consts::PI * 4.0 * std::f32::consts::PI * 0.25;
        assert!((set.total_power() - want).abs().max_element() < 1e-4 * want.max_element());
        let r = chi2_sphere(
            &cfg(),
            |s| {
                let e = set.sample_emission(s.next_1d(), s.next_2d(), s.next_2d())?;
                assert!(((e.p - c).length() - 0.5).abs() < 1e-4 && (e.n - (e.p - c) / 0.5).length() < 1e-4);
                assert!((e.power - want).abs().max_element() < 1e-3 * want.max_element());
                Some(Frame::from_normal(e.n).to_local(e.dir))
            },
            |d| square_to_cosine_hemisphere_pdf(d) as f64,
        );
        assert!(r.passed, "{r:?}");
        // a flipped triangle mesh emits downwards
        let set =
            LightSet::new(&[], &[shape(Geometry::Mesh(split_rectangle(1.0)), Some(radiance), true)], bounds_of(Vec3::ZERO, Vec3::ONE));
        let mut s = Sampler::new(9, 0, 0);
        for _ in 0..1000 {
            let e = set.sample_emission(s.next_1d(), s.next_2d(), s.next_2d()).unwrap();
            assert!(e.dir.z < 0.0 && e.n == -Vec3::Z && (e.p.z - 1.0).abs() < 1e-6);
            assert!((e.power - radiance * std::f32::consts::PI * 2.0).abs().max_element() < 1e-4);
        }
    }

    #[test]
    fn mean_emitted_power_equals_total_power() {
        let spot_frame = Frame::from_normal(Vec3::new(0.0, -1.0, 0.0));
        let lights = vec![
            Light::Point { position: Vec3::new(0.0, 2.0, 0.0), intensity: Color::new(1.0, 0.5, 0.2) },
            Light::Spot {
                position: Vec3::new(1.0, 2.0, 0.0),
                frame: spot_frame,
                intensity: Color::splat(5.0),
                cos_cutoff: 30f32.to_radians().cos(),
                cos_falloff_start: 20f32.to_radians().cos(),
            },
            Light::Directional { direction: Vec3::new(0.0, -1.0, 0.0), irradiance: Color::splat(0.3) },
            Light::Constant { radiance: Color::new(0.1, 0.2, 0.3) },
        ];
        let shapes = [
            shape(Geometry::Mesh(split_rectangle(1.5)), Some(Color::splat(2.0)), false),
            shape(Geometry::Sphere { center: Vec3::new(-1.0, 0.5, 0.0), radius: 0.25 }, Some(Color::new(3.0, 1.0, 1.0)), false),
            shape(Geometry::Mesh(split_rectangle(0.0)), None, false),
        ];
        let bounds = bounds_of(Vec3::new(-2.0, -1.0, -1.0), Vec3::new(2.0, 2.0, 2.0));
        let set = LightSet::new(&lights, &shapes, bounds);
        assert_eq!(set.lights.len(), 6);
        assert_eq!(set.shape_light(2), None);
        assert_eq!(set.shape_light(1), Some(5));
        let (centre, radius) = set.scene_sphere();
        let n = 400_000;
        let mut s = Sampler::new(21, 0, 0);
        let mut acc = glam::DVec3::ZERO;
        let mut per_light = [0usize; 6];
        for _ in 0..n {
            let e = set.sample_emission(s.next_1d(), s.next_2d(), s.next_2d()).unwrap();
            assert!((e.dir.length() - 1.0).abs() < 1e-4 && e.power.is_finite() && e.power.min_element() >= 0.0);
            per_light[e.light as usize] += 1;
            match &set.lights[e.light as usize] {
                Light::Spot { frame, cos_cutoff, .. } => assert!(frame.n.dot(e.dir) >= cos_cutoff - 1e-5),
                Light::Directional { direction, .. } => assert!((e.dir - *direction).length() < 1e-6),
                _ => {}
            }
            if matches!(set.lights[e.light as usize], Light::Directional { .. } | Light::Constant { .. }) {
                // starts outside the bounding sphere, aimed through it
                let oc = e.p - centre;
                assert!(oc.length() >= radius * 0.999);
                let closest = oc - e.dir * oc.dot(e.dir);
                assert!(closest.length() <= radius * 1.0001 && oc.dot(e.dir) < 0.0);
            }
            acc += e.power.as_dvec3();
        }
        let mean = (acc / n as f64).as_vec3();
        let total = set.total_power();
        assert!((mean - total).abs().max_element() < 0.01 * total.max_element(), "mean {mean} vs total {total}");
        for (l, &count) in per_light.iter().enumerate() {
            let expect = set.select_pmf(l as u32) as f64 * n as f64;
            assert!((count as f64 - expect).abs() < 5.0 * expect.sqrt() + 1.0, "light {l}: {count} vs {expect}");
        }
        // each light's power by its formula
        let pi = std::f32::consts::PI;
        let checks = [
            (0u32, Color::new(1.0, 0.5, 0.2) * 4.0 * pi),
            (2, Color::splat(0.3) * pi * radius * radius),
            (3, Color::new(0.1, 0.2, 0.3) * 4.0 * pi * pi * radius * radius),
            (4, Color::splat(2.0) * pi * 2.0),
            (5, Color::new(3.0, 1.0, 1.0) * pi * 4.0 * pi * 0.0625),
        ];
        for (l, want) in checks {
            assert!(
                (set.light_power(l) - want).abs().max_element() < 1e-4 * want.max_element(),
                "light {l}: {} vs {want}",
                set.light_power(l)
            );
        }
    }

    #[test]
    fn spot_power_integrates_the_falloff() {
        for &(cutoff, beam) in &[(30.0f32, 20.0f32), (20.0, 15.0), (60.0, 60.0), (90.0, 10.0)] {
            let (cc, cb) = (cutoff.to_radians().cos(), beam.to_radians().cos());
            let l = Light::Spot {
                position: Vec3::ZERO,
                frame: Frame::from_normal(Vec3::Z),
                intensity: Color::ONE,
                cos_cutoff: cc,
                cos_falloff_start: cb,
            };
            assert!(l.validate().is_ok());
            // midpoint rule in θ of 2π ∫ I(θ) sin θ dθ
            let n = 200_000;
            let dt = std::f64::consts::PI / n as f64;
            let numeric: f64 = (0..n)
                .map(|i| {
                    let t = (i as f64 + 0.5) * dt;
                    spot_falloff(t.cos() as f32, cc, cb) as f64 * t.sin() * dt
                })
                .sum::<f64>()
                * std::f64::consts::TAU;
            let p = light_power(&l, None, None, 1.0).x as f64;
            assert!((p - numeric).abs() < 1e-4 * numeric, "cutoff {cutoff} beam {beam}: {p} vs {numeric}");
            // for narrow transitions the approximation 2π(1 - (cos c + cos b)/2) is close
            let approx = std::f64::consts::TAU * (1.0 - (cc + cb) as f64 / 2.0);
            assert!(cutoff - beam > 10.0 || (p - approx).abs() < 0.03 * p, "{p} vs {approx}");
        }
        // falloff: full inside the beam, linear in angle, zero beyond the cutoff
        let (cc, cb) = (30f32.to_radians().cos(), 20f32.to_radians().cos());
        assert_eq!(spot_falloff(1.0, cc, cb), 1.0);
        assert!((spot_falloff(25f32.to_radians().cos(), cc, cb) - 0.5).abs() < 1e-4);
        assert_eq!(spot_falloff(31f32.to_radians().cos(), cc, cb), 0.0);
    }

    #[test]
    fn delta_and_environment_lights() {
        let p = Vec3::new(0.0, 0.0, 0.0);
        let set = LightSet::new(&[Light::Point { position: Vec3::new(0.0, 3.0, 4.0), intensity: Color::splat(10.0) }], &[], Bounds3::EMPTY);
        // a single light ignores the selection number
        let a = set.sample_li(p, 0.1, Vec2::new(0.3, 0.3)).unwrap();
        let b = set.sample_li(p, 0.95, Vec2::new(0.7, 0.1)).unwrap();
        assert!(a.delta && a.pdf == 1.0 && (a.dist - 5.0).abs() < 1e-6 && (a.li - Color::splat(10.0 / 25.0)).abs().max_element() < 1e-6);
        assert_eq!((a.wi, a.li), (b.wi, b.li));
        assert!((a.wi - Vec3::new(0.0, 0.6, 0.8)).length() < 1e-6);

        let frame = Frame::from_normal(Vec3::new(0.0, 0.0, -1.0));
        let spot = Light::Spot {
            position: Vec3::new(0.0, 0.0, 2.0),
            frame,
            intensity: Color::splat(4.0),
            cos_cutoff: 0.9,
            cos_falloff_start: 0.95,
        };
        let set = LightSet::new(&[spot], &[], Bounds3::EMPTY);
        let ls = set.sample_li(p, 0.5, Vec2::ZERO).unwrap();
        assert!((ls.li - Color::splat(1.0)).abs().max_element() < 1e-6, "on axis: I / d²");
        assert!(set.sample_li(Vec3::new(5.0, 0.0, 0.0), 0.5, Vec2::ZERO).is_none(), "outside the cone");

        let dir = Vec3::new(1.0, -1.0, 0.0).normalize();
        let env = Color::new(0.5, 0.25, 1.0);
        let lights = [Light::Directional { direction: dir, irradiance: Color::splat(2.0) }, Light::Constant { radiance: env }];
        let set = LightSet::new(&lights, &[], bounds_of(Vec3::splat(-1.0), Vec3::splat(1.0)));
        assert_eq!(set.env_le(Vec3::X), env);
        let p_env = set.select_pmf(1);
        assert!((set.pdf_li_env(Vec3::Y) - p_env / (4.0 * std::f32::consts::PI)).abs() < 1e-7);
        let mut s = Sampler::new(2, 0, 0);
        let (mut n_env, n) = (0usize, 20_000);
        for _ in 0..n {
            let ls = set.sample_li(p, s.next_1d(), s.next_2d()).unwrap();
            assert!(ls.dist.is_infinite());
            if ls.delta {
                assert!((ls.wi + dir).length() < 1e-6 && ls.li == Color::splat(2.0) && (ls.pdf - set.select_pmf(0)).abs() < 1e-7);
            } else {
                n_env += 1;
                assert_eq!(ls.li, env);
                assert!((ls.pdf - set.pdf_li_env(ls.wi)).abs() < 1e-7);
            }
        }
        let expect = p_env as f64 * n as f64;
        assert!((n_env as f64 - expect).abs() < 5.0 * expect.sqrt());
        // an empty set samples nothing
        let empty = LightSet::new(&[], &[], Bounds3::EMPTY);
        assert!(
            empty.is_empty()
                && empty.sample_li(p, 0.5, Vec2::ZERO).is_none()
                && empty.sample_emission(0.5, Vec2::ZERO, Vec2::ZERO).is_none()
        );
        assert_eq!(empty.total_power(), Color::ZERO);
    }

    #[test]
    fn validation_rejects_bad_lights() {
        let f = Frame::from_normal(Vec3::Z);
        assert!(Light::Point { position: Vec3::ZERO, intensity: Color::ONE }.validate().is_ok());
        assert!(Light::Point { position: Vec3::splat(f32::NAN), intensity: Color::ONE }.validate().is_err());
        assert!(Light::Point { position: Vec3::ZERO, intensity: -Color::ONE }.validate().is_err());
        let spot =
            |cc: f32, cb: f32| Light::Spot { position: Vec3::ZERO, frame: f, intensity: Color::ONE, cos_cutoff: cc, cos_falloff_start: cb };
        assert!(spot(0.8, 0.9).validate().is_ok());
        assert!(spot(0.9, 0.8).validate().is_err(), "beam wider than the cutoff");
        assert!(spot(1.0, 1.0).validate().is_err(), "zero cutoff angle");
        assert!(spot(-1.5, 0.5).validate().is_err());
        assert!(Light::Directional { direction: Vec3::new(0.0, 0.0, 2.0), irradiance: Color::ONE }.validate().is_err());
        assert!(Light::Constant { radiance: Color::new(0.0, f32::INFINITY, 0.0) }.validate().is_err());
        assert!(Light::Area { shape: 0, radiance: Color::ONE }.validate().is_ok());
    }
}
