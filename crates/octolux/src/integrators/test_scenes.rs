//! Small analytic scenes shared by the integrators' tests (compiled for tests only).

use crate::accel::BackendKind;
use crate::math::Color;
use crate::scene::camera::{look_at, CameraDesc, FovAxis};
use crate::scene::material::{Material, Texture};
use crate::scene::Scene;
use crate::scene::{FilmDesc, Geometry, PixelFilter, SceneDesc, ShapeDesc, TriMesh};
use glam::{Mat4, Vec3};

pub(crate) fn quad(name: &str, to_world: Mat4, material: u32, emission: Option<Color>) -> ShapeDesc {
    ShapeDesc { name: name.into(), geometry: Geometry::Mesh(TriMesh::rectangle(&to_world)), material, emission, flip_normals: false }
}

/// A closed unit-scale Cornell-like box (size 2, y up, inward normals) with a grey floor,
/// red left and green right walls, a ceiling light, and a camera looking in from the front
/// wall; `res`² pixels.
pub(crate) fn box_scene(res: u32) -> Scene {
    box_scene_with(res, PixelFilter::Box)
}

/// [`box_scene`] with another reconstruction filter.
pub(crate) fn box_scene_with(res: u32, filter: PixelFilter) -> Scene {
    Scene::prepare(box_desc_with(res, filter), BackendKind::Bvh).expect("valid test scene")
}

/// The description of [`box_scene`] (8² pixels).
pub(crate) fn box_desc() -> SceneDesc {
    box_desc_with(8, PixelFilter::Box)
}

fn box_desc_with(res: u32, filter: PixelFilter) -> SceneDesc {
    use std::f32::consts::FRAC_PI_2;
    let t = Mat4::from_translation;
    let rx = Mat4::from_rotation_x;
    let ry = Mat4::from_rotation_y;
    let shapes = vec![
        quad("floor", t(Vec3::new(0.0, 0.0, 0.0)) * rx(-FRAC_PI_2), 0, None),
        quad("ceiling", t(Vec3::new(0.0, 2.0, 0.0)) * rx(FRAC_PI_2), 0, None),
        quad("back", t(Vec3::new(0.0, 1.0, -1.0)), 0, None),
        quad("front", t(Vec3::new(0.0, 1.0, 1.0)) * ry(std::f32::consts::PI), 0, None),
        quad("left", t(Vec3::new(-1.0, 1.0, 0.0)) * ry(FRAC_PI_2), 1, None),
        quad("right", t(Vec3::new(1.0, 1.0, 0.0)) * ry(-FRAC_PI_2), 2, None),
        quad("light", t(Vec3::new(0.0, 1.99, 0.0)) * rx(FRAC_PI_2) * Mat4::from_scale(Vec3::splat(0.3)), 0, Some(Color::splat(15.0))),
    ];
    SceneDesc {
        shapes,
        materials: vec![
            Material::Diffuse { reflectance: Texture::Const(Color::splat(0.7)) },
            Material::Diffuse { reflectance: Texture::Const(Color::new(0.7, 0.1, 0.1)) },
            Material::Diffuse { reflectance: Texture::Const(Color::new(0.1, 0.7, 0.1)) },
        ],
        camera: CameraDesc {
            to_world: look_at(Vec3::new(0.0, 1.0, 0.95), Vec3::new(0.0, 1.0, -1.0), Vec3::Y),
            fov_deg: 90.0,
            fov_axis: FovAxis::X,
            near_clip: 1e-3,
        },
        film: FilmDesc { width: res, height: res, filter, sample_border: false },
        ..Default::default()
    }
}

/// The inside of a sphere of radius 1 whose walls are Lambertian of albedo `rho` and emit
/// `le` inwards, seen from the centre: radiance is `le / (1 - rho)` everywhere, of which
/// `le` is emission and `rho le` reflected direct light, so the indirect irradiance is
/// `π (le / (1 - rho) - le - rho le) / rho = π rho le / (1 - rho)`.
pub(crate) fn furnace_scene(rho: f32, le: f32) -> Scene {
    let desc = SceneDesc {
        shapes: vec![ShapeDesc {
            name: "sphere".into(),
            geometry: Geometry::Sphere { center: Vec3::ZERO, radius: 1.0 },
            material: 0,
            emission: Some(Color::splat(le)),
            flip_normals: true,
        }],
        materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(rho)) }],
        camera: CameraDesc { to_world: look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y), fov_deg: 60.0, fov_axis: FovAxis::X, near_clip: 1e-3 },
        film: FilmDesc { width: 16, height: 16, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    };
    Scene::prepare(desc, BackendKind::Bvh).expect("valid furnace scene")
}

/// Mean of an image over all pixels and channels.
pub(crate) fn image_mean(img: &[Color]) -> f64 {
    img.iter().map(|c| c.element_sum() as f64 / 3.0).sum::<f64>() / img.len() as f64
}

/// Render `integrator` on the furnace (ρ = 0.5, Le = 1): the render is 2, the indirect
/// irradiance π.
pub(crate) fn check_furnace(render_mean: f64, irradiance_mean: f64, tolerance: f64, what: &str) {
    eprintln!("{what}: furnace render {render_mean:.4} (2), indirect irradiance {irradiance_mean:.4} (π)");
    assert!((render_mean - 2.0).abs() < 2.0 * tolerance, "{what}: render {render_mean}, expected 2");
    let pi = std::f64::consts::PI;
    assert!((irradiance_mean - pi).abs() < pi * tolerance, "{what}: indirect irradiance {irradiance_mean}, expected π");
}

/// The inside of the cube [-1, 1]³ whose walls are Lambertian of albedo `rho` and emit `le`
/// inwards, seen from the centre: as [`furnace_scene`] (radiance `le / (1 - rho)` everywhere,
/// indirect irradiance `π rho le / (1 - rho)`), with planar walls, whose triangles the
/// octree's geometry-area estimator uses, and the camera looking at the back wall.
pub(crate) fn furnace_box_scene(rho: f32, le: f32) -> Scene {
    let desc = SceneDesc {
        shapes: vec![ShapeDesc {
            name: "cube".into(),
            geometry: Geometry::Mesh(TriMesh::cube(&Mat4::IDENTITY)),
            material: 0,
            emission: Some(Color::splat(le)),
            flip_normals: true,
        }],
        materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(rho)) }],
        // 60°: the camera sees the middle of the back wall, at least 0.42 from its edges, where
        // next-event estimation from the adjacent walls (1/r² at the edge) has heavy tails.
        camera: CameraDesc { to_world: look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y), fov_deg: 60.0, fov_axis: FovAxis::X, near_clip: 1e-3 },
        film: FilmDesc { width: 16, height: 16, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    };
    Scene::prepare(desc, BackendKind::Bvh).expect("valid furnace scene")
}

/// A Lambertian square of albedo `rho` and half-edge 50 in the plane y = 0, under a constant
/// sky of radiance `sky`, seen from 1 above, looking down with a 60° field of view (every
/// pixel sees the square). Its outgoing radiance is `rho sky` (irradiance `π sky`), all of
/// it direct light: the square cannot see itself, so no light reaches it indirectly.
pub(crate) fn sky_plane_scene(rho: f32, sky: f32) -> Scene {
    Scene::prepare(sky_plane_desc(rho, sky), BackendKind::Bvh).expect("valid sky scene")
}

/// The description of [`sky_plane_scene`] (to swap its light).
pub(crate) fn sky_plane_desc(rho: f32, sky: f32) -> SceneDesc {
    let to_world = Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2) * Mat4::from_scale(Vec3::splat(50.0));
    SceneDesc {
        shapes: vec![quad("ground", to_world, 0, None)],
        materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(rho)) }],
        lights: vec![crate::scene::Light::Constant { radiance: Color::splat(sky) }],
        camera: CameraDesc {
            to_world: look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, Vec3::Z),
            fov_deg: 60.0,
            fov_axis: FovAxis::X,
            near_clip: 1e-3,
        },
        film: FilmDesc { width: 16, height: 16, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    }
}

/// The test box with a cube (centre, half side) appended as its last shape, absent from any
/// bake of the box: the prepared scene and the cube's shape index.
pub(crate) fn box_with_cube(centre: Vec3, half: Vec3, width: u32) -> (Scene, u32) {
    let mut desc = box_desc();
    desc.film.width = width;
    desc.film.height = width;
    let first = desc.shapes.len() as u32;
    let cube = Mat4::from_translation(centre) * Mat4::from_scale(half);
    desc.shapes.push(ShapeDesc {
        name: "inserted".into(),
        geometry: Geometry::Mesh(TriMesh::cube(&cube)),
        material: 0,
        emission: None,
        flip_normals: false,
    });
    (Scene::prepare(desc, BackendKind::Bvh).unwrap(), first)
}
