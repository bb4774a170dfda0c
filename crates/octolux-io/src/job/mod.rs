//! One render or one bake as a front end asks for it: load the scene, prepare it, build the
//! integrator or load the lighting cache, render the frames, write the outputs. The command
//! line (`octolux render`, `octolux bake`), the Python module and, through it, the Dask farm
//! all call these functions, so that a check, a default or a message exists once and a bake
//! or a render made through any of them gives the same bytes (docs/guide/python.md).
//!
//! - [`run_render`]: the whole of `octolux render` (one image, or the frames of a camera path,
//!   the scene's sensors or an object path; `--insert`; `--cache`; the output set per image).
//! - [`run_bake`]: the whole of `octolux bake` (the cache file and its JSON report).
//! - The steps they are made of, for a front end that keeps a prepared scene between calls
//!   (Python's `load_scene`, `render`, `bake`): [`load`], [`prepare`], [`read_cache`],
//!   [`resolve_settings`], [`make_integrator`], [`render_image`], [`bake::bake`].
//!
//! Rooms: [`output`] (the output set: checked first, staged, renamed JSON last), [`frames`]
//! (camera paths and sensors as numbered frames), [`insert`] (an object added to baked
//! lighting), [`stats`] (`OUT.json` and the log's statistics), [`bake`] (the cache file and
//! its report).
//!
//! A front end supplies a [`Frontend`] (where warnings, notes, log lines and progress go; when
//! the render loop runs, for the CLI's signal handler) and a cancel flag that the render loop
//! reads before each tile. Threads are the caller's rayon pool (the CLI's global one, a pool
//! per Python call).

pub mod bake;
mod cpu_clock;
pub mod frames;
pub mod insert;
pub mod output;
mod render;
pub mod stats;

pub use render::{run_render, RenderJob, RenderOutcome};

use crate::cache::{self, LoadedCache};
use crate::settings::{self, keys, FlagSetting, IntegratorRemark, SettingsInput};
use crate::LoadedScene;
use octolux::accel::BackendKind;
use octolux::budget;
use octolux::film::Reconstruction;
use octolux::image::Image;
use octolux::integrators::{build, Integrator, IntegratorSettings};
use octolux::render::{render_cancellable, RenderSettings, RenderStats};
use octolux::sampling::SamplerKind;
use octolux::scene::camera::Camera;
use octolux::scene::{Scene, SceneDesc, SceneHints};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// An error of a job: one line naming the input and the problem (the CLI prints it after
/// `error: `, Python raises it as `OctoluxError`).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct JobError(pub String);

/// A job's result.
pub type Result<T, E = JobError> = std::result::Result<T, E>;

macro_rules! bail {
    ($($t:tt)*) => { return Err($crate::job::JobError(format!($($t)*))) };
}
pub(crate) use bail;

/// `anyhow`'s `context` for this module: the context, then the cause after a colon.
pub(crate) trait Context<T> {
    fn context(self, c: impl std::fmt::Display) -> Result<T>;
    fn with_context<C: std::fmt::Display>(self, f: impl FnOnce() -> C) -> Result<T>;
}

impl<T, E: std::fmt::Display> Context<T> for std::result::Result<T, E> {
    fn context(self, c: impl std::fmt::Display) -> Result<T> {
        self.map_err(|e| JobError(format!("{c}: {e}")))
    }
    fn with_context<C: std::fmt::Display>(self, f: impl FnOnce() -> C) -> Result<T> {
        self.map_err(|e| JobError(format!("{}: {e}", f())))
    }
}

impl From<settings::SettingsError> for JobError {
    fn from(e: settings::SettingsError) -> Self {
        JobError(e.to_string())
    }
}

impl From<crate::IoError> for JobError {
    fn from(e: crate::IoError) -> Self {
        JobError(e.to_string())
    }
}

impl From<String> for JobError {
    fn from(e: String) -> Self {
        JobError(e)
    }
}

/// Where a job's messages go. Every method may be called from the job's thread; `progress`
/// from the render's threads.
pub trait Frontend: Sync {
    /// A line of the log: what is being done, statistics. A quiet front end drops it.
    fn info(&self, line: &str);
    /// A warning: the job renders something other than what the input says (it is also kept
    /// in `OUT.json`).
    fn warning(&self, w: &str);
    /// A milder remark than a warning (what the scene file says that Mitsuba ignores too).
    fn note(&self, n: &str);
    /// The render loop of one image starts (`Some(pixels)`) or ends (`None`): the CLI's
    /// signal handler then asks the loop to stop instead of exiting, and its progress shows.
    fn rendering(&self, _pixels: Option<u64>) {}
    /// Pixels done of the pass under way (called from the render's threads).
    fn progress(&self, _done: u64, _total: u64) {}
}

/// A front end that keeps warnings and notes and drops the log (the Python module's).
#[derive(Default)]
pub struct Collect {
    pub warnings: std::sync::Mutex<Vec<String>>,
    pub notes: std::sync::Mutex<Vec<String>>,
}

impl Frontend for Collect {
    fn info(&self, _line: &str) {}
    fn warning(&self, w: &str) {
        self.warnings.lock().unwrap_or_else(|e| e.into_inner()).push(w.to_string());
    }
    fn note(&self, n: &str) {
        self.notes.lock().unwrap_or_else(|e| e.into_inner()).push(n.to_string());
    }
}

/// The scene a job names.
#[derive(Clone, Debug, Default)]
pub struct SceneSpec {
    /// A built-in name, or a Mitsuba XML, glTF, OBJ or PLY file.
    pub scene: String,
    /// Mitsuba's `-D name=value` overrides of `<default>` parameters.
    pub defines: Vec<(String, String)>,
    /// glTF: buffer and image URIs may name files outside the glTF file's folder.
    pub allow_outside_uris: bool,
}

/// Load a scene; its notes and warnings go to `fe` (and stay in the result).
pub fn load(spec: &SceneSpec, fe: &dyn Frontend) -> Result<LoadedScene> {
    crate::gltf_scene::allow_outside_uris(spec.allow_outside_uris);
    let loaded = crate::load_scene(&spec.scene, &spec.defines).with_context(|| format!("cannot load scene '{}'", spec.scene))?;
    for n in &loaded.notes {
        fe.note(n);
    }
    for w in &loaded.warnings {
        fe.warning(w);
    }
    Ok(loaded)
}

/// The film of `desc` with `resolution` applied, checked against the memory budget (the
/// loader checks a film it reads; a built-in scene's or one set here is checked now).
pub fn set_film(desc: &mut SceneDesc, resolution: Option<(u32, u32)>, scene: &str) -> Result<()> {
    if let Some((w, h)) = resolution {
        budget::check_film(w as u64, h as u64).context("resolution")?;
        desc.film.width = w;
        desc.film.height = h;
    }
    budget::check_film(desc.film.width as u64, desc.film.height as u64).with_context(|| format!("scene '{scene}'"))
}

/// Prepare a scene (acceleration structure, lights); the warning of a scene that will render
/// black goes to `fe` and into `warnings`.
pub fn prepare(desc: SceneDesc, backend: BackendKind, scene: &str, fe: &dyn Frontend, warnings: &mut Vec<String>) -> Result<Scene> {
    let s = Scene::prepare(desc, backend).with_context(|| format!("cannot prepare scene '{scene}'"))?;
    if let Some(w) = s.light_warning() {
        fe.warning(w);
        warnings.push(w.to_string());
    }
    Ok(s)
}

/// `max_depth` as a front end gives it: -1 (unbounded) or at least 0.
pub fn check_max_depth(d: Option<i32>, what: &str) -> Result<()> {
    if let Some(d) = d {
        settings::check_max_depth(d as i64).map_err(|e| JobError(format!("{what} {e}")))?;
    }
    Ok(())
}

/// A lighting cache read and checked (every check of [`crate::cache`]), with its read time.
pub struct CacheIn {
    pub path: PathBuf,
    pub cache: LoadedCache,
    /// Seconds to read and check it.
    pub load_s: f64,
    /// Render even when the scene's lighting fingerprint differs from the bake's (a warning).
    pub allow_stale: bool,
}

/// Read a lighting cache before the scene (which may take long to load).
pub fn read_cache(path: &Path, allow_stale: bool) -> Result<CacheIn> {
    let t = Instant::now();
    let cache = cache::read(path)?;
    Ok(CacheIn { path: path.to_path_buf(), cache, load_s: t.elapsed().as_secs_f64(), allow_stale })
}

/// What chooses a render's integrator and its settings.
#[derive(Clone, Debug, Default)]
pub struct IntegratorRequest {
    /// `--integrator` / `integrator=`; none: the settings file's `type`, else `path`.
    pub integrator: Option<String>,
    /// `--settings FILE` / `settings_file=`.
    pub settings_file: Option<PathBuf>,
    /// Shortcuts for settings keys (the CLI's flags, Python's `photons=`, `max_depth`).
    pub flags: Vec<FlagSetting>,
    /// `KEY=VALUE` writes (`--set`, or Python's settings dict flattened).
    pub sets: Vec<String>,
    /// The render's seed, also the photon pass's (`photons.seed`) unless the settings set it.
    pub seed: u64,
    /// How the messages name what the user typed (the CLI's `--set`, Python's settings dict).
    pub spelling: settings::Spelling,
}

/// The integrator settings of a render or a bake: the library's defaults, or the cache's, then
/// the scene's `max_depth` and the seed, the file, the flags, `--set` (later wins;
/// [`crate::settings`]). Warnings go to `fe` and into `warnings`; the photon count is checked
/// against the memory budget (not with a cache: nothing is traced).
pub fn resolve_settings(
    req: &IntegratorRequest,
    hints: &SceneHints,
    cache: Option<&CacheIn>,
    fe: &dyn Frontend,
    warnings: &mut Vec<String>,
) -> Result<IntegratorSettings> {
    let (name, base, derived) = match cache {
        Some(c) => {
            if let Some(n) = req.integrator.as_deref().filter(|&n| n != "octree") {
                match req.spelling {
                    settings::Spelling::Cli => {
                        bail!("--cache holds the octree integrator's lighting; --integrator {n} cannot render from it")
                    }
                    settings::Spelling::Python => {
                        bail!("cache= holds the octree integrator's lighting; integrator='{n}' cannot render from it")
                    }
                }
            }
            // the cache's settings are the defaults; nothing is derived from the scene or the seed
            (Some("octree"), Some(settings::cache_base(&c.cache)?), vec![])
        }
        None => (
            req.integrator.as_deref(),
            None,
            vec![(keys::MAX_DEPTH, json!(hints.max_depth.unwrap_or(-1))), (keys::PHOTON_SEED, json!(req.seed))],
        ),
    };
    let resolved = settings::resolve_spelt(
        &SettingsInput { integrator: name, base, derived, file: req.settings_file.as_deref(), flags: req.flags.clone(), sets: &req.sets },
        req.spelling,
    )?;
    for w in resolved.warnings {
        fe.warning(&w);
        warnings.push(w);
    }
    if let Some(c) = cache {
        settings::check_cache_settings(&c.path, &c.cache, &resolved.settings)?;
    }
    if let (Some(n), None) = (settings::get(&resolved.settings, keys::PHOTON_COUNT).and_then(|v| v.as_u64()), cache) {
        budget::check_photons(n).context("the photon count (--photons or photons.photons)")?;
    }
    Ok(resolved.settings)
}

/// The remark due when the scene file names an integrator that is not the one rendering and
/// nothing chose it (`chosen`: an integrator, a settings file or a cache was given).
pub fn scene_integrator_remark(hints: &SceneHints, scene: &str, used: &str, chosen: bool, fe: &dyn Frontend, warnings: &mut Vec<String>) {
    match settings::scene_integrator_remark(hints.integrator.as_deref(), scene, used, chosen) {
        Some(IntegratorRemark::Note(n)) => fe.note(&n),
        Some(IntegratorRemark::Warning(w)) => {
            fe.warning(&w);
            warnings.push(w);
        }
        None => {}
    }
}

/// A ready integrator and what `OUT.json` says of how it was made.
pub struct Made {
    pub integrator: Integrator,
    /// With a cache: the file, its size, its load time, where it was baked ([`cache_report`]).
    pub cache: Option<Value>,
    /// Seconds to build it (or to take it from the cache).
    pub build_s: f64,
}

/// The integrator of `settings` for `scene`: taken from the cache (its fingerprint checked
/// against `scene`'s, refused when they differ unless the cache allows it; its render-time
/// settings replaced; its leak planes derived from `scene`),
/// or built, tracing the photons in `photon_scene` (`scene` unless `--cache-scene` says
/// otherwise).
pub fn make_integrator(
    settings: &IntegratorSettings,
    scene: &Scene,
    photon_scene: &Scene,
    cache: Option<CacheIn>,
    scene_name: &str,
    fe: &dyn Frontend,
    warnings: &mut Vec<String>,
) -> Result<Made> {
    let t = Instant::now();
    let (integrator, report) = match cache {
        Some(CacheIn { path, cache: c, load_s, allow_stale }) => {
            let stale = cache::check_fingerprint(&path, &c, &scene.lighting_fingerprint(), scene_name, allow_stale)?;
            if let Some(w) = &stale {
                fe.warning(w);
                warnings.push(w.clone());
            }
            let report = cache_report(&path, &c, load_s, &stale);
            let mut integrator = c.integrator;
            // only the render-time keys may differ: check_cache_settings
            if let (Integrator::Octree(o), IntegratorSettings::Octree(s)) = (&mut integrator, settings) {
                o.settings = s.clone();
            }
            integrator.prepare(scene);
            fe.info(&format!("octree: lighting from {} (read and checked in {load_s:.3} s; no photon traced)", path.display()));
            (integrator, Some(report))
        }
        None => {
            if let Some(n) = settings::get(settings, keys::PHOTON_COUNT).and_then(|v| v.as_u64()) {
                fe.info(&format!("{}: tracing {n} photons and building the cache ...", settings.name()));
            }
            (build(settings, photon_scene).context("cannot build the integrator")?, None)
        }
    };
    Ok(Made { integrator, cache: report, build_s: t.elapsed().as_secs_f64() })
}

/// What `OUT.json` says of the cache a render read.
pub fn cache_report(path: &Path, c: &LoadedCache, load_s: f64, stale: &Option<String>) -> Value {
    json!({
        "file": path.display().to_string(),
        "file_bytes": c.file_bytes,
        "load_s": load_s,
        "baked_from": c.info,
        "stale": stale,
    })
}

/// The integrator's build report for `OUT.json`; taken from a cache, the build's times are
/// `null` (a cache file holds none: [`crate::cache::TIMING_KEYS`]; the bake's report has them).
pub fn build_report(integrator: &Integrator, from_cache: bool) -> Value {
    let mut r = integrator.build_report();
    if from_cache {
        if let Value::Object(m) = &mut r {
            for k in cache::TIMING_KEYS {
                m.insert(k.into(), Value::Null);
            }
            for tree in ["global", "caustic"] {
                if let Some(Value::Object(t)) = m.get_mut(tree) {
                    for k in cache::TREE_TIMING_KEYS {
                        t.insert(k.into(), Value::Null);
                    }
                }
            }
        }
    }
    r
}

/// Render one image of a prepared scene, its progress going to `fe`.
pub fn render_image(
    scene: &Scene,
    integrator: &Integrator,
    rs: &RenderSettings,
    fe: &dyn Frontend,
    cancel: &AtomicBool,
) -> (Image, RenderStats) {
    fe.rendering(Some(scene.film.width as u64 * scene.film.height as u64));
    let progress = |done: u64, total: u64| fe.progress(done, total);
    let out = render_cancellable(scene, integrator, rs, &progress, Some(cancel));
    fe.rendering(None);
    out
}

/// Create the folder of an output where it is missing, saying so on the log.
fn output_folder(path: &Path, fe: &dyn Frontend) -> Result<()> {
    if let Some(dir) = crate::files::create_output_folder(path).map_err(JobError)? {
        fe.info(&format!("created the output folder '{}'", dir.display()));
    }
    Ok(())
}

/// Everything `octolux bake` takes (the CLI's flags; Python's `bake` with a scene name).
#[derive(Clone, Debug)]
pub struct BakeJob {
    pub scene: SceneSpec,
    /// The `octree` settings: `integrator` must be none or `octree`; `seed` is the photons'.
    pub settings: IntegratorRequest,
    pub max_depth: Option<i32>,
    pub backend: BackendKind,
    /// The cache file (its JSON report is written beside it, [`bake::report_path`]).
    pub output: PathBuf,
    /// Fill and store the volumetric values (`bake --volume`, [`bake::bake`]).
    pub volume: bool,
    pub command_line: Vec<String>,
}

/// The whole of `octolux bake`: the output checked first, the scene loaded and prepared, the
/// octrees built (and with `volume` their volumetric values filled), the cache and its report
/// written.
/// A missing output folder is created (and removed again, if still empty, when the job fails).
pub fn run_bake(job: &BakeJob, fe: &dyn Frontend) -> Result<bake::BakeReport> {
    let out = bake_job(job, fe);
    if out.is_err() {
        crate::files::remove_created_folders();
    } else {
        crate::files::keep_created_folders();
    }
    out
}

fn bake_job(job: &BakeJob, fe: &dyn Frontend) -> Result<bake::BakeReport> {
    let t0 = Instant::now();
    check_max_depth(job.max_depth, "--max-depth")?;
    let inputs = [Some(Path::new(&job.scene.scene)), job.settings.settings_file.as_deref()];
    for p in inputs.into_iter().flatten() {
        crate::files::note_input(p);
    }
    output_folder(&job.output, fe)?;
    crate::files::check_output(&job.output)?;
    let report_path = bake::report_path(&job.output)?;
    crate::files::check_output(&report_path)?;
    let loaded = load(&job.scene, fe)?;
    // the scene's own files are inputs too, known once it is read
    crate::files::recheck_output(&job.output)?;
    crate::files::recheck_output(&report_path)?;
    let mut warnings = loaded.warnings.clone();
    let mut req = job.settings.clone();
    req.flags.extend(job.max_depth.map(settings::max_depth_flag));
    let settings = bake::bake_settings(&req, &loaded.desc.hints, fe, &mut warnings)?;
    let load_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let scene = prepare(loaded.desc, job.backend, &job.scene.scene, fe, &mut warnings)?;
    let prepare_s = t1.elapsed().as_secs_f64();
    let mut baked = bake::bake(&scene, &job.scene.scene, settings, job.volume, fe)?;
    baked.add_front_end(&job.command_line, load_s, prepare_s, warnings);
    bake::write(&baked, &job.output, &report_path, t0, fe)
}
