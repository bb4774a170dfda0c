//! What the `octree` integrator's leak test precomputes per tree from the scene
//! (`docs/octree.md`, "Leak control"; paper §7's blend is what leaks): the leaf planes
//! ([`LeafPlanes`], most segments of the test answered without a ray) and, per sampled photon
//! of each valid leaf, its *reach*: how far the light it received travelled from the last
//! surface before it, up to [`REACH_MAX`] cell edges (the distance along the photon's incident
//! direction to the first surface: the surface that lit it, or the light). The test
//! [`super::octree::LeakTest::VisibleOrigin`] looks from the query point at the photon's light
//! origin, a point on that segment, which therefore never lies behind the surface that lit the
//! photon (a floor photon lit by a wall a few millimetres away has its origin in front of the
//! wall, not in the next room).

use crate::caches::octree::{LeafPlanes, ANCHOR_SAMPLES};
use crate::caches::Octree;
use crate::math::Ray;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// Longest reach kept, in cell edges of the leaf (the planes around a leaf cover segments
/// this long, [`LeafPlanes`]).
pub const REACH_MAX: f32 = 1.0;

/// Hits nearer than this (cell edges) along a sample's incident direction are taken for the
/// sample's own surface: the stored position is quantised to 1/256 of the cell (up to
/// ~0.0034 cell off the surface), seen at a grazing incidence down to ~0.07.
pub const REACH_SKIP: f32 = 0.05;

/// The per-tree data of the leak test: planes and sample reaches, computed once.
#[derive(Debug)]
pub struct LeakData {
    pub planes: LeafPlanes,
    /// Per valid leaf, per sampled photon: its reach in world units (see the module docs).
    reach: Vec<[f32; ANCHOR_SAMPLES]>,
}

impl LeakData {
    /// The planes and sample reaches of `tree` (built for `scene`).
    pub fn new(scene: &Scene, tree: &Octree, planes: LeafPlanes) -> LeakData {
        let reach = tree.valid_leaves().par_iter().map(|q| q.samples.map(|(p, w)| sample_reach(scene, p, w, q.cell_size))).collect();
        LeakData { planes, reach }
    }

    /// The reaches of valid leaf `index`'s samples (world units).
    #[inline]
    pub fn reach(&self, index: u32) -> Option<&[f32; ANCHOR_SAMPLES]> {
        self.reach.get(index as usize)
    }
}

/// Distance from a sampled photon at `p` along its incident direction `w` (unit, or zero) to
/// the first surface, at most [`REACH_MAX`] `cell_size`; hits nearer than [`REACH_SKIP`]
/// cell edges are ignored (the photon's own surface).
pub fn sample_reach(scene: &Scene, p: Vec3, w: Vec3, cell_size: f32) -> f32 {
    let (skip, max) = (REACH_SKIP * cell_size, REACH_MAX * cell_size);
    if w == Vec3::ZERO || !(max > skip) {
        return 0.0;
    }
    let ray = Ray::segment(p + w * skip, w, max - skip);
    scene.intersect(&ray).map_or(max, |h| skip + h.t)
}
