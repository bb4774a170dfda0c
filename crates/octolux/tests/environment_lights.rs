//! End-to-end checks of the environment emitters (`envmap`, `sunsky`) through the path tracer
//! (next-event estimation, BSDF sampling of escaped rays, MIS between them) and the photon
//! emission of the light set.
//!
//! - Furnace: a uniform envmap is the constant environment: a convex diffuse sphere of albedo ρ
//!   under it has radiance ρ·L, the background L.
//! - A diffuse plane of albedo ρ facing up under an environment `L(ω)` (nothing else in the
//!   scene) has radiance `ρ/π ∫_{z>0} L(ω) cos θ dω` everywhere; the integral is computed by
//!   quadrature from the emitter's own `eval` (plus the sun disk in closed form for `sunsky`).
//! - Photons: the mean power of emitted photons equals the light set's total power, and their
//!   directions point into the scene.

use octolux::accel::BackendKind;
use octolux::glam::{DVec3, Mat3, Mat4, Vec3};
use octolux::image::Image;
use octolux::integrators::{path::PathSettings, Integrator};
use octolux::render::{render, RenderSettings};
use octolux::sampling::Sampler;
use octolux::scene::camera::{look_at, CameraDesc, FovAxis};
use octolux::scene::envmap::EnvMap;
use octolux::scene::lights::LightSelection;
use octolux::scene::material::{Material, Texture};
use octolux::scene::sunsky::{SunSky, SunSkyDesc};
use octolux::scene::Light;
use octolux::scene::Scene;
use octolux::scene::{FilmDesc, Geometry, PixelFilter, SceneDesc, ShapeDesc, TriMesh};
use octolux::Color;
use std::f64::consts::PI;

fn camera(from: Vec3) -> CameraDesc {
    CameraDesc { to_world: look_at(from, Vec3::ZERO, Vec3::Y), fov_deg: 30.0, fov_axis: FovAxis::X, near_clip: 1e-3 }
}

fn render_desc(desc: SceneDesc, spp: u32, max_depth: i32) -> Image {
    let scene = Scene::prepare(desc, BackendKind::Auto).expect("valid scene");
    let integrator = Integrator::Path(PathSettings { max_depth, ..Default::default() });
    let settings = RenderSettings { spp, seed: 3, ..Default::default() };
    render(&scene, &integrator, &settings, &|_, _| {}).0
}

/// A small map with strong variation (a bright patch, a dark band, colours).
fn test_map() -> Image {
    let (w, h) = (16u32, 8u32);
    let data = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            if (x, y) == (3, 2) {
                Color::new(40.0, 30.0, 20.0)
            } else if y == 5 {
                Color::splat(0.02)
            } else {
                Color::new(0.2 + 0.05 * x as f32, 0.5, 0.3 + 0.1 * y as f32)
            }
        })
        .collect();
    Image { width: w, height: h, data }
}

fn mean_of(img: &Image, x0: usize, x1: usize) -> DVec3 {
    let mut acc = DVec3::ZERO;
    let mut n = 0;
    for y in x0..x1 {
        for x in x0..x1 {
            acc += img.data[y * img.width as usize + x].as_dvec3();
            n += 1;
        }
    }
    acc / n as f64
}

#[test]
fn uniform_envmap_is_a_white_furnace() {
    let img = Image { width: 4, height: 2, data: vec![Color::ONE; 8] };
    let desc = SceneDesc {
        shapes: vec![ShapeDesc {
            name: "sphere".into(),
            geometry: Geometry::Sphere { center: Vec3::ZERO, radius: 1.0 },
            material: 0,
            emission: None,
            flip_normals: false,
        }],
        materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }],
        images: vec![img],
        lights: vec![Light::Envmap { image: 0, scale: 1.0, to_world: Mat3::from_rotation_z(0.4) }],
        camera: camera(Vec3::new(0.0, 0.0, 4.0)),
        film: FilmDesc { width: 24, height: 24, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    };
    let out = render_desc(desc, 256, -1);
    let m = mean_of(&out, 9, 15);
    assert!((m - DVec3::splat(0.5)).abs().max_element() < 0.01, "sphere {m}");
    assert!((out.data[0] - Color::ONE).abs().max_element() < 1e-5, "background {}", out.data[0]);
}

fn plane_scene(light: Light, images: Vec<Image>) -> SceneDesc {
    SceneDesc {
        shapes: vec![ShapeDesc {
            name: "plane".into(),
            geometry: Geometry::Mesh(TriMesh::rectangle(&Mat4::from_scale(Vec3::splat(50.0)))),
            material: 0,
            emission: None,
            flip_normals: false,
        }],
        materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }],
        images,
        lights: vec![light],
        camera: camera(Vec3::new(0.0, 0.0, 5.0)),
        film: FilmDesc { width: 16, height: 16, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    }
}

/// `∫_{z>0} L(ω) cos θ dω` by the midpoint rule in (cos θ, φ) (so the measure is exact).
fn cosine_integral(eval: impl Fn(Vec3) -> Color) -> DVec3 {
    let (nz, nphi) = (400, 800);
    let mut acc = DVec3::ZERO;
    for i in 0..nz {
        let z = (i as f64 + 0.5) / nz as f64;
        let r = (1.0 - z * z).sqrt();
        for j in 0..nphi {
            let phi = (j as f64 + 0.5) / nphi as f64 * 2.0 * PI;
            let d = DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3();
            acc += eval(d).as_dvec3() * z;
        }
    }
    acc * (1.0 / nz as f64) * (2.0 * PI / nphi as f64)
}

#[test]
fn diffuse_plane_under_an_envmap_reflects_its_cosine_weighted_integral() {
    let map = test_map();
    let to_world = Mat3::from_rotation_x(std::f32::consts::FRAC_PI_2) * Mat3::from_rotation_y(0.7);
    let env = EnvMap::new(&map, 1.5, to_world).unwrap();
    let want = cosine_integral(|d| env.eval(d)) * (0.5 / PI);
    for max_depth in [2, -1] {
        let out = render_desc(plane_scene(Light::Envmap { image: 0, scale: 1.5, to_world }, vec![map.clone()]), 256, max_depth);
        let m = mean_of(&out, 0, 16);
        assert!((m - want).abs().max_element() < 0.01 * want.max_element(), "max_depth {max_depth}: {m} vs {want}");
    }
}

#[test]
fn diffuse_plane_under_a_sunsky_reflects_its_cosine_weighted_integral() {
    let desc = SunSkyDesc { sun_direction: Vec3::new(0.4, -0.3, 0.6).normalize(), sun_aperture_deg: 2.0, ..Default::default() };
    let sky = SunSky::new(&SunSkyDesc { sun_scale: 0.0, ..desc.clone() }).unwrap();
    let sun = SunSky::new(&desc).unwrap();
    // the sun disk in closed form: L_sun times the cone's cosine-weighted solid angle
    // (≈ Ω cos θ_sun for a small disk; exact to 1e-4 at 1°)
    let half = (0.5f64 * desc.sun_aperture_deg as f64).to_radians();
    let omega = 2.0 * PI * (1.0 - (half.cos() as f32) as f64);
    let e_sun = sun.sun_radiance().as_dvec3() * omega * desc.sun_direction.z as f64;
    let want = (cosine_integral(|d| sky.eval(d)) + e_sun) * (0.5 / PI);
    let out = render_desc(plane_scene(Light::Sunsky(desc), vec![]), 256, 2);
    let m = mean_of(&out, 0, 16);
    assert!((m - want).abs().max_element() < 0.01 * want.max_element(), "{m} vs {want}");
}

#[test]
fn photons_from_environments_carry_the_total_power() {
    let map = test_map();
    let lights = vec![
        Light::Envmap { image: 0, scale: 2.0, to_world: Mat3::from_rotation_x(0.3) },
        Light::Sunsky(SunSkyDesc { sun_direction: Vec3::new(0.2, 0.3, 0.9).normalize(), sun_aperture_deg: 3.0, ..Default::default() }),
        Light::Constant { radiance: Color::splat(0.1) },
    ];
    let desc = SceneDesc { lights, images: vec![map], ..plane_scene(Light::Constant { radiance: Color::ZERO }, vec![]) };
    let scene = Scene::prepare(desc, BackendKind::Auto).unwrap();
    let set = &scene.lights;
    let (centre, radius) = set.scene_sphere();
    let n = 400_000;
    let mut s = Sampler::new(11, 0, 0);
    let mut acc = DVec3::ZERO;
    for _ in 0..n {
        let e = set.sample_emission(s.next_1d(), s.next_2d(), s.next_2d()).unwrap_or_else(|| panic!("no photon"));
        let oc = e.p - centre;
        assert!(oc.length() >= radius * 0.999 && oc.dot(e.dir) < 0.0, "photon must start outside and enter the scene");
        assert!(e.power.is_finite() && e.power.min_element() >= 0.0);
        acc += e.power.as_dvec3();
    }
    let mean = acc / n as f64;
    let total = set.total_power().as_dvec3();
    assert!((mean - total).abs().max_element() < 0.02 * total.max_element(), "{mean} vs {total}");
    // next-event samples agree with the environment radiance and mixture pdf
    for sel in [LightSelection::Tree, LightSelection::Power] {
        for _ in 0..2000 {
            if let Some(ls) = set.sample_li(sel, Vec3::ZERO, Vec3::Y, s.next_1d(), s.next_2d()) {
                assert!(ls.dist.is_infinite());
                assert!((ls.li - set.env_le(ls.wi)).abs().max_element() <= 1e-6 * ls.li.max_element().max(1.0));
                assert!((ls.pdf - set.pdf_li_env(sel, ls.wi)).abs() <= 1e-5 * ls.pdf);
            }
        }
    }
}
