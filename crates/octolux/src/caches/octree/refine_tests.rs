//! Tests of the free-space refinement (`refine.rs`): it splits where the flights' light
//! changes and nowhere else, leaves every surface query as it was, and the tree it leaves
//! reads back from its parts.

use super::*;
use crate::caches::octree::{Estimator, FlightSums, OctreeSettings};
use crate::math::Bounds3;
use crate::photon::Photon;
use crate::sampling::{square_to_uniform_sphere, Sampler};

/// Photons on a floor `y = 0.02` of the unit cube (so that the cells above it stay large
/// and atmospheric), lit from above.
fn floor_tree() -> Octree {
    let g = 200;
    let mut photons = Vec::new();
    for i in 0..g {
        for j in 0..g {
            let p = Vec3::new((i as f32 + 0.5) / g as f32, 0.02, (j as f32 + 0.5) / g as f32);
            photons.push(Photon { p, wi: Vec3::Y, power: Vec3::splat(1e-3), ng: Vec3::Y });
        }
    }
    let settings = OctreeSettings { estimator: Estimator::Cosine, ..Default::default() };
    Octree::build(&photons, Bounds3 { min: Vec3::ZERO, max: Vec3::ONE }, &settings, None).unwrap()
}

/// `n` vertical flights of power 1 down from the top of the cube to the floor, at random
/// points of `x < x_max`: uniform light over that slab, none beside it.
fn slab_flights(x_max: f32, n: u64, seed: u64) -> Vec<(Vec3, Vec3, f32, Vec3)> {
    (0..n)
        .map(|i| {
            let mut s = Sampler::new(seed, i, 0);
            let o = Vec3::new(x_max * s.next_1d(), 1.0, s.next_1d());
            (o, Vec3::NEG_Y, 0.98, Vec3::ONE)
        })
        .collect()
}

/// The flights in chunks of 4096, summed per octant: the caller's side of `refine_free_space`.
fn sums(tree: &Octree, flights: &[(Vec3, Vec3, f32, Vec3)]) -> Vec<OctantSums> {
    flights.chunks(4096).map(|c| tree.octant_sums(c.iter().copied())).collect()
}

fn depth_at(tree: &Octree, p: Vec3) -> u32 {
    tree.find_leaf(p).unwrap().1
}

/// Light in the slab `x < 0.3` only: the atmospheric cells the slab's border crosses are
/// split, those wholly inside it or wholly dark are not.
#[test]
fn free_space_is_split_where_its_light_changes_and_only_there() {
    let mut tree = floor_tree();
    let before = tree.clone();
    let flights = slab_flights(0.3, 200_000, 1);
    let st = tree.refine_free_space(|t| sums(t, &flights));
    eprintln!("{st:?}; leaves {} -> {}, max depth {}", before.stats().leaves, tree.stats().leaves, tree.stats().max_depth);
    assert!(st.split_leaves > 0, "{st:?}");
    assert_eq!(tree.stats().leaves, before.stats().leaves + 7 * st.split_leaves);
    assert_eq!(tree.stats().nodes, before.stats().nodes + 8 * st.split_leaves);
    assert_eq!(tree.stats().max_depth, before.stats().max_depth);
    for y in [0.6, 0.8] {
        for x in [0.29, 0.31] {
            let p = Vec3::new(x, y, 0.7);
            assert!(depth_at(&tree, p) > depth_at(&before, p), "{p}: at the border, not split");
        }
        // wholly lit: split only as far as the border's cells were (the cell [0, 0.25])
        let p = Vec3::new(0.1, y, 0.7);
        assert!(depth_at(&tree, p) <= 2, "{p}: depth {}", depth_at(&tree, p));
        // wholly dark, and far from the border: as before
        let p = Vec3::new(0.8, y, 0.7);
        assert_eq!(depth_at(&tree, p), depth_at(&before, p), "{p}");
    }
    // the refined tree's flight estimate: light in the lit cells, none in a dark cell beside
    // the border
    let f = tree.flights_from(sums_flights(&tree, &flights));
    let lit = tree.find_leaf(Vec3::new(0.2, 0.6, 0.5)).unwrap().0;
    let dark = tree.find_leaf(Vec3::new(0.34, 0.6, 0.5)).unwrap().0;
    assert_ne!(f.index[lit as usize], u32::MAX, "the lit cell took its flights");
    assert_eq!(f.index[dark as usize], u32::MAX, "the dark cell beside the border has none");
}

fn sums_flights(tree: &Octree, flights: &[(Vec3, Vec3, f32, Vec3)]) -> Vec<FlightSums> {
    flights.chunks(4096).map(|c| tree.flight_sums(c.iter().copied())).collect()
}

/// Uniform light everywhere (isotropic uniform random lines through the cube: each a
/// direction uniform on the sphere and a point uniform on the disc across it): the octants
/// differ by noise alone, and nothing is split.
#[test]
fn uniform_free_space_light_splits_nothing() {
    let mut tree = floor_tree();
    let flights: Vec<_> = (0..200_000u64)
        .map(|i| {
            let mut s = Sampler::new(9, i, 0);
            let d = square_to_uniform_sphere(s.next_2d());
            let (e1, e2) = d.any_orthonormal_pair();
            let (r, phi) = (s.next_1d().sqrt(), std::f32::consts::TAU * s.next_1d());
            let o = Vec3::splat(0.5) + (e1 * phi.cos() + e2 * phi.sin()) * r - d * 2.0;
            (o, d, 4.0, Vec3::ONE)
        })
        .collect();
    let st = tree.refine_free_space(|t| sums(t, &flights));
    assert_eq!(st.split_leaves, 0, "{st:?}");
    assert_eq!(st.rounds, 1);
}

/// The refined tree answers every surface query as before, bit for bit, and reads back from
/// its parts as it is (its nodes in the order a cache file rebuilds them).
#[test]
fn a_refined_tree_keeps_its_surface_queries_and_reads_back() {
    let mut tree = floor_tree();
    let before = tree.clone();
    let flights = slab_flights(0.3, 100_000, 2);
    assert!(tree.refine_free_space(|t| sums(t, &flights)).split_leaves > 0);
    for i in 0..400u64 {
        let mut s = Sampler::new(3, i, 0);
        let p = Vec3::new(s.next_1d(), 0.02, s.next_1d());
        assert_eq!(tree.irradiance(p, Vec3::Y), before.irradiance(p, Vec3::Y), "{p}");
    }
    let parts = tree.to_parts();
    let back = Octree::from_parts(parts.clone()).unwrap();
    assert_eq!(back.to_parts(), parts);
    // the canonical order: children allocated as the depth-first walk reaches their parent
    let mut next = 1u32;
    let mut stack = vec![0u32];
    while let Some(id) = stack.pop() {
        let n = tree.nodes[id as usize];
        if !n.is_leaf() {
            assert_eq!(n.link, next, "node {id}");
            stack.extend((0..8).rev().map(|c| next + c));
            next += 8;
        }
    }
    assert_eq!(next as usize, tree.nodes.len());
}
