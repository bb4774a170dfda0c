//! The volume query of the atmospheric values (`atmosphere.rs`, module docs "Query"):
//! [`Octree::incident_matrix_volume`] and [`Octree::irradiance_volume`], and how a leaf with
//! diffused or flight values is read (an ambient cube, or free space by the order-2 fit of its
//! moments).

use super::super::compress::CompressedLeaf;
use super::*;
use crate::caches::sh;

/// An atmospheric leaf's matrix `m` (half-axis `k` of axis `a`, the side of `n_a`) as the
/// volume query uses it when the leaf lacks some of its six (a partial diffusion; with all six,
/// [`free_space_irradiance`]): its irradiance on the axis, `E_k = mᵀ (±e_a)`, as a matrix that
/// gives `E_k` for the normal `n` (`(±e_a / |n_a|) ⊗ E_k`). The blend `Σ_a n_a² M_aᵀ n` then
/// returns `Σ_a n_a² E_a`, the "ambient cube", exact under an isotropic field, where the
/// paper's projection `mᵀ n` read `Σ|n_a|³` (0.58 for `(1, 1, 1)/√3`).
#[inline]
fn ambient_cube(m: Mat3, a: usize, n_a: f32) -> Mat3 {
    if n_a == 0.0 {
        return Mat3::ZERO;
    }
    let mut axis = Vec3::ZERO;
    axis[a] = n_a.signum();
    let e = m.transpose() * axis;
    let d = axis / n_a.abs();
    Mat3::from_cols(d * e.x, d * e.y, d * e.z)
}

/// An atmospheric leaf's six matrices as the volume query uses them for the normal `n`, as the
/// matrix `n ⊗ E(n)`. The six matrices hold the half-space moments `V_k = ∫_{H_k} L w dω`
/// (18 numbers per colour). Fitting them with a radiance of spherical-harmonic order 2 (9
/// coefficients, least squares; the 18 x 9 system has full rank, singular values 0.86–2.5)
/// and taking that radiance's irradiance (Ramamoorthi & Hanrahan's cosine convolution) gives
/// the closed form
/// `E(n) = Σ_a n_a² (E(+a) + E(−a))/2 + m·n/2 + ¼ Σ_{a<b} T_ab n_a n_b`,
/// where `E(±a)` are the axis irradiances (the matrices' diagonal entries), `m = Σ_k V_k / 3`
/// the first moment, and `T_ab = V_{+a,b} − V_{−a,b} + V_{+b,a} − V_{−b,a}`. Exact for every
/// field of order 2 (test `free_space_query_is_exact_for_order_2_fields`); clamped at 0.
/// The paper's projection `Σ_a n_a² M_aᵀ n` is right on a surface, where no light comes from
/// behind it; in free space light from behind the sensor enters it with a negative weight
/// (under an isotropic field a sensor facing `(1, 1, 1)/√3` read 0.58 of its irradiance).
#[inline]
pub(in crate::caches::octree) fn free_space_irradiance(six: &[Mat3; 6], n: Vec3) -> Vec3 {
    free_space_quadratic(six, n).max(Vec3::ZERO)
}

/// [`free_space_irradiance`] before the clamp: a polynomial of degree 2 in `n`.
#[inline]
fn free_space_quadratic(six: &[Mat3; 6], n: Vec3) -> Vec3 {
    // row b of matrix k: component b of its moment, per colour
    let v = |k: usize, b: usize| six[k].row(b);
    let mut m = Vec3::ZERO;
    for mk in six {
        m += mk.transpose() * n;
    }
    let mut e = m * (0.5 / 3.0);
    for a in 0..3 {
        e += (v(2 * a, a) - v(2 * a + 1, a)) * (0.5 * n[a] * n[a]);
    }
    for (a, b) in [(0, 1), (1, 2), (0, 2)] {
        let t = v(2 * a, b) - v(2 * a + 1, b) + v(2 * b, a) - v(2 * b + 1, a);
        e += t * (0.25 * n[a] * n[b]);
    }
    e
}

/// The radiance SH coefficients (bands 0..=2, per colour) of the order-2 fit that
/// [`free_space_irradiance`] reads: the irradiance's coefficients `E_lm` divided by the
/// cosine lobe's `A_l`. `E_lm = ∫ E Y_lm dω` is exact from the 12 vertices of an icosahedron,
/// a spherical 5-design (`E Y_lm` is a polynomial of degree at most 4).
pub(in crate::caches::octree) fn free_space_sh(six: &[Mat3; 6]) -> [Vec3; sh::MAX_COEFFS] {
    let g = 0.5 * (1.0 + 5f32.sqrt());
    let mut c = [Vec3::ZERO; sh::MAX_COEFFS];
    for (a, b) in [(1.0, g), (-1.0, g), (1.0, -g), (-1.0, -g)] {
        for v in [Vec3::new(0.0, a, b), Vec3::new(a, b, 0.0), Vec3::new(b, 0.0, a)] {
            let v = v.normalize();
            let e = free_space_quadratic(six, v);
            for (ci, y) in c.iter_mut().zip(sh::basis(v)) {
                *ci += e * y;
            }
        }
    }
    let w = 4.0 * std::f32::consts::PI / 12.0;
    for (i, ci) in c.iter_mut().enumerate() {
        *ci *= w / sh::COSINE_LOBE[sh::band(i)];
    }
    c
}

/// Bytes of a free-space block that carry its value (its SH coefficients, quantised as an SH
/// probe's; the rest of the 36-byte block is zero, and a cache file leaves it out).
pub const FREE_SPACE_BYTES: usize = 28;

/// An atmospheric leaf with all six matrices, as a compressed tree stores it: the SH
/// coefficients of [`free_space_sh`] quantised as an SH probe's ([`sh::pack`]: band 0 as RGBE,
/// the others as signed bytes relative to it; 28 bytes), in a 36-byte block (8 bytes zero,
/// which a cache file leaves out).
/// The query reads nothing else of such a leaf; the paper's compression of its six matrices
/// lost a third of its accuracy (docs/guide/baking.md, "A volumetric solution").
pub(in crate::caches::octree) fn encode_free_space(six: &FullLeaf) -> CompressedLeaf {
    const _: () = assert!(FREE_SPACE_BYTES == 4 + 3 * (sh::MAX_COEFFS - 1));
    let p = sh::pack(&free_space_sh(six), sh::ShOrder::L2, true);
    let mut out = [0u8; 36];
    out[..4].copy_from_slice(&p.l0);
    for (i, h) in p.higher.iter().enumerate() {
        for (ch, &x) in h.iter().enumerate() {
            out[4 + 3 * i + ch] = x as u8;
        }
    }
    out
}

/// The SH coefficients of a block of [`encode_free_space`].
pub(in crate::caches::octree) fn decode_free_space(b: &CompressedLeaf) -> [Vec3; sh::MAX_COEFFS] {
    let mut higher = [[0i8; 3]; sh::MAX_COEFFS - 1];
    for (i, h) in higher.iter_mut().enumerate() {
        for (ch, x) in h.iter_mut().enumerate() {
            *x = b[4 + 3 * i + ch] as i8;
        }
    }
    let p = sh::PackedProbe { l0: [b[0], b[1], b[2], b[3]], higher, validity: 255 };
    sh::unpack(&p, sh::ShOrder::L2)
}

/// [`free_space_irradiance`] as a matrix for the blend: `n ⊗ E`, so that `(n ⊗ E)ᵀ n = E`.
#[inline]
fn free_space_matrix(six: &[Mat3; 6], n: Vec3) -> Mat3 {
    let e = free_space_irradiance(six, n);
    Mat3::from_cols(n * e.x, n * e.y, n * e.z)
}

impl Octree {
    /// What a query meets of a leaf: (own value index or `NO_VALUE`, own bits, diffused entry
    /// or `NONE`, diffused bits).
    #[inline]
    fn volume_leaf(&self, node: u32) -> (u32, u8, u32, u8) {
        let v = self.nodes[node as usize].value();
        let own = if v == NO_VALUE { 0 } else { self.facing.get(v as usize).copied().unwrap_or(ALL_FACING) };
        let (e, filled) = match &self.atmosphere {
            Some(a) => {
                let e = a.index[node as usize];
                (e, if e == NONE { 0 } else { a.entry_bits[e as usize] })
            }
            None => (NONE, 0),
        };
        (v, own, e, filled)
    }

    /// Matrix `k` of a leaf met by a volume query: the diffused one where filled, else its own.
    #[inline]
    fn volume_matrix(&self, v: u32, e: u32, filled: u8, k: usize) -> Mat3 {
        if filled & (1 << k) != 0 {
            if let Some(a) = &self.atmosphere {
                return match &a.values {
                    LeafValues::Compressed(c) => decompress_matrix(&c[e as usize][k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES]),
                    LeafValues::Full(f) => f[e as usize][k],
                };
            }
        }
        self.valid_matrix(v as usize, k)
    }

    /// The leak test's view of a leaf met by a volume query at `p`: a valid leaf's anchors;
    /// for an atmospheric leaf with a flight estimate, its anchor (where its flights pass: a
    /// cell that holds a sliver of a room and the sunlit space behind its wall has its anchor
    /// outside, and a point in the room does not see it); for one with a diffused value, the
    /// point of its cell nearest to `p` (nudged a thousandth of the cell inwards; `p` itself
    /// inside the cell). Each as position and as every sample, normal zero. Not the cell's
    /// centre: an inserted object often encloses the centre of the cell it stands in, and its
    /// own surface then hid the cell from every point on it (measured: a black ring on a ball,
    /// 28% of its light missing in one frame of eight).
    fn volume_query_leaf(&self, p: Vec3, v: u32, e: u32, depth: u32, ijk: [u32; 3]) -> QueryLeaf {
        let view = self.view();
        let (cmin, s) = (view.cell_min(depth, ijk), self.cell_size[depth as usize]);
        if v == NO_VALUE {
            let anchor = self.atmosphere.as_ref().and_then(|a| a.anchors.get(e as usize)).and_then(|&q| anchor_point(q, cmin, s));
            let c = anchor.unwrap_or_else(|| p.clamp(cmin + Vec3::splat(1e-3 * s), cmin + Vec3::splat(0.999 * s)));
            return QueryLeaf {
                position: c,
                normal: Vec3::ZERO,
                cell_size: s,
                samples: [(c, Vec3::ZERO); ANCHOR_SAMPLES],
                index: NO_VALUE,
            };
        }
        let a = &self.anchors[v as usize];
        QueryLeaf {
            position: a.mean.position(cmin, s),
            normal: a.mean.normal(),
            cell_size: s,
            samples: a.samples.map(|x| (x.position(cmin, s), x.normal().normalize_or_zero())),
            index: v,
        }
    }

    /// The blended incident-radiance matrix `M(N)` at any point of the tree's volume: the §7
    /// blend over every leaf meeting the query box that has the matrices `N` needs, its own or
    /// diffused ones (module docs). `keep`, when given, sees each such leaf (an atmospheric one
    /// as its point nearest to `p`) and may drop it (leak control). `None` when no leaf contributes.
    pub fn incident_matrix_volume(&self, p: Vec3, n: Vec3, mut keep: Option<&mut dyn FnMut(QueryLeaf) -> bool>) -> Option<Mat3> {
        if !p.is_finite() || !n.is_finite() {
            return None;
        }
        let sel: [usize; 3] = [if n.x >= 0.0 { 0 } else { 1 }, if n.y >= 0.0 { 2 } else { 3 }, if n.z >= 0.0 { 4 } else { 5 }];
        let wgt = [n.x * n.x, n.y * n.y, n.z * n.z];
        let need = sel.iter().fold(0u8, |b, &k| b | (1 << k));
        let mut sum = [Mat3::ZERO; 3];
        let mut wsum = [0.0f32; 3];
        self.view().visit_tents(p, |node, depth, ijk, g| {
            let (v, own, e, filled) = self.volume_leaf(node);
            let bits = own | filled;
            if bits & need == 0 {
                return;
            }
            if let Some(k) = keep.as_mut() {
                if !k(self.volume_query_leaf(p, v, e, depth, ijk)) {
                    return;
                }
            }
            let free = (v == NO_VALUE && bits == ALL_FACING).then(|| match self.atmosphere.as_ref().map(|a| &a.values) {
                Some(LeafValues::Compressed(c)) => {
                    let e = sh::irradiance(&decode_free_space(&c[e as usize]), sh::ShOrder::L2, n);
                    Mat3::from_cols(n * e.x, n * e.y, n * e.z)
                }
                _ => {
                    let six: [Mat3; 6] = std::array::from_fn(|k| self.volume_matrix(v, e, filled, k));
                    free_space_matrix(&six, n)
                }
            });
            for a in 0..3 {
                let k = sel[a];
                if bits & (1 << k) != 0 {
                    let m = match free {
                        Some(f) => f,
                        None if v == NO_VALUE => ambient_cube(self.volume_matrix(v, e, filled, k), a, n[a]),
                        None => self.volume_matrix(v, e, filled, k),
                    };
                    sum[a] += m * g;
                    wsum[a] += g;
                }
            }
        });
        let (mut out, mut norm, mut any) = (Mat3::ZERO, 0.0f32, false);
        for a in 0..3 {
            if wsum[a] > 0.0 {
                any = true;
                if wgt[a] > 0.0 {
                    out += sum[a] * (wgt[a] / wsum[a]);
                    norm += wgt[a];
                }
            }
        }
        if !any {
            return None;
        }
        Some(if norm > 0.0 { out * (1.0 / norm) } else { Mat3::ZERO })
    }

    /// Irradiance (W/m², RGB) for the unit normal `n` at any point of the tree's volume,
    /// negative channels clamped to 0 (see [`Octree::incident_matrix_volume`]).
    pub fn irradiance_volume(&self, p: Vec3, n: Vec3, keep: Option<&mut dyn FnMut(QueryLeaf) -> bool>) -> Option<Color> {
        self.incident_matrix_volume(p, n, keep).map(|m| (m.transpose() * n).max(Vec3::ZERO))
    }
}
