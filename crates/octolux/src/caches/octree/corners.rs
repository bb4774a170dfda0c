//! The §7 blend precomputed at the corners of each valid leaf and interpolated trilinearly
//! inside it (`query = corners`; `docs/performance.md`, "The octree's query"; issue 14 item 4).
//!
//! The paper's query (§7) blends, at every shading point `P`, the valid leaves that the box
//! `V = P ± h` meets, weighted by their overlap volumes, and the leak test
//! (`integrators/octree.rs`) decides per leaf met whether its light can reach `P`. Per query
//! that reads 3–6 leaves and casts about one visibility ray on the Cornell boxes. Here the
//! blend is evaluated once per valid leaf `L` and *query class* (the dominant half-axis of the
//! geometric normal on the query's side) at the 8 corners of `L`'s cell, with the leak test's
//! verdict for each leaf `L`'s box can meet decided once, from `L`'s own sampled photons on that
//! side, instead of from `P`. A query then locates `L` and interpolates: per corner and
//! matrix `k` of the six (`+X, −X, +Y, −Y, +Z, −Z`), the sums `Σ γ_j M_{j,k}` and `Σ γ_j` over
//! the kept leaves `j` whose matrix `k` carries a value; both are interpolated with the
//! trilinear weights of `P` in the cell and divided, per axis, as the exact blend divides its
//! sums ([`super::query`]).
//!
//! What it is and is not:
//! - Exact where the field is constant (furnaces): every corner then holds `Σγ · M` and `Σγ`.
//! - Continuous across the faces of leaves of equal size that share the corners and the
//!   verdicts; not across a face shared with smaller leaves (a T-junction), nor where the
//!   verdicts of neighbouring leaves differ (the exact blend's leak test is not continuous
//!   there either).
//! - Inside a leaf larger than the query box the exact blend is flat in the middle and ramps
//!   near the faces; the trilinear interpolation ramps across the whole leaf.
//! - The leak test's verdicts come from the leaf's photons, not from `P`: the caller decides
//!   per query whether `P` may use the table (it sees the table's origin; else the exact query).
//!
//! 1 920 bytes per table (8 corners × 6 matrices × (9 + 1) floats), built at preparation,
//! render-time data (not in cache files).

use super::compress::{decompress_matrix, MATRIX_BYTES};
use super::{LeafValues, Octree, ANCHOR_SAMPLES, NO_VALUE};
use crate::math::Color;
use glam::{Mat3, Vec3, Vec4};
use rayon::prelude::*;

/// Classes of queries: the dominant half-axis of the geometric normal on the query's side, in
/// the order `+X, −X, +Y, −Y, +Z, −Z`.
pub const QUERY_CLASSES: usize = 6;

/// The class of a query whose geometric normal (on the query's side) is `n`.
#[inline]
pub fn query_class(n: Vec3) -> usize {
    let a = n.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    2 * axis + (n[axis] < 0.0) as usize
}

/// The unit half-axis of class `c`.
#[inline]
pub fn class_axis(c: usize) -> Vec3 {
    let mut v = Vec3::ZERO;
    v[c / 2] = if c.is_multiple_of(2) { 1.0 } else { -1.0 };
    v
}

/// Weight `N_a²` under which an axis is left out of the interpolated blend.
const AXIS_SKIP: f32 = 1e-6;

/// One leaf's blend at its cell's corners, for one query class.
#[derive(Clone, Debug)]
pub struct CornerTable {
    /// Per matrix `k`, per sum `i` (0–8: the components of `Σ γ_j M_{j,k}` in column order,
    /// over the kept leaves `j` whose matrix `k` carries a value; 9: the matching `Σ γ_j`), the
    /// 8 corners as two lanes of 4 (corner `c`: bit 0 x, bit 1 y, bit 2 z at the cell's upper
    /// face), so that the interpolation is two products and a sum per value.
    sums: [[[Vec4; 2]; 10]; 6],
    /// Where the verdicts were decided from (lifted photons of the leaf, on the class's side;
    /// the first `origins_len`): a query point may use the table when it sees one of them.
    pub origins: [Vec3; ANCHOR_SAMPLES],
    pub origins_len: u8,
}

/// The corner tables of one octree ([`Octree::corner_tables`]).
#[derive(Clone, Debug, Default)]
pub struct CornerTables {
    /// Per valid leaf, per class: `index + 1` into `tables`, 0 when none (the exact query).
    slot: Vec<[u32; QUERY_CLASSES]>,
    tables: Vec<CornerTable>,
}

/// What the caller's leak test decided for one leaf and class ([`Octree::corner_tables`]).
pub struct Verdicts {
    /// Per entry of the leaf's list of leaves a query box can meet: whether its light is kept.
    pub keep: Vec<bool>,
    /// See [`CornerTable::origins`] (at most [`ANCHOR_SAMPLES`] are kept).
    pub origins: Vec<Vec3>,
}

impl CornerTables {
    /// The table of valid leaf `v` for query class `class`.
    #[inline]
    pub fn get(&self, v: u32, class: usize) -> Option<&CornerTable> {
        let s = self.slot.get(v as usize)?[class];
        (s != 0).then(|| &self.tables[s as usize - 1])
    }

    /// Tables built, and the bytes they hold.
    pub fn size(&self) -> (usize, usize) {
        (self.tables.len(), std::mem::size_of_val(self.tables.as_slice()) + std::mem::size_of_val(self.slot.as_slice()))
    }
}

impl CornerTable {
    /// The blend of [`super::query`] from the sums interpolated at `t` (in `[0, 1]³` of the
    /// cell): `leaf(m)` gives an axis's term from its blended matrix `m`.
    #[inline]
    fn blend<T>(&self, t: Vec3, n: Vec3, zero: T, leaf: impl Fn(&Mat3) -> T) -> Option<T>
    where
        T: Copy + std::ops::AddAssign + std::ops::Mul<f32, Output = T>,
    {
        // trilinear weights, corners 0–3 (z low) and 4–7 (z high)
        let (u, v) = (Vec3::ONE - t, t);
        let xy = Vec4::new(u.x * u.y, v.x * u.y, u.x * v.y, v.x * v.y);
        let (lo, hi) = (xy * u.z, xy * v.z);
        let dot = |l: &[Vec4; 2]| (lo * l[0] + hi * l[1]).element_sum();
        let s = |v: f32, a: usize| if v >= 0.0 { 2 * a } else { 2 * a + 1 };
        let sel = [s(n.x, 0), s(n.y, 1), s(n.z, 2)];
        let sw = [n.x * n.x, n.y * n.y, n.z * n.z];
        let (mut out, mut norm, mut any) = (zero, 0.0f32, false);
        for a in 0..3 {
            let k = &self.sums[sel[a]];
            let den = dot(&k[9]);
            if den > 0.0 {
                any = true;
                // an axis whose weight `N_a²` is below 1e-6 changes the result by less than
                // that share: skipped (the exact blend counts it)
                if sw[a] > AXIS_SKIP {
                    let m = Mat3::from_cols_array(&std::array::from_fn(|i| dot(&k[i])));
                    out += leaf(&m) * (sw[a] / den);
                    norm += sw[a];
                }
            }
        }
        if !any {
            return None;
        }
        Some(if norm > 0.0 { out * (1.0 / norm) } else { zero })
    }
}

impl Octree {
    /// The valid leaf whose cell holds `p`, and `p`'s position in that cell (`[0, 1]³`);
    /// `None` outside the root cube or in an atmospheric leaf.
    #[inline]
    pub fn valid_leaf_at(&self, p: Vec3) -> Option<(u32, Vec3)> {
        let flat = self.flat();
        let node = flat.locate(self, p)?;
        let v = self.nodes[node as usize].value();
        if v == NO_VALUE {
            return None;
        }
        let c = flat.cell(v as usize);
        Some((v, ((p - c.min) / (c.max - c.min)).clamp(Vec3::ZERO, Vec3::ONE)))
    }

    /// Irradiance (W/m², RGB, negative channels clamped) at the point at `t` in valid leaf
    /// `v`'s cell from `table` (one of `v`'s), for unit normal `n`: the exact query's
    /// [`Octree::irradiance`] with its sums interpolated from the corners.
    #[inline]
    pub fn irradiance_from(&self, table: &CornerTable, t: Vec3, n: Vec3) -> Option<Color> {
        table.blend(t, n, Vec3::ZERO, |m| m.transpose() * n).map(|e| e.max(Vec3::ZERO))
    }

    /// [`Octree::incident_matrix`] from `table` (see [`Octree::irradiance_from`]).
    #[inline]
    pub fn incident_matrix_from(&self, table: &CornerTable, t: Vec3, n: Vec3) -> Option<Mat3> {
        table.blend(t, n, Mat3::ZERO, |m| *m)
    }

    /// The corner tables: for every valid leaf `v` and class `c` (its facing half-axes; with
    /// `per_class` false, one table for every class, from class 0), `verdicts(v, c, list)` gets
    /// the valid leaves a query box centred in `v`'s cell can meet (`list`, ascending) and says
    /// which of them the leak test keeps (or `None`: no table, the exact query). Deterministic
    /// (the tables depend on `verdicts` and the tree only); parallel over leaves.
    pub fn corner_tables(&self, per_class: bool, verdicts: impl Fn(u32, usize, &[u32]) -> Option<Verdicts> + Sync) -> CornerTables {
        let flat = self.flat();
        let n_valid = self.anchors.len();
        let h = Vec3::splat(self.query_half);
        let matrix = |j: usize, k: usize| match &self.values {
            LeafValues::Compressed(c) => decompress_matrix(&c[j][k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES]),
            LeafValues::Full(f) => f[j][k],
        };
        let per_leaf: Vec<Vec<(usize, CornerTable)>> = (0..n_valid)
            .into_par_iter()
            .map(|v| {
                let list = flat.list_of_valid(v);
                let cell = flat.cell(v);
                let mut out = Vec::new();
                // a query's class is the dominant half-axis of the surface it lies on, which
                // the leaf's facing bits hold (all of them when the geometry is unknown)
                let bits = if per_class { self.facing.get(v).copied().unwrap_or(super::ALL_FACING) } else { 1 };
                for class in (0..QUERY_CLASSES).filter(|c| bits & (1 << c) != 0) {
                    let Some(ver) = verdicts(v as u32, class, list) else { continue };
                    let mut origins = [Vec3::ZERO; ANCHOR_SAMPLES];
                    let origins_len = ver.origins.len().min(ANCHOR_SAMPLES);
                    origins[..origins_len].copy_from_slice(&ver.origins[..origins_len]);
                    let mut t = CornerTable { sums: [[[Vec4::ZERO; 2]; 10]; 6], origins, origins_len: origins_len as u8 };
                    let corners: [Vec3; 8] = std::array::from_fn(|c| {
                        Vec3::new(
                            if c & 1 != 0 { cell.max.x } else { cell.min.x },
                            if c & 2 != 0 { cell.max.y } else { cell.min.y },
                            if c & 4 != 0 { cell.max.z } else { cell.min.z },
                        )
                    });
                    // per kept leaf its matrices, decoded once; then its weight at each corner
                    // (the sums of each corner and matrix still add the leaves in list order)
                    for (&j, _) in list.iter().zip(&ver.keep).filter(|(_, &keep)| keep) {
                        let b = flat.cell(j as usize);
                        let bits = self.facing.get(j as usize).copied().unwrap_or(super::ALL_FACING);
                        let m: [Option<[f32; 9]>; 6] =
                            std::array::from_fn(|k| (bits & (1 << k) != 0).then(|| matrix(j as usize, k).to_cols_array()));
                        for (c, corner) in corners.iter().enumerate() {
                            let (qmin, qmax) = (*corner - h, *corner + h);
                            if !(qmin.cmplt(b.upper).all() && qmax.cmpgt(b.min).all()) {
                                continue;
                            }
                            let o = b.max.min(qmax) - b.min.max(qmin);
                            let g = o.x * o.y * o.z;
                            for (sums, m) in t.sums.iter_mut().zip(&m) {
                                if let Some(m) = m {
                                    for i in 0..9 {
                                        sums[i][c / 4][c % 4] += m[i] * g;
                                    }
                                    sums[9][c / 4][c % 4] += g;
                                }
                            }
                        }
                    }
                    out.push((class, t));
                }
                out
            })
            .collect();
        let mut tables = CornerTables { slot: vec![[0; QUERY_CLASSES]; n_valid], tables: Vec::new() };
        for (v, l) in per_leaf.into_iter().enumerate() {
            for (class, t) in l {
                tables.tables.push(t);
                let i = tables.tables.len() as u32;
                if per_class {
                    tables.slot[v][class] = i;
                } else {
                    tables.slot[v] = [i; QUERY_CLASSES];
                }
            }
        }
        tables
    }
}
