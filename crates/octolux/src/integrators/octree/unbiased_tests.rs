//! `mode = unbiased` (the residual estimator): its mean is the path tracer's whatever the
//! cache holds. Each check is a z-test over independent renders (render seeds 0..K): the
//! spread of their image means gives the standard error, so a bias shows as a large |z|.

use super::*;
use crate::integrators::path::PathSettings;
use crate::integrators::test_scenes::{box_desc, furnace_box_scene, image_mean};
use crate::integrators::Integrator;
use crate::math::Color;
use crate::render::{render, RenderSettings};
use crate::scene::material::{Material, MicrofacetKind, Roughness, Texture};
use crate::scene::SceneDesc;
use glam::Vec3;

/// Mean and standard error of the image means of `k` renders with seeds `0..k`.
fn means(scene: &Scene, integrator: &Integrator, spp: u32, k: u64) -> (f64, f64) {
    let m: Vec<f64> = (0..k)
        .map(|seed| {
            let (img, _) = render(scene, integrator, &RenderSettings { spp, seed, ..Default::default() }, &|_, _| {});
            assert!(img.data.iter().all(|c| c.is_finite()), "a non-finite pixel");
            image_mean(&img.data)
        })
        .collect();
    let mean = m.iter().sum::<f64>() / k as f64;
    let var = m.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (k - 1) as f64;
    (mean, (var / k as f64).sqrt())
}

/// z of the difference of two independent (mean, standard error) pairs.
fn z(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - b.0) / (a.1 * a.1 + b.1 * b.1).sqrt()
}

fn octree(scene: &Scene, mode: Mode, q: f32, photons: u64) -> Integrator {
    let mut s = OctreeIntegratorSettings { mode, q, ..Default::default() };
    s.photons.photons = photons;
    Integrator::Octree(Box::new(OctreeIntegrator::build(scene, s).unwrap()))
}

fn path() -> Integrator {
    Integrator::Path(PathSettings { max_depth: -1, rr_depth: 5, ..Default::default() })
}

/// The test box (`test_scenes::box_desc`) at `res`² pixels with its light `scale` times as
/// bright.
fn box_with_light(res: u32, scale: f32) -> Scene {
    let mut d: SceneDesc = box_desc();
    d.film.width = res;
    d.film.height = res;
    for s in &mut d.shapes {
        if let Some(e) = &mut s.emission {
            *e *= scale;
        }
    }
    Scene::prepare(d, crate::accel::BackendKind::Bvh).unwrap()
}

/// The furnace (radiance 2 everywhere) under `mode = unbiased`, for q = 20 (every path traced on), 1 and 0.1: the
/// image mean's z against 2 stays within 4.
#[test]
fn unbiased_furnace_is_exact() {
    let scene = furnace_box_scene(0.5, 1.0);
    for q in [20.0, 1.0, 0.1] {
        let (m, se) = means(&scene, &octree(&scene, Mode::Unbiased, q, 50_000), 4, 24);
        let z = (m - 2.0) / se;
        eprintln!("unbiased furnace, q {q}: {m:.5} ± {se:.5} (2), z {z:.2}");
        assert!(z.abs() < 4.0, "q {q}: mean {m} ± {se}, expected 2");
    }
}

/// A cache baked with the light at twice its radiance: `mode = terminate` renders the box
/// far too bright, `mode = unbiased` converges to the path tracer's image (z within 4 at
/// q = 1 and 0.1, where terminate's z passes 10): the residual corrects whatever the cache
/// holds, and the linear control variate of the diffuse walls has the cache's value as its mean.
#[test]
fn unbiased_with_a_cache_baked_at_twice_the_light_converges_to_path() {
    let (truth_scene, bright) = (box_with_light(16, 1.0), box_with_light(16, 2.0));
    let k = 8;
    let p = means(&truth_scene, &path(), 16, k);
    let wrong = |mode: Mode, q: f32| {
        let mut s = OctreeIntegratorSettings { mode, q, ..Default::default() };
        s.photons.photons = 100_000;
        Integrator::Octree(Box::new(OctreeIntegrator::build(&bright, s).unwrap()))
    };
    let t = means(&truth_scene, &wrong(Mode::Terminate, 1.0), 16, k);
    eprintln!("path {:.5} ± {:.5}; terminate with the 2x cache {:.5} ± {:.5}, z {:.1}", p.0, p.1, t.0, t.1, z(t, p));
    assert!(z(t, p) > 10.0, "the stale cache should bias terminate: {t:?} vs {p:?}");
    for q in [1.0, 0.1] {
        let u = means(&truth_scene, &wrong(Mode::Unbiased, q), 16, k);
        eprintln!("unbiased with the 2x cache, q {q}: {:.5} ± {:.5}, z {:.2}", u.0, u.1, z(u, p));
        assert!(z(u, p).abs() < 4.0, "q {q}: {u:?} vs path {p:?}");
    }
}

/// Glossy, glass and mirror surfaces (the constant control variate, caustics through a glass
/// sphere, narrow lobes traced on): the unbiased mode agrees with the path tracer (z within 4).
#[test]
fn unbiased_agrees_with_path_on_glossy_and_glass() {
    let mut d = box_desc();
    d.film.width = 16;
    d.film.height = 16;
    let rough = |alpha: f32| Roughness {
        kind: MicrofacetKind::Ggx,
        alpha_u: Texture::Const(Color::splat(alpha)),
        alpha_v: Texture::Const(Color::splat(alpha)),
    };
    // the floor becomes rough plastic, the back wall rough metal (wide), a sphere glass, one metal
    d.materials.push(Material::RoughPlastic {
        diffuse_reflectance: Texture::Const(Color::splat(0.5)),
        specular_reflectance: Color::ONE,
        distribution: crate::scene::material::Microfacet { kind: MicrofacetKind::Ggx, alpha_u: 0.4, alpha_v: 0.4 },
        eta: 1.5,
        nonlinear: false,
    });
    d.materials.push(Material::RoughConductor {
        distribution: rough(0.5),
        eta: Color::ZERO,
        k: Color::ZERO,
        specular_reflectance: Color::splat(0.8),
    });
    d.materials.push(Material::Dielectric { eta: 1.5, specular_reflectance: Color::ONE, specular_transmittance: Color::ONE });
    d.shapes[0].material = 3;
    d.shapes[2].material = 4;
    let sphere = |c: Vec3, m: u32| crate::scene::ShapeDesc {
        name: "sphere".into(),
        geometry: crate::scene::Geometry::Sphere { center: c, radius: 0.3 },
        material: m,
        emission: None,
        flip_normals: false,
    };
    d.shapes.push(sphere(Vec3::new(-0.3, 0.3, -0.3), 5));
    let scene = Scene::prepare(d, crate::accel::BackendKind::Bvh).unwrap();
    let k = 8;
    let p = means(&scene, &path(), 16, k);
    let u = means(&scene, &octree(&scene, Mode::Unbiased, 0.5, 100_000), 16, k);
    eprintln!("glossy and glass: path {:.5} ± {:.5}, unbiased {:.5} ± {:.5}, z {:.2}", p.0, p.1, u.0, u.1, z(u, p));
    assert!(z(u, p).abs() < 4.0, "{u:?} vs path {p:?}");
}
