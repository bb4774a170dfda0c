//! What the `octree` integrator's leak test precomputes per tree from the scene
//! (`docs/octree.md`, "Leak control"; paper §7's blend is what leaks): the leaf planes
//! ([`LeafPlanes`], most segments of the test answered without a ray) and, per sampled photon
//! of each valid leaf, its *reach*: how far the light it received travelled from the last
//! surface before it, up to [`REACH_MAX`] cell edges (the distance along the photon's incident
//! direction to the first surface: the surface that lit it, or the light). The test
//! [`super::LeakTest::VisibleOrigin`] looks from the query point at the photon's light
//! origin, a point on that segment, which therefore never lies behind the surface that lit the
//! photon (a floor photon lit by a wall a few millimetres away has its origin in front of the
//! wall, not in the next room). Each sample also gets the normal of the surface it lies on
//! (found by a ray back along its incident direction; the anchors keep only the incident
//! direction), so that the test counts only the samples on surfaces facing like the query
//! point's: the matrices a query reads hold the light of those (the split by normal).

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
    /// Per valid leaf, per sampled photon: its reach and normal (see the module docs).
    samples: Vec<[SampleReach; ANCHOR_SAMPLES]>,
}

impl LeakData {
    /// The planes of `tree` (built for `scene`), and its samples' reaches and normals when
    /// `reach` (two rays per sample; without them, [`LeakData::samples`] is `None` and the
    /// test that needs them casts those rays per query).
    pub fn new(scene: &Scene, tree: &Octree, planes: LeafPlanes, reach: bool) -> LeakData {
        let samples = if reach {
            tree.valid_leaves().par_iter().map(|q| q.samples.map(|(p, w)| SampleReach::new(scene, p, w, q.cell_size))).collect()
        } else {
            Vec::new()
        };
        LeakData { planes, samples }
    }

    /// The reaches and normals of valid leaf `index`'s samples, when computed.
    #[inline]
    pub fn samples(&self, index: u32) -> Option<&[SampleReach; ANCHOR_SAMPLES]> {
        self.samples.get(index as usize)
    }
}

/// A sampled photon's reach and surface normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleReach {
    /// Distance to the surface that lit it along its incident direction, world units, at most
    /// [`REACH_MAX`] cell edges ([`sample_reach`]).
    pub reach: f32,
    /// Unit normal of the surface it lies on, on the side its light came from; its incident
    /// direction where no surface is found ([`sample_normal`]).
    pub normal: Vec3,
}

impl SampleReach {
    /// Reach and normal of the sample at `p` with incident direction `w` in a leaf of edge
    /// `cell_size`.
    pub fn new(scene: &Scene, p: Vec3, w: Vec3, cell_size: f32) -> SampleReach {
        SampleReach { reach: sample_reach(scene, p, w, cell_size), normal: sample_normal(scene, p, w, cell_size) }
    }
}

/// The normal of the surface a sampled photon at `p` with incident direction `w` lies on:
/// a ray from [`REACH_SKIP`] cell edges along `w` back towards the photon, over up to three
/// times that (the quantised position's offset, divided by the incidence's cosine); `w` when
/// it finds nothing.
pub fn sample_normal(scene: &Scene, p: Vec3, w: Vec3, cell_size: f32) -> Vec3 {
    let skip = REACH_SKIP * cell_size;
    if w == Vec3::ZERO || !(skip > 0.0) {
        return w;
    }
    let ray = Ray::segment(p + w * skip, -w, 3.0 * skip);
    scene.intersect(&ray).map_or(w, |h| crate::math::facing(h.ng, w))
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
