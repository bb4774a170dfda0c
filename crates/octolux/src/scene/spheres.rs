//! The analytic spheres' own bounding-volume hierarchy. The intersection backends (`accel`)
//! hold triangles only; a scene's spheres were tested one by one on every ray, which made a
//! scene of a thousand small spheres 14x slower per ray than one of ten (measured:
//! docs/lab/2026-12-07-path-overheads.md). [`SphereBvh`] answers the scene's sphere queries:
//! up to [`LINEAR_MAX`] spheres by testing each, above through a binary tree of boxes, with
//! the same answers as the linear test: the nearest hit
//! `t` (each sphere's by [`intersect_sphere`], the very function the linear test calls), ties
//! to the lowest sphere index, as the linear test's strict `<` gives.

use super::{intersect_sphere, SphereShape};
use crate::math::Ray;
use glam::{Vec3, Vec3A};

/// Scenes with at most this many spheres test them one by one.
pub const LINEAR_MAX: usize = 16;
/// Spheres per leaf at most.
const LEAF_MAX: usize = 4;
/// The box test's relative widening of both ends (pbrt's 2·gamma(3)): a sphere's `t` and the
/// slabs' carry rounding errors of that order, which the box's pad does not cover far from the
/// ray's origin.
const WIDEN: f32 = 2.0 * 3.0 * f32::EPSILON;
/// Traversal stack: the tree's depth stays below 64 (median splits: about `log2(n / LEAF_MAX)`).
const STACK: usize = 64;

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

/// The tree (module docs); without nodes, the spheres are tested one by one.
#[derive(Clone, Debug)]
pub struct SphereBvh {
    nodes: Vec<Node>,
    /// Sphere indices, each leaf's contiguous.
    order: Vec<u32>,
}

/// What the box test reads of a ray: its origin, its direction's reciprocals (at most 1e30 in
/// magnitude) and `tmin`.
struct Slabs {
    o: Vec3A,
    inv: Vec3A,
    tmin: f32,
}

impl Slabs {
    #[inline]
    fn new(ray: &Ray) -> Slabs {
        let inv = ray.d.map(|x| 1.0 / if x.abs() < 1e-30 { 1e-30f32.copysign(x) } else { x });
        Slabs { o: ray.o.into(), inv: inv.into(), tmin: ray.tmin }
    }
}

/// A sphere's box, widened so that no hit [`intersect_sphere`] reports lies outside it (the
/// solve's rounding: a relative 1e-4 of the radius and of the centre's magnitude).
fn sphere_box(s: &SphereShape) -> (Vec3, Vec3) {
    let pad = s.radius.abs() * (1.0 + 1e-4) + 1e-4 * s.center.abs().max_element();
    (s.center - Vec3::splat(pad), s.center + Vec3::splat(pad))
}

impl SphereBvh {
    /// The tree over `spheres`; none (the linear test) for at most [`LINEAR_MAX`] of them (or
    /// more than `u32::MAX`).
    pub fn build(spheres: &[SphereShape]) -> SphereBvh {
        if spheres.len() <= LINEAR_MAX || spheres.len() > u32::MAX as usize {
            return SphereBvh { nodes: Vec::new(), order: Vec::new() };
        }
        let mut bvh = SphereBvh { nodes: Vec::with_capacity(2 * spheres.len() / LEAF_MAX + 1), order: (0..spheres.len() as u32).collect() };
        bvh.build_node(spheres, 0, spheres.len(), 0);
        bvh
    }

    fn build_node(&mut self, spheres: &[SphereShape], start: usize, end: usize, depth: usize) {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let (mut clo, mut chi) = (lo, hi);
        for &i in &self.order[start..end] {
            let (a, b) = sphere_box(&spheres[i as usize]);
            (lo, hi) = (lo.min(a), hi.max(b));
            let c = spheres[i as usize].center;
            (clo, chi) = (clo.min(c), chi.max(c));
        }
        let node = self.nodes.len();
        self.nodes.push(Node { lo, hi, start: start as u32, count: (end - start) as u32 });
        let extent = chi - clo;
        // a leaf when small, when every centre coincides, or deep (the stack's bound)
        if end - start <= LEAF_MAX || !(extent.max_element() > 0.0) || depth + 2 >= STACK {
            return;
        }
        let axis = extent.max_position();
        let mid = start + (end - start) / 2;
        // by centre along the axis, ties by index: the same tree from the same spheres
        let key = |i: &u32| (spheres[*i as usize].center[axis], *i);
        self.order[start..end].select_nth_unstable_by(mid - start, |a, b| key(a).partial_cmp(&key(b)).unwrap_or(std::cmp::Ordering::Equal));
        self.build_node(spheres, start, mid, depth + 1);
        let second = self.nodes.len() as u32;
        self.build_node(spheres, mid, end, depth + 1);
        self.nodes[node].start = second;
        self.nodes[node].count = 0;
    }

    /// Entry distance of the ray into `n`'s box when it enters before `tmax`. Four lanes at a
    /// time (`Vec3A`): every lane is finite or infinite, never NaN (the reciprocals are at most
    /// 1e30 in magnitude), so the lanes' min and max are the scalar ones.
    #[inline]
    fn enter(n: &Node, r: &Slabs, tmax: f32) -> Option<f32> {
        let (t0, t1) = ((Vec3A::from(n.lo) - r.o) * r.inv, (Vec3A::from(n.hi) - r.o) * r.inv);
        // both ends widened in proportion to the distance ([`WIDEN`])
        let near = t0.min(t1).max_element();
        let near = (near - near.abs() * WIDEN).max(r.tmin);
        let far = t0.max(t1).min_element().min(tmax) * (1.0 + WIDEN);
        (near <= far).then_some(near)
    }

    /// The nearest sphere the ray meets before `tmax` (index, `t`): what testing every sphere
    /// in index order with a shrinking bound gives.
    pub fn closest(&self, ray: &Ray, spheres: &[SphereShape], tmax: f32) -> Option<(usize, f32)> {
        let mut best: Option<(usize, f32)> = None;
        let mut bound = tmax;
        if self.nodes.is_empty() {
            for (i, s) in spheres.iter().enumerate() {
                if let Some(t) = intersect_sphere(ray, s.center, s.radius, bound) {
                    bound = t;
                    best = Some((i, t));
                }
            }
            return best;
        }
        let r = Slabs::new(ray);
        // (node, its entry distance): a node's box is tested once, when its parent is popped;
        // popped, it is kept while `near <= bound (1 + WIDEN)`, which is what testing its box
        // again against the shrunk bound gives (`enter`'s far end is `min(box, bound)`, and
        // scaling by a positive factor keeps the order of the minimum's operands)
        let near = Self::enter(&self.nodes[0], &r, bound)?;
        let mut stack = [(0u32, 0.0f32); STACK];
        stack[0] = (0, near);
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let (at, near) = stack[sp];
            // a box entered exactly at the bound may hold a tie of lower index
            if !(near <= bound * (1.0 + WIDEN)) {
                continue;
            }
            let n = &self.nodes[at as usize];
            if n.count > 0 {
                for &i in &self.order[n.start as usize..(n.start + n.count) as usize] {
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
            let (a, b) = (at + 1, n.start);
            // the nearer child on top
            match (Self::enter(&self.nodes[a as usize], &r, bound), Self::enter(&self.nodes[b as usize], &r, bound)) {
                (Some(x), Some(y)) => {
                    let (first, second) = if y < x { ((b, y), (a, x)) } else { ((a, x), (b, y)) };
                    stack[sp] = second;
                    stack[sp + 1] = first;
                    sp += 2;
                }
                (Some(x), None) => {
                    stack[sp] = (a, x);
                    sp += 1;
                }
                (None, Some(y)) => {
                    stack[sp] = (b, y);
                    sp += 1;
                }
                (None, None) => {}
            }
        }
        best
    }

    /// Whether any sphere meets the ray in `[tmin, tmax)`.
    pub fn any(&self, ray: &Ray, spheres: &[SphereShape]) -> bool {
        if self.nodes.is_empty() {
            return spheres.iter().any(|s| intersect_sphere(ray, s.center, s.radius, ray.tmax).is_some());
        }
        let r = Slabs::new(ray);
        let mut stack = [0u32; STACK];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let at = stack[sp];
            let n = &self.nodes[at as usize];
            if Self::enter(n, &r, ray.tmax).is_none() {
                continue;
            }
            if n.count > 0 {
                let hit = self.order[n.start as usize..(n.start + n.count) as usize].iter().any(|&i| {
                    let s = &spheres[i as usize];
                    intersect_sphere(ray, s.center, s.radius, ray.tmax).is_some()
                });
                if hit {
                    return true;
                }
                continue;
            }
            stack[sp] = n.start;
            stack[sp + 1] = at + 1;
            sp += 2;
        }
        false
    }
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
        assert!(SphereBvh::build(&spheres[..LINEAR_MAX]).nodes.is_empty());
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
}
