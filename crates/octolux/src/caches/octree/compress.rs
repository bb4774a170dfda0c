//! Leaf-matrix compression of the paper's §5.3 ("§6" in the English summary): 6 bytes per
//! 3x3 incident-radiance matrix, 36 bytes per leaf.
//!
//! A matrix `M` (rows x, y, z; columns r, g, b) is approximated by the rank-one `D Cᵀ` with
//! `C = (|M_r|, |M_g|, |M_b|)` (column norms) and `|D| = 1`. With `C` fixed, minimising
//! `|M − D Cᵀ|²_F = |M|² − 2 D·(M C) + |C|²` over unit `D` gives `D = M C / |M C|`, the
//! paper's `α_i = r m_i1 + g m_i2 + b m_i3`.
//!
//! - `D` goes on two bytes as in Jensen's photon map: `θ = acos(D_z)` on 256 bins of `π/256`
//!   and `φ = atan2(D_y, D_x)` on 256 bins of `2π/256`. Unlike Jensen's code (which decodes
//!   the bin's lower edge) we decode the bin *centre*, which halves the error. The largest
//!   angle between a unit vector and its decoded direction is reached on the equator, where
//!   a bin is a right spherical "rectangle" of half-sides `π/512` (θ) and `π/256` (φ):
//!   `cos d_max = cos(π/512) · cos(π/256)`, `d_max ≈ 0.013720 rad ≈ 0.786°`
//!   ([`DIRECTION_MAX_ANGLE`]); towards the poles the φ half-side shrinks by `sin θ`.
//! - `C` goes on four bytes in Ward's RGBE: a shared exponent `e` with `max(C) = m 2^e`,
//!   `m ∈ [0.5, 1)`, mantissas `⌊c · 256 / 2^e⌋`, decoded at the bin centre
//!   `(byte + 0.5) 2^(e−8)`. Every channel's absolute error is at most `2^(e−9) ≤ max(C)/256`
//!   ([`RGBE_MAX_REL_ERROR`], relative to the largest channel). Values under `2^−128` encode
//!   as black; values at or above `2^127` saturate.

use glam::{Mat3, Vec3};
use std::f32::consts::PI;
use std::sync::OnceLock;

/// Bytes per compressed matrix.
pub const MATRIX_BYTES: usize = 6;
/// Bytes per compressed leaf (six matrices).
pub const LEAF_BYTES: usize = 6 * MATRIX_BYTES;
/// A compressed leaf: matrices in the order `+X, −X, +Y, −Y, +Z, −Z`, each `[θ, φ, R, G, B, E]`.
pub type CompressedLeaf = [u8; LEAF_BYTES];
/// An uncompressed leaf: the six matrices, same order.
pub type FullLeaf = [Mat3; 6];

/// Largest angle (rad) between a unit vector and its θ/φ-byte decoding:
/// `acos(cos(π/512) cos(π/256))`.
pub const DIRECTION_MAX_ANGLE: f32 = 0.013_720_1;
/// Largest RGBE error of any channel, relative to the largest channel.
pub const RGBE_MAX_REL_ERROR: f32 = 1.0 / 256.0;

/// Decoding tables (built once): bin-centre cos/sin of θ and φ, and the RGBE scales `2^(e−136)`.
pub(crate) struct Tables {
    pub cos_t: [f32; 256],
    pub sin_t: [f32; 256],
    pub cos_p: [f32; 256],
    pub sin_p: [f32; 256],
    pub exp_scale: [f32; 256],
}

fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| {
        let mut t = Tables { cos_t: [0.0; 256], sin_t: [0.0; 256], cos_p: [0.0; 256], sin_p: [0.0; 256], exp_scale: [0.0; 256] };
        for i in 0..256 {
            let th = (i as f64 + 0.5) * std::f64::consts::PI / 256.0;
            let ph = (i as f64 + 0.5) * 2.0 * std::f64::consts::PI / 256.0;
            t.cos_t[i] = th.cos() as f32;
            t.sin_t[i] = th.sin() as f32;
            t.cos_p[i] = ph.cos() as f32;
            t.sin_p[i] = ph.sin() as f32;
            // byte 0 means black; otherwise 2^(e - 128 - 8)
            t.exp_scale[i] = if i == 0 { 0.0 } else { 2f64.powi(i as i32 - 136) as f32 };
        }
        t
    })
}

/// Encode a direction on Jensen's θ/φ byte pair. `d` need not be normalised; a zero or
/// non-finite vector encodes as +Z.
#[inline]
pub fn encode_direction(d: Vec3) -> [u8; 2] {
    let len = d.length();
    if !(len > 0.0) || !len.is_finite() {
        return [0, 0];
    }
    let d = d / len;
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let i = ((theta * (256.0 / PI)) as i32).clamp(0, 255);
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let j = ((phi * (256.0 / (2.0 * PI))) as i32).rem_euclid(256);
    [i as u8, j as u8]
}

/// Decode a θ/φ byte pair to the unit vector at the bin centre.
#[inline]
pub fn decode_direction(b: [u8; 2]) -> Vec3 {
    let t = tables();
    let (st, ct) = (t.sin_t[b[0] as usize], t.cos_t[b[0] as usize]);
    Vec3::new(st * t.cos_p[b[1] as usize], st * t.sin_p[b[1] as usize], ct)
}

/// Ward's RGBE encoding of a non-negative colour (negative or NaN channels count as 0).
pub fn encode_rgbe(c: Vec3) -> [u8; 4] {
    let r = if c.x > 0.0 { c.x as f64 } else { 0.0 };
    let g = if c.y > 0.0 { c.y as f64 } else { 0.0 };
    let b = if c.z > 0.0 { c.z as f64 } else { 0.0 };
    let v = r.max(g).max(b);
    if !(v >= 2f64.powi(-128)) {
        return [0, 0, 0, 0];
    }
    if !v.is_finite() || v >= 2f64.powi(127) {
        return [255, 255, 255, 255];
    }
    // frexp: v = m 2^e, m in [0.5, 1)
    let e = ((v.to_bits() >> 52) & 0x7ff) as i32 - 1022;
    let scale = 256.0 / 2f64.powi(e);
    let q = |x: f64| ((x * scale) as i64).clamp(0, 255) as u8;
    [q(r), q(g), q(b), (e + 128) as u8]
}

/// Decode Ward's RGBE (bin centres).
#[inline]
pub fn decode_rgbe(b: [u8; 4]) -> Vec3 {
    let f = tables().exp_scale[b[3] as usize];
    Vec3::new((b[0] as f32 + 0.5) * f, (b[1] as f32 + 0.5) * f, (b[2] as f32 + 0.5) * f)
}

/// The rank-one factors `(D, C)` of `M ≈ D Cᵀ` (columns of `M` = r, g, b).
pub fn factor_matrix(m: &Mat3) -> (Vec3, Vec3) {
    let c = Vec3::new(m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
    let a = *m * c; // α = M C
    let d = if a.length_squared() > 0.0 && a.is_finite() {
        a.normalize()
    } else {
        // degenerate (zero matrix, or columns cancelling): keep the strongest column's direction
        let k = if c.x >= c.y && c.x >= c.z {
            m.x_axis
        } else if c.y >= c.z {
            m.y_axis
        } else {
            m.z_axis
        };
        k.try_normalize().unwrap_or(Vec3::Z)
    };
    (d, c)
}

/// Compress one matrix to `[θ, φ, R, G, B, E]`.
pub fn compress_matrix(m: &Mat3) -> [u8; MATRIX_BYTES] {
    let (d, c) = factor_matrix(m);
    let [t, p] = encode_direction(d);
    let [r, g, b, e] = encode_rgbe(c);
    [t, p, r, g, b, e]
}

/// The decoded factors `(D, C)` of one compressed matrix.
#[inline]
pub fn decompress_factors(b: &[u8]) -> (Vec3, Vec3) {
    (decode_direction([b[0], b[1]]), decode_rgbe([b[2], b[3], b[4], b[5]]))
}

/// Decompress one matrix: `D Cᵀ`.
#[inline]
pub fn decompress_matrix(b: &[u8]) -> Mat3 {
    let (d, c) = decompress_factors(b);
    Mat3::from_cols(d * c.x, d * c.y, d * c.z)
}

/// Compress the six matrices of a leaf (the paper's factors).
pub fn compress_leaf(m: &FullLeaf) -> CompressedLeaf {
    let mut out = [0u8; LEAF_BYTES];
    for (k, mk) in m.iter().enumerate() {
        out[k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES].copy_from_slice(&compress_matrix(mk));
    }
    out
}

/// The factors `(D, C)` of `M ≈ D Cᵀ` that keep the irradiance exact for the normal `n`:
/// `D` as the paper's, `C_c = (m_c·n) / (D·n)`, so `(D Cᵀ)ᵀ n = Mᵀ n` in every channel.
/// With the paper's `C` = column norms, `|m_c| (D·n) ≥ m_c·n` whenever the channels' mean
/// directions differ (a red wall on one side, a green one on the other), which biases the
/// irradiance up: +1% over whole Cornell-box images, 2x the relMSE of uncompressed leaves.
/// Falls back to the paper's factors when `D·n` is too small to divide by.
pub fn factor_matrix_for_normal(m: &Mat3, n: Vec3) -> (Vec3, Vec3) {
    let (d, c) = factor_matrix(m);
    let dn = d.dot(n);
    if !(dn > 0.25) {
        return (d, c);
    }
    let e = m.transpose() * n;
    (d, (e / dn).max(Vec3::ZERO))
}

/// Compress the six matrices of a leaf with [`factor_matrix_for_normal`], matrix `k` for the
/// mean normal `normals[k]` of the surfaces it describes (order `+X, −X, +Y, −Y, +Z, −Z`).
pub fn compress_leaf_for_normals(m: &FullLeaf, normals: &[Vec3; 6]) -> CompressedLeaf {
    let mut out = [0u8; LEAF_BYTES];
    for (k, mk) in m.iter().enumerate() {
        let (d, c) = factor_matrix_for_normal(mk, normals[k]);
        let [t, p] = encode_direction(d);
        let [r, g, b, e] = encode_rgbe(c);
        out[k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES].copy_from_slice(&[t, p, r, g, b, e]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{square_to_uniform_sphere, Sampler};

    fn angle(a: Vec3, b: Vec3) -> f32 {
        // atan2 form: accurate for small angles
        a.cross(b).length().atan2(a.dot(b))
    }

    #[test]
    fn direction_bound_is_the_exact_equatorial_value() {
        let exact = ((PI as f64 / 512.0).cos() * (PI as f64 / 256.0).cos()).acos();
        assert!((exact as f32 - DIRECTION_MAX_ANGLE).abs() < 1e-6, "{exact}");
    }

    #[test]
    fn direction_round_trip_stays_within_the_bound_and_the_bound_is_tight() {
        let mut s = Sampler::new(3, 0, 0);
        let mut worst = 0.0f32;
        let mut check = |d: Vec3| {
            let e = angle(d, decode_direction(encode_direction(d)));
            assert!(e <= DIRECTION_MAX_ANGLE + 2e-6, "{d:?}: {e}");
            worst = worst.max(e);
        };
        for _ in 0..200_000 {
            check(square_to_uniform_sphere(s.next_2d()));
        }
        // the worst case: on the equator, on a φ bin edge
        for k in 0..256 {
            let phi = k as f32 * 2.0 * PI / 256.0;
            check(Vec3::new(phi.cos(), phi.sin(), 0.0));
        }
        for d in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            check(d);
        }
        assert!(worst > 0.98 * DIRECTION_MAX_ANGLE, "bound not reached: {worst}");
        // decoded directions are unit
        for t in [0u8, 17, 128, 255] {
            for p in [0u8, 64, 200] {
                assert!((decode_direction([t, p]).length() - 1.0).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn rgbe_round_trip_relative_error_bound() {
        let mut s = Sampler::new(5, 0, 0);
        let mut worst = 0.0f32;
        for i in 0..100_000 {
            // magnitudes from 1e-30 to 1e30, random channel ratios (some exact zeros)
            let scale = 10f32.powf(-30.0 + 60.0 * s.next_1d());
            let mut c = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * scale;
            if i % 7 == 0 {
                c.y = 0.0;
            }
            let d = decode_rgbe(encode_rgbe(c));
            let m = c.max_element();
            let err = (d - c).abs().max_element() / m;
            assert!(err <= RGBE_MAX_REL_ERROR * (1.0 + 1e-5), "{c:?} -> {d:?}: {err}");
            worst = worst.max(err);
        }
        assert!(worst > 0.9 * RGBE_MAX_REL_ERROR, "bound not approached: {worst}");
        assert_eq!(decode_rgbe(encode_rgbe(Vec3::ZERO)), Vec3::ZERO);
        assert_eq!(decode_rgbe(encode_rgbe(Vec3::new(-1.0, f32::NAN, 0.0))), Vec3::ZERO);
        // exact powers of two are exact up to the +0.5 bin centre
        let d = decode_rgbe(encode_rgbe(Vec3::new(1.0, 0.5, 0.25)));
        assert!((d - Vec3::new(1.0, 0.5, 0.25)).abs().max_element() <= 1.0 / 256.0);
    }

    #[test]
    fn rank_one_matrix_compresses_within_both_bounds() {
        let mut s = Sampler::new(9, 0, 0);
        for _ in 0..10_000 {
            let d = square_to_uniform_sphere(s.next_2d());
            let c = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 40.0 + Vec3::splat(1e-3);
            let m = Mat3::from_cols(d * c.x, d * c.y, d * c.z);
            let (fd, fc) = factor_matrix(&m);
            assert!(angle(fd, d) < 1e-3 && (fc - c).abs().max_element() < 1e-4 * c.max_element());
            let b = compress_matrix(&m);
            let (dd, dc) = decompress_factors(&b);
            assert!(angle(dd, d) <= DIRECTION_MAX_ANGLE + 2e-6);
            assert!((dc - c).abs().max_element() <= RGBE_MAX_REL_ERROR * 1.00001 * c.max_element());
            // irradiance for any normal: |ΔE| <= |C| (angle + rgbe) bound
            let n = square_to_uniform_sphere(s.next_2d());
            let e = m.transpose() * n;
            let ed = decompress_matrix(&b).transpose() * n;
            let bound = c.max_element() * (DIRECTION_MAX_ANGLE + RGBE_MAX_REL_ERROR) * 1.001;
            assert!((e - ed).abs().max_element() <= bound, "{e:?} {ed:?}");
        }
    }

    #[test]
    fn compressed_leaf_is_36_bytes_and_the_factor_is_the_least_squares_direction() {
        assert_eq!(std::mem::size_of::<CompressedLeaf>(), 36);
        assert_eq!(std::mem::align_of::<CompressedLeaf>(), 1);
        // D = M C / |M C| beats any perturbed unit direction in Frobenius error
        let m = Mat3::from_cols(Vec3::new(1.0, 0.2, 0.0), Vec3::new(0.3, 1.0, 0.1), Vec3::new(0.0, 0.1, 0.5));
        let (d, c) = factor_matrix(&m);
        let err = |d: Vec3| {
            let r = m - Mat3::from_cols(d * c.x, d * c.y, d * c.z);
            r.x_axis.length_squared() + r.y_axis.length_squared() + r.z_axis.length_squared()
        };
        let mut s = Sampler::new(1, 1, 1);
        for _ in 0..1000 {
            let p = (d + 0.2 * square_to_uniform_sphere(s.next_2d())).normalize();
            assert!(err(d) <= err(p) + 1e-6);
        }
        let leaf = compress_leaf(&[m; 6]);
        assert_eq!(&leaf[0..6], &compress_matrix(&m));
        assert_eq!(&leaf[30..36], &compress_matrix(&m));
    }

    #[test]
    fn factors_for_a_normal_keep_its_irradiance_where_the_papers_overestimate_it() {
        // Irradiance vectors of three channels from different sides (red from the left,
        // green from the right, blue from above), on a floor of normal +z.
        let n = Vec3::Z;
        let m = Mat3::from_cols(Vec3::new(-0.6, 0.0, 0.8) * 2.0, Vec3::new(0.5, 0.0, 0.866) * 1.5, Vec3::Z * 0.7);
        let truth = m.transpose() * n;
        let approx = |(d, c): (Vec3, Vec3)| Mat3::from_cols(d * c.x, d * c.y, d * c.z).transpose() * n;
        let ours = approx(factor_matrix_for_normal(&m, n));
        let paper = approx(factor_matrix(&m));
        assert!((ours - truth).abs().max_element() < 1e-5, "{ours:?} vs {truth:?}");
        assert!(paper.x > 1.05 * truth.x && paper.y > 1.05 * truth.y, "paper's factors: {paper:?} vs {truth:?}");
        // and through the 6-byte encoding
        let leaf = compress_leaf_for_normals(&[m; 6], &[n; 6]);
        let e = decompress_matrix(&leaf[..MATRIX_BYTES]).transpose() * n;
        assert!(((e - truth) / truth).abs().max_element() < 2.0 * RGBE_MAX_REL_ERROR + 1e-3, "{e:?} vs {truth:?}");
    }
}
