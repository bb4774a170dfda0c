//! The octree build rate on a real scene (issue 14 item 4, docs/lab/2026-11-30-performance.md "Octree build
//! rate"): one photon pass, then the `octree` integrator's two trees (global and caustic,
//! default settings, the scene's triangles and spheres for the geometry-area estimator) built
//! `--repeat` times on each thread count, timed by wall clock and by the process's CPU time.
//! Prints photons per wall- and CPU-second and a hash of the built trees (nodes, values,
//! facing bits, anchors; first and last repeat) so that two binaries can be checked for
//! bit-identical output. CPU: user + system time of the process over all repeats, per build.
//!
//! ```sh
//! cargo run --release -p octolux-cli --example build_rate -- --scene cornell-box
//!     [--photons 1000000] [--threads 1,2] [--repeat 5] [--full]
//! ```
//!
//! `--scene`: a built-in scene, `cbox`, `bitterli`, a collection scene's name, or a path.
//! `--full`: full (216-byte) leaves instead of compressed ones, so the hash covers the exact
//! f32 matrices.

use anyhow::{bail, Context, Result};
use octolux::accel::BackendKind;
use octolux::caches::octree::Surfaces;
use octolux::caches::{Octree, Storage};
use octolux::integrators::octree::{estimator_surfaces, OctreeIntegratorSettings};
use octolux::photon::trace::trace_photons;
use octolux::scene::Scene;
use std::time::Instant;

fn load(name: &str) -> Result<Scene> {
    // a name of the benches' alias table (bench/scenes.json), a built-in scene or a file
    let spec = octolux_io::shared::scene_spec(name)?.with_context(|| format!("{name}: not in the shared folder"))?;
    let loaded = octolux_io::load_scene(&spec, &[])?;
    Ok(Scene::prepare(loaded.desc, BackendKind::Auto)?)
}

/// User + system CPU seconds of this process.
fn cpu_s() -> f64 {
    let Ok(s) = std::fs::read_to_string("/proc/self/stat") else { return f64::NAN };
    // fields after the command name (which may hold spaces): utime is field 14, stime 15
    let rest = s.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = 100.0; // sysconf(_SC_CLK_TCK) on Linux
    match (f.get(11).and_then(|x| x.parse::<f64>().ok()), f.get(12).and_then(|x| x.parse::<f64>().ok())) {
        (Some(u), Some(s)) => (u + s) / tick,
        _ => f64::NAN,
    }
}

/// FNV-1a over the Debug text of the tree's data (f32 Debug is exact: shortest round trip).
fn hash(t: &Octree) -> u64 {
    let p = t.to_parts();
    let text = format!("{:?}{:?}{:?}{:?}", p.nodes, p.values, p.facing, p.anchors);
    text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3))
}

/// The octree build rate on a real scene (see the file's docs).
#[derive(clap::Parser)]
struct Args {
    /// A scene alias of bench/scenes.json, a built-in scene or a path.
    #[arg(long, default_value = "cornell-box")]
    scene: String,
    #[arg(long, default_value_t = 1_000_000)]
    photons: u64,
    /// Thread counts, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    threads: Vec<usize>,
    #[arg(long, default_value_t = 5)]
    repeat: usize,
    /// Full (216-byte) leaves instead of compressed ones.
    #[arg(long)]
    full: bool,
}

fn main() -> Result<()> {
    let Args { scene: scene_name, photons, threads, repeat, full } = clap::Parser::parse();
    let scene = load(&scene_name)?;
    let mut settings = OctreeIntegratorSettings::default();
    settings.photons.photons = photons;
    if full {
        settings.global.storage = Storage::Full;
        settings.caustic.storage = Storage::Full;
    }
    let maps = trace_photons(&scene, &settings.photons)?;
    let (tris, spheres) = estimator_surfaces(&scene);
    let surfaces = Some(Surfaces { triangles: &tris, spheres: &spheres });
    let n = maps.global.len() + maps.caustic.len();
    println!(
        "{scene_name}: {} global + {} caustic photons, {} triangles, {} spheres",
        maps.global.len(),
        maps.caustic.len(),
        tris.len(),
        spheres.len()
    );
    for &t in &threads {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build()?;
        let (mut walls, mut cpus, mut hashes) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..repeat {
            let (w0, c0) = (Instant::now(), cpu_s());
            let (g, c) = pool.install(|| -> Result<_> {
                let g = Octree::build_with_surfaces(&maps.global, scene.bounds, &settings.global, surfaces)?;
                let c = if maps.caustic.is_empty() {
                    None
                } else {
                    Some(Octree::build_with_surfaces(&maps.caustic, scene.bounds, &settings.caustic, surfaces)?)
                };
                Ok((g, c))
            })?;
            walls.push(w0.elapsed().as_secs_f64());
            cpus.push(cpu_s() - c0);
            if walls.len() == 1 || walls.len() == repeat {
                hashes.push((hash(&g), c.as_ref().map(hash)));
            }
        }
        if repeat == 0 {
            continue;
        }
        if hashes.iter().any(|h| *h != hashes[0]) {
            bail!("the trees differ between repeats: {hashes:?}");
        }
        let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
        let median = |v: &[f64]| {
            let mut s = v.to_vec();
            s.sort_by(f64::total_cmp);
            s[s.len() / 2]
        };
        // CPU per build: the sum over the repeats (the clock ticks at 10 ms)
        let cpu = cpus.iter().sum::<f64>() / repeat as f64;
        println!(
            "threads {t}: wall best {:.4} s median {:.4} s ({:.2} M photons/s best, {:.2} median), CPU {:.4} s per build ({:.2} M photons per CPU-second); hash {:016x} {}",
            best(&walls),
            median(&walls),
            n as f64 / best(&walls) * 1e-6,
            n as f64 / median(&walls) * 1e-6,
            cpu,
            n as f64 / cpu * 1e-6,
            hashes[0].0,
            hashes[0].1.map_or("-".to_string(), |h| format!("{h:016x}"))
        );
    }
    Ok(())
}
