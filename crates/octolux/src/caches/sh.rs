//! Real spherical harmonics up to band 2, irradiance by the cosine-lobe convolution
//! (Ramamoorthi & Hanrahan, "An efficient representation for irradiance environment maps",
//! SIGGRAPH 2001), and the quantised storage of a set of coefficients: an SH probe's
//! (`caches::probes`), and an atmospheric leaf's free-space light (`caches::octree`,
//! `atmosphere.rs`).
//!
//! Basis (unit vector `(x, y, z)`, the usual real SH in the order `l = 0; l = 1: m = −1, 0, 1;
//! l = 2: m = −2 .. 2`): `Y00 = 0.282095`; `Y1 = 0.488603 (y, z, x)`;
//! `Y2 = (1.092548 xy, 1.092548 yz, 0.315392 (3z² − 1), 1.092548 xz, 0.546274 (x² − y²))`.
//! A radiance function `L(ω)` (W m⁻² sr⁻¹) has coefficients `c_lm = ∫ L Y_lm dω`; the
//! irradiance on a surface of normal `n` (W m⁻²) is `E(n) = Σ_lm A_l c_lm Y_lm(n)` with
//! `A_0 = π`, `A_1 = 2π/3`, `A_2 = π/4` (the clamped cosine's coefficients): exact for any
//! radiance whose band-limited part ends at `l = 2` (band 3's `A_3` is 0; the neglected bands
//! ≥ 4 carry under 1% of a clamped cosine, R&H §3), and for a radiance linear in `ω` already at
//! order 1.

use glam::Vec3;

/// How many SH bands a probe keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShOrder {
    /// Bands 0 and 1: 4 coefficients per channel (Unity's APV default, "L1").
    L1,
    /// Bands 0, 1 and 2: 9 coefficients per channel (Unreal's volumetric lightmap, "L2").
    L2,
}

impl ShOrder {
    /// Coefficients per colour channel.
    pub const fn coefficients(self) -> usize {
        match self {
            ShOrder::L1 => 4,
            ShOrder::L2 => 9,
        }
    }

    /// Stored bytes per probe: L0 as RGBE (4 bytes), each higher coefficient of each channel
    /// as a signed byte relative to that channel's L0, and one validity byte.
    pub const fn probe_bytes(self) -> usize {
        4 + 3 * (self.coefficients() - 1) + 1
    }
}

/// Most coefficients a probe holds (order 2).
pub const MAX_COEFFS: usize = 9;

/// The real SH basis at the unit vector `d`, bands 0..=2.
#[inline]
pub fn basis(d: Vec3) -> [f32; MAX_COEFFS] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_094_8,
        0.488_602_5 * y,
        0.488_602_5 * z,
        0.488_602_5 * x,
        1.092_548_4 * x * y,
        1.092_548_4 * y * z,
        0.315_391_57 * (3.0 * z * z - 1.0),
        1.092_548_4 * x * z,
        0.546_274_2 * (x * x - y * y),
    ]
}

/// Band of coefficient `i`.
#[inline]
pub const fn band(i: usize) -> usize {
    match i {
        0 => 0,
        1..=3 => 1,
        _ => 2,
    }
}

/// The clamped cosine's convolution weights `A_l`.
pub const COSINE_LOBE: [f32; 3] = [std::f32::consts::PI, 2.0 * std::f32::consts::PI / 3.0, std::f32::consts::FRAC_PI_4];

/// Irradiance (per channel, W m⁻²) for the normal `n` from the radiance coefficients `c`
/// (`c[i]` is coefficient `i` of the three channels) of the given order. Negative values
/// (ringing) are clamped to 0.
pub fn irradiance(c: &[Vec3; MAX_COEFFS], order: ShOrder, n: Vec3) -> Vec3 {
    let y = basis(n);
    let mut e = Vec3::ZERO;
    for i in 0..order.coefficients() {
        e += c[i] * (COSINE_LOBE[band(i)] * y[i]);
    }
    e.max(Vec3::ZERO)
}

/// Largest `|Y_lm / Y_00|` over the sphere per band: a non-negative radiance has
/// `|c_lm| ≤ bound_l c_00`, so the stored ratio `c_lm / (bound_l c_00)` lies in `[−1, 1]`.
pub const RATIO_BOUND: [f32; 3] = [1.0, 1.732_050_8, 2.236_068];

/// One probe as stored: L0 (RGBE), the higher coefficients as snorm8 ratios to L0, validity.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PackedProbe {
    pub l0: [u8; 4],
    /// `[coefficient 1.. ][channel]`, only the first `order.coefficients() − 1` used.
    pub higher: [[i8; 3]; MAX_COEFFS - 1],
    /// 255: valid; 0: invalid (Unity stores the validity per probe, 8 bits).
    pub validity: u8,
}

/// Quantise coefficients as stored (see [`PackedProbe`]).
pub fn pack(c: &[Vec3; MAX_COEFFS], order: ShOrder, valid: bool) -> PackedProbe {
    let l0 = crate::caches::octree::compress::encode_rgbe(c[0]);
    let base = crate::caches::octree::compress::decode_rgbe(l0);
    let mut higher = [[0i8; 3]; MAX_COEFFS - 1];
    for i in 1..order.coefficients() {
        for ch in 0..3 {
            let b = base[ch] * RATIO_BOUND[band(i)];
            let r = if b > 0.0 && c[0][ch] > 0.0 { c[i][ch] / b } else { 0.0 };
            let r = if r.is_finite() { r.clamp(-1.0, 1.0) } else { 0.0 };
            higher[i - 1][ch] = (r * 127.0).round() as i8;
        }
    }
    PackedProbe { l0, higher, validity: if valid { 255 } else { 0 } }
}

/// Decode a stored probe into coefficients.
pub fn unpack(p: &PackedProbe, order: ShOrder) -> [Vec3; MAX_COEFFS] {
    let mut c = [Vec3::ZERO; MAX_COEFFS];
    // RGBE's all-zero code stands for black (its bin centre would be a tiny positive value).
    c[0] = if p.l0 == [0; 4] { Vec3::ZERO } else { crate::caches::octree::compress::decode_rgbe(p.l0) };
    for i in 1..order.coefficients() {
        let h = p.higher[i - 1];
        let s = RATIO_BOUND[band(i)] / 127.0;
        c[i] = Vec3::new(h[0] as f32, h[1] as f32, h[2] as f32) * s * c[0];
    }
    c
}
