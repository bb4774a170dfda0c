//! Identical triangles, dropped before any backend builds (issue 12, item 8; docs/guide/errors.md,
//! "Geometry").
//!
//! Two triangles are identical when they have the same three corner positions, in any order,
//! winding or vertex indices. A ray hits identical triangles at the same `t`, so keeping one of
//! each set changes only which index a hit reports, never what is hit; the kept one is the
//! lowest index of its set, and its own `(u, v)` are reported. Without this, a million
//! coincident copies of one triangle (a mesh copied onto itself, or an OBJ face listing the same
//! three vertices over and over) make every backend build a tree of a million overlapping
//! boxes that each ray through them visits to the bottom: the pure-Rust BVH took 13 ms per
//! sample, Embree more than two minutes for a 32x32 image at 8 samples per pixel.
//!
//! Cost on distinct triangles: one 64-bit hash per triangle and a parallel sort of
//! (hash, index) pairs (test `million_distinct_triangles`: 0.7 s for a million on two cores
//! shared with a load of 15, so a fraction of that on an idle machine).

use glam::Vec3;
use rayon::prelude::*;

/// The corner positions as bit patterns (`-0.0` read as `0.0`), sorted: equal keys are
/// identical triangles.
fn key(vertices: &[Vec3], t: &[u32; 3]) -> [[u32; 3]; 3] {
    let mut k = t.map(|i| vertices[i as usize].to_array().map(|c| (c + 0.0).to_bits()));
    k.sort_unstable();
    k
}

/// A 64-bit mix of a key (not cryptographic: equal hashes are checked on the full key).
fn hash(k: &[[u32; 3]; 3]) -> u64 {
    let mut h: u64 = 0x9e37_79b9_7f4a_7c15;
    for w in k.iter().flatten() {
        h = (h ^ u64::from(*w)).wrapping_mul(0xff51_afd7_ed55_8ccd).rotate_left(29);
    }
    h ^ (h >> 32)
}

/// Indices (increasing) of the triangles to keep when some are identical to a triangle of
/// lower index; `None` when all are distinct. Indices must be valid for `vertices`.
pub fn unique_triangles(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Option<Vec<u32>> {
    let mut order: Vec<(u64, u32)> = triangles.par_iter().enumerate().map(|(i, t)| (hash(&key(vertices, t)), i as u32)).collect();
    order.par_sort_unstable();
    let mut dropped = Vec::new();
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && order[end].0 == order[start].0 {
            end += 1;
        }
        if end - start > 1 {
            // Equal hashes: group by the full key (sorting, so that even colliding hashes
            // cost n log n), keep the lowest index of each key.
            let mut run: Vec<([[u32; 3]; 3], u32)> =
                order[start..end].iter().map(|&(_, i)| (key(vertices, &triangles[i as usize]), i)).collect();
            run.sort_unstable();
            dropped.extend(run.windows(2).filter(|w| w[0].0 == w[1].0).map(|w| w[1].1));
        }
        start = end;
    }
    if dropped.is_empty() {
        return None;
    }
    let mut keep = vec![true; triangles.len()];
    for i in dropped {
        keep[i as usize] = false;
    }
    Some((0..triangles.len() as u32).filter(|&i| keep[i as usize]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_triangles_keep_the_lowest_index() {
        let v = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::new(-0.0, 0.0, 0.0)];
        // Distinct triangles: nothing to drop.
        assert_eq!(unique_triangles(&v, &[[0, 1, 2], [0, 1, 3], [1, 2, 3]]), None);
        assert_eq!(unique_triangles(&v, &[]), None);
        // Copies in another order or winding, and through another vertex at the same place
        // (-0.0 is 0.0), are identical; the lowest index of each set is kept.
        let tris = [[1, 2, 3], [0, 1, 2], [2, 1, 0], [0, 1, 3], [4, 2, 1], [3, 2, 1], [1, 2, 0]];
        assert_eq!(unique_triangles(&v, &tris), Some(vec![0, 1, 3]));
        // A million copies.
        let many = vec![[0, 1, 2]; 1_000_000];
        assert_eq!(unique_triangles(&v, &many), Some(vec![0]));
    }

    /// A million distinct triangles (a strip): nothing dropped; the time is printed.
    #[test]
    fn million_distinct_triangles() {
        let n = 1_000_000u32;
        let v: Vec<Vec3> = (0..n + 2).map(|i| Vec3::new(i as f32 * 0.5, (i % 2) as f32, 0.0)).collect();
        let tris: Vec<[u32; 3]> = (0..n).map(|i| [i, i + 1, i + 2]).collect();
        let t = std::time::Instant::now();
        assert_eq!(unique_triangles(&v, &tris), None);
        println!("dedup of {n} distinct triangles: {:?}", t.elapsed());
    }
}
