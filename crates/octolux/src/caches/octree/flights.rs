//! Free-space light from the photons' flights: the values of the atmospheric cells (issue 26,
//! item 1; docs/guide/baking.md, "A volumetric solution"). The paper leaves its atmospheric
//! cells empty (§3) and names values in them as future work (§10); `atmosphere.rs` diffuses the
//! surfaces' values into them, which copies what the nearby surfaces that face the same way
//! receive. A cell crossed by enough photon flights takes instead the light that passes
//! through it.
//!
//! # The estimate
//! A photon of power `Φ` (W, RGB) flying a length `ℓ` through a cell of volume `V` adds
//! `Φ ℓ / V` to the cell's mean fluence `∫ L(ω) dω` (W/m²): the track-length estimator of
//! particle transport. Weighted by a function `g` of the direction `w` the light comes from
//! (the photon's `wi`), `Σ Φ ℓ g(w) / V` estimates the cell's mean of `∫ L(w) g(w) dω`. With
//! `g(w) = w` over the directions of one half-axis (`w_a > 0` for `+a`), this is the
//! irradiance vector of that hemisphere, the quantity of a valid leaf's matrix: a sensor of
//! normal `N_k` anywhere in the cell receives `E = M_kᵀ N_k`. Each flight adds `Φ ℓ w / V` to
//! the three matrices of the half-axes its `w` lies on (the paper's direction split, §5.2);
//! a query of another normal blends them as the paper does (`M(N) = Σ_a M_a^{s(N_a)} N_a²`).
//!
//! # The flights
//! The flights are those of the global photons (light reflected at least once by a non-delta
//! surface, the light the octree stands for; direct light is traced at render time): from each
//! stored photon back along `wi` to the surface it left, found by one ray. The SH probes of
//! `caches::probes` use the same flights. Flights that end on a mirror or glass, or that leave
//! the scene, store no photon and are not counted.
//!
//! # Anchors
//! Each leaf's flights also give where its light passes: their centroid, each crossing's
//! midpoint weighted by its power (channel mean) times its length in the cell. The volume
//! query's leak test sees the leaf there (`atmosphere/volume.rs`): a cell cut by a wall whose
//! flights lie behind it is not seen from the room.
//!
//! # Determinism
//! Photons are taken in fixed chunks; each chunk's crossings are sorted by leaf and summed in
//! f64, and the chunks' sums are added in chunk order: the values are bit-identical for any
//! thread count.

use super::compress::FullLeaf;
use super::Octree;
use crate::photon::Photon;
use glam::{Mat3, Vec3};
use rayon::prelude::*;

/// Least flight crossings for an atmospheric leaf to take its flight estimate instead of the
/// diffused values (a leaf crossed by fewer keeps the diffusion's, which then flows from the
/// leaves that have flights). Relative noise of the estimate is about `1/sqrt(crossings)`.
pub const FLIGHT_MIN: u32 = 32;

/// Photons per chunk of the deterministic sum.
const CHUNK: usize = 4096;

/// No index.
const NONE: u32 = u32::MAX;

/// The flight estimate of a tree's atmospheric leaves ([`Octree::flights`]), for
/// [`Octree::fill_atmosphere`].
#[derive(Clone, Debug, Default)]
pub struct Flights {
    /// Per node: index into `values` (an atmospheric leaf crossed at least [`FLIGHT_MIN`]
    /// times), or none.
    pub(super) index: Vec<u32>,
    /// The six matrices of each such leaf.
    pub(super) values: Vec<FullLeaf>,
    /// Per entry of `values`: where its light passes, the flights' centroid (each crossing's
    /// midpoint weighted by its power, channel mean, times its length in the cell).
    pub(super) anchors: Vec<Vec3>,
    /// Flights used (finite, positive length).
    pub flights: usize,
    /// Leaf crossings of those flights in atmospheric leaves.
    pub crossings: u64,
}

/// One chunk's sums of [`Octree::flight_sums`] (opaque), for [`Octree::flights_from`].
#[derive(Clone, Debug, Default)]
pub struct FlightSums {
    /// (node × 8 + octant of the direction the light comes from, sums of `w ⊗ Φ ℓ`, crossings),
    /// sorted by key.
    sums: Vec<(u64, [f64; 9], u32)>,
    /// (node, `Σ x · midpoint`, `Σ x`) with `x` = power (channel mean) × length, sorted by node.
    centroids: Vec<(u32, [f64; 3], f64)>,
    /// Flights used.
    used: usize,
}

impl Flights {
    /// Atmospheric leaves that take their flight estimate.
    pub fn leaves(&self) -> usize {
        self.values.len()
    }
}

impl Octree {
    /// The leaves met by the segment `o + t d`, `t ∈ [0, t_max]`, clipped to the root cube, in
    /// order (`d` need not be unit), with each leaf's cell (depth, integer coordinates) and the
    /// segment's parameters where it enters and leaves it: `f(node, depth, ijk, t_in, t_out)`.
    /// The lengths `t_out − t_in` add up to the clipped segment's.
    pub(super) fn segment_cells(&self, o: Vec3, d: Vec3, t_max: f32, mut f: impl FnMut(u32, u32, [u32; 3], f32, f32)) {
        if !(o.is_finite() && d.is_finite() && t_max > 0.0) {
            return;
        }
        let b = self.bounds();
        let (mut t0, mut t1) = (0.0f32, t_max);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < b.min[a] || o[a] > b.max[a] {
                    return;
                }
                continue;
            }
            let (u, v) = ((b.min[a] - o[a]) / d[a], (b.max[a] - o[a]) / d[a]);
            t0 = t0.max(u.min(v));
            t1 = t1.min(u.max(v));
        }
        if !(t0 < t1) {
            return;
        }
        // a step past a cell's exit, in units of t
        let nudge = 1e-4 * self.stats.min_leaf_size.max(1e-3 * self.size) / d.length();
        let view = self.view();
        let mut t = t0;
        while t < t1 {
            let p = o + d * (t + nudge.min(0.5 * (t1 - t)));
            let Some((node, depth, ijk)) = self.find_leaf(p) else { break };
            let (cmin, s) = (view.cell_min(depth, ijk), self.cell_size[depth as usize]);
            let mut te = t1;
            for a in 0..3 {
                if d[a] != 0.0 {
                    let far = if d[a] > 0.0 { cmin[a] + s } else { cmin[a] };
                    te = te.min((far - o[a]) / d[a]);
                }
            }
            let te = te.max(t + nudge).min(t1);
            f(node, depth, ijk, t, te);
            t = te;
        }
    }

    /// One chunk's share of the flight estimate: the atmospheric leaves that the flights cross,
    /// with their sums. A flight starts at `o`, travels along `d` (unit) for `t` (scene units;
    /// infinite: it left the scene, and counts until it leaves the root cube) and carries
    /// `power` (W, RGB). Sums in f64 over the chunk, in flight order per leaf.
    pub fn flight_sums(&self, flights: impl IntoIterator<Item = (Vec3, Vec3, f32, Vec3)>) -> FlightSums {
        // summed as the flights come (flight order per leaf), so that a chunk holds one entry
        // per leaf and octant it met, not one per crossing
        let mut acc: std::collections::HashMap<u64, ([f64; 9], u32)> = std::collections::HashMap::new();
        let mut cen: std::collections::HashMap<u32, ([f64; 3], f64)> = std::collections::HashMap::new();
        let mut used = 0usize;
        for (o, d, t, c) in flights {
            if !(t > 0.0 && o.is_finite() && d.is_finite() && c.is_finite()) {
                continue;
            }
            used += 1;
            // the direction the light comes from, seen from the cells it crosses
            let w = -d;
            let oct = (w.x < 0.0) as u64 | ((w.y < 0.0) as u64) << 1 | ((w.z < 0.0) as u64) << 2;
            let power = (c.x as f64 + c.y as f64 + c.z as f64) / 3.0;
            self.segment_cells(o, d, t, |node, _, _, t0, t1| {
                if self.nodes[node as usize].value() == super::NO_VALUE {
                    let l = t1 - t0;
                    let a = w * l;
                    let v = [a.x * c.x, a.y * c.x, a.z * c.x, a.x * c.y, a.y * c.y, a.z * c.y, a.x * c.z, a.y * c.z, a.z * c.z];
                    let e = acc.entry(node as u64 * 8 + oct).or_insert(([0.0; 9], 0));
                    e.0.iter_mut().zip(v).for_each(|(s, x)| *s += x as f64);
                    e.1 += 1;
                    let x = power * l as f64;
                    let mid = o + d * (0.5 * (t0 + t1));
                    let g = cen.entry(node).or_insert(([0.0; 3], 0.0));
                    g.0.iter_mut().zip(mid.to_array()).for_each(|(s, m)| *s += x * m as f64);
                    g.1 += x;
                }
            });
        }
        let mut sums: Vec<(u64, [f64; 9], u32)> = acc.into_iter().map(|(k, (v, m))| (k, v, m)).collect();
        sums.sort_unstable_by_key(|r| r.0);
        let mut centroids: Vec<(u32, [f64; 3], f64)> = cen.into_iter().map(|(k, (v, m))| (k, v, m)).collect();
        centroids.sort_unstable_by_key(|r| r.0);
        FlightSums { sums, centroids, used }
    }

    /// The flight estimate (module docs) from the chunks' sums, added in the order given.
    pub fn flights_from(&self, chunks: Vec<FlightSums>) -> Flights {
        let mut atm = vec![NONE; self.nodes.len()];
        let mut atm_nodes = Vec::new();
        for l in self.leaves() {
            if self.nodes[l.node as usize].value() == super::NO_VALUE {
                atm[l.node as usize] = atm_nodes.len() as u32;
                atm_nodes.push(l);
            }
        }
        let mut sums = vec![[0f64; 9]; atm_nodes.len() * 8];
        let mut count = vec![0u32; atm_nodes.len()];
        let mut cen = vec![([0f64; 3], 0f64); atm_nodes.len()];
        let (mut flights, mut crossings) = (0usize, 0u64);
        for chunk in chunks {
            flights += chunk.used;
            for (node, v, m) in chunk.centroids {
                let Some(&j) = atm.get(node as usize).filter(|&&j| j != NONE) else { continue };
                let g = &mut cen[j as usize];
                g.0.iter_mut().zip(v).for_each(|(s, x)| *s += x);
                g.1 += m;
            }
            for (k, v, m) in chunk.sums {
                let Some(&j) = atm.get((k / 8) as usize).filter(|&&j| j != NONE) else { continue };
                let s = &mut sums[j as usize * 8 + (k % 8) as usize];
                s.iter_mut().zip(v).for_each(|(s, x)| *s += x);
                count[j as usize] = count[j as usize].saturating_add(m);
                crossings += m as u64;
            }
        }
        let mut index = vec![NONE; self.nodes.len()];
        let mut values = Vec::new();
        let mut anchors = Vec::new();
        for (j, l) in atm_nodes.iter().enumerate() {
            if count[j] < FLIGHT_MIN {
                continue;
            }
            let inv_v = 1.0 / (self.cell_size[l.depth as usize] as f64).powi(3);
            let leaf: FullLeaf = std::array::from_fn(|k| {
                let (a, neg) = (k / 2, k % 2);
                let mut m = [0f64; 9];
                for oct in (0..8).filter(|o| (o >> a) & 1 == neg) {
                    m.iter_mut().zip(&sums[j * 8 + oct]).for_each(|(s, x)| *s += x);
                }
                let col = |c: usize| Vec3::new((m[3 * c] * inv_v) as f32, (m[3 * c + 1] * inv_v) as f32, (m[3 * c + 2] * inv_v) as f32);
                Mat3::from_cols(col(0), col(1), col(2))
            });
            index[l.node as usize] = values.len() as u32;
            values.push(leaf);
            let (g, m) = cen[j];
            anchors.push(if m > 0.0 { Vec3::new((g[0] / m) as f32, (g[1] / m) as f32, (g[2] / m) as f32) } else { Vec3::NAN });
        }
        Flights { index, values, anchors, flights, crossings }
    }

    /// The flight estimate from stored photons and their flight lengths (scene units;
    /// `lengths[i]` belongs to `photons[i]`, 0 or not finite: no flight): each photon's flight
    /// runs from the surface it left, `p + wi · length`, to `p`.
    pub fn flights(&self, photons: &[Photon], lengths: &[f32]) -> Flights {
        let n = photons.len().min(lengths.len());
        let chunks: Vec<FlightSums> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let r = c * CHUNK..((c + 1) * CHUNK).min(n);
                self.flight_sums(
                    photons[r.clone()]
                        .iter()
                        .zip(&lengths[r])
                        .filter(|(p, l)| l.is_finite() && p.is_finite())
                        .map(|(p, &l)| (p.p + p.wi * l, -p.wi, l, p.power)),
                )
            })
            .collect();
        self.flights_from(chunks)
    }
}
