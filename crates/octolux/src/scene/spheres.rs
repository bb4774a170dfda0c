//! The analytic spheres' own bounding-volume hierarchy. The intersection backends (`accel`)
//! hold triangles only; a scene's spheres were tested one by one on every ray, which made a
//! scene of a thousand small spheres 14x slower per ray than one of ten (measured:
//! docs/lab/2026-12-07-path-overheads.md). [`SphereBvh`] answers the scene's sphere queries:
//! up to [`LINEAR_MAX`] spheres by testing each, above through a tree of boxes four wide (a
//! node's four boxes tested in one slab test, one lane each), with
//! the same answers as the linear test: the nearest hit
//! `t` (each sphere's by [`intersect_sphere`], the very function the linear test calls), ties
//! to the lowest sphere index, as the linear test's strict `<` gives.

use super::{intersect_sphere, SphereShape};
use crate::math::Ray;
use glam::{Vec3, Vec4};

/// Scenes with at most this many spheres test them one by one.
pub const LINEAR_MAX: usize = 16;
/// Spheres per leaf at most.
const LEAF_MAX: usize = 4;
/// The box test's relative widening of both ends (pbrt's 2·gamma(3)): a sphere's `t` and the
/// slabs' carry rounding errors of that order, which the box's pad does not cover far from the
/// ray's origin.
const WIDEN: f32 = 2.0 * 3.0 * f32::EPSILON;
/// The binary tree's depth stays below this (median splits: about `log2(n / LEAF_MAX)`).
const STACK: usize = 64;
/// Traversal stack: each level of the collapsed tree (at most [`STACK`]) leaves at most three
/// children waiting.
const STACK4: usize = 3 * STACK + 4;

/// A node of the binary tree the build makes (then collapsed into [`Node4`]s).
#[derive(Clone, Copy, Debug)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: the first of its `count` entries of `order`; inner node: its second child (the
    /// first is the next node).
    start: u32,
    /// Spheres of a leaf; 0 for an inner node.
    count: u32,
}

/// A node as the traversal reads it: the boxes of up to four children, one lane each (per
/// axis, their lower and upper bounds), and what each child is.
#[derive(Clone, Copy, Debug)]
struct Node4 {
    lo: [Vec4; 3],
    hi: [Vec4; 3],
    /// Per child: a node's index, or [`LEAF`] `| l` for entry `l` of `leaves`.
    child: [u32; 4],
    /// The lanes in use (bit per lane).
    lanes: u32,
}

/// Marks a child that is a leaf.
const LEAF: u32 = 1 << 31;

/// The tree (module docs); without spheres in `order`, the spheres are tested one by one.
#[derive(Clone, Debug)]
pub struct SphereBvh {
    nodes: Vec<Node4>,
    /// Per leaf: its spheres, `order[start..start + count]`.
    leaves: Vec<(u32, u32)>,
    /// Sphere indices, each leaf's contiguous.
    order: Vec<u32>,
    /// The root: a node, or a leaf ([`LEAF`]) when every centre coincides.
    root: u32,
}

/// A sphere's box, widened so that no hit [`intersect_sphere`] reports lies outside it (the
/// solve's rounding: a relative 1e-4 of the radius and of the centre's magnitude).
fn sphere_box(s: &SphereShape) -> (Vec3, Vec3) {
    let pad = s.radius.abs() * (1.0 + 1e-4) + 1e-4 * s.center.abs().max_element();
    (s.center - Vec3::splat(pad), s.center + Vec3::splat(pad))
}

/// What the box test reads of a ray, one axis per entry splatted over the four lanes: its
/// origin, its direction's reciprocals (at most 1e30 in magnitude), and `tmin`.
struct Slabs {
    o: [Vec4; 3],
    inv: [Vec4; 3],
    tmin: Vec4,
}

impl Slabs {
    #[inline]
    fn new(ray: &Ray) -> Slabs {
        let inv = ray.d.map(|x| 1.0 / if x.abs() < 1e-30 { 1e-30f32.copysign(x) } else { x });
        Slabs { o: [0, 1, 2].map(|a| Vec4::splat(ray.o[a])), inv: [0, 1, 2].map(|a| Vec4::splat(inv[a])), tmin: Vec4::splat(ray.tmin) }
    }
}

impl SphereBvh {
    /// The tree over `spheres`; none (the linear test) for at most [`LINEAR_MAX`] of them (or
    /// more than `u32::MAX / 2`).
    pub fn build(spheres: &[SphereShape]) -> SphereBvh {
        let mut bvh = SphereBvh { nodes: Vec::new(), leaves: Vec::new(), order: Vec::new(), root: 0 };
        if spheres.len() <= LINEAR_MAX || spheres.len() >= LEAF as usize {
            return bvh;
        }
        bvh.order = (0..spheres.len() as u32).collect();
        let mut bin = Vec::with_capacity(2 * spheres.len() / LEAF_MAX + 1);
        build_node(&mut bin, &mut bvh.order, spheres, 0, spheres.len(), 0);
        bvh.root = bvh.collapse(&bin, 0);
        bvh
    }

    /// Node `at` of the binary tree as a child reference: a leaf, or a [`Node4`] over its
    /// children, each inner child opened once more while there is room (up to four).
    fn collapse(&mut self, bin: &[Node], at: u32) -> u32 {
        let b = bin[at as usize];
        if b.count > 0 {
            self.leaves.push((b.start, b.count));
            return LEAF | (self.leaves.len() - 1) as u32;
        }
        let mut kids = vec![at + 1, b.start];
        let mut k = 0;
        while kids.len() < 4 && k < kids.len() {
            let c = bin[kids[k] as usize];
            if c.count == 0 {
                let first = kids[k] + 1;
                kids[k] = first;
                kids.insert(k + 1, c.start);
                k += 2;
            } else {
                k += 1;
            }
        }
        let idx = self.nodes.len();
        let (inf, ninf) = (Vec4::splat(f32::INFINITY), Vec4::splat(f32::NEG_INFINITY));
        self.nodes.push(Node4 { lo: [inf; 3], hi: [ninf; 3], child: [0; 4], lanes: (1 << kids.len()) - 1 });
        for (lane, &kid) in kids.iter().enumerate() {
            let c = bin[kid as usize];
            for a in 0..3 {
                self.nodes[idx].lo[a][lane] = c.lo[a];
                self.nodes[idx].hi[a][lane] = c.hi[a];
            }
            let r = self.collapse(bin, kid);
            self.nodes[idx].child[lane] = r;
        }
        idx as u32
    }

    /// The lanes whose box the ray enters before `tmax`, and their entry distances: per lane
    /// the scalar slab test, `near = max(max_a min(t0, t1) (1 − WIDEN·sign), tmin)` and
    /// `far = min(min_a max(t0, t1), tmax) (1 + WIDEN)`, entered when `near <= far`. Every
    /// operation is a lane's own IEEE one (and no lane's slab is NaN: the reciprocals are
    /// finite), so each lane's answer is the one-box test's to the bit.
    #[inline]
    fn enter(n: &Node4, r: &Slabs, tmax: f32) -> (u32, Vec4) {
        let (mut near, mut far) = (Vec4::splat(f32::NEG_INFINITY), Vec4::splat(f32::INFINITY));
        for a in 0..3 {
            let (t0, t1) = ((n.lo[a] - r.o[a]) * r.inv[a], (n.hi[a] - r.o[a]) * r.inv[a]);
            near = near.max(t0.min(t1));
            far = far.min(t0.max(t1));
        }
        // both ends widened in proportion to the distance ([`WIDEN`]); an infinite `near`
        // gives NaN here, which `max` replaces by `tmin` (as `f32::max` does)
        let near = (near - near.abs() * WIDEN).max(r.tmin);
        let far = far.min(Vec4::splat(tmax)) * (1.0 + WIDEN);
        (near.cmple(far).bitmask() & n.lanes, near)
    }

    /// The spheres of leaf reference `at` ([`LEAF`] set).
    #[inline]
    fn leaf(&self, at: u32) -> &[u32] {
        let (start, count) = self.leaves[(at & !LEAF) as usize];
        &self.order[start as usize..(start + count) as usize]
    }

    /// The nearest sphere the ray meets before `tmax` (index, `t`): what testing every sphere
    /// in index order with a shrinking bound gives.
    pub fn closest(&self, ray: &Ray, spheres: &[SphereShape], tmax: f32) -> Option<(usize, f32)> {
        let mut best: Option<(usize, f32)> = None;
        let mut bound = tmax;
        if self.order.is_empty() {
            for (i, s) in spheres.iter().enumerate() {
                if let Some(t) = intersect_sphere(ray, s.center, s.radius, bound) {
                    bound = t;
                    best = Some((i, t));
                }
            }
            return best;
        }
        let r = Slabs::new(ray);
        // (child, its entry distance): a box is tested once, with its siblings, when its
        // parent is popped; popped, a child is kept while `near <= bound (1 + WIDEN)`, which
        // is what testing its box again against the shrunk bound gives (`enter`'s far end is
        // `min(box, bound)`, and scaling by a positive factor keeps the order of the
        // minimum's operands). The root's own box is not tested.
        let mut stack = [(0u32, 0.0f32); STACK4];
        stack[0] = (self.root, f32::NEG_INFINITY);
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let (at, near) = stack[sp];
            // a box entered exactly at the bound may hold a tie of lower index
            if !(near <= bound * (1.0 + WIDEN)) {
                continue;
            }
            if at & LEAF != 0 {
                for &i in self.leaf(at) {
                    let s = &spheres[i as usize];
                    if let Some(t) = intersect_sphere(ray, s.center, s.radius, tmax) {
                        let i = i as usize;
                        if t < bound || best.is_some_and(|(b, _)| t == bound && i < b) {
                            best = Some((i, t));
                            bound = t;
                        }
                    }
                }
                continue;
            }
            let n = &self.nodes[at as usize];
            let (mut mask, near) = Self::enter(n, &r, bound);
            let near = near.to_array();
            // the entered children, the nearest on top
            let mut kids = [(0u32, 0.0f32); 4];
            let mut m = 0;
            while mask != 0 {
                let l = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let mut j = m;
                while j > 0 && kids[j - 1].1 < near[l] {
                    kids[j] = kids[j - 1];
                    j -= 1;
                }
                kids[j] = (n.child[l], near[l]);
                m += 1;
            }
            stack[sp..sp + m].copy_from_slice(&kids[..m]);
            sp += m;
        }
        best
    }

    /// Whether any sphere meets the ray in `[tmin, tmax)`.
    pub fn any(&self, ray: &Ray, spheres: &[SphereShape]) -> bool {
        let hits = |i: &u32| {
            let s = &spheres[*i as usize];
            intersect_sphere(ray, s.center, s.radius, ray.tmax).is_some()
        };
        if self.order.is_empty() {
            return spheres.iter().any(|s| intersect_sphere(ray, s.center, s.radius, ray.tmax).is_some());
        }
        let r = Slabs::new(ray);
        let mut stack = [0u32; STACK4];
        stack[0] = self.root;
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let at = stack[sp];
            if at & LEAF != 0 {
                if self.leaf(at).iter().any(hits) {
                    return true;
                }
                continue;
            }
            let n = &self.nodes[at as usize];
            let (mut mask, _) = Self::enter(n, &r, ray.tmax);
            while mask != 0 {
                stack[sp] = n.child[mask.trailing_zeros() as usize];
                sp += 1;
                mask &= mask - 1;
            }
        }
        false
    }
}

/// The binary tree's node over `order[start..end]` (median split on the centres' widest axis)
/// and its subtree, appended to `bin`.
fn build_node(bin: &mut Vec<Node>, order: &mut [u32], spheres: &[SphereShape], start: usize, end: usize, depth: usize) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let (mut clo, mut chi) = (lo, hi);
    for &i in &order[start..end] {
        let (a, b) = sphere_box(&spheres[i as usize]);
        (lo, hi) = (lo.min(a), hi.max(b));
        let c = spheres[i as usize].center;
        (clo, chi) = (clo.min(c), chi.max(c));
    }
    let node = bin.len();
    bin.push(Node { lo, hi, start: start as u32, count: (end - start) as u32 });
    let extent = chi - clo;
    // a leaf when small, when every centre coincides, or deep (the stack's bound)
    if end - start <= LEAF_MAX || !(extent.max_element() > 0.0) || depth + 2 >= STACK {
        return;
    }
    let axis = extent.max_position();
    let mid = start + (end - start) / 2;
    // by centre along the axis, ties by index: the same tree from the same spheres
    let key = |i: &u32| (spheres[*i as usize].center[axis], *i);
    order[start..end].select_nth_unstable_by(mid - start, |a, b| key(a).partial_cmp(&key(b)).unwrap_or(std::cmp::Ordering::Equal));
    build_node(bin, order, spheres, start, mid, depth + 1);
    let second = bin.len() as u32;
    build_node(bin, order, spheres, mid, end, depth + 1);
    bin[node].start = second;
    bin[node].count = 0;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    fn linear_closest(ray: &Ray, spheres: &[SphereShape], tmax: f32) -> Option<(usize, f32)> {
        let mut best = None;
        let mut bound = tmax;
        for (i, s) in spheres.iter().enumerate() {
            if let Some(t) = intersect_sphere(ray, s.center, s.radius, bound) {
                bound = t;
                best = Some((i, t));
            }
        }
        best
    }

    /// The tree gives what the linear test gives, index and `t` to the bit, over rays from
    /// inside and outside the cloud and from far away, with coincident spheres (ties), nested
    /// ones, tiny and large ones, and bounds that cut the ray short.
    #[test]
    fn the_tree_finds_what_the_linear_test_finds() {
        let mut s = Sampler::new(17, 0, 0);
        let mut v = |scale: f32| (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 2.0 - 1.0) * scale;
        let mut spheres: Vec<SphereShape> = (0..600)
            .map(|i| SphereShape { center: v(10.0), radius: if i % 50 == 0 { 3.0 } else { 0.05 + 0.5 * v(1.0).x.abs() }, shape: i })
            .collect();
        // exact duplicates: ties of equal `t` at different indices
        for k in 0..40 {
            let mut d = spheres[k * 7];
            d.shape = 1000 + k as u32;
            spheres.push(d);
        }
        spheres.push(SphereShape { center: Vec3::splat(1e4), radius: 1e-3, shape: 9999 });
        let bvh = SphereBvh::build(&spheres);
        assert!(!bvh.nodes.is_empty(), "above the linear count");
        assert!(SphereBvh::build(&spheres[..LINEAR_MAX]).order.is_empty());
        let (mut hits, mut ties) = (0, 0);
        for k in 0..20_000 {
            let target = spheres[(7 * k) % 600].center;
            let (o, d) = match k % 4 {
                0 => (spheres[k % spheres.len()].center, v(1.0).normalize_or(Vec3::Z)),
                // from far away, at a sphere's edge: the rounding of a long ray
                1 => {
                    let o = v(1.0).normalize_or(Vec3::X) * 1e4;
                    (o, (target + v(0.4) - o).normalize_or(Vec3::Z))
                }
                _ => (v(15.0), v(1.0).normalize_or(Vec3::Z)),
            };
            let tmax = if k % 5 == 0 { 4.0 } else { f32::INFINITY };
            let mut ray = Ray::new(o, d);
            ray.tmax = tmax;
            let want = linear_closest(&ray, &spheres, tmax);
            let got = bvh.closest(&ray, &spheres, tmax);
            assert_eq!(got.map(|(i, t)| (i, t.to_bits())), want.map(|(i, t)| (i, t.to_bits())), "ray {k}");
            assert_eq!(bvh.any(&ray, &spheres), spheres.iter().any(|s| intersect_sphere(&ray, s.center, s.radius, tmax).is_some()));
            hits += usize::from(want.is_some());
            ties += usize::from(want.is_some_and(|(i, _)| (0..40).any(|j| i == j * 7)));
        }
        // the rays test what they should: many hits, some on the duplicated spheres
        assert!(hits > 5000 && ties > 50, "{hits} hits, {ties} on duplicated spheres");
    }

    /// Spheres that share one centre make a tree that is a single leaf: the root is that leaf,
    /// and the answers are still the linear test's (the lowest index among equal hits).
    #[test]
    fn one_centre_makes_a_leaf_root() {
        let spheres: Vec<SphereShape> =
            (0..40).map(|i| SphereShape { center: Vec3::new(1.0, 2.0, 3.0), radius: 0.5 + 0.01 * (i % 5) as f32, shape: i }).collect();
        let bvh = SphereBvh::build(&spheres);
        assert!(bvh.nodes.is_empty() && bvh.root & LEAF != 0, "a leaf root");
        for (k, d) in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::new(1.0, 1.0, 0.3)].into_iter().enumerate() {
            let ray = Ray::new(Vec3::new(1.0, 2.0, 3.0) - d.normalize() * (5.0 + k as f32), d.normalize());
            let want = linear_closest(&ray, &spheres, f32::INFINITY);
            assert!(want.is_some());
            assert_eq!(bvh.closest(&ray, &spheres, f32::INFINITY).map(|(i, t)| (i, t.to_bits())), want.map(|(i, t)| (i, t.to_bits())));
            assert!(bvh.any(&ray, &spheres));
            assert!(!bvh.any(&Ray::new(ray.o, -ray.d), &spheres), "away from the spheres");
        }
    }
}
