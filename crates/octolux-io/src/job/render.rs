//! `octolux render` as a job (the CLI's flags, Python's `render_to_files`): every input and
//! output checked before any long work, the integrator made or read from a cache, an inserted
//! object placed (and re-baked) per frame, each image written as its output set.

use super::*;
use octolux::scene::Addition;

/// Everything `octolux render` takes (the CLI's flags; Python's `render_to_files`).
#[derive(Clone, Debug)]
pub struct RenderJob {
    pub scene: SceneSpec,
    pub integrator: IntegratorRequest,
    /// Samples per pixel (default: the scene's sampler, else 64); per pass with a time budget.
    pub spp: Option<u32>,
    /// Image size (default: the scene's film).
    pub resolution: Option<(u32, u32)>,
    /// Mitsuba's `max_depth` (default: the scene's, else -1).
    pub max_depth: Option<i32>,
    pub time_budget_s: Option<f64>,
    pub backend: BackendKind,
    pub reconstruction: Reconstruction,
    pub sampler: SamplerKind,
    /// A lighting cache written by a bake.
    pub cache: Option<PathBuf>,
    pub allow_stale_cache: bool,
    /// Trace the photons and build the cache in this scene instead (same defines).
    pub cache_scene: Option<String>,
    pub camera_path: Option<PathBuf>,
    pub sensors: bool,
    /// Frames A to B (from 1, both included).
    pub frames: Option<(u64, u64)>,
    pub insert: Option<insert::InsertRequest>,
    /// `OUT.exr` (`.png` and `.json` beside it; `OUT_0001.exr`, ... for frames).
    pub output: PathBuf,
    /// As `OUT.json` records it.
    pub command_line: Vec<String>,
    /// Warnings the front end met before the job (its flags), kept in `OUT.json`.
    pub warnings: Vec<String>,
}

/// How a render job ended.
#[derive(Debug)]
pub enum RenderOutcome {
    /// Every image written: the EXR paths.
    Done(Vec<PathBuf>),
    /// Stopped by the cancel flag; the message says what was written.
    Interrupted(String),
}

/// The whole of `octolux render`: every input and output checked before any long work, then
/// the integrator, then one image or each frame written as its output set.
/// A missing output folder is created (and removed again, if still empty, when the job fails
/// or is interrupted before writing anything).
pub fn run_render(job: &RenderJob, fe: &dyn Frontend, cancel: &AtomicBool) -> Result<RenderOutcome> {
    let out = render_job(job, fe, cancel);
    if matches!(out, Ok(RenderOutcome::Done(_))) {
        crate::files::keep_created_folders();
    } else {
        crate::files::remove_created_folders();
    }
    out
}

fn render_job(job: &RenderJob, fe: &dyn Frontend, cancel: &AtomicBool) -> Result<RenderOutcome> {
    let t0 = Instant::now();
    check_max_depth(job.max_depth, "--max-depth")?;
    if let Some(b) = job.time_budget_s {
        if !(b.is_finite() && b > 0.0) {
            bail!("--time-budget must be a positive number of seconds, got {b}");
        }
    }
    if job.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    // the film the flags ask for, before reading the scene
    if let Some((w, h)) = job.resolution {
        budget::check_film(w as u64, h as u64).context("--resolution")?;
    }
    if job.cache.is_some() {
        if let Some(n) = job.integrator.integrator.as_deref().filter(|&n| n != "octree") {
            bail!("--cache holds the octree integrator's lighting; --integrator {n} cannot render from it");
        }
        if job.cache_scene.is_some() {
            bail!("--cache and --cache-scene exclude each other: the cache's lighting was baked in its own scene");
        }
    }
    let ins = job.insert.as_ref();
    let inputs =
        [Some(Path::new(&job.scene.scene)), job.integrator.settings_file.as_deref(), job.cache.as_deref(), job.camera_path.as_deref()]
            .into_iter()
            .chain([ins.map(|i| Path::new(&i.file)), ins.and_then(|i| i.path.as_deref())]);
    for p in inputs.flatten() {
        crate::files::note_input(p);
    }
    output_folder(&job.output, fe)?;
    let outputs = output::Outputs::check(&job.output)?;
    // a lighting cache is read and checked before the scene (which may take long to load)
    let cache = job.cache.as_deref().map(|p| read_cache(p, job.allow_stale_cache)).transpose()?;
    let loaded = load(&job.scene, fe)?;
    let load_s = t0.elapsed().as_secs_f64();
    let insertion = job.insert.as_ref().map(|r| insert::read(r, fe)).transpose()?;
    let plan = frames::plan(
        &frames::PlanRequest {
            scene: &job.scene.scene,
            camera_path: job.camera_path.as_deref(),
            sensors: job.sensors,
            insert_path: ins.and_then(|i| i.path.as_deref()),
            frames: job.frames,
        },
        &loaded.sensors,
        &loaded.desc.camera,
        insertion.as_ref().and_then(|i| i.path.as_ref()),
    )?;
    // one job per image: the single one, or each frame of the plan (every output checked now)
    let images: Vec<(output::Outputs, Option<(frames::Frame, frames::FrameInfo)>)> = match &plan {
        None => vec![(outputs, None)],
        Some(p) => {
            let mut v = Vec::with_capacity(p.frames.len());
            for f in &p.frames {
                let out = output::Outputs::check(&output::frame_path(&job.output, f.index, p.count))?;
                let info = frames::FrameInfo { index: f.index, count: p.count, time_s: f.time_s, source: p.source.clone() };
                v.push((out, Some((f.clone(), info))));
            }
            v
        }
    };
    let mut warnings = job.warnings.clone();
    warnings.extend(loaded.warnings.iter().cloned());
    let mut desc = loaded.desc;
    set_film(&mut desc, job.resolution, &job.scene.scene)?;
    // values that are valid but leave nothing to see
    let bounds = desc.bounds();
    let cams = images.iter().filter_map(|(_, f)| f.as_ref().map(|(f, _)| &f.camera)).chain(plan.is_none().then_some(&desc.camera));
    let mut camera_warnings: Vec<String> = Vec::new();
    for c in cams {
        if let Some(w) = c.near_clip_warning(&bounds).filter(|w| !camera_warnings.contains(w)) {
            fe.warning(&w);
            camera_warnings.push(w);
        }
    }
    warnings.extend(camera_warnings);
    // the scene without the inserted object: the lighting's (its fingerprint, its photons)
    let base_desc = insertion.as_ref().map(|_| desc.clone());
    let spp = job.spp.or(desc.hints.spp).unwrap_or(64);

    // the integrator's settings, checked before any long work
    let mut req = job.integrator.clone();
    req.flags.extend(job.max_depth.map(settings::max_depth_flag));
    let integrator_settings = resolve_settings(&req, &desc.hints, cache.as_ref(), fe, &mut warnings)?;
    let name = integrator_settings.name();
    if let (Some(ins), Some(c), IntegratorSettings::Octree(s)) = (&insertion, &cache, &integrator_settings) {
        if let (insert::InsertLight::Volume, Integrator::Octree(o)) = (ins.light, &c.cache.integrator) {
            if let Some(why) = o.missing_leak_samples(s, true) {
                bail!("lighting cache {} with --insert {} --insert-light volume: {why}", c.path.display(), ins.file);
            }
        }
    }
    if let (Some(ins), Some(_), "octree") = (&insertion, &job.cache_scene, name) {
        if ins.light == insert::InsertLight::Rebake {
            bail!("--insert {} re-bakes the photons of the rendered scene, not of --cache-scene: add --insert-light volume", ins.file);
        }
    }
    let chosen = job.integrator.integrator.is_some() || job.integrator.settings_file.is_some() || cache.is_some();
    scene_integrator_remark(&desc.hints, &job.scene.scene, name, chosen, fe, &mut warnings);
    let traces = settings::get(&integrator_settings, keys::PHOTON_COUNT).is_some();

    let t1 = Instant::now();
    let mut scene = prepare(desc, job.backend, &job.scene.scene, fe, &mut warnings)?;
    // the scene the photons are traced in (the rendered one unless --cache-scene says otherwise)
    let cache_scene = match &job.cache_scene {
        Some(spec) if traces => {
            let other = load(&SceneSpec { scene: spec.clone(), ..job.scene.clone() }, fe)?;
            Some(Scene::prepare(other.desc, job.backend).with_context(|| format!("cannot prepare cache scene '{spec}'"))?)
        }
        Some(_) => bail!("--cache-scene needs a cache integrator (octree, ward, christensen, photonmap), not {name}"),
        None => None,
    };
    let prepare_s = t1.elapsed().as_secs_f64();
    // every input is read now (the scene's meshes and textures too): no output may be one
    for (out, _) in &images {
        out.recheck()?;
    }
    let threads = rayon::current_num_threads();
    let from_cache = cache.is_some();
    let made =
        make_integrator(&integrator_settings, &scene, cache_scene.as_ref().unwrap_or(&scene), cache, &job.scene.scene, fe, &mut warnings)?;
    let mut integrator = made.integrator;
    if cache_scene.is_some() {
        // the photons were traced in the cache scene, the rays of the leak test run here
        integrator.prepare(&scene);
    }
    let t_fill = Instant::now();
    // the photon pass kept path by path, for the inserted object's re-bake per frame
    let mut rebaking = None;
    if let (Some(ins), Integrator::Octree(o)) = (&insertion, &mut integrator) {
        if ins.light == insert::InsertLight::Rebake {
            rebaking = Some(insert::Rebaking::start(o, &scene, ins, fe)?);
        } else if o.volume.is_none() {
            let st = o.fill_atmosphere(&scene);
            fe.info(&format!("octree: volumetric values for --insert {}: {}", ins.file, st.summary()));
        }
    }
    let build_s = made.build_s + t_fill.elapsed().as_secs_f64();
    let build = build_report(&integrator, from_cache);
    match &integrator {
        Integrator::Octree(o) => stats::octree_stats_lines(&o.stats, from_cache).iter().for_each(|l| fe.info(l)),
        _ if !build.is_null() => fe.info(&format!("{name}: {}", stats::summary(&build))),
        _ => {}
    }
    let tris = scene.triangle_count();
    fe.info(&format!(
        "octolux: {} ({tris} triangle{}), {}x{}, {} spp, integrator {}, backend {}{}, {} threads",
        job.scene.scene,
        if tris == 1 { "" } else { "s" },
        scene.film.width,
        scene.film.height,
        spp,
        integrator.name(),
        scene.backend_name(),
        scene.backend_choice().map(|c| format!(" ({c})")).unwrap_or_default(),
        threads
    ));
    if let Some(view) = settings::get(&integrator_settings, "view").filter(|v| v != "render") {
        fe.info(&format!("{name}: view {view}"));
    }
    if let Some(p) = &plan {
        fe.info(&format!("{}: rendering frames {}..{} of {}", p.source, p.frames[0].index, p.frames[p.frames.len() - 1].index, p.count));
    }
    let render_settings = RenderSettings {
        spp,
        seed: job.integrator.seed,
        time_budget_s: job.time_budget_s,
        reconstruction: job.reconstruction,
        sampler: job.sampler,
        ..Default::default()
    };

    // the frames written so far (for the message of an interrupt)
    let mut written: Vec<PathBuf> = Vec::new();
    // the scene without the inserted object, once a frame has one: each frame's scene shares
    // its intersection structure and builds one over the object alone
    let mut base_scene: Option<Scene> = None;
    for (outputs, frame) in images {
        let t_frame = Instant::now();
        let mut placed = None;
        let mut rebake_report = None;
        if let (Some(ins), Some(base)) = (&insertion, &base_desc) {
            let m = ins.transform_at(frame.as_ref().and_then(|(f, _)| f.time_s));
            let shapes = ins.placed_shapes(base.materials.len() as u32, &m);
            let add = Addition { materials: ins.materials(), shapes: &shapes };
            let framed = Scene::prepare_adding(base, base_scene.as_ref().unwrap_or(&scene), add, job.backend)
                .with_context(|| format!("cannot prepare scene '{}' with the inserted object {}", job.scene.scene, ins.file))?;
            let before = std::mem::replace(&mut scene, framed);
            base_scene.get_or_insert(before);
            let inserted = ins.inserted(base.shapes.len(), &m);
            placed = Some((m, inserted.shapes.clone()));
            if let Integrator::Octree(o) = &mut integrator {
                match &mut rebaking {
                    // the object is part of the photon solution: shaded as any surface
                    Some(r) => rebake_report = Some(r.frame(o, &scene, ins, &m, inserted.shapes.clone(), fe)?),
                    None => o.inserted = inserted,
                }
            }
        }
        if let Some((f, _)) = &frame {
            scene.camera = Camera::new(&f.camera, scene.film.width, scene.film.height);
        }
        let insert_report = match (&insertion, &placed) {
            (Some(ins), Some((m, shapes))) => Some(insert::report(ins, &scene, m, shapes, rebake_report.as_ref())),
            _ => None,
        };
        let cpu0 = super::cpu_clock::process_cpu_s();
        let (image, rstats) = render_image(&scene, &integrator, &render_settings, fe, cancel);
        let render_cpu_s = cpu0.zip(super::cpu_clock::process_cpu_s()).map(|(a, b)| b - a);
        if rstats.interrupted && rstats.passes == 0 {
            let msg = match (&frame, written.first(), written.last()) {
                (Some((_, info)), Some(first), Some(last)) => format!(
                    "octolux: interrupted during frame {} before its first pass was complete: nothing written for it; \
                     the {} frames before it are complete ({} to {})",
                    info.index,
                    written.len(),
                    first.display(),
                    last.display()
                ),
                _ => "octolux: interrupted before the first pass was complete; nothing written".to_string(),
            };
            return Ok(RenderOutcome::Interrupted(msg));
        }
        let t2 = Instant::now();
        let mut file = stats::StatsFile {
            octolux_version: env!("CARGO_PKG_VERSION"),
            command_line: job.command_line.clone(),
            scene: &job.scene.scene,
            integrator: integrator.name(),
            integrator_settings: serde_json::to_value(&integrator_settings).context("the settings")?,
            backend: scene.backend_name(),
            kernels: octolux::cpu::level().name(),
            threads,
            triangles: scene.triangle_count(),
            seed: job.integrator.seed,
            render_settings,
            timings: stats::Timings { load_s, prepare_s, build_s, render_s: rstats.render_s, render_cpu_s, write_s: 0.0, total_s: 0.0 },
            samples_per_second: rstats.samples_per_second,
            rays_per_second: rstats.rays_per_second,
            render: &rstats,
            cache_query_share: stats::query_share(&rstats, threads),
            build: build.clone(),
            render_report: integrator.render_report(),
            warnings: &warnings,
            partial: rstats.interrupted.then(|| stats::Partial::interrupted(&rstats)),
            cache: made.cache.clone(),
            frame: frame.as_ref().map(|(_, info)| info.clone()),
            insert: insert_report,
        };
        // the JSON's own write time is not in it; the images' is
        outputs.write(&image, || {
            file.timings.write_s = t2.elapsed().as_secs_f64();
            file.timings.total_s = if frame.is_some() { t_frame.elapsed().as_secs_f64() } else { t0.elapsed().as_secs_f64() };
            serde_json::to_string_pretty(&file).map_err(|e| JobError(e.to_string()))
        })?;
        written.push(outputs.exr.clone());
        let (png, json) = (&outputs.png, &outputs.json);
        if rstats.interrupted {
            return Ok(RenderOutcome::Interrupted(format!(
                "octolux: interrupted after {} passes ({} spp); wrote the partial image to {}, {}, {}",
                rstats.passes,
                rstats.spp,
                outputs.exr.display(),
                png.display(),
                json.display()
            )));
        }
        fe.info(&format!(
            "rendered {} spp in {:.2} s: {:.3} M samples/s, {:.2} M rays/s -> {}, {}, {}",
            rstats.spp,
            rstats.render_s,
            rstats.samples_per_second * 1e-6,
            rstats.rays_per_second * 1e-6,
            outputs.exr.display(),
            png.display(),
            json.display()
        ));
    }
    Ok(RenderOutcome::Done(written))
}
