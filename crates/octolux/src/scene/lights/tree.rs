//! A light tree for next-event estimation: the lights with a position (area, point, spot) in a
//! binary tree whose nodes bound their lights' positions (a box), emission directions (a cone)
//! and power, after Conty Estevez & Kulla, "Importance Sampling of Many Lights with Adaptive
//! Tree Splitting" (HPG 2018), the light tree of Cycles, and pbrt-v4's `BVHLightSampler`.
//!
//! Sampling descends from the root, choosing each child with probability proportional to its
//! *importance* at the shading point `p` with normal `n` ([`LightBounds::importance`]): an
//! upper bound of `phi · cos θ' / d²`, where `phi` is the node's intensity (W/sr: `L · A` for
//! an area light, `I` for a point or spot light, so that `phi / d²` is an irradiance), `d` the
//! distance from `p` to the box centre (at least half the box diagonal), and `θ'` the smallest
//! angle between an emission direction of the cone and the direction to `p` that the box allows;
//! it is zero where the cone cannot reach `p`. With a normal it is multiplied by the largest
//! `|cos|` to `n` that the box allows (both sides: transmission). The probability of a light is
//! the product of the choices on its way from the root ([`LightTree::pmf`] recomputes them:
//! the same floating-point operations as the descent, so sample and pmf agree bit for bit).
//!
//! The tree is built top-down by the surface area orientation heuristic of Conty & Kulla
//! (12 buckets per axis, cost `phi · M_Ω · area · K_r`), with a split by count where every
//! centroid coincides and below [`SAOH_LEVELS`] levels (a balanced split: a light's way from
//! the root then fits the 64 bits of a `u64` for any number of lights below 2³²). The build
//! is deterministic: ties are broken by light index.

use crate::math::Color;
use crate::sampling::ONE_MINUS_EPSILON;
use glam::Vec3;
use std::f32::consts::PI;

/// Levels split by the SAOH; deeper nodes are split by count (module docs).
pub const SAOH_LEVELS: u32 = 32;
const BUCKETS: usize = 12;

/// What the tree knows of a light or a set of lights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    pub lo: Vec3,
    pub hi: Vec3,
    /// Axis of the emission cone (unit).
    pub axis: Vec3,
    /// Cosine of the cone's half angle around `axis` holding every emitter normal (or beam axis).
    pub cos_o: f32,
    /// Cosine of the angle beyond `θ_o` to which light is emitted (π/2 for a Lambertian
    /// emitter: `cos_e = 0`; for a spot, its cutoff minus its falloff start).
    pub cos_e: f32,
    /// Intensity (W/sr, mean over RGB; module docs).
    pub phi: f32,
}

impl LightBounds {
    /// Bounds of one light.
    pub fn new(lo: Vec3, hi: Vec3, axis: Vec3, cos_o: f32, cos_e: f32, phi: Color) -> LightBounds {
        let phi = (phi.x + phi.y + phi.z) / 3.0;
        LightBounds { lo, hi, axis, cos_o, cos_e, phi: if phi.is_finite() { phi.max(0.0) } else { 0.0 } }
    }

    fn centroid(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }

    /// The union of two bounds: box, cone (the smallest cone around both), the larger `θ_e`,
    /// the summed intensity.
    pub fn union(&self, o: &LightBounds) -> LightBounds {
        if o.phi <= 0.0 {
            return *self;
        }
        if self.phi <= 0.0 {
            return *o;
        }
        let (axis, cos_o) = cone_union(self.axis, self.cos_o, o.axis, o.cos_o);
        LightBounds { lo: self.lo.min(o.lo), hi: self.hi.max(o.hi), axis, cos_o, cos_e: self.cos_e.min(o.cos_e), phi: self.phi + o.phi }
    }

    /// Importance at point `p` with normal `n` (`Vec3::ZERO`: none); module docs.
    #[inline]
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        Reach::of(self).importance(p, n)
    }
}

/// What [`LightBounds::importance`] reads of a node, with the values that depend on the node
/// alone (the box's centre and half diagonal, the cone's sine) computed once, by the same
/// operations: the importance is the same to the bit. The tree's nodes keep this form.
#[derive(Clone, Copy, Debug)]
struct Reach {
    centroid: Vec3,
    /// A quarter of the box diagonal's squared length (the squared radius of its bounding sphere).
    half_diag2: f32,
    axis: Vec3,
    cos_o: f32,
    sin_o: f32,
    cos_e: f32,
    phi: f32,
}

impl Reach {
    fn of(b: &LightBounds) -> Reach {
        Reach {
            centroid: b.centroid(),
            half_diag2: 0.25 * (b.hi - b.lo).length_squared(),
            axis: b.axis,
            cos_o: b.cos_o,
            sin_o: (1.0 - b.cos_o * b.cos_o).max(0.0).sqrt(),
            cos_e: b.cos_e,
            phi: b.phi,
        }
    }

    /// [`LightBounds::importance`].
    #[inline]
    fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        if !(self.phi > 0.0) {
            return 0.0;
        }
        let half_diag2 = self.half_diag2;
        let to_p = p - self.centroid;
        let dist2 = to_p.length_squared();
        let d2 = dist2.max(half_diag2);
        if !(d2 > 0.0) {
            // a point light at the shading point
            return 0.0;
        }
        let wi = if dist2 > 0.0 { to_p / dist2.sqrt() } else { Vec3::ZERO };
        let cos_w = self.axis.dot(wi).clamp(-1.0, 1.0);
        let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
        // The cone of directions from `p` to the box's bounding sphere.
        let (sin_b, cos_b) = if dist2 <= half_diag2 {
            (0.0, -1.0)
        } else {
            let s2 = half_diag2 / dist2;
            (s2.sqrt(), (1.0 - s2).max(0.0).sqrt())
        };
        // θ' = max(0, θ_w − θ_o − θ_b)
        let cos_x = cos_sub(sin_w, cos_w, self.sin_o, self.cos_o);
        let sin_x = sin_sub(sin_w, cos_w, self.sin_o, self.cos_o);
        let cos_p = cos_sub(sin_x, cos_x, sin_b, cos_b);
        if cos_p < self.cos_e {
            return 0.0;
        }
        let mut imp = self.phi * cos_p.max(0.0) / d2;
        if n != Vec3::ZERO {
            let cos_i = wi.dot(n).abs().min(1.0);
            let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
            imp *= cos_sub(sin_i, cos_i, sin_b, cos_b).max(0.0);
        }
        if imp.is_finite() {
            imp.max(0.0)
        } else {
            0.0
        }
    }
}

/// `cos(max(0, a − b))` from the sines and cosines of `a` and `b` (angles in [0, π]).
#[inline]
fn cos_sub(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// `sin(max(0, a − b))`.
#[inline]
fn sin_sub(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

/// The smallest cone holding cones `(a, cos_a)` and `(b, cos_b)`.
fn cone_union(a: Vec3, cos_a: f32, b: Vec3, cos_b: f32) -> (Vec3, f32) {
    let ta = cos_a.clamp(-1.0, 1.0).acos();
    let tb = cos_b.clamp(-1.0, 1.0).acos();
    let td = a.dot(b).clamp(-1.0, 1.0).acos();
    if (td + tb).min(PI) <= ta {
        return (a, cos_a);
    }
    if (td + ta).min(PI) <= tb {
        return (b, cos_b);
    }
    let to = 0.5 * (ta + td + tb);
    if to >= PI {
        return (a, -1.0);
    }
    let wr = a.cross(b);
    if wr.length_squared() < 1e-12 {
        return (a, -1.0);
    }
    // rotate `a` towards `b` by `θ_o − θ_a` (Rodrigues)
    let k = wr.normalize();
    let t = to - ta;
    let w = a * t.cos() + k.cross(a) * t.sin() + k * k.dot(a) * (1.0 - t.cos());
    (w.normalize_or_zero(), to.cos())
}

/// The cone measure `M_Ω` of Conty & Kulla: the solid angle a cone `θ_o` spreading by `θ_e`
/// lights, weighed by cosine.
fn cone_measure(b: &LightBounds) -> f32 {
    let to = b.cos_o.clamp(-1.0, 1.0).acos();
    let te = b.cos_e.clamp(-1.0, 1.0).acos();
    let tw = (to + te).min(PI);
    let (so, co) = (to.sin(), to.cos());
    2.0 * PI * (1.0 - co) + 0.5 * PI * (2.0 * tw * so - (to - 2.0 * tw).cos() - 2.0 * to * so + co)
}

#[derive(Clone, Debug)]
struct Node {
    reach: Reach,
    /// Leaf: the light's index; inner node: its first child (the second is `child + 1`).
    child_or_light: u32,
    leaf: bool,
}

/// The tree (module docs).
#[derive(Clone, Debug)]
pub struct LightTree {
    nodes: Vec<Node>,
    /// Per light of the set: its way from the root (bit `k` = 1: the second child at depth
    /// `k`) and its depth; `None` for lights not in the tree.
    trail: Vec<Option<(u64, u32)>>,
}

impl LightTree {
    /// Build from `(light index, bounds)` for the lights with a position; `n_lights` is the
    /// size of the light set. `None` when no light has a positive intensity.
    pub fn build(lights: &[(u32, LightBounds)], n_lights: usize) -> Option<LightTree> {
        let mut items: Vec<(u32, LightBounds)> =
            lights.iter().copied().filter(|(_, b)| b.phi > 0.0 && b.lo.is_finite() && b.hi.is_finite()).collect();
        if items.is_empty() {
            return None;
        }
        let mut tree = LightTree { nodes: Vec::with_capacity(2 * items.len()), trail: vec![None; n_lights] };
        tree.nodes.push(Node { reach: Reach::of(&items[0].1), child_or_light: 0, leaf: true });
        tree.build_node(0, &mut items, 0, 0);
        Some(tree)
    }

    fn build_node(&mut self, node: usize, items: &mut [(u32, LightBounds)], bits: u64, depth: u32) {
        let bounds = items[1..].iter().fold(items[0].1, |acc, (_, b)| acc.union(b));
        if items.len() == 1 {
            let l = items[0].0;
            self.nodes[node] = Node { reach: Reach::of(&bounds), child_or_light: l, leaf: true };
            if let Some(t) = self.trail.get_mut(l as usize) {
                *t = Some((bits, depth));
            }
            return;
        }
        let mid = if depth >= SAOH_LEVELS { items.len() / 2 } else { split(items, &bounds) };
        let child = self.nodes.len();
        let reach = Reach::of(&bounds);
        self.nodes[node] = Node { reach, child_or_light: child as u32, leaf: false };
        let placeholder = Node { reach, child_or_light: 0, leaf: true };
        self.nodes.push(placeholder.clone());
        self.nodes.push(placeholder);
        let (left, right) = items.split_at_mut(mid);
        self.build_node(child, left, bits, depth + 1);
        self.build_node(child + 1, right, bits | (1u64 << depth), depth + 1);
    }

    /// Probability of descending from inner node `node` into its first child at `(p, n)`;
    /// `None` when neither child can light `p`. The one place both [`Self::sample`] and
    /// [`Self::pmf`] take it from, so that they agree bit for bit.
    #[inline]
    fn first_child_probability(&self, node: &Node, p: Vec3, n: Vec3) -> Option<f32> {
        let c = node.child_or_light as usize;
        let ia = self.nodes[c].reach.importance(p, n) as f64;
        let ib = self.nodes[c + 1].reach.importance(p, n) as f64;
        // f64: the sum of two large finite importances does not overflow
        let total = ia + ib;
        (total > 0.0).then(|| (ia / total) as f32)
    }

    /// Pick a light for point `p` with normal `n` (`Vec3::ZERO`: none) with `u` in [0, 1):
    /// (light index, probability). `None` when no light of the tree can reach `p`.
    #[inline]
    pub fn sample(&self, p: Vec3, n: Vec3, mut u: f32) -> Option<(u32, f32)> {
        let mut node = &self.nodes[0];
        // an inner node's own importance is not needed: its children's decide
        if node.leaf && !(node.reach.importance(p, n) > 0.0) {
            return None;
        }
        let mut pmf = 1.0f32;
        while !node.leaf {
            let c = node.child_or_light as usize;
            let pa = self.first_child_probability(node, p, n)?;
            if u < pa {
                u = (u / pa).min(ONE_MINUS_EPSILON);
                pmf *= pa;
                node = &self.nodes[c];
            } else {
                let pb = 1.0 - pa;
                u = ((u - pa) / pb).clamp(0.0, ONE_MINUS_EPSILON);
                pmf *= pb;
                node = &self.nodes[c + 1];
            }
        }
        (pmf > 0.0).then_some((node.child_or_light, pmf))
    }

    /// Probability that [`Self::sample`] at `(p, n)` picks light `light` (0 for a light not
    /// in the tree); the same value, bit for bit, that `sample` returns with it.
    #[inline]
    pub fn pmf(&self, light: u32, p: Vec3, n: Vec3) -> f32 {
        let Some(Some((bits, depth))) = self.trail.get(light as usize) else { return 0.0 };
        let mut node = &self.nodes[0];
        // an inner node's own importance is not needed: its children's decide
        if node.leaf && !(node.reach.importance(p, n) > 0.0) {
            return 0.0;
        }
        let mut pmf = 1.0f32;
        for k in 0..*depth {
            let c = node.child_or_light as usize;
            let Some(pa) = self.first_child_probability(node, p, n) else { return 0.0 };
            if bits >> k & 1 == 0 {
                pmf *= pa;
                node = &self.nodes[c];
            } else {
                pmf *= 1.0 - pa;
                node = &self.nodes[c + 1];
            }
        }
        pmf
    }

    /// Number of nodes (for tests and statistics).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }
}

/// Partition `items` for a node with `bounds` by the lowest SAOH cost; returns the size of the
/// first part (1..len).
fn split(items: &mut [(u32, LightBounds)], bounds: &LightBounds) -> usize {
    let (mut clo, mut chi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for (_, b) in items.iter() {
        clo = clo.min(b.centroid());
        chi = chi.max(b.centroid());
    }
    let extent = bounds.hi - bounds.lo;
    let max_extent = extent.max_element();
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, buckets on the left)
    for axis in 0..3 {
        let (lo, hi) = (clo[axis], chi[axis]);
        if !(hi > lo) {
            continue;
        }
        let bucket = |b: &LightBounds| (((b.centroid()[axis] - lo) / (hi - lo) * BUCKETS as f32) as usize).min(BUCKETS - 1);
        let mut acc: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (_, b) in items.iter() {
            let k = bucket(b);
            acc[k] = Some(acc[k].map_or(*b, |a| a.union(b)));
        }
        let kr = if extent[axis] > 0.0 { max_extent / extent[axis] } else { 1.0 };
        for cut in 1..BUCKETS {
            let side = |r: &[Option<LightBounds>]| r.iter().flatten().copied().reduce(|a, b| a.union(&b));
            let (Some(l), Some(r)) = (side(&acc[..cut]), side(&acc[cut..])) else { continue };
            let cost = kr * (l.phi * cone_measure(&l) * surface_area(&l) + r.phi * cone_measure(&r) * surface_area(&r));
            if cost.is_finite() && best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, cut));
            }
        }
    }
    let Some((_, axis, cut)) = best else {
        // every centroid coincides: split by count
        return items.len() / 2;
    };
    let (lo, hi) = (clo[axis], chi[axis]);
    let key = |b: &LightBounds| (((b.centroid()[axis] - lo) / (hi - lo) * BUCKETS as f32) as usize).min(BUCKETS - 1);
    items.sort_by(|x, y| key(&x.1).cmp(&key(&y.1)).then(x.0.cmp(&y.0)));
    let mid = items.iter().position(|(_, b)| key(b) >= cut).unwrap_or(items.len() / 2);
    mid.clamp(1, items.len() - 1)
}

/// Surface area of a bounds' box (at least a small positive value, so that point lights have a
/// cost).
fn surface_area(b: &LightBounds) -> f32 {
    let d = (b.hi - b.lo).max(Vec3::ZERO);
    (2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)).max(1e-12)
}
