//! Ward's irradiance cache (Ward, Rubinstein & Clear, SIGGRAPH 1988), the paper's first
//! baseline (the paper's §9, "Ward, configuration A"): irradiance samples stored with their
//! position, normal and validity radius, interpolated with Ward's weights.
//!
//! # Weights and interpolation (WRC88, eq. 2–3)
//! A sample `i` (position `x_i`, unit normal `n_i`, irradiance `E_i`, radius `R_i`) weighs at
//! the point `x` of unit normal `n`
//! `w_i(x, n) = 1 / (|x − x_i| / R_i + sqrt(1 − n·n_i))`,
//! and is *valid* at `x` when `w_i > 1/a` (`a`: the accuracy; smaller is denser). The
//! irradiance at `x` is `E(x) = Σ_S w_i E_i / Σ_S w_i` over the valid set `S`. Two more
//! exclusions, as in Ward's implementation: a sample *in front* of `x`
//! (`(x − x_i)·(n + n_i)/2 < −0.05 R_i`: it sits above the surface at `x` and sees a
//! different hemisphere), and a sample with `n·n_i ≤ 0` (the other side of a sheet; for
//! `a > √2` the weight alone would not exclude it). `w_i` is capped at `1e6` (`x = x_i`).
//!
//! The cache is *sufficient* at `x` when `S` is not empty and `Σ_S w_i ≥ min_weight`
//! (`min_weight = 0`: Ward's original rule, "any valid sample"); otherwise a new sample is
//! computed there.
//!
//! # Storage (Ward's octree)
//! Validity implies `|x − x_i| < a R_i =: ρ_i` (the sample's reach). Samples live in an
//! octree over the scene's cube: a sample descends to the child containing `x_i` while the
//! child's half edge is at least `ρ_i`, so it ends in a node whose size matches its reach.
//! Every node keeps `reach = max_i (ρ_i + dist(x_i, cell))` over its subtree; a lookup visits
//! only nodes whose cell is within `reach` of `x`: exact (no valid sample is missed) and
//! `O(depth)` nodes for a well-spread cache.
//!
//! # Determinism ([`WardCache::prime`])
//! Ward fills the cache lazily while rendering, which makes the result depend on the order of
//! the lookups. Here the cache is filled before rendering, from an ordered list of points, in
//! batches: the batch's points not covered by the cache (frozen for the batch) get a sample
//! computed in parallel, then the samples are inserted in list order, each skipped when the
//! samples inserted before it in the same batch now cover its point. The outcome depends on
//! the list and the batch size only, never on the thread count. After priming the cache is
//! read-only (`Sync`); a render lookup that finds it insufficient computes a temporary sample
//! and does not store it.

use crate::math::{Bounds3, Color};
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

/// Deepest octree level.
const MAX_DEPTH: u32 = 24;
/// Ward's "in front" tolerance, in units of `R_i`.
const FRONT_TOLERANCE: f32 = 0.05;
/// Largest weight (a lookup exactly at a sample).
const MAX_WEIGHT: f32 = 1e6;
/// Marks a node without children.
const NO_CHILDREN: u32 = 0;

/// One irradiance sample (also the record of Christensen's irradiance photons), 40 bytes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct IrradianceSample {
    pub p: Vec3,
    /// Unit normal on the side the irradiance was measured.
    pub n: Vec3,
    /// Irradiance (RGB).
    pub e: Color,
    /// Validity radius `R_i` (scene units, > 0).
    pub r: f32,
}

impl IrradianceSample {
    /// Finite fields, unit-ish normal, positive radius, non-negative irradiance.
    pub fn is_valid(&self) -> bool {
        self.p.is_finite()
            && self.n.is_finite()
            && (self.n.length_squared() - 1.0).abs() < 1e-3
            && self.e.is_finite()
            && self.e.min_element() >= 0.0
            && self.r.is_finite()
            && self.r > 0.0
    }
}

impl crate::caches::kdtree::KdItem for IrradianceSample {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// Ward's weight of `s` at `(x, n)` for accuracy `a`, or `None` when `s` is not valid there
/// (see the module docs).
#[inline]
pub fn ward_weight(x: Vec3, n: Vec3, s: &IrradianceSample, a: f32) -> Option<f32> {
    let ndot = n.dot(s.n);
    if ndot <= 0.0 {
        return None;
    }
    let dv = x - s.p;
    if 0.5 * dv.dot(n + s.n) < -FRONT_TOLERANCE * s.r {
        return None;
    }
    let denom = dv.length() / s.r + (1.0 - ndot).max(0.0).sqrt();
    let w = if denom * MAX_WEIGHT > 1.0 { 1.0 / denom } else { MAX_WEIGHT };
    (w * a > 1.0).then_some(w)
}

/// Sums of a lookup.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WardLookup {
    /// `Σ w_i E_i` over the valid samples.
    pub sum_we: Color,
    /// `Σ w_i`.
    pub sum_w: f32,
    /// Valid samples.
    pub count: u32,
}

impl WardLookup {
    /// Interpolated irradiance (zero when no sample is valid).
    #[inline]
    pub fn irradiance(&self) -> Color {
        if self.count == 0 || !(self.sum_w > 0.0) {
            Color::ZERO
        } else {
            self.sum_we / self.sum_w
        }
    }
}

/// Outcome of [`WardCache::prime`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct PrimeStats {
    /// Points examined.
    pub points: usize,
    /// Samples computed (inserted + discarded + rejected).
    pub computed: usize,
    /// Samples inserted.
    pub inserted: usize,
    /// Samples computed in a batch but made redundant by an earlier sample of the same batch.
    pub discarded: usize,
    /// Computations that returned no valid sample.
    pub rejected: usize,
}

impl std::ops::AddAssign for PrimeStats {
    fn add_assign(&mut self, o: Self) {
        self.points += o.points;
        self.computed += o.computed;
        self.inserted += o.inserted;
        self.discarded += o.discarded;
        self.rejected += o.rejected;
    }
}

/// Statistics of a cache.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct WardCacheStats {
    pub samples: usize,
    pub nodes: usize,
    pub max_depth: u32,
    /// Bytes: samples + nodes + per-node sample index lists.
    pub bytes: usize,
    /// Mean validity radius `R_i` of the samples.
    pub mean_radius: f64,
}

#[derive(Clone, Debug)]
struct Node {
    /// Index of the first of 8 children, or `NO_CHILDREN` (the root is node 0, never a child).
    children: u32,
    /// Largest `ρ_i + dist(x_i, cell)` over the samples of the subtree.
    reach: f32,
    samples: Vec<u32>,
}

/// Ward's irradiance cache (see the module docs). Not thread-safe for insertion; lookups
/// take `&self`.
#[derive(Clone, Debug)]
pub struct WardCache {
    origin: Vec3,
    size: f32,
    a: f32,
    min_weight: f32,
    nodes: Vec<Node>,
    samples: Vec<IrradianceSample>,
    max_depth: u32,
}

/// Distance from `p` to the cube `[lo, lo + size]³` (0 inside).
#[inline]
fn cube_distance(p: Vec3, lo: Vec3, size: f32) -> f32 {
    let d = (lo - p).max(p - (lo + Vec3::splat(size))).max(Vec3::ZERO);
    d.length()
}

impl WardCache {
    /// An empty cache over `bounds` (made a cube, padded by 1e-4 of its size; a unit cube at
    /// the origin when `bounds` is empty or not finite). `a` must be positive and finite;
    /// `min_weight` non-negative (callers validate their settings first; bad values are
    /// clamped to sane ones here).
    pub fn new(bounds: Bounds3, a: f32, min_weight: f32) -> Self {
        let (origin, size) = if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
            (Vec3::splat(-0.5), 1.0)
        } else {
            let e = bounds.extent().max_element().max(1e-6) * (1.0 + 1e-4);
            (bounds.center() - Vec3::splat(e * 0.5), e)
        };
        let a = if a.is_finite() && a > 0.0 { a } else { 0.2 };
        let min_weight = if min_weight.is_finite() { min_weight.max(0.0) } else { 0.0 };
        WardCache {
            origin,
            size,
            a,
            min_weight,
            nodes: vec![Node { children: NO_CHILDREN, reach: 0.0, samples: Vec::new() }],
            samples: Vec::new(),
            max_depth: 0,
        }
    }

    /// The accuracy `a`.
    pub fn accuracy(&self) -> f32 {
        self.a
    }

    pub fn samples(&self) -> &[IrradianceSample] {
        &self.samples
    }

    pub fn len(&self) -> usize {
        self.samples.len()
    }

    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Insert a sample; returns false (and stores nothing) when it is not valid.
    pub fn insert(&mut self, s: IrradianceSample) -> bool {
        if !s.is_valid() {
            return false;
        }
        let rho = self.a * s.r;
        let idx = self.samples.len() as u32;
        self.samples.push(s);
        let (mut node, mut lo, mut size, mut depth) = (0usize, self.origin, self.size, 0u32);
        loop {
            let reach = rho + cube_distance(s.p, lo, size);
            let next = self.nodes.len() as u32;
            let n = &mut self.nodes[node];
            n.reach = n.reach.max(reach);
            if depth >= MAX_DEPTH || size * 0.25 < rho {
                n.samples.push(idx);
                break;
            }
            if n.children == NO_CHILDREN {
                n.children = next;
                for _ in 0..8 {
                    self.nodes.push(Node { children: NO_CHILDREN, reach: 0.0, samples: Vec::new() });
                }
            }
            let half = size * 0.5;
            let rel = ((s.p - lo) / half).floor().clamp(Vec3::ZERO, Vec3::ONE);
            let c = rel.x as usize | (rel.y as usize) << 1 | (rel.z as usize) << 2;
            node = self.nodes[node].children as usize + c;
            lo += rel * half;
            size = half;
            depth += 1;
        }
        self.max_depth = self.max_depth.max(depth);
        true
    }

    /// Ward's sums at `(x, n)` over the valid samples.
    pub fn lookup(&self, x: Vec3, n: Vec3) -> WardLookup {
        let mut out = WardLookup::default();
        if self.samples.is_empty() {
            return out;
        }
        let mut stack: [(u32, Vec3, f32); 8 * (MAX_DEPTH as usize + 1)] = [(0, Vec3::ZERO, 0.0); 8 * (MAX_DEPTH as usize + 1)];
        let mut top = 1usize;
        stack[0] = (0, self.origin, self.size);
        while top > 0 {
            top -= 1;
            let (ni, lo, size) = stack[top];
            let node = &self.nodes[ni as usize];
            if cube_distance(x, lo, size) > node.reach {
                continue;
            }
            for &si in &node.samples {
                let s = &self.samples[si as usize];
                if let Some(w) = ward_weight(x, n, s, self.a) {
                    out.sum_we += s.e * w;
                    out.sum_w += w;
                    out.count += 1;
                }
            }
            if node.children != NO_CHILDREN {
                let half = size * 0.5;
                for c in 0..8u32 {
                    let child = node.children + c;
                    if self.nodes[child as usize].reach <= 0.0 || top >= stack.len() {
                        continue;
                    }
                    let clo = lo + Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32) * half;
                    stack[top] = (child, clo, half);
                    top += 1;
                }
            }
        }
        out
    }

    /// Whether the cache is sufficient at `(x, n)`, with the lookup's sums.
    #[inline]
    pub fn query(&self, x: Vec3, n: Vec3) -> (bool, WardLookup) {
        let l = self.lookup(x, n);
        (l.count > 0 && l.sum_w >= self.min_weight, l)
    }

    /// Fill the cache from `points` (position, unit normal) in order, in batches of `batch`
    /// points (module docs). `compute(i)` returns the sample for point `i`, or `None`.
    pub fn prime<F>(&mut self, points: &[(Vec3, Vec3)], batch: usize, compute: F) -> PrimeStats
    where
        F: Fn(usize) -> Option<IrradianceSample> + Sync,
    {
        let mut stats = PrimeStats::default();
        for start in (0..points.len()).step_by(batch.max(1)) {
            let end = (start + batch.max(1)).min(points.len());
            stats += self.prime_batch(&points[start..end], |i| compute(start + i));
        }
        stats
    }

    /// One batch of [`Self::prime`]: the points the cache (frozen) does not cover get a sample
    /// computed in parallel, inserted in order unless an earlier one of the batch now covers
    /// the point. `compute(i)` is called with indices into `points`.
    pub fn prime_batch<F>(&mut self, points: &[(Vec3, Vec3)], compute: F) -> PrimeStats
    where
        F: Fn(usize) -> Option<IrradianceSample> + Sync,
    {
        let mut stats = PrimeStats { points: points.len(), ..Default::default() };
        let this = &*self;
        let uncovered: Vec<usize> = (0..points.len()).into_par_iter().filter(|&i| !this.query(points[i].0, points[i].1).0).collect();
        let computed: Vec<(usize, Option<IrradianceSample>)> = uncovered.into_par_iter().map(|i| (i, compute(i))).collect();
        stats.computed += computed.len();
        let mut first = true;
        for (i, s) in computed {
            let Some(s) = s else {
                stats.rejected += 1;
                continue;
            };
            // The first one is uncovered by construction (nothing was inserted since).
            if !first && self.query(points[i].0, points[i].1).0 {
                stats.discarded += 1;
                continue;
            }
            if self.insert(s) {
                stats.inserted += 1;
                first = false;
            } else {
                stats.rejected += 1;
            }
        }
        stats
    }

    /// Statistics (sizes, bytes).
    pub fn stats(&self) -> WardCacheStats {
        let index_bytes: usize = self.nodes.iter().map(|n| n.samples.len() * std::mem::size_of::<u32>()).sum();
        let mean_radius =
            if self.samples.is_empty() { 0.0 } else { self.samples.iter().map(|s| s.r as f64).sum::<f64>() / self.samples.len() as f64 };
        WardCacheStats {
            samples: self.samples.len(),
            nodes: self.nodes.len(),
            max_depth: self.max_depth,
            bytes: std::mem::size_of_val(self.samples.as_slice()) + self.nodes.len() * std::mem::size_of::<Node>() + index_bytes,
            mean_radius,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    fn sample(p: Vec3, n: Vec3, e: f32, r: f32) -> IrradianceSample {
        IrradianceSample { p, n, e: Color::splat(e), r }
    }

    #[test]
    fn weights_follow_ward_formula() {
        let s = sample(Vec3::ZERO, Vec3::Y, 1.0, 2.0);
        let a = 0.5;
        // distance term only: w = R / d
        let w = ward_weight(Vec3::new(0.5, 0.0, 0.0), Vec3::Y, &s, a).unwrap();
        assert!((w - 4.0).abs() < 1e-5);
        // at the reach a R = 1: w = 1/a is not valid (strict)
        assert!(ward_weight(Vec3::new(1.0, 0.0, 0.0), Vec3::Y, &s, a).is_none());
        assert!(ward_weight(Vec3::new(0.99, 0.0, 0.0), Vec3::Y, &s, a).is_some());
        // normal term: n·n_i = cos 30° at x = x_i
        let n = Vec3::new(0.5, 3f32.sqrt() / 2.0, 0.0);
        let w = ward_weight(Vec3::ZERO, n, &s, 1.0).unwrap();
        assert!((w - 1.0 / (1.0 - 3f32.sqrt() / 2.0).sqrt()).abs() < 1e-3, "{w}");
        // opposite side, in front, exactly at the sample
        assert!(ward_weight(Vec3::ZERO, -Vec3::Y, &s, 100.0).is_none());
        assert!(ward_weight(Vec3::new(0.1, -0.2, 0.0), Vec3::Y, &s, 100.0).is_none(), "sample in front");
        assert!(ward_weight(Vec3::new(0.1, 0.2, 0.0), Vec3::Y, &s, 100.0).is_some(), "sample behind");
        assert_eq!(ward_weight(Vec3::ZERO, Vec3::Y, &s, 0.1), Some(MAX_WEIGHT));
    }

    /// Interpolating a linear irradiance field from samples on a grid is exact at the samples
    /// and within the field's variation over the reach between them.
    #[test]
    fn interpolation_of_an_analytic_field() {
        let field = |p: Vec3| 1.0 + 0.1 * p.x + 0.05 * p.z;
        let bounds = Bounds3 { min: Vec3::new(0.0, -1.0, 0.0), max: Vec3::new(10.0, 1.0, 10.0) };
        let mut c = WardCache::new(bounds, 0.5, 0.0);
        for i in 0..=10 {
            for j in 0..=10 {
                let p = Vec3::new(i as f32, 0.0, j as f32);
                assert!(c.insert(sample(p, Vec3::Y, field(p), 3.0)));
            }
        }
        let mut s = Sampler::new(1, 1, 1);
        for _ in 0..500 {
            let x = Vec3::new(10.0 * s.next_1d(), 0.0, 10.0 * s.next_1d());
            let (ok, l) = c.query(x, Vec3::Y);
            assert!(ok);
            // reach a R = 1.5: the valid samples lie within 1.5 of x, and a weighted mean of
            // a linear field over them is within the field's variation on that disk
            let e = l.irradiance().x;
            assert!((e - field(x)).abs() <= 1.5 * (0.1f32.hypot(0.05)) + 1e-4, "{x}: {e} vs {}", field(x));
            // brute force over all samples gives the same sums
            let mut bw = 0.0f32;
            let mut bwe = 0.0f32;
            for smp in c.samples() {
                if let Some(w) = ward_weight(x, Vec3::Y, smp, 0.5) {
                    bw += w;
                    bwe += w * smp.e.x;
                }
            }
            assert!((bw - l.sum_w).abs() < 1e-3 * bw && (bwe - l.sum_we.x).abs() < 1e-3 * bwe);
        }
        // exact at a sample; symmetric point between 4 samples gets their mean
        let p = Vec3::new(3.0, 0.0, 4.0);
        assert!((c.lookup(p, Vec3::Y).irradiance().x - field(p)).abs() < 1e-4);
        let mid = Vec3::new(3.5, 0.0, 4.5);
        assert!((c.lookup(mid, Vec3::Y).irradiance().x - field(mid)).abs() < 1e-4);
        // a wall at right angles does not take the floor's samples
        assert!(!c.query(Vec3::new(5.0, 0.5, 5.0), Vec3::X).0);
        // far away: nothing
        assert_eq!(c.lookup(Vec3::new(50.0, 0.0, 5.0), Vec3::Y).count, 0);
    }

    #[test]
    fn octree_lookup_matches_brute_force_for_mixed_radii() {
        let bounds = Bounds3 { min: Vec3::ZERO, max: Vec3::splat(100.0) };
        let mut c = WardCache::new(bounds, 0.3, 0.0);
        let mut s = Sampler::new(2, 2, 2);
        for _ in 0..2000 {
            let p = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 120.0 - 10.0; // some outside
            let n = crate::sampling::square_to_uniform_sphere(s.next_2d());
            let r = 0.5 + 60.0 * s.next_1d().powi(4);
            c.insert(sample(p, n, s.next_1d(), r));
        }
        assert!(c.stats().max_depth >= 3);
        for _ in 0..300 {
            let x = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 110.0 - 5.0;
            let n = crate::sampling::square_to_uniform_sphere(s.next_2d());
            let l = c.lookup(x, n);
            let count = c.samples().iter().filter(|smp| ward_weight(x, n, smp, 0.3).is_some()).count();
            assert_eq!(l.count as usize, count);
        }
        assert!(!c.insert(sample(Vec3::ZERO, Vec3::Y, 1.0, 0.0)), "zero radius is refused");
        assert!(!c.insert(sample(Vec3::ZERO, Vec3::Y, f32::NAN, 1.0)), "NaN is refused");
    }

    #[test]
    fn priming_is_deterministic_and_respects_the_spacing() {
        // points on a plane in a scrambled order; samples of radius 1 with a = 0.5
        let mut s = Sampler::new(4, 4, 4);
        let points: Vec<(Vec3, Vec3)> = (0..5000).map(|_| (Vec3::new(20.0 * s.next_1d(), 0.0, 20.0 * s.next_1d()), Vec3::Y)).collect();
        let bounds = Bounds3 { min: Vec3::new(0.0, -1.0, 0.0), max: Vec3::new(20.0, 1.0, 20.0) };
        let run = |threads: usize, batch: usize| {
            rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| {
                let mut c = WardCache::new(bounds, 0.5, 0.0);
                let st = c.prime(&points, batch, |i| Some(sample(points[i].0, points[i].1, 1.0, 1.0)));
                (c.samples().to_vec(), st)
            })
        };
        let (a, sa) = run(1, 64);
        let (b, sb) = run(2, 64);
        assert_eq!(a, b);
        assert_eq!(sa, sb);
        assert_eq!(sa.inserted, a.len());
        assert_eq!(sa.computed, sa.inserted + sa.discarded + sa.rejected);
        // no two samples closer than the reach a R = 0.5, and every point covered
        for (i, p) in a.iter().enumerate() {
            for q in &a[i + 1..] {
                assert!(p.p.distance(q.p) >= 0.5 - 1e-5);
            }
        }
        let mut c = WardCache::new(bounds, 0.5, 0.0);
        for smp in &a {
            c.insert(*smp);
        }
        assert!(points.iter().all(|&(p, n)| c.query(p, n).0));
        // batch size 1 is Ward's sequential lazy fill: nothing computed in vain
        let (_, s1) = run(2, 1);
        assert_eq!(s1.discarded, 0);
    }
}
