//! `octolux._octolux`: the Python bindings, wrapped by the pure-Python
//! package `octolux` (`python/octolux/__init__.py`), which turns settings dicts into `--set`
//! writes, stats JSON into dicts and scene warnings into Python warnings.
//!
//! The bindings call the CLI's code, not copies of it: every step is `octolux_io::job`'s (the
//! scene's load and preparation, the settings' resolution, so that a bad key raises the CLI's
//! message in Python's words (`Spelling::Python`), the cache's checks, the integrator's build,
//! the bake with its volumetric values, `OUT.json`), and `render_to_files` is `octolux render`
//! itself (the Dask farm's frames).
//!
//! Long work (loading, the photon pass, rendering) runs on a worker thread while the calling
//! thread waits with the GIL released, checking for signals every 20 ms: Ctrl-C stops a render
//! at its next tile (through `render_cancellable`'s flag) and raises `KeyboardInterrupt`; a
//! photon pass or a load is not cut short, the interrupt is raised when it ends.

use numpy::{PyArray1, PyReadonlyArray3, PyUntypedArrayMethods};
use octolux::accel::BackendKind;
use octolux::image::Image;
use octolux::math::Color;
use octolux::render::RenderSettings;
use octolux_io::job::{self, bake as jbake, stats, Collect, IntegratorRequest, RenderOutcome};
use octolux_io::settings::{keys, FlagSetting, Spelling};
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use serde_json::json;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

pyo3::create_exception!(octolux, OctoluxError, PyException, "An octolux error: the message is the CLI's.");

fn error(e: impl std::fmt::Display) -> PyErr {
    OctoluxError::new_err(e.to_string())
}

/// Run `f` on a worker thread (inside a pool of `threads` workers when given) while this
/// thread waits without the GIL; a signal (Ctrl-C) sets `cancel` and is raised once `f`
/// returns.
fn interruptible<T: Send>(py: Python<'_>, threads: Option<usize>, cancel: &AtomicBool, f: impl FnOnce() -> T + Send) -> PyResult<T> {
    let pool = match threads {
        Some(0) => return Err(error("threads must be at least 1")),
        Some(n) => Some(
            rayon::ThreadPoolBuilder::new().num_threads(n).build().map_err(|e| error(format!("cannot start the worker threads: {e}")))?,
        ),
        None => None,
    };
    let mut signal = None;
    let out = std::thread::scope(|s| {
        let worker = s.spawn(|| match &pool {
            Some(p) => p.install(f),
            None => f(),
        });
        while !worker.is_finished() {
            py.detach(|| std::thread::sleep(Duration::from_millis(20)));
            if signal.is_none() {
                if let Err(e) = py.check_signals() {
                    cancel.store(true, Ordering::Relaxed);
                    signal = Some(e);
                }
            }
        }
        worker.join()
    });
    if let Some(e) = signal {
        return Err(e);
    }
    out.map_err(|_| error("internal error: the worker thread panicked"))
}

fn backend(name: &str) -> PyResult<BackendKind> {
    Ok(match name {
        "auto" => BackendKind::Auto,
        "embree" => BackendKind::Embree,
        "bvh" => BackendKind::Bvh,
        _ => return Err(error(format!("backend '{name}': expected auto, embree or bvh"))),
    })
}

/// A loaded and prepared scene, reusable across renders.
#[pyclass(frozen, module = "octolux")]
struct Scene {
    scene: octolux::scene::Scene,
    spec: String,
    hints: octolux::scene::SceneHints,
    #[pyo3(get)]
    warnings: Vec<String>,
    #[pyo3(get)]
    notes: Vec<String>,
}

#[pymethods]
impl Scene {
    /// The scene as it was named (built-in name or path).
    #[getter]
    fn name(&self) -> &str {
        &self.spec
    }
    /// (width, height) of the film in pixels.
    #[getter]
    fn resolution(&self) -> (u32, u32) {
        (self.scene.film.width, self.scene.film.height)
    }
    /// The ray-intersection backend in use (`embree` or `bvh`).
    #[getter]
    fn backend(&self) -> String {
        self.scene.backend_name()
    }
    fn __repr__(&self) -> String {
        format!("octolux.Scene('{}', {}x{}, {})", self.spec, self.scene.film.width, self.scene.film.height, self.scene.backend_name())
    }
}

/// Load and prepare a scene: a built-in name, a Mitsuba XML file (with `defines`, Mitsuba's
/// `-D name=value`), a glTF file, or an OBJ/PLY mesh.
#[pyfunction]
#[pyo3(signature = (path, defines = Vec::new(), resolution = None, backend = "auto"))]
fn load_scene(
    py: Python<'_>,
    path: &str,
    defines: Vec<(String, String)>,
    resolution: Option<(u32, u32)>,
    backend: &str,
) -> PyResult<Scene> {
    let kind = self::backend(backend)?;
    if let Some((w, h)) = resolution {
        octolux::budget::check_film(w as u64, h as u64).map_err(|e| error(format!("resolution: {e}")))?;
    }
    let never = AtomicBool::new(false);
    let spec = job::SceneSpec { scene: path.to_string(), defines, allow_outside_uris: false };
    interruptible(py, None, &never, || -> job::Result<Scene> {
        let fe = Collect::default();
        let loaded = job::load(&spec, &fe)?;
        let mut desc = loaded.desc;
        job::set_film(&mut desc, resolution, &spec.scene)?;
        let hints = desc.hints.clone();
        let mut warnings = loaded.warnings;
        let scene = job::prepare(desc, kind, &spec.scene, &fe, &mut warnings)?;
        Ok(Scene { scene, spec: spec.scene.clone(), hints, warnings, notes: loaded.notes })
    })?
    .map_err(error)
}

/// What a call says of the integrator's settings besides its name: `photons=` and
/// `max_depth=` are shortcuts for their keys, as the CLI's flags are.
fn request(
    integrator: Option<&str>,
    seed: u64,
    photons: Option<u64>,
    max_depth: Option<i32>,
    sets: Vec<String>,
    file: Option<PathBuf>,
) -> PyResult<IntegratorRequest> {
    job::check_max_depth(max_depth, "max_depth").map_err(error)?;
    let mut flags = Vec::new();
    if let Some(n) = photons {
        flags.push(FlagSetting { flag: "photons=", only: None, keys: vec![keys::PHOTON_COUNT.into()], value: json!(n), at_most: false });
    }
    if let Some(d) = max_depth {
        flags.push(FlagSetting { flag: "max_depth=", only: None, keys: vec![keys::MAX_DEPTH.into()], value: json!(d), at_most: false });
    }
    Ok(IntegratorRequest { integrator: integrator.map(String::from), settings_file: file, flags, sets, seed, spelling: Spelling::Python })
}

/// Render; returns the pixels (row-major rgb f32, `height*width*3`) and the stats as JSON (the
/// CLI's `OUT.json`).
#[pyfunction]
#[pyo3(signature = (scene, integrator = None, spp = None, seed = 0, max_depth = None, photons = None, sets = Vec::new(),
                    settings_file = None, cache = None, allow_stale_cache = false, threads = None, time_budget = None))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    scene: &Scene,
    integrator: Option<&str>,
    spp: Option<u32>,
    seed: u64,
    max_depth: Option<i32>,
    photons: Option<u64>,
    sets: Vec<String>,
    settings_file: Option<PathBuf>,
    cache: Option<PathBuf>,
    allow_stale_cache: bool,
    threads: Option<usize>,
    time_budget: Option<f64>,
) -> PyResult<(Bound<'py, PyArray1<f32>>, String)> {
    let spp = spp.or(scene.hints.spp).unwrap_or(64);
    if spp == 0 {
        return Err(error("spp must be at least 1"));
    }
    if let Some(b) = time_budget.filter(|b| !(b.is_finite() && *b > 0.0)) {
        return Err(error(format!("time_budget must be a positive number of seconds, got {b}")));
    }
    let req = request(integrator, seed, photons, max_depth, sets, settings_file)?;
    let cancel = AtomicBool::new(false);
    let out = interruptible(py, threads, &cancel, || -> job::Result<(Image, String)> {
        let fe = Collect::default();
        let mut warnings = scene.warnings.clone();
        let cache = cache.as_deref().map(|p| job::read_cache(p, allow_stale_cache)).transpose()?;
        let settings = job::resolve_settings(&req, &scene.hints, cache.as_ref(), &fe, &mut warnings)?;
        let chosen = req.integrator.is_some() || req.settings_file.is_some() || cache.is_some();
        job::scene_integrator_remark(&scene.hints, &scene.spec, settings.name(), chosen, &fe, &mut warnings);
        let from_cache = cache.is_some();
        let made = job::make_integrator(&settings, &scene.scene, &scene.scene, cache, &scene.spec, &fe, &mut warnings)?;
        let rs = RenderSettings { spp, seed, time_budget_s: time_budget, ..Default::default() };
        let (img, rstats) = job::render_image(&scene.scene, &made.integrator, &rs, &fe, &cancel);
        let threads = rayon::current_num_threads();
        let file = stats::StatsFile {
            octolux_version: env!("CARGO_PKG_VERSION"),
            command_line: vec![],
            scene: &scene.spec,
            integrator: made.integrator.name(),
            integrator_settings: serde_json::to_value(&settings).map_err(|e| job::JobError(e.to_string()))?,
            backend: scene.scene.backend_name(),
            kernels: octolux::cpu::level().name(),
            threads,
            triangles: scene.scene.triangle_count(),
            seed,
            render_settings: rs,
            timings: stats::Timings { build_s: made.build_s, render_s: rstats.render_s, ..Default::default() },
            samples_per_second: rstats.samples_per_second,
            rays_per_second: rstats.rays_per_second,
            render: &rstats,
            cache_query_share: stats::query_share(&rstats, threads),
            build: job::build_report(&made.integrator, from_cache),
            render_report: made.integrator.render_report(),
            warnings: &warnings,
            partial: rstats.interrupted.then(|| stats::Partial::interrupted(&rstats)),
            cache: made.cache,
            frame: None,
            insert: None,
        };
        Ok((img, serde_json::to_string(&file).map_err(|e| job::JobError(e.to_string()))?))
    })?;
    let (img, stats) = out.map_err(error)?;
    let pixels: Vec<f32> = img.data.iter().flat_map(|c| [c.x, c.y, c.z]).collect();
    Ok((PyArray1::from_vec(py, pixels), stats))
}

/// Bake the `octree` integrator's lighting of `scene` into the cache file `output` (its JSON
/// report beside it); returns the report as JSON.
#[pyfunction]
#[pyo3(signature = (scene, output, seed = 0, max_depth = None, photons = None, sets = Vec::new(), settings_file = None, threads = None, volume = false))]
#[allow(clippy::too_many_arguments)]
fn bake(
    py: Python<'_>,
    scene: &Scene,
    output: PathBuf,
    seed: u64,
    max_depth: Option<i32>,
    photons: Option<u64>,
    sets: Vec<String>,
    settings_file: Option<PathBuf>,
    threads: Option<usize>,
    volume: bool,
) -> PyResult<String> {
    let req = request(Some("octree"), seed, photons, max_depth, sets, settings_file)?;
    // a missing output folder is created, as `octolux bake` creates it, and removed again
    // (if still empty) when the bake fails
    let out = bake_into(py, scene, &output, req, threads, volume);
    if out.is_err() {
        octolux_io::files::remove_created_folders();
    } else {
        octolux_io::files::keep_created_folders();
    }
    out
}

fn bake_into(
    py: Python<'_>,
    scene: &Scene,
    output: &std::path::Path,
    req: IntegratorRequest,
    threads: Option<usize>,
    volume: bool,
) -> PyResult<String> {
    octolux_io::files::create_output_folder(output).map_err(error)?;
    octolux_io::files::check_output(output).map_err(error)?;
    let report_path = jbake::report_path(output).map_err(error)?;
    octolux_io::files::check_output(&report_path).map_err(error)?;
    let never = AtomicBool::new(false);
    let t0 = Instant::now();
    let report = interruptible(py, threads, &never, || -> job::Result<jbake::BakeReport> {
        let fe = Collect::default();
        let mut warnings = scene.warnings.clone();
        let settings = jbake::bake_settings(&req, &scene.hints, &fe, &mut warnings)?;
        let mut baked = jbake::bake(&scene.scene, &scene.spec, settings, volume, &fe)?;
        baked.add_front_end(&[], 0.0, 0.0, warnings);
        jbake::write(&baked, output, &report_path, t0, &fe)
    })?
    .map_err(error)?;
    serde_json::to_string(&report).map_err(error)
}

/// `octolux render` with the CLI's defaults, as a job: one image or the frames of a camera
/// path or of the scene's sensors, each written as EXR, PNG and JSON. Returns the EXR paths
/// and the warnings.
#[pyfunction]
#[pyo3(signature = (scene, output, defines = Vec::new(), resolution = None, backend = "auto", integrator = None, spp = None,
                    seed = 0, max_depth = None, photons = None, sets = Vec::new(), settings_file = None, cache = None,
                    allow_stale_cache = false, camera_path = None, sensors = false, frames = None, threads = None, time_budget = None))]
#[allow(clippy::too_many_arguments)]
fn render_to_files(
    py: Python<'_>,
    scene: String,
    output: PathBuf,
    defines: Vec<(String, String)>,
    resolution: Option<(u32, u32)>,
    backend: &str,
    integrator: Option<&str>,
    spp: Option<u32>,
    seed: u64,
    max_depth: Option<i32>,
    photons: Option<u64>,
    sets: Vec<String>,
    settings_file: Option<PathBuf>,
    cache: Option<PathBuf>,
    allow_stale_cache: bool,
    camera_path: Option<PathBuf>,
    sensors: bool,
    frames: Option<(u64, u64)>,
    threads: Option<usize>,
    time_budget: Option<f64>,
) -> PyResult<(Vec<PathBuf>, Vec<String>)> {
    if let Some((a, b)) = frames.filter(|&(a, b)| a == 0 || b < a) {
        return Err(error(format!("frame range {a}..{b}: frames count from 1 and B must not be below A")));
    }
    // max_depth is the job's own (checked and written as the CLI's --max-depth)
    let integrator = request(integrator, seed, photons, None, sets, settings_file)?;
    let render = job::RenderJob {
        scene: job::SceneSpec { scene, defines, allow_outside_uris: false },
        integrator,
        spp,
        resolution,
        max_depth,
        time_budget_s: time_budget,
        backend: self::backend(backend)?,
        reconstruction: Default::default(),
        sampler: Default::default(),
        cache,
        allow_stale_cache,
        cache_scene: None,
        camera_path,
        sensors,
        frames,
        insert: None,
        output,
        command_line: vec!["octolux.render_to_files".into()],
        warnings: vec![],
    };
    let cancel = AtomicBool::new(false);
    let fe = Collect::default();
    let outcome = interruptible(py, threads, &cancel, || job::run_render(&render, &fe, &cancel))?.map_err(error)?;
    let warnings = fe.warnings.into_inner().unwrap_or_else(|e| e.into_inner());
    match outcome {
        RenderOutcome::Done(written) => Ok((written, warnings)),
        RenderOutcome::Interrupted(msg) => Err(error(msg)),
    }
}

/// The frames of a camera path (or of the scene's sensors), as `render_to_files` counts them.
#[pyfunction]
#[pyo3(signature = (scene, defines = Vec::new(), camera_path = None, sensors = false))]
fn frame_count(
    py: Python<'_>,
    scene: String,
    defines: Vec<(String, String)>,
    camera_path: Option<PathBuf>,
    sensors: bool,
) -> PyResult<u64> {
    let never = AtomicBool::new(false);
    let spec = job::SceneSpec { scene, defines, allow_outside_uris: false };
    interruptible(py, None, &never, || job::frames::frame_count(&spec, camera_path.as_deref(), sensors, &Collect::default()))?
        .map_err(error)
}

/// Prepare an output image path (`OUT.exr`, with `OUT.png` and `OUT.json` beside it) by the
/// CLI's rule, before any work: a missing folder is created (as `octolux render` creates it),
/// then the folder must take a file, nothing but a regular file may be under the names, and
/// the name must end in `.exr`. A folder created for a path that is then refused is removed
/// again.
#[pyfunction]
fn check_output(path: PathBuf) -> PyResult<()> {
    let out =
        octolux_io::files::create_output_folder(&path).map_err(job::JobError).and_then(|_| job::output::Outputs::check(&path).map(|_| ()));
    if out.is_err() {
        octolux_io::files::remove_created_folders();
    }
    out.map_err(error)
}

/// Remove the output folders this process created that are still empty (a Dask job that
/// failed before its first frame was written).
#[pyfunction]
fn remove_created_folders() {
    octolux_io::files::remove_created_folders();
}

/// Forget the output folders created so far (a Dask job that succeeded): a later job's failure
/// in this process leaves them.
#[pyfunction]
fn keep_created_folders() {
    octolux_io::files::keep_created_folders();
}

fn to_image(a: &PyReadonlyArray3<'_, f32>, what: &str) -> PyResult<Image> {
    let shape = a.shape();
    if shape[2] != 3 {
        return Err(error(format!("{what}: expected an (H, W, 3) array, got {shape:?}")));
    }
    let v = a.as_array();
    let data =
        (0..shape[0]).flat_map(|y| (0..shape[1]).map(move |x| (y, x))).map(|(y, x)| Color::new(v[[y, x, 0]], v[[y, x, 1]], v[[y, x, 2]]));
    Ok(Image { width: shape[1] as u32, height: shape[0] as u32, data: data.collect() })
}

/// relMSE, RMSE and channel means of `image` against `reference` (both (H, W, 3) float32), as
/// JSON: the CLI's `octolux compare`.
#[pyfunction]
fn compare(image: PyReadonlyArray3<'_, f32>, reference: PyReadonlyArray3<'_, f32>) -> PyResult<String> {
    let (a, r) = (to_image(&image, "image")?, to_image(&reference, "reference")?);
    let mut bad = Vec::new();
    for (what, img) in [("the image", &a), ("the reference", &r)] {
        let n = img.data.iter().flat_map(|c| [c.x, c.y, c.z]).filter(|v| !v.is_finite()).count();
        if n > 0 {
            bad.push(format!("{what} holds {n} non-finite values (NaN or infinity)"));
        }
    }
    if !bad.is_empty() {
        return Err(error(format!("cannot compare: {}", bad.join("; "))));
    }
    let e = octolux::metrics::compare(&a, &r)
        .ok_or_else(|| error(format!("the image is {}x{} but the reference is {}x{}", a.width, a.height, r.width, r.height)))?;
    serde_json::to_string(&e).map_err(error)
}

/// Read an EXR file: (pixels, width, height).
#[pyfunction]
fn read_exr<'py>(py: Python<'py>, path: PathBuf) -> PyResult<(Bound<'py, PyArray1<f32>>, u32, u32)> {
    let img = octolux_io::image_io::read_exr(&path).map_err(error)?;
    let pixels: Vec<f32> = img.data.iter().flat_map(|c| [c.x, c.y, c.z]).collect();
    Ok((PyArray1::from_vec(py, pixels), img.width, img.height))
}

/// Write an (H, W, 3) float32 array as an EXR file (staged, then renamed).
#[pyfunction]
fn write_exr(path: PathBuf, image: PyReadonlyArray3<'_, f32>) -> PyResult<()> {
    let img = to_image(&image, "image")?;
    octolux_io::image_io::write_exr(&path, &img).map_err(error)
}

/// The built-in scenes' names.
#[pyfunction]
fn builtin_scenes() -> Vec<&'static str> {
    octolux_io::builtin::NAMES.to_vec()
}

#[pymodule]
fn _octolux(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("OctoluxError", m.py().get_type::<OctoluxError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("INTEGRATORS", octolux::integrators::IntegratorSettings::NAMES.to_vec())?;
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(bake, m)?)?;
    m.add_function(wrap_pyfunction!(render_to_files, m)?)?;
    m.add_function(wrap_pyfunction!(frame_count, m)?)?;
    m.add_function(wrap_pyfunction!(check_output, m)?)?;
    m.add_function(wrap_pyfunction!(remove_created_folders, m)?)?;
    m.add_function(wrap_pyfunction!(keep_created_folders, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(builtin_scenes, m)?)?;
    Ok(())
}
