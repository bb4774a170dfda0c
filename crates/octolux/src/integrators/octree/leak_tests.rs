//! The thin-wall test of the octree's leak control (`docs/guide/octree.md`, "Leak control"; paper
//! §7's blend is what leaks). Two closed rooms share a wall; a light hangs in the left one.
//! No light path reaches the right room, so the path tracer's irradiance there is exactly 0.
//! The octree's is measured on the dark side near the wall (floor, ceiling and the wall's
//! face) for walls 0.05 to 1 leaf thick, with each [`LeakTest`], relative to the mean
//! irradiance of the lit room's floor.

use super::{LeakTest, OctreeIntegrator, OctreeIntegratorSettings};
use crate::accel::BackendKind;
use crate::caches::octree::Depth;
use crate::integrators::test_scenes::quad;
use crate::integrators::RayCounters;
use crate::math::{Color, Ray};
use crate::scene::camera::{look_at, CameraDesc};
use crate::scene::material::{Material, Texture};
use crate::scene::{FilmDesc, Geometry, PixelFilter, Scene, SceneDesc, ShapeDesc, TriMesh};
use glam::{Mat4, Vec3};

/// Depth of the global tree in the test: leaves of edge 2/2^5 = 0.0625 near the surfaces.
const DEPTH: u32 = 5;

/// The rooms span x in [-1, 1], y and z in [0, 1]; the wall spans `[x_lit, x_lit + t]` and
/// pokes out of the box, so that the rooms share no opening.
pub(super) fn two_rooms(x_lit: f32, t: f32) -> Scene {
    let camera = look_at(Vec3::new(-0.5, 0.5, 0.9), Vec3::new(-0.5, 0.5, 0.0), Vec3::Y);
    Scene::prepare(two_rooms_desc(x_lit, t, camera, 8), BackendKind::Bvh).expect("valid two-room scene")
}

/// [`two_rooms`] seen by the camera `to_world` on a `res`² film.
fn two_rooms_desc(x_lit: f32, t: f32, to_world: Mat4, res: u32) -> SceneDesc {
    let mesh = |name: &str, centre: Vec3, half: Vec3, flip: bool| ShapeDesc {
        name: name.into(),
        geometry: Geometry::Mesh(TriMesh::cube(&(Mat4::from_translation(centre) * Mat4::from_scale(half)))),
        material: 0,
        emission: None,
        flip_normals: flip,
    };
    let light = Mat4::from_translation(Vec3::new(-0.5, 0.99, 0.5))
        * Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2)
        * Mat4::from_scale(Vec3::splat(0.15));
    SceneDesc {
        shapes: vec![
            mesh("rooms", Vec3::new(0.0, 0.5, 0.5), Vec3::new(1.0, 0.5, 0.5), true),
            mesh("wall", Vec3::new(x_lit + 0.5 * t, 0.5, 0.5), Vec3::new(0.5 * t, 0.52, 0.52), false),
            quad("light", light, 0, Some(Color::splat(20.0))),
        ],
        materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(0.6)) }],
        camera: CameraDesc { to_world, ..CameraDesc::default() },
        film: FilmDesc { width: res, height: res, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    }
}

/// The octree's global irradiance (mean of the channels) where the ray from `o` along `d`
/// lands, with the normal on the ray's side.
fn irradiance(o: &OctreeIntegrator, scene: &Scene, from: Vec3, d: Vec3, counters: &mut RayCounters) -> f64 {
    let hit = scene.intersect(&Ray::new(from, d)).expect("the rooms are closed");
    let n = crate::math::facing(hit.frame.n, -d);
    o.irradiance_at(scene, super::Tree::Global, &hit, n, counters).map_or(0.0, |e| e.element_sum() as f64 / 3.0)
}

struct Leak {
    /// Largest dark-side irradiance over the lit floor's mean.
    max: f64,
    /// Mean dark-side irradiance over the lit floor's mean.
    mean: f64,
    /// Lit floor's mean near the wall (within 1.5 leaves) over the lit floor's mean with
    /// `LeakTest::None`: leak control must not darken the lit side.
    lit_near_wall: f64,
}

fn measure(o: &OctreeIntegrator, scene: &Scene, x_lit: f32, t: f32, s: f32, lit_mean: f64) -> (Leak, f64) {
    let mut c = RayCounters::default();
    let x_dark = x_lit + t;
    let zs = [0.3f32, 0.5, 0.7];
    let mut dark = Vec::new();
    for d in [0.1f32, 0.3, 0.6, 1.0, 1.5] {
        let x = x_dark + d * s;
        for &z in &zs {
            dark.push(irradiance(o, scene, Vec3::new(x, 0.5, z), -Vec3::Y, &mut c));
            dark.push(irradiance(o, scene, Vec3::new(x, 0.5, z), Vec3::Y, &mut c));
        }
    }
    for y in [0.1f32, 0.5, 0.9] {
        for &z in &zs {
            dark.push(irradiance(o, scene, Vec3::new(x_dark + 0.5, y, z), -Vec3::X, &mut c));
        }
    }
    let mut lit = Vec::new();
    for d in [0.1f32, 0.5, 1.0, 1.5] {
        for &z in &zs {
            lit.push(irradiance(o, scene, Vec3::new(x_lit - d * s, 0.5, z), -Vec3::Y, &mut c));
        }
    }
    let floor: Vec<f64> = (0..8)
        .flat_map(|i| zs.map(|z| (i, z)))
        .map(|(i, z)| irradiance(o, scene, Vec3::new(-0.9 + 0.1 * i as f32, 0.5, z), -Vec3::Y, &mut c))
        .collect();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let lit_mean = if lit_mean > 0.0 { lit_mean } else { mean(&floor) };
    let leak = Leak {
        max: dark.iter().copied().fold(0.0, f64::max) / lit_mean,
        mean: mean(&dark) / lit_mean,
        lit_near_wall: mean(&lit) / lit_mean,
    };
    (leak, lit_mean)
}

/// Leakage through a thin wall per [`LeakTest`] and wall thickness (in leaves). The
/// visibility test must keep it at or under 1% of the lit floor's irradiance at every
/// thickness (the goal is 1% once the wall is one leaf thick), the paper's blend must leak
/// (else the test proves nothing), and the lit side near the wall must keep its light.
#[test]
fn thin_wall_leaks_at_most_one_percent_with_the_visibility_test() {
    let root = 2.0 * (1.0 + 2e-5); // the root cube's edge (`build.rs`, `cube_of`)
    let s = root / (1u32 << DEPTH) as f32;
    // the lit face 0.3 leaf inside a cell, not on a cell border
    let x_lit = -1.0 - 1e-5 * 2.0 + (16.0 + 0.3) * s;
    let mut worst_none = 0.0f64;
    eprintln!("thin wall (leaf {s:.4}): thickness/leaf, then per test max% / mean% of the lit floor, lit side near the wall");
    for t_leaves in [0.05f32, 0.1, 0.25, 0.5, 1.0] {
        let t = t_leaves * s;
        let scene = two_rooms(x_lit, t);
        let mut st = OctreeIntegratorSettings::default();
        st.photons.photons = 200_000;
        st.global.h_max = Depth::Fixed(DEPTH);
        st.global.n_max = 100;
        st.global.n_min = 10;
        let mut o = OctreeIntegrator::build(&scene, st).unwrap();
        let mut lit_mean = 0.0;
        let mut line = format!("{t_leaves:>5}:");
        let mut res = Vec::new();
        for leak in [LeakTest::None, LeakTest::VisibleSample] {
            o.settings.leak = leak;
            o.prepare(&scene);
            let (l, m) = measure(&o, &scene, x_lit, t, s, lit_mean);
            lit_mean = m;
            line += &format!("  {leak:?} {:.2}% / {:.2}% (lit {:.3})", 100.0 * l.max, 100.0 * l.mean, l.lit_near_wall);
            res.push(l);
        }
        eprintln!("{line}");
        let none = &res[0];
        worst_none = worst_none.max(none.max);
        for vis in &res[1..] {
            assert!(vis.max <= 0.01, "thickness {t_leaves} leaf: leak {:.2}% of the lit floor", 100.0 * vis.max);
            assert!(
                vis.lit_near_wall > 0.9 * none.lit_near_wall,
                "thickness {t_leaves}: lit side near the wall darkened from {:.3} to {:.3}",
                none.lit_near_wall,
                vis.lit_near_wall
            );
        }
    }
    assert!(worst_none > 0.05, "the paper's blend should leak here: {worst_none}");
}

/// The thin wall under the termination rule: a camera in the dark room looks at the wall and
/// the floor beside it. No light path reaches that room, so the path tracer's image is exactly
/// 0; the octree's is read one bounce from the camera, where leaves near the wall hold the lit
/// room's light. Measured (16², 16 spp, 200k photons), dark over lit room radiance (rendered the
/// same way from the mirror-image camera), for walls 0.05, 0.25 and 1 leaf thick, at `footprint`
/// 1: without a leak test (`leak = auto` on this scene) 1.04%, 0.83%, 0.32%; with
/// `visible_sample` 0.054%, 0, 0. At the default `footprint` 0.25: 0, 0, 0.23% and 0.055%, 0,
/// 0. One bounce from the camera a leak is a twentieth of what the direct read shows (the test
/// above: up to 20%). Bounds at either footprint: without a test at most 1.5%; `visible_sample`
/// under 0.25%; at `footprint` 1 the untested leak is at least 0.5% (else the test proves
/// nothing) and `visible_sample` removes four fifths of it.
#[test]
fn thin_wall_under_the_termination_rule() {
    use crate::integrators::Integrator;
    use crate::render::{render, RenderSettings};
    let root = 2.0 * (1.0 + 2e-5);
    let s = root / (1u32 << DEPTH) as f32;
    let x_lit = -1.0 - 1e-5 * 2.0 + (16.0 + 0.3) * s;
    let (mut worst_none, mut worst_test) = (0.0f64, 0.0f64);
    for (footprint, t_leaves) in [1.0f32, super::DEFAULT_FOOTPRINT].into_iter().flat_map(|k| [(k, 0.05f32), (k, 0.25), (k, 1.0)]) {
        let t = t_leaves * s;
        let x_dark = x_lit + t;
        // the cameras look at the wall from 0.4 away, down at 30°, from either side
        let dark_cam = look_at(Vec3::new(x_dark + 0.4, 0.5, 0.5), Vec3::new(x_dark, 0.27, 0.5), Vec3::Y);
        let lit_cam = look_at(Vec3::new(x_lit - 0.4, 0.5, 0.5), Vec3::new(x_lit, 0.27, 0.5), Vec3::Y);
        let mut st = OctreeIntegratorSettings::default();
        st.photons.photons = 200_000;
        st.global.h_max = Depth::Fixed(DEPTH);
        st.global.n_max = 100;
        st.global.n_min = 10;
        st.footprint = footprint;
        let mut line = format!("footprint {footprint}, thin wall {t_leaves} leaf, dark / lit room radiance:");
        for leak in [LeakTest::None, LeakTest::VisibleSample] {
            st.leak = leak;
            let mean = |cam: Mat4, lit: bool| {
                let scene = Scene::prepare(two_rooms_desc(x_lit, t, cam, 16), BackendKind::Bvh).expect("valid scene");
                let o = OctreeIntegrator::build(&scene, st.clone()).unwrap();
                let (img, stats) =
                    render(&scene, &Integrator::Octree(Box::new(o)), &RenderSettings { spp: 16, ..Default::default() }, &|_, _| {});
                // in the lit room paths end in the cache; in the dark one only where a leaf's light
                // passes the leak test (a path that finds no value there is traced on)
                assert!(!lit || stats.counters.cache_ends.iter().sum::<u64>() > 0, "no path ended in the cache");
                crate::integrators::test_scenes::image_mean(&img.data)
            };
            let (dark, lit) = (mean(dark_cam, false), mean(lit_cam, true));
            let ratio = dark / lit;
            line += &format!(" {leak:?} {:.3}%", 100.0 * ratio);
            if leak == LeakTest::None {
                assert!(
                    ratio <= 0.015,
                    "{t_leaves} leaf, no leak test: the dark room has {:.3}% of the lit room's radiance",
                    100.0 * ratio
                );
                if footprint == 1.0 {
                    worst_none = worst_none.max(ratio);
                }
            } else {
                assert!(ratio <= 0.0025, "{t_leaves} leaf: the dark room has {:.3}% of the lit room's radiance", 100.0 * ratio);
                if footprint == 1.0 {
                    worst_test = worst_test.max(ratio);
                }
            }
        }
        eprintln!("{line}");
    }
    assert!(worst_none > 0.005, "without a leak test the dark room should get light here: {worst_none}");
    assert!(worst_test < 0.2 * worst_none, "the leak test removes little: {worst_test} of {worst_none}");
}
