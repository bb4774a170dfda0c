//! The octree's query against the rest of a camera sample, per query, on one core (issue 14
//! item 4, `docs/lab/2026-11-30-performance.md`, "The octree's query").
//!
//! ```sh
//! cargo run --release -p octolux-cli --example query_cost -- cornell-box [--photons 1000000] [--res 128] [--rounds 3]
//! ```
//!
//! Builds the `octree` integrator with its default settings, finds the first diffuse vertex of
//! `res²` camera rays (one per pixel centre), then times, on this thread (CPU time of the
//! thread), the global tree's query at those vertices with each leak test, and the integrator's
//! whole `li` for the same rays; prints ns per query, ns per `li`, their ratio, and the leaves a
//! query meets (mean and histogram) and the visibility rays it casts.

use anyhow::Result;
use glam::Vec2;
use octolux::accel::BackendKind;
use octolux::integrators::common::walk_specular;
use octolux::integrators::octree::{LeakTest, OctreeIntegrator, OctreeIntegratorSettings, Tree};
use octolux::integrators::RayCounters;
use octolux::math::Ray;
use octolux::sampling::Sampler;
use octolux::scene::Scene;

fn load(name: &str) -> Result<Option<Scene>> {
    // a name of the benches' alias table (bench/scenes.json), a built-in scene or a file
    let Some(spec) = octolux_io::shared::scene_spec(name)? else { return Ok(None) };
    let loaded = octolux_io::load_scene(&spec, &[])?;
    Ok(Some(Scene::prepare(loaded.desc, BackendKind::Auto)?))
}

/// CPU time of this thread, seconds.
fn thread_cpu() -> f64 {
    let mut ts = nix::libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: a valid pointer to a timespec
    unsafe { nix::libc::clock_gettime(nix::libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64
}

/// The octree's query against the rest of a camera sample (see the file's docs).
#[derive(clap::Parser)]
struct Args {
    /// A scene alias of bench/scenes.json, a built-in scene or a path.
    #[arg(default_value = "cornell-box")]
    scene: String,
    #[arg(long, default_value_t = 1_000_000)]
    photons: u64,
    #[arg(long, default_value_t = 128)]
    res: u32,
    #[arg(long, default_value_t = 3)]
    rounds: u32,
}

fn main() -> Result<()> {
    let Args { scene: scene_name, photons, res, rounds } = clap::Parser::parse();
    let Some(scene) = load(&scene_name)? else {
        println!("skip: {scene_name} (shared scenes not found)");
        return Ok(());
    };
    let mut st = OctreeIntegratorSettings::default();
    st.photons.photons = photons;
    let o = OctreeIntegrator::build(&scene, st)?;
    o.prepare_query();
    let (w, h) = (scene.film.width as f32, scene.film.height as f32);
    let rays: Vec<Ray> = (0..res * res)
        .map(|i| {
            let film = Vec2::new(((i % res) as f32 + 0.5) * w / res as f32, ((i / res) as f32 + 0.5) * h / res as f32);
            let (org, d, tmin) = scene.camera.generate_ray(film);
            let mut r = Ray::new(org, d);
            r.tmin = tmin;
            r
        })
        .collect();
    let mut c = RayCounters::default();
    let verts: Vec<_> = rays
        .iter()
        .enumerate()
        .filter_map(|(i, r)| walk_specular(&scene, *r, None, 64, false, &mut Sampler::new(0, i as u64, 0), &mut c).vertex)
        .collect();
    println!("{scene_name}: {} photons, {} vertices of {} rays", photons, verts.len(), rays.len());
    // leaves met per query and rays per query (default leak test)
    let mut hist = [0u64; 33];
    let (mut met, mut own_only) = (0u64, 0u64);
    for v in &verts {
        let mut k = 0usize;
        o.global.irradiance_where(v.hit.p, v.n, |_| {
            k += 1;
            Some(1.0)
        });
        hist[k.min(32)] += 1;
        met += k as u64;
        own_only += (k == 1) as u64;
    }
    let nq = verts.len().max(1) as f64;
    println!("leaves met per query: mean {:.2}, exactly one {:.3}", met as f64 / nq, own_only as f64 / nq);
    println!(
        "histogram (leaves: share): {}",
        (0..33).filter(|&i| hist[i] > 0).map(|i| format!("{i}:{:.3}", hist[i] as f64 / nq)).collect::<Vec<_>>().join(" ")
    );
    let parts = o.to_parts();
    let configs = [LeakTest::None, LeakTest::VisibleSample];
    let integrators: Vec<OctreeIntegrator> = configs
        .iter()
        .map(|&leak| {
            let mut p = parts.clone();
            p.settings.leak = leak;
            let mut o = OctreeIntegrator::from_parts(p).expect("same parts");
            let t0 = thread_cpu();
            o.prepare(&scene);
            println!("{leak:?}: preparation {:.3} s of CPU (one thread), report {}", thread_cpu() - t0, o.leak_report());
            o
        })
        .collect();
    for round in 0..rounds {
        let mut line = format!("round {round}:");
        let only: Option<usize> = std::env::var("QUERY_COST_ONLY").ok().and_then(|v| v.parse().ok());
        for (i, (o, leak)) in integrators.iter().zip(configs).enumerate() {
            if only.is_some_and(|k| k != i) {
                continue;
            }
            let mut c = RayCounters::default();
            let t0 = thread_cpu();
            let mut sum = 0.0f64;
            for v in &verts {
                sum += o.irradiance_at(&scene, Tree::Global, &v.hit, v.n, &mut c).map_or(0.0, |e| e.x as f64);
            }
            let tq = thread_cpu() - t0;
            let mut c2 = RayCounters::default();
            let t0 = thread_cpu();
            let mut li = 0.0f64;
            for (i, r) in rays.iter().enumerate() {
                li += o.li(&scene, *r, None, &mut Sampler::new(1, i as u64, 0), &mut c2).x as f64;
            }
            let tl = thread_cpu() - t0;
            let per_li = tl / rays.len() as f64;
            let per_q = tq / nq;
            let share = per_q * c2.cache_queries as f64 / rays.len() as f64 / per_li;
            line += &format!(
                "\n  {leak:?}: query {:.0} ns ({:.2} rays) [{sum:.4e}], li {:.0} ns/ray [{li:.4e}], est. share {share:.3}",
                1e9 * per_q,
                c.shadow_rays as f64 / nq,
                1e9 * per_li
            );
        }
        println!("{line}");
    }
    Ok(())
}
