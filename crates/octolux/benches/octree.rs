//! Octree benchmarks: build rate (photons/s) for 1M and 4M photons on a synthetic
//! Cornell-box-like distribution (photons on the 6 inner walls of the unit box, diffuse
//! directions) with the paper's settings, the geometry-area estimator and the `octree`
//! integrator's default global tree, and query rate (irradiance queries/s) on the walls.
//! The build rate on real scenes: `crates/octolux-cli/examples/build_rate.rs`.
//!
//! Run: `cargo bench -p octolux --bench octree`.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::Vec3;
use octolux::caches::octree::{Estimator, Octree, OctreeSettings, Storage};
use octolux::integrators::octree::OctreeIntegratorSettings;
use octolux::math::Bounds3;
use octolux::photon::Photon;
use octolux::sampling::{around, square_to_cosine_hemisphere, Sampler};
use rayon::prelude::*;

fn unit_box() -> Bounds3 {
    Bounds3 { min: Vec3::ZERO, max: Vec3::ONE }
}

/// A point on wall `i % 6` of the unit box with its inward normal.
fn wall_point(s: &mut Sampler, i: usize) -> (Vec3, Vec3) {
    let axis = (i % 6) / 2;
    let side = (i % 2) as f32;
    let mut p = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
    p[axis] = side;
    let mut n = Vec3::ZERO;
    n[axis] = 1.0 - 2.0 * side;
    (p, n)
}

fn cornell_photons(n: usize) -> Vec<Photon> {
    (0..n)
        .into_par_iter()
        .map(|i| {
            let mut s = Sampler::new(42, i as u64, 0);
            let (p, ng) = wall_point(&mut s, i);
            let wi = around(ng, square_to_cosine_hemisphere(s.next_2d()));
            let power = match i % 6 {
                0 => Vec3::new(0.6, 0.05, 0.05),
                1 => Vec3::new(0.1, 0.5, 0.1),
                _ => Vec3::splat(0.4),
            } / n as f32;
            Photon { p, wi, power, ng }
        })
        .collect()
}

fn cornell_geometry() -> Vec<[Vec3; 3]> {
    let mut g = Vec::new();
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0.0f32, 1.0] {
            let pt = |a: f32, b: f32| {
                let mut p = Vec3::ZERO;
                p[axis] = side;
                p[u] = a;
                p[v] = b;
                p
            };
            let (p0, p1, p2, p3) = (pt(0.0, 0.0), pt(1.0, 0.0), pt(1.0, 1.0), pt(0.0, 1.0));
            if side == 0.0 {
                g.extend([[p0, p1, p2], [p0, p2, p3]]);
            } else {
                g.extend([[p0, p2, p1], [p0, p3, p2]]);
            }
        }
    }
    g
}

fn bench_build(c: &mut Criterion) {
    let mut g = c.benchmark_group("octree_build");
    g.sample_size(10);
    let geometry = cornell_geometry();
    for n in [1_000_000usize, 4_000_000] {
        let photons = cornell_photons(n);
        g.throughput(Throughput::Elements(n as u64));
        for (name, s) in [
            ("paper", OctreeSettings::default()),
            ("geometry_area", OctreeSettings { estimator: Estimator::GeometryArea, ..OctreeSettings::default() }),
            // the `octree` integrator's global tree: geometry-area estimator, split by the
            // surface normal (`add_by_surface`), depth from the photon count
            ("integrator_default", OctreeIntegratorSettings::default().global),
        ] {
            let t = Octree::build(&photons, unit_box(), &s, Some(&geometry)).unwrap();
            eprintln!("{name} {n}: {}", serde_json::to_string(t.stats()).unwrap());
            g.bench_with_input(BenchmarkId::new(name, n), &photons, |b, ph| {
                b.iter(|| Octree::build(black_box(ph), unit_box(), &s, Some(&geometry)).unwrap())
            });
        }
    }
    g.finish();
}

fn bench_query(c: &mut Criterion) {
    let photons = cornell_photons(1_000_000);
    let mut s = Sampler::new(7, 0, 0);
    let queries: Vec<(Vec3, Vec3)> = (0..4096).map(|i| wall_point(&mut s, i)).collect();
    let mut g = c.benchmark_group("octree_query");
    g.throughput(Throughput::Elements(queries.len() as u64));
    for storage in [Storage::Compressed, Storage::Full] {
        let t = Octree::build(&photons, unit_box(), &OctreeSettings { storage, ..OctreeSettings::default() }, None).unwrap();
        g.bench_function(BenchmarkId::new("irradiance", format!("{storage:?}")), |b| {
            b.iter(|| {
                let mut acc = Vec3::ZERO;
                for &(p, n) in &queries {
                    acc += t.irradiance(black_box(p), n).unwrap_or(Vec3::ZERO);
                }
                acc
            })
        });
        g.bench_function(BenchmarkId::new("incident_matrix", format!("{storage:?}")), |b| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for &(p, n) in &queries {
                    acc += t.incident_matrix(black_box(p), n).map_or(0.0, |m| m.x_axis.x);
                }
                acc
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench_build, bench_query);
criterion_main!(benches);
