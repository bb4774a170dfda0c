//! The path tracer and Mitsuba 3's `mask`, on a floor lit by a square light with a mask quad
//! between them, seen from below the light through the mask:
//! - an opaque mask renders bit-identically to its nested bsdf;
//! - a clear mask (opacity 0) is a delta vertex that counts towards `max_depth`, and shadow
//!   rays stop at it, as in Mitsuba 3's `path.cpp` (checked there with this very scene: the
//!   floor seen through the mask is black at max_depth 2 and 3 and lit from 4 on);
//! - what reaches the floor through the clear mask is the direct light of the scene without
//!   it (in expectation; Mitsuba's estimator, BSDF sampling only, is noisier).

use octolux::accel::BackendKind;
use octolux::glam::{Mat4, Vec3};
use octolux::integrators::{path::PathSettings, Integrator};
use octolux::render::{render, RenderSettings};
use octolux::scene::camera::{look_at, CameraDesc, FovAxis};
use octolux::scene::material::{Material, Texture};
use octolux::scene::{FilmDesc, Geometry, PixelFilter, Scene, SceneDesc, ShapeDesc, TriMesh};
use octolux::Color;
use std::f32::consts::FRAC_PI_2;

const RES: u32 = 32;

/// `mask`: the material of the quad at y = 1 (None: no quad).
fn scene(mask: Option<Material>) -> Scene {
    let quad = |m: Mat4, material: u32, emission: Option<Color>| ShapeDesc {
        name: format!("quad {material}"),
        geometry: Geometry::Mesh(TriMesh::rectangle(&m)),
        material,
        emission,
        flip_normals: false,
    };
    let (t, rx, s) = (Mat4::from_translation, Mat4::from_rotation_x, |k: f32| Mat4::from_scale(Vec3::splat(k)));
    let mut shapes = vec![
        quad(rx(-FRAC_PI_2) * s(3.0), 0, None),
        quad(t(Vec3::new(0.0, 3.0, 0.0)) * rx(FRAC_PI_2) * s(0.8), 1, Some(Color::splat(10.0))),
    ];
    let mut materials = vec![
        Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) },
        Material::Diffuse { reflectance: Texture::Const(Color::ZERO) },
    ];
    if let Some(m) = mask {
        shapes.push(quad(t(Vec3::new(0.0, 1.0, 0.0)) * rx(-FRAC_PI_2) * s(1.2), 2, None));
        materials.push(m);
    }
    let desc = SceneDesc {
        shapes,
        materials,
        camera: CameraDesc {
            to_world: look_at(Vec3::new(0.0, 2.5, 0.0), Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0)),
            fov_deg: 70.0,
            fov_axis: FovAxis::X,
            near_clip: 1e-3,
        },
        film: FilmDesc { width: RES, height: RES, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    };
    Scene::prepare(desc, BackendKind::Auto).expect("valid scene")
}

fn mask(opacity: f32) -> Material {
    Material::Mask {
        opacity: Texture::Const(Color::splat(opacity)),
        nested: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::new(0.2, 0.6, 0.3)) }),
    }
}

fn image(scene: &Scene, spp: u32, max_depth: i32) -> Vec<Color> {
    let integrator = Integrator::Path(PathSettings { max_depth, ..Default::default() });
    render(scene, &integrator, &RenderSettings { spp, seed: 3, ..Default::default() }, &|_, _| {}).0.data
}

/// Mean over the central 8x8 pixels (the floor seen through the mask quad) and its standard
/// error from the spread of the 64 pixels.
fn centre(img: &[Color]) -> (f64, f64) {
    let v: Vec<f64> =
        (12..20).flat_map(|y| (12..20).map(move |x| (y, x))).map(|(y, x)| img[(y * RES + x) as usize].element_sum() as f64 / 3.0).collect();
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let var = v.iter().map(|a| (a - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
    (m, (var / v.len() as f64).sqrt())
}

#[test]
fn an_opaque_mask_renders_as_its_nested_bsdf() {
    let nested = Material::Diffuse { reflectance: Texture::Const(Color::new(0.2, 0.6, 0.3)) };
    for depth in [3, -1] {
        assert_eq!(image(&scene(Some(mask(1.0))), 8, depth), image(&scene(Some(nested.clone())), 8, depth), "max_depth {depth}");
    }
}

#[test]
fn a_clear_mask_is_a_delta_vertex_that_shadow_rays_do_not_cross() {
    let clear = scene(Some(mask(0.0)));
    // Through the mask the floor is the 3rd vertex: no light sample at max_depth 2; at 3 the
    // shadow ray stops at the mask and the light is 2 vertices further (null, light).
    for depth in [2, 3] {
        let (m, _) = centre(&image(&clear, 16, depth));
        assert_eq!(m, 0.0, "max_depth {depth}: the floor seen through a clear mask is black in Mitsuba 3");
    }
    // From max_depth 4 on, BSDF samples through the mask reach the light: in expectation the
    // floor's direct light without the mask.
    let (through, se) = centre(&image(&clear, 1024, 4));
    let (direct, se_direct) = centre(&image(&scene(None), 64, 2));
    let tol = 4.0 * (se * se + se_direct * se_direct).sqrt();
    eprintln!("through a clear mask {through:.4} ± {se:.4}, direct without it {direct:.4} ± {se_direct:.4}");
    assert!(direct > 0.05, "the floor is lit: {direct}");
    assert!((through - direct).abs() < tol, "through the mask {through}, without it {direct} (tolerance {tol})");
}
