//! The octree re-estimated on its own topology (issue 26, item 2: an object inserted or moved
//! in a baked solution; `integrators/octree/insert.rs`, docs/guide/baking.md "Inserted
//! objects").
//!
//! [`Octree::refit`] keeps the tree's cube, depth and node array (which nodes are internal,
//! which are leaves) and assigns a new photon list to its leaves the way the build does (the
//! same Morton sort, the same binary searches on the key bits, the leaves numbered in the same
//! depth-first order): a leaf that gains photons becomes valid, one that loses them all
//! becomes atmospheric. Each valid leaf is then estimated as the build estimates it (`estimate.rs`),
//! from the photons of its enlarged cell and the surfaces in it.
//!
//! Given the boxes where anything changed (photons removed or added, surfaces moved), only the
//! leaves whose gathering box meets one of them are estimated; the others copy their value,
//! facing bits and anchors from the tree refitted. A leaf whose gathering box meets no change
//! gathers the same photons in the same order and clips the same surfaces, so its estimate
//! would be the same bits: the incremental result equals the full refit bit for bit (test
//! `an_incremental_update_equals_a_rebake_on_the_same_topology`). The atmospheric values
//! (`atmosphere.rs`) are not carried: a refitted tree has none. A tree without its leak test's
//! sampled photons ([`Octree::has_leak_samples`]) gives a refitted tree without them.

use super::build::{assemble, sort_assign_estimate, Frame, LeafOut, Leaves};
use super::cells::{quantize, LeafBuild};
use super::estimate::LeafState;
use super::sort::KeyFn;
use super::{Estimator, Octree, OctreeError, Surfaces, NO_VALUE};
use crate::math::Bounds3;
use crate::photon::Photon;
use glam::Vec3;

/// Where the input of a [`Octree::refit`] changed: boxes (a surface moved, added or removed)
/// and points (photons removed or added).
#[derive(Clone, Copy, Debug, Default)]
pub struct Changes<'a> {
    pub boxes: &'a [Bounds3],
    pub points: &'a [Vec3],
}

/// The states of the leaves a refit estimated, by node (`incremental.rs`).
pub(super) type Captured = Vec<(u32, Box<LeafState>)>;

/// What a [`Octree::refit`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RefitStats {
    /// Valid leaves estimated anew.
    pub estimated: usize,
    /// Valid leaves whose value was copied.
    pub copied: usize,
    /// Valid leaves whose sums the photons that moved updated ([`Octree::refit_incremental`]).
    pub updated: usize,
}

impl Octree {
    /// The leaf whose (half-open) cell holds `p`, with its depth and cell coordinates: the leaf
    /// the build's keys put it in; `None` outside the root cube.
    pub(super) fn leaf_node(&self, p: Vec3) -> Option<(u32, u32, [u32; 3])> {
        let (o, e) = (self.origin, self.origin + Vec3::splat(self.size));
        if !(p.cmpge(o).all() && p.cmple(e).all()) {
            return None;
        }
        let q = quantize(p, self.origin, self.inv_quant, self.h_max);
        let (mut node, mut depth) = (0u32, 0u32);
        loop {
            let n = self.nodes[node as usize];
            if n.is_leaf() || depth >= self.h_max {
                let s = self.h_max - depth;
                return Some((node, depth, [q[0] >> s, q[1] >> s, q[2] >> s]));
            }
            let s = self.h_max - depth - 1;
            node = n.link + (((q[0] >> s) & 1) | (((q[1] >> s) & 1) << 1) | (((q[2] >> s) & 1) << 2));
            depth += 1;
        }
    }

    /// This tree's root cube and depth, for a tree assembled on its topology from `photons`
    /// photons.
    pub(super) fn frame(&self, photons: usize) -> Frame {
        Frame {
            origin: self.origin,
            size: self.size,
            cell_size: self.cell_size,
            inv_quant: self.inv_quant,
            h: self.h_max,
            surface_area: self.stats.surface_area,
            photons,
        }
    }

    /// The largest box a leaf gathers from (`estimate.rs`: its cell enlarged by `1 + ε` about
    /// its centre, or the cell itself), padded by 1e-4 of it.
    pub(super) fn gather_bound(&self, depth: u32, ijk: [u32; 3]) -> Bounds3 {
        let s = self.cell_size[depth as usize];
        let centre = self.view().cell_min(depth, ijk) + Vec3::splat(0.5 * s);
        let half = Vec3::splat(0.5 * s * (1.0 + self.settings.epsilon.max(0.0)) * (1.0 + 1e-4));
        Bounds3 { min: centre - half, max: centre + half }
    }

    /// This tree's topology with `photons` (module docs). `surfaces`: the scene's, as the
    /// build takes them (needed by `Estimator::GeometryArea`). `changed`: the boxes outside which
    /// neither the photons nor the surfaces differ from those this tree was built from, and the
    /// photons removed or added; `None` estimates every leaf.
    pub fn refit(
        &self,
        photons: &[Photon],
        surfaces: Option<Surfaces<'_>>,
        changed: Option<Changes<'_>>,
    ) -> Result<(Octree, RefitStats), OctreeError> {
        self.refit_capture(photons, surfaces, changed, false).map(|(t, st, _)| (t, st))
    }

    /// [`Octree::refit`]; with `capture`, also the [`LeafState`]s of the leaves estimated, by
    /// node.
    pub(super) fn refit_capture(
        &self,
        photons: &[Photon],
        surfaces: Option<Surfaces<'_>>,
        changed: Option<Changes<'_>>,
        capture: bool,
    ) -> Result<(Octree, RefitStats, Captured), OctreeError> {
        let settings = &self.settings;
        if settings.estimator == Estimator::GeometryArea && surfaces.is_none() {
            return Err(OctreeError::MissingGeometry);
        }
        if photons.len() > u32::MAX as usize {
            return Err(OctreeError::TooManyPhotons(photons.len()));
        }
        let view = self.view();
        // the leaves holding a moved photon (the same node ids in the refitted tree)
        let mut marked = vec![false; self.nodes.len()];
        for &p in changed.map_or(&[][..], |c| c.points) {
            if let Some((node, ..)) = self.leaf_node(p) {
                marked[node as usize] = true;
            }
        }
        // a leaf is estimated when its gathering box, at its largest (`estimate.rs`: the cell
        // enlarged by `1 + ε` about its centre, or the cell itself), meets a changed box or a
        // leaf holding a moved photon: a superset of the leaves whose input changed
        let meets_change = |leaf: &LeafBuild| {
            let Some(c) = changed else { return true };
            let Bounds3 { min: lo, max: hi } = self.gather_bound(leaf.depth, leaf.ijk);
            if c.boxes.iter().any(|b| lo.cmple(b.max).all() && b.min.cmple(hi).all()) {
                return true;
            }
            let mut hit = false;
            view.visit(lo, hi, |node, _, _, _| hit |= marked[node as usize]);
            hit
        };
        let old_value = |leaf: &LeafBuild| self.nodes[leaf.node as usize].value();
        let select = |leaf: &LeafBuild| old_value(leaf) == NO_VALUE || meets_change(leaf);
        let kf = KeyFn { origin: self.origin, inv_quant: self.inv_quant, h: self.h_max };
        let which = Leaves::Fixed { topology: &self.nodes, select: &select, capture };
        let (tree, n_kept, est) = sort_assign_estimate(photons, kf, self.size, &self.cell_size, settings, surfaces, which);
        let mut stats = RefitStats::default();
        let mut states = Vec::new();
        let outs: Vec<LeafOut> = tree
            .valid
            .iter()
            .zip(est)
            .map(|(leaf, e)| match e {
                Some(mut e) => {
                    stats.estimated += 1;
                    states.extend(e.state.take().map(|s| (leaf.node, s)));
                    LeafOut::New(Box::new(e))
                }
                None => {
                    stats.copied += 1;
                    LeafOut::Old(self, old_value(leaf))
                }
            })
            .collect();
        let mut out = assemble(tree, n_kept, outs, self.frame(photons.len()), settings);
        // the copied leaves keep what this tree holds (only the means, when read so from a cache)
        out.leak_samples = self.leak_samples;
        Ok((out, stats, states))
    }
}
