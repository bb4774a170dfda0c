//! Christensen's precomputed irradiance photons ("Faster photon map global illumination",
//! JGT 4(3), 1999/2000), the paper's second baseline (the paper's §9, `m_e` = 378).
//!
//! Irradiance is estimated once at every `every`-th photon of the global map (in the photon
//! pass's emission order, which is a random subset of the photons; Christensen used every
//! fourth) with the photon density estimate of [`crate::caches::kdtree`] (`n_max` photons
//! within `r_max`, normal = the photon's surface normal on its arrival side), and stored with
//! the photon's position and normal as an [`IrradianceSample`] (the radius `r` is the disk
//! the estimate gathered). A lookup at `(x, n)` returns the **nearest** irradiance photon
//! within the lookup radius (usually `r_max`) whose normal is compatible, `n·n_p > normal_cos` (Christensen: a normal
//! test, so that light is not taken from the other side of a corner or of a thin sheet): a
//! piecewise-constant (Voronoi) irradiance, no interpolation.
//!
//! Determinism: the estimates run in parallel but each is a pure function of its photon and
//! the (deterministic) photon kd-tree, collected in photon order; the irradiance photons'
//! kd-tree is deterministic too.

use crate::caches::kdtree::{photon_irradiance, Density, KdTree, PhotonTree};
use crate::caches::ward::IrradianceSample;
use crate::photon::Photon;
use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

/// Statistics of the precomputation.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ChristensenStats {
    /// Irradiance photons (`m_e`).
    pub samples: usize,
    /// Precomputation time, seconds.
    pub t_precompute_s: f64,
    /// Bytes of the irradiance photons' kd-tree.
    pub bytes: usize,
    /// Mean photons per estimate.
    pub mean_photons: f64,
}

/// Irradiance photons in a kd-tree, read-only (`Sync`).
#[derive(Clone, Debug)]
pub struct ChristensenCache {
    tree: KdTree<IrradianceSample>,
    r_max: f32,
    normal_cos: f32,
    stats: ChristensenStats,
}

impl ChristensenCache {
    /// Precompute the irradiance at every `every`-th photon of `photons` (the global map, in
    /// emission order) from `map` (the same photons in a kd-tree); lookups search within
    /// `lookup_radius`. `every` 0 is taken as 1; photons with non-finite fields are skipped.
    pub fn build(photons: &[Photon], map: &PhotonTree, every: u32, density: Density, lookup_radius: f32, normal_cos: f32) -> Self {
        let t0 = std::time::Instant::now();
        let every = every.max(1) as usize;
        let chosen: Vec<&Photon> = photons.iter().step_by(every).filter(|p| p.is_finite()).collect();
        let est: Vec<(IrradianceSample, usize)> = chosen
            .par_iter()
            .map_init(Vec::new, |scratch, ph| {
                let d = photon_irradiance(map, ph.p, ph.ng, density, scratch);
                (IrradianceSample { p: ph.p, n: ph.ng, e: d.e, r: d.r.max(f32::MIN_POSITIVE) }, d.count)
            })
            .collect();
        let mean_photons = if est.is_empty() { 0.0 } else { est.iter().map(|e| e.1 as f64).sum::<f64>() / est.len() as f64 };
        let tree = KdTree::build(est.into_iter().map(|e| e.0).collect());
        let stats = ChristensenStats { samples: tree.len(), t_precompute_s: t0.elapsed().as_secs_f64(), bytes: tree.bytes(), mean_photons };
        ChristensenCache { tree, r_max: lookup_radius, normal_cos, stats }
    }

    /// The nearest irradiance photon within the lookup radius of `x` with `n·n_p > normal_cos`.
    #[inline]
    pub fn lookup(&self, x: Vec3, n: Vec3) -> Option<&IrradianceSample> {
        let c = self.normal_cos;
        self.tree.nearest(x, self.r_max, |s| s.n.dot(n) > c).map(|(i, _)| &self.tree.items()[i])
    }

    pub fn samples(&self) -> &[IrradianceSample] {
        self.tree.items()
    }

    pub fn stats(&self) -> &ChristensenStats {
        &self.stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Color;
    use crate::sampling::Sampler;

    /// Photons on a floor (y = 0, normal +y) and a wall (x = 0, normal +x) meeting at a corner,
    /// with different flux densities.
    fn corner_photons(n: usize) -> Vec<Photon> {
        let mut s = Sampler::new(7, 7, 7);
        (0..n)
            .map(|i| {
                let (u, v) = (s.next_1d() * 10.0, s.next_1d() * 10.0);
                if i % 2 == 0 {
                    Photon { p: Vec3::new(u, 0.0, v), wi: Vec3::new(0.2, 0.9, 0.1).normalize(), power: Color::splat(1e-3), ng: Vec3::Y }
                } else {
                    Photon { p: Vec3::new(0.0, u, v), wi: Vec3::new(0.9, 0.2, 0.1).normalize(), power: Color::splat(3e-3), ng: Vec3::X }
                }
            })
            .collect()
    }

    #[test]
    fn lookup_picks_the_nearest_compatible_sample() {
        let photons = corner_photons(40_000);
        let map = PhotonTree::build(photons.clone());
        let d = Density { n_max: 100, r_max: 1.0 };
        // every 3rd: both surfaces (alternating photons) get irradiance photons
        let c = ChristensenCache::build(&photons, &map, 3, d, d.r_max, 0.9);
        assert_eq!(c.stats().samples, 13_334);
        let mut s = Sampler::new(8, 8, 8);
        for _ in 0..200 {
            // near the corner on the floor: the nearest sample may be on the wall, the lookup
            // must still return a floor one, the nearest of them
            let x = Vec3::new(0.5 * s.next_1d(), 0.0, 10.0 * s.next_1d());
            let got = c.lookup(x, Vec3::Y).expect("a floor sample within r_max");
            assert_eq!(got.n, Vec3::Y);
            let best = c.samples().iter().filter(|t| t.n.dot(Vec3::Y) > 0.9).map(|t| t.p.distance_squared(x)).fold(f32::INFINITY, f32::min);
            assert_eq!(got.p.distance_squared(x), best);
        }
        // irradiance of the floor far from the wall: 20 000 photons of 1e-3 W on 100 units² = 0.2
        let x = Vec3::new(5.0, 0.0, 5.0);
        let e = c.lookup(x, Vec3::Y).unwrap().e.x;
        assert!((e - 0.2).abs() < 0.05, "{e}");
        // wall: 0.6
        let e = c.lookup(Vec3::new(0.0, 5.0, 5.0), Vec3::X).unwrap().e.x;
        assert!((e - 0.6).abs() < 0.15, "{e}");
        // no compatible normal (ceiling facing down), or too far
        assert!(c.lookup(x, -Vec3::Y).is_none());
        assert!(c.lookup(Vec3::new(5.0, 3.0, 5.0), Vec3::Y).is_none());
    }

    #[test]
    fn precomputation_is_identical_for_one_and_two_threads() {
        let photons = corner_photons(20_000);
        let run = |t| {
            rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap().install(|| {
                let map = PhotonTree::build(photons.clone());
                ChristensenCache::build(&photons, &map, 3, Density { n_max: 50, r_max: 2.0 }, 2.0, 0.9).samples().to_vec()
            })
        };
        assert_eq!(run(1), run(2));
    }
}
