//! Sampler and film benchmarks: the per-sample work of the render loop outside the integrator.
//! A camera sample (sampler creation + film position) and the first five draws of a path
//! (light choice, light point, lobe, direction, roulette) for each [`SamplerKind`], the
//! splatting filter weights, and the sampling of a 2048x1024 environment map's cells (a sky
//! with a sun, 16 MB of CDFs and probabilities) by [`Distribution2D`] (the marginal and one
//! row's CDF searched through their guide tables), each sample followed by the lookup of its
//! cell's probability, as `LatLong::sample_direction` does
//! (docs/lab/2026-12-04-light-tree-env-sampling.md, "Environment-map sampling", for the
//! hierarchical warp and the alias table it was measured against).
//!
//! Run: `cargo bench -p octolux --bench sampling`.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use octolux::film::{camera_sample, FilterWeights, Pixel, Reconstruction};
use octolux::sampling::{Distribution2D, Sampler, SamplerKind};
use octolux::scene::PixelFilter;

fn bench_sampler(c: &mut Criterion) {
    let mut g = c.benchmark_group("sampler");
    let n = 4096u64;
    g.throughput(Throughput::Elements(n));
    for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
        g.bench_function(BenchmarkId::new("camera_sample_and_one_bounce", format!("{kind:?}")), |b| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for i in 0..n {
                    let pixel = Pixel { x: (i % 64) as u32, y: (i / 64) as u32, width: 64 };
                    let (mut s, pos) = camera_sample(kind, 7, pixel, black_box(i & 31), PixelFilter::Tent, Reconstruction::Splat);
                    acc += pos.x + s.next_1d() + s.next_2d().x + s.next_1d() + s.next_2d().y + s.next_1d();
                }
                acc
            })
        });
    }
    g.finish();
}

fn bench_filter(c: &mut Criterion) {
    let mut g = c.benchmark_group("filter_weights");
    let n = 4096;
    g.throughput(Throughput::Elements(n as u64));
    let w = FilterWeights::new(PixelFilter::Gaussian { stddev: 0.5 });
    g.bench_function("gaussian_taps", |b| b.iter(|| (0..n).map(|i| w.at(black_box(i as f32 * (4.0 / n as f32) - 2.0))).sum::<f32>()));
    g.finish();
}

/// Luminance times `sin θ` of a synthetic 2048x1024 sky's cells: a gradient, streaks of cloud,
/// and a sun of a few pixels holding a third of the total.
fn sky_weights(nx: usize, ny: usize) -> Vec<f32> {
    let mut w = Vec::with_capacity(nx * ny);
    for j in 0..ny {
        let theta = (j as f32 + 0.5) / ny as f32 * std::f32::consts::PI;
        for i in 0..nx {
            let phi = (i as f32 + 0.5) / nx as f32 * std::f32::consts::TAU;
            let sky = if theta < std::f32::consts::FRAC_PI_2 { 0.3 + 0.7 * theta.cos() } else { 0.05 };
            let cloud = 1.0 + 0.5 * (13.0 * phi + 7.0 * theta).sin() * (5.0 * phi - 3.0 * theta).cos();
            let (dx, dy) = (i as f32 - 0.3 * nx as f32, j as f32 - 0.25 * ny as f32);
            let sun = 3.0e4 * (-(dx * dx + dy * dy) / 8.0).exp();
            w.push((sky * cloud + sun) * theta.sin());
        }
    }
    w
}

fn bench_env_tables(c: &mut Criterion) {
    let (nx, ny) = (2048usize, 1023usize);
    let w = sky_weights(nx, ny);
    let rows = Distribution2D::new(&w, nx, ny).unwrap();
    let mut g = c.benchmark_group("env_2048x1024");
    let n = 4096u64;
    g.throughput(Throughput::Elements(n));
    let run = |f: &dyn Fn(glam::Vec2) -> f32| {
        // the first 2D slot of 64 samples in each of 64 pixels
        let mut acc = 0.0f32;
        for i in 0..n {
            acc += f(Sampler::with_kind(SamplerKind::Sobol, 3, i / 64, i % 64).next_2d());
        }
        acc
    };
    g.bench_function("guided_row_cdfs", |b| b.iter(|| run(&|u| rows.sample_cell(u).map_or(0.0, |(x, y, p, r)| p + rows.pmf(x, y) + r.x))));
    g.finish();
}

criterion_group!(benches, bench_sampler, bench_filter, bench_env_tables);
criterion_main!(benches);
