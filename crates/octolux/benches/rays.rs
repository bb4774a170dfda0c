//! Ray-casting throughput of the intersection backends (Mrays/s = Melem/s in criterion's output).
//!
//! Scenes: `spheres_in_room(7)` (three displaced icospheres in a box room, 983 052 triangles)
//! and a 34-triangle Cornell-box-like scene. Ray kinds, all traced on one thread:
//! - `primary`: pinhole camera rays in scanline order (coherent), closest hit;
//! - `diffuse`: from uniformly chosen surface points, cosine-distributed about the geometric
//!   normal, closest hit (incoherent);
//! - `shadow`: occlusion of the segment between two random surface points (any hit).
//!
//! Each backend that can be built (Embree needs its shared library) is measured; build times
//! are printed once per scene.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use octolux::accel::meshes::{self, MeshData};
use octolux::accel::{Accel, BackendKind};
use octolux::glam::Vec3;
use octolux::math::{offset_origin, Frame, Ray};
use octolux::sampling::{square_to_cosine_hemisphere, square_to_uniform_triangle, Sampler};
use std::hint::black_box;
use std::time::{Duration, Instant};

const N_RAYS: usize = 1 << 16;

/// Pinhole camera rays, `res x res`, scanline order.
fn primary_rays(eye: Vec3, target: Vec3, fov_deg: f32, res: usize) -> Vec<Ray> {
    let f = Frame::from_normal((target - eye).normalize());
    let h = (fov_deg.to_radians() * 0.5).tan();
    let mut rays = Vec::with_capacity(res * res);
    for y in 0..res {
        for x in 0..res {
            let sx = ((x as f32 + 0.5) / res as f32 * 2.0 - 1.0) * h;
            let sy = (1.0 - (y as f32 + 0.5) / res as f32 * 2.0) * h;
            rays.push(Ray::new(eye, f.to_world(Vec3::new(sx, sy, 1.0)).normalize()));
        }
    }
    rays
}

/// A uniformly chosen triangle and a uniform point on it: (point, unit geometric normal).
fn surface_point(m: &MeshData, s: &mut Sampler) -> (Vec3, Vec3) {
    let i = (s.next_u32() as usize) % m.triangles.len();
    let [a, b, c] = m.corners(i);
    let uv = square_to_uniform_triangle(s.next_2d());
    let p = a * (1.0 - uv.x - uv.y) + b * uv.x + c * uv.y;
    (p, (b - a).cross(c - a).normalize_or(Vec3::Z))
}

fn diffuse_rays(m: &MeshData, n: usize) -> Vec<Ray> {
    let mut s = Sampler::new(17, 0, 0);
    (0..n)
        .map(|_| {
            let (p, ng) = surface_point(m, &mut s);
            let d = Frame::from_normal(ng).to_world(square_to_cosine_hemisphere(s.next_2d())).normalize();
            Ray::new(offset_origin(p, ng, d), d)
        })
        .collect()
}

fn shadow_rays(m: &MeshData, n: usize) -> Vec<Ray> {
    let mut s = Sampler::new(23, 0, 0);
    (0..n)
        .map(|_| {
            let (p, np) = surface_point(m, &mut s);
            let (q, nq) = surface_point(m, &mut s);
            let d = (q - p).normalize_or(Vec3::Z);
            let o = offset_origin(p, np, d);
            let end = offset_origin(q, nq, -d);
            Ray::segment(o, d, (end - o).length())
        })
        .collect()
}

fn bench_scene(c: &mut Criterion, name: &str, m: &MeshData, primary: &[Ray]) {
    let diffuse = diffuse_rays(m, N_RAYS);
    let shadow = shadow_rays(m, N_RAYS);
    for kind in [BackendKind::Embree, BackendKind::Bvh] {
        let t0 = Instant::now();
        let accel = match Accel::build(&m.vertices, &m.triangles, kind) {
            Ok(a) => a,
            Err(e) => {
                eprintln!("{name}: skipping {kind:?}: {e}");
                continue;
            }
        };
        let backend = accel.name();
        let hits = primary.iter().filter(|r| accel.intersect(r).is_some()).count();
        let occl = shadow.iter().filter(|r| accel.occluded(r)).count();
        eprintln!(
            "{name}: {} triangles, {backend} built in {:.3} s; primary hit rate {:.2}, shadow occluded rate {:.2}",
            m.triangles.len(),
            t0.elapsed().as_secs_f64(),
            hits as f64 / primary.len() as f64,
            occl as f64 / shadow.len() as f64
        );
        let mut g = c.benchmark_group(format!("{name}/{backend}"));
        g.sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(2));
        for (kind, rays) in [("primary", primary), ("diffuse", &diffuse[..]), ("shadow", &shadow[..])] {
            g.throughput(Throughput::Elements(rays.len() as u64));
            g.bench_function(BenchmarkId::from_parameter(kind), |b| {
                b.iter(|| {
                    let mut n = 0u32;
                    if kind == "shadow" {
                        for r in rays {
                            n += u32::from(accel.occluded(black_box(r)));
                        }
                    } else {
                        for r in rays {
                            n += accel.intersect(black_box(r)).map_or(0, |h| h.prim & 1);
                        }
                    }
                    n
                })
            });
        }
        g.finish();
    }
}

fn rays(c: &mut Criterion) {
    let big = meshes::spheres_in_room(7);
    bench_scene(c, "spheres_1M", &big, &primary_rays(Vec3::new(0.0, 1.5, 3.9), Vec3::new(0.0, 0.2, 0.0), 60.0, 256));
    let cbox = meshes::cornell_box();
    bench_scene(c, "cornell_box", &cbox, &primary_rays(Vec3::new(0.0, 1.0, 3.9), Vec3::new(0.0, 1.0, 0.0), 40.0, 256));
}

criterion_group!(benches, rays);
criterion_main!(benches);
