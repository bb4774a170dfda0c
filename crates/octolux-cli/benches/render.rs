//! Criterion benchmarks of whole-image rendering throughput (samples per second) on the
//! built-in scenes: `path` per backend, and `octree` rendering (cache built once, outside the
//! timed loop; its build is benchmarked in `octolux/benches/octree.rs`).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use octolux::accel::BackendKind;
use octolux::integrators::octree::{OctreeIntegrator, OctreeIntegratorSettings};
use octolux::integrators::{path::PathSettings, Integrator};
use octolux::render::{render, RenderSettings};
use octolux::scene::Scene;

fn scene(name: &str, backend: BackendKind, res: u32) -> Option<Scene> {
    let mut desc = octolux_io::builtin::scene(name)?;
    desc.film.width = res;
    desc.film.height = res;
    Scene::prepare(desc, backend).ok()
}

fn bench_render(c: &mut Criterion) {
    let res = 64u32;
    let spp = 4u32;
    let mut g = c.benchmark_group("render");
    g.sample_size(10);
    g.throughput(Throughput::Elements((res * res * spp) as u64));
    let settings = RenderSettings { spp, seed: 0, ..Default::default() };
    for name in ["cornell-box", "cornell-spheres"] {
        for (bname, backend) in [("embree", BackendKind::Embree), ("bvh", BackendKind::Bvh)] {
            let Some(s) = scene(name, backend, res) else {
                eprintln!("{name}/{bname}: backend unavailable, skipped");
                continue;
            };
            let integrator = Integrator::Path(PathSettings::default());
            g.bench_function(format!("path/{name}/{bname}"), |b| b.iter(|| render(&s, &integrator, &settings, &|_, _| {})));
        }
        if let Some(s) = scene(name, BackendKind::Auto, res) {
            let mut os = OctreeIntegratorSettings::default();
            os.photons.photons = 200_000;
            let integrator = Integrator::Octree(Box::new(OctreeIntegrator::build(&s, os).expect("octree builds")));
            g.bench_function(format!("octree/{name}"), |b| b.iter(|| render(&s, &integrator, &settings, &|_, _| {})));
        }
    }
    g.finish();
}

criterion_group!(benches, bench_render);
criterion_main!(benches);
