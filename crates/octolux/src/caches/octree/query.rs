//! Queries (paper §5.2 normal interpolation, §7 overlap-volume blend) and debug accessors.
//!
//! A query box `V` of side `alpha × min_leaf_size` centred on `P` is intersected with the
//! leaves by a depth-first traversal that only enters children overlapping `V` (positive
//! volume); valid leaves add `γ_k M_k(N)` and `γ_k`, atmospheric ones nothing. No
//! allocation: the traversal is a recursion of depth at most `h_max`.
//!
//! `M_k(N) = Σ_a M_{k,a}^{s(N_a)} N_a²`, `E = M(N)ᵀ N`; with compressed leaves
//! `M ≈ D Cᵀ`, so `Mᵀ N = C (D·N)` costs one dot product per matrix. The blend over leaves
//! is done per axis, so that a leaf whose matrix `(a, s)` describes no surface (a floor-only
//! cell queried for a wall's normal) is left out of that axis instead of pulling it to 0.

use super::cells::{quantize, TreeView};
use super::compress::{decompress_matrix, MATRIX_BYTES};
use super::{LeafInfo, LeafValues, Octree, QueryLeaf, ALL_FACING, NO_VALUE};
use crate::math::{Bounds3, Color};
use glam::{Mat3, Vec3};

/// The type of "no leak test" in [`Octree::blend`].
type NoKeep = fn(QueryLeaf) -> Option<f32>;

/// The three matrices (indices into the `+X, −X, +Y, −Y, +Z, −Z` order) used for normal
/// `n`, and their weights `N_a²`.
#[inline]
fn selection(n: Vec3) -> ([usize; 3], [f32; 3]) {
    let s = |v: f32, a: usize| if v >= 0.0 { 2 * a } else { 2 * a + 1 };
    ([s(n.x, 0), s(n.y, 1), s(n.z, 2)], [n.x * n.x, n.y * n.y, n.z * n.z])
}

impl Octree {
    #[inline]
    pub(super) fn view(&self) -> TreeView<'_> {
        TreeView { nodes: &self.nodes, origin: self.origin, cell_size: &self.cell_size }
    }

    /// Visit the valid leaves overlapping the query box centred on `p`: `f(value, γ)`, in
    /// depth-first order. From the flat lists (`flat.rs`: locate the leaf holding `p`, loop over
    /// its list); the tree walk for a point outside the root cube. Both give the same leaves,
    /// order and weights.
    #[inline]
    fn visit_query<F: FnMut(usize, f32)>(&self, p: Vec3, mut f: F) {
        let h = Vec3::splat(self.query_half);
        let (qmin, qmax) = (p - h, p + h);
        if self.flat().visit(self, p, qmin, qmax, &mut f) {
            return;
        }
        let nodes = &self.nodes;
        self.view().visit(qmin, qmax, |node, _, _, g| {
            let v = nodes[node as usize].value();
            if v != NO_VALUE {
                f(v as usize, g);
            }
        });
    }

    /// The anchors of valid leaf `v` (cell at `depth`, `ijk`) in world space (decoded once per
    /// tree into the flat lists, `flat.rs`).
    pub(super) fn query_leaf(&self, v: usize, depth: u32, ijk: [u32; 3]) -> QueryLeaf {
        let view = self.view();
        let (cmin, s) = (view.cell_min(depth, ijk), self.cell_size[depth as usize]);
        let a = &self.anchors[v];
        let samples = a.samples.map(|x| (x.position(cmin, s), x.normal().normalize_or_zero()));
        QueryLeaf { position: a.mean.position(cmin, s), normal: a.mean.normal(), cell_size: s, samples, index: v as u32 }
    }

    /// Mean direction the light of valid leaf `index` arrives from, for the normal `n` (the
    /// summed irradiance vectors of the matrix of `n`'s dominant axis; unit, pointing away from
    /// the surface; zero when unknown or when `index` is not a valid leaf).
    pub fn leaf_direction(&self, index: u32, n: Vec3) -> Vec3 {
        let (v, sel) = (index as usize, selection(n));
        let k = sel.0[if sel.1[0] >= sel.1[1] && sel.1[0] >= sel.1[2] {
            0
        } else if sel.1[1] >= sel.1[2] {
            1
        } else {
            2
        }];
        let m = match &self.values {
            LeafValues::Compressed(c) if v < c.len() => decompress_matrix(&c[v][k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES]),
            LeafValues::Full(f) if v < f.len() => f[v][k],
            _ => return Vec3::ZERO,
        };
        (m.x_axis + m.y_axis + m.z_axis).normalize_or_zero()
    }

    /// `M_{k,a}^{s(N_a)ᵀ} N` of one leaf for the three axes (not yet weighted by `N_a²`).
    #[inline]
    fn leaf_irradiance(&self, v: usize, n: Vec3, sel: &([usize; 3], [f32; 3])) -> [Vec3; 3] {
        let mut e = [Vec3::ZERO; 3];
        match &self.values {
            LeafValues::Compressed(_) => {
                // `D` and `C` of each matrix, decoded once per tree (`flat.rs`)
                let leaf = &self.flat().decoded[v];
                for (a, ea) in e.iter_mut().enumerate() {
                    let [d, col] = leaf[sel.0[a]];
                    *ea = col * d.dot(n);
                }
            }
            LeafValues::Full(m) => {
                let leaf = &m[v];
                for (a, ea) in e.iter_mut().enumerate() {
                    *ea = leaf[sel.0[a]].transpose() * n;
                }
            }
        }
        e
    }

    /// `M_{k,a}^{s(N_a)}` of one leaf for the three axes: `D Cᵀ` from the factors decoded once
    /// per tree (`flat.rs`), as [`decompress_matrix`] forms it.
    #[inline]
    fn leaf_matrix(&self, v: usize, sel: &([usize; 3], [f32; 3])) -> [Mat3; 3] {
        match &self.values {
            LeafValues::Compressed(_) => {
                let leaf = &self.flat().decoded[v];
                std::array::from_fn(|a| {
                    let [d, c] = leaf[sel.0[a]];
                    Mat3::from_cols(d * c.x, d * c.y, d * c.z)
                })
            }
            LeafValues::Full(f) => std::array::from_fn(|a| f[v][sel.0[a]]),
        }
    }

    /// The §7 blend, per axis: `M(N) = Σ_a N_a² (Σ_k γ_k M_{k,a}) / (Σ_k γ_k)` where `k` runs
    /// over the valid leaves whose matrix `(a, s(N_a))` carries a value ([`Octree::facing`];
    /// all of them unless `Split::Normal` knows the geometry); the `N_a²` are renormalised
    /// over the axes that got any leaf. `None` when no leaf contributes.
    /// `keep`, when given, sees every valid leaf met and may drop it (`None`: out of both
    /// sums) or scale its value by a factor (leak control; see [`Octree::irradiance_where`]).
    #[inline]
    fn blend<T, K>(&self, p: Vec3, n: Vec3, zero: T, keep: Option<K>, leaf: impl Fn(usize, &([usize; 3], [f32; 3])) -> [T; 3]) -> Option<T>
    where
        T: Copy + std::ops::AddAssign + std::ops::Mul<f32, Output = T>,
        K: FnMut(QueryLeaf) -> Option<f32>,
    {
        self.blend_over(p, n, zero, keep, leaf, None)
    }

    /// [`Octree::blend`] over the valid leaves the query box meets, or with `only = Some(v)`
    /// over valid leaf `v` alone, of weight 1 ([`Octree::leaf_incident_matrix`]).
    #[inline]
    fn blend_over<T, K>(
        &self,
        p: Vec3,
        n: Vec3,
        zero: T,
        mut keep: Option<K>,
        leaf: impl Fn(usize, &([usize; 3], [f32; 3])) -> [T; 3],
        only: Option<usize>,
    ) -> Option<T>
    where
        T: Copy + std::ops::AddAssign + std::ops::Mul<f32, Output = T>,
        K: FnMut(QueryLeaf) -> Option<f32>,
    {
        if !p.is_finite() || !n.is_finite() {
            return None;
        }
        let sel = selection(n);
        let mut sum = [zero; 3];
        let mut wsum = [0.0f32; 3];
        let leaves = keep.is_some().then(|| self.flat().leaves.as_slice());
        let mut add = |v: usize, g: f32| {
            let f = match (keep.as_mut(), leaves) {
                (Some(k), Some(leaves)) => match k(leaves[v]) {
                    Some(f) => f,
                    None => return,
                },
                _ => 1.0,
            };
            let bits = self.facing.get(v).copied().unwrap_or(ALL_FACING);
            let terms = leaf(v, &sel);
            for a in 0..3 {
                if bits & (1 << sel.0[a]) != 0 {
                    sum[a] += terms[a] * (g * f);
                    wsum[a] += g;
                }
            }
        };
        match only {
            Some(v) => add(v, 1.0),
            None => self.visit_query(p, &mut add),
        }
        let mut out = zero;
        let mut norm = 0.0f32;
        let mut any = false;
        for a in 0..3 {
            if wsum[a] > 0.0 {
                any = true;
                if sel.1[a] > 0.0 {
                    out += sum[a] * (sel.1[a] / wsum[a]);
                    norm += sel.1[a];
                }
            }
        }
        if !any {
            return None;
        }
        Some(if norm > 0.0 { out * (1.0 / norm) } else { zero })
    }

    /// Irradiance (W/m², RGB) at `p` for the unit normal `n`: the §7 blend of `M_k(N)ᵀ N`,
    /// negative channels clamped to 0. `None` when no valid leaf meets the query box (or
    /// `p`/`n` is not finite).
    pub fn irradiance(&self, p: Vec3, n: Vec3) -> Option<Color> {
        self.blend(p, n, Vec3::ZERO, None::<NoKeep>, |v, sel| self.leaf_irradiance(v, n, sel)).map(|e| e.max(Vec3::ZERO))
    }

    /// The blended incident-radiance matrix `M(N)` at `p` (columns = r, g, b irradiance
    /// vectors), for glossy shading. `None` as for [`Octree::irradiance`].
    pub fn incident_matrix(&self, p: Vec3, n: Vec3) -> Option<Mat3> {
        self.blend(p, n, Mat3::ZERO, None::<NoKeep>, |v, sel| self.leaf_matrix(v, sel))
    }

    /// [`Octree::irradiance`] over the valid leaves that `keep` accepts: it sees each leaf's
    /// anchors (where its photons lie, where their light came from) and says whether that light
    /// can reach `p`, e.g. by visibility rays (leak control, see the module docs): `None` drops
    /// the leaf from the blend (out of both sums), `Some(f)` keeps its weight `γ_k` and scales
    /// its value by `f` (the share of its light that reaches `p`, in [0, 1]). Where `keep`
    /// answers `Some(1.0)` for every leaf the result is [`Octree::irradiance`]'s, with the same
    /// continuity.
    /// `keep` is generic (a `&mut dyn FnMut` works too), so that a closure is called directly
    /// for every leaf met.
    pub fn irradiance_where(&self, p: Vec3, n: Vec3, keep: impl FnMut(QueryLeaf) -> Option<f32>) -> Option<Color> {
        self.blend(p, n, Vec3::ZERO, Some(keep), |v, sel| self.leaf_irradiance(v, n, sel)).map(|e| e.max(Vec3::ZERO))
    }

    /// [`Octree::incident_matrix`] over the valid leaves that `keep` accepts (see
    /// [`Octree::irradiance_where`]).
    pub fn incident_matrix_where(&self, p: Vec3, n: Vec3, keep: impl FnMut(QueryLeaf) -> Option<f32>) -> Option<Mat3> {
        self.blend(p, n, Mat3::ZERO, Some(keep), |v, sel| self.leaf_matrix(v, sel))
    }

    /// `M(N)` of the valid leaf holding `p` alone: the §7 blend's per-axis rule over that one
    /// leaf, without its neighbours (no overlap weights, no leak test). `None` in an
    /// atmospheric leaf, outside the cube, or where the leaf's matrices of `n`'s axes carry no
    /// value.
    pub fn leaf_incident_matrix(&self, p: Vec3, n: Vec3) -> Option<Mat3> {
        self.leaf_edge_and_matrix(p, n)?.1
    }

    /// The edge of the leaf holding `p` (its [`LeafInfo::bounds`]' x extent) and, for a valid
    /// leaf, its [`Octree::leaf_incident_matrix`]: one descent for both. `None` outside the
    /// cube.
    pub fn leaf_edge_and_matrix(&self, p: Vec3, n: Vec3) -> Option<(f32, Option<Mat3>)> {
        let (node, depth, ijk) = self.find_leaf(p)?;
        let min = self.view().cell_min(depth, ijk).x;
        // as `info` forms the bounds, so that the edge is theirs to the last bit
        let edge = (min + self.cell_size[depth as usize]) - min;
        let v = self.nodes[node as usize].value();
        if v == NO_VALUE {
            return Some((edge, None));
        }
        Some((edge, self.blend_over(p, n, Mat3::ZERO, None::<NoKeep>, |v, sel| self.leaf_matrix(v, sel), Some(v as usize))))
    }

    /// The six matrices of the valid leaf containing `p` (decompressed), in the order
    /// `+X, −X, +Y, −Y, +Z, −Z`; `None` outside the cube or in an atmospheric leaf.
    pub fn leaf_matrices(&self, p: Vec3) -> Option<[Mat3; 6]> {
        let (node, _, _) = self.find_leaf(p)?;
        let v = self.nodes[node as usize].value();
        if v == NO_VALUE {
            return None;
        }
        Some(match &self.values {
            LeafValues::Compressed(c) => {
                std::array::from_fn(|k| decompress_matrix(&c[v as usize][k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES]))
            }
            LeafValues::Full(f) => f[v as usize],
        })
    }

    /// Descend to the leaf whose (half-open) cell holds `p`: `(node, depth, ijk)`.
    pub(super) fn find_leaf(&self, p: Vec3) -> Option<(u32, u32, [u32; 3])> {
        if !p.is_finite() || !self.bounds().contains(p) {
            return None;
        }
        let q = quantize(p, self.origin, self.inv_quant, self.h_max);
        let mut node = 0u32;
        let mut depth = 0u32;
        loop {
            let n = self.nodes[node as usize];
            if n.is_leaf() {
                let s = self.h_max - depth;
                return Some((node, depth, [q[0] >> s, q[1] >> s, q[2] >> s]));
            }
            let s = self.h_max - depth - 1;
            let c = ((q[0] >> s) & 1) | (((q[1] >> s) & 1) << 1) | (((q[2] >> s) & 1) << 2);
            node = n.link + c;
            depth += 1;
        }
    }

    fn info(&self, node: u32, depth: u32, ijk: [u32; 3]) -> LeafInfo {
        let n = self.nodes[node as usize];
        let min = self.view().cell_min(depth, ijk);
        LeafInfo {
            bounds: Bounds3 { min, max: min + Vec3::splat(self.cell_size[depth as usize]) },
            depth,
            valid: n.value() != NO_VALUE,
            photons: n.photons,
        }
    }

    /// The leaf containing `p` (debug / visualisation); `None` outside the root cube.
    pub fn leaf_at(&self, p: Vec3) -> Option<LeafInfo> {
        self.find_leaf(p).map(|(node, depth, ijk)| self.info(node, depth, ijk))
    }

    /// Every leaf, atmospheric included, in depth-first order (debug / visualisation).
    pub fn leaf_infos(&self) -> Vec<LeafInfo> {
        let mut out = Vec::with_capacity(self.stats.leaves);
        let b = self.bounds();
        self.view().visit(b.min, b.max, |node, depth, ijk, _| out.push(self.info(node, depth, ijk)));
        out
    }

    /// Sum of the query weights `γ_k` over the valid leaves and over all leaves, for the
    /// query box centred on `p` (tests and diagnostics).
    pub fn query_weights(&self, p: Vec3) -> (f32, f32) {
        let h = Vec3::splat(self.query_half);
        let (mut valid, mut all) = (0.0f32, 0.0f32);
        self.view().visit(p - h, p + h, |node, _, _, g| {
            all += g;
            if self.nodes[node as usize].value() != NO_VALUE {
                valid += g;
            }
        });
        (valid, all)
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{cornell_geometry, cornell_photons};
    use super::super::{Estimator, Octree, OctreeSettings, Split};
    use crate::math::Bounds3;
    use crate::sampling::{square_to_uniform_sphere, Sampler};
    use glam::Vec3;

    /// A leaf alone gives the blend's value wherever the query box lies inside that leaf's cell
    /// (the §7 blend over one leaf: per axis, the facing bits, the weights renormalised), and
    /// nothing where the blend finds no valid leaf either; near a cell's border they differ.
    /// The leaves know the box's walls (the normal split), so that some of their matrices face
    /// none (checked: the test fails when a leaf alone ignores its facing bits, or does not
    /// renormalise over the axes left).
    #[test]
    fn a_leaf_alone_is_the_blend_inside_its_cell() {
        let photons = cornell_photons(100_000, 6);
        let cube = Bounds3 { min: Vec3::ZERO, max: Vec3::ONE };
        let s = OctreeSettings { n_max: 100, split: Split::Normal, estimator: Estimator::GeometryArea, ..Default::default() };
        // with the geometry, the leaves know which of their six matrices face a surface
        let t = Octree::build(&photons, cube, &s, Some(&cornell_geometry())).unwrap();
        let h = 0.5 * t.query_size();
        let mut rng = Sampler::new(9, 0, 0);
        let (mut inside, mut valued, mut differ) = (0, 0, 0);
        for i in 0..16_000 {
            let mut p = Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d());
            if i % 2 == 0 {
                p[i % 3] = h * (1.001 + rng.next_1d()); // near the walls, where the photons are
            }
            let n = square_to_uniform_sphere(rng.next_2d());
            let leaf = t.leaf_at(p).unwrap();
            let (single, blend) = (t.leaf_incident_matrix(p, n), t.incident_matrix(p, n));
            let b = leaf.bounds;
            if (p - Vec3::splat(h)).cmpge(b.min).all() && (p + Vec3::splat(h)).cmple(b.max).all() {
                inside += 1;
                match (single, blend) {
                    (Some(a), Some(b)) => {
                        valued += 1;
                        let scale = b.abs().to_cols_array().into_iter().fold(1e-12f32, f32::max);
                        let err = (a - b).abs().to_cols_array().into_iter().fold(0.0f32, f32::max);
                        assert!(err <= 1e-5 * scale, "{p} {n}: {a} against the blend's {b}");
                    }
                    (a, b) => assert_eq!(a.is_some(), b.is_some(), "{p} {n}"),
                }
            } else if single != blend {
                differ += 1;
            }
        }
        assert!(inside > 200 && valued > 50, "points inside one cell: {inside}, {valued} with a value");
        assert!(differ > 100, "near borders the blend mixes leaves: {differ}");
    }
}
