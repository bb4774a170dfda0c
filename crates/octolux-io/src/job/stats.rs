//! `OUT.json`: what was rendered, how, and every counter of the build and of the render; and
//! the build statistics printed to the log.

use octolux::integrators::octree::OctreeBuildStats;
use octolux::render::{RenderSettings, RenderStats};
use serde::Serialize;

/// Timings of the phases of one run, in seconds.
#[derive(Serialize, Default)]
pub struct Timings {
    pub load_s: f64,
    /// Scene preparation (acceleration structure), and the cache scene's with `--cache-scene`.
    pub prepare_s: f64,
    /// The integrator's build (photon pass, cache construction, priming), seconds.
    pub build_s: f64,
    pub render_s: f64,
    /// CPU seconds of the process during `render_s`, all threads (user and system): the cost
    /// to divide by where the machine is shared. `None` where the platform has no such clock.
    pub render_cpu_s: Option<f64>,
    pub write_s: f64,
    pub total_s: f64,
}

/// The contents of `OUT.json`.
#[derive(Serialize)]
pub struct StatsFile<'a> {
    pub octolux_version: &'a str,
    pub command_line: Vec<String>,
    pub scene: &'a str,
    pub integrator: &'a str,
    /// The integrator's settings as used, tagged with `type`: a valid `--settings` file.
    pub integrator_settings: serde_json::Value,
    pub backend: String,
    /// The level the hot kernels ran at (`octolux::cpu`: `baseline` or `avx2`).
    pub kernels: &'static str,
    pub threads: usize,
    pub triangles: usize,
    pub seed: u64,
    pub render_settings: RenderSettings,
    pub timings: Timings,
    pub samples_per_second: f64,
    pub rays_per_second: f64,
    /// The render loop's statistics, with its counters (`render.counters`: rays, shadow rays,
    /// cache queries and the time spent in them, measured alike for every cache).
    pub render: &'a RenderStats,
    /// Share of the render's thread time spent in radiance-cache lookups (0 for `path`).
    pub cache_query_share: f64,
    /// The integrator's build report: photon pass and cache statistics (the paper's tables 1
    /// and 3 for `octree`); null for `path`.
    pub build: serde_json::Value,
    /// The integrator's own render-time counters that the render loop does not keep (Ward's
    /// temporary samples, Christensen's lookups that found no irradiance photon, ...).
    pub render_report: serde_json::Value,
    /// Warnings of the scene loader and of the command line.
    pub warnings: &'a [String],
    /// Set when the render stopped early (an interrupt): the image holds what is said here,
    /// fewer samples than asked for. Null for a complete render.
    pub partial: Option<Partial>,
    /// With `--cache`: the file, its size, its load time (read, checksum, octree checks) and
    /// where it was baked; null otherwise.
    pub cache: Option<serde_json::Value>,
    /// For the frames of `--camera-path` / `--sensors`: which frame this is; null otherwise.
    pub frame: Option<super::frames::FrameInfo>,
    /// With `--insert`: the object, its transform and the pixels it covers (`insert.rs`).
    pub insert: Option<serde_json::Value>,
}

/// What a partial image holds.
#[derive(Serialize, Debug)]
pub struct Partial {
    /// Why the render stopped (`"interrupted"`: SIGINT, SIGTERM or SIGHUP).
    pub reason: &'static str,
    /// Whole passes done (each of `render_settings.spp` samples per pixel).
    pub passes: u32,
    /// Samples per pixel in the image.
    pub spp: u32,
    /// Samples in the image (all pixels).
    pub samples: u64,
}

impl Partial {
    pub fn interrupted(r: &RenderStats) -> Self {
        Partial { reason: "interrupted", passes: r.passes, spp: r.spp, samples: r.samples }
    }
}

/// Share of the render's thread time spent in cache lookups.
pub fn query_share(r: &RenderStats, threads: usize) -> f64 {
    let thread_time_ns = r.render_s * 1e9 * threads as f64;
    if thread_time_ns > 0.0 {
        r.counters.cache_query_ns as f64 / thread_time_ns
    } else {
        0.0
    }
}

/// The build statistics of the `octree` integrator as log lines, in words with the paper's
/// symbols in brackets (tables 1 and 3). From a cache the photons were traced by the bake:
/// no time is given (the bake's report has them).
pub fn octree_stats_lines(b: &OctreeBuildStats, from_cache: bool) -> Vec<String> {
    let mut lines = vec![if from_cache {
        format!(
            "photons (baked): {} emitted, {} global, {} caustic; octrees of {} bytes [F_m]",
            b.photons_emitted, b.global_photons, b.caustic_photons, b.bytes
        )
    } else {
        format!(
            "photons: {} emitted, {} global, {} caustic, traced in {:.3} s; octrees built in {:.3} s ({:.1} M photons/s), \
             {} bytes [F_m]; photons and octrees {:.3} s [t_c]",
            b.photons_emitted,
            b.global_photons,
            b.caustic_photons,
            b.t_photons_s,
            b.t_octree_s,
            b.build_photons_per_s * 1e-6,
            b.bytes,
            b.t_c_s
        )
    }];
    let row = |name: &str, s: &octolux::caches::OctreeStats| {
        format!(
            "  {name} octree: {} valid leaves [m_v] of {}, {:.1} photons per leaf [n_p], mean cell edge {:.4} [s], {} bytes [F_m] \
             ({:.1} B per valid leaf), valid leaves per depth {:?}",
            s.valid_leaves, s.leaves, s.mean_photons_per_leaf, s.mean_cell_size, s.bytes, s.bytes_per_valid_leaf, s.depth_histogram
        )
    };
    lines.push(row("global", &b.global));
    if let Some(c) = &b.caustic {
        lines.push(row("caustic", c));
    }
    lines
}

/// A baseline's build report (`ward`, `christensen`, `photonmap`) as one line in words, the
/// paper's symbols in brackets.
pub fn summary(build: &serde_json::Value) -> String {
    let n = |v: &serde_json::Value, k: &str| v.get(k).and_then(serde_json::Value::as_f64);
    let mut parts = Vec::new();
    if let Some(p) = build.get("photons") {
        let count = |k| n(p, k).map_or("?".to_string(), |x| format!("{x:.0}"));
        let mut s = format!(
            "photons: {} emitted, {} global, {} caustic",
            count("photons_emitted"),
            count("global_photons"),
            count("caustic_photons")
        );
        if let (Some(t), Some(k)) = (n(p, "t_photons_s"), n(p, "t_kdtree_s")) {
            s += &format!(", traced in {t:.3} s, kd-trees built in {k:.3} s");
        }
        parts.push(s);
    }
    for (key, words) in [("m_e", "cache samples [m_e]"), ("m_a", "added Ward samples [m_a]"), ("prime_points", "priming points")] {
        if let Some(v) = n(build, key).filter(|&v| v > 0.0) {
            parts.push(format!("{v:.0} {words}"));
        }
    }
    if let Some(t) = n(build, "t_prime_s").filter(|&t| t > 0.0) {
        parts.push(format!("priming {t:.3} s"));
    }
    if let Some(b) = n(build, "bytes") {
        parts.push(format!("{b:.0} bytes [F_m]"));
    }
    if let Some(t) = n(build, "t_c_s") {
        parts.push(format!("built in {t:.3} s [t_c]"));
    }
    parts.join("; ")
}
