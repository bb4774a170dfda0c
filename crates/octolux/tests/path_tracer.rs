//! End-to-end checks of the path tracer against closed-form answers, and determinism.
//!
//! - White furnace: a convex diffuse sphere of albedo 1 under a constant environment of
//!   radiance 1 has radiance exactly 1 everywhere; albedo ρ gives ρ (a convex object never sees
//!   itself, so one bounce is exact).
//! - A disk light of radiance `Le`, radius `r`, at height `h` above a diffuse plane of albedo ρ:
//!   on the axis the irradiance is `π Le r² / (r² + h²)`, so the outgoing radiance is
//!   `ρ Le r² / (r² + h²)`.
//! - Bit-identical images for 1 and 2 threads, with either sampler kind.

use octolux::accel::BackendKind;
use octolux::glam::{Mat4, Vec3};
use octolux::integrators::{path::PathSettings, Integrator};
use octolux::render::{render, RenderSettings};
use octolux::sampling::SamplerKind;
use octolux::scene::camera::{look_at, CameraDesc, FovAxis};
use octolux::scene::material::{Material, Texture};
use octolux::scene::{FilmDesc, Geometry, Light, PixelFilter, Scene, SceneDesc, ShapeDesc, TriMesh};
use octolux::Color;

fn furnace_scene(albedo: f32) -> SceneDesc {
    SceneDesc {
        shapes: vec![ShapeDesc {
            name: "sphere".into(),
            geometry: Geometry::Sphere { center: Vec3::ZERO, radius: 1.0 },
            material: 0,
            emission: None,
            flip_normals: false,
        }],
        materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(albedo)) }],
        lights: vec![Light::Constant { radiance: Color::ONE }],
        camera: CameraDesc {
            to_world: look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y),
            fov_deg: 30.0,
            fov_axis: FovAxis::X,
            near_clip: 1e-3,
        },
        film: FilmDesc { width: 24, height: 24, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    }
}

fn render_desc(desc: SceneDesc, spp: u32, max_depth: i32, seed: u64) -> octolux::image::Image {
    render_desc_with(desc, spp, max_depth, seed, SamplerKind::Independent)
}

fn render_desc_with(desc: SceneDesc, spp: u32, max_depth: i32, seed: u64, sampler: SamplerKind) -> octolux::image::Image {
    let scene = Scene::prepare(desc, BackendKind::Auto).expect("valid scene");
    let integrator = Integrator::Path(PathSettings { max_depth, ..Default::default() });
    let settings = RenderSettings { spp, seed, sampler, ..Default::default() };
    render(&scene, &integrator, &settings, &|_, _| {}).0
}

#[test]
fn white_furnace_is_one_everywhere() {
    let img = render_desc(furnace_scene(1.0), 64, -1, 1);
    let mean: f64 = img.data.iter().map(|c| (c.x + c.y + c.z) as f64 / 3.0).sum::<f64>() / img.data.len() as f64;
    assert!((mean - 1.0).abs() < 0.01, "furnace mean {mean}");
    // Centre pixel sees the sphere: it must be 1 too (not just the background).
    let c = img.data[(12 * 24 + 12) as usize];
    assert!((c.x - 1.0).abs() < 0.1, "centre {c}");
}

#[test]
fn grey_sphere_under_constant_sky_reflects_its_albedo() {
    // Direct only (max_depth 2) and unbounded must agree for a convex object.
    for max_depth in [2, -1] {
        let img = render_desc(furnace_scene(0.5), 256, max_depth, 2);
        // Pixels well inside the sphere's silhouette.
        let mut sum = 0.0f64;
        let mut n = 0;
        for y in 9..15 {
            for x in 9..15 {
                let c = img.data[y * 24 + x];
                sum += c.y as f64;
                n += 1;
            }
        }
        let m = sum / n as f64;
        assert!((m - 0.5).abs() < 0.01, "max_depth {max_depth}: {m}");
        let corner = img.data[0];
        assert!((corner - Color::ONE).abs().max_element() < 1e-5, "background {corner}");
    }
}

#[test]
fn disk_light_over_a_plane_matches_the_form_factor() {
    let (le, r, h, rho) = (10.0f32, 0.5f32, 1.0f32, 0.6f32);
    let disk = TriMesh::disk(
        &(Mat4::from_translation(Vec3::new(0.0, 0.0, h)) * Mat4::from_scale(Vec3::splat(r)) * Mat4::from_rotation_x(std::f32::consts::PI)),
        256,
    );
    let plane = TriMesh::rectangle(&Mat4::from_scale(Vec3::splat(10.0)));
    let desc = SceneDesc {
        shapes: vec![
            ShapeDesc { name: "plane".into(), geometry: Geometry::Mesh(plane), material: 0, emission: None, flip_normals: false },
            ShapeDesc {
                name: "light".into(),
                geometry: Geometry::Mesh(disk),
                material: 1,
                emission: Some(Color::splat(le)),
                flip_normals: false,
            },
        ],
        materials: vec![
            Material::Diffuse { reflectance: Texture::Const(Color::splat(rho)) },
            Material::Diffuse { reflectance: Texture::Const(Color::ZERO) },
        ],
        // A narrow camera looking at the origin from the side, under the light's rim.
        camera: CameraDesc {
            to_world: look_at(Vec3::new(3.0, 0.0, 0.8), Vec3::ZERO, Vec3::Z),
            fov_deg: 0.5,
            fov_axis: FovAxis::X,
            near_clip: 1e-3,
        },
        film: FilmDesc { width: 8, height: 8, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    };
    let expect = (rho * le * r * r / (r * r + h * h)) as f64;
    // Sobol' points converge to the same value (a bias in the sequence's use would show).
    for sampler in [SamplerKind::Independent, SamplerKind::Sobol] {
        let img = render_desc_with(desc.clone(), 512, 2, 3, sampler);
        let mean = img.data.iter().map(|c| c.x as f64).sum::<f64>() / img.data.len() as f64;
        assert!((mean - expect).abs() < 0.01 * expect, "{sampler:?}: {mean} vs {expect}");
    }
}

#[test]
fn image_is_bit_identical_for_one_and_two_threads() {
    let desc = furnace_scene(0.7);
    for sampler in [SamplerKind::Independent, SamplerKind::Sobol] {
        let run = |n: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
            pool.install(|| render_desc_with(desc.clone(), 8, -1, 9, sampler))
        };
        let a = run(1);
        let b = run(2);
        assert!(a.data.iter().zip(&b.data).all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits)), "{sampler:?}");
    }
}
