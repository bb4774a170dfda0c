//! The kernel levels of the traversal (`crate::cpu`) give the same hits, bit for bit.

use super::Bvh8;
use crate::math::Ray;
use crate::sampling::{square_to_uniform_sphere, Sampler};
use glam::Vec3;

/// Random rays (from inside and outside, finite and bounded, some along the axes) against a
/// soup of 3 000 random triangles and a grid of axis-aligned ones (rays grazing shared edges
/// and box planes): the AVX2 traversal's hits (`t`, `u`, `v` as bits, triangle) and occlusion
/// answers equal the baseline's. Skipped, with a line saying so, on a CPU without AVX2.
#[test]
fn every_kernel_level_gives_the_same_hits() {
    #[cfg(target_arch = "x86_64")]
    {
        if crate::cpu::detected() != crate::cpu::KernelLevel::Avx2 {
            eprintln!("skipped: this CPU has no AVX2 and FMA");
            return;
        }
        let mut s = Sampler::new(5, 0, 0);
        let mut v: Vec<Vec3> = Vec::new();
        let mut t: Vec<[u32; 3]> = Vec::new();
        for _ in 0..3000 {
            let c = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 10.0 - Vec3::splat(5.0);
            let k = v.len() as u32;
            for _ in 0..3 {
                v.push(c + square_to_uniform_sphere(s.next_2d()) * 0.3);
            }
            t.push([k, k + 1, k + 2]);
        }
        for i in 0..20 {
            for j in 0..20 {
                let k = v.len() as u32;
                let (x, z) = (i as f32 * 0.5 - 5.0, j as f32 * 0.5 - 5.0);
                v.extend([
                    Vec3::new(x, -6.0, z),
                    Vec3::new(x + 0.5, -6.0, z),
                    Vec3::new(x, -6.0, z + 0.5),
                    Vec3::new(x + 0.5, -6.0, z + 0.5),
                ]);
                t.extend([[k, k + 1, k + 2], [k + 1, k + 3, k + 2]]);
            }
        }
        let bvh = Bvh8::build(&v, &t);
        let (mut hits, mut blocked) = (0, 0);
        for n in 0..20_000 {
            let o = if n % 3 == 0 {
                Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 8.0 - Vec3::splat(4.0)
            } else {
                Vec3::new(0.0, 20.0, 0.0)
            };
            let d = match n % 7 {
                0 => -Vec3::Y,
                1 => Vec3::X,
                _ => square_to_uniform_sphere(s.next_2d()),
            };
            let o = if n % 7 == 0 { Vec3::new((n % 40) as f32 * 0.25 - 5.0, 2.0, 0.5) } else { o };
            let ray = if n % 2 == 0 { Ray::new(o, d) } else { Ray::segment(o, d, 6.0) };
            let base = bvh.intersect_with::<false>(&ray);
            // SAFETY: the CPU has AVX2 and FMA (checked above).
            let wide = unsafe { bvh.intersect_avx2(&ray) };
            let bits = |h: Option<crate::accel::TriHit>| h.map(|h| (h.t.to_bits(), h.u.to_bits(), h.v.to_bits(), h.prim));
            assert_eq!(bits(base), bits(wide), "ray {n}: {ray:?}");
            let (ob, ow) = (bvh.occluded_with::<false>(&ray), unsafe { bvh.occluded_avx2(&ray) });
            assert_eq!(ob, ow, "ray {n}: {ray:?}");
            hits += usize::from(base.is_some());
            blocked += usize::from(ob);
        }
        assert!(hits > 2_000 && blocked > 2_000 && hits < 20_000, "{hits} hits, {blocked} blocked of 20 000");
    }
}
