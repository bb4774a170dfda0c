//! Deterministic random numbers and sample warping.
//!
//! Every random number in octolux is a pure function of (seed, stream index, sample index,
//! dimension): a [`Sampler`] is created for one (seed, pixel or photon index, sample index)
//! triple and then yields dimensions in order. Results therefore do not depend on the thread
//! that computes them, which makes images bit-identical for any thread count.
//!
//! Two kinds ([`SamplerKind`]): independent numbers (PCG32), and padded Owen-scrambled Sobol'
//! points ([`sobol`]), where each draw (`next_1d` or `next_2d`) is one slot, stratified over
//! the samples of a pixel (the render's default). The photon pass uses independent numbers.
//!
//! Each warp `square_to_*` has a matching `*_pdf` (density w.r.t. the measure named in the doc).

use crate::math::{spherical_direction, Frame};
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::f32::consts::{FRAC_1_PI, PI};

pub mod distribution;
pub mod sobol;

pub use distribution::{Distribution1D, Distribution2D};

/// The largest `f32` below 1 (a remapped sample stays in [0, 1)).
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// 64-bit finaliser (SplitMix64 / Murmur3 style); a good avalanche hash.
#[inline]
pub fn mix64(mut x: u64) -> u64 {
    x ^= x >> 30;
    x = x.wrapping_mul(0xbf58476d1ce4e5b9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94d049bb133111eb);
    x ^= x >> 31;
    x
}

/// Which numbers the render's samplers yield (`sampler = "independent" | "sobol"` in the render
/// settings, `--sampler` on the command line).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SamplerKind {
    /// Independent uniform numbers (PCG32), as Mitsuba's `independent` sampler.
    Independent,
    /// Owen-scrambled Sobol' points, padded per 2D slot (module `sobol`): stratified in every
    /// slot over each power-of-two run of samples of a pixel. 1.2–1.7x lower relMSE than
    /// independent numbers at equal spp for `path`, 1.4–2.5x for `octree`; the default
    /// (docs/lab/2026-11-30-performance.md).
    #[default]
    Sobol,
}

/// A deterministic sampler: PCG32 (O'Neill 2014) whose state and stream are derived by hashing
/// `(seed, index, sample)`, or padded Sobol' points keyed by the same triple.
#[derive(Clone, Debug)]
pub struct Sampler {
    inner: Inner,
}

#[derive(Clone, Debug)]
enum Inner {
    Pcg {
        state: u64,
        inc: u64,
    },
    /// `key`: hash of (seed, index); `sample_rev`: the Sobol' index, its bits reversed (as
    /// the scramble reads it, `sobol::sample_2d_rev`); `slot`: draws so far; `keys`: the
    /// slots' keys kept for the pixel's next samples ([`Sampler::restart`]).
    Sobol {
        key: u64,
        sample_rev: u32,
        slot: u32,
        keys: SlotKeys,
    },
}

/// Most slots whose keys a sampler keeps (a path draws a few slots per bounce; later slots are
/// hashed each time, as before).
const KEPT_SLOTS: usize = 128;

/// The keys of a Sobol' sampler's slots, `sobol::keys` of each slot's hash. They depend on the
/// pixel and the slot, not on the sample, so a sampler that [`Sampler::restart`]s on the same
/// pixel computes each once, on the first sample that draws it, and reads it back on the
/// others: three 64-bit hashes less per draw, the same numbers.
#[derive(Clone, Debug, Default)]
struct SlotKeys {
    /// Keys of slots `0..len`, in slot order.
    kept: Vec<(u32, u32, u32)>,
    /// Whether new slots are kept (a sampler from [`Sampler::with_kind`] or
    /// [`Sampler::split`], used for one sample, keeps none).
    keep: bool,
}

impl SlotKeys {
    /// The keys of the next slot (`*slot`, then counted) of the sampler keyed by `key`.
    #[inline]
    fn next(&mut self, key: u64, slot: &mut u32) -> (u32, u32, u32) {
        let s = *slot as usize;
        *slot += 1;
        match self.kept.get(s) {
            Some(&k) => k,
            None => self.compute(key, s),
        }
    }

    /// The keys of slot `s`, hashed, and kept when they are the next to keep (out of line: the
    /// kept keys' path is the one to inline).
    #[inline(never)]
    fn compute(&mut self, key: u64, s: usize) -> (u32, u32, u32) {
        let k = sobol::keys(mix64(key ^ (s as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15)));
        if self.keep && s == self.kept.len() && s < KEPT_SLOTS {
            self.kept.push(k);
        }
        k
    }
}

impl Sampler {
    /// Independent sampler for pixel/photon `index`, sample number `sample`, under the global
    /// `seed`.
    #[inline]
    pub fn new(seed: u64, index: u64, sample: u64) -> Self {
        let h1 = mix64(seed ^ mix64(index.wrapping_add(0x9e3779b97f4a7c15)));
        let h2 = mix64(h1 ^ mix64(sample.wrapping_add(0x632be59bd9b4e019)));
        let mut s = Sampler { inner: Inner::Pcg { state: 0, inc: (mix64(h2 ^ 0xda942042e4dd58b5) << 1) | 1 } };
        s.next_u32();
        if let Inner::Pcg { state, .. } = &mut s.inner {
            *state = state.wrapping_add(h2);
        }
        s.next_u32();
        s
    }

    /// Sampler of the given kind for pixel `index`, sample `sample` under `seed`. Sobol'
    /// indices are 32-bit: past 2^32 samples of one pixel the sequence repeats.
    #[inline]
    pub fn with_kind(kind: SamplerKind, seed: u64, index: u64, sample: u64) -> Self {
        match kind {
            SamplerKind::Independent => Sampler::new(seed, index, sample),
            SamplerKind::Sobol => Sampler {
                inner: Inner::Sobol {
                    key: pixel_key(seed, index),
                    sample_rev: (sample as u32).reverse_bits(),
                    slot: 0,
                    keys: SlotKeys::default(),
                },
            },
        }
    }

    /// Make this the sampler [`Sampler::with_kind`] gives for `(kind, seed, index, sample)`,
    /// the same numbers, keeping what it can of the previous sample's work: a Sobol' sampler
    /// restarted on the pixel it last drew for reads its slots' keys back instead of hashing
    /// them again (`SlotKeys`). The render restarts one sampler per tile for every sample.
    #[inline]
    pub fn restart(&mut self, kind: SamplerKind, seed: u64, index: u64, sample: u64) {
        match (kind, &mut self.inner) {
            (SamplerKind::Sobol, Inner::Sobol { key, sample_rev, slot, keys }) => {
                let k = pixel_key(seed, index);
                if k != *key || !keys.keep {
                    keys.kept.clear();
                    keys.keep = true;
                }
                (*key, *sample_rev, *slot) = (k, (sample as u32).reverse_bits(), 0);
            }
            _ => {
                *self = Sampler::with_kind(kind, seed, index, sample);
                if let Inner::Sobol { keys, .. } = &mut self.inner {
                    keys.keep = true;
                }
            }
        }
    }

    /// The sampler of continuation `j` of `k` split from this one at its current dimension
    /// (`integrators::pathloop`, "Splitting"): a Sobol' sampler goes on with sample
    /// `sample · k + j` of a sequence keyed apart from the pixel's, so that the `k`
    /// continuations of the pixel's samples are stratified together; an independent sampler
    /// with a stream hashed from its state and `j`.
    pub fn split(&self, j: u32, k: u32) -> Sampler {
        match self.inner {
            Inner::Pcg { state, inc } => Sampler::new(mix64(state ^ inc.rotate_left(17)), j as u64, k as u64),
            Inner::Sobol { key, sample_rev, slot, .. } => Sampler {
                inner: Inner::Sobol {
                    key: mix64(key ^ 0x2545_f491_4f6c_dd1d),
                    sample_rev: sample_rev.reverse_bits().wrapping_mul(k).wrapping_add(j).reverse_bits(),
                    slot,
                    keys: SlotKeys::default(),
                },
            },
        }
    }

    /// 32 random bits (a Sobol' sampler gives the bits of a 1D slot).
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        match &mut self.inner {
            Inner::Pcg { state, inc } => {
                let old = *state;
                *state = old.wrapping_mul(6364136223846793005).wrapping_add(*inc);
                let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
                let rot = (old >> 59) as u32;
                xorshifted.rotate_right(rot)
            }
            Inner::Sobol { key, sample_rev, slot, keys } => sobol::sample_1d_rev(*sample_rev, keys.next(*key, slot)),
        }
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        // 24 random mantissa bits: exactly representable, strictly below 1.
        to_unit(self.next_u32())
    }

    /// Uniform in [0, 1)²; one 2D slot of a Sobol' sampler.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        match &mut self.inner {
            Inner::Pcg { .. } => {
                let x = self.next_1d();
                Vec2::new(x, self.next_1d())
            }
            Inner::Sobol { key, sample_rev, slot, keys } => {
                let (x, y) = sobol::sample_2d_rev(*sample_rev, keys.next(*key, slot));
                Vec2::new(to_unit(x), to_unit(y))
            }
        }
    }
}

/// The hash of `(seed, pixel index)` that keys a Sobol' sampler's slots.
#[inline]
fn pixel_key(seed: u64, index: u64) -> u64 {
    mix64(seed ^ mix64(index.wrapping_add(0x5851_f42d_4c95_7f2d)))
}

/// The top 24 bits of a 32-bit fraction as an f32 in [0, 1).
#[inline]
fn to_unit(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Cosine-weighted hemisphere around +z (Malley's method on a concentric disk).
/// Density w.r.t. solid angle: `cos θ / π`.
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_uniform_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn square_to_cosine_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z > 0.0 {
        v.z * FRAC_1_PI
    } else {
        0.0
    }
}

/// Shirley–Chiu concentric map from the unit square to the unit disk. Density w.r.t. area: `1/π`.
#[inline]
pub fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let a = 2.0 * u.x - 1.0;
    let b = 2.0 * u.y - 1.0;
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    let (r, phi) = if a * a > b * b { (a, (PI / 4.0) * (b / a)) } else { (b, PI / 2.0 - (PI / 4.0) * (a / b)) };
    let (s, c) = phi.sin_cos();
    Vec2::new(r * c, r * s)
}

/// Uniform direction on the unit sphere. Density w.r.t. solid angle: `1/(4π)`.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.y;
    let r = (1.0 - z * z).max(0.0).sqrt();
    spherical_direction(r, z, 2.0 * PI * u.x)
}

pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction in the hemisphere around +z. Density w.r.t. solid angle: `1/(2π)`.
#[inline]
pub fn square_to_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.y;
    let r = (1.0 - z * z).max(0.0).sqrt();
    spherical_direction(r, z, 2.0 * PI * u.x)
}

pub const UNIFORM_HEMISPHERE_PDF: f32 = 1.0 / (2.0 * PI);

/// Uniform direction in the cone of directions within `acos(cos_max)` of +z.
/// Density w.r.t. solid angle: `1 / (2π (1 - cos_max))`.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.y * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    spherical_direction(r, z, 2.0 * PI * u.x)
}

#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentric coordinates `(b1, b2)` on a triangle (the point is
/// `(1-b1-b2) p0 + b1 p1 + b2 p2`). Density w.r.t. area: `1/area`.
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    let t = (1.0 - u.x).sqrt();
    Vec2::new(1.0 - t, u.y * t)
}

/// Direction `w` mapped into the frame around `n` (convenience for warps around +z).
#[inline]
pub fn around(n: Vec3, local: Vec3) -> Vec3 {
    Frame::from_normal(n).to_world(local)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points of slot `slot` (after `skip` earlier 2D draws) for samples `lo..lo + n`.
    fn sobol_points(pixel: u64, skip: usize, lo: u64, n: u64) -> Vec<Vec2> {
        (lo..lo + n)
            .map(|i| {
                let mut s = Sampler::with_kind(SamplerKind::Sobol, 9, pixel, i);
                for _ in 0..skip {
                    s.next_2d();
                }
                s.next_2d()
            })
            .collect()
    }

    #[test]
    fn sobol_slots_fill_every_elementary_interval_once() {
        // Each aligned block of 2^k samples, in each slot, puts exactly one point in every
        // elementary interval 2^-a x 2^-b with a + b = k (a (0,k,2)-net).
        for (pixel, skip, k, block) in [(0u64, 0usize, 8u32, 0u64), (17, 1, 10, 0), (17, 5, 6, 3), (123_456, 40, 9, 1)] {
            let n = 1u64 << k;
            let pts = sobol_points(pixel, skip, block * n, n);
            for a in 0..=k {
                let b = k - a;
                let mut hit = vec![false; n as usize];
                for p in &pts {
                    let (cx, cy) = ((p.x * (1u64 << a) as f32) as usize, (p.y * (1u64 << b) as f32) as usize);
                    let cell = (cy << a) + cx;
                    assert!(!hit[cell], "pixel {pixel} slot {skip} k {k}: interval {a}x{b} cell {cell} twice");
                    hit[cell] = true;
                }
            }
        }
        // 1D slots: one point per interval [j/2^k, (j+1)/2^k).
        let k = 10;
        let mut hit = vec![false; 1 << k];
        for i in 0..1u64 << k {
            let mut s = Sampler::with_kind(SamplerKind::Sobol, 3, 77, i);
            s.next_2d();
            let u = s.next_1d();
            let cell = (u * (1 << k) as f32) as usize;
            assert!(!hit[cell], "1D cell {cell} twice");
            hit[cell] = true;
        }
    }

    #[test]
    fn sobol_slots_are_uncorrelated_with_each_other() {
        // Without the per-slot index shuffle, the leading digits of all slots of one sample
        // are tied (each is the same Sobol' digit flipped by a constant): the fraction of
        // samples whose x falls on the same side of 1/2 in slots 0 and 1 would be 0 or 1.
        for pixel in [0u64, 5, 999] {
            let n = 4096u64;
            let agree = (0..n)
                .filter(|&i| {
                    let mut s = Sampler::with_kind(SamplerKind::Sobol, 1, pixel, i);
                    let (a, b) = (s.next_2d(), s.next_2d());
                    (a.x < 0.5) == (b.x < 0.5)
                })
                .count() as f64
                / n as f64;
            assert!((agree - 0.5).abs() < 0.05, "pixel {pixel}: {agree}");
            // Two pixels differ: their first points are not equal.
            let p = |px| Sampler::with_kind(SamplerKind::Sobol, 1, px, 0).next_2d();
            assert_ne!(p(pixel), p(pixel + 1));
        }
    }

    #[test]
    fn sobol_integrates_a_smooth_4d_function_better_than_independent_numbers() {
        // f = x0 y0 x1 y1 over two slots, exact 1/16; mean squared error over 64 pixels at
        // 256 spp: padded Sobol' integrates the additive part almost exactly, so its error is
        // about (1/81 - 1/256) / (7/144)² = 3.6x below that of independent numbers.
        let err = |kind| {
            let mut e = 0.0f64;
            for pixel in 0..64 {
                let mut sum = 0.0f64;
                for i in 0..256 {
                    let mut s = Sampler::with_kind(kind, 4, pixel, i);
                    let (a, b) = (s.next_2d(), s.next_2d());
                    sum += (a.x * a.y * b.x * b.y) as f64;
                }
                e += (sum / 256.0 - 1.0 / 16.0).powi(2);
            }
            e / 64.0
        };
        let (ind, sob) = (err(SamplerKind::Independent), err(SamplerKind::Sobol));
        assert!(sob * 2.0 < ind, "Sobol MSE {sob:e} vs independent {ind:e}");
        // The independent kind is the plain sampler.
        let mut a = Sampler::with_kind(SamplerKind::Independent, 1, 2, 3);
        let mut b = Sampler::new(1, 2, 3);
        assert_eq!(a.next_u32(), b.next_u32());
    }

    /// A sampler restarted for each sample (the render's, keeping its slots' keys) draws the
    /// numbers of a fresh one: across pixels, past the kept slots, mixed 1D and 2D draws, a
    /// split in between, the kind changed.
    #[test]
    fn a_restarted_sampler_draws_what_a_fresh_one_draws() {
        let mut kept = Sampler::with_kind(SamplerKind::Sobol, 0, 0, 0);
        let mut rng = Sampler::new(11, 12, 13);
        let mut kept_slots = 0;
        for step in 0..400u64 {
            let kind = if step % 97 == 50 { SamplerKind::Independent } else { SamplerKind::Sobol };
            let (seed, pixel, sample) = (3 + step / 200, step / 7 % 5, step % 7 + 1000 * (step % 3));
            kept.restart(kind, seed, pixel, sample);
            let mut fresh = Sampler::with_kind(kind, seed, pixel, sample);
            let draws = 1 + rng.next_u32() as usize % (KEPT_SLOTS + 40);
            for d in 0..draws {
                if d % 3 == 1 {
                    assert_eq!(kept.next_u32(), fresh.next_u32(), "step {step}, draw {d}");
                } else {
                    assert_eq!(kept.next_2d(), fresh.next_2d(), "step {step}, draw {d}");
                }
                if d == 20 && step % 11 == 0 {
                    let (mut a, mut b) = (kept.split(1, 3), fresh.split(1, 3));
                    for _ in 0..30 {
                        assert_eq!(a.next_2d(), b.next_2d(), "step {step}: the split");
                    }
                }
            }
            if let Inner::Sobol { keys, .. } = &kept.inner {
                assert!(keys.keep && keys.kept.len() <= KEPT_SLOTS);
                kept_slots = kept_slots.max(keys.kept.len());
            }
        }
        assert_eq!(kept_slots, KEPT_SLOTS, "the keys were kept");
    }

    #[test]
    fn sampler_is_deterministic_and_in_range() {
        let mut a = Sampler::new(7, 123, 4);
        let mut b = Sampler::new(7, 123, 4);
        let mut c = Sampler::new(7, 123, 5);
        let mut differs = false;
        for _ in 0..1000 {
            let x = a.next_1d();
            assert!((0.0..1.0).contains(&x));
            assert_eq!(x, b.next_1d());
            differs |= x != c.next_1d();
        }
        assert!(differs);
    }

    #[test]
    fn sampler_mean_and_variance_are_uniform() {
        let mut s = Sampler::new(1, 2, 3);
        let n = 200_000;
        let (mut m, mut m2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let x = s.next_1d() as f64;
            m += x;
            m2 += x * x;
        }
        m /= n as f64;
        m2 /= n as f64;
        assert!((m - 0.5).abs() < 0.003, "mean {m}");
        assert!((m2 - m * m - 1.0 / 12.0).abs() < 0.002);
    }

    #[test]
    fn warps_land_where_their_pdf_says() {
        let mut s = Sampler::new(0, 0, 0);
        for _ in 0..1000 {
            let u = s.next_2d();
            let c = square_to_cosine_hemisphere(u);
            assert!((c.length() - 1.0).abs() < 1e-4 && c.z >= 0.0);
            let d = square_to_uniform_sphere(u);
            assert!((d.length() - 1.0).abs() < 1e-4);
            let k = square_to_uniform_cone(u, 0.9);
            assert!(k.z >= 0.9 - 1e-5);
            let b = square_to_uniform_triangle(u);
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        }
    }

    #[test]
    fn distribution_2d_sampling_matches_its_pdf() {
        use crate::testing::{chi2_2d_piecewise as chi2_2d, Chi2Config};
        // 4 x 3 grid with an empty row and an empty cell
        let w = [1.0, 2.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0, 3.0, 1.0, 1.0, 8.0];
        let d = Distribution2D::new(&w, 4, 3).unwrap();
        assert_eq!(d.size(), (4, 3));
        assert!((d.total() - 20.0).abs() < 1e-9);
        assert!((d.pmf(3, 0) - 0.2).abs() < 1e-6 && d.pmf(2, 0) == 0.0 && d.pmf(1, 1) == 0.0);
        let sum: f32 = (0..3).flat_map(|y| (0..4).map(move |x| (x, y))).map(|(x, y)| d.pmf(x, y)).sum();
        assert!((sum - 1.0).abs() < 1e-6);
        let cfg = Chi2Config { bins_x: 8, bins_y: 6, ..Default::default() };
        let out = chi2_2d(&cfg, Vec2::ZERO, Vec2::ONE, |s| d.sample(s.next_2d()).map(|(p, _)| p), |p| d.pdf(p) as f64);
        assert!(out.passed, "{out:?}");
        assert!((out.pdf_integral - 1.0).abs() < 1e-4);
        let mut s = Sampler::new(3, 0, 0);
        for _ in 0..1000 {
            let (p, pdf) = d.sample(s.next_2d()).unwrap();
            assert_eq!(pdf, d.pdf(p));
        }
        assert!(Distribution2D::new(&[0.0; 4], 2, 2).is_none());
        assert!(Distribution2D::new(&[1.0; 3], 2, 2).is_none());
    }
}
