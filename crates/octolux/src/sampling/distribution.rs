//! Piecewise-constant distributions sampled by CDF inversion: [`Distribution1D`] over items (a
//! guide table narrows the search), [`Distribution2D`] over the cells of a grid (a marginal
//! over rows, a conditional per row). Used by the light selection and environment maps.

use glam::Vec2;

/// A piecewise-constant discrete distribution over `n` items, sampled by CDF inversion.
#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    /// Per index `i` in `0..=n`: the normalised CDF below it, `[i].0` (`cdf[0] = 0`,
    /// `cdf[n] = 1`), and its probability, `[i].1` (0 for `i = n`): side by side, so that the
    /// probability of the index a search finds is on the cache line the search read.
    cells: Vec<(f32, f32)>,
    /// `n`.
    n: usize,
    /// A guide table (empty below [`GUIDE_MIN`] entries): `guide[k]` is the number of CDF
    /// values `<= k / G` for `k = 0..=G`, `G = guide.len() - 1` a power of two, about `n / 8`.
    /// A sample `u` in `[k/G, (k+1)/G)` then searches only `cells[guide[k]..guide[k + 1]]`, a few
    /// entries on one or two cache lines instead of `log2 n` of them far apart: the same index
    /// as the search of the whole CDF, with one cache miss where that had a chain of them.
    guide: Vec<u32>,
    /// Sum of the (unnormalised) weights, accumulated in f64.
    total: f64,
}

/// Distributions with fewer values than this search their CDF without a guide table.
pub const GUIDE_MIN: usize = 64;

/// Distributions with fewer values than this count the CDF values below a sample instead of
/// searching them.
const LINEAR_MAX: usize = 16;

impl Distribution1D {
    /// Build from non-negative finite weights. Returns `None` when the sum is not positive.
    pub fn new(weights: &[f32]) -> Option<Self> {
        let mut acc = 0.0f64;
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        cdf.push(0.0f64);
        for &w in weights {
            let w = if w.is_finite() && w > 0.0 { w as f64 } else { 0.0 };
            acc += w;
            cdf.push(acc);
        }
        if !(acc > 0.0) {
            return None;
        }
        let pmf = weights.iter().map(|&w| if w.is_finite() && w > 0.0 { (w as f64 / acc) as f32 } else { 0.0 });
        let cdf = cdf.into_iter().map(|c| (c / acc) as f32).collect::<Vec<_>>();
        let guide = if weights.len() < GUIDE_MIN || weights.len() > u32::MAX as usize / 2 {
            Vec::new()
        } else {
            // k / g is exact in f32 (g a power of two below 2^24)
            let g = (weights.len() / 8).next_power_of_two().min(1 << 22);
            (0..=g).map(|k| cdf.partition_point(|&c| c <= k as f32 / g as f32) as u32).collect()
        };
        let cells = cdf.iter().copied().zip(pmf.chain([0.0])).collect();
        Some(Distribution1D { cells, n: weights.len(), guide, total: acc })
    }

    pub fn len(&self) -> usize {
        self.n
    }
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }
    pub fn total(&self) -> f64 {
        self.total
    }
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.cells[i].1
    }

    /// Sample an index with `u` in [0,1); returns the index, its probability and `u` rescaled
    /// to [0,1) within the chosen bucket (for reuse as a fresh uniform number).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        let n = self.n;
        // the number of CDF values <= u, through the guide table when there is one
        let below = if n < LINEAR_MAX {
            // a few values: counted without branches (a search's branches on `u` mispredict);
            // the CDF is nondecreasing, so the count is where the search would end
            self.cells.iter().map(|c| usize::from(c.0 <= u)).sum()
        } else if self.guide.len() < 2 {
            self.cells.partition_point(|c| c.0 <= u)
        } else {
            let g = self.guide.len() - 1;
            let k = ((u * g as f32) as usize).min(g - 1);
            let (lo, hi) = (self.guide[k] as usize, self.guide[k + 1] as usize);
            lo + self.cells[lo..hi].partition_point(|c| c.0 <= u)
        };
        // first index i with cdf[i+1] > u
        let mut i = below.saturating_sub(1).min(n - 1);
        // skip zero-probability buckets that floating point may land on
        while self.cells[i].1 == 0.0 && i + 1 < n {
            i += 1;
        }
        while self.cells[i].1 == 0.0 && i > 0 {
            i -= 1;
        }
        let lo = self.cells[i].0;
        let w = self.cells[i + 1].0 - lo;
        let ur = if w > 0.0 { ((u - lo) / w).clamp(0.0, 1.0 - f32::EPSILON) } else { 0.5 };
        (i, self.cells[i].1, ur)
    }
}

/// A piecewise-constant distribution over an `nx × ny` grid of cells covering the unit square
/// (row-major weights, `weights[iy * nx + ix]`), sampled by a marginal distribution over rows
/// and one conditional distribution per row (Pharr, Jakob & Humphreys, PBRT 3rd ed. §13.6.7).
#[derive(Clone, Debug)]
pub struct Distribution2D {
    nx: usize,
    ny: usize,
    /// Per row: distribution over its cells (`None` for a row of zero weight).
    rows: Vec<Option<Distribution1D>>,
    /// Distribution over rows (by row total).
    marginal: Distribution1D,
}

impl Distribution2D {
    /// Build from non-negative weights; `None` when the grid is empty, the length is not
    /// `nx * ny` or the total weight is not positive.
    pub fn new(weights: &[f32], nx: usize, ny: usize) -> Option<Self> {
        if nx == 0 || ny == 0 || weights.len() != nx * ny {
            return None;
        }
        let rows: Vec<Option<Distribution1D>> = weights.chunks(nx).map(Distribution1D::new).collect();
        let totals: Vec<f32> = rows.iter().map(|r| r.as_ref().map_or(0.0, |d| d.total() as f32)).collect();
        let marginal = Distribution1D::new(&totals)?;
        Some(Distribution2D { nx, ny, rows, marginal })
    }

    /// Grid size `(nx, ny)`.
    pub fn size(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Sum of the weights (accumulated in f64).
    pub fn total(&self) -> f64 {
        self.marginal.total()
    }

    /// Probability of cell `(ix, iy)` (zero outside the grid).
    #[inline]
    pub fn pmf(&self, ix: usize, iy: usize) -> f32 {
        if ix >= self.nx || iy >= self.ny {
            return 0.0;
        }
        match &self.rows[iy] {
            Some(r) => self.marginal.pmf(iy) * r.pmf(ix),
            None => 0.0,
        }
    }

    /// Sample a cell with `u` in [0,1)²: returns `(ix, iy)`, its probability and `u`
    /// rescaled to [0,1)² within the cell.
    #[inline]
    pub fn sample_cell(&self, u: Vec2) -> Option<(usize, usize, f32, Vec2)> {
        let (iy, py, uy) = self.marginal.sample(u.y);
        let row = self.rows[iy].as_ref()?;
        let (ix, px, ux) = row.sample(u.x);
        let p = px * py;
        (p > 0.0).then_some((ix, iy, p, Vec2::new(ux, uy)))
    }

    /// Sample a point of the unit square; returns it and its density w.r.t. area.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec2, f32)> {
        let (ix, iy, p, r) = self.sample_cell(u)?;
        let pt = Vec2::new((ix as f32 + r.x) / self.nx as f32, (iy as f32 + r.y) / self.ny as f32);
        Some((pt.min(Vec2::splat(1.0 - f32::EPSILON)), p * (self.nx * self.ny) as f32))
    }

    /// Density w.r.t. area at a point of the unit square (the density [`Self::sample`] uses).
    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        if !(p.x >= 0.0 && p.x <= 1.0 && p.y >= 0.0 && p.y <= 1.0) {
            return 0.0;
        }
        let ix = ((p.x * self.nx as f32) as usize).min(self.nx - 1);
        let iy = ((p.y * self.ny as f32) as usize).min(self.ny - 1);
        self.pmf(ix, iy) * (self.nx * self.ny) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    #[test]
    fn distribution_sampling_matches_pmf() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0]).unwrap();
        let mut counts = [0usize; 4];
        let n = 80_000;
        for i in 0..n {
            let (k, p, ur) = d.sample((i as f32 + 0.5) / n as f32);
            assert!((0.0..1.0).contains(&ur));
            assert_eq!(p, d.pmf(k));
            counts[k] += 1;
        }
        assert_eq!(counts[1], 0);
        assert!((counts[0] as f32 / n as f32 - 0.125).abs() < 1e-3);
        assert!((counts[3] as f32 / n as f32 - 0.5).abs() < 1e-3);
        assert!(Distribution1D::new(&[0.0, 0.0]).is_none());
        assert!(Distribution1D::new(&[f32::NAN]).is_none());
    }

    /// The index a binary search of the whole CDF finds for `u` (zero buckets skipped).
    fn searched(d: &Distribution1D, u: f32) -> usize {
        let n = d.len();
        let mut i = d.cells.partition_point(|c| c.0 <= u).saturating_sub(1).min(n - 1);
        while d.pmf(i) == 0.0 && i + 1 < n {
            i += 1;
        }
        while d.pmf(i) == 0.0 && i > 0 {
            i -= 1;
        }
        i
    }

    /// Small distributions count the CDF values below `u` instead of searching: the same
    /// index for every `u`, the CDF's own values included, with zero weights among them.
    #[test]
    fn the_count_of_a_small_distribution_finds_what_the_search_finds() {
        let mut s = Sampler::new(3, 0, 0);
        for n in 1..LINEAR_MAX + 2 {
            let w: Vec<f32> = (0..n).map(|i| if i % 3 == 1 { 0.0 } else { s.next_1d() + 0.1 }).collect();
            let d = Distribution1D::new(&w).unwrap();
            let us: Vec<f32> = (0..2000).map(|_| s.next_1d()).chain(d.cells.iter().map(|c| c.0).filter(|&c| c < 1.0)).collect();
            for u in us {
                let (i, p, _) = d.sample(u);
                assert_eq!((i, p), (searched(&d, u), d.pmf(searched(&d, u))), "n = {n}, u = {u}");
            }
        }
    }

    /// The guide table changes where the search looks, not what it finds: the same index as a
    /// search of the whole CDF for every `u`, the guide's own boundaries `k / G` included, over
    /// weights with runs of zeros and a few large values.
    #[test]
    fn the_guide_table_finds_what_the_whole_search_finds() {
        let mut s = Sampler::new(9, 0, 0);
        let w: Vec<f32> = (0..5000)
            .map(|i| {
                if (i / 97) % 3 == 1 {
                    0.0
                } else if i % 1013 == 0 {
                    5000.0
                } else {
                    s.next_1d()
                }
            })
            .collect();
        let d = Distribution1D::new(&w).unwrap();
        assert_eq!(d.guide.len(), 1024 + 1);
        let whole = |u: f32| searched(&d, u);
        let us = (0..200_000).map(|_| s.next_1d()).chain((0..1024).map(|k| k as f32 / 1024.0)).chain([0.0, 1.0 - f32::EPSILON / 2.0]);
        for u in us {
            assert_eq!(d.sample(u).0, whole(u), "u = {u}");
        }
        // small distributions search without a guide
        assert!(Distribution1D::new(&w[..GUIDE_MIN - 1]).unwrap().guide.is_empty());
    }
}
