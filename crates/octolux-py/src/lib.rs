//! `octolux._octolux`: the Python bindings (issue 15, item 1), wrapped by the pure-Python
//! package `octolux` (`python/octolux/__init__.py`), which turns settings dicts into `--set`
//! writes, stats JSON into dicts and scene warnings into Python warnings.
//!
//! The bindings take the CLI's paths, not copies of them: scenes load through
//! `octolux_io::load_scene`, settings resolve through `octolux_io::settings::resolve` (so a bad
//! key raises the CLI's message), integrators build through `octolux::integrators::build`, and
//! lighting caches read, check and write through `octolux_io::cache`.
//!
//! Long work (loading, the photon pass, rendering) runs on a worker thread while the calling
//! thread waits with the GIL released, checking for signals every 20 ms: Ctrl-C stops a render
//! at its next tile (through `render_cancellable`'s flag) and raises `KeyboardInterrupt`; a
//! photon pass or a load is not cut short, the interrupt is raised when it ends.

use numpy::{PyArray1, PyReadonlyArray3, PyUntypedArrayMethods};
use octolux::accel::BackendKind;
use octolux::image::Image;
use octolux::integrators::{build, Integrator, IntegratorSettings};
use octolux::math::Color;
use octolux::render::{render_cancellable, RenderSettings};
use octolux_io::cache::{self, CacheFile, CacheInfo};
use octolux_io::settings::{self, keys, SettingsInput};
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
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
/// `-D name=value`), or an OBJ/PLY mesh.
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
    let spec = path.to_string();
    interruptible(py, None, &never, || -> Result<Scene, String> {
        let loaded = octolux_io::load_scene(&spec, &defines).map_err(|e| format!("cannot load scene '{spec}': {e}"))?;
        let mut desc = loaded.desc;
        if let Some((w, h)) = resolution {
            desc.film.width = w;
            desc.film.height = h;
        }
        octolux::budget::check_film(desc.film.width as u64, desc.film.height as u64).map_err(|e| format!("scene '{spec}': {e}"))?;
        let hints = desc.hints.clone();
        let scene = octolux::scene::Scene::prepare(desc, kind).map_err(|e| format!("cannot prepare scene '{spec}': {e}"))?;
        let mut warnings = loaded.warnings;
        warnings.extend(scene.light_warning().map(String::from));
        Ok(Scene { scene, spec: spec.clone(), hints, warnings, notes: loaded.notes })
    })?
    .map_err(error)
}

/// What a call says of the integrator's settings besides its name.
struct Layers<'a> {
    seed: u64,
    photons: Option<u64>,
    max_depth: Option<i32>,
    /// `KEY=VALUE` writes, as `--set` takes them.
    sets: &'a [String],
    file: Option<&'a Path>,
}

/// The integrator settings of one call, through the CLI's resolution.
fn resolve(scene: &Scene, integrator: Option<&str>, base: Option<Value>, l: &Layers) -> PyResult<(IntegratorSettings, Vec<String>)> {
    let Layers { seed, photons, max_depth, sets, file: settings_file } = *l;
    let mut sets = sets.to_vec();
    if let Some(d) = max_depth {
        if d < -1 {
            return Err(error(format!("max_depth must be -1 (unbounded) or at least 0, got {d}")));
        }
        sets.insert(0, format!("{}={d}", keys::MAX_DEPTH));
    }
    if let Some(n) = photons {
        sets.insert(0, format!("{}={n}", keys::PHOTON_COUNT));
    }
    let derived = if base.is_some() {
        vec![]
    } else {
        vec![(keys::MAX_DEPTH, json!(scene.hints.max_depth.unwrap_or(-1))), (keys::PHOTON_SEED, json!(seed))]
    };
    let r =
        settings::resolve(&SettingsInput { integrator, base, derived, file: settings_file, flags: vec![], sets: &sets }).map_err(error)?;
    if let Some(n) = settings::get(&r.settings, keys::PHOTON_COUNT).and_then(|v| v.as_u64()) {
        octolux::budget::check_photons(n).map_err(|e| error(format!("the photon count (photons.photons): {e}")))?;
    }
    Ok((r.settings, r.warnings))
}

/// Render; returns the pixels (row-major rgb f32, `height*width*3`) and the stats as JSON.
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
    let cancel = AtomicBool::new(false);
    let layers = Layers { seed, photons, max_depth, sets: &sets, file: settings_file.as_deref() };
    let t_build = Instant::now();
    let (built, settings, mut warnings, report) = match &cache {
        Some(path) => {
            if let Some(n) = integrator.filter(|&n| n != "octree") {
                return Err(error(format!("cache holds the octree integrator's lighting; integrator {n} cannot render from it")));
            }
            let c = cache::read(path).map_err(error)?;
            let base = settings::cache_base(&c).map_err(error)?;
            let (s, mut warnings) = resolve(scene, Some("octree"), Some(base), &layers)?;
            settings::check_cache_settings(path, &c, &s).map_err(error)?;
            let fp = scene.scene.lighting_fingerprint();
            warnings.extend(cache::check_fingerprint(path, &c, &fp, &scene.spec, allow_stale_cache).map_err(error)?);
            let report = json!({ "file": path.display().to_string(), "file_bytes": c.file_bytes, "baked_from": c.info });
            let mut integrator = c.integrator;
            // only the render-time keys may differ: check_cache_settings
            if let (Integrator::Octree(o), IntegratorSettings::Octree(s)) = (&mut integrator, &s) {
                o.settings = s.clone();
            }
            integrator.prepare(&scene.scene);
            (integrator, s, warnings, report)
        }
        None => {
            let (s, warnings) = resolve(scene, integrator, None, &layers)?;
            let built = interruptible(py, threads, &cancel, || build(&s, &scene.scene))?.map_err(error)?;
            (built, s, warnings, Value::Null)
        }
    };
    let build_s = t_build.elapsed().as_secs_f64();
    let chosen = integrator.is_some() || cache.is_some() || settings_file.is_some();
    if let Some(settings::IntegratorRemark::Warning(w)) =
        settings::scene_integrator_remark(scene.hints.integrator.as_deref(), &scene.spec, settings.name(), chosen)
    {
        warnings.push(w);
    }
    let rs = RenderSettings { spp, seed, time_budget_s: time_budget, ..Default::default() };
    let (img, stats) = interruptible(py, threads, &cancel, || render_cancellable(&scene.scene, &built, &rs, &|_, _| {}, Some(&cancel)))?;
    let stats = json!({
        "integrator": settings.name(),
        "settings": settings,
        "build_s": build_s,
        "render": stats,
        "cache": report,
        "warnings": warnings,
    });
    let pixels: Vec<f32> = img.data.iter().flat_map(|c| [c.x, c.y, c.z]).collect();
    Ok((PyArray1::from_vec(py, pixels), stats.to_string()))
}

/// Bake the `octree` integrator's lighting of `scene` into the cache file `output`; returns a
/// JSON summary (bytes on disk, valid leaves, timings).
#[pyfunction]
#[pyo3(signature = (scene, output, seed = 0, max_depth = None, photons = None, sets = Vec::new(), settings_file = None, threads = None))]
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
) -> PyResult<String> {
    let layers = Layers { seed, photons, max_depth, sets: &sets, file: settings_file.as_deref() };
    let (s, warnings) = resolve(scene, Some("octree"), None, &layers)?;
    let IntegratorSettings::Octree(os) = s else {
        return Err(error("bake builds the octree integrator's lighting; the settings name another integrator"));
    };
    let never = AtomicBool::new(false);
    let t = Instant::now();
    let o = interruptible(py, threads, &never, || octolux::integrators::octree::OctreeIntegrator::build(&scene.scene, os))?
        .map_err(|e| error(format!("cannot build the octrees: {e}")))?;
    let bake_s = t.elapsed().as_secs_f64();
    let info =
        CacheInfo { octolux_version: env!("CARGO_PKG_VERSION").into(), scene: scene.spec.clone(), backend: scene.scene.backend_name() };
    let valid = o.stats.global.valid_leaves + o.stats.caustic.as_ref().map_or(0, |c| c.valid_leaves);
    let memory = o.stats.bytes;
    let bytes = cache::encode(&CacheFile { fingerprint: scene.scene.lighting_fingerprint(), info, parts: o.to_parts() });
    octolux_io::image_io::write_bytes_atomically(&output, &bytes).map_err(error)?;
    Ok(json!({ "file": output.display().to_string(), "file_bytes": bytes.len(), "valid_leaves": valid, "memory_bytes": memory,
               "bake_s": bake_s, "warnings": warnings })
    .to_string())
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
    m.add("INTEGRATORS", IntegratorSettings::NAMES.to_vec())?;
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(bake, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(builtin_scenes, m)?)?;
    Ok(())
}
