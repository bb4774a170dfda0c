//! The BVH's builder (`super` docs, "Build"): top-down binned SAH over triangle references,
//! children collected until a node has its `4H`, object medians below [`MAX_SAH_DEPTH`].

use super::{MAX_LEAF_TRIS, MAX_SAH_DEPTH};
use glam::Vec3A;
use rayon::prelude::*;

const NUM_BINS: usize = 32;
/// Ranges larger than this build their children in parallel.
const PAR_THRESHOLD: usize = 8192;
/// SAH traversal cost of one BVH2-level split, relative to intersecting one 4-triangle block.
const TRAV_COST: f32 = 0.5;

/// Axis-aligned box used by the builder.
#[derive(Clone, Copy, Debug)]
pub(super) struct Aabb {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
}

impl Aabb {
    pub(super) const EMPTY: Aabb = Aabb { lo: Vec3A::splat(f32::INFINITY), hi: Vec3A::splat(f32::NEG_INFINITY) };
    #[inline]
    fn grow(&mut self, o: &Aabb) {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
    }
    #[inline]
    fn grow_point(&mut self, p: Vec3A) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
    /// Half the surface area (0 for empty boxes).
    #[inline]
    fn half_area(&self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3A::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// Triangle reference during the build: bounds and original index.
#[derive(Clone, Copy, Debug)]
pub(super) struct PrimRef {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
    pub(super) idx: u32,
}

impl PrimRef {
    /// Twice the box centre (saves a multiply; only relative positions matter).
    #[inline]
    fn c2(&self) -> Vec3A {
        self.lo + self.hi
    }
}

/// Intermediate tree produced by the (parallel) builder and flattened afterwards.
pub(super) enum BuildNode {
    Inner(Vec<(Aabb, BuildNode)>),
    /// `start` is a global index into the reordered `PrimRef` array.
    Leaf {
        start: usize,
        count: usize,
    },
}

/// How to split a range.
#[derive(Clone, Copy, Debug)]
enum SplitPlan {
    /// Primitives whose centroid bin on `axis` is `<= bin` go left.
    Sah { axis: usize, bin: usize, origin: f32, scale: f32 },
    /// Object median along `axis`.
    Median { axis: usize },
}

/// A child candidate while forming one BVH4 node. `start`/`end` are local to the node's slice.
struct Cand {
    start: usize,
    end: usize,
    bounds: Aabb,
    cbounds: Aabb,
    /// `None`: make a leaf.
    plan: Option<SplitPlan>,
}

pub(super) fn range_bounds(prims: &[PrimRef]) -> (Aabb, Aabb) {
    let mut b = Aabb::EMPTY;
    let mut c = Aabb::EMPTY;
    for p in prims {
        b.grow(&Aabb { lo: p.lo, hi: p.hi });
        c.grow_point(p.c2());
    }
    (b, c)
}

#[inline]
fn blocks(n: usize) -> f32 {
    n.div_ceil(4) as f32
}

/// Decide leaf vs split for a range and, for a split, how.
fn plan(prims: &[PrimRef], bounds: &Aabb, cbounds: &Aabb, depth: usize) -> Option<SplitPlan> {
    let n = prims.len();
    if n <= 4 {
        return None;
    }
    let ext = cbounds.hi - cbounds.lo;
    let axis_largest = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    if ext.max_element() <= 0.0 {
        // All centroids coincide: no spatial split separates them.
        return (n > MAX_LEAF_TRIS).then_some(SplitPlan::Median { axis: axis_largest });
    }
    if depth >= MAX_SAH_DEPTH {
        return Some(SplitPlan::Median { axis: axis_largest });
    }
    // Binning on all three axes.
    let mut bin_b = [[Aabb::EMPTY; NUM_BINS]; 3];
    let mut bin_n = [[0u32; NUM_BINS]; 3];
    let scale = Vec3A::select(ext.cmpgt(Vec3A::ZERO), (NUM_BINS as f32 * (1.0 - 1e-6)) / ext, Vec3A::ZERO);
    let origin = cbounds.lo;
    for p in prims {
        let bi = ((p.c2() - origin) * scale).as_uvec3().min(glam::UVec3::splat(NUM_BINS as u32 - 1));
        let pb = Aabb { lo: p.lo, hi: p.hi };
        for axis in 0..3 {
            let k = bi[axis] as usize;
            bin_b[axis][k].grow(&pb);
            bin_n[axis][k] += 1;
        }
    }
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if scale[axis] == 0.0 {
            continue;
        }
        // Right-to-left sweep: cost of the right part for a split after bin k.
        let mut right_cost = [0.0f32; NUM_BINS];
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0usize;
        for k in (1..NUM_BINS).rev() {
            acc.grow(&bin_b[axis][k]);
            cnt += bin_n[axis][k] as usize;
            right_cost[k - 1] = acc.half_area() * blocks(cnt);
        }
        let mut acc = Aabb::EMPTY;
        let mut cnt = 0usize;
        for k in 0..NUM_BINS - 1 {
            acc.grow(&bin_b[axis][k]);
            cnt += bin_n[axis][k] as usize;
            if cnt == 0 || cnt == n {
                continue;
            }
            let c = acc.half_area() * blocks(cnt) + right_cost[k];
            if c < best.0 {
                best = (c, axis, k);
            }
        }
    }
    let area = bounds.half_area().max(f32::MIN_POSITIVE);
    if !best.0.is_finite() {
        return (n > MAX_LEAF_TRIS).then_some(SplitPlan::Median { axis: axis_largest });
    }
    let split_cost = TRAV_COST + best.0 / area;
    let leaf_cost = blocks(n);
    if n <= MAX_LEAF_TRIS && leaf_cost <= split_cost {
        return None;
    }
    let (_, axis, bin) = best;
    Some(SplitPlan::Sah { axis, bin, origin: origin[axis], scale: scale[axis] })
}

/// Partition `prims` by `plan`; returns the size of the left part (always in `1..len`).
fn partition(prims: &mut [PrimRef], plan: SplitPlan) -> usize {
    let n = prims.len();
    match plan {
        SplitPlan::Sah { axis, bin, origin, scale } => {
            let left = |p: &PrimRef| (((p.c2()[axis] - origin) * scale) as usize).min(NUM_BINS - 1) <= bin;
            let (mut i, mut j) = (0usize, n);
            while i < j {
                if left(&prims[i]) {
                    i += 1;
                } else {
                    j -= 1;
                    prims.swap(i, j);
                }
            }
            if i == 0 || i == n {
                // Cannot happen with counts from the same binning, but stay safe.
                return partition(prims, SplitPlan::Median { axis });
            }
            i
        }
        SplitPlan::Median { axis } => {
            let mid = n / 2;
            prims.select_nth_unstable_by(mid, |a, b| a.c2()[axis].total_cmp(&b.c2()[axis]));
            mid
        }
    }
}

/// Build one node with up to `width` children over `prims` (which start at global index `offset`).
pub(super) fn build_inner(prims: &mut [PrimRef], offset: usize, bounds: Aabb, cbounds: Aabb, depth: usize, width: usize) -> BuildNode {
    let root_plan = plan(prims, &bounds, &cbounds, depth);
    let mut cands = vec![Cand { start: 0, end: prims.len(), bounds, cbounds, plan: root_plan }];
    while cands.len() < width {
        // Split the splittable candidate with the largest surface area (SAH levels) or with
        // the most triangles (median levels, to bound the depth).
        let key = |c: &Cand| if depth >= MAX_SAH_DEPTH { (c.end - c.start) as f32 } else { c.bounds.half_area() };
        let Some(k) = (0..cands.len()).filter(|&k| cands[k].plan.is_some()).max_by(|&a, &b| key(&cands[a]).total_cmp(&key(&cands[b])))
        else {
            break;
        };
        let c = &cands[k];
        let (s, e) = (c.start, c.end);
        let Some(p) = c.plan else { break };
        let m = s + partition(&mut prims[s..e], p);
        let (lb, lc) = range_bounds(&prims[s..m]);
        let (rb, rc) = range_bounds(&prims[m..e]);
        let lp = plan(&prims[s..m], &lb, &lc, depth);
        let rp = plan(&prims[m..e], &rb, &rc, depth);
        cands[k] = Cand { start: s, end: m, bounds: lb, cbounds: lc, plan: lp };
        cands.insert(k + 1, Cand { start: m, end: e, bounds: rb, cbounds: rc, plan: rp });
    }
    // Children in order; split the slice into disjoint parts for (parallel) recursion.
    let mut parts: Vec<(&Cand, &mut [PrimRef])> = Vec::with_capacity(cands.len());
    let mut rest: &mut [PrimRef] = prims;
    for c in &cands {
        let (a, b) = std::mem::take(&mut rest).split_at_mut(c.end - c.start);
        parts.push((c, a));
        rest = b;
    }
    let make = |(c, slice): (&Cand, &mut [PrimRef])| -> (Aabb, BuildNode) {
        let node = if c.plan.is_none() {
            BuildNode::Leaf { start: offset + c.start, count: c.end - c.start }
        } else {
            build_inner(slice, offset + c.start, c.bounds, c.cbounds, depth + 1, width)
        };
        (c.bounds, node)
    };
    let children: Vec<(Aabb, BuildNode)> =
        if prims_len(&parts) > PAR_THRESHOLD { parts.into_par_iter().map(make).collect() } else { parts.into_iter().map(make).collect() };
    BuildNode::Inner(children)
}

fn prims_len(parts: &[(&Cand, &mut [PrimRef])]) -> usize {
    parts.iter().map(|(_, s)| s.len()).sum()
}
