//! Values in the atmospheric cells: the volumetric solution the paper names as future work
//! (§10: "diffusing radiance into [the atmospheric cells] would make the solution volumetric
//! and allow inserting and moving objects in a lit scene"); issue 13, item 4; measured in
//! docs/guide/baking.md ("A volumetric solution").
//!
//! # Flights first
//! [`Octree::fill_atmosphere`] takes the photon-flight estimates of the atmospheric leaves
//! (`flights.rs`: the light that passes through a cell) as sources that stay fixed; the
//! diffusion below fills what they leave: the leaves few flights cross and the valid leaves'
//! missing matrices. Without flights it diffuses from the surfaces only.
//!
//! # What is diffused
//! A valid leaf's matrix `k` (one of `+X, −X, +Y, −Y, +Z, −Z`) is the irradiance vector of the
//! hemisphere around `N_k` on the surfaces of the cell that face `N_k` (the facing bits). A
//! small object placed in free space sees, on its side facing `N_k`, about what the nearby
//! surfaces facing the same way see: the floor's `+Y` matrices stand for the tops of objects
//! above it, the ceiling's `−Y` for their undersides, the walls' for their sides. So each of
//! the six matrices is diffused on its own, from the leaves whose photons give it (the
//! sources: the facing bits whose half-axis one of the leaf's photon normals faces) into
//! every other leaf: atmospheric leaves, and the valid leaves' missing matrices (a floor cell's
//! `−Y`), so that a query anywhere meets values for every normal.
//!
//! # How
//! A graph over the leaves: two leaves are neighbours when their cells share a face (area
//! `A > 0`), with weight `A / d` (`d` between the cells' centres, the finite-volume
//! Laplacian's). Each leaf has a probe point: an atmospheric leaf's centre, a valid leaf's mean
//! photon position lifted [`PROBE_LIFT`] cell edges along the mean photon normal (on the lit
//! side of its surface). **An edge exists only when the segment between the two probe points
//! is unoccluded** (the caller's visibility test, a shadow ray in the scene): light is never
//! diffused through a wall, however thin against the cells, and cells inside solid geometry
//! or outside a closed room are never reached (they stay without a value).
//!
//! Values flow one way along their own axis: matrix `k` enters a leaf across a face of `k`'s
//! axis only from the neighbour behind it (on the `−N_k` side), across the other faces from
//! any neighbour. A sensor facing `N_k` sees what the surfaces facing `N_k` *below* it (along
//! `N_k`) see, not what those above it see: the top of a light fixture hung under the ceiling
//! (a dark gap facing up) must not darken the up-facing values of the room under it
//! (measured: it did, to 0.3 of the path-traced value 0.4 below the ceiling).
//!
//! Then, per matrix: a front grows from the sources, one graph layer per sweep, each reached
//! leaf taking the weighted mean of its neighbours reached before (a deterministic
//! breadth-first fill, sweeps in parallel over the leaves, each reading only the previous
//! sweep); then [`SMOOTHING_SWEEPS`] damped Jacobi sweeps (`v ← ½v + ½ mean of neighbours`)
//! relax the filled values towards the harmonic interpolation of the sources, which stay
//! fixed. The result is bit-identical for any thread count.
//!
//! # Query
//! [`Octree::irradiance_volume`] blends like §7 (`query.rs`): every leaf meeting the query box,
//! weighted by its overlap, per axis over the leaves that have that matrix (a leaf's own
//! value first, its diffused one otherwise). A valid leaf is read the paper's way; an
//! atmospheric leaf with all six matrices as free space ([`free_space_irradiance`]: the
//! irradiance of the order-2 radiance that fits its moments), one with fewer per axis
//! ([`ambient_cube`]). The weights are continuous in `P`, so the result is `C0` across cell
//! borders wherever the caller's `keep` keeps the same leaves.
//!
//! # Storage
//! Per leaf (depth-first order) one byte of filled bits, and per leaf with any filled bit the
//! six matrices in the tree's storage (36 bytes compressed, zero where not filled); compressed,
//! an atmospheric leaf with all six holds instead the SH coefficients of its free-space reading
//! (`volume.rs`, `encode_free_space`: the only thing the query reads of it). The cache
//! file carries both when the bake is asked for them (`bake --volume`; `octolux_io::cache`).

mod volume;

pub use volume::FREE_SPACE_BYTES;
#[cfg(test)]
pub(super) use volume::{decode_free_space, encode_free_space, free_space_irradiance};

use super::compress::{compress_leaf, decompress_matrix, FullLeaf, MATRIX_BYTES};
use super::flights::Flights;
use super::refine::RefineStats;
use super::{LeafValues, Octree, QueryLeaf, ALL_FACING, ANCHOR_SAMPLES, NO_VALUE};
use crate::math::Color;
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How far (in cell edges) a valid leaf's probe point lies off its photons' surface, along
/// their mean normal (the `octree` integrator lifts its leak test's anchors as much).
pub const PROBE_LIFT: f32 = 0.25;
/// A valid leaf's matrix `k` is a source of the diffusion when one of its photon normals lies
/// within 60° of the half-axis `k` (`Octree::source_bits`).
pub const SOURCE_MAX_ANGLE_COS: f32 = 0.5;
/// Damped Jacobi sweeps after the fill.
pub const SMOOTHING_SWEEPS: u32 = 16;
/// No value index.
const NONE: u32 = u32::MAX;

/// The diffused values of a tree (module docs).
#[derive(Clone, Debug)]
pub(super) struct Atmosphere {
    /// Per leaf, depth-first order: which matrices were diffused into it.
    pub(super) filled: Vec<u8>,
    /// One entry per leaf with any filled bit, in order.
    pub(super) values: LeafValues,
    /// Per node: index into `values`, or `NONE` (derived from `filled`).
    index: Vec<u32>,
    /// Per entry of `values`: its filled bits (derived from `filled`).
    entry_bits: Vec<u8>,
    /// Per entry of `values`: where its light passes, within its cell ([`quantise_anchor`];
    /// [`NO_ANCHOR`]: a diffused value), or empty: none recorded.
    pub(super) anchors: Vec<[u8; 3]>,
}

/// An entry's anchor byte that marks no anchor (a diffused value: the leak test then reads
/// the leaf at its point nearest to the query).
pub const NO_ANCHOR: [u8; 3] = [255, 255, 255];

/// A point of a cell (corner `cmin`, edge `s`) as three bytes, `0..=254` per axis; the
/// centre of the byte's slab on decoding ([`anchor_point`]).
pub(super) fn quantise_anchor(p: Vec3, cmin: Vec3, s: f32) -> [u8; 3] {
    let q = |a: usize| ((p[a] - cmin[a]) / s * 255.0).floor().clamp(0.0, 254.0) as u8;
    [q(0), q(1), q(2)]
}

/// The point of a cell an anchor's bytes stand for; `None` for [`NO_ANCHOR`] (any first byte
/// 255).
pub(super) fn anchor_point(q: [u8; 3], cmin: Vec3, s: f32) -> Option<Vec3> {
    (q[0] != 255).then(|| cmin + Vec3::new(q[0] as f32 + 0.5, q[1] as f32 + 0.5, q[2] as f32 + 0.5) * (s / 255.0))
}

/// What the fill did.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AtmosphereStats {
    /// Leaves of the tree (valid and atmospheric).
    pub leaves: usize,
    /// Atmospheric leaves that took their photon-flight estimate (`flights.rs`).
    #[serde(default)]
    pub flight_leaves: usize,
    /// Face-sharing leaf pairs whose probe points see each other.
    pub edges: usize,
    /// Pairs refused by the visibility test (a surface between the probes).
    pub blocked_edges: usize,
    /// Leaves that received at least one diffused matrix.
    pub filled_leaves: usize,
    /// Atmospheric leaves left without any value (inside solids, outside closed rooms).
    pub unreached_leaves: usize,
    /// Fill sweeps (graph layers) of the slowest matrix.
    pub fill_sweeps: u32,
    /// Bytes stored: filled bits and values.
    pub bytes: usize,
    /// The free-space refinement before the fill (`refine.rs`; none: not refined).
    #[serde(default)]
    pub refine: RefineStats,
    /// Seconds.
    pub t_s: f64,
}

impl AtmosphereStats {
    /// One line for a log: what the refinement and the fill did.
    pub fn summary(&self) -> String {
        let r = &self.refine;
        format!(
            "free space split where its light changes ({} leaves in {} rounds, {:.3} s), {} of {} leaves filled ({} from photon \
             flights), {} empty leaves unreached, {} edges ({} blocked by surfaces), {} bytes, {:.3} s",
            r.split_leaves,
            r.rounds,
            r.t_s,
            self.filled_leaves,
            self.leaves,
            self.flight_leaves,
            self.unreached_leaves,
            self.edges,
            self.blocked_edges,
            self.bytes,
            self.t_s
        )
    }
}

/// Whether matrix `k` may flow into a leaf from a neighbour on `side` (2 × axis + 1 when the
/// neighbour lies above along the axis of the shared face): across faces of the other axes,
/// always; along its own axis only in the direction `N_k` (module docs).
#[inline]
fn flows(k: usize, side: u8) -> bool {
    let (axis, above) = ((side / 2) as usize, side % 2 == 1);
    axis != k / 2 || above == (k % 2 == 1)
}

/// One leaf of the tree, for the fill.
#[derive(Clone, Copy)]
pub(super) struct Leaf {
    pub(super) node: u32,
    pub(super) depth: u32,
    pub(super) ijk: [u32; 3],
}

/// Per-node value index of the leaves with filled bits (`filled` in depth-first leaf order).
fn node_index(tree: &Octree, filled: &[u8]) -> Vec<u32> {
    let mut index = vec![NONE; tree.nodes.len()];
    let (mut leaf, mut next) = (0usize, 0u32);
    let b = tree.bounds();
    tree.view().visit(b.min, b.max, |node, _, _, _| {
        if filled.get(leaf).copied().unwrap_or(0) != 0 {
            index[node as usize] = next;
            next += 1;
        }
        leaf += 1;
    });
    index
}

impl Atmosphere {
    /// From stored parts: lengths are the caller's to check (`parts.rs`).
    pub(super) fn new(tree: &Octree, filled: Vec<u8>, values: LeafValues, anchors: Vec<[u8; 3]>) -> Atmosphere {
        let index = node_index(tree, &filled);
        let entry_bits = filled.iter().copied().filter(|&f| f != 0).collect();
        Atmosphere { filled, values, index, entry_bits, anchors }
    }

    pub(super) fn bytes(&self) -> usize {
        self.filled.len() + self.values.bytes() + 3 * self.anchors.len()
    }
}

impl Octree {
    /// The leaves in depth-first order.
    pub(super) fn leaves(&self) -> Vec<Leaf> {
        let mut out = Vec::with_capacity(self.stats.leaves);
        let b = self.bounds();
        self.view().visit(b.min, b.max, |node, depth, ijk, _| out.push(Leaf { node, depth, ijk }));
        out
    }

    /// Matrix `k` of valid leaf `v`.
    #[inline]
    fn valid_matrix(&self, v: usize, k: usize) -> Mat3 {
        match &self.values {
            LeafValues::Compressed(c) => decompress_matrix(&c[v][k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES]),
            LeafValues::Full(f) => f[v][k],
        }
    }

    /// The matrices valid leaf `v` gives: those of its facing bits (all without them) whose
    /// half-axis the leaf's mean photon normal (its mean anchor) faces within
    /// [`SOURCE_MAX_ANGLE_COS`] (a corner's mean normal lies within 55° of each of its walls). The facing bits alone are not enough: a floor
    /// whose rotated normal is `(0, 1, −4e-8)` sets the `−Z` bit, and the matrix of such a
    /// sliver (a few photons over a vanishing projected area) is noise, once even negative;
    /// as a source it would pin the diffused field to it.
    fn source_bits(&self, v: usize) -> u8 {
        let own = self.facing.get(v).copied().unwrap_or(ALL_FACING);
        let a = &self.anchors[v];
        // the mean normal only: since format 3 the sampled anchors hold incident directions,
        // which on a floor reach within 60° of the side axes and made it a source again
        let normals = std::iter::once(a.mean.normal().normalize_or_zero());
        let mut faced = 0u8;
        for n in normals {
            for k in 0..6 {
                let c = if k % 2 == 0 { n[k / 2] } else { -n[k / 2] };
                if c > SOURCE_MAX_ANGLE_COS {
                    faced |= 1 << k;
                }
            }
        }
        own & faced
    }

    /// Diffuse the six matrices into every leaf that lacks them (module docs). `visible(a, b)`
    /// says whether the segment between two points is free of surfaces (a shadow ray). The
    /// atmospheric leaves crossed by enough photon `flights` take their flight estimate
    /// (`flights.rs`) and keep it: they are sources of the diffusion like the valid leaves' own
    /// matrices, and the leaves without one are filled from them and from the surfaces. Replaces
    /// any previous fill.
    pub fn fill_atmosphere(&mut self, visible: &(dyn Fn(Vec3, Vec3) -> bool + Sync), flights: Option<&Flights>) -> AtmosphereStats {
        let t0 = std::time::Instant::now();
        self.atmosphere = None;
        let leaves = self.leaves();
        let n = leaves.len();
        let mut leaf_of_node = vec![NONE; self.nodes.len()];
        for (i, l) in leaves.iter().enumerate() {
            leaf_of_node[l.node as usize] = i as u32;
        }
        let view = self.view();
        let centre = |l: &Leaf| view.cell_min(l.depth, l.ijk) + Vec3::splat(0.5 * self.cell_size[l.depth as usize]);
        let probes: Vec<Vec3> = leaves
            .iter()
            .map(|l| {
                let v = self.nodes[l.node as usize].value();
                if v == NO_VALUE {
                    centre(l)
                } else {
                    let (cmin, s) = (view.cell_min(l.depth, l.ijk), self.cell_size[l.depth as usize]);
                    let a = &self.anchors[v as usize].mean;
                    a.position(cmin, s) + a.normal() * (PROBE_LIFT * s)
                }
            })
            .collect();
        // Face neighbours j > i of each leaf, with their weight and visibility.
        let delta = 0.25 * self.stats.min_leaf_size;
        let pairs: Vec<Vec<(u32, f32, bool, u8)>> = leaves
            .par_iter()
            .enumerate()
            .map(|(i, l)| {
                let s = self.cell_size[l.depth as usize];
                let (cmin, c) = (view.cell_min(l.depth, l.ijk), centre(l));
                let mut out = Vec::new();
                for a in 0..3 {
                    // the upper face only: every shared face is some leaf's upper face
                    let mut lo = cmin;
                    let mut hi = cmin + Vec3::splat(s);
                    lo[a] = hi[a];
                    hi[a] += delta;
                    view.visit(lo, hi, |node, depth, ijk, vol| {
                        let j = leaf_of_node[node as usize];
                        if j == NONE || vol <= 0.0 {
                            return;
                        }
                        let lj = Leaf { node, depth, ijk };
                        let d = (centre(&lj) - c).length().max(1e-12);
                        let ok = visible(probes[i], probes[j as usize]);
                        out.push((j, vol / delta / d, ok, a as u8));
                    });
                }
                out
            })
            .collect();
        // Symmetric adjacency (CSR) over the visible pairs.
        let mut degree = vec![0u32; n + 1];
        let (mut edges, mut blocked) = (0usize, 0usize);
        for (i, p) in pairs.iter().enumerate() {
            for &(j, _, ok, _) in p {
                if ok {
                    degree[i] += 1;
                    degree[j as usize] += 1;
                    edges += 1;
                } else {
                    blocked += 1;
                }
            }
        }
        let mut start = vec![0usize; n + 1];
        for i in 0..n {
            start[i + 1] = start[i] + degree[i] as usize;
        }
        let mut fill_at = start.clone();
        // (neighbour, weight, side): side = 2 × shared face's axis + 1 when the neighbour lies
        // above along it
        let mut adj = vec![(0u32, 0f32, 0u8); start[n]];
        for (i, p) in pairs.iter().enumerate() {
            for &(j, w, ok, a) in p {
                if ok {
                    adj[fill_at[i]] = (j, w, 2 * a + 1);
                    fill_at[i] += 1;
                    adj[fill_at[j as usize]] = (i as u32, w, 2 * a);
                    fill_at[j as usize] += 1;
                }
            }
        }
        drop(pairs);
        // Sources and working values.
        let source: Vec<u8> = leaves
            .iter()
            .map(|l| {
                let v = self.nodes[l.node as usize].value();
                if v == NO_VALUE {
                    0
                } else {
                    self.source_bits(v as usize)
                }
            })
            .collect();
        let mut vals: Vec<FullLeaf> = leaves
            .iter()
            .zip(&source)
            .map(|(l, &src)| {
                let v = self.nodes[l.node as usize].value();
                std::array::from_fn(|k| if src & (1 << k) != 0 { self.valid_matrix(v as usize, k) } else { Mat3::ZERO })
            })
            .collect();
        // The flight estimates: known and fixed from the start.
        let mut fixed = source.clone();
        let mut flight_leaves = 0usize;
        if let Some(f) = flights.filter(|f| f.index.len() == self.nodes.len()) {
            for (i, l) in leaves.iter().enumerate() {
                let e = f.index[l.node as usize];
                if e != NONE && self.nodes[l.node as usize].value() == NO_VALUE {
                    vals[i] = f.values[e as usize];
                    fixed[i] = ALL_FACING;
                    flight_leaves += 1;
                }
            }
        }
        let mut known = fixed.clone();
        let neighbours = |i: usize| &adj[start[i]..start[i + 1]];
        // The weighted mean of matrix `k` over the neighbours of leaf `i` that know it and
        // from which it flows (none: `None`).
        let neighbour_mean = |i: usize, k: usize, known: &[u8], vals: &[FullLeaf]| -> Option<Mat3> {
            let (mut sum, mut wsum) = (Mat3::ZERO, 0.0f32);
            for &(j, w, side) in neighbours(i) {
                if known[j as usize] & (1 << k) != 0 && flows(k, side) {
                    sum += vals[j as usize][k] * w;
                    wsum += w;
                }
            }
            (wsum > 0.0).then(|| sum * (1.0 / wsum))
        };
        // Breadth-first fill, one layer per sweep.
        let mut sweeps = 0u32;
        loop {
            let updates: Vec<(usize, u8, FullLeaf)> = (0..n)
                .into_par_iter()
                .filter_map(|i| {
                    let missing = ALL_FACING & !known[i];
                    if missing == 0 {
                        return None;
                    }
                    let (mut bits, mut m) = (0u8, vals[i]);
                    for (k, mk) in m.iter_mut().enumerate() {
                        if missing & (1 << k) == 0 {
                            continue;
                        }
                        if let Some(mean) = neighbour_mean(i, k, &known, &vals) {
                            *mk = mean;
                            bits |= 1 << k;
                        }
                    }
                    (bits != 0).then_some((i, bits, m))
                })
                .collect();
            if updates.is_empty() {
                break;
            }
            sweeps += 1;
            for (i, bits, m) in updates {
                known[i] |= bits;
                vals[i] = m;
            }
        }
        // Damped Jacobi towards the harmonic interpolation; sources fixed.
        for _ in 0..SMOOTHING_SWEEPS {
            let next: Vec<FullLeaf> = (0..n)
                .into_par_iter()
                .map(|i| {
                    let free = known[i] & !fixed[i];
                    let mut m = vals[i];
                    if free == 0 {
                        return m;
                    }
                    for (k, mk) in m.iter_mut().enumerate() {
                        if free & (1 << k) == 0 {
                            continue;
                        }
                        if let Some(mean) = neighbour_mean(i, k, &known, &vals) {
                            *mk = *mk * 0.5 + mean * 0.5;
                        }
                    }
                    m
                })
                .collect();
            vals = next;
        }
        // Store the filled matrices (zero where a leaf's own value serves).
        let filled: Vec<u8> = known.iter().zip(&source).map(|(k, s)| k & !s).collect();
        // (the matrices, and whether the leaf is atmospheric with all six: free space)
        let entries: Vec<(FullLeaf, bool)> = filled
            .iter()
            .zip(&vals)
            .zip(&leaves)
            .filter(|((f, _), _)| **f != 0)
            .map(|((&f, m), l)| {
                let free = f == ALL_FACING && self.nodes[l.node as usize].value() == NO_VALUE;
                (std::array::from_fn(|k| if f & (1 << k) != 0 { m[k] } else { Mat3::ZERO }), free)
            })
            .collect();
        let values = match &self.values {
            LeafValues::Compressed(_) => LeafValues::Compressed(
                entries.iter().map(|(m, free)| if *free { volume::encode_free_space(m) } else { compress_leaf(m) }).collect(),
            ),
            LeafValues::Full(_) => LeafValues::Full(entries.into_iter().map(|e| e.0).collect()),
        };
        let unreached_leaves =
            leaves.iter().zip(&known).filter(|(l, &k)| self.nodes[l.node as usize].value() == NO_VALUE && k == 0).count();
        let filled_leaves = filled.iter().filter(|&&f| f != 0).count();
        // the flight leaves' anchors, per entry
        let anchors = match flights {
            Some(f) => {
                let view = self.view();
                filled
                    .iter()
                    .zip(&leaves)
                    .filter(|(&f, _)| f != 0)
                    .map(|(_, l)| match f.index.get(l.node as usize).copied().filter(|&j| j != NONE) {
                        Some(j) if f.anchors[j as usize].is_finite() => {
                            quantise_anchor(f.anchors[j as usize], view.cell_min(l.depth, l.ijk), self.cell_size[l.depth as usize])
                        }
                        _ => NO_ANCHOR,
                    })
                    .collect()
            }
            None => Vec::new(),
        };
        let atmosphere = Atmosphere::new(self, filled, values, anchors);
        let bytes = atmosphere.bytes();
        self.stats.bytes += bytes;
        self.stats.bytes_per_valid_leaf =
            if self.stats.valid_leaves > 0 { self.stats.bytes as f64 / self.stats.valid_leaves as f64 } else { 0.0 };
        self.atmosphere = Some(atmosphere);
        AtmosphereStats {
            leaves: n,
            flight_leaves,
            edges,
            blocked_edges: blocked,
            filled_leaves,
            unreached_leaves,
            fill_sweeps: sweeps,
            bytes,
            refine: RefineStats::default(),
            t_s: t0.elapsed().as_secs_f64(),
        }
    }
}
