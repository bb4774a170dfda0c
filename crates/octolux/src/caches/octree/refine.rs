//! Free space subdivided where its light changes: atmospheric leaves split by the photons'
//! flights (issue 26, item 1; docs/guide/baking.md, "A volumetric solution").
//!
//! The paper subdivides a cell only while it holds more than `n_max` photons (§3), so free
//! space, which holds none, keeps the large cells that the surfaces' subdivision leaves
//! around them. A flight estimate (`flights.rs`) is the mean over its cell: a cell that holds
//! the lit space under a lamp and a dark corner gives both the same value (measured: on
//! sponza, a fifth of the free points read over twice their path-traced indirect light).
//!
//! # The test
//! The flights crossing an atmospheric leaf give each of its eight octants `c` a mean fluence
//! `F_c = Σ x / V_c` (`x = Φ̄ ℓ`: the flight's power, channel mean, times its length in the
//! octant; `V_c` the octant's volume), with variance `σ_c² ≈ Σ x² / V_c²`. Splitting the leaf
//! replaces its mean `F̄` by the eight `F_c`. Summed over the octants, the expected squared
//! error goes from `D* + N/8` (the octants' true departure from their mean, plus the noise of
//! the mean) to `N = Σ σ_c²`; `D = Σ (F_c − F̄)²` estimates `D* + 7N/8`. So splitting pays
//! when `D − 7N/4 > 0`. The leaf is split when that gain exceeds
//! `8 τ² (F̄² + (ε F_ref)²)`: a relative departure [`REFINE_TAU`] per octant, against the
//! leaf's own light and, in dim space, a fraction [`REFINE_FLOOR`] of the mean free-space
//! fluence `F_ref` (a comparison's relMSE weighs errors the same way: relative, with a floor).
//! It must also be crossed at least `8 ×` [`FLIGHT_MIN`] times, so that its octants can take
//! their own estimate.
//!
//! Rounds (each with the flights of the same photon paths, traced again by the caller) until
//! no leaf splits, down to the depth of the deepest leaf: the query box (`alpha` times the
//! smallest leaf) is unchanged, and so is every surface query (an atmospheric leaf holds no
//! photon; its eight children hold none either).
//!
//! # The free-space tree
//! Refining the surface tree's own atmospheric leaves leaves out the free space inside its
//! valid leaves' cells: near every surface, and in a small room almost everywhere (the
//! Bitterli box: 266 of 300 free points; read as their surface, relMSE 0.43 there). So the
//! volumetric solution is a tree of its own ([`Octree::free_space_tree`]): the surface tree's
//! root cube, cut uniformly to depth [`FREE_SPACE_BASE_DEPTH`], every leaf atmospheric, then
//! refined by the test above. A cell that a wall cuts has octants the flights reach and
//! octants they do not, so the test splits it towards the wall; its flight estimate then
//! reads the light on the wall's open side. The flights' centroid in each leaf (`flights.rs`)
//! is its anchor for the leak test, so that a cell that holds a sliver of a room and the
//! sunlit space behind its wall does not light the room.
//!
//! # Determinism
//! The caller's chunks are added in order, in f64; the nodes are laid out again in the order a
//! cache file reads them (children allocated depth first): bit-identical for any thread count.

use super::flights::FLIGHT_MIN;
use super::{Node, Octree, OctreeStats, LEAF_BIT, NO_VALUE};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};

/// Relative departure of an atmospheric leaf's octants from its mean that a split must gain
/// per octant (module docs).
pub const REFINE_TAU: f64 = 0.1;
/// The floor of the relative test in dim space, as a fraction of the mean free-space fluence.
pub const REFINE_FLOOR: f64 = 0.1;
/// Depth of the uniform start of a free-space tree ([`Octree::free_space_tree`]): 512 cells.
/// Measured (docs/lab/2026-12-06-free-space-tree.md): on the Bitterli box, starting from the
/// surface tree's own cells gave the same error with 2.8x the bytes, from depth 4 1.7x.
pub const FREE_SPACE_BASE_DEPTH: u32 = 3;

/// One chunk of flights summed per octant of the atmospheric leaves they cross
/// ([`Octree::octant_sums`]), for [`Octree::refine_free_space`].
#[derive(Clone, Debug, Default)]
pub struct OctantSums {
    /// (node × 8 + octant, `Σ x`, `Σ x²`, crossings), sorted by key.
    sums: Vec<(u64, f64, f64, u32)>,
}

/// What [`Octree::refine_free_space`] did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RefineStats {
    /// Rounds of flights (the last one split nothing, or reached the depth limit).
    pub rounds: u32,
    /// Atmospheric leaves split in eight.
    pub split_leaves: usize,
    /// Seconds, flights included.
    pub t_s: f64,
}

/// The pieces of the segment `o + t d`, `t ∈ [t0, t1]`, in the octants of the cell whose
/// centre is `mid`: `f(octant, length in units of t)`.
fn octant_pieces(o: Vec3, d: Vec3, mid: Vec3, t0: f32, t1: f32, mut f: impl FnMut(usize, f32)) {
    let mut ts = [t0, t1, t1, t1, t1];
    let mut k = 1;
    for a in 0..3 {
        if d[a] != 0.0 {
            let t = (mid[a] - o[a]) / d[a];
            if t > t0 && t < t1 {
                ts[k] = t;
                k += 1;
            }
        }
    }
    ts[1..k].sort_unstable_by(f32::total_cmp);
    ts[k] = t1;
    for w in ts[..=k].windows(2) {
        if w[1] > w[0] {
            let p = o + d * (0.5 * (w[0] + w[1]));
            let c = (p.x >= mid.x) as usize | ((p.y >= mid.y) as usize) << 1 | ((p.z >= mid.z) as usize) << 2;
            f(c, w[1] - w[0]);
        }
    }
}

impl Octree {
    /// One chunk's share of the refinement test: the flights (as [`Octree::flight_sums`] takes
    /// them: start, unit direction, length, power) summed per octant of the atmospheric
    /// leaves above the depth limit that they cross.
    pub fn octant_sums(&self, flights: impl IntoIterator<Item = (Vec3, Vec3, f32, Vec3)>) -> OctantSums {
        let limit = self.stats.max_depth;
        let view = self.view();
        let mut acc: HashMap<u64, (f64, f64, u32)> = HashMap::new();
        for (o, d, t, c) in flights {
            if !(t > 0.0 && o.is_finite() && d.is_finite() && c.is_finite()) {
                continue;
            }
            let power = (c.x as f64 + c.y as f64 + c.z as f64) / 3.0;
            self.segment_cells(o, d, t, |node, depth, ijk, t0, t1| {
                if depth >= limit || self.nodes[node as usize].value() != NO_VALUE {
                    return;
                }
                let s = self.cell_size[depth as usize];
                let mid = view.cell_min(depth, ijk) + Vec3::splat(0.5 * s);
                octant_pieces(o, d, mid, t0, t1, |oct, l| {
                    let x = power * l as f64;
                    let e = acc.entry(node as u64 * 8 + oct as u64).or_insert((0.0, 0.0, 0));
                    e.0 += x;
                    e.1 += x * x;
                    e.2 += 1;
                });
            });
        }
        let mut sums: Vec<(u64, f64, f64, u32)> = acc.into_iter().map(|(k, (s, q, n))| (k, s, q, n)).collect();
        sums.sort_unstable_by_key(|r| r.0);
        OctantSums { sums }
    }

    /// The atmospheric leaves the test splits (module docs), in node order. `f_ref` is the mean
    /// free-space fluence, set by the first round.
    fn leaves_to_split(&self, chunks: Vec<OctantSums>, f_ref: &mut Option<f64>) -> Vec<u32> {
        let mut per: BTreeMap<u32, [(f64, f64, u32); 8]> = BTreeMap::new();
        for chunk in chunks {
            for (k, s, q, n) in chunk.sums {
                let e = &mut per.entry((k / 8) as u32).or_default()[(k % 8) as usize];
                e.0 += s;
                e.1 += q;
                e.2 = e.2.saturating_add(n);
            }
        }
        let mut depth = vec![0u32; self.nodes.len()];
        for l in self.leaves() {
            depth[l.node as usize] = l.depth;
        }
        let volume = |node: u32| (self.cell_size[depth[node as usize] as usize] as f64).powi(3);
        let f_ref = *f_ref.get_or_insert_with(|| {
            let (s, v) = per.iter().fold((0.0, 0.0), |(s, v), (&node, o)| (s + o.iter().map(|x| x.0).sum::<f64>(), v + volume(node)));
            if v > 0.0 {
                s / v
            } else {
                0.0
            }
        });
        let floor2 = (REFINE_FLOOR * f_ref).powi(2);
        per.iter()
            .filter(|(&node, o)| {
                let n: u64 = o.iter().map(|x| x.2 as u64).sum();
                if n < 8 * FLIGHT_MIN as u64 {
                    return false;
                }
                let v = volume(node) / 8.0;
                let f = o.map(|x| x.0 / v);
                let mean = f.iter().sum::<f64>() / 8.0;
                let departure: f64 = f.iter().map(|x| (x - mean).powi(2)).sum();
                let noise: f64 = o.iter().map(|x| x.1 / (v * v)).sum();
                departure - 1.75 * noise > 8.0 * REFINE_TAU * REFINE_TAU * (mean * mean + floor2)
            })
            .map(|(&node, _)| node)
            .collect()
    }

    /// Split the atmospheric leaves where the photons' flights show their light changing
    /// (module docs). `flights(tree)` returns the flights of the photon pass summed by
    /// [`Octree::octant_sums`] of `tree`, chunk by chunk in a fixed order; it is called once per
    /// round. Any diffused values are dropped (fill them after).
    pub fn refine_free_space(&mut self, mut flights: impl FnMut(&Octree) -> Vec<OctantSums>) -> RefineStats {
        let t0 = std::time::Instant::now();
        let mut st = RefineStats::default();
        let mut f_ref = None;
        let limit = self.stats.max_depth;
        while st.rounds < limit {
            let split = self.leaves_to_split(flights(self), &mut f_ref);
            st.rounds += 1;
            if split.is_empty() {
                break;
            }
            st.split_leaves += split.len();
            self.split_atmospheric(&split);
        }
        st.t_s = t0.elapsed().as_secs_f64();
        st
    }

    /// The start of a free-space tree over this tree's root cube, with its settings (module
    /// docs, "The free-space tree"): every cell of depth [`FREE_SPACE_BASE_DEPTH`] an
    /// atmospheric leaf, no photon, no surface value. [`Octree::refine_free_space`] splits it
    /// down to this tree's deepest leaf, and [`Octree::fill_atmosphere`] gives its
    /// leaves their values.
    pub fn free_space_tree(&self) -> Octree {
        let mut t = Octree {
            origin: self.origin,
            size: self.size,
            cell_size: self.cell_size,
            inv_quant: self.inv_quant,
            h_max: self.h_max,
            nodes: vec![Node { link: LEAF_BIT | NO_VALUE, photons: 0 }],
            values: match &self.values {
                super::LeafValues::Compressed(_) => super::LeafValues::Compressed(Vec::new()),
                super::LeafValues::Full(_) => super::LeafValues::Full(Vec::new()),
            },
            facing: Vec::new(),
            anchors: Vec::new(),
            leak_samples: self.leak_samples,
            query_half: self.query_half,
            atmosphere: None,
            flat: Default::default(),
            settings: self.settings.clone(),
            stats: OctreeStats {
                nodes: 1,
                leaves: 1,
                bytes: std::mem::size_of::<Node>(),
                max_depth: self.stats.max_depth,
                min_leaf_size: self.stats.min_leaf_size,
                h_max: self.stats.h_max,
                surface_area: self.stats.surface_area,
                ..OctreeStats::default()
            },
        };
        for _ in 0..FREE_SPACE_BASE_DEPTH.min(self.stats.max_depth) {
            let leaves: Vec<u32> = t.leaves().iter().map(|l| l.node).collect();
            t.split_atmospheric(&leaves);
        }
        t
    }

    /// Make each of `leaves` (atmospheric) an internal node with eight atmospheric children, and
    /// lay the nodes out again in the order a cache file reads them.
    fn split_atmospheric(&mut self, leaves: &[u32]) {
        for &node in leaves {
            let first = self.nodes.len() as u32;
            self.nodes[node as usize] = Node { link: first, photons: 0 };
            self.nodes.extend([Node { link: LEAF_BIT | NO_VALUE, photons: 0 }; 8]);
        }
        self.relayout();
        let added = 8 * leaves.len();
        self.stats.nodes = self.nodes.len();
        self.stats.leaves += 7 * leaves.len();
        self.stats.bytes += added * std::mem::size_of::<Node>();
        if let Some(a) = self.atmosphere.take() {
            self.stats.bytes -= a.bytes();
        }
        let nv = self.stats.valid_leaves;
        self.stats.bytes_per_valid_leaf = if nv > 0 { self.stats.bytes as f64 / nv as f64 } else { 0.0 };
        self.flat = Default::default();
    }

    /// The nodes in depth-first order, children allocated as their parent is reached (the
    /// order `octolux_io`'s cache reader rebuilds). Leaves keep their value indices.
    fn relayout(&mut self) {
        let old = std::mem::take(&mut self.nodes);
        let mut new = vec![Node { link: 0, photons: 0 }; old.len()];
        let mut next = 1usize;
        let mut stack = vec![(0usize, 0usize)];
        while let Some((o, n)) = stack.pop() {
            let node = old[o];
            if node.is_leaf() {
                new[n] = node;
                continue;
            }
            new[n] = Node { link: next as u32, photons: node.photons };
            stack.extend((0..8).rev().map(|c| (node.link as usize + c, next + c)));
            next += 8;
        }
        new.truncate(next);
        self.nodes = new;
    }
}

#[cfg(test)]
#[path = "refine_tests.rs"]
mod tests;
