//! Sorting the photons by Morton key (build step 1, paper §3).
//!
//! The photons arrive in tracing order, i.e. spatially random. Gathering them through a
//! sorted index would read them at random (a TLB and cache miss per photon, ~70–100 ns on
//! the reference machine), so the photon records themselves are moved, in two streaming
//! steps:
//! 1. an MSD pass: keys computed once (`u32` when they fit), then each photon is scattered,
//!    as a compact record with its key, to the bucket of its top (at most 10) key bits
//!    (chunked histograms, stable);
//! 2. a local LSD counting sort of each bucket on the remaining key bits (buckets are small
//!    enough to stay in cache), buckets in parallel.
//!
//! The result is the stable sort by key: ties keep the input order, so it does not depend on
//! the thread count. Dropped photons (non-finite fields, outside the cube) carry a flag bit
//! above the key, sort last and are cut off.

use super::cells::{morton, quantize};
use crate::photon::Photon;
use glam::Vec3;
use rayon::prelude::*;

/// The attributes of a photon that the estimates read, in sorted order (the positions
/// are kept apart: the gathering tests read only them).
pub(super) trait PhotonRec: Copy + Send + Sync {
    /// `cosine_min`: `Some(min_cos)` stores `w / max(|w·ng|, min_cos)` in place of `w`
    /// (`Estimator::Cosine`: same direction and sign, weight folded in).
    fn from_photon(ph: &Photon, cosine_min: Option<f32>) -> Self;
    fn w(&self) -> Vec3;
    fn c(&self) -> Vec3;
    fn ng(&self) -> Vec3;
}

#[inline]
fn weighted_w(ph: &Photon, cosine_min: Option<f32>) -> Vec3 {
    match cosine_min {
        Some(m) => ph.wi / ph.wi.dot(ph.ng).abs().max(m),
        None => ph.wi,
    }
}

/// Direction, power (24 bytes).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(super) struct Rec {
    w: Vec3,
    c: Vec3,
}

impl PhotonRec for Rec {
    #[inline]
    fn from_photon(ph: &Photon, cosine_min: Option<f32>) -> Self {
        Rec { w: weighted_w(ph, cosine_min), c: ph.power }
    }
    #[inline]
    fn w(&self) -> Vec3 {
        self.w
    }
    #[inline]
    fn c(&self) -> Vec3 {
        self.c
    }
    #[inline]
    fn ng(&self) -> Vec3 {
        Vec3::ZERO
    }
}

/// With the geometric normal, for `Estimator::GeometryArea` (36 bytes).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(super) struct RecNg {
    w: Vec3,
    c: Vec3,
    ng: Vec3,
}

impl PhotonRec for RecNg {
    #[inline]
    fn from_photon(ph: &Photon, cosine_min: Option<f32>) -> Self {
        RecNg { w: weighted_w(ph, cosine_min), c: ph.power, ng: ph.ng }
    }
    #[inline]
    fn w(&self) -> Vec3 {
        self.w
    }
    #[inline]
    fn c(&self) -> Vec3 {
        self.c
    }
    #[inline]
    fn ng(&self) -> Vec3 {
        self.ng
    }
}

/// The Morton key at depth `h` of a photon position inside the cube.
#[derive(Clone, Copy, Debug)]
pub(super) struct KeyFn {
    pub origin: Vec3,
    pub inv_quant: f32,
    pub h: u32,
}

impl KeyFn {
    #[inline]
    pub fn key(&self, p: Vec3) -> u64 {
        morton(quantize(p, self.origin, self.inv_quant, self.h))
    }
}

/// Raw output pointer shared by the scatter jobs.
#[derive(Clone, Copy)]
struct ScatterPtr<T>(*mut T);
// SAFETY: the jobs write disjoint index ranges of the buffer, never read it.
unsafe impl<T: Send> Send for ScatterPtr<T> {}
unsafe impl<T: Send> Sync for ScatterPtr<T> {}
impl<T> ScatterPtr<T> {
    #[inline]
    fn get(self) -> *mut T {
        self.0
    }
}

/// Storage of a Morton key: `u32` when `3 h_max + 1 <= 32`, else `u64`.
pub(super) trait SortKey: Copy + Send + Sync + Default {
    fn from_u64(k: u64) -> Self;
    fn get(self) -> u64;
}

impl SortKey for u32 {
    #[inline]
    fn from_u64(k: u64) -> Self {
        k as u32
    }
    #[inline]
    fn get(self) -> u64 {
        self as u64
    }
}

impl SortKey for u64 {
    #[inline]
    fn from_u64(k: u64) -> Self {
        k
    }
    #[inline]
    fn get(self) -> u64 {
        self
    }
}

/// Photons sorted by Morton key: `keys[i]` is the key of the photon at `pos[i]`, `recs[i]`.
pub(super) struct Sorted<R, K> {
    pub keys: Vec<K>,
    pub pos: Vec<Vec3>,
    pub recs: Vec<R>,
}

/// Sort the photons lying in the cube `[origin, origin + size]³` by their Morton key at
/// depth `h` (see the module docs). `K` must hold `3 h + 1` bits.
pub(super) fn sort_photons<R: PhotonRec, K: SortKey>(photons: &[Photon], kf: KeyFn, size: f32, cosine_min: Option<f32>) -> Sorted<R, K> {
    let n = photons.len();
    let flag = 3 * kf.h; // <= 63
    let bits = flag + 1;
    debug_assert!(bits as usize <= 8 * std::mem::size_of::<K>());
    let top = bits.min(10);
    let low = bits - top;
    let nb = 1usize << top;
    let hi = kf.origin + Vec3::splat(size);
    let keys_in: Vec<K> = photons
        .par_iter()
        .map(|ph| {
            let ok = ph.is_finite() && ph.p.cmpge(kf.origin).all() && ph.p.cmple(hi).all();
            K::from_u64(if ok { kf.key(ph.p) } else { 1u64 << flag })
        })
        .collect();

    // MSD pass: chunked histograms, offsets bucket-major then chunk order (stability)
    let chunk = n.div_ceil(4 * rayon::current_num_threads()).max(1 << 14);
    let mut offs: Vec<Vec<u32>> = keys_in
        .par_chunks(chunk)
        .map(|c| {
            let mut hist = vec![0u32; nb];
            for &k in c {
                hist[(k.get() >> low) as usize] += 1;
            }
            hist
        })
        .collect();
    let mut bucket_start = vec![0usize; nb + 1];
    let mut sum = 0u32;
    for (b, start) in bucket_start.iter_mut().enumerate().take(nb) {
        *start = sum as usize;
        for o in offs.iter_mut() {
            let k = o[b];
            o[b] = sum;
            sum += k;
        }
    }
    bucket_start[nb] = n;
    let mut keys: Vec<K> = Vec::with_capacity(n);
    let mut pos: Vec<Vec3> = Vec::with_capacity(n);
    let mut recs: Vec<R> = Vec::with_capacity(n);
    let kp = ScatterPtr(keys.spare_capacity_mut().as_mut_ptr() as *mut K);
    let pp = ScatterPtr(pos.spare_capacity_mut().as_mut_ptr() as *mut Vec3);
    let rp = ScatterPtr(recs.spare_capacity_mut().as_mut_ptr() as *mut R);
    photons.par_chunks(chunk).zip(keys_in.par_chunks(chunk)).zip(offs.par_iter_mut()).for_each(|((pc, kc), off)| {
        for (ph, &k) in pc.iter().zip(kc) {
            let b = (k.get() >> low) as usize;
            let dst = off[b] as usize;
            off[b] += 1;
            // SAFETY: `off[b]` walks the range reserved for (this chunk, bucket b); the ranges
            // of all (chunk, bucket) pairs are disjoint and tile `0..n`, within the capacity.
            unsafe {
                kp.get().add(dst).write(k);
                pp.get().add(dst).write(ph.p);
                rp.get().add(dst).write(R::from_photon(ph, cosine_min));
            }
        }
    });
    // SAFETY: every index of `0..n` was written exactly once above.
    unsafe {
        keys.set_len(n);
        pos.set_len(n);
        recs.set_len(n);
    }
    drop(keys_in);

    // the kept photons are the buckets without the flag bit
    let kept_buckets = 1usize << (top - 1);
    let kept = bucket_start[kept_buckets];
    keys.truncate(kept);
    pos.truncate(kept);
    recs.truncate(kept);
    // local sorts of the low bits, bucket by bucket
    if low > 0 {
        let mut slices = Vec::with_capacity(kept_buckets);
        let (mut krest, mut prest, mut rrest) = (&mut keys[..], &mut pos[..], &mut recs[..]);
        for b in 0..kept_buckets {
            let len = bucket_start[b + 1] - bucket_start[b];
            let (k, kt) = krest.split_at_mut(len);
            let (p, pt) = prest.split_at_mut(len);
            let (r, rt) = rrest.split_at_mut(len);
            slices.push((k, p, r));
            krest = kt;
            prest = pt;
            rrest = rt;
        }
        slices.into_par_iter().for_each_init(|| (Vec::new(), Vec::new()), |sc, (k, p, r)| local_sort(k, p, r, low, sc));
    }
    Sorted { keys, pos, recs }
}

/// Stable LSD counting sort of `(keys, pos, recs)` on the key bits `[0, low)`.
#[allow(clippy::type_complexity)]
fn local_sort<R: Copy, K: SortKey>(keys: &mut [K], pos: &mut [Vec3], recs: &mut [R], low: u32, sc: &mut (Vec<(K, Vec3, R)>, Vec<u32>)) {
    if keys.len() < 2 {
        return;
    }
    let (tmp, counts) = sc;
    let passes = low.div_ceil(11);
    let digit = low.div_ceil(passes);
    let mut shift = 0;
    while shift < low {
        let d = digit.min(low - shift);
        let mask = (1u64 << d) - 1;
        counts.clear();
        counts.resize(1 << d, 0);
        for &k in keys.iter() {
            counts[((k.get() >> shift) & mask) as usize] += 1;
        }
        let mut sum = 0u32;
        for c in counts.iter_mut() {
            let k = *c;
            *c = sum;
            sum += k;
        }
        tmp.clear();
        tmp.extend(keys.iter().zip(pos.iter()).zip(recs.iter()).map(|((&k, &p), &r)| (k, p, r)));
        for &(k, p, r) in tmp.iter() {
            let b = ((k.get() >> shift) & mask) as usize;
            let dst = counts[b] as usize;
            counts[b] += 1;
            keys[dst] = k;
            pos[dst] = p;
            recs[dst] = r;
        }
        shift += d;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    fn check(n: usize, h: u32, seed: u64) {
        let mut s = Sampler::new(seed, 0, 0);
        let mut photons: Vec<Photon> = (0..n)
            .map(|i| Photon {
                p: Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()),
                wi: Vec3::Z,
                power: Vec3::splat(i as f32), // identifies the photon
                ng: Vec3::Z,
            })
            .collect();
        if n > 10 {
            photons[3].p.x = 2.0; // outside
            photons[7].power.y = f32::NAN; // broken
        }
        let inv = (1u64 << h) as f32;
        let kf = KeyFn { origin: Vec3::ZERO, inv_quant: inv, h };
        let sorted: Sorted<Rec, u64> = sort_photons(&photons, kf, 1.0, None);
        if h <= 10 {
            let s32: Sorted<Rec, u32> = sort_photons(&photons, kf, 1.0, None);
            assert!(s32.keys.iter().zip(&sorted.keys).all(|(&a, &b)| a as u64 == b));
        }
        // the expected order: stable sort of the kept photons by key
        let mut expect: Vec<(u64, usize)> = photons
            .iter()
            .enumerate()
            .filter(|(_, ph)| ph.is_finite() && ph.p.x <= 1.0)
            .map(|(i, ph)| (morton(quantize(ph.p, Vec3::ZERO, inv, h)), i))
            .collect();
        expect.sort();
        assert_eq!(sorted.recs.len(), expect.len());
        assert_eq!(sorted.keys.len(), expect.len());
        for (i, &(k, idx)) in expect.iter().enumerate() {
            assert_eq!(sorted.keys[i], k);
            assert_eq!(kf.key(sorted.pos[i]), k);
            assert_eq!(sorted.recs[i].c.x, idx as f32, "photon {idx} at {i}");
        }
    }

    #[test]
    fn sort_is_the_stable_sort_by_key() {
        check(0, 6, 1);
        check(1, 6, 1);
        check(5000, 0, 2);
        check(100_000, 2, 3); // 7 key bits: MSD only, many ties
        check(100_000, 6, 4); // 19 bits: 10 + 9
        check(60_000, 12, 5); // 37 bits: local passes of 9 bits
        check(30_000, 21, 6); // 64 bits
    }
}
