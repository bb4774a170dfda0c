//! Scene description: plain data produced by loaders (built-in scenes, Mitsuba XML, OBJ, PLY)
//! and consumed by [`crate::prepared::Scene::prepare`].
//!
//! Invariants a loader must establish (checked again by `validate`):
//! - geometry is in world space (loaders apply `to_world`);
//! - every `material` index is `< materials.len()`, every bitmap index `< images.len()`;
//! - all numbers are finite; triangle indices are in range.
//!
//! Units are the scene's own (metres for Mitsuba scenes, millimetres for the built-in Cornell
//! box, whose published geometry is in mm); radiance is in W/(m² sr) per RGB channel.

use crate::camera::CameraDesc;
use crate::light::Light;
use crate::material::{Image, Material};
use crate::math::{Bounds3, Color};
use glam::{Mat4, Vec2, Vec3};
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

    /// Mitsuba's `rectangle`: the square [-1,1]² in the z = 0 plane, normal +z, uv in [0,1]².
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

/// Film description.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FilmDesc {
    pub width: u32,
    pub height: u32,
    pub filter: PixelFilter,
}

impl Default for FilmDesc {
    fn default() -> Self {
        FilmDesc { width: 512, height: 512, filter: PixelFilter::Tent }
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
        self.camera.validate().map_err(SceneError::BadCamera)?;
        for s in &self.shapes {
            if s.material as usize >= self.materials.len() {
                return Err(SceneError::BadMaterial { shape: s.name.clone(), material: s.material, count: self.materials.len() });
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
                crate::envmap::LatLong::new(img.width as usize, img.height as usize, &img.data)
                    .map_err(|problem| SceneError::BadLight { index, problem })?;
            }
        }
        Ok(())
    }

    /// Bounds of all geometry.
    pub fn bounds(&self) -> Bounds3 {
        let mut b = Bounds3::EMPTY;
        for s in &self.shapes {
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
}
