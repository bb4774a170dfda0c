//! The incremental re-bake (`rebake.rs`) against a full re-bake on the same topology, and an
//! inserted object's effect on the scene against path tracing.

use super::super::{OctreeIntegrator, OctreeIntegratorSettings};
use super::{ObjectMove, RebakeState};
use crate::caches::octree::Surfaces;
use crate::integrators::octree::estimator_surfaces;
use crate::integrators::path::PathSettings;
use crate::integrators::test_scenes::{box_scene, box_with_cube};
use crate::integrators::Integrator;
use crate::math::{Bounds3, Ray};
use crate::render::{render, RenderSettings};
use glam::Vec3;

fn cube_bounds(centre: Vec3, half: f32) -> Bounds3 {
    Bounds3 { min: centre - Vec3::splat(half), max: centre + Vec3::splat(half) }
}

fn baked(photons: u64) -> OctreeIntegrator {
    let mut s = OctreeIntegratorSettings::default();
    s.photons.photons = photons;
    OctreeIntegrator::build(&box_scene(8), s).unwrap()
}

/// A small cube inserted into the baked box, then moved: after the updates the photons
/// equal, photon for photon, a full pass traced in the scene with the cube, and both octrees
/// equal the re-bake of that scene on the same topology (`Octree::refit` of every leaf): the
/// same nodes and facing bits, the values within 1e-5 of each leaf's largest entry, the mean
/// anchors within one step of their quantisation. Each update traces a part of the paths
/// (measured: 1.4% and 2.1%); the photons they move land all over the closed box. The first
/// update estimates every leaf and keeps the sums; the second updates most leaves from the
/// photons that moved and estimates only those around the cube from their photons. A last
/// update that moves nothing (the cube where it is) copies the leaves away from the cube. Run
/// with the default estimator (per-photon weights from the lit surfaces) and with the paper's
/// (one weight per leaf, the octant sums).
#[test]
fn an_incremental_update_equals_a_rebake_on_the_same_topology() {
    use crate::caches::octree::{LeafValueParts, Storage};
    use crate::caches::{Estimator, Split};
    for (estimator, split) in [(Estimator::GeometryArea, Split::Normal), (Estimator::Paper, Split::Direction)] {
        let bake = || {
            let mut s = OctreeIntegratorSettings::default();
            s.photons.photons = 60_000;
            (s.global.estimator, s.global.split, s.global.storage) = (estimator, split, Storage::Full);
            OctreeIntegrator::build(&box_scene(8), s).unwrap()
        };
        let base = box_scene(8);
        let mut inc = bake();
        let mut state = RebakeState::new(inc.photon_paths(&base).unwrap());
        assert_eq!(state.paths().global(), &crate::photon::trace::trace_photons(&base, &inc.settings.traced_photons()).unwrap().global[..]);
        let (a, b, half) = (Vec3::new(-0.6, 0.08, -0.6), Vec3::new(-0.45, 0.08, -0.55), 0.08);
        let (scene_a, first) = box_with_cube(a, Vec3::splat(half), 8);
        let (scene_b, _) = box_with_cube(b, Vec3::splat(half), 8);
        let (ba, bb) = ([cube_bounds(a, half)], [cube_bounds(b, half)]);
        let shapes = first..first + 1;
        let st_a = inc.rebake(&mut state, &scene_a, &ObjectMove { was: &[], now: &ba, shapes: shapes.clone() }).unwrap();
        let st_b = inc.rebake(&mut state, &scene_b, &ObjectMove { was: &ba, now: &bb, shapes: shapes.clone() }).unwrap();
        let st_c = inc.rebake(&mut state, &scene_b, &ObjectMove { was: &bb, now: &bb, shapes }).unwrap();
        eprintln!("{estimator:?}: insert: {st_a:?}\nmove: {st_b:?}\nstay: {st_c:?}");
        for st in [&st_a, &st_b] {
            assert!(st.paths_retraced > 0 && st.paths_retraced < st.paths / 10 && st.photons_moved > 0, "{st:?}");
        }
        assert!(st_a.leaves_updated == 0 && st_a.leaves_copied == 0, "the first update estimates every leaf: {st_a:?}");
        assert!(st_b.leaves_updated > 5 * st_b.leaves_estimated, "{st_b:?}");
        assert!(st_c.photons_moved == 0 && st_c.leaves_estimated > 0 && st_c.leaves_copied > 10 * st_c.leaves_estimated, "{st_c:?}");

        // the reference: every path traced in scene B, every leaf of the baked topology estimated
        let full = bake();
        let mut all = full.photon_paths(&base).unwrap();
        let ids: Vec<u32> = (0..all.len() as u32).collect();
        all.retrace(&scene_b, &ids).unwrap();
        let (g1, g2) = (state.paths().global(), all.global());
        if let Some(i) = g1.iter().zip(g2).position(|(a, b)| a != b) {
            panic!("{} and {} global photons, first difference at {i}: {:?} against {:?}", g1.len(), g2.len(), g1[i], g2[i]);
        }
        assert_eq!(g1.len(), g2.len(), "global photons");
        assert!(state.paths().caustic() == all.caustic(), "caustic photons");
        let (tris, spheres) = estimator_surfaces(&scene_b);
        let surfaces = Some(Surfaces { triangles: &tris, spheres: &spheres });
        let (global, st) = full.global.refit(all.global(), surfaces, None).unwrap();
        assert_eq!(st.copied, 0);
        let (want, got) = (global.to_parts().without_leak_samples(), inc.global.to_parts());
        assert_eq!(want.nodes, got.nodes, "nodes");
        assert_eq!(want.facing, got.facing, "facing bits");
        let (LeafValueParts::Full(wv), LeafValueParts::Full(gv)) = (&want.values, &got.values) else { panic!("full storage") };
        assert_eq!(wv.len(), gv.len());
        let mut worst = 0.0f32;
        for (w, g) in wv.iter().zip(gv) {
            let scale = w.iter().map(|m| m.abs().to_cols_array().into_iter().fold(0.0f32, f32::max)).fold(0.0f32, f32::max);
            for (mw, mg) in w.iter().zip(g) {
                let d = (*mw - *mg).abs().to_cols_array().into_iter().fold(0.0f32, f32::max);
                worst = worst.max(d / scale.max(1e-30));
            }
        }
        eprintln!("{estimator:?}: largest difference {worst:.2e} of a leaf's largest entry");
        assert!(worst <= 1e-5, "{estimator:?}: values differ by {worst:e} of a leaf's largest entry");
        let step = |a: &[u8; 3], b: &[u8; 3]| a.iter().zip(b).all(|(x, y)| x.abs_diff(*y) <= 1);
        let nstep = |a: &[i8; 3], b: &[i8; 3]| a.iter().zip(b).all(|(x, y)| x.abs_diff(*y) <= 1);
        for (w, g) in want.anchors.iter().zip(&got.anchors) {
            assert!(step(&w.mean.pos, &g.mean.pos) && nstep(&w.mean.normal, &g.mean.normal), "anchors {w:?} against {g:?}");
        }
        assert_eq!(global.stats().valid_leaves, inc.global.stats().valid_leaves);
        assert!(full.caustic.is_none() && inc.caustic.is_none(), "no caustic tree in the box");
    }
}

/// Mean of the pixels `mask` keeps.
fn masked_mean(img: &crate::image::Image, mask: &[bool]) -> f64 {
    let (sum, n) =
        mask.iter().zip(&img.data).filter(|(m, _)| **m).fold((0.0, 0usize), |(s, n), (_, c)| (s + c.element_sum() as f64 / 3.0, n + 1));
    sum / n.max(1) as f64
}

/// A box standing on the floor of the baked Cornell box, rendered from the bake updated for it
/// (`rebake`) and by the path tracer with the box present: on the box's pixels and on the floor
/// pixels around it (its indirect shadow), the means within 5% of the path tracer's. The bake
/// without the update lights the floor as if the box were absent: its indirect light there
/// is too bright, which the update removes.
#[test]
fn a_rebaked_insertion_matches_path_tracing_on_the_object_and_around_it() {
    let res = 32u32;
    let base = box_scene(8);
    let mut o = baked(400_000);
    let mut state = RebakeState::new(o.photon_paths(&base).unwrap());
    let (centre, half) = (Vec3::new(0.1, 0.3, -0.2), 0.3);
    let (scene, first) = box_with_cube(centre, Vec3::splat(half), res);
    let mut stale = OctreeIntegrator::from_parts(o.to_parts()).unwrap();
    stale.prepare(&base);
    let stale = Integrator::Octree(Box::new(stale));
    o.rebake(&mut state, &scene, &ObjectMove { was: &[], now: &[cube_bounds(centre, half)], shapes: first..first + 1 }).unwrap();
    let rs = RenderSettings { spp: 32, ..Default::default() };
    let (img, _) = render(&scene, &Integrator::Octree(Box::new(o)), &rs, &|_, _| {});
    let (old, _) = render(&scene, &stale, &rs, &|_, _| {});
    let (truth, _) =
        render(&scene, &Integrator::Path(PathSettings::default()), &RenderSettings { spp: 512, ..Default::default() }, &|_, _| {});
    // the camera ray's first hit: on the cube, or on the floor within 0.35 of its footprint
    let hits: Vec<_> = (0..res * res)
        .map(|i| {
            let (x, y) = ((i % res) as f32 + 0.5, (i / res) as f32 + 0.5);
            let (o, d, _) = scene.camera.generate_ray(glam::Vec2::new(x, y));
            scene.intersect(&Ray::new(o, d))
        })
        .collect();
    let on_cube: Vec<bool> = hits.iter().map(|h| h.as_ref().is_some_and(|h| h.shape == first)).collect();
    let near = |p: Vec3| p.y < 1e-3 && (p.x - centre.x).abs() < half + 0.35 && (p.z - centre.z).abs() < half + 0.35;
    let around: Vec<bool> = hits.iter().map(|h| h.as_ref().is_some_and(|h| h.shape != first && near(h.p))).collect();
    let count = |m: &[bool]| m.iter().filter(|&&b| b).count();
    assert!(count(&on_cube) > 40 && count(&around) > 20, "{} cube, {} floor pixels", count(&on_cube), count(&around));
    for (what, mask) in [("cube", &on_cube), ("floor around it", &around)] {
        let (a, s, t) = (masked_mean(&img, mask), masked_mean(&old, mask), masked_mean(&truth, mask));
        eprintln!("{what}: rebaked {a:.4}, stale bake {s:.4}, path {t:.4} (ratios {:.3}, {:.3})", a / t, s / t);
        assert!((a / t - 1.0).abs() < 0.05, "{what}: rebaked {a} against path {t}");
    }
}

/// The clusters' slab tests pass over no segment that meets a triangle: random segments, short
/// and crossing the whole scene, near a sphere of 288 triangles, against testing every
/// triangle (at least 2 000 of each kind, meeting and missing).
#[test]
fn the_cluster_test_misses_no_triangle_a_segment_meets() {
    use super::{segment_meets_triangle, TriangleClusters};
    use crate::sampling::{square_to_uniform_sphere, Sampler};
    // a UV sphere of radius 1 about the origin: 16 × 10 quads
    let at = |i: u32, j: u32| {
        let (th, ph) = (std::f32::consts::PI * j as f32 / 10.0, std::f32::consts::TAU * i as f32 / 16.0);
        Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    // (the poles' degenerate triangles left out: the segment test's "in doubt" answers them
    // by bounding boxes, which no slab test reproduces, and no ray can hit them)
    let tris: Vec<[Vec3; 3]> = (0..16)
        .flat_map(|i| (0..10).flat_map(move |j| [[at(i, j), at(i + 1, j), at(i + 1, j + 1)], [at(i, j), at(i + 1, j + 1), at(i, j + 1)]]))
        .filter(|t| (t[1] - t[0]).cross(t[2] - t[0]).length() > 1e-6)
        .collect();
    let clusters = TriangleClusters::new(&tris, Vec3::splat(1e-4));
    let mut s = Sampler::new(3, 0, 0);
    let (mut meets, mut misses) = (0, 0);
    for k in 0..20_000 {
        let a = square_to_uniform_sphere(s.next_2d()) * (0.5 + 2.0 * s.next_1d());
        let len = if k % 2 == 0 { 0.3 } else { 50.0 };
        let b = a + square_to_uniform_sphere(s.next_2d()) * len;
        let truth = tris.iter().any(|t| segment_meets_triangle(a, b, t));
        assert!(!truth || clusters.meets(&tris, a, b), "segment {a} to {b} meets a triangle, the clusters say no");
        if truth {
            meets += 1;
        } else {
            misses += 1;
        }
    }
    assert!(meets > 2_000 && misses > 2_000, "{meets} segments meet, {misses} miss");
}
