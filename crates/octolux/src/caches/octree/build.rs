//! Octree construction (paper §3); the per-leaf density estimates (§4, eq. 5.4) are in
//! `estimate.rs`, the cell addressing in `cells.rs`.
//!
//! Steps, each deterministic whatever the thread count:
//! 1. Morton keys of the photon positions at depth `h_max` (21 bits per axis at most); the
//!    photons, as compact records, are sorted by key (`sort.rs`: stable, parallel).
//! 2. Top-down subdivision over the sorted ranges: the children of a node are 8 contiguous
//!    sub-ranges found by binary search on the next 3 key bits (sequential; the node count is
//!    about `photons / n_max`).
//! 3. For `Estimator::GeometryArea`: the triangles are filtered down the tree by bounding box
//!    against the enlarged cells (an enlarged child lies inside its enlarged parent).
//! 4. Per valid leaf, in parallel: gather the photons of the enlarged cell (own range plus the
//!    neighbouring leaves met by the enlarged box, tested point by point, on the axes where
//!    they stick out, unless the whole neighbour lies inside), then sum the six matrices
//!    sequentially (8 octant sums, f32 blocks of 64 photons flushed into f64).

use super::cells::{LeafBuild, TreeView};
use super::compress::{compress_leaf, compress_leaf_for_normals, MATRIX_BYTES};
use super::estimate::{EstimateCtx, LeafEstimate, Scratch};
use super::settings::{auto_depth, Depth, Estimator, Split, Storage, MAX_DEPTH};
use super::sort::{sort_photons, KeyFn, PhotonRec, Rec, RecNg, SortKey, Sorted};
use super::{LeafValues, Node, Octree, OctreeError, OctreeSettings, OctreeStats, Surfaces, ALL_FACING, LEAF_BIT, NO_VALUE};
use crate::math::Bounds3;
use crate::photon::Photon;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// The root cube of a box: same centre, edge = largest extent padded by 1e-5 (at least a
/// small positive size for a flat or point-like box).
fn cube_of(b: &Bounds3) -> Result<(Vec3, f32), OctreeError> {
    if !b.min.is_finite() || !b.max.is_finite() {
        return Err(OctreeError::InvalidBounds(format!("non-finite box {b:?}")));
    }
    if b.is_empty() {
        return Err(OctreeError::InvalidBounds(format!("empty box {b:?}")));
    }
    let c = b.center();
    let ext = b.extent().max_element();
    let edge = (ext * (1.0 + 2e-5)).max(1e-5 * (1.0 + c.abs().max_element()));
    if !edge.is_finite() {
        return Err(OctreeError::InvalidBounds(format!("box too large {b:?}")));
    }
    Ok((c - Vec3::splat(0.5 * edge), edge))
}

/// Total area of the surfaces (scene units², f64): triangles plus analytic spheres.
fn surface_area(s: &Surfaces<'_>) -> f64 {
    let tri: f64 =
        s.triangles.iter().map(|t| 0.5 * (t[1] - t[0]).as_dvec3().cross((t[2] - t[0]).as_dvec3()).length()).filter(|a| a.is_finite()).sum();
    let sph: f64 = s.spheres.iter().map(|sp| 4.0 * std::f64::consts::PI * (sp.radius as f64).powi(2)).filter(|a| a.is_finite()).sum();
    tri + sph
}

/// Make node `leaf.node` a leaf over its photon range: valid (numbered next) when it has
/// photons, atmospheric otherwise.
fn push_leaf(nodes: &mut [Node], start: &mut [u32], leaves: &mut Vec<LeafBuild>, valid: &mut Vec<LeafBuild>, leaf: LeafBuild) {
    let id = leaf.node as usize;
    start[id] = leaf.lo;
    leaves.push(leaf);
    if leaf.hi > leaf.lo {
        nodes[id].link = LEAF_BIT | valid.len() as u32;
        valid.push(leaf);
    } else {
        nodes[id].link = LEAF_BIT | NO_VALUE;
    }
}

struct TreeBuilder<'a, K> {
    keys: &'a [K],
    h: u32,
    n_max: usize,
    n_min: usize,
    respect_n_min: bool,
    nodes: Vec<Node>,
    /// Photon range start of every leaf node (build only).
    start: Vec<u32>,
    leaves: Vec<LeafBuild>,
    valid: Vec<LeafBuild>,
}

impl<K: SortKey> TreeBuilder<'_, K> {
    fn make_leaf(&mut self, id: usize, lo: usize, hi: usize, depth: u32, ijk: [u32; 3]) {
        push_leaf(
            &mut self.nodes,
            &mut self.start,
            &mut self.leaves,
            &mut self.valid,
            LeafBuild { node: id as u32, lo: lo as u32, hi: hi as u32, depth, ijk },
        );
    }

    fn node(&mut self, id: usize, lo: usize, hi: usize, depth: u32, ijk: [u32; 3]) {
        let count = hi - lo;
        self.nodes[id].photons = count as u32;
        // hard cap on the node count (links are 31 bits): stop splitting near it
        let room = self.nodes.len() + 8 < NO_VALUE as usize;
        if count == 0 || count <= self.n_max || depth >= self.h || !room {
            return self.make_leaf(id, lo, hi, depth, ijk);
        }
        let shift = 3 * (self.h - depth - 1);
        let s = &self.keys[lo..hi];
        let mut cut = [0usize; 9];
        cut[8] = count;
        for (c, cut_c) in cut.iter_mut().enumerate().take(8).skip(1) {
            *cut_c = s.partition_point(|k| ((k.get() >> shift) & 7) < c as u64);
        }
        if self.respect_n_min && (0..8).any(|c| (1..self.n_min).contains(&(cut[c + 1] - cut[c]))) {
            return self.make_leaf(id, lo, hi, depth, ijk);
        }
        let first = self.nodes.len();
        self.nodes.resize(first + 8, Node { link: 0, photons: 0 });
        self.start.resize(first + 8, 0);
        self.nodes[id].link = first as u32;
        for c in 0..8u32 {
            let cijk = [2 * ijk[0] + (c & 1), 2 * ijk[1] + ((c >> 1) & 1), 2 * ijk[2] + ((c >> 2) & 1)];
            self.node(first + c as usize, lo + cut[c as usize], lo + cut[c as usize + 1], depth + 1, cijk);
        }
    }
}

/// Triangle lists per valid leaf (by value index), filtered down the tree by bounding box
/// against the `(1+ε)`-enlarged cells.
fn distribute_triangles(view: &TreeView, tri_bounds: &[Bounds3], eps: f32, n_valid: usize) -> Vec<Vec<u32>> {
    fn enlarged(view: &TreeView, depth: u32, ijk: [u32; 3], eps: f32) -> Bounds3 {
        let s = view.cell_size[depth as usize];
        let c = view.cell_min(depth, ijk) + Vec3::splat(0.5 * s);
        let half = Vec3::splat(0.5 * s * (1.0 + eps));
        Bounds3 { min: c - half, max: c + half }
    }
    fn overlaps(a: &Bounds3, b: &Bounds3) -> bool {
        a.min.cmple(b.max).all() && b.min.cmple(a.max).all()
    }
    fn rec(view: &TreeView, tb: &[Bounds3], eps: f32, node: u32, depth: u32, ijk: [u32; 3], ids: &[u32]) -> Vec<(u32, Vec<u32>)> {
        let n = view.nodes[node as usize];
        if n.is_leaf() {
            return if n.value() != NO_VALUE { vec![(n.value(), ids.to_vec())] } else { Vec::new() };
        }
        let child = |c: u32| -> Vec<(u32, Vec<u32>)> {
            let cijk = [2 * ijk[0] + (c & 1), 2 * ijk[1] + ((c >> 1) & 1), 2 * ijk[2] + ((c >> 2) & 1)];
            let eb = enlarged(view, depth + 1, cijk, eps);
            let sub: Vec<u32> = ids.iter().copied().filter(|&t| overlaps(&tb[t as usize], &eb)).collect();
            if sub.is_empty() {
                Vec::new()
            } else {
                rec(view, tb, eps, n.link + c, depth + 1, cijk, &sub)
            }
        };
        if ids.len() > 2048 {
            (0..8u32).into_par_iter().map(child).collect::<Vec<_>>().concat()
        } else {
            (0..8u32).flat_map(child).collect()
        }
    }
    let root_box = enlarged(view, 0, [0; 3], eps);
    let ids: Vec<u32> = (0..tri_bounds.len() as u32).filter(|&t| overlaps(&tri_bounds[t as usize], &root_box)).collect();
    let mut lists = vec![Vec::new(); n_valid];
    for (v, l) in rec(view, tri_bounds, eps, 0, 0, [0; 3], &ids) {
        lists[v as usize] = l;
    }
    lists
}

/// The built node array with its leaves.
pub(super) struct Tree {
    pub nodes: Vec<Node>,
    start: Vec<u32>,
    pub leaves: Vec<LeafBuild>,
    pub valid: Vec<LeafBuild>,
}

fn subdivide<K: SortKey>(keys: &[K], h: u32, settings: &OctreeSettings) -> Tree {
    let mut tb = TreeBuilder {
        keys,
        h,
        n_max: settings.n_max as usize,
        n_min: settings.n_min as usize,
        respect_n_min: settings.split_respects_n_min,
        nodes: vec![Node { link: 0, photons: 0 }],
        start: vec![0],
        leaves: Vec::new(),
        valid: Vec::new(),
    };
    tb.node(0, 0, keys.len(), 0, [0; 3]);
    Tree { nodes: tb.nodes, start: tb.start, leaves: tb.leaves, valid: tb.valid }
}

/// The sorted photons assigned to the leaves of a given topology (`refit.rs`): the node array
/// of `topology` with its links and leaves kept, the photon counts, ranges and valid leaves
/// recomputed. The ranges are found as [`TreeBuilder::node`] finds them (binary search on the
/// next 3 key bits), and the leaves are numbered in the same depth-first order.
fn assign<K: SortKey>(keys: &[K], h: u32, topology: &[Node]) -> Tree {
    fn rec<K: SortKey>(t: &mut Tree, keys: &[K], h: u32, id: usize, range: std::ops::Range<usize>, depth: u32, ijk: [u32; 3]) {
        let (lo, hi) = (range.start, range.end);
        t.nodes[id].photons = (hi - lo) as u32;
        if t.nodes[id].is_leaf() {
            let leaf = LeafBuild { node: id as u32, lo: lo as u32, hi: hi as u32, depth, ijk };
            return push_leaf(&mut t.nodes, &mut t.start, &mut t.leaves, &mut t.valid, leaf);
        }
        let first = t.nodes[id].link as usize;
        let mut cut = [0usize; 9];
        cut[8] = hi - lo;
        if depth < h {
            let shift = 3 * (h - depth - 1);
            let s = &keys[lo..hi];
            for (c, cut_c) in cut.iter_mut().enumerate().take(8).skip(1) {
                *cut_c = s.partition_point(|k| ((k.get() >> shift) & 7) < c as u64);
            }
        }
        for c in 0..8u32 {
            let cijk = [2 * ijk[0] + (c & 1), 2 * ijk[1] + ((c >> 1) & 1), 2 * ijk[2] + ((c >> 2) & 1)];
            rec(t, keys, h, first + c as usize, lo + cut[c as usize]..lo + cut[c as usize + 1], depth + 1, cijk);
        }
    }
    let mut t = Tree { nodes: topology.to_vec(), start: vec![0; topology.len()], leaves: Vec::new(), valid: Vec::new() };
    rec(&mut t, keys, h, 0, 0..keys.len(), 0, [0; 3]);
    t
}

/// The tree [`assign`] gives for photons sorted by key with `own[node]` of them in each leaf
/// node of `topology` (`incremental.rs`: the counts updated by the photons that moved).
pub(super) fn assign_counts(topology: &[Node], own: &[u32]) -> Tree {
    fn rec(t: &mut Tree, own: &[u32], id: usize, lo: u32, depth: u32, ijk: [u32; 3]) -> u32 {
        if t.nodes[id].is_leaf() {
            let hi = lo + own[id];
            t.nodes[id].photons = own[id];
            push_leaf(&mut t.nodes, &mut t.start, &mut t.leaves, &mut t.valid, LeafBuild { node: id as u32, lo, hi, depth, ijk });
            return hi;
        }
        let first = t.nodes[id].link as usize;
        let mut hi = lo;
        for c in 0..8u32 {
            let cijk = [2 * ijk[0] + (c & 1), 2 * ijk[1] + ((c >> 1) & 1), 2 * ijk[2] + ((c >> 2) & 1)];
            hi = rec(t, own, first + c as usize, hi, depth + 1, cijk);
        }
        t.nodes[id].photons = hi - lo;
        hi
    }
    let mut t = Tree { nodes: topology.to_vec(), start: vec![0; topology.len()], leaves: Vec::new(), valid: Vec::new() };
    rec(&mut t, own, 0, 0, 0, [0; 3]);
    t
}

/// Which leaves [`estimates`] estimates: all of them on a new subdivision, or, on a given
/// topology, those `select` picks (the others get `None`), with their [`LeafState`]s when
/// `capture` asks for them (`incremental.rs`).
#[derive(Clone, Copy)]
pub(super) enum Leaves<'a> {
    Subdivide,
    Fixed { topology: &'a [Node], select: &'a (dyn Fn(&LeafBuild) -> bool + Sync), capture: bool },
}

/// Steps 2-4 on sorted photons: subdivision (or a given topology), triangle lists, per-leaf
/// estimates.
fn estimates<R: PhotonRec, K: SortKey>(
    sorted: Sorted<R, K>,
    origin: Vec3,
    h: u32,
    cell_size: &[f32; MAX_DEPTH as usize + 1],
    settings: &OctreeSettings,
    surfaces: Surfaces<'_>,
    which: Leaves<'_>,
) -> (Tree, usize, Vec<Option<LeafEstimate>>) {
    let Surfaces { triangles, spheres } = surfaces;
    let Sorted { keys, pos, recs } = sorted;
    let tree = match which {
        Leaves::Subdivide => subdivide(&keys, h, settings),
        Leaves::Fixed { topology, .. } => assign(&keys, h, topology),
    };
    drop(keys);
    let view = TreeView { nodes: &tree.nodes, origin, cell_size };
    let tri_lists = if triangles.is_empty() {
        Vec::new()
    } else {
        let tri_bounds: Vec<Bounds3> = triangles
            .par_iter()
            .map(|t| {
                if t.iter().all(|v| v.is_finite()) {
                    let mut b = Bounds3::EMPTY;
                    t.iter().for_each(|&v| b.extend(v));
                    b
                } else {
                    Bounds3::EMPTY // never overlaps
                }
            })
            .collect();
        distribute_triangles(&view, &tri_bounds, settings.epsilon, tree.valid.len())
    };
    let ctx = EstimateCtx { view, start: &tree.start, pos: &pos, recs: &recs, settings, triangles, tri_lists: &tri_lists, spheres };
    let est: Vec<Option<LeafEstimate>> = tree
        .valid
        .par_iter()
        .enumerate()
        .map_init(Scratch::default, |sc, (v, leaf)| match which {
            Leaves::Fixed { select, .. } if !select(leaf) => None,
            Leaves::Fixed { capture, .. } => Some(ctx.estimate(leaf, v, sc, capture)),
            Leaves::Subdivide => Some(ctx.estimate(leaf, v, sc, false)),
        })
        .collect();
    let n = recs.len();
    (tree, n, est)
}

/// Steps 1-4 with the key storage chosen by the depth.
#[allow(clippy::too_many_arguments)] // the build's inputs, passed through
fn sort_and_estimate<R: PhotonRec>(
    photons: &[Photon],
    kf: KeyFn,
    size: f32,
    cosine_min: Option<f32>,
    cell_size: &[f32; MAX_DEPTH as usize + 1],
    settings: &OctreeSettings,
    surfaces: Surfaces<'_>,
    which: Leaves<'_>,
) -> (Tree, usize, Vec<Option<LeafEstimate>>) {
    if 3 * kf.h < 32 {
        estimates(sort_photons::<R, u32>(photons, kf, size, cosine_min), kf.origin, kf.h, cell_size, settings, surfaces, which)
    } else {
        estimates(sort_photons::<R, u64>(photons, kf, size, cosine_min), kf.origin, kf.h, cell_size, settings, surfaces, which)
    }
}

/// Steps 1-4 for `settings` (the record type chosen by the estimator): `(tree, photons kept,
/// estimates)`.
pub(super) fn sort_assign_estimate(
    photons: &[Photon],
    kf: KeyFn,
    size: f32,
    cell_size: &[f32; MAX_DEPTH as usize + 1],
    settings: &OctreeSettings,
    geometry: Option<Surfaces<'_>>,
    which: Leaves<'_>,
) -> (Tree, usize, Vec<Option<LeafEstimate>>) {
    let cosine_min = (settings.estimator == Estimator::Cosine).then_some(settings.min_cos);
    let surfaces = geometry.filter(|_| settings.estimator == Estimator::GeometryArea).unwrap_or_default();
    if settings.estimator == Estimator::GeometryArea || settings.split == Split::Normal {
        sort_and_estimate::<RecNg>(photons, kf, size, cosine_min, cell_size, settings, surfaces, which)
    } else {
        sort_and_estimate::<Rec>(photons, kf, size, cosine_min, cell_size, settings, Surfaces::default(), which)
    }
}

/// A valid leaf's value in a tree being assembled: a new estimate, or the value of another
/// tree of the same settings (`refit.rs`: a leaf nothing changed around).
pub(super) enum LeafOut<'a> {
    New(Box<LeafEstimate>),
    Old(&'a Octree, u32),
}

pub(super) fn build(
    photons: &[Photon],
    bounds: Bounds3,
    settings: &OctreeSettings,
    geometry: Option<Surfaces<'_>>,
) -> Result<Octree, OctreeError> {
    let t0 = Instant::now();
    settings.validate()?;
    if settings.estimator == Estimator::GeometryArea && geometry.is_none() {
        return Err(OctreeError::MissingGeometry);
    }
    if photons.len() > u32::MAX as usize {
        return Err(OctreeError::TooManyPhotons(photons.len()));
    }
    let (origin, size) = cube_of(&bounds)?;
    let surface_area = geometry.map_or(0.0, |g| surface_area(&g));
    let surface_area = if surface_area > 0.0 { surface_area } else { 6.0 * size as f64 * size as f64 };
    let h = match settings.h_max {
        Depth::Fixed(h) => h,
        Depth::Auto => auto_depth(photons.len(), surface_area, size as f64, settings.n_max),
    };
    // shared with `parts.rs`, so that an octree read back has the same bits
    let inv_quant = super::parts::morton_scale(h, size);
    let cell_size = super::parts::cell_sizes(size);

    // 1.-2. sort and subdivision, 3.-4. estimates
    let kf = KeyFn { origin, inv_quant, h };
    let (tree, n_kept, est) = sort_assign_estimate(photons, kf, size, &cell_size, settings, geometry, Leaves::Subdivide);
    // a new subdivision estimates every valid leaf (`estimates`): no `None`
    let outs = est.into_iter().flatten().map(|e| LeafOut::New(Box::new(e))).collect();
    let frame = Frame { origin, size, cell_size, inv_quant, h, surface_area, photons: photons.len() };
    let mut tree = assemble(tree, n_kept, outs, frame, settings);
    tree.stats.t_build_s = t0.elapsed().as_secs_f64();
    Ok(tree)
}

/// The root cube and depth of a tree, and what its statistics report of the input.
pub(super) struct Frame {
    pub origin: Vec3,
    pub size: f32,
    pub cell_size: [f32; MAX_DEPTH as usize + 1],
    pub inv_quant: f32,
    pub h: u32,
    pub surface_area: f64,
    /// Photons given (kept and dropped).
    pub photons: usize,
}

/// The octree from its leaves and their values: facing bits, anchors, storage, statistics.
/// `Old` values are copied as stored; the statistics count them with their tree's mean
/// gathered photons and no fallback (`refit.rs`).
pub(super) fn assemble(tree: Tree, n_kept: usize, outs: Vec<LeafOut<'_>>, f: Frame, settings: &OctreeSettings) -> Octree {
    let Tree { nodes, leaves, valid, .. } = tree;
    let Frame { origin, size, cell_size, inv_quant, h, surface_area, photons } = f;
    let facing_of = |o: &LeafOut| match o {
        LeafOut::New(e) => e.facing,
        LeafOut::Old(t, j) => t.facing.get(*j as usize).copied().unwrap_or(ALL_FACING),
    };
    // The facing bits are kept only when they say something (Split::Normal with geometry);
    // an empty list reads as "every matrix carries a value".
    let facing: Vec<u8> = if outs.iter().any(|o| facing_of(o) != ALL_FACING) { outs.iter().map(facing_of).collect() } else { Vec::new() };
    let anchors: Vec<_> = outs
        .iter()
        .map(|o| match o {
            LeafOut::New(e) => e.anchor,
            LeafOut::Old(t, j) => t.anchors[*j as usize],
        })
        .collect();
    let values = match settings.storage {
        Storage::Compressed => LeafValues::Compressed(
            outs.par_iter()
                .map(|o| match o {
                    LeafOut::New(e) if settings.split == Split::Normal => compress_leaf_for_normals(&e.m, &e.normals),
                    LeafOut::New(e) => compress_leaf(&e.m),
                    LeafOut::Old(t, j) => match &t.values {
                        LeafValues::Compressed(v) => v[*j as usize],
                        LeafValues::Full(v) => compress_leaf(&v[*j as usize]),
                    },
                })
                .collect(),
        ),
        Storage::Full => LeafValues::Full(
            outs.iter()
                .map(|o| match o {
                    LeafOut::New(e) => e.m,
                    LeafOut::Old(t, j) => match &t.values {
                        LeafValues::Full(v) => v[*j as usize],
                        LeafValues::Compressed(v) => {
                            let b = &v[*j as usize];
                            std::array::from_fn(|k| super::compress::decompress_matrix(&b[k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES]))
                        }
                    },
                })
                .collect(),
        ),
    };

    // statistics
    let max_depth = leaves.iter().map(|l| l.depth).max().unwrap_or(0);
    let min_leaf_size = cell_size[max_depth as usize];
    let mut depth_histogram = vec![0u32; h as usize + 1];
    let (mut own, mut gath, mut cells) = (0.0f64, 0.0f64, 0.0f64);
    let mut fallback = 0usize;
    for (l, o) in valid.iter().zip(&outs) {
        depth_histogram[l.depth as usize] += 1;
        own += (l.hi - l.lo) as f64;
        match o {
            LeafOut::New(e) => {
                gath += e.gathered as f64;
                fallback += e.fallback as usize;
            }
            LeafOut::Old(t, _) => gath += t.stats.mean_gathered_photons,
        }
        cells += cell_size[l.depth as usize] as f64;
    }
    let nv = valid.len();
    let mean = |s: f64| if nv > 0 { s / nv as f64 } else { 0.0 };
    let bytes = std::mem::size_of_val(nodes.as_slice()) + values.bytes() + facing.len() + std::mem::size_of_val(anchors.as_slice());
    let stats = OctreeStats {
        t_build_s: 0.0,
        bytes,
        bytes_per_valid_leaf: if nv > 0 { bytes as f64 / nv as f64 } else { 0.0 },
        leaves: leaves.len(),
        valid_leaves: nv,
        mean_photons_per_leaf: mean(own),
        mean_gathered_photons: mean(gath),
        mean_cell_size: mean(cells),
        depth_histogram,
        photons: n_kept,
        photons_dropped: photons - n_kept,
        nodes: nodes.len(),
        max_depth,
        min_leaf_size,
        geometry_fallback_leaves: fallback,
        h_max: h,
        surface_area,
    };
    Octree {
        origin,
        size,
        cell_size,
        inv_quant,
        h_max: h,
        nodes,
        values,
        facing,
        anchors,
        leak_samples: true,
        query_half: 0.5 * settings.alpha * min_leaf_size,
        atmosphere: None,
        flat: Default::default(),
        settings: settings.clone(),
        stats,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cube_is_centred_and_covers_the_box() {
        let b = Bounds3 { min: Vec3::new(-1.0, 0.0, 2.0), max: Vec3::new(3.0, 1.0, 2.5) };
        let (o, s) = cube_of(&b).unwrap();
        assert!((4.0..4.001).contains(&s));
        assert!(o.cmple(b.min).all() && (o + Vec3::splat(s)).cmpge(b.max).all());
        assert!(((o + Vec3::splat(0.5 * s)) - b.center()).length() < 1e-5);
        // a point gives a small cube, an empty or NaN box an error
        let p = Bounds3 { min: Vec3::ONE, max: Vec3::ONE };
        assert!(cube_of(&p).unwrap().1 > 0.0);
        assert!(cube_of(&Bounds3::EMPTY).is_err());
        assert!(cube_of(&Bounds3 { min: Vec3::ZERO, max: Vec3::new(f32::NAN, 1.0, 1.0) }).is_err());
    }

    /// `h_max = auto` depends on the scene only through `A / S²` and the photon count: the
    /// photons and walls of a box, and the same box 100x larger, give the same depth and the
    /// same leaves relative to the box; 4x the photons give one level more.
    #[test]
    fn auto_depth_is_the_same_for_a_box_and_the_box_scaled_100x() {
        use super::super::tests::{cornell_geometry, cornell_photons};
        use super::super::{Estimator, Split};
        let s = OctreeSettings { h_max: Depth::Auto, estimator: Estimator::GeometryArea, split: Split::Normal, ..Default::default() };
        let build_at = |scale: f32, n: usize| {
            let mut photons = cornell_photons(n, 3);
            photons.iter_mut().for_each(|p| p.p *= scale);
            let tris: Vec<[Vec3; 3]> = cornell_geometry().iter().map(|t| t.map(|v| v * scale)).collect();
            let b = Bounds3 { min: Vec3::ZERO, max: Vec3::splat(scale) };
            let surfaces = Surfaces { triangles: &tris, spheres: &[] };
            build(&photons, b, &s, Some(surfaces)).unwrap()
        };
        let (unit, big) = (build_at(1.0, 200_000), build_at(100.0, 200_000));
        let (u, b) = (unit.stats(), big.stats());
        eprintln!("auto depth: unit box {} (area {:.3}), 100x {} (area {:.1})", u.h_max, u.surface_area, b.h_max, b.surface_area);
        // 6 faces, 200k photons, n_max 500: s* = sqrt(500·6/200k) = 0.122, log2(1/s*) + 2.5 = 5.5
        assert_eq!((u.h_max, b.h_max), (6, 6));
        assert!((u.surface_area - 6.0).abs() < 1e-3 && (b.surface_area / 6e4 - 1.0).abs() < 1e-3);
        assert_eq!((u.valid_leaves, u.max_depth), (b.valid_leaves, b.max_depth));
        assert!((u.min_leaf_size * 100.0 / b.min_leaf_size - 1.0).abs() < 1e-4);
        assert!((u.mean_cell_size * 100.0 / b.mean_cell_size - 1.0).abs() < 1e-4);
        assert_eq!(build_at(1.0, 800_000).stats().h_max, 7, "4x the photons: one level more");
        // an explicit depth wins
        let fixed = OctreeSettings { h_max: Depth::Fixed(3), ..Default::default() };
        assert_eq!(build(&cornell_photons(1000, 1), Bounds3 { min: Vec3::ZERO, max: Vec3::ONE }, &fixed, None).unwrap().stats().h_max, 3);
    }
}
