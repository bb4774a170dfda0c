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
    pub frame: Option<crate::frames::FrameInfo>,
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

/// Print the paper's table-1 / table-3 quantities.
pub fn print_octree_stats(b: &OctreeBuildStats) {
    eprintln!(
        "photons: {} emitted, {} global, {} caustic, traced in {:.3} s; octrees built in {:.3} s ({:.1} M photons/s); t_c = {:.3} s",
        b.photons_emitted,
        b.global_photons,
        b.caustic_photons,
        b.t_photons_s,
        b.t_octree_s,
        b.build_photons_per_s * 1e-6,
        b.t_c_s
    );
    let row = |name: &str, s: &octolux::caches::OctreeStats| {
        eprintln!(
            "  {name:8} m_v {:>7}  leaves {:>7}  n_p {:>7.1}  s {:>9.4}  F_m {:>10} B ({:.1} B/valid leaf)  depth hist {:?}",
            s.valid_leaves, s.leaves, s.mean_photons_per_leaf, s.mean_cell_size, s.bytes, s.bytes_per_valid_leaf, s.depth_histogram
        );
    };
    row("global", &b.global);
    if let Some(c) = &b.caustic {
        row("caustic", c);
    }
}
