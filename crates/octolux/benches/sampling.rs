//! Sampler and film benchmarks: the per-sample work of the render loop outside the integrator.
//! A camera sample (sampler creation + film position) and the first five draws of a path
//! (light choice, light point, lobe, direction, roulette) for each [`SamplerKind`], and the
//! splatting filter weights.
//!
//! Run: `cargo bench -p octolux --bench sampling`.

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use octolux::film::{camera_sample, FilterWeights, Pixel, Reconstruction};
use octolux::sampling::SamplerKind;
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

criterion_group!(benches, bench_sampler, bench_filter);
criterion_main!(benches);
