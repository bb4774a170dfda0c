//! Incident radiance at a free point from the photons' flights: the *beam* (ray-map)
//! estimate. A stored photon ([`crate::photon::Photon`]) landed at `p` coming from `wi`
//! after a straight flight of length `len` (to the surface it left: the caller finds it by
//! one ray). Its flight is the segment `p + t wi`, `t ∈ [0, len]`.
//!
//! For a direction `ω`, the photon flights crossing a disc of area `π r²` centred on `x` and
//! perpendicular to `ω` carry the flux `π r² L(x, ω) dω` (for a radiance field smooth over
//! the disc). So, with a kernel `K` over the disc of unit integral,
//! `c_lm(x) ≈ Σ_p K(d_p) Φ_p Y_lm(wi_p)` over the flights passing at distance `d_p < r` of `x`
//! (the point of closest approach lying within the flight) estimates the SH coefficients
//! `∫ L(x, ω) Y_lm(ω) dω` of the incident radiance at `x`, in free space as near surfaces
//! (a surface cutting the disc hides flights that end before it: an underestimate at grazing
//! directions within `r` of a surface). This is the "beam radiance estimate" of Jarosz,
//! Zwicker & Jensen (Eurographics 2008) without a medium, equivalently the ray maps of
//! Havran et al. (Eurographics 2005) read at a point. The kernel is Epanechnikov's,
//! `K(d) = 2 (1 − d²/r²) / (π r²)`.
//!
//! Search: each flight is marched in steps of one grid cell and listed in the cell of every
//! step point (once per run of equal cells; counting sort into one index array). A query
//! visits the cells overlapping its ball grown by half a cell and tests each listed flight
//! exactly; a flight is counted in one cell only, that of its step point nearest to its
//! closest approach (within half a cell of it, so inside the visited cells): no duplicate,
//! no sort. Deterministic: each query sums its flights in cell and index order. One grid per
//! kernel radius (the caller makes one per brick level, cell = radius): the cost per query
//! stays a fixed multiple of the flights it uses.

use super::sh::{basis, ShOrder, MAX_COEFFS};
use crate::photon::Photon;
use glam::Vec3;

/// Most index entries the grid may hold (4 bytes each); the cell grows past the asked size
/// rather than exceed it.
pub const MAX_ENTRIES: usize = 64 << 20;

/// Photon flights bucketed in a uniform grid over a cube.
pub struct Flights<'a> {
    photons: &'a [Photon],
    lengths: &'a [f32],
    origin: Vec3,
    cell: f32,
    n: usize,
    /// CSR: flights of cell `i` are `index[start[i]..start[i + 1]]`.
    start: Vec<u32>,
    index: Vec<u32>,
}

impl<'a> Flights<'a> {
    /// Bucket the flights (`lengths[i]`: flight length of `photons[i]`, world units) over the
    /// cube at `origin` of edge `size`, in cells of about `cell` (grown to fit
    /// `MAX_ENTRIES` and at most 256 cells per axis).
    pub fn new(photons: &'a [Photon], lengths: &'a [f32], origin: Vec3, size: f32, cell: f32) -> Flights<'a> {
        assert_eq!(photons.len(), lengths.len());
        let total: f64 = lengths.iter().map(|&l| if l.is_finite() { l.min(2.0 * size) as f64 } else { 0.0 }).sum();
        let mut cell = cell.max(size / 256.0);
        // entries ≈ Σ len / cell + photons
        let budget = (MAX_ENTRIES - photons.len().min(MAX_ENTRIES / 2)) as f64;
        if total / cell as f64 > budget {
            cell = (total / budget) as f32;
        }
        let n = ((size / cell).ceil() as usize).clamp(1, 256);
        let cell = size / n as f32;
        let mut f = Flights { photons, lengths, origin, cell, n, start: vec![0; n * n * n + 1], index: Vec::new() };
        let mut counts = vec![0u32; n * n * n];
        f.march(|c, _| counts[c] += 1);
        let mut acc = 0u32;
        for (i, c) in counts.iter().enumerate() {
            f.start[i] = acc;
            acc += c;
        }
        f.start[n * n * n] = acc;
        let mut next = f.start.clone();
        let mut index = vec![0u32; acc as usize];
        f.march(|c, i| {
            index[next[c] as usize] = i;
            next[c] += 1;
        });
        f.index = index;
        f
    }

    /// Cell edge used.
    pub fn cell(&self) -> f32 {
        self.cell
    }

    /// Index entries held.
    pub fn entries(&self) -> usize {
        self.index.len()
    }

    fn cell_of(&self, p: Vec3) -> Option<usize> {
        let q = (p - self.origin) / self.cell;
        if !(q.min_element() >= 0.0) || !(q.max_element() < self.n as f32) {
            return None;
        }
        let n = self.n;
        Some(q.x as usize + n * (q.y as usize + n * q.z as usize))
    }

    /// The flight's length as marched (clamped to where it leaves the cube for good: its
    /// landing point's distance to the cube's centre plus the cube's edge) and its step count.
    #[inline]
    fn steps(&self, ph: &Photon, len: f32) -> (f32, usize) {
        let size = self.cell * self.n as f32;
        let reach = (ph.p - (self.origin + Vec3::splat(0.5 * size))).length() + size;
        let len = len.min(reach);
        (len, (len / self.cell).ceil() as usize)
    }

    /// Cell of step `k` of a flight of (marched) length `len`.
    #[inline]
    fn step_cell(&self, ph: &Photon, len: f32, k: usize) -> Option<usize> {
        let t = (k as f32 * self.cell).min(len);
        self.cell_of(ph.p + ph.wi * t)
    }

    /// Every (cell, flight) pair of the steps, once per run of equal cells, in flight order.
    fn march(&self, mut f: impl FnMut(usize, u32)) {
        for (i, (ph, &len)) in self.photons.iter().zip(self.lengths).enumerate() {
            if !ph.is_finite() || !(len >= 0.0) {
                continue;
            }
            let (len, steps) = self.steps(ph, len);
            let mut last = usize::MAX;
            for k in 0..=steps {
                if let Some(c) = self.step_cell(ph, len, k) {
                    if c != last {
                        f(c, i as u32);
                        last = c;
                    }
                }
            }
        }
    }

    /// The beam estimate of the incident radiance's SH coefficients at `x` with kernel radius
    /// `r` (see the module docs; best with `r` about the grid's cell), and the number of
    /// flights it used.
    pub fn estimate(&self, x: Vec3, r: f32, order: ShOrder) -> ([Vec3; MAX_COEFFS], usize) {
        let grow = r + 0.5 * self.cell;
        let last = self.n as f32 - 1.0;
        let lo = ((x - grow - self.origin) / self.cell).floor().clamp(Vec3::ZERO, Vec3::splat(last));
        let hi = ((x + grow - self.origin) / self.cell).floor().clamp(Vec3::ZERO, Vec3::splat(last));
        let n = self.n;
        let r2 = r * r;
        let norm = 2.0 / (std::f64::consts::PI * r2 as f64);
        let k = order.coefficients();
        let mut acc = [[0.0f64; 3]; MAX_COEFFS];
        let mut used = 0;
        for z in lo.z as usize..=hi.z as usize {
            for y in lo.y as usize..=hi.y as usize {
                for xx in lo.x as usize..=hi.x as usize {
                    let c = xx + n * (y + n * z);
                    for &i in &self.index[self.start[c] as usize..self.start[c + 1] as usize] {
                        let ph = &self.photons[i as usize];
                        let (len, steps) = self.steps(ph, self.lengths[i as usize]);
                        let v = x - ph.p;
                        let t = v.dot(ph.wi);
                        if !(t >= 0.0 && t <= len) {
                            continue;
                        }
                        let d2 = v.length_squared() - t * t;
                        if !(d2 < r2) {
                            continue;
                        }
                        // counted in the cell of the step point nearest to the closest approach
                        let k_near = ((t / self.cell).round() as usize).min(steps);
                        if self.step_cell(ph, len, k_near) != Some(c) {
                            continue;
                        }
                        used += 1;
                        let w = norm * (1.0 - (d2 / r2).max(0.0)) as f64;
                        let yb = basis(ph.wi);
                        for (j, a) in acc.iter_mut().enumerate().take(k) {
                            let s = w * yb[j] as f64;
                            a[0] += s * ph.power.x as f64;
                            a[1] += s * ph.power.y as f64;
                            a[2] += s * ph.power.z as f64;
                        }
                    }
                }
            }
        }
        let mut c = [Vec3::ZERO; MAX_COEFFS];
        for (ci, a) in c.iter_mut().zip(acc.iter()) {
            *ci = Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
        }
        (c, used)
    }
}
