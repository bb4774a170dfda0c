//! Where on the bounding disc distant-light photons are worth emitting (a cheap portal
//! estimate for paper §2's photon pass; issue 11, items 3 and 5).
//!
//! Distant lights (sun, sky, environment maps, constant and directional light) emit photons
//! from a disc of the scene's bounding sphere, perpendicular to the photon's direction
//! (`scene/lights.rs`). In an interior lit through windows almost all of that disc sends its
//! photons past the building or onto its outside walls: Bitterli's `classroom` stored 302
//! global photons out of 250 000 emitted, `dining-room` 5 141.
//!
//! A pilot pass (rounds of [`PILOT_ROUND`] photons until [`PILOT_STORED`] are stored, at most
//! [`pilot_cap`]), its photons emitted exactly as the main pass emits them,
//! counts per direction bin ([`DIR_Z`] x [`DIR_PHI`] equal-area bins of the travel direction)
//! and per disc cell ([`GRID`]² cells of the unit square that the area-preserving concentric
//! map sends onto the disc) how many photons each cell's paths stored. The main pass then
//! draws the disc position of a distant-light photon from, per direction bin,
//!
//! `q(u) = DEFENSIVE + (1 − DEFENSIVE) · c(u) / c̄`
//!
//! (density on the unit square, mean 1; `c` the pilot counts blurred over 3x3 cells, `c̄` their
//! mean) instead of uniformly, and multiplies the photon's power by `1 / q(u)`. Since `q > 0`
//! everywhere the estimate of every stored flux stays unbiased for any pilot outcome; the
//! defensive share bounds the weight by `1 / DEFENSIVE`, which is what a photon from a cell the
//! pilot missed can carry. A bin whose pilot photons stored fewer than [`MIN_STORED`] photons
//! keeps the uniform disc (weight 1): too few to say where its useful part is.
//!
//! Pilot photon `i` draws from `Sampler::new(seed, i, PILOT_STREAM)` and the counts are integers
//! summed in index order, so the guide, like the maps, is the same for any thread count.

use crate::sampling::Distribution2D;
use crate::scene::Light;
use glam::{Vec2, Vec3};

/// Equal-area bins of the direction's z (cosine) coordinate. Even, so that z = 0 — where
/// `Frame::from_normal`, which orients the disc, flips — is a bin edge.
pub const DIR_Z: usize = 8;
/// Bins of the direction's azimuth.
pub const DIR_PHI: usize = 16;
/// Disc cells per side of the unit square (classroom: bounding radius 25 m, cells of 1.6 m).
pub const GRID: usize = 32;
/// Share of the uniform disc in every guided bin (weights stay at most `1 / DEFENSIVE`).
pub const DEFENSIVE: f32 = 0.1;
/// Least stored pilot photons for a direction bin to be guided.
pub const MIN_STORED: u32 = 16;

/// Pilot paths per round.
pub const PILOT_ROUND: u64 = 1 << 15;
/// The pilot stops once its paths have stored this many photons (32 per direction bin on
/// average; classroom does not get there within 1M paths: 0.12% of its paths store a photon).
pub const PILOT_STORED: u64 = 4096;

/// Most pilot paths for a pass of `photons`: as many, between 2^16 and 2^21.
pub fn pilot_cap(photons: u64) -> u64 {
    photons.clamp(1 << 16, 1 << 21)
}

/// Whether a light emits its photons from the scene's bounding disc.
pub fn from_disc(light: &Light) -> bool {
    match light {
        Light::Directional { .. } | Light::Constant { .. } | Light::Envmap { .. } | Light::Sunsky(_) => true,
        Light::Area { .. } | Light::Point { .. } | Light::Spot { .. } => false,
    }
}

/// Direction bin of a unit travel direction.
pub fn dir_bin(d: Vec3) -> usize {
    let iz = (((d.z + 1.0) * 0.5 * DIR_Z as f32) as usize).min(DIR_Z - 1);
    let phi = d.y.atan2(d.x) + std::f32::consts::PI;
    let ip = ((phi * (0.5 / std::f32::consts::PI) * DIR_PHI as f32) as usize).min(DIR_PHI - 1);
    iz * DIR_PHI + ip
}

/// Cell of a point of the unit square (row-major, `iy * GRID + ix`).
pub fn cell(u: Vec2) -> usize {
    let ix = ((u.x * GRID as f32) as usize).min(GRID - 1);
    let iy = ((u.y * GRID as f32) as usize).min(GRID - 1);
    iy * GRID + ix
}

/// Per direction bin, the distribution of disc positions (`None`: uniform).
#[derive(Clone, Debug, Default)]
pub struct DiscGuide {
    bins: Vec<Option<Distribution2D>>,
}

impl DiscGuide {
    /// From the pilot's counts: `counts[bin * GRID² + cell]` = photons stored by the paths
    /// that started in that bin and cell.
    pub fn from_counts(counts: &[u32]) -> DiscGuide {
        let cells = GRID * GRID;
        let bins = (0..DIR_Z * DIR_PHI)
            .map(|b| {
                let c = counts.get(b * cells..(b + 1) * cells)?;
                if c.iter().map(|&x| x as u64).sum::<u64>() < MIN_STORED as u64 {
                    return None;
                }
                // 3x3 blur: a window seen by a few pilot photons is wider than their cells.
                let mut w = vec![0.0f32; cells];
                for iy in 0..GRID {
                    for ix in 0..GRID {
                        let mut s = 0.0f32;
                        for jy in iy.saturating_sub(1)..(iy + 2).min(GRID) {
                            for jx in ix.saturating_sub(1)..(ix + 2).min(GRID) {
                                s += c[jy * GRID + jx] as f32;
                            }
                        }
                        w[iy * GRID + ix] = s;
                    }
                }
                let mean = w.iter().map(|&x| x as f64).sum::<f64>() / cells as f64;
                let scale = (1.0 - DEFENSIVE) / mean as f32;
                w.iter_mut().for_each(|x| *x = DEFENSIVE + *x * scale);
                Distribution2D::new(&w, GRID, GRID)
            })
            .collect();
        DiscGuide { bins }
    }

    /// Direction bins that are guided.
    pub fn guided_bins(&self) -> usize {
        self.bins.iter().filter(|b| b.is_some()).count()
    }

    /// Redraw the disc position of a photon travelling along `dir` from the uniform `u`:
    /// the new point of the unit square and the power factor `1 / q` (1 where unguided).
    pub fn sample(&self, dir: Vec3, u: Vec2) -> (Vec2, f32) {
        match self.bins.get(dir_bin(dir)).and_then(Option::as_ref).and_then(|d| d.sample(u)) {
            Some((p, pdf)) if pdf > 0.0 => (p, 1.0 / pdf),
            _ => (u, 1.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_cover_the_sphere_and_the_square() {
        let mut seen = [false; DIR_Z * DIR_PHI];
        let mut s = crate::sampling::Sampler::new(1, 2, 3);
        for _ in 0..20_000 {
            let d = crate::sampling::square_to_uniform_sphere(s.next_2d());
            seen[dir_bin(d)] = true;
        }
        assert!(seen.iter().all(|&x| x), "every direction bin is reachable");
        assert_eq!(dir_bin(Vec3::Z), (DIR_Z - 1) * DIR_PHI + DIR_PHI / 2);
        assert_eq!(cell(Vec2::new(0.999_999, 0.999_999)), GRID * GRID - 1);
        assert_eq!(cell(Vec2::ZERO), 0);
    }

    #[test]
    fn guided_density_is_normalised_and_bounded() {
        // One bin with all its pilot photons in one cell: the density there is large, the
        // others get the defensive share, and E_q[1/q] over the square is 1 (unbiased).
        let cells = GRID * GRID;
        let mut counts = vec![0u32; DIR_Z * DIR_PHI * cells];
        let bin = dir_bin(Vec3::new(0.3, -0.2, 0.93).normalize());
        counts[bin * cells + 5 * GRID + 7] = 1000;
        counts[(bin + 1) * cells + 3] = MIN_STORED - 1; // too few: stays uniform
        let g = DiscGuide::from_counts(&counts);
        assert_eq!(g.guided_bins(), 1);
        let dir = Vec3::new(0.3, -0.2, 0.93).normalize();
        let mut s = crate::sampling::Sampler::new(0, 0, 9);
        let (n, mut sum_w, mut inside) = (200_000, 0.0f64, 0usize);
        for _ in 0..n {
            let (p, w) = g.sample(dir, s.next_2d());
            assert!(p.x >= 0.0 && p.x < 1.0 && p.y >= 0.0 && p.y < 1.0);
            assert!(w > 0.0 && w <= 1.0 / DEFENSIVE * 1.0001, "weight {w}");
            sum_w += w as f64;
            let (ix, iy) = ((p.x * GRID as f32) as usize, (p.y * GRID as f32) as usize);
            inside += (ix.abs_diff(7) <= 1 && iy.abs_diff(5) <= 1) as usize;
        }
        // Uniform density integrates to 1: mean weight 1 within noise (weights in [0.01, 10]).
        let mean = sum_w / n as f64;
        assert!((mean - 1.0).abs() < 0.02, "mean weight {mean}");
        // 9 blurred cells hold 90% of the guided mass plus their defensive share.
        let frac = inside as f64 / n as f64;
        let want = (1.0 - DEFENSIVE as f64) + DEFENSIVE as f64 * 9.0 / cells as f64;
        assert!((frac - want).abs() < 0.01, "{frac} of the samples near the pilot's cell, want {want}");
        let (p, w) = g.sample(Vec3::new(-0.3, 0.2, -0.93).normalize(), Vec2::new(0.25, 0.75));
        assert_eq!((p, w), (Vec2::new(0.25, 0.75), 1.0), "an unguided bin keeps the uniform sample");
    }
}
