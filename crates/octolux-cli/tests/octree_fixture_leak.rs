//! The light-fixture gap of Bitterli's Cornell box (`../shared/scenes/bitterli-cornell-box`,
//! `docs/octree.md` "Leak control"): the rectangle light hangs 0.02 under the ceiling, and the
//! octree's leaves (0.03–0.07 there) hold both the lit ceiling around the light and the dark
//! ceiling above it. The camera sees the ceiling in the gap between the light's front edge and
//! the ceiling. There the true irradiance is nearly 0 (the light's back is black and faces the
//! ceiling; light only enters through the 0.02 slit).
//!
//! The reference is computed here, by path tracing the irradiance at the same points (cosine-
//! weighted directions, `E = π · mean L`, Mitsuba's path tracer agrees with octolux's `path`
//! within noise, `agreement_mitsuba.rs`). The octree's irradiance with `leak = visible_origin`
//! and `visible_light` must stay within a bound of it, and the paper's blend (`leak = none`)
//! must leak there (else the test proves nothing); the default's (`visible_sample`, which
//! leaks there: neither opt-in test kept sponza's relMSE, `docs/octree.md`) is printed.

use glam::Vec3;
use octolux::accel::BackendKind;
use octolux::integrators::octree::{LeakTest, OctreeIntegrator, OctreeIntegratorSettings};
use octolux::integrators::path::PathSettings;
use octolux::integrators::RayCounters;
use octolux::math::{Frame, Ray};
use octolux::sampling::{square_to_cosine_hemisphere, Sampler};
use octolux::scene::Scene;

fn scene() -> Option<Scene> {
    let path = octolux_io::shared::shared_scene("bitterli-cornell-box/scene_mi3.xml")?;
    let loaded = octolux_io::load_scene(path.to_str().expect("utf-8 path"), &[]).expect("the scene loads");
    Some(Scene::prepare(loaded.desc, BackendKind::Auto).expect("the scene prepares"))
}

/// Ceiling points (hit from below, normal −Y towards the room) on a grid over `x`, `z`.
fn ceiling_points(scene: &Scene, xs: &[f32], zs: &[f32]) -> Vec<octolux::scene::SurfaceHit> {
    let mut out = Vec::new();
    for &x in xs {
        for &z in zs {
            let hit = scene.intersect(&Ray::new(Vec3::new(x, 1.99, z), Vec3::Y)).expect("the ceiling is above");
            assert!((hit.p.y - 2.0).abs() < 1e-3, "{:?}", hit.p);
            out.push(hit);
        }
    }
    out
}

/// Path-traced irradiance (mean of the channels) at `hit` for the normal −Y.
fn path_irradiance(scene: &Scene, hit: &octolux::scene::SurfaceHit, index: u64, n: u32) -> f64 {
    let settings = PathSettings::default();
    let frame = Frame::from_normal(-Vec3::Y);
    let mut counters = RayCounters::default();
    let mut sum = 0.0f64;
    for k in 0..n {
        let mut s = Sampler::new(7, index, k as u64);
        let wi = frame.to_world(square_to_cosine_hemisphere(s.next_2d()));
        let ray = hit.spawn(wi);
        let l = octolux::integrators::path::li(&settings, scene, ray, None, &mut s, &mut counters);
        sum += l.element_sum() as f64 / 3.0;
    }
    std::f64::consts::PI * sum / n as f64
}

/// The gap irradiance of the leak tests that aim at it (`visible_origin`, `visible_light`) may
/// exceed the path tracer's by this share of the lit ceiling's.
const BOUND: f64 = 0.1;

#[test]
fn the_light_fixture_gap_does_not_leak() {
    let Some(scene) = scene() else { return };
    // in the gap: above the light (x in [-0.24, 0.23], z in [-0.22, 0.16]), where the camera sees
    // the ceiling (z > 0.03); outside: the lit ceiling just in front of the light
    let gap = ceiling_points(&scene, &[-0.15, -0.05, 0.05, 0.15], &[0.06, 0.1, 0.14]);
    let lit = ceiling_points(&scene, &[-0.15, -0.05, 0.05, 0.15], &[0.3, 0.4]);
    let truth_gap = gap.iter().enumerate().map(|(i, h)| path_irradiance(&scene, h, i as u64, 2048)).sum::<f64>() / gap.len() as f64;
    let truth_lit = lit.iter().enumerate().map(|(i, h)| path_irradiance(&scene, h, 100 + i as u64, 512)).sum::<f64>() / lit.len() as f64;
    let mut s = OctreeIntegratorSettings::default();
    s.photons.photons = 1_000_000;
    let mut o = OctreeIntegrator::build(&scene, s).expect("octree builds");
    let mut mean = |leak: LeakTest, pts: &[octolux::scene::SurfaceHit]| {
        o.settings.leak = leak;
        let mut c = RayCounters::default();
        pts.iter()
            .map(|h| o.irradiance_at(&scene, &o.global, h, -Vec3::Y, &mut c).map_or(0.0, |e| e.element_sum() as f64 / 3.0))
            .sum::<f64>()
            / pts.len() as f64
    };
    let (origin_gap, origin_lit) = (mean(LeakTest::VisibleOrigin, &gap), mean(LeakTest::VisibleOrigin, &lit));
    let (light_gap, light_lit) = (mean(LeakTest::VisibleLight, &gap), mean(LeakTest::VisibleLight, &lit));
    let (sample_gap, none_gap) = (mean(LeakTest::VisibleSample, &gap), mean(LeakTest::None, &gap));
    println!(
        "fixture gap irradiance: path {truth_gap:.4}, octree visible_origin {origin_gap:.4}, visible_light {light_gap:.4}, \
         visible_sample (default) {sample_gap:.4}, none {none_gap:.4}; lit ceiling in front: path {truth_lit:.4}, octree \
         visible_origin {origin_lit:.4}, visible_light {light_lit:.4}"
    );
    assert!(none_gap > truth_gap + 0.2 * truth_lit, "the paper's blend should leak here: {none_gap} vs {truth_gap}");
    // measured (deterministic): path 0.0019, visible_origin 0.0234, visible_light 0.0211,
    // visible_sample 0.1788, none 0.1773, lit ceiling 0.2616 (path) and 0.2698 (octree): the
    // leak falls from 68% of the lit ceiling's irradiance to 8.2% (visible_origin) and 7.3%
    // (visible_light), not to the path tracer's 0.7%
    for (name, g, l) in [("visible_origin", origin_gap, origin_lit), ("visible_light", light_gap, light_lit)] {
        assert!(
            (g - truth_gap).abs() <= BOUND * truth_lit,
            "{name}: gap irradiance {g:.4} vs the path tracer's {truth_gap:.4} (lit ceiling {truth_lit:.4})"
        );
        assert!(g - truth_gap <= 0.25 * (sample_gap - truth_gap), "{name} {g:.4} against visible_sample {sample_gap:.4}");
        assert!((l / truth_lit - 1.0).abs() < 0.15, "{name}: lit ceiling {l:.4} vs {truth_lit:.4}");
    }
}
