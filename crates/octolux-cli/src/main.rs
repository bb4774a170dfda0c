//! The `octolux` command-line renderer.
//!
//! `octolux render [SCENE] ...` renders a built-in scene (default `cornell-box`), a Mitsuba XML
//! file, or an OBJ/PLY mesh, and writes `OUT.exr`, `OUT.png` and `OUT.json` (statistics).
//! `octolux export SCENE -o scene.xml` writes the scene as Mitsuba 3 XML (meshes as PLY).
//! `octolux bake SCENE -o lighting.oxc` writes the `octree` integrator's lighting, which
//! `render --cache` renders from, for one image or the frames of `--camera-path` / `--sensors`
//! (docs/baking.md); `octolux flicker` measures how such frames flicker.
//!
//! Rooms: [`args`] (the command line), [`settings`] (flags, `--settings` and `--set` merged
//! into the library's integrator settings), [`stats`] (`OUT.json` and the build log),
//! [`output`] (the output set: checked first, written through staged files, renamed JSON last),
//! [`interrupt`] (SIGINT/SIGTERM: a partial render is written, a second signal exits),
//! [`bake`] (`bake`, and the checks of `render --cache`), [`frames`] (camera paths, sensors),
//! [`report`] (`report`: the HTML comparison page), [`flicker`] (the flicker measure of a frame
//! folder), [`insert`] (`--insert`: an object added to baked lighting, moved per frame).
//!
//! Hostile input (issue 12): sizes from the command line or the scene (film, photons) are
//! checked against the memory budget ([`octolux::budget`]) and the output folder is checked
//! before any long work; `compare` refuses images holding non-finite values.

mod args;
mod bake;
mod flicker;
mod frames;
mod insert;
mod interrupt;
mod output;
mod report;
mod settings;
mod stats;

use anyhow::{bail, Context, Result};
use args::{keys, BackendArg, Cli, Command, ExportArgs, ReconstructionArg, RenderArgs, SamplerArg, SceneArgs};
use clap::Parser;
use frames::FrameInfo;
use indicatif::{ProgressBar, ProgressStyle};
use octolux::accel::BackendKind;
use octolux::budget;
use octolux::film::Reconstruction;
use octolux::integrators::{build, Integrator, IntegratorSettings};
use octolux::render::{render_cancellable, RenderSettings};
use octolux::sampling::SamplerKind;
use octolux::scene::camera::Camera;
use octolux::scene::Scene;
use serde_json::json;
use settings::SettingsInput;
use stats::{StatsFile, Timings};
use std::path::Path;
use std::time::Instant;

fn parse_defines(defs: &[String]) -> Result<Vec<(String, String)>> {
    defs.iter()
        .map(|d| {
            let (k, v) = d.split_once('=').with_context(|| format!("-D {d}: expected NAME=VALUE"))?;
            Ok((k.trim().to_string(), v.trim().to_string()))
        })
        .collect()
}

/// Print a result on stdout; a closed pipe (`octolux compare a b | head -1`) ends the output
/// quietly instead of panicking as `println!` does.
pub(crate) fn print_out(text: &str) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e).context("cannot write to stdout"),
        _ => Ok(()),
    }
}

/// Remember the files a command names as its inputs: no output may replace one
/// ([`octolux_io::files`]; the loaders add every file they read).
pub(crate) fn note_inputs<'a>(paths: impl IntoIterator<Item = &'a Path>) {
    for p in paths {
        octolux_io::files::note_input(p);
    }
}

pub(crate) fn load(args: &SceneArgs) -> Result<octolux_io::LoadedScene> {
    let defines = parse_defines(&args.define)?;
    octolux_io::gltf_scene::allow_outside_uris(args.allow_outside_uris);
    let loaded = octolux_io::load_scene(&args.scene, &defines).with_context(|| format!("cannot load scene '{}'", args.scene))?;
    for n in &loaded.notes {
        eprintln!("note: {n}");
    }
    for w in &loaded.warnings {
        eprintln!("warning: {w}");
    }
    Ok(loaded)
}

pub(crate) fn backend_kind(b: BackendArg) -> BackendKind {
    match b {
        BackendArg::Auto => BackendKind::Auto,
        BackendArg::Embree => BackendKind::Embree,
        BackendArg::Bvh => BackendKind::Bvh,
    }
}

fn cmd_render(args: &RenderArgs) -> Result<std::process::ExitCode> {
    let t0 = Instant::now();
    let flag_warnings = bake::check_run_flags(args.threads, args.memory_limit.as_deref(), args.max_depth)?;
    args.octree.check_removed()?;
    if let Some(b) = args.time_budget {
        if !(b.is_finite() && b > 0.0) {
            bail!("--time-budget must be a positive number of seconds, got {b}");
        }
    }
    if args.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    // The film the flags ask for, before reading the scene.
    if let Some((w, h)) = args.resolution {
        budget::check_film(w as u64, h as u64).context("--resolution")?;
    }
    note_inputs(
        [Some(Path::new(&args.scene.scene)), args.settings.as_deref(), args.cache.as_deref(), args.camera_path.as_deref()]
            .into_iter()
            .chain([args.insert.as_deref().map(Path::new), args.insert_path.as_deref()])
            .flatten(),
    );
    let outputs = output::Outputs::check(&args.output)?;
    // A lighting cache is read and checked before the scene (which may take long to load).
    let cache = match &args.cache {
        Some(path) => {
            if let Some(n) = args.integrator.as_deref().filter(|&n| n != "octree") {
                bail!("--cache holds the octree integrator's lighting; --integrator {n} cannot render from it");
            }
            if args.octree.cache_scene.is_some() {
                bail!("--cache and --cache-scene exclude each other: the cache's lighting was baked in its own scene");
            }
            Some(bake::read_cache(path)?)
        }
        None => None,
    };
    interrupt::install()?;
    let loaded = load(&args.scene)?;
    let load_s = t0.elapsed().as_secs_f64();
    let insertion = insert::read(args)?;
    let plan = frames::plan(args, &loaded.sensors, &loaded.desc.camera, insertion.as_ref().and_then(|i| i.path.as_ref()))?;
    // One job per image: the single one, or each frame of the plan (every output checked now,
    // before any long work).
    let jobs: Vec<(output::Outputs, Option<(frames::Frame, FrameInfo)>)> = match &plan {
        None => vec![(outputs, None)],
        Some(p) => {
            let mut jobs = Vec::with_capacity(p.frames.len());
            for f in &p.frames {
                let out = output::Outputs::check(&output::frame_path(&args.output, f.index, p.count))?;
                let info = FrameInfo { index: f.index, count: p.count, time_s: f.time_s, source: p.source.clone() };
                jobs.push((out, Some((f.clone(), info))));
            }
            jobs
        }
    };
    let mut desc = loaded.desc;
    if let Some((w, h)) = args.resolution {
        desc.film.width = w;
        desc.film.height = h;
    }
    // values that are valid but leave nothing to see
    let mut camera_warnings: Vec<String> = Vec::new();
    let bounds = desc.bounds();
    let cams = jobs.iter().filter_map(|(_, f)| f.as_ref().map(|(f, _)| &f.camera)).chain(plan.is_none().then_some(&desc.camera));
    for c in cams {
        if let Some(w) = c.near_clip_warning(&bounds).filter(|w| !camera_warnings.contains(w)) {
            eprintln!("warning: {w}");
            camera_warnings.push(w);
        }
    }
    // the scene without the inserted object: the lighting's (its fingerprint, its photons)
    let base_desc = insertion.as_ref().map(|_| desc.clone());
    // The loader checks a film it reads; a built-in scene's, or one set in code, is checked here.
    budget::check_film(desc.film.width as u64, desc.film.height as u64).with_context(|| format!("scene '{}'", args.scene.scene))?;
    let spp = args.spp.or(desc.hints.spp).unwrap_or(64);

    // The integrator's settings, checked before any long work.
    let mut flags = args.octree.settings();
    flags.extend(args.max_depth.map(settings::max_depth_flag));
    let (integrator_name, base, derived) = match &cache {
        // the cache's settings are the defaults; nothing is derived from the scene or the seed
        Some((c, _)) => (Some("octree"), Some(settings::cache_base(c)?), vec![]),
        None => (
            args.integrator.as_deref(),
            None,
            vec![(keys::MAX_DEPTH, json!(desc.hints.max_depth.unwrap_or(-1))), (keys::PHOTON_SEED, json!(args.seed))],
        ),
    };
    let resolved = settings::resolve(&SettingsInput {
        integrator: integrator_name,
        base,
        derived,
        file: args.settings.as_deref(),
        flags,
        sets: &args.set,
    })?;
    let mut warnings = flag_warnings;
    warnings.extend(loaded.warnings);
    warnings.extend(camera_warnings);
    for w in &resolved.warnings {
        eprintln!("warning: {w}");
        warnings.push(w.clone());
    }
    let integrator_settings = resolved.settings;
    if let (Some((c, _)), Some(path)) = (&cache, &args.cache) {
        settings::check_cache_settings(path, c, &integrator_settings)?;
    }
    let name = integrator_settings.name();
    match settings::scene_integrator_remark(
        desc.hints.integrator.as_deref(),
        &args.scene.scene,
        name,
        args.integrator.is_some() || args.settings.is_some() || cache.is_some(),
    ) {
        Some(settings::IntegratorRemark::Note(n)) => eprintln!("note: {n}"),
        Some(settings::IntegratorRemark::Warning(w)) => {
            eprintln!("warning: {w}");
            warnings.push(w);
        }
        None => {}
    }
    let photon_count = settings::get(&integrator_settings, keys::PHOTON_COUNT).and_then(|v| v.as_u64());
    if let (Some(n), None) = (photon_count, &cache) {
        budget::check_photons(n).context("the photon count (--photons or photons.photons)")?;
    }

    let backend = backend_kind(args.backend);
    let t1 = Instant::now();
    let mut scene = Scene::prepare(desc, backend).with_context(|| format!("cannot prepare scene '{}'", args.scene.scene))?;
    if let Some(w) = scene.light_warning() {
        eprintln!("warning: {w}");
        warnings.push(w.to_string());
    }
    // The scene the photons are traced in (the rendered one unless --cache-scene says otherwise).
    let cache_scene = match &args.octree.cache_scene {
        Some(spec) if photon_count.is_some() => {
            let other = load(&SceneArgs {
                scene: spec.clone(),
                define: args.scene.define.clone(),
                allow_outside_uris: args.scene.allow_outside_uris,
            })?;
            Some(Scene::prepare(other.desc, backend).with_context(|| format!("cannot prepare cache scene '{spec}'"))?)
        }
        Some(_) => bail!("--cache-scene needs a cache integrator (octree, ward, christensen, photonmap), not {name}"),
        None => None,
    };
    let photon_scene = cache_scene.as_ref().unwrap_or(&scene);
    let prepare_s = t1.elapsed().as_secs_f64();
    let threads = rayon::current_num_threads();

    let t_build = Instant::now();
    let (mut integrator, cache_report) = match (cache, &args.cache) {
        (Some((c, load_s)), Some(path)) => {
            let stale =
                octolux_io::cache::check_fingerprint(path, &c, &scene.lighting_fingerprint(), &args.scene.scene, args.allow_stale_cache)
                    .map_err(anyhow::Error::msg)?;
            if let Some(w) = &stale {
                eprintln!("warning: {w}");
                warnings.push(w.clone());
            }
            let report = bake::report(path, &c, load_s, &stale);
            let mut integrator = c.integrator;
            // only the render-time keys may differ: check_cache_settings
            if let (Integrator::Octree(o), IntegratorSettings::Octree(s)) = (&mut integrator, &integrator_settings) {
                o.settings = s.clone();
            }
            integrator.prepare(&scene);
            if !args.quiet {
                eprintln!("octree: lighting from {} (read and checked in {load_s:.3} s, no photon traced)", path.display());
            }
            (integrator, Some(report))
        }
        _ => {
            if let (Some(n), false) = (photon_count, args.quiet) {
                eprintln!("{name}: tracing {n} photons and building the cache ...");
            }
            (build(&integrator_settings, photon_scene).context("cannot build the integrator")?, None)
        }
    };
    if let (Some(ins), Integrator::Octree(o)) = (&insertion, &mut integrator) {
        if !o.global.has_atmosphere() {
            let st = o.fill_atmosphere(&scene);
            if !args.quiet {
                eprintln!(
                    "octree: volumetric values for --insert {}: {} leaves filled, {} unreached, {} edges ({} blocked) in {:.3} s",
                    ins.file, st.filled_leaves, st.unreached_leaves, st.edges, st.blocked_edges, st.t_s
                );
            }
        }
    }
    let build_s = t_build.elapsed().as_secs_f64();
    let build_report = integrator.build_report();
    if !args.quiet {
        match &integrator {
            Integrator::Octree(o) => stats::print_octree_stats(&o.stats),
            _ if !build_report.is_null() => eprintln!("build: {build_report}"),
            _ => {}
        }
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
        if let Some(view) = settings::get(&integrator_settings, "view").filter(|v| v != "render") {
            eprintln!("{name}: view {view}");
        }
    }
    let reconstruction = match args.reconstruction {
        ReconstructionArg::Splat => Reconstruction::Splat,
        ReconstructionArg::Importance => Reconstruction::ImportanceSampled,
    };
    if let (Some(p), false) = (&plan, args.quiet) {
        eprintln!("{}: rendering frames {}..{} of {}", p.source, p.frames[0].index, p.frames[p.frames.len() - 1].index, p.count);
    }
    let sampler = match args.sampler {
        SamplerArg::Independent => SamplerKind::Independent,
        SamplerArg::Sobol => SamplerKind::Sobol,
    };
    let render_settings =
        RenderSettings { spp, seed: args.seed, time_budget_s: args.time_budget, reconstruction, sampler, ..Default::default() };

    // the frames written so far (for the message of an interrupt)
    let mut written: Vec<std::path::PathBuf> = Vec::new();
    for (outputs, frame) in jobs {
        let t_frame = Instant::now();
        let mut placed = None;
        if let (Some(ins), Some(base)) = (&insertion, &base_desc) {
            let m = ins.transform_at(frame.as_ref().and_then(|(f, _)| f.time_s));
            scene = Scene::prepare(ins.scene_desc(base, &m), backend)
                .with_context(|| format!("cannot prepare scene '{}' with the inserted object {}", args.scene.scene, ins.file))?;
            let inserted = ins.inserted(base.shapes.len(), &m);
            placed = Some((m, inserted.shapes.clone()));
            if let Integrator::Octree(o) = &mut integrator {
                o.inserted = inserted;
            }
        }
        if let Some((f, _)) = &frame {
            scene.camera = Camera::new(&f.camera, scene.film.width, scene.film.height);
        }
        let insert_report = match (&insertion, &placed) {
            (Some(ins), Some((m, shapes))) => Some(insert::report(ins, &scene, m, shapes)),
            _ => None,
        };
        let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new((scene.film.width as u64) * (scene.film.height as u64)) };
        bar.set_style(
            ProgressStyle::with_template("{spinner} rendering [{bar:40}] {percent}% {elapsed_precise} eta {eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        let progress = |done: u64, total: u64| {
            bar.set_length(total);
            bar.set_position(done.min(total));
        };
        interrupt::set_rendering(true);
        let (image, rstats) = render_cancellable(&scene, &integrator, &render_settings, &progress, Some(&interrupt::CANCEL));
        bar.finish_and_clear();
        if rstats.interrupted && rstats.passes == 0 {
            match (&frame, written.first(), written.last()) {
                (Some((_, info)), Some(first), Some(last)) => eprintln!(
                    "octolux: interrupted during frame {} before its first pass was complete: nothing written for it; \
                     the {} frames before it are complete ({} to {})",
                    info.index,
                    written.len(),
                    first.display(),
                    last.display()
                ),
                _ => eprintln!("octolux: interrupted before the first pass was complete; nothing written"),
            }
            return Ok(std::process::ExitCode::from(interrupt::EXIT_INTERRUPTED));
        }

        let t2 = Instant::now();
        let mut stats = StatsFile {
            octolux_version: env!("CARGO_PKG_VERSION"),
            command_line: std::env::args().collect(),
            scene: &args.scene.scene,
            integrator: integrator.name(),
            integrator_settings: serde_json::to_value(&integrator_settings)?,
            backend: scene.backend_name(),
            threads,
            triangles: scene.triangle_count(),
            seed: args.seed,
            render_settings,
            timings: Timings { load_s, prepare_s, build_s, render_s: rstats.render_s, write_s: 0.0, total_s: 0.0 },
            samples_per_second: rstats.samples_per_second,
            rays_per_second: rstats.rays_per_second,
            render: &rstats,
            cache_query_share: stats::query_share(&rstats, threads),
            build: build_report.clone(),
            render_report: integrator.render_report(),
            warnings: &warnings,
            partial: rstats.interrupted.then(|| stats::Partial::interrupted(&rstats)),
            cache: cache_report.clone(),
            frame: frame.as_ref().map(|(_, info)| info.clone()),
            insert: insert_report,
        };
        // The JSON's own write time is not in it; the images' is.
        outputs.write(&image, || {
            stats.timings.write_s = t2.elapsed().as_secs_f64();
            stats.timings.total_s = if frame.is_some() { t_frame.elapsed().as_secs_f64() } else { t0.elapsed().as_secs_f64() };
            Ok(serde_json::to_string_pretty(&stats)?)
        })?;
        written.push(outputs.exr.clone());
        let (png, json) = (&outputs.png, &outputs.json);
        if rstats.interrupted {
            eprintln!(
                "octolux: interrupted after {} passes ({} spp); wrote the partial image to {}, {}, {}",
                rstats.passes,
                rstats.spp,
                outputs.exr.display(),
                png.display(),
                json.display()
            );
            return Ok(std::process::ExitCode::from(interrupt::EXIT_INTERRUPTED));
        }
        if !args.quiet {
            eprintln!(
                "rendered {} spp in {:.2} s: {:.3} M samples/s, {:.2} M rays/s -> {}, {}, {}",
                rstats.spp,
                rstats.render_s,
                rstats.samples_per_second * 1e-6,
                rstats.rays_per_second * 1e-6,
                outputs.exr.display(),
                png.display(),
                json.display()
            );
        }
    }
    Ok(std::process::ExitCode::SUCCESS)
}

fn cmd_export(args: &ExportArgs) -> Result<()> {
    // the values `render` would refuse: the exported scene must load back
    if args.spp == 0 {
        bail!("--spp must be at least 1");
    }
    settings::check_max_depth(args.max_depth as i64).map_err(|e| anyhow::anyhow!("--max-depth {e}"))?;
    note_inputs([Path::new(&args.scene.scene)]);
    output::check_file(&args.output)?;
    // a signal exits at once, removing the staged files (interrupt.rs)
    interrupt::install()?;
    let loaded = load(&args.scene)?;
    loaded.desc.validate().with_context(|| format!("scene '{}' is invalid", args.scene.scene))?;
    octolux_io::export::write_mitsuba_scene(&loaded.desc, args.spp, args.max_depth, &args.output)
        .with_context(|| format!("cannot export to {}", args.output.display()))?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}

/// Errors are printed as one line with their chain of causes (no stack trace, even when
/// RUST_BACKTRACE is set: these are user errors, not crashes), and the exit status is 1; an
/// interrupted render exits with [`interrupt::EXIT_INTERRUPTED`].
fn main() -> std::process::ExitCode {
    match run(Cli::parse()) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<std::process::ExitCode> {
    // A malformed OCTOLUX_MEMORY_LIMIT is an error, not a silently ignored setting.
    budget::limit_from_env().map_err(anyhow::Error::msg)?;
    match cli.command {
        Command::Render(a) => cmd_render(&a),
        Command::Bake(a) => bake::cmd_bake(&a),
        Command::Export(a) => cmd_export(&a).map(|()| std::process::ExitCode::SUCCESS),
        Command::Compare { image, reference } => cmd_compare(&image, &reference).map(|()| std::process::ExitCode::SUCCESS),
        Command::Report { images, reference, bench, output } => {
            report::cmd_report(&images, reference.as_deref(), &bench, &output).map(|()| std::process::ExitCode::SUCCESS)
        }
        Command::Flicker(a) => flicker::cmd_flicker(&a).map(|()| std::process::ExitCode::SUCCESS),
        Command::Scenes => {
            print_out(&octolux_io::builtin::NAMES.join("\n"))?;
            Ok(std::process::ExitCode::SUCCESS)
        }
    }
}

/// `compare`: refuses images holding NaN or infinite values (a metric over them would be NaN,
/// printed as `null`), saying how many each holds.
fn cmd_compare(image: &std::path::Path, reference: &std::path::Path) -> Result<()> {
    let a = octolux_io::image_io::read_exr(image).with_context(|| format!("cannot read {}", image.display()))?;
    let r = octolux_io::image_io::read_exr(reference).with_context(|| format!("cannot read {}", reference.display()))?;
    let mut bad = Vec::new();
    for (path, img) in [(image, &a), (reference, &r)] {
        let n = img.data.iter().flat_map(|c| [c.x, c.y, c.z]).filter(|v| !v.is_finite()).count();
        if n > 0 {
            let pixels = img.data.iter().filter(|c| !c.is_finite()).count();
            let plural = if pixels == 1 { "" } else { "s" };
            bad.push(format!("{} holds {n} non-finite values (NaN or infinity) in {pixels} pixel{plural}", path.display()));
        }
    }
    if !bad.is_empty() {
        bail!("cannot compare: {}", bad.join("; "));
    }
    let e = octolux::metrics::compare(&a, &r).with_context(|| {
        format!("{} is {}x{} but {} is {}x{}", image.display(), a.width, a.height, reference.display(), r.width, r.height)
    })?;
    print_out(&serde_json::to_string_pretty(&e)?)?;
    Ok(())
}
