//! The `octolux` command-line renderer.
//!
//! `octolux render [SCENE] ...` renders a built-in scene (default `cornell-box`), a Mitsuba XML
//! file, or an OBJ/PLY mesh, and writes `OUT.exr`, `OUT.png` and `OUT.json` (statistics).
//! `octolux export SCENE -o scene.xml` writes the scene as Mitsuba 3 XML (meshes as PLY).

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use octolux::accel::BackendKind;
use octolux::caches::{Estimator, Split, Storage};
use octolux::integrators::christensen::{AddedSamples, ChristensenIntegrator, ChristensenSettings};
use octolux::integrators::octree::{OctreeBuildStats, OctreeIntegrator, OctreeIntegratorSettings, OctreeView};
use octolux::integrators::photonmap::{CacheView, PhotonMapIntegrator, PhotonMapSettings};
use octolux::integrators::ward::{WardIntegrator, WardSettings};
use octolux::integrators::{path::PathSettings, Integrator};
use octolux::photon_pass::PhotonSettings;
use octolux::prepared::Scene;
use octolux::render::{render, Reconstruction, RenderSettings, RenderStats};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser)]
#[command(
    name = "octolux",
    version,
    about = "Offline renderer with a photon-built octree of incident radiance (Pacanowski, Granier & Schlick 2005)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to OUT.exr, OUT.png and OUT.json.
    Render(RenderArgs),
    /// Write a scene as Mitsuba 3 XML (meshes as PLY files in a `meshes/` folder beside it).
    Export(ExportArgs),
    /// List the built-in scenes.
    Scenes,
    /// Compare an image with a reference: relMSE, RMSE and channel means (JSON on stdout).
    Compare {
        /// The image to judge (EXR).
        image: PathBuf,
        /// The reference (EXR).
        reference: PathBuf,
    },
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum IntegratorArg {
    /// Path tracing with next-event estimation and MIS (the reference).
    Path,
    /// The paper's ray tracer with a global and a caustic incident-radiance octree.
    Octree,
    /// Baseline: Ward's irradiance cache, samples computed from the photons.
    Ward,
    /// Baseline: Christensen's precomputed irradiance photon map.
    Christensen,
    /// Baseline: Jensen's photon map with final gathering.
    Photonmap,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum ViewArg {
    /// The rendered image.
    Render,
    /// Irradiance from the global octree at the first diffuse/glossy hit (paper fig. 2).
    Irradiance,
    /// Irradiance from the global and caustic octrees.
    IrradianceAll,
    /// The octree's leaves (depth as colour, borders dark, atmospheric cells black).
    Leaves,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum AddedArg {
    /// Christensen's method alone.
    None,
    /// Configuration C: added samples take the nearest irradiance photon's value.
    Precomputed,
    /// Configuration C: added samples take the global map's density estimate.
    Density,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum EstimatorArg {
    Paper,
    Cosine,
    GeometryArea,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum SplitArg {
    Direction,
    Normal,
}

/// Settings of the octree integrator (defaults: the paper's configuration where it has one).
#[derive(clap::Args)]
struct OctreeArgs {
    /// Photon paths emitted from the lights (octree and the baselines).
    #[arg(long, default_value_t = 1_000_000)]
    photons: u64,
    /// octree: read the global octree one bounce away (a BSDF-sampled gather ray per sample)
    /// instead of at the first surface: less bias, a little noise.
    #[arg(long)]
    gather: bool,
    /// Maximum octree depth h_max.
    #[arg(long)]
    h_max: Option<u32>,
    /// Wanted least photons per leaf.
    #[arg(long)]
    n_min: Option<u32>,
    /// Photons above which a cell is split.
    #[arg(long)]
    n_max: Option<u32>,
    /// Cell enlargement for photon gathering.
    #[arg(long)]
    epsilon: Option<f32>,
    /// Query box side in units of the smallest leaf.
    #[arg(long)]
    alpha: Option<f32>,
    /// Estimator of the leaf matrices.
    #[arg(long, value_enum)]
    estimator: Option<EstimatorArg>,
    /// How photons go to the six axis matrices: `direction` (the paper's, by the sign of the
    /// incident direction) or `normal` (by the side of the surface they landed on; the
    /// integrator's default, exact for planes of any orientation).
    #[arg(long, value_enum)]
    split: Option<SplitArg>,
    /// Store full f32 matrices instead of the paper's 36-byte compressed leaves.
    #[arg(long)]
    uncompressed: bool,
    /// What to write into the image.
    #[arg(long, value_enum, default_value = "render")]
    view: ViewArg,
    /// Trace the photons and build the cache on this scene instead (same -D defines), then
    /// render SCENE with it: e.g. a cache built on simplified geometry, rendered on detailed
    /// geometry (the paper's figure 4).
    #[arg(long, value_name = "SCENE")]
    cache_scene: Option<String>,
    /// christensen: precompute irradiance at every N-th global photon (default 4).
    #[arg(long, value_name = "N")]
    every: Option<u32>,
    /// christensen: samples added during rendering (the paper's configuration C).
    #[arg(long, value_enum, default_value = "none")]
    added: AddedArg,
    /// h_max of the caustic octree (default: the integrator's).
    #[arg(long)]
    caustic_h_max: Option<u32>,
    /// n_max of the caustic octree (default: the integrator's).
    #[arg(long)]
    caustic_n_max: Option<u32>,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum ReconstructionArg {
    Splat,
    Importance,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum BackendArg {
    Auto,
    Embree,
    Bvh,
}

#[derive(clap::Args)]
struct SceneArgs {
    /// Built-in scene name (cornell-box, cornell-spheres), Mitsuba XML file, or OBJ/PLY mesh.
    #[arg(default_value = "cornell-box")]
    scene: String,
    /// Override a Mitsuba `<default>` parameter: -D name=value (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    define: Vec<String>,
}

#[derive(clap::Args)]
struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    #[arg(long, value_enum, default_value = "path")]
    integrator: IntegratorArg,
    /// Samples per pixel (default: the scene's sampler, else 64). With --time-budget: per pass.
    #[arg(long)]
    spp: Option<u32>,
    /// Image size WxH (default: the scene's film).
    #[arg(long, value_parser = parse_resolution)]
    resolution: Option<(u32, u32)>,
    /// Longest path in vertices, Mitsuba's meaning (default: the scene's, else -1 = unbounded).
    #[arg(long, allow_negative_numbers = true)]
    max_depth: Option<i32>,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Keep adding passes of --spp samples until this many seconds have passed.
    #[arg(long)]
    time_budget: Option<f64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Ray-intersection backend.
    #[arg(long, value_enum, default_value = "auto")]
    backend: BackendArg,
    /// How the film's filter is applied: `splat` (uniform positions in the pixel, weighted into
    /// the neighbours, as Mitsuba 3 does; about 2.25x less pixel noise with a tent) or
    /// `importance` (positions drawn from the filter, one pixel per sample).
    #[arg(long, value_enum, default_value = "splat")]
    reconstruction: ReconstructionArg,
    #[command(flatten)]
    octree: OctreeArgs,
    /// Output image path; `.exr` (and `.png`, `.json` beside it).
    #[arg(short, long, default_value = "out.exr")]
    output: PathBuf,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(clap::Args)]
struct ExportArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output XML path.
    #[arg(short, long)]
    output: PathBuf,
    #[arg(long, default_value_t = 64)]
    spp: u32,
    #[arg(long, default_value_t = -1, allow_negative_numbers = true)]
    max_depth: i32,
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WxH (e.g. 512x512)"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height in '{s}'"))?;
    if w == 0 || h == 0 || w > 32768 || h > 32768 {
        return Err(format!("resolution {w}x{h} is out of range 1..32768"));
    }
    Ok((w, h))
}

fn parse_defines(defs: &[String]) -> Result<Vec<(String, String)>> {
    defs.iter()
        .map(|d| {
            let (k, v) = d.split_once('=').with_context(|| format!("-D {d}: expected NAME=VALUE"))?;
            Ok((k.trim().to_string(), v.trim().to_string()))
        })
        .collect()
}

fn load(args: &SceneArgs) -> Result<octolux_io::LoadedScene> {
    let defines = parse_defines(&args.define)?;
    let loaded = octolux_io::load_scene(&args.scene, &defines).with_context(|| format!("cannot load scene '{}'", args.scene))?;
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    Ok(loaded)
}

/// Timings of the phases of one run, in seconds.
#[derive(Serialize, Default)]
struct Timings {
    load_s: f64,
    prepare_s: f64,
    render_s: f64,
    write_s: f64,
    total_s: f64,
}

#[derive(Serialize)]
struct StatsFile<'a> {
    octolux_version: &'a str,
    command_line: Vec<String>,
    scene: &'a str,
    integrator: &'a str,
    integrator_settings: serde_json::Value,
    backend: String,
    threads: usize,
    triangles: usize,
    seed: u64,
    render_settings: RenderSettings,
    timings: Timings,
    samples_per_second: f64,
    rays_per_second: f64,
    render: &'a RenderStats,
    /// Share of the render time spent in radiance-cache lookups (0 for `path`).
    cache_query_share: f64,
    /// Photon pass and octree statistics (the paper's tables 1 and 3), for `octree`.
    build: Option<serde_json::Value>,
    warnings: &'a [String],
}

fn cmd_render(args: RenderArgs) -> Result<()> {
    let t0 = Instant::now();
    if let Some(n) = args.threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        rayon::ThreadPoolBuilder::new().num_threads(n).build_global().context("cannot start the worker threads")?;
    }
    if let Some(b) = args.time_budget {
        if !(b.is_finite() && b > 0.0) {
            bail!("--time-budget must be a positive number of seconds, got {b}");
        }
    }
    if args.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    let ext = args.output.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !ext.eq_ignore_ascii_case("exr") {
        bail!("output '{}' must end in .exr (a .png and a .json are written beside it)", args.output.display());
    }
    let loaded = load(&args.scene)?;
    let load_s = t0.elapsed().as_secs_f64();
    let mut desc = loaded.desc;
    if let Some((w, h)) = args.resolution {
        desc.film.width = w;
        desc.film.height = h;
    }
    let spp = args.spp.or(desc.hints.spp).unwrap_or(64);
    let max_depth = args.max_depth.or(desc.hints.max_depth).unwrap_or(-1);
    if max_depth < -1 {
        bail!("--max-depth must be -1 (unbounded) or at least 0, got {max_depth}");
    }
    let backend = match args.backend {
        BackendArg::Auto => BackendKind::Auto,
        BackendArg::Embree => BackendKind::Embree,
        BackendArg::Bvh => BackendKind::Bvh,
    };
    let t1 = Instant::now();
    let scene = Scene::prepare(desc, backend).with_context(|| format!("cannot prepare scene '{}'", args.scene.scene))?;
    if scene.lights.is_empty() {
        eprintln!("warning: the scene has no light; the image will be black");
    }
    // The scene the photons are traced in (the rendered one unless --cache-scene says otherwise).
    let cache_scene = match &args.octree.cache_scene {
        Some(spec) if args.integrator != IntegratorArg::Path => {
            let other = load(&SceneArgs { scene: spec.clone(), define: args.scene.define.clone() })?;
            Some(Scene::prepare(other.desc, backend).with_context(|| format!("cannot prepare cache scene '{spec}'"))?)
        }
        Some(_) => bail!("--cache-scene needs a cache integrator (octree, ward, christensen, photonmap)"),
        None => None,
    };
    let photon_scene = cache_scene.as_ref().unwrap_or(&scene);
    let cache_view = match args.octree.view {
        ViewArg::Render => CacheView::Render,
        ViewArg::Irradiance => CacheView::Irradiance,
        ViewArg::IrradianceAll => CacheView::IrradianceAll,
        ViewArg::Leaves if matches!(args.integrator, IntegratorArg::Ward | IntegratorArg::Christensen | IntegratorArg::Photonmap) => {
            bail!("--view leaves exists only for --integrator octree")
        }
        ViewArg::Leaves => CacheView::Render,
    };
    for flag in ignored_octree_flags(&args.octree, args.integrator) {
        eprintln!("warning: {flag} applies to --integrator octree only; ignored");
    }
    let prepare_s = t1.elapsed().as_secs_f64();
    let threads = rayon::current_num_threads();
    let mut build_stats = None;
    let (integrator, integrator_settings) = match args.integrator {
        IntegratorArg::Path => {
            let s = PathSettings { max_depth, ..Default::default() };
            (Integrator::Path(s), serde_json::to_value(s)?)
        }
        IntegratorArg::Octree => {
            let s = octree_settings(&args, max_depth);
            let value = serde_json::to_value(&s)?;
            if !args.quiet {
                eprintln!("octree: tracing {} photons and building the octrees ...", s.photons.photons);
            }
            let built = OctreeIntegrator::build(photon_scene, s).context("cannot build the octrees")?;
            if !args.quiet {
                print_octree_stats(&built.stats);
            }
            build_stats = Some(serde_json::to_value(&built.stats)?);
            (Integrator::Octree(Box::new(built)), value)
        }
        IntegratorArg::Ward | IntegratorArg::Christensen | IntegratorArg::Photonmap => {
            let photons = PhotonSettings { photons: args.octree.photons, seed: args.seed, ..Default::default() };
            if !args.quiet {
                eprintln!("{:?}: tracing {} photons and building the cache ...", args.integrator, photons.photons);
            }
            let (integrator, value, stats) = match args.integrator {
                IntegratorArg::Ward => {
                    let s = WardSettings { photons, max_depth, view: cache_view, ..Default::default() };
                    let value = serde_json::to_value(&s)?;
                    let built = WardIntegrator::build(photon_scene, s).context("cannot build the Ward cache")?;
                    let stats = serde_json::to_value(&built.stats)?;
                    (Integrator::Ward(Box::new(built)), value, stats)
                }
                IntegratorArg::Christensen => {
                    let mut s = ChristensenSettings { photons, max_depth, view: cache_view, ..Default::default() };
                    if let Some(n) = args.octree.every {
                        s.every = n;
                    }
                    s.added = match args.octree.added {
                        AddedArg::None => AddedSamples::None,
                        AddedArg::Precomputed => AddedSamples::Precomputed,
                        AddedArg::Density => AddedSamples::Density,
                    };
                    let value = serde_json::to_value(&s)?;
                    let built = ChristensenIntegrator::build(photon_scene, s).context("cannot build the irradiance photon map")?;
                    let stats = serde_json::to_value(&built.stats)?;
                    (Integrator::Christensen(Box::new(built)), value, stats)
                }
                _ => {
                    let s = PhotonMapSettings { photons, max_depth, view: cache_view, ..Default::default() };
                    let value = serde_json::to_value(&s)?;
                    let built = PhotonMapIntegrator::build(photon_scene, s).context("cannot build the photon maps")?;
                    let stats = serde_json::to_value(&built.stats)?;
                    (Integrator::PhotonMap(Box::new(built)), value, stats)
                }
            };
            if !args.quiet {
                eprintln!("build: {}", serde_json::to_string(&stats)?);
            }
            build_stats = Some(stats);
            (integrator, value)
        }
    };
    if !args.quiet {
        eprintln!(
            "octolux: {} ({} triangles), {}x{}, {} spp, integrator {}, backend {}, {} threads",
            args.scene.scene,
            scene.triangle_count(),
            scene.film.width,
            scene.film.height,
            spp,
            integrator.name(),
            scene.backend_name(),
            threads
        );
    }
    let reconstruction = match args.reconstruction {
        ReconstructionArg::Splat => Reconstruction::Splat,
        ReconstructionArg::Importance => Reconstruction::ImportanceSampled,
    };
    let settings = RenderSettings { spp, seed: args.seed, time_budget_s: args.time_budget, reconstruction, ..Default::default() };
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new((scene.film.width as u64) * (scene.film.height as u64)) };
    bar.set_style(
        ProgressStyle::with_template("{spinner} rendering [{bar:40}] {percent}% {elapsed_precise} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    if !args.quiet && args.integrator == IntegratorArg::Octree {
        eprintln!("octree: view {:?}", args.octree.view);
    }
    let progress = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done.min(total));
    };
    let (image, rstats) = render(&scene, &integrator, &settings, &progress);
    bar.finish_and_clear();

    let t2 = Instant::now();
    let png = args.output.with_extension("png");
    let json = args.output.with_extension("json");
    octolux_io::image_io::write_exr(&args.output, &image).with_context(|| format!("cannot write {}", args.output.display()))?;
    octolux_io::image_io::write_png(&png, &image).with_context(|| format!("cannot write {}", png.display()))?;
    let write_s = t2.elapsed().as_secs_f64();
    let stats = StatsFile {
        octolux_version: env!("CARGO_PKG_VERSION"),
        command_line: std::env::args().collect(),
        scene: &args.scene.scene,
        integrator: integrator.name(),
        integrator_settings,
        backend: scene.backend_name(),
        threads,
        triangles: scene.triangle_count(),
        seed: args.seed,
        render_settings: settings,
        timings: Timings { load_s, prepare_s, render_s: rstats.render_s, write_s, total_s: t0.elapsed().as_secs_f64() },
        samples_per_second: rstats.samples_per_second,
        rays_per_second: rstats.rays_per_second,
        render: &rstats,
        cache_query_share: query_share(&rstats, threads),
        build: build_stats,
        warnings: &loaded.warnings,
    };
    write_json(&json, &stats)?;
    if !args.quiet {
        eprintln!(
            "rendered {} spp in {:.2} s: {:.3} M samples/s, {:.2} M rays/s -> {}, {}, {}",
            rstats.spp,
            rstats.render_s,
            rstats.samples_per_second * 1e-6,
            rstats.rays_per_second * 1e-6,
            args.output.display(),
            png.display(),
            json.display()
        );
    }
    Ok(())
}

/// Share of the render's thread time spent in cache lookups.
fn query_share(r: &RenderStats, threads: usize) -> f64 {
    let thread_time_ns = r.render_s * 1e9 * threads as f64;
    if thread_time_ns > 0.0 {
        r.counters.cache_query_ns as f64 / thread_time_ns
    } else {
        0.0
    }
}

/// The octree-only options given with another integrator (they would be silently ignored).
fn ignored_octree_flags(o: &OctreeArgs, integrator: IntegratorArg) -> Vec<&'static str> {
    if integrator == IntegratorArg::Octree {
        return Vec::new();
    }
    let given = [
        ("--gather", o.gather),
        ("--h-max", o.h_max.is_some()),
        ("--n-min", o.n_min.is_some()),
        ("--n-max", o.n_max.is_some()),
        ("--epsilon", o.epsilon.is_some()),
        ("--alpha", o.alpha.is_some()),
        ("--estimator", o.estimator.is_some()),
        ("--split", o.split.is_some()),
        ("--uncompressed", o.uncompressed),
        ("--caustic-h-max", o.caustic_h_max.is_some()),
        ("--caustic-n-max", o.caustic_n_max.is_some()),
    ];
    given.into_iter().filter(|&(_, g)| g).map(|(f, _)| f).collect()
}

fn octree_settings(args: &RenderArgs, max_depth: i32) -> OctreeIntegratorSettings {
    let o = &args.octree;
    let mut s = OctreeIntegratorSettings::default();
    s.photons.photons = o.photons;
    s.photons.seed = args.seed;
    s.max_depth = max_depth;
    s.gather = o.gather;
    for t in [&mut s.global, &mut s.caustic] {
        if let Some(v) = o.h_max {
            t.h_max = v;
        }
        if let Some(v) = o.n_min {
            t.n_min = v;
        }
        if let Some(v) = o.n_max {
            t.n_max = v;
        }
        if let Some(v) = o.epsilon {
            t.epsilon = v;
        }
        if let Some(v) = o.alpha {
            t.alpha = v;
        }
        if let Some(e) = o.estimator {
            t.estimator = match e {
                EstimatorArg::Paper => Estimator::Paper,
                EstimatorArg::Cosine => Estimator::Cosine,
                EstimatorArg::GeometryArea => Estimator::GeometryArea,
            };
        }
        if let Some(v) = o.split {
            t.split = match v {
                SplitArg::Direction => Split::Direction,
                SplitArg::Normal => Split::Normal,
            };
        }
        if o.uncompressed {
            t.storage = Storage::Full;
        }
    }
    if let Some(v) = o.caustic_h_max {
        s.caustic.h_max = v;
    }
    if let Some(v) = o.caustic_n_max {
        s.caustic.n_max = v;
        s.caustic.n_min = s.caustic.n_min.min(v);
    }
    s.view = match o.view {
        ViewArg::Render => OctreeView::Render,
        ViewArg::Irradiance => OctreeView::Irradiance,
        ViewArg::IrradianceAll => OctreeView::IrradianceAll,
        ViewArg::Leaves => OctreeView::Leaves,
    };
    s
}

/// Print the paper's table-1 / table-3 quantities.
fn print_octree_stats(b: &OctreeBuildStats) {
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

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let tmp = path.with_extension("json.tmp");
    std::fs::write(&tmp, serde_json::to_string_pretty(value)?).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

fn cmd_export(args: ExportArgs) -> Result<()> {
    let loaded = load(&args.scene)?;
    loaded.desc.validate().with_context(|| format!("scene '{}' is invalid", args.scene.scene))?;
    octolux_io::export::write_mitsuba_scene(&loaded.desc, args.spp, args.max_depth, &args.output)
        .with_context(|| format!("cannot export to {}", args.output.display()))?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}

/// Errors are printed as one line with their chain of causes (no stack trace, even when
/// RUST_BACKTRACE is set: these are user errors, not crashes), and the exit status is 1.
fn main() -> std::process::ExitCode {
    match run(Cli::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(a) => cmd_render(a),
        Command::Export(a) => cmd_export(a),
        Command::Compare { image, reference } => {
            let a = octolux_io::image_io::read_exr(&image).with_context(|| format!("cannot read {}", image.display()))?;
            let r = octolux_io::image_io::read_exr(&reference).with_context(|| format!("cannot read {}", reference.display()))?;
            let e = octolux::metrics::compare(&a, &r).with_context(|| {
                format!("{} is {}x{} but {} is {}x{}", image.display(), a.width, a.height, reference.display(), r.width, r.height)
            })?;
            println!("{}", serde_json::to_string_pretty(&e)?);
            Ok(())
        }
        Command::Scenes => {
            for n in octolux_io::builtin::NAMES {
                println!("{n}");
            }
            Ok(())
        }
    }
}
