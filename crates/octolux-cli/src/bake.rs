//! `octolux bake` and the lighting cache of `render --cache` (issue 13, docs/baking.md).
//!
//! `bake` resolves the `octree` integrator's settings as `render` does (defaults, the scene's
//! `max_depth`, `--seed` for the photons, `--settings`, flags, `--set`), traces the photons,
//! builds both octrees, diffuses the global one's values into its empty leaves (the volumetric
//! values `render --insert` reads, `octolux::caches::octree` `atmosphere.rs`) and writes them
//! with the scene's lighting fingerprint ([`octolux_io::cache`]; staged and renamed like every
//! output, so an interrupt, which exits at once as before `render`'s loop, never leaves a
//! half-written cache under the final name). `render --cache` reads and
//! checks the file before the scene is even loaded, takes the cache's settings as the base of
//! its own (so only the render-time keys may change; a key that shaped the
//! octrees is refused), and compares the fingerprints once the scene is prepared.

use crate::args::{keys, BakeArgs};
use crate::settings::{self, SettingsInput};
use crate::{backend_kind, load, output, stats};
use anyhow::{bail, Context, Result};
use octolux::budget;
use octolux::integrators::octree::OctreeIntegrator;
use octolux::integrators::IntegratorSettings;
use octolux::scene::Scene;
use octolux_io::cache::{self, CacheFile, CacheInfo, LoadedCache};
use serde_json::{json, Value};
use std::path::Path;
use std::time::Instant;

/// Most worker threads per core `--threads` may start: more only adds switching (and 100,000
/// threads hung the start).
pub const MAX_THREADS_PER_CORE: usize = 8;

/// Checks shared by `render` and `bake` before any work: threads, memory limit, max depth.
/// Returns the warnings (a `--threads` above [`MAX_THREADS_PER_CORE`] times the cores is
/// lowered to that).
pub fn check_run_flags(threads: Option<usize>, memory_limit: Option<&str>, max_depth: Option<i32>) -> Result<Vec<String>> {
    let mut warnings = Vec::new();
    if let Some(d) = max_depth {
        settings::check_max_depth(d as i64).map_err(|e| anyhow::anyhow!("--max-depth {e}"))?;
    }
    if let Some(mut n) = threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
        let most = cores.saturating_mul(MAX_THREADS_PER_CORE);
        if n > most {
            let w = format!("--threads {n} is more than {MAX_THREADS_PER_CORE} per core on this machine's {cores} cores; using {most}");
            eprintln!("warning: {w}");
            warnings.push(w);
            n = most;
        }
        rayon::ThreadPoolBuilder::new().num_threads(n).build_global().context("cannot start the worker threads")?;
    }
    if let Some(m) = memory_limit {
        let bytes = budget::parse_bytes(m)
            .with_context(|| format!("--memory-limit {m}: expected a memory size (bytes with an optional K, M, G or T suffix)"))?;
        budget::set_memory_limit(bytes);
    }
    Ok(warnings)
}

pub fn cmd_bake(args: &BakeArgs) -> Result<std::process::ExitCode> {
    let t0 = Instant::now();
    let _ = check_run_flags(args.threads, args.memory_limit.as_deref(), args.max_depth)?;
    args.octree.check_removed()?;
    if args.octree.cache_scene.is_some() {
        bail!("--cache-scene does not apply to bake: bake that scene itself");
    }
    crate::note_inputs([Some(Path::new(&args.scene.scene)), args.settings.as_deref()].into_iter().flatten());
    output::check_file(&args.output)?;
    // As before `render`'s loop: a signal exits at once (status 130), removing the staged
    // cache file; a cache under the final name is the previous run's, untouched.
    crate::interrupt::install()?;
    let loaded = load(&args.scene)?;
    let desc = loaded.desc;
    let mut flags = args.octree.settings();
    flags.extend(args.max_depth.map(settings::max_depth_flag));
    let resolved = settings::resolve(&SettingsInput {
        integrator: Some("octree"),
        base: None,
        derived: vec![(keys::MAX_DEPTH, json!(desc.hints.max_depth.unwrap_or(-1))), (keys::PHOTON_SEED, json!(args.seed))],
        file: args.settings.as_deref(),
        flags,
        sets: &args.set,
    })?;
    for w in &resolved.warnings {
        eprintln!("warning: {w}");
    }
    let IntegratorSettings::Octree(mut octree_settings) = resolved.settings else {
        bail!("bake builds the octree integrator's lighting; the settings name another integrator");
    };
    // `view` chooses what a render writes: the cache keeps the default (render)
    let default_view = octolux::integrators::octree::OctreeIntegratorSettings::default().view;
    if octree_settings.view != default_view {
        let name = serde_json::to_value(octree_settings.view).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default();
        eprintln!(
            "warning: view {name} does not apply to bake (it chooses what a render writes; give it to `render --cache`); the cache \
             holds the default view"
        );
        octree_settings.view = default_view;
    }
    budget::check_photons(octree_settings.photons.photons).context("the photon count (--photons or photons.photons)")?;
    let t1 = Instant::now();
    let scene = Scene::prepare(desc, backend_kind(args.backend)).with_context(|| format!("cannot prepare scene '{}'", args.scene.scene))?;
    let prepare_s = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let fingerprint = scene.lighting_fingerprint();
    let fingerprint_s = t2.elapsed().as_secs_f64();
    if !args.quiet {
        eprintln!("octree: tracing {} photons and building the octrees ...", octree_settings.photons.photons);
    }
    let t3 = Instant::now();
    let mut o = OctreeIntegrator::build(&scene, octree_settings).context("cannot build the octrees")?;
    let bake_s = t3.elapsed().as_secs_f64();
    // the volumetric values (`render --insert`): diffused into the global tree's empty leaves
    let atmosphere = o.fill_atmosphere(&scene);
    if !args.quiet {
        stats::print_octree_stats(&o.stats);
        eprintln!(
            "octree: volumetric values: {} of {} leaves filled, {} empty leaves unreached, {} edges ({} blocked by surfaces), \
             {} bytes, {:.3} s",
            atmosphere.filled_leaves,
            atmosphere.leaves,
            atmosphere.unreached_leaves,
            atmosphere.edges,
            atmosphere.blocked_edges,
            atmosphere.bytes,
            atmosphere.t_s
        );
    }
    let t4 = Instant::now();
    let info =
        CacheInfo { octolux_version: env!("CARGO_PKG_VERSION").into(), scene: args.scene.scene.clone(), backend: scene.backend_name() };
    let bytes = cache::encode(&CacheFile { fingerprint, info, parts: o.to_parts() });
    output::write_file_atomic(&args.output, &bytes)?;
    let write_s = t4.elapsed().as_secs_f64();
    let valid = o.stats.global.valid_leaves + o.stats.caustic.as_ref().map_or(0, |c| c.valid_leaves);
    eprintln!(
        "baked {} -> {}: {} bytes on disk ({:.1} B per valid leaf, {} valid leaves), {} bytes in memory; photons + octrees {:.3} s, \
         fingerprint {:.3} s, encode + write {:.3} s (prepare {:.3} s, total {:.3} s)",
        args.scene.scene,
        args.output.display(),
        bytes.len(),
        bytes.len() as f64 / valid.max(1) as f64,
        valid,
        o.stats.bytes,
        bake_s,
        fingerprint_s,
        write_s,
        prepare_s,
        t0.elapsed().as_secs_f64()
    );
    Ok(std::process::ExitCode::SUCCESS)
}

/// Read a lighting cache (every check of [`octolux_io::cache`]) and time it.
pub fn read_cache(path: &Path) -> Result<(LoadedCache, f64)> {
    let t = Instant::now();
    let c = cache::read(path)?;
    Ok((c, t.elapsed().as_secs_f64()))
}

/// What `OUT.json` says of the cache.
pub fn report(path: &Path, c: &LoadedCache, load_s: f64, stale: &Option<String>) -> Value {
    json!({
        "file": path.display().to_string(),
        "file_bytes": c.file_bytes,
        "load_s": load_s,
        "baked_from": c.info,
        "stale": stale,
    })
}
