//! Octree construction (paper §3) and the per-leaf density estimates (§4, eq. 5.4).
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

use super::compress::{compress_leaf, compress_leaf_for_normals, FullLeaf};
use super::geometry::{lit_areas, projected_lit_area, OrientedArea};
use super::query::TreeView;
use super::settings::{Enlarge, Estimator, Split, Storage, MAX_DEPTH};
use super::sort::{sort_photons, KeyFn, PhotonRec, Rec, RecNg, SortKey, Sorted};
use super::{LeafValues, Node, Octree, OctreeError, OctreeSettings, OctreeStats, ALL_FACING, LEAF_BIT, NO_VALUE};
use crate::math::Bounds3;
use crate::photon::Photon;
use glam::{DVec3, Mat3, Vec3, Vec3A};
use rayon::prelude::*;
use std::time::Instant;

/// Spread the low 21 bits of `v` to every third bit.
#[inline]
pub(super) const fn spread_bits(v: u32) -> u64 {
    let mut x = (v as u64) & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// `spread_bits` of the 10-bit values.
static SPREAD10: [u32; 1024] = {
    let mut t = [0u32; 1024];
    let mut i = 0;
    while i < 1024 {
        t[i] = spread_bits(i as u32) as u32;
        i += 1;
    }
    t
};

/// Morton key of integer cell coordinates: bit 0 of each triple is x, bit 1 y, bit 2 z.
#[inline]
pub(super) fn morton(q: [u32; 3]) -> u64 {
    if (q[0] | q[1] | q[2]) < 1024 {
        (SPREAD10[q[0] as usize] | (SPREAD10[q[1] as usize] << 1) | (SPREAD10[q[2] as usize] << 2)) as u64
    } else {
        spread_bits(q[0]) | (spread_bits(q[1]) << 1) | (spread_bits(q[2]) << 2)
    }
}

/// Integer cell coordinates at depth `h` of a point inside the root cube (clamped to it).
#[inline]
pub(super) fn quantize(p: Vec3, origin: Vec3, inv_quant: f32, h: u32) -> [u32; 3] {
    let max = (1u32 << h) - 1;
    let q = (p - origin) * inv_quant;
    // `as` saturates (negative and NaN give 0)
    [(q.x as u32).min(max), (q.y as u32).min(max), (q.z as u32).min(max)]
}

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

/// A leaf during the build.
#[derive(Clone, Copy, Debug)]
struct LeafBuild {
    node: u32,
    /// Photon range `[lo, hi)` in the sorted order.
    lo: u32,
    hi: u32,
    depth: u32,
    ijk: [u32; 3],
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
        let leaf = LeafBuild { node: id as u32, lo: lo as u32, hi: hi as u32, depth, ijk };
        self.start[id] = lo as u32;
        self.leaves.push(leaf);
        if hi > lo {
            self.nodes[id].link = LEAF_BIT | self.valid.len() as u32;
            self.valid.push(leaf);
        } else {
            self.nodes[id].link = LEAF_BIT | NO_VALUE;
        }
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

/// Per-leaf scratch buffers (one set per rayon job).
#[derive(Default)]
struct Scratch {
    /// Gathered photon ranges `[lo, hi)` (own cell and neighbours inside the box).
    segs: Vec<(u32, u32)>,
    /// Gathered single photons (from neighbours cut by the box).
    singles: Vec<u32>,
    pos: Vec<Vec3>,
    ng: Vec<Vec3>,
    areas: Vec<OrientedArea>,
}

/// Result of one leaf estimate.
struct LeafEstimate {
    m: FullLeaf,
    gathered: u32,
    fallback: bool,
    /// Bit `k` (order `+X, −X, +Y, −Y, +Z, −Z`): the cell has surfaces facing that
    /// half-axis, so matrix `k` carries a value (see [`super::Octree::facing`]).
    facing: u8,
    /// Mean normal of the surfaces matrix `k` describes (weights `n_a² × area`), or the
    /// half-axis itself when the geometry is unknown: the compression keeps the irradiance
    /// exact for it.
    normals: [Vec3; 6],
}

struct EstimateCtx<'a, R> {
    view: TreeView<'a>,
    start: &'a [u32],
    pos: &'a [Vec3],
    recs: &'a [R],
    settings: &'a OctreeSettings,
    triangles: &'a [[Vec3; 3]],
    tri_lists: &'a [Vec<u32>],
}

/// The six 3x3 sums. Each photon adds `(w · weight) cᵀ` to one of 8 octant sums (by the
/// signs of `w`); the axis matrices are the sums of the 4 octants on their side. A photon
/// with a zero component belongs to no matrix of that axis: it goes to `zero` sums, one per
/// axis matrix. f32 blocks of at most `BLOCK` photons are flushed into f64 totals, so the
/// rounding error does not grow with the photon count of a leaf.
struct Accumulator {
    block: [[Vec3A; 3]; 8],
    total: [[DVec3; 3]; 8],
    /// Photons with a zero direction component, added directly to the axis matrices (f64).
    zero: [[DVec3; 3]; 6],
    count: u32,
}

impl Accumulator {
    const BLOCK: u32 = 64;

    fn new() -> Self {
        Accumulator { block: [[Vec3A::ZERO; 3]; 8], total: [[DVec3::ZERO; 3]; 8], zero: [[DVec3::ZERO; 3]; 6], count: 0 }
    }

    fn flush(&mut self) {
        for (t, b) in self.total.iter_mut().zip(self.block.iter_mut()) {
            for (tc, bc) in t.iter_mut().zip(b.iter_mut()) {
                *tc += DVec3::from(Vec3::from(*bc));
                *bc = Vec3A::ZERO;
            }
        }
        self.count = 0;
    }

    /// [`Split::Normal`]: straight into the axis matrices on the side of `ng` (f64; the
    /// weights differ per axis, so the octant sums do not apply).
    #[inline]
    fn add_by_normal(&mut self, w: Vec3, c: Vec3, weight: f32, ng: Vec3) {
        let n2 = ng * ng;
        let norm = n2.dot(n2);
        if !(norm > 0.0) {
            return;
        }
        let wd = DVec3::from(w * weight);
        for a in 0..3 {
            if ng[a] != 0.0 {
                let g = (n2[a] / norm) as f64;
                let m = &mut self.zero[2 * a + (ng[a] < 0.0) as usize];
                m[0] += wd * (g * c.x as f64);
                m[1] += wd * (g * c.y as f64);
                m[2] += wd * (g * c.z as f64);
            }
        }
    }

    /// [`Split::Normal`] with [`Estimator::GeometryArea`]: matrix `(a, s)` estimates the
    /// light on the surfaces facing the half-axis `(a, s)`, weighted by `n_a²`:
    /// `M_a^s = Σ_p ng_a² Φ_p w_p / A⊥_a^s(w_p)` with `A⊥_a^s(w) = Σ_t n_{t,a}² A_t (n_t·w)₊`
    /// over the lit pieces whose normal has the sign `s` on axis `a`. Each photon is thus
    /// divided by the area of the surfaces it can have landed on in that matrix, not by all
    /// the surfaces of the cell (which would average a dim face with the bright floor
    /// beside it). For one plane of normal `N`: `M_a^{s(N_a)} = ∫ L w dω` for every axis, so
    /// the query's `Σ_a N_a² = 1` returns it exactly.
    #[inline]
    fn add_by_surface(&mut self, w: Vec3, c: Vec3, ng: Vec3, areas: &[OrientedArea], min_cos: f32) {
        for a in 0..3 {
            if ng[a] == 0.0 {
                continue;
            }
            let neg = ng[a] < 0.0;
            let (mut proj, mut total) = (0.0f32, 0.0f32);
            for e in areas {
                if e.n[a] != 0.0 && (e.n[a] < 0.0) == neg {
                    let g = e.n[a] * e.n[a] * e.area;
                    total += g;
                    proj += g * e.n.dot(w).max(0.0);
                }
            }
            let den = proj.max(min_cos * total);
            if !(den > 0.0) {
                continue;
            }
            let f = (ng[a] * ng[a] / den) as f64;
            let wd = DVec3::from(w) * f;
            let m = &mut self.zero[2 * a + neg as usize];
            m[0] += wd * c.x as f64;
            m[1] += wd * c.y as f64;
            m[2] += wd * c.z as f64;
        }
    }

    #[inline(always)]
    fn add(&mut self, w: Vec3, c: Vec3, weight: f32) {
        let wd = Vec3A::from(w) * weight;
        let cols = [wd * c.x, wd * c.y, wd * c.z];
        if w.x == 0.0 || w.y == 0.0 || w.z == 0.0 {
            // rare: straight into the matrices of the non-zero components
            for a in 0..3 {
                if w[a] != 0.0 {
                    let m = &mut self.zero[2 * a + (w[a] < 0.0) as usize];
                    for (mc, cc) in m.iter_mut().zip(&cols) {
                        *mc += DVec3::from(Vec3::from(*cc));
                    }
                }
            }
            return;
        }
        let o = (w.x < 0.0) as usize | ((w.y < 0.0) as usize) << 1 | ((w.z < 0.0) as usize) << 2;
        let m = &mut self.block[o];
        m[0] += cols[0];
        m[1] += cols[1];
        m[2] += cols[2];
        self.count += 1;
        if self.count == Self::BLOCK {
            self.flush();
        }
    }

    fn finish(mut self) -> FullLeaf {
        self.flush();
        let mut m = [Mat3::ZERO; 6];
        for (k, mk) in m.iter_mut().enumerate() {
            let (axis, neg) = (k / 2, k % 2);
            let mut cols = self.zero[k];
            for (o, t) in self.total.iter().enumerate() {
                if (o >> axis) & 1 == neg {
                    for (cc, tc) in cols.iter_mut().zip(t) {
                        *cc += *tc;
                    }
                }
            }
            *mk = Mat3::from_cols(cols[0].as_vec3(), cols[1].as_vec3(), cols[2].as_vec3());
        }
        m
    }
}

impl<R: PhotonRec> EstimateCtx<'_, R> {
    /// Box gathered by a leaf and whether it is enlarged.
    fn gather_box(&self, leaf: &LeafBuild) -> (Bounds3, bool) {
        let s = self.view.cell_size[leaf.depth as usize];
        let cmin = self.view.cell_min(leaf.depth, leaf.ijk);
        let eps = self.settings.epsilon;
        let enlarged = eps > 0.0
            && match self.settings.enlarge {
                Enlarge::All => true,
                Enlarge::UnderNMin => leaf.hi - leaf.lo < self.settings.n_min,
            };
        if enlarged {
            let c = cmin + Vec3::splat(0.5 * s);
            let half = Vec3::splat(0.5 * s * (1.0 + eps));
            (Bounds3 { min: c - half, max: c + half }, true)
        } else {
            (Bounds3 { min: cmin, max: cmin + Vec3::splat(s) }, false)
        }
    }

    /// The photons inside the gathering box: the own range, whole ranges of neighbours
    /// inside the box, single photons of neighbours cut by it (half-open box test).
    fn gather(&self, leaf: &LeafBuild, ebox: &Bounds3, enlarged: bool, segs: &mut Vec<(u32, u32)>, singles: &mut Vec<u32>) {
        segs.clear();
        singles.clear();
        segs.push((leaf.lo, leaf.hi));
        if !enlarged {
            return;
        }
        let (emin, emax) = (ebox.min, ebox.max);
        self.view.visit(emin, emax, |node, depth, ijk, _| {
            let n = self.view.nodes[node as usize];
            if node == leaf.node || n.photons == 0 {
                return;
            }
            let lo = self.start[node as usize];
            let hi = lo + n.photons;
            let cmin = self.view.cell_min(depth, ijk);
            let cmax = cmin + Vec3::splat(self.view.cell_size[depth as usize]);
            if cmin.cmpge(emin).all() && cmax.cmple(emax).all() {
                segs.push((lo, hi));
            } else {
                // test only the axes along which the neighbour sticks out of the box (one for
                // a face neighbour, the common case): a loop per axis set
                let base = singles.len();
                singles.resize(base + n.photons as usize, 0);
                let pos = &self.pos[lo as usize..hi as usize];
                let out = &mut singles[base..];
                let cut = (cmin.cmplt(emin) | cmax.cmpgt(emax)).bitmask();
                let (a, b) = (emin, emax);
                let k = match cut {
                    0b001 => compact(lo, pos, out, |p| (p.x >= a.x) & (p.x < b.x)),
                    0b010 => compact(lo, pos, out, |p| (p.y >= a.y) & (p.y < b.y)),
                    0b100 => compact(lo, pos, out, |p| (p.z >= a.z) & (p.z < b.z)),
                    0b011 => compact(lo, pos, out, |p| (p.x >= a.x) & (p.x < b.x) & (p.y >= a.y) & (p.y < b.y)),
                    0b101 => compact(lo, pos, out, |p| (p.x >= a.x) & (p.x < b.x) & (p.z >= a.z) & (p.z < b.z)),
                    0b110 => compact(lo, pos, out, |p| (p.y >= a.y) & (p.y < b.y) & (p.z >= a.z) & (p.z < b.z)),
                    _ => compact(lo, pos, out, |p| p.cmpge(a).all() & p.cmplt(b).all()),
                };
                singles.truncate(base + k);
            }
        });
    }

    fn estimate(&self, leaf: &LeafBuild, value: usize, sc: &mut Scratch) -> LeafEstimate {
        let (ebox, enlarged) = self.gather_box(leaf);
        self.gather(leaf, &ebox, enlarged, &mut sc.segs, &mut sc.singles);
        let photons = sc.segs.iter().map(|&(lo, hi)| (lo..hi).len()).sum::<usize>() + sc.singles.len();
        let edge = ebox.extent().x;
        let inv_da = 1.0 / (edge * edge);
        let min_cos = self.settings.min_cos;
        let mut estimator = self.settings.estimator;
        let mut fallback = false;
        let mut lit_total = 0.0f32;
        let recs = self.recs;
        if estimator == Estimator::GeometryArea {
            sc.pos.clear();
            sc.ng.clear();
            let all = sc.segs.iter().flat_map(|&(lo, hi)| lo..hi).chain(sc.singles.iter().copied());
            for i in all {
                sc.pos.push(self.pos[i as usize]);
                sc.ng.push(recs[i as usize].ng());
            }
            let ids = self.tri_lists.get(value).map(Vec::as_slice).unwrap_or(&[]);
            lit_areas(self.triangles, ids, &ebox, &sc.pos, &sc.ng, &mut sc.areas);
            lit_total = sc.areas.iter().map(|a| a.area).sum();
            if !(lit_total > 0.0) {
                estimator = Estimator::Cosine;
                fallback = true;
            }
        }
        let areas = &sc.areas;
        let mut acc = Accumulator::new();
        let by_normal = self.settings.split == Split::Normal;
        let mut add = |i: u32| {
            let r = &recs[i as usize];
            let w = r.w();
            if by_normal && estimator == Estimator::GeometryArea {
                // per-matrix areas: no single weight
                acc.add_by_surface(w, r.c(), r.ng(), areas, min_cos);
                return;
            }
            let weight = match estimator {
                // `w` carries the cosine weight
                Estimator::Paper | Estimator::Cosine => inv_da,
                Estimator::GeometryArea => 1.0 / projected_lit_area(areas, w).max(min_cos * lit_total),
            };
            if by_normal {
                acc.add_by_normal(w, r.c(), weight, r.ng());
            } else {
                acc.add(w, r.c(), weight);
            }
        };
        for &(lo, hi) in &sc.segs {
            (lo..hi).for_each(&mut add);
        }
        sc.singles.iter().for_each(|&i| add(i));
        let mut normals: [Vec3; 6] = std::array::from_fn(|k| {
            let mut v = Vec3::ZERO;
            v[k / 2] = if k % 2 == 0 { 1.0 } else { -1.0 };
            v
        });
        let facing = if by_normal && estimator == Estimator::GeometryArea {
            let mut bits = 0u8;
            let mut sums = [Vec3::ZERO; 6];
            for e in areas.iter() {
                for a in 0..3 {
                    if e.n[a] != 0.0 {
                        let k = 2 * a + (e.n[a] < 0.0) as usize;
                        bits |= 1 << k;
                        sums[k] += e.n * (e.n[a] * e.n[a] * e.area);
                    }
                }
            }
            for (n, s) in normals.iter_mut().zip(sums) {
                if let Some(u) = s.try_normalize() {
                    *n = u;
                }
            }
            bits
        } else {
            ALL_FACING
        };
        LeafEstimate { m: acc.finish(), gathered: photons as u32, fallback, facing, normals }
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

/// Branchless compaction: the indices `lo + j` of the positions `pos[j]` that pass `inside`
/// go to the front of `out` (as long as `pos`); returns their count.
#[inline(always)]
fn compact(lo: u32, pos: &[Vec3], out: &mut [u32], inside: impl Fn(Vec3) -> bool) -> usize {
    let mut k = 0usize;
    for (i, &p) in (lo..).zip(pos) {
        out[k] = i;
        k += inside(p) as usize;
    }
    k
}

/// The built node array with its leaves.
struct Tree {
    nodes: Vec<Node>,
    start: Vec<u32>,
    leaves: Vec<LeafBuild>,
    valid: Vec<LeafBuild>,
}

fn subdivide<K: SortKey>(keys: &[K], settings: &OctreeSettings) -> Tree {
    let mut tb = TreeBuilder {
        keys,
        h: settings.h_max,
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

/// Steps 2-4 on sorted photons: subdivision, triangle lists, per-leaf estimates.
fn estimates<R: PhotonRec, K: SortKey>(
    sorted: Sorted<R, K>,
    origin: Vec3,
    cell_size: &[f32; MAX_DEPTH as usize + 1],
    settings: &OctreeSettings,
    triangles: &[[Vec3; 3]],
) -> (Tree, usize, Vec<LeafEstimate>) {
    let Sorted { keys, pos, recs } = sorted;
    let tree = subdivide(&keys, settings);
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
    let ctx = EstimateCtx { view, start: &tree.start, pos: &pos, recs: &recs, settings, triangles, tri_lists: &tri_lists };
    let est: Vec<LeafEstimate> =
        tree.valid.par_iter().enumerate().map_init(Scratch::default, |sc, (v, leaf)| ctx.estimate(leaf, v, sc)).collect();
    let n = recs.len();
    (tree, n, est)
}

/// Steps 1-4 with the key storage chosen by the depth.
fn sort_and_estimate<R: PhotonRec>(
    photons: &[Photon],
    kf: KeyFn,
    size: f32,
    cosine_min: Option<f32>,
    cell_size: &[f32; MAX_DEPTH as usize + 1],
    settings: &OctreeSettings,
    triangles: &[[Vec3; 3]],
) -> (Tree, usize, Vec<LeafEstimate>) {
    if 3 * kf.h < 32 {
        estimates(sort_photons::<R, u32>(photons, kf, size, cosine_min), kf.origin, cell_size, settings, triangles)
    } else {
        estimates(sort_photons::<R, u64>(photons, kf, size, cosine_min), kf.origin, cell_size, settings, triangles)
    }
}

pub(super) fn build(
    photons: &[Photon],
    bounds: Bounds3,
    settings: &OctreeSettings,
    geometry: Option<&[[Vec3; 3]]>,
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
    let h = settings.h_max;
    let inv_quant = ((1u64 << h) as f64 / size as f64) as f32;
    let mut cell_size = [0.0f32; MAX_DEPTH as usize + 1];
    for (d, cs) in cell_size.iter_mut().enumerate() {
        *cs = size / (1u64 << d) as f32;
    }

    // 1.-2. sort and subdivision, 3.-4. estimates
    let cosine_min = (settings.estimator == Estimator::Cosine).then_some(settings.min_cos);
    let kf = KeyFn { origin, inv_quant, h };
    let tris = geometry.filter(|_| settings.estimator == Estimator::GeometryArea).unwrap_or(&[]);
    let (tree, n_kept, est) = if settings.estimator == Estimator::GeometryArea || settings.split == Split::Normal {
        sort_and_estimate::<RecNg>(photons, kf, size, cosine_min, &cell_size, settings, tris)
    } else {
        sort_and_estimate::<Rec>(photons, kf, size, cosine_min, &cell_size, settings, &[])
    };
    let Tree { nodes, leaves, valid, .. } = tree;
    // The facing bits are kept only when they say something (Split::Normal with geometry);
    // an empty list reads as "every matrix carries a value".
    let facing: Vec<u8> = if est.iter().any(|e| e.facing != ALL_FACING) { est.iter().map(|e| e.facing).collect() } else { Vec::new() };
    let values = match settings.storage {
        Storage::Compressed if settings.split == Split::Normal => {
            LeafValues::Compressed(est.par_iter().map(|e| compress_leaf_for_normals(&e.m, &e.normals)).collect())
        }
        Storage::Compressed => LeafValues::Compressed(est.par_iter().map(|e| compress_leaf(&e.m)).collect()),
        Storage::Full => LeafValues::Full(est.iter().map(|e| e.m).collect()),
    };

    // statistics
    let max_depth = leaves.iter().map(|l| l.depth).max().unwrap_or(0);
    let min_leaf_size = cell_size[max_depth as usize];
    let mut depth_histogram = vec![0u32; h as usize + 1];
    let (mut own, mut gath, mut cells) = (0.0f64, 0.0f64, 0.0f64);
    for (l, e) in valid.iter().zip(&est) {
        depth_histogram[l.depth as usize] += 1;
        own += (l.hi - l.lo) as f64;
        gath += e.gathered as f64;
        cells += cell_size[l.depth as usize] as f64;
    }
    let nv = valid.len();
    let mean = |s: f64| if nv > 0 { s / nv as f64 } else { 0.0 };
    let bytes = std::mem::size_of_val(nodes.as_slice()) + values.bytes() + facing.len();
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
        photons_dropped: photons.len() - n_kept,
        nodes: nodes.len(),
        max_depth,
        min_leaf_size,
        geometry_fallback_leaves: est.iter().filter(|e| e.fallback).count(),
    };
    let mut tree = Octree {
        origin,
        size,
        cell_size,
        inv_quant,
        h_max: h,
        nodes,
        values,
        facing,
        query_half: 0.5 * settings.alpha * min_leaf_size,
        settings: settings.clone(),
        stats,
    };
    tree.stats.t_build_s = t0.elapsed().as_secs_f64();
    Ok(tree)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_matches_a_bit_loop() {
        let naive = |q: [u32; 3]| {
            let mut k = 0u64;
            for b in 0..21 {
                for (a, qa) in q.iter().enumerate() {
                    k |= (((qa >> b) & 1) as u64) << (3 * b + a);
                }
            }
            k
        };
        let mut s = crate::sampling::Sampler::new(1, 2, 3);
        for _ in 0..10_000 {
            let q = [s.next_u32() & 0x1f_ffff, s.next_u32() & 0x1f_ffff, s.next_u32() & 0x1f_ffff];
            assert_eq!(morton(q), naive(q));
        }
        assert_eq!(morton([0x1f_ffff; 3]), (1u64 << 63) - 1);
    }

    #[test]
    fn accumulator_matches_the_direct_sums() {
        let mut s = crate::sampling::Sampler::new(2, 2, 2);
        let mut acc = Accumulator::new();
        let mut direct = [[DVec3::ZERO; 3]; 6];
        for i in 0..1000 {
            let mut w = crate::sampling::square_to_uniform_sphere(s.next_2d());
            if i % 10 == 0 {
                w[i % 3] = 0.0; // zero components: in no matrix of that axis
            }
            let c = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
            let weight = 0.5 + s.next_1d();
            acc.add(w, c, weight);
            for a in 0..3 {
                if w[a] != 0.0 {
                    let k = 2 * a + (w[a] < 0.0) as usize;
                    for j in 0..3 {
                        direct[k][j] += (w * weight * c[j]).as_dvec3();
                    }
                }
            }
        }
        let m = acc.finish();
        for k in 0..6 {
            let expect = Mat3::from_cols(direct[k][0].as_vec3(), direct[k][1].as_vec3(), direct[k][2].as_vec3());
            let d = m[k] - expect;
            let err = d.x_axis.abs().max(d.y_axis.abs()).max(d.z_axis.abs()).max_element();
            assert!(err < 1e-3, "{k}: {err}");
        }
    }

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
}
