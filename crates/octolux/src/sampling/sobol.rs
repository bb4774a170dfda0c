//! Owen-scrambled, shuffled Sobol' points in two dimensions (Burley 2020, "Practical Hash-based
//! Owen Scrambling", JCGT 9(4); the hash is Vegdahl's 2021 refinement of Laine and Karras's).
//!
//! A sampler asks for one 1D or 2D number per *slot* (film position, light choice, BSDF
//! direction, ...). Every slot draws from the first two dimensions of Sobol's sequence — the
//! ones that form a (0,2)-sequence — under its own randomisation ("padding", as pbrt-v4's
//! `PaddedSobolSampler` does):
//!
//! - the **index is shuffled** by a nested uniform (Owen) scramble of its bits, keyed by
//!   (pixel, slot): output bit `k` depends only on input bits `>= k`, so the first `2^k`
//!   indices map onto one aligned block of `2^k` Sobol' indices, in an order of their own per
//!   slot. Slots therefore stay uncorrelated with each other, and no sample count needs to be
//!   known in advance (time-budget passes continue the sequence).
//! - each coordinate is **Owen-scrambled** with its own key, which keeps the net property.
//!
//! Consequence (tested): for every `k` and every aligned block of `2^k` sample indices, the
//! points of one slot fill each elementary interval of area `2^-k` of the unit square exactly
//! once, and a 1D slot each interval `[j/2^k, (j+1)/2^k)` exactly once.

/// Generator columns of Sobol's second dimension (the Pascal matrix mod 2): `V[0] = 2^31`,
/// `V[k] = V[k-1] ^ (V[k-1] >> 1)`.
const SOBOL_DIM1: [u32; 32] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    v
};

/// [`SOBOL_DIM1`] applied to each byte of the index: the map is linear over GF(2), so the
/// index's four bytes are looked up and added (xor).
const SOBOL_DIM1_BYTES: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut v = 0;
        while v < 256 {
            let mut r = 0;
            let mut k = 0;
            while k < 8 {
                if v & (1 << k) != 0 {
                    r ^= SOBOL_DIM1[8 * b + k];
                }
                k += 1;
            }
            t[b][v] = r;
            v += 1;
        }
        b += 1;
    }
    t
};

/// [`SOBOL_DIM1_BYTES`] with every entry's bits reversed: the reversal is linear over GF(2)
/// too, so the tables give `sobol_dim1(i).reverse_bits()` without reversing.
const SOBOL_DIM1_REV_BYTES: [[u32; 256]; 4] = {
    let mut t = SOBOL_DIM1_BYTES;
    let mut b = 0;
    while b < 4 {
        let mut v = 0;
        while v < 256 {
            t[b][v] = t[b][v].reverse_bits();
            v += 1;
        }
        b += 1;
    }
    t
};

/// `sobol_dim1(i).reverse_bits()`, from [`SOBOL_DIM1_REV_BYTES`].
#[inline]
fn sobol_dim1_rev(i: u32) -> u32 {
    let t = &SOBOL_DIM1_REV_BYTES;
    t[0][(i & 0xff) as usize] ^ t[1][((i >> 8) & 0xff) as usize] ^ t[2][((i >> 16) & 0xff) as usize] ^ t[3][(i >> 24) as usize]
}

/// Sobol' dimension 1 of index `i` (32-bit fixed point in [0, 1)).
#[inline]
pub fn sobol_dim1(i: u32) -> u32 {
    let t = &SOBOL_DIM1_BYTES;
    t[0][(i & 0xff) as usize] ^ t[1][((i >> 8) & 0xff) as usize] ^ t[2][((i >> 16) & 0xff) as usize] ^ t[3][(i >> 24) as usize]
}

/// A permutation of 32-bit integers in which output bit `k` depends only on input bits
/// `<= k` (Laine–Karras, with Vegdahl's constants).
#[inline]
fn lk_hash(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Nested uniform (Owen) scramble of a 32-bit fraction: output bit `31 - k` (the `k`-th
/// binary digit after the point) depends only on the digits before and at it.
#[inline]
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    lk_hash(x.reverse_bits(), seed).reverse_bits()
}

/// Sobol' dimension 0 of index `i`, Owen-scrambled: the van der Corput radical inverse
/// `reverse_bits(i)` scrambled, written without reversing twice.
#[inline]
fn scrambled_dim0(i: u32, seed: u32) -> u32 {
    lk_hash(i, seed).reverse_bits()
}

/// The keys of one slot (from its 64-bit hash `key`): index shuffle, x scramble, y scramble.
#[inline]
pub(super) fn keys(key: u64) -> (u32, u32, u32) {
    let a = super::mix64(key);
    let b = super::mix64(a ^ 0x2545_f491_4f6c_dd1d);
    (a as u32, (a >> 32) as u32, b as u32)
}

/// Sample `index` of the 2D slot whose `keys` are `(ks, kx, ky)`, as two 32-bit fractions,
/// given the index with its bits reversed, `index_rev` (a sampler keeps it so, for all the
/// slots of a sample): the scrambled index `i`, its radical inverse scrambled, Sobol'
/// dimension 1 of `i` scrambled, with three bit reversals where the definition takes five.
#[inline]
pub fn sample_2d_rev(index_rev: u32, (ks, kx, ky): (u32, u32, u32)) -> (u32, u32) {
    let i = lk_hash(index_rev, ks).reverse_bits();
    // both coordinates' reversals in one of 64 bits: `y`'s hash in the high half comes out
    // reversed in the low half, `x`'s in the high half
    let both = (((lk_hash(sobol_dim1_rev(i), ky) as u64) << 32) | lk_hash(i, kx) as u64).reverse_bits();
    ((both >> 32) as u32, both as u32)
}

/// Sample `index` of the 1D slot whose `keys` are `(ks, kx, _)`, as a 32-bit fraction,
/// given `index_rev` as for [`sample_2d_rev`].
#[inline]
pub fn sample_1d_rev(index_rev: u32, (ks, kx, _): (u32, u32, u32)) -> u32 {
    scrambled_dim0(lk_hash(index_rev, ks).reverse_bits(), kx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_byte_tables_match_the_generator_columns() {
        let slow = |mut i: u32| {
            let mut r = 0;
            while i != 0 {
                r ^= SOBOL_DIM1[i.trailing_zeros() as usize];
                i &= i - 1;
            }
            r
        };
        let mut s = super::super::Sampler::new(1, 2, 3);
        for i in (0..4096).chain((0..4096).map(|_| s.next_u32())) {
            assert_eq!(sobol_dim1(i), slow(i), "index {i}");
        }
    }

    /// The samplers' form (the index kept bit-reversed, dimension 1 from reversed tables)
    /// gives the numbers of the definition: the index Owen-scrambled, dimension 0 its radical
    /// inverse scrambled, dimension 1 scrambled (module docs).
    #[test]
    fn the_reversed_forms_give_the_defined_numbers() {
        let mut s = super::super::Sampler::new(4, 5, 6);
        for n in 0..20_000u32 {
            let index = if n < 4096 { n } else { s.next_u32() };
            let key = (s.next_u32() as u64) << 32 | s.next_u32() as u64;
            let (ks, kx, ky) = keys(key);
            let i = owen_scramble(index, ks);
            let want = (owen_scramble(i.reverse_bits(), kx), owen_scramble(sobol_dim1(i), ky));
            assert_eq!(sample_2d_rev(index.reverse_bits(), (ks, kx, ky)), want, "index {index}, key {key:#x}");
            assert_eq!(sample_1d_rev(index.reverse_bits(), (ks, kx, ky)), want.0, "index {index}, key {key:#x}");
            assert_eq!(sobol_dim1_rev(index), sobol_dim1(index).reverse_bits());
        }
    }

    #[test]
    fn the_generator_gives_sobols_second_dimension() {
        // The start of the sequence (dimension 1) in index order, not Gray-code order:
        // columns 1/2, 3/4, 5/8, so 0, 1/2, 3/4, 1/4, 5/8, 1/8, 3/8, 7/8.
        let want = [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875];
        for (i, w) in want.iter().enumerate() {
            assert_eq!(sobol_dim1(i as u32) as f64 / 4294967296.0, *w, "index {i}");
        }
    }

    #[test]
    fn the_scrambles_are_permutations_that_keep_prefixes() {
        // Owen scrambling maps each dyadic interval [j/2^k, (j+1)/2^k) onto one such interval,
        // and the index shuffle maps each aligned block of 2^k indices onto one such block.
        for seed in [0u32, 1, 0xdead_beef, 0x8000_0001] {
            for k in [1u32, 4, 9] {
                let shift = 32 - k;
                for j in 0..(1u32 << k).min(64) {
                    let lo = j << shift;
                    let target = owen_scramble(lo, seed) >> shift;
                    for t in [1u32, 77, (1 << shift) - 1] {
                        assert_eq!(owen_scramble(lo + t, seed) >> shift, target, "seed {seed:#x} k {k} j {j}");
                    }
                }
                // Index side: 2^k consecutive aligned indices hit 2^k distinct values in one block.
                let mut seen: Vec<u32> = (0..1u32 << k).map(|i| owen_scramble(i + (5 << k), seed)).collect();
                let block = seen[0] >> k;
                assert!(seen.iter().all(|v| v >> k == block));
                seen.sort_unstable();
                seen.dedup();
                assert_eq!(seen.len(), 1 << k);
            }
        }
    }
}
