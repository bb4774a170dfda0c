//! Scene description: plain data produced by loaders (built-in scenes, Mitsuba XML, OBJ, PLY)
//! and consumed by [`crate::scene::Scene::prepare`]. Nothing here depends on the prepared
//! scene: the description types (shapes, meshes, film, the light enum) sit upstream of it.
//!
//! Invariants a loader must establish (checked again by `validate`):
//! - geometry is in world space (loaders apply `to_world`);
//! - every `material` index is `< materials.len()`, every bitmap index `< images.len()`;
//! - all numbers are finite; triangle indices are in range.
//!
//! Units are the scene's own (metres for Mitsuba scenes, millimetres for the built-in Cornell
//! box, whose published geometry is in mm); radiance is in W/(m² sr) per RGB channel.

use super::camera::CameraDesc;
use super::material::Material;
use super::sunsky::SunSkyDesc;
use crate::image::Image;
use crate::math::{Bounds3, Color, Frame};
use glam::{Mat3, Mat4, Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// An indexed triangle mesh in world space.
#[derive(Clone, Debug, Default)]
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (same length as `positions`) or none (flat shading).
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates (same length as `positions`) or none.
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Apply a world transform (points, and normals by the inverse transpose).
    pub fn transform(&mut self, m: &Mat4) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        if let Some(ns) = &mut self.normals {
            let nm = m.inverse().transpose();
            for n in ns.iter_mut() {
                *n = nm.transform_vector3(*n).normalize_or_zero();
            }
        }
    }

    /// Remove triangles of zero area or with non-finite vertices; returns how many were removed.
    pub fn remove_degenerate(&mut self) -> usize {
        let before = self.indices.len();
        let pos = &self.positions;
        self.indices.retain(|t| {
            let (a, b, c) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
            let area2 = (b - a).cross(c - a).length();
            area2.is_finite() && area2 > 0.0
        });
        before - self.indices.len()
    }

    pub fn bounds(&self) -> Bounds3 {
        let mut b = Bounds3::EMPTY;
        for t in &self.indices {
            for &i in t {
                b.extend(self.positions[i as usize]);
            }
        }
        b
    }

    /// Total surface area.
    pub fn area(&self) -> f64 {
        self.indices
            .iter()
            .map(|t| {
                let (a, b, c) = (self.positions[t[0] as usize], self.positions[t[1] as usize], self.positions[t[2] as usize]);
                0.5 * (b - a).cross(c - a).length() as f64
            })
            .sum()
    }

    /// Mitsuba's `rectangle`: the square \[-1,1\]² in the z = 0 plane, normal +z, uv in \[0,1\]².
    pub fn rectangle(to_world: &Mat4) -> TriMesh {
        let mut m = TriMesh {
            positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)],
            normals: Some(vec![Vec3::Z; 4]),
            uvs: Some(vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]),
            indices: vec![[0, 1, 2], [2, 3, 0]],
        };
        m.transform(to_world);
        m
    }

    /// Mitsuba's `cube`: the cube [-1,1]³ with outward normals, 24 vertices, 12 triangles.
    pub fn cube(to_world: &Mat4) -> TriMesh {
        let mut m = TriMesh { normals: Some(Vec::new()), uvs: Some(Vec::new()), ..Default::default() };
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let mut n = Vec3::ZERO;
                n[axis] = sign;
                // two tangent axes so that (t1 x t2) = n
                let mut t1 = Vec3::ZERO;
                t1[(axis + 1) % 3] = 1.0;
                let mut t2 = Vec3::ZERO;
                t2[(axis + 2) % 3] = sign;
                let base = m.positions.len() as u32;
                for (du, dv) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    m.positions.push(n + t1 * du + t2 * dv);
                    m.normals.as_mut().unwrap().push(n);
                    m.uvs.as_mut().unwrap().push(Vec2::new((du + 1.0) * 0.5, (dv + 1.0) * 0.5));
                }
                m.indices.push([base, base + 1, base + 2]);
                m.indices.push([base + 2, base + 3, base]);
            }
        }
        m.transform(to_world);
        m
    }

    /// Mitsuba's `disk`: the unit disk in the z = 0 plane, normal +z, as a triangle fan of
    /// `segments` triangles (the area error is below 0.1% for 128 segments).
    pub fn disk(to_world: &Mat4, segments: u32) -> TriMesh {
        let segments = segments.max(3);
        let mut m = TriMesh {
            normals: Some(vec![Vec3::Z]),
            uvs: Some(vec![Vec2::new(0.5, 0.5)]),
            positions: vec![Vec3::ZERO],
            indices: Vec::new(),
        };
        for i in 0..segments {
            let phi = i as f32 / segments as f32 * std::f32::consts::TAU;
            let (s, c) = phi.sin_cos();
            m.positions.push(Vec3::new(c, s, 0.0));
            m.normals.as_mut().unwrap().push(Vec3::Z);
            m.uvs.as_mut().unwrap().push(Vec2::new(0.5 + 0.5 * c, 0.5 + 0.5 * s));
            m.indices.push([0, 1 + i, 1 + (i + 1) % segments]);
        }
        m.transform(to_world);
        m
    }
}

/// The geometry of a shape.
#[derive(Clone, Debug)]
pub enum Geometry {
    Mesh(TriMesh),
    /// An analytic sphere (intersected exactly, not tessellated).
    Sphere {
        center: Vec3,
        radius: f32,
    },
}

/// One shape: geometry, the material it uses and optionally an area emitter on it.
#[derive(Clone, Debug)]
pub struct ShapeDesc {
    /// Name for messages (Mitsuba `id`, file name, ...).
    pub name: String,
    pub geometry: Geometry,
    /// Index into [`SceneDesc::materials`].
    pub material: u32,
    /// Radiance of an area emitter on this shape (emits on the front side only, like Mitsuba).
    pub emission: Option<Color>,
    /// Flip the geometric and shading normals (Mitsuba's `flip_normals`).
    pub flip_normals: bool,
}

/// A light source as described by a scene (area lights may also be given as
/// [`ShapeDesc::emission`]; [`crate::scene::lights::LightSet`] prepares them for sampling).
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
    /// Constant environment of radiance `radiance` (W/(m² sr)) from every direction.
    Constant { radiance: Color },
    /// Latitude-longitude environment map (Mitsuba `envmap`, see [`super::envmap`]): image
    /// `image` (index into [`SceneDesc::images`], linear RGB radiance in W/(m² sr)) times
    /// `scale`, oriented by the orthogonal `to_world` (local `+y` is up).
    Envmap { image: u32, scale: f32, to_world: Mat3 },
    /// Sun and sky (Mitsuba 3 `sunsky`, see [`super::sunsky`]).
    Sunsky(SunSkyDesc),
}

impl Light {
    /// Check the parameters: finite, non-negative colours, unit directions, a spot's cone.
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
            Light::Envmap { scale, to_world, .. } => super::envmap::check_frame(*scale, to_world),
            Light::Sunsky(desc) => desc.validate(),
        }
    }
}

/// Reconstruction filter of the film (Mitsuba's `rfilter`); realised by filter importance
/// sampling of the pixel sample positions.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case", tag = "type")]
pub enum PixelFilter {
    /// Box filter of the pixel's own footprint.
    Box,
    /// Tent of the given radius in pixels (Mitsuba default radius 1).
    #[default]
    Tent,
    /// Gaussian of standard deviation `stddev` pixels, truncated at 4 stddev (Mitsuba: 0.5).
    Gaussian { stddev: f32 },
}

impl PixelFilter {
    /// Smallest accepted Gaussian standard deviation (pixels): below it the filter's weights
    /// underflow to NaN in f32.
    pub const MIN_STDDEV: f32 = 1e-3;
    /// Largest accepted Gaussian standard deviation (pixels): a filter 4·64 pixels wide is far
    /// past any use (the renderer cuts splats at a margin of 8 pixels anyway).
    pub const MAX_STDDEV: f32 = 64.0;

    /// Check the filter's parameters: a Gaussian's `stddev` must lie in
    /// [[`Self::MIN_STDDEV`], [`Self::MAX_STDDEV`]] (zero, negative or NaN would make the
    /// renderer's filter sampling loop forever).
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            PixelFilter::Box | PixelFilter::Tent => Ok(()),
            PixelFilter::Gaussian { stddev } => {
                if (Self::MIN_STDDEV..=Self::MAX_STDDEV).contains(&stddev) {
                    Ok(())
                } else {
                    Err(format!("Gaussian filter stddev {stddev} pixels is out of range [{}, {}]", Self::MIN_STDDEV, Self::MAX_STDDEV))
                }
            }
        }
    }
}

/// Film description.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FilmDesc {
    pub width: u32,
    pub height: u32,
    pub filter: PixelFilter,
    /// Mitsuba 3's `sample_border` (0.6's `highQualityEdges`): pixels outside the film, as far
    /// as the filter reaches, are sampled too and splat into the edge pixels, which then get
    /// as many samples as any other (`crate::render`).
    #[serde(default)]
    pub sample_border: bool,
}

impl Default for FilmDesc {
    fn default() -> Self {
        FilmDesc { width: 512, height: 512, filter: PixelFilter::Tent, sample_border: false }
    }
}

/// Settings a scene file may suggest (Mitsuba `integrator` / `sampler`); the CLI overrides them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneHints {
    pub spp: Option<u32>,
    /// Mitsuba's `max_depth` (-1 = unbounded).
    pub max_depth: Option<i32>,
    pub integrator: Option<String>,
}

/// A complete scene description.
#[derive(Clone, Debug, Default)]
pub struct SceneDesc {
    pub shapes: Vec<ShapeDesc>,
    pub materials: Vec<Material>,
    /// Bitmaps referenced by textured materials (linear RGB).
    pub images: Vec<Image>,
    /// Lights other than area lights (area lights are `ShapeDesc::emission`).
    pub lights: Vec<Light>,
    pub camera: CameraDesc,
    pub film: FilmDesc,
    pub hints: SceneHints,
}

/// Problems found when validating a scene description.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SceneError {
    #[error("shape '{shape}' uses material {material} but the scene has {count} materials")]
    BadMaterial { shape: String, material: u32, count: usize },
    #[error("shape '{shape}': {problem}")]
    BadShape { shape: String, problem: String },
    #[error("light {index}: {problem}")]
    BadLight { index: usize, problem: String },
    #[error("camera: {0}")]
    BadCamera(String),
    #[error("film: {0}")]
    BadFilm(String),
    #[error("the scene has no geometry")]
    Empty,
    #[error("ray-intersection backend: {0}")]
    Accel(String),
}

impl SceneDesc {
    /// Check the invariants listed in the module documentation.
    pub fn validate(&self) -> Result<(), SceneError> {
        if self.film.width == 0 || self.film.height == 0 || self.film.width > 1 << 15 || self.film.height > 1 << 15 {
            return Err(SceneError::BadFilm(format!("resolution {}x{} is out of range 1..32768", self.film.width, self.film.height)));
        }
        self.film.filter.validate().map_err(SceneError::BadFilm)?;
        self.camera.validate().map_err(SceneError::BadCamera)?;
        for s in &self.shapes {
            Self::validate_shape(s, self.materials.len())?;
        }
        for (i, m) in self.materials.iter().enumerate() {
            m.validate(self.images.len()).map_err(|p| SceneError::BadShape { shape: format!("material {i}"), problem: p })?;
        }
        for (index, l) in self.lights.iter().enumerate() {
            l.validate().map_err(|problem| SceneError::BadLight { index, problem })?;
            if let Light::Envmap { image, .. } = l {
                let Some(img) = self.images.get(*image as usize) else {
                    return Err(SceneError::BadLight {
                        index,
                        problem: format!("environment map image {image} is missing (the scene has {} images)", self.images.len()),
                    });
                };
                super::envmap::LatLong::new(img.width as usize, img.height as usize, &img.data)
                    .map_err(|problem| SceneError::BadLight { index, problem })?;
            }
        }
        Ok(())
    }

    /// The checks of [`SceneDesc::validate`] on one shape, in a scene of `materials` materials.
    pub fn validate_shape(s: &ShapeDesc, materials: usize) -> Result<(), SceneError> {
        if s.material as usize >= materials {
            return Err(SceneError::BadMaterial { shape: s.name.clone(), material: s.material, count: materials });
        }
        if let Some(e) = s.emission {
            if !e.is_finite() || e.min_element() < 0.0 {
                return Err(SceneError::BadShape {
                    shape: s.name.clone(),
                    problem: format!("emitted radiance {e} must be finite and non-negative"),
                });
            }
        }
        match &s.geometry {
            Geometry::Sphere { center, radius } => {
                if !center.is_finite() || !radius.is_finite() || *radius <= 0.0 {
                    return Err(SceneError::BadShape {
                        shape: s.name.clone(),
                        problem: format!("sphere centre {center} radius {radius} is invalid"),
                    });
                }
            }
            Geometry::Mesh(m) => {
                let n = m.positions.len();
                if let Some(p) = m.positions.iter().find(|p| !p.is_finite()) {
                    return Err(SceneError::BadShape { shape: s.name.clone(), problem: format!("vertex {p} is not finite") });
                }
                if m.indices.iter().any(|t| t.iter().any(|&i| i as usize >= n)) {
                    return Err(SceneError::BadShape {
                        shape: s.name.clone(),
                        problem: format!("a triangle index is out of range (mesh has {n} vertices)"),
                    });
                }
                if m.normals.as_ref().is_some_and(|v| v.len() != n) || m.uvs.as_ref().is_some_and(|v| v.len() != n) {
                    return Err(SceneError::BadShape {
                        shape: s.name.clone(),
                        problem: "normal or uv count differs from the vertex count".into(),
                    });
                }
            }
        }
        Ok(())
    }

    /// Bounds of all geometry.
    pub fn bounds(&self) -> Bounds3 {
        Self::shapes_bounds(Bounds3::EMPTY, &self.shapes)
    }

    /// `b` extended by the bounds of `shapes`, in their order ([`SceneDesc::bounds`] is those
    /// of all shapes from empty bounds).
    pub fn shapes_bounds(mut b: Bounds3, shapes: &[ShapeDesc]) -> Bounds3 {
        for s in shapes {
            match &s.geometry {
                Geometry::Mesh(m) => b = b.union(&m.bounds()),
                Geometry::Sphere { center, radius } => {
                    b.extend(*center - Vec3::splat(*radius));
                    b.extend(*center + Vec3::splat(*radius));
                }
            }
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitive_meshes_have_the_right_area_and_orientation() {
        let r = TriMesh::rectangle(&Mat4::IDENTITY);
        assert!((r.area() - 4.0).abs() < 1e-6);
        let (a, b, c) = (r.positions[0], r.positions[1], r.positions[2]);
        assert!((b - a).cross(c - a).normalize().dot(Vec3::Z) > 0.999);
        let cube = TriMesh::cube(&Mat4::from_scale(Vec3::splat(2.0)));
        assert!((cube.area() - 96.0).abs() < 1e-4);
        for t in &cube.indices {
            let (a, b, c) = (cube.positions[t[0] as usize], cube.positions[t[1] as usize], cube.positions[t[2] as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.dot((a + b + c) / 3.0) > 0.0, "cube faces point outwards");
        }
        let d = TriMesh::disk(&Mat4::IDENTITY, 128);
        assert!((d.area() - std::f64::consts::PI).abs() / std::f64::consts::PI < 1e-3);
    }

    /// A valid one-triangle scene with the given film filter.
    fn scene_with_filter(filter: PixelFilter) -> SceneDesc {
        let mesh = TriMesh { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], indices: vec![[0, 1, 2]], ..Default::default() };
        SceneDesc {
            shapes: vec![ShapeDesc { name: "t".into(), geometry: Geometry::Mesh(mesh), material: 0, emission: None, flip_normals: false }],
            materials: vec![Material::Diffuse { reflectance: crate::scene::material::Texture::Const(Color::splat(0.5)) }],
            film: FilmDesc { width: 8, height: 8, filter, sample_border: false },
            ..Default::default()
        }
    }

    #[test]
    fn validation_rejects_out_of_range_filters() {
        for filter in [PixelFilter::Box, PixelFilter::Tent, PixelFilter::Gaussian { stddev: 0.5 }, PixelFilter::Gaussian { stddev: 2.0 }] {
            assert_eq!(scene_with_filter(filter).validate(), Ok(()), "{filter:?}");
        }
        for stddev in [0.0, -0.5, f32::NAN, f32::INFINITY, 1e-30, 1e6] {
            let err = scene_with_filter(PixelFilter::Gaussian { stddev }).validate();
            assert!(matches!(&err, Err(SceneError::BadFilm(m)) if m.contains("stddev")), "stddev {stddev}: {err:?}");
        }
    }

    #[test]
    fn degenerate_triangles_are_removed() {
        let mut m = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0],
            indices: vec![[0, 1, 2], [0, 1, 3]],
            ..Default::default()
        };
        assert_eq!(m.remove_degenerate(), 1);
        assert_eq!(m.indices.len(), 1);
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
