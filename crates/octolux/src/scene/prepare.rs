//! [`Scene::prepare`]: a scene description made ready for rendering (its meshes in one list
//! of triangles, the intersection structure built, the lights' distributions, the materials'
//! tables), and [`Scene::prepare_adding`] for a scene with an object added to a prepared one.

use super::desc::{Geometry, SceneDesc, SceneError};
use super::{material, Camera, LightSet, Material, Scene, ShapeInfo, SphereShape};
use crate::accel::layered::LayeredAccel;
use crate::accel::BackendKind;
use glam::{Vec2, Vec3};

impl Scene {
    /// Validate and prepare a description; builds the intersection backend.
    pub fn prepare(desc: SceneDesc, backend: BackendKind) -> Result<Scene, SceneError> {
        Scene::prepare_over(desc, backend, None)
    }

    /// [`Scene::prepare`] for a description that adds shapes after those of the scene `base`
    /// was prepared from (an object inserted into it): where `base`'s triangles and the vertices
    /// they use come first, unchanged, its intersection structure is shared and one is built
    /// over the added triangles only (`accel::layered`); otherwise the whole is built.
    pub fn prepare_adding(desc: SceneDesc, backend: BackendKind, base: &Scene) -> Result<Scene, SceneError> {
        Scene::prepare_over(desc, backend, Some(base))
    }

    fn prepare_over(desc: SceneDesc, backend: BackendKind, base: Option<&Scene>) -> Result<Scene, SceneError> {
        desc.validate()?;
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
        let mut triangles = Vec::new();
        let mut tri_shape = Vec::new();
        let mut spheres = Vec::new();
        let mut shapes = Vec::new();
        for (si, s) in desc.shapes.iter().enumerate() {
            let mut info =
                ShapeInfo { material: s.material, flip: s.flip_normals, has_normals: false, has_uvs: false, name: s.name.clone() };
            match &s.geometry {
                Geometry::Mesh(m) => {
                    let base = positions.len() as u32;
                    positions.extend_from_slice(&m.positions);
                    info.has_normals = m.normals.is_some();
                    info.has_uvs = m.uvs.is_some();
                    match &m.normals {
                        Some(n) => normals.extend_from_slice(n),
                        None => normals.extend(std::iter::repeat_n(Vec3::ZERO, m.positions.len())),
                    }
                    match &m.uvs {
                        Some(u) => uvs.extend_from_slice(u),
                        None => uvs.extend(std::iter::repeat_n(Vec2::ZERO, m.positions.len())),
                    }
                    for t in &m.indices {
                        triangles.push([t[0] + base, t[1] + base, t[2] + base]);
                        tri_shape.push(si as u32);
                    }
                }
                Geometry::Sphere { center, radius } => spheres.push(SphereShape { center: *center, radius: *radius, shape: si as u32 }),
            }
            shapes.push(info);
        }
        if triangles.is_empty() && spheres.is_empty() {
            return Err(SceneError::Empty);
        }
        let bounds = desc.bounds();
        let accel = match base {
            Some(b)
                if b.accel.is_single()
                    && positions.get(..b.positions.len()) == Some(&b.positions[..])
                    && triangles.get(..b.triangles.len()) == Some(&b.triangles[..]) =>
            {
                LayeredAccel::adding(&b.accel, b.triangles.len(), &positions, &triangles, backend)
            }
            _ => LayeredAccel::build(&positions, &triangles, backend),
        }
        .map_err(|e| SceneError::Accel(e.to_string()))?;
        let lights = LightSet::with_images(&desc.lights, &desc.shapes, &desc.images, bounds);
        let camera = Camera::new(&desc.camera, desc.film.width, desc.film.height);
        let mut materials = desc.materials;
        let mut mask_nested = vec![None; materials.len()];
        for i in 0..materials.len() {
            if let Material::Mask { nested, .. } = &materials[i] {
                let copy = (**nested).clone();
                mask_nested[i] = Some(materials.len() as u32);
                materials.push(copy);
            }
        }
        mask_nested.resize(materials.len(), None);
        material::plastic::precompute_plastic_tables(&materials);
        Ok(Scene {
            materials,
            images: desc.images,
            lights,
            camera,
            film: desc.film,
            bounds,
            accel,
            positions,
            normals,
            uvs,
            triangles,
            tri_shape,
            spheres,
            shapes,
            mask_nested,
        })
    }
}
