//! [`Scene::prepare`]: a scene description made ready for rendering (its meshes in one list
//! of triangles, the intersection structure built, the lights' distributions, the materials'
//! tables), and [`Scene::prepare_adding`] for a scene with an object added to a prepared one.

use super::desc::{Geometry, SceneDesc, SceneError, ShapeDesc};
use super::spheres::SphereBvh;
use super::{material, Camera, Flat, LightSet, Material, Scene, ShapeInfo, SphereShape, VertexShading};
use crate::accel::layered::LayeredAccel;
use crate::accel::BackendKind;
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// Shapes added to a prepared scene ([`Scene::prepare_adding`]): their materials, which
/// follow the base description's, and the shapes, whose material indices count from the
/// base description's first material (so `base_desc.materials.len()` is the first of these).
#[derive(Clone, Copy, Debug)]
pub struct Addition<'a> {
    pub materials: &'a [Material],
    pub shapes: &'a [ShapeDesc],
}

impl Flat {
    /// Append `shapes`, the first of them shape number `self.shapes.len()`.
    fn add(&mut self, shapes: &[ShapeDesc]) {
        for s in shapes {
            let si = self.shapes.len() as u32;
            let mut info =
                ShapeInfo { material: s.material, flip: s.flip_normals, has_normals: false, has_uvs: false, name: s.name.clone() };
            match &s.geometry {
                Geometry::Mesh(m) => {
                    let base = self.positions.len() as u32;
                    self.positions.extend_from_slice(&m.positions);
                    info.has_normals = m.normals.is_some();
                    info.has_uvs = m.uvs.is_some();
                    self.shading.extend((0..m.positions.len()).map(|k| VertexShading {
                        n: m.normals.as_ref().map_or(Vec3::ZERO, |n| n[k]),
                        uv: m.uvs.as_ref().map_or(Vec2::ZERO, |u| u[k]),
                    }));
                    for t in &m.indices {
                        self.triangles.push([t[0] + base, t[1] + base, t[2] + base]);
                        self.tri_shape.push(si);
                    }
                }
                Geometry::Sphere { center, radius } => self.spheres.push(SphereShape { center: *center, radius: *radius, shape: si }),
            }
            self.shapes.push(info);
        }
    }
}

/// The materials with, after them, a copy of each `mask`'s nested material (rendered where the
/// mask is opaque), and for each material the index of its copy.
fn with_mask_copies(mut materials: Vec<Material>) -> (Vec<Material>, Vec<Option<u32>>) {
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
    (materials, mask_nested)
}

impl Scene {
    /// Validate and prepare a description; builds the intersection backend.
    pub fn prepare(desc: SceneDesc, backend: BackendKind) -> Result<Scene, SceneError> {
        desc.validate()?;
        let mut flat = Flat::default();
        flat.add(&desc.shapes);
        if flat.triangles.is_empty() && flat.spheres.is_empty() {
            return Err(SceneError::Empty);
        }
        let bounds = desc.bounds();
        let accel = LayeredAccel::build(&flat.positions, &flat.triangles, backend).map_err(|e| SceneError::Accel(e.to_string()))?;
        let lights = LightSet::with_images(&desc.lights, &desc.shapes, &desc.images, bounds);
        let camera = Camera::new(&desc.camera, desc.film.width, desc.film.height);
        let (materials, mask_nested) = with_mask_copies(desc.materials);
        let images = Arc::new(desc.images);
        let sphere_bvh = SphereBvh::build(&flat.spheres);
        Ok(Scene { materials, images, lights, camera, film: desc.film, bounds, accel, flat, sphere_bvh, mask_nested })
    }

    /// The scene `base` (prepared from `base_desc`) with `add`'s shapes and materials appended:
    /// the scene [`Scene::prepare`] makes of `base_desc` with them appended, made without going
    /// through the whole description again. The base's arrays are copied and the added shapes
    /// flattened after them; its intersection structure is shared and one is built over the
    /// added triangles only (`accel::layered`); its textures are shared; its lights are kept
    /// unless the bounds grow or an added shape emits. Only the added shapes and materials are
    /// validated (the base's were). A `base` that was not prepared from `base_desc` (other
    /// shape or triangle counts) is prepared again whole.
    pub fn prepare_adding(base_desc: &SceneDesc, base: &Scene, add: Addition<'_>, backend: BackendKind) -> Result<Scene, SceneError> {
        let desc_triangles: usize =
            base_desc.shapes.iter().map(|s| if let Geometry::Mesh(m) = &s.geometry { m.indices.len() } else { 0 }).sum();
        if base.flat.shapes.len() != base_desc.shapes.len() || base.flat.triangles.len() != desc_triangles {
            let mut whole = base_desc.clone();
            whole.materials.extend_from_slice(add.materials);
            whole.shapes.extend_from_slice(add.shapes);
            return Scene::prepare(whole, backend);
        }
        let n_materials = base_desc.materials.len() + add.materials.len();
        for s in add.shapes {
            SceneDesc::validate_shape(s, n_materials)?;
        }
        for (i, m) in add.materials.iter().enumerate() {
            m.validate(base_desc.images.len())
                .map_err(|p| SceneError::BadShape { shape: format!("material {}", base_desc.materials.len() + i), problem: p })?;
        }
        let mut flat = base.flat.clone();
        flat.add(add.shapes);
        let bounds = SceneDesc::shapes_bounds(base.bounds, add.shapes);
        let accel = if base.accel.is_single() {
            LayeredAccel::adding(&base.accel, base.flat.triangles.len(), &flat.positions, &flat.triangles, backend)
        } else {
            LayeredAccel::build(&flat.positions, &flat.triangles, backend)
        }
        .map_err(|e| SceneError::Accel(e.to_string()))?;
        // the lights depend on the shapes only through those that emit, and on the bounds
        let lights = if bounds == base.bounds && add.shapes.iter().all(|s| s.emission.is_none()) {
            let mut l = base.lights.clone();
            l.cover_shapes(flat.shapes.len());
            l
        } else {
            let shapes: Vec<ShapeDesc> = base_desc.shapes.iter().chain(add.shapes).cloned().collect();
            LightSet::with_images(&base_desc.lights, &shapes, &base_desc.images, bounds)
        };
        let camera = Camera::new(&base_desc.camera, base_desc.film.width, base_desc.film.height);
        let materials = base_desc.materials.iter().chain(add.materials).cloned().collect();
        let (materials, mask_nested) = with_mask_copies(materials);
        let images = base.images.clone();
        let sphere_bvh = SphereBvh::build(&flat.spheres);
        Ok(Scene { materials, images, lights, camera, film: base_desc.film, bounds, accel, flat, sphere_bvh, mask_nested })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::test_scenes::box_desc;
    use crate::math::{Color, Ray};
    use crate::sampling::{square_to_uniform_sphere, Sampler};
    use crate::scene::material::Texture;
    use crate::scene::{Light, TriMesh};
    use glam::Mat4;

    /// The box with a sky (lights that depend on the bounds) and a mask material, prepared with
    /// an addition, against the concatenated description prepared whole: the same arrays,
    /// materials, bounds and lights, and the same hit for every ray; with the addition inside
    /// the box (the lights kept) and reaching out of it (the lights made again).
    #[test]
    fn an_addition_prepares_the_scene_a_whole_description_prepares() {
        let mut base_desc = box_desc();
        base_desc.lights.push(Light::Constant { radiance: Color::splat(0.5) });
        let grey = Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) };
        base_desc.materials.push(Material::Mask { opacity: Texture::Const(Color::splat(0.5)), nested: Box::new(grey.clone()) });
        base_desc.shapes[3].material = 3;
        let base = Scene::prepare(base_desc.clone(), BackendKind::Bvh).unwrap();
        let added_materials =
            [grey, Material::Mask { opacity: Texture::Const(Color::splat(0.3)), nested: Box::new(base_desc.materials[1].clone()) }];
        for (centre, grows) in [(Vec3::new(0.2, 0.5, -0.3), false), (Vec3::new(0.9, 0.5, 0.0), true)] {
            let cube = Mat4::from_translation(centre) * Mat4::from_scale(Vec3::splat(0.25));
            let shapes = [
                ShapeDesc {
                    name: "cube".into(),
                    geometry: Geometry::Mesh(TriMesh::cube(&cube)),
                    material: 4,
                    emission: None,
                    flip_normals: false,
                },
                ShapeDesc {
                    name: "ball".into(),
                    geometry: Geometry::Sphere { center: centre + Vec3::Y * 0.5, radius: 0.2 },
                    material: 5,
                    emission: None,
                    flip_normals: true,
                },
            ];
            let add = Addition { materials: &added_materials, shapes: &shapes };
            let added = Scene::prepare_adding(&base_desc, &base, add, BackendKind::Bvh).unwrap();
            let mut whole_desc = base_desc.clone();
            whole_desc.materials.extend(added_materials.iter().cloned());
            whole_desc.shapes.extend(shapes.iter().cloned());
            let whole = Scene::prepare(whole_desc, BackendKind::Bvh).unwrap();
            assert_eq!(added.bounds != base.bounds, grows);
            assert_eq!((&added.flat.positions, &added.flat.shading), (&whole.flat.positions, &whole.flat.shading));
            assert_eq!(
                (&added.flat.triangles, &added.flat.tri_shape, added.flat.shapes.len()),
                (&whole.flat.triangles, &whole.flat.tri_shape, whole.flat.shapes.len())
            );
            assert_eq!(format!("{:?}", added.flat.spheres), format!("{:?}", whole.flat.spheres));
            assert_eq!((&added.materials, &added.mask_nested, added.bounds), (&whole.materials, &whole.mask_nested, whole.bounds));
            assert_eq!(format!("{:?}", added.lights), format!("{:?}", whole.lights));
            let mut s = Sampler::new(7, 0, 0);
            for _ in 0..2000 {
                let o = Vec3::new(0.0, 1.0, 0.0) + (s.next_2d().extend(s.next_1d()) - 0.5) * 1.6;
                let r = Ray::new(o, square_to_uniform_sphere(s.next_2d()));
                let (a, b) = (added.intersect(&r), whole.intersect(&r));
                assert_eq!(a.map(|h| (h.t, h.shape, h.p)), b.map(|h| (h.t, h.shape, h.p)), "ray {r:?}");
            }
        }
        // a base not prepared from the description it is given is prepared again whole
        let other = Scene::prepare(crate::integrators::test_scenes::sky_plane_desc(0.5, 1.0), BackendKind::Bvh).unwrap();
        let add = Addition { materials: &[], shapes: &[] };
        let again = Scene::prepare_adding(&base_desc, &other, add, BackendKind::Bvh).unwrap();
        assert_eq!((again.flat.triangles.len(), again.flat.shapes.len()), (base.flat.triangles.len(), base.flat.shapes.len()));
    }
}
