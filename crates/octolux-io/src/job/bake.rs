//! A bake (docs/guide/baking.md): the `octree` integrator's settings resolved as a render
//! resolves them (defaults, the scene's `max_depth`, the seed for the photons, the settings
//! file, the flags, `--set`), the photons traced, both octrees built, with `--volume` the
//! global one's volumetric values (those `render --insert-light volume` reads,
//! `octolux::caches::octree` `atmosphere.rs`; without them such a render computes them at its
//! start), and the whole written with the scene's lighting fingerprint ([`crate::cache`];
//! staged and renamed like every output, so an interrupt never leaves a half-written cache
//! under the final name).
//!
//! What a leaf keeps on disk (issue 26, item 3): its 36-byte value, its facing bits and its
//! mean anchor (where its photons lie, which the volumetric values' diffusion reads); the
//! leak test's sampled photons (24 bytes more) only when the bake's settings run the
//! `visible_sample` leak test or `--volume` is given (an inserted object's volume query tests
//! leaks with them). A render that needs them from a cache without them is refused by name
//! (`OctreeIntegrator::missing_leak_samples`).
//!
//! The cache holds no time, so the same bake gives the same bytes; the times, the statistics
//! and the warnings go to the bake's JSON report, written beside the cache
//! (`lighting.oxc` -> `lighting.json`, [`report_path`]) and returned to Python as a dict.

use super::{bail, Context, Frontend, IntegratorRequest, JobError, Result};
use crate::cache::{self, CacheFile, CacheInfo, CacheLayout};
use octolux::caches::octree::AtmosphereStats;
use octolux::integrators::octree::{LeakTest, OctreeIntegrator, OctreeIntegratorSettings};
use octolux::integrators::IntegratorSettings;
use octolux::scene::{Scene, SceneHints};
use serde::Serialize;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The bake's report beside its cache file: the same name with `.json`. A cache named
/// `*.json` is refused (the report would replace it).
pub fn report_path(cache: &Path) -> Result<PathBuf> {
    if cache.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) {
        bail!("output '{}': a lighting cache may not end in .json (its report is written beside it as NAME.json)", cache.display());
    }
    Ok(cache.with_extension("json"))
}

/// The `octree` settings of a bake, resolved and checked (module docs). `view` chooses what a
/// render writes: the cache keeps the default, with a warning.
pub fn bake_settings(
    req: &IntegratorRequest,
    hints: &SceneHints,
    fe: &dyn Frontend,
    warnings: &mut Vec<String>,
) -> Result<OctreeIntegratorSettings> {
    if let Some(n) = req.integrator.as_deref().filter(|&n| n != "octree") {
        bail!("bake builds the octree integrator's lighting, not {n}'s");
    }
    let mut req = req.clone();
    req.integrator = Some("octree".into());
    let IntegratorSettings::Octree(mut s) = super::resolve_settings(&req, hints, None, fe, warnings)? else {
        bail!("bake builds the octree integrator's lighting; the settings name another integrator");
    };
    let default_view = OctreeIntegratorSettings::default().view;
    if s.view != default_view {
        let name = serde_json::to_value(s.view).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default();
        let w = format!(
            "view {name} does not apply to bake (it chooses what a render writes; give it to `render --cache`); the cache holds \
             the default view"
        );
        fe.warning(&w);
        warnings.push(w);
        s.view = default_view;
    }
    Ok(s)
}

/// Times of a bake, seconds.
#[derive(Serialize, Debug, Clone, Default)]
pub struct BakeTimings {
    /// Reading the scene and resolving the settings.
    pub load_s: f64,
    /// The acceleration structure.
    pub prepare_s: f64,
    /// The scene's lighting fingerprint.
    pub fingerprint_s: f64,
    /// Photon pass and both octrees (`build.t_c_s` is their part without the integrator's setup).
    pub build_s: f64,
    /// The volumetric values (`--volume`; 0 without).
    pub atmosphere_s: f64,
    /// Encoding the cache (and writing it and the report, [`write()`]).
    pub write_s: f64,
    pub total_s: f64,
}

/// The report of a bake (`lighting.json`): what was baked, how, and its times.
#[derive(Serialize, Debug, Clone)]
pub struct BakeReport {
    pub octolux_version: &'static str,
    pub command_line: Vec<String>,
    pub scene: String,
    pub backend: String,
    /// The level the hot kernels ran at (`octolux::cpu`: `baseline` or `avx2`).
    pub kernels: &'static str,
    pub threads: usize,
    /// The `octree` settings baked, tagged with `type`: a valid `--settings` file.
    pub integrator_settings: Value,
    pub timings: BakeTimings,
    /// The build statistics with their times (the paper's tables 1 and 3).
    pub build: Value,
    /// The volumetric values' fill (`--volume`; none without).
    pub atmosphere: Option<AtmosphereStats>,
    /// Whether the cache keeps the leak test's sampled photons (module docs).
    pub leak_samples: bool,
    /// Bytes of the cache file.
    pub file_bytes: usize,
    /// Where they go.
    pub file_layout: CacheLayout,
    /// Valid leaves of both octrees.
    pub valid_leaves: usize,
    /// Nodes of both octrees.
    pub nodes: usize,
    /// Bytes of both octrees in memory.
    pub memory_bytes: usize,
    /// The cache file written (set by [`write()`]).
    pub file: Option<String>,
    pub warnings: Vec<String>,
}

/// A bake done: the cache's bytes and its report.
pub struct Baked {
    pub bytes: Vec<u8>,
    pub report: BakeReport,
}

impl Baked {
    /// What the front end adds to the report: its command line, the load and prepare times,
    /// the warnings met before the bake.
    pub fn add_front_end(&mut self, command_line: &[String], load_s: f64, prepare_s: f64, mut warnings: Vec<String>) {
        self.report.command_line = command_line.to_vec();
        self.report.timings.load_s = load_s;
        self.report.timings.prepare_s = prepare_s;
        self.report.timings.total_s += load_s + prepare_s;
        warnings.append(&mut self.report.warnings);
        self.report.warnings = warnings;
    }
}

/// Bake `scene` (prepared) with `settings`: the octrees, with `volume` their volumetric values,
/// and the cache file's bytes (module docs). `scene_name` is recorded in the file as the scene
/// was named.
pub fn bake(scene: &Scene, scene_name: &str, settings: OctreeIntegratorSettings, volume: bool, fe: &dyn Frontend) -> Result<Baked> {
    let t0 = Instant::now();
    octolux::budget::check_photons(settings.photons.photons).context("the photon count (--photons or photons.photons)")?;
    let fingerprint = scene.lighting_fingerprint();
    let fingerprint_s = t0.elapsed().as_secs_f64();
    fe.info(&format!("octree: tracing {} photons and building the octrees ...", settings.photons.photons));
    let t1 = Instant::now();
    let mut o = OctreeIntegrator::build(scene, settings).context("cannot build the octrees")?;
    let build_s = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let atmosphere = volume.then(|| o.fill_atmosphere(scene));
    let atmosphere_s = t2.elapsed().as_secs_f64();
    for l in super::stats::octree_stats_lines(&o.stats, false) {
        fe.info(&l);
    }
    if let Some(a) = &atmosphere {
        fe.info(&format!("octree: volumetric values: {}", a.summary()));
    }
    let t3 = Instant::now();
    let info =
        CacheInfo { octolux_version: env!("CARGO_PKG_VERSION").into(), scene: scene_name.to_string(), backend: scene.backend_name() };
    let mut parts = o.to_parts();
    // the free-space tree's leak test reads its own anchors, not the global leaves' samples
    let leak_samples = o.leak() == LeakTest::VisibleSample;
    if !leak_samples {
        parts.global = parts.global.without_leak_samples();
        parts.caustic = parts.caustic.map(|c| c.without_leak_samples());
    }
    let (bytes, file_layout) = cache::encode_with_layout(&CacheFile { fingerprint, info, parts });
    let valid = o.stats.global.valid_leaves + o.stats.caustic.as_ref().map_or(0, |c| c.valid_leaves);
    let nodes = o.stats.global.nodes + o.stats.caustic.as_ref().map_or(0, |c| c.nodes);
    let report = BakeReport {
        octolux_version: env!("CARGO_PKG_VERSION"),
        command_line: Vec::new(),
        scene: scene_name.to_string(),
        backend: scene.backend_name(),
        kernels: octolux::cpu::level().name(),
        threads: rayon::current_num_threads(),
        integrator_settings: serde_json::to_value(IntegratorSettings::Octree(o.settings.clone())).map_err(|e| JobError(e.to_string()))?,
        timings: BakeTimings { fingerprint_s, build_s, atmosphere_s, write_s: t3.elapsed().as_secs_f64(), ..Default::default() },
        build: serde_json::to_value(&o.stats).map_err(|e| JobError(e.to_string()))?,
        atmosphere,
        leak_samples,
        file_bytes: bytes.len(),
        file_layout,
        valid_leaves: valid,
        nodes,
        memory_bytes: o.stats.bytes,
        file: None,
        warnings: Vec::new(),
    };
    let mut baked = Baked { bytes, report };
    baked.report.timings.total_s = t0.elapsed().as_secs_f64();
    Ok(baked)
}

/// Write the cache and its report (each staged and renamed; the report last, so that a
/// complete report means a complete cache), and log the summary line. `t0`: the job's start.
pub fn write(baked: &Baked, cache_path: &Path, report_path: &Path, t0: Instant, fe: &dyn Frontend) -> Result<BakeReport> {
    let t = Instant::now();
    super::output::write_file_atomic(cache_path, &baked.bytes)?;
    let mut report = baked.report.clone();
    report.file = Some(cache_path.display().to_string());
    report.timings.write_s += t.elapsed().as_secs_f64();
    report.timings.total_s = t0.elapsed().as_secs_f64();
    let text = serde_json::to_string_pretty(&report).map_err(|e| JobError(e.to_string()))?;
    super::output::write_file_atomic(report_path, text.as_bytes())?;
    let volume = match report.atmosphere {
        Some(_) => format!(", volumetric values {:.3} s", report.timings.atmosphere_s),
        None => String::new(),
    };
    let l = &report.file_layout;
    fe.info(&format!(
        "baked {} -> {}: {} bytes on disk ({:.1} B per valid leaf, {} valid leaves; {:.2} B per node, {} nodes; values {}, \
         anchors {}{}, nodes {}, facing {}, volumetric {}, header {}), {} bytes in memory; photons + octrees {:.3} s{volume} \
         (total {:.3} s); report {}",
        report.scene,
        cache_path.display(),
        report.file_bytes,
        report.file_bytes as f64 / report.valid_leaves.max(1) as f64,
        report.valid_leaves,
        l.nodes as f64 / report.nodes.max(1) as f64,
        report.nodes,
        l.values,
        l.anchors,
        if report.leak_samples { " with the leak test's samples" } else { " (means)" },
        l.nodes,
        l.facing,
        l.atmosphere,
        l.header,
        report.memory_bytes,
        report.timings.build_s,
        report.timings.total_s,
        report_path.display()
    ));
    Ok(report)
}
