//! The `octolux` command-line renderer.
//!
//! `octolux render [SCENE] ...` renders a built-in scene (default `cornell-box`), a Mitsuba XML
//! file, or an OBJ/PLY mesh, and writes `OUT.exr`, `OUT.png` and `OUT.json` (statistics).
//! `octolux export SCENE -o scene.xml` writes the scene as Mitsuba 3 XML (meshes as PLY).
//! `octolux bake SCENE -o lighting.oxc` writes the `octree` integrator's lighting, which
//! `render --cache` renders from, for one image or the frames of `--camera-path` / `--sensors`
//! (docs/guide/baking.md); `octolux flicker` measures how such frames flicker.
//!
//! The work of `render` and `bake` is the library's (`octolux_io::job`, shared with the Python
//! module); this crate turns the command line into its jobs and prints what they report. Rooms:
//! [`args`] (the command line), [`bake`] (`bake`, and the flags `render` shares with it),
//! [`interrupt`] (SIGINT/SIGTERM: a partial render is written, a second signal exits),
//! [`report`] (`report`: the HTML comparison page), [`flicker`] (the flicker measure of a frame
//! folder).
//!
//! Hostile input (issue 12): sizes from the command line or the scene (film, photons) are
//! checked against the memory budget ([`octolux::budget`]) and the output folder is checked
//! before any long work; `compare` refuses images holding non-finite values.

/// `eprintln!` that survives a closed stderr (`octolux render ... 2>&1 | head -1`): a line that
/// cannot be written is dropped and the run goes on (`eprintln!` panics, exit status 101).
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

mod args;
mod bake;
mod flicker;
mod interrupt;
mod report;
mod view;

use anyhow::{bail, Context, Result};
use args::{Cli, Command, ExportArgs, RenderArgs, SceneArgs};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};
use octolux::budget;
use octolux_io::job::{self, output, Frontend, RenderOutcome};
use std::io::IsTerminal;
use std::path::Path;
use std::sync::Mutex;
use std::time::{Duration, Instant};

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

/// Create the folder of an output where it is missing (as the render and bake jobs do), saying
/// so; a failed run removes it again if it stayed empty (`main`).
pub(crate) fn output_folder(path: &Path) -> Result<()> {
    if let Some(dir) = octolux_io::files::create_output_folder(path).map_err(anyhow::Error::msg)? {
        say!("created the output folder '{}'", dir.display());
    }
    Ok(())
}

/// The command line's front end of a job: warnings and notes on stderr, the log unless `-q`,
/// and while an image renders its progress (unless `-q`): a bar on a terminal, else a line
/// every [`progress_every`] seconds (a log file, a batch job's output); the signal handler is
/// told when the loop runs.
pub(crate) struct Log {
    pub quiet: bool,
    progress: Mutex<Option<Progress>>,
}

/// The progress of the image under way.
enum Progress {
    Bar(ProgressBar),
    /// Lines on stderr: when the image started, when the last line was printed.
    Lines {
        start: Instant,
        last: Instant,
        every: Duration,
    },
}

/// Seconds between two progress lines without a terminal: 5, or `$OCTOLUX_PROGRESS_SECONDS`.
pub(crate) fn progress_every() -> Duration {
    std::env::var("OCTOLUX_PROGRESS_SECONDS")
        .ok()
        .and_then(|s| s.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .map_or(Duration::from_secs(5), Duration::from_secs_f64)
}

/// A progress line: `rendering: 42% (1720 of 4096 pixels), 12 s`.
fn progress_line(done: u64, total: u64, elapsed: Duration) -> String {
    let pct = (done.min(total) * 100).checked_div(total).unwrap_or(100);
    format!("rendering: {pct}% ({} of {total} pixels), {:.0} s", done.min(total), elapsed.as_secs_f64())
}

impl Log {
    pub fn new(quiet: bool) -> Self {
        Log { quiet, progress: Mutex::new(None) }
    }
}

impl Frontend for Log {
    fn info(&self, line: &str) {
        if !self.quiet {
            say!("{line}");
        }
    }
    fn warning(&self, w: &str) {
        say!("warning: {w}");
    }
    fn note(&self, n: &str) {
        say!("note: {n}");
    }
    fn rendering(&self, pixels: Option<u64>) {
        let mut progress = self.progress.lock().unwrap_or_else(|e| e.into_inner());
        match pixels {
            Some(n) => {
                // the first signal now asks the loop to stop (and stays so until the run ends:
                // a signal while a frame is written stops the next one cleanly)
                interrupt::set_rendering(true);
                if self.quiet {
                    return;
                }
                *progress = Some(if std::io::stderr().is_terminal() {
                    let b = ProgressBar::new(n);
                    b.set_style(
                        ProgressStyle::with_template("{spinner} rendering [{bar:40}] {percent}% {elapsed_precise} eta {eta}")
                            .unwrap_or_else(|_| ProgressStyle::default_bar()),
                    );
                    Progress::Bar(b)
                } else {
                    let now = Instant::now();
                    Progress::Lines { start: now, last: now, every: progress_every() }
                });
            }
            None => {
                if let Some(Progress::Bar(b)) = progress.take() {
                    b.finish_and_clear();
                }
            }
        }
    }
    fn progress(&self, done: u64, total: u64) {
        match self.progress.lock().unwrap_or_else(|e| e.into_inner()).as_mut() {
            Some(Progress::Bar(b)) => {
                b.set_length(total);
                b.set_position(done.min(total));
            }
            Some(Progress::Lines { start, last, every }) => {
                let now = Instant::now();
                if now.duration_since(*last) >= *every && done < total {
                    *last = now;
                    say!("{}", progress_line(done, total, now.duration_since(*start)));
                }
            }
            None => {}
        }
    }
}

/// The scene a command names.
pub(crate) fn scene_spec(args: &SceneArgs) -> Result<job::SceneSpec> {
    Ok(job::SceneSpec { scene: args.scene.clone(), defines: parse_defines(&args.define)?, allow_outside_uris: args.allow_outside_uris })
}

/// Load a scene, its notes and warnings printed.
pub(crate) fn load(args: &SceneArgs) -> Result<octolux_io::LoadedScene> {
    Ok(job::load(&scene_spec(args)?, &Log::new(false))?)
}

/// `render`: the flags checked, then the library's render job ([`job::run_render`]).
fn cmd_render(args: &RenderArgs) -> Result<std::process::ExitCode> {
    let warnings = bake::check_run_flags(args.threads, args.memory_limit.as_deref(), args.max_depth)?;
    let render = args.job(warnings)?;
    interrupt::install()?;
    let log = Log::new(args.quiet);
    match job::run_render(&render, &log, &interrupt::CANCEL)? {
        RenderOutcome::Done(_) => Ok(std::process::ExitCode::SUCCESS),
        RenderOutcome::Interrupted(msg) => {
            say!("{msg}");
            Ok(std::process::ExitCode::from(interrupt::EXIT_INTERRUPTED))
        }
    }
}

fn cmd_export(args: &ExportArgs) -> Result<()> {
    // the values `render` would refuse: the exported scene must load back
    if args.spp == 0 {
        bail!("--spp must be at least 1");
    }
    job::check_max_depth(Some(args.max_depth), "--max-depth")?;
    note_inputs([Path::new(&args.scene.scene)]);
    output_folder(&args.output)?;
    output::check_file(&args.output)?;
    // a signal exits at once, removing the staged files (interrupt.rs)
    interrupt::install()?;
    let loaded = load(&args.scene)?;
    loaded.desc.validate().with_context(|| format!("scene '{}' is invalid", args.scene.scene))?;
    octolux_io::export::write_mitsuba_scene(&loaded.desc, args.spp, args.max_depth, &args.output)
        .with_context(|| format!("cannot export to {}", args.output.display()))?;
    say!("wrote {}", args.output.display());
    Ok(())
}

/// Errors are printed as one line with their chain of causes (no stack trace, even when
/// RUST_BACKTRACE is set: these are user errors, not crashes), and the exit status is 1; an
/// interrupted render exits with [`interrupt::EXIT_INTERRUPTED`].
fn main() -> std::process::ExitCode {
    if let Some(msg) = args::removed_flag(&std::env::args().collect::<Vec<_>>()) {
        say!("error: {msg}");
        return std::process::ExitCode::FAILURE;
    }
    if let Err(msg) = octolux::cpu::forced() {
        say!("error: {msg}");
        return std::process::ExitCode::FAILURE;
    }
    match run(Cli::parse()) {
        Ok(code) => code,
        Err(e) => {
            // the output folders this run created, if they stayed empty
            octolux_io::files::remove_created_folders();
            say!("error: {e:#}");
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
        Command::View(a) => view::cmd_view(&a),
        Command::Export(a) => cmd_export(&a).map(|()| std::process::ExitCode::SUCCESS),
        Command::Compare { image, reference } => cmd_compare(&image, &reference).map(|()| std::process::ExitCode::SUCCESS),
        Command::Report { images, reference, bench, output } => {
            report::cmd_report(&images, reference.as_deref(), &bench, &output).map(|()| std::process::ExitCode::SUCCESS)
        }
        Command::Flicker(a) => flicker::cmd_flicker(&a).map(|()| std::process::ExitCode::SUCCESS),
        Command::Settings { integrator, markdown } => {
            let text = match (integrator, markdown) {
                (_, true) => octolux_io::settings::reference::markdown(),
                (Some(name), false) => {
                    octolux_io::settings::reference::text(&name).with_context(|| format!("unknown integrator '{name}'"))?
                }
                (None, false) => format!(
                    "integrators: {}\n`octolux settings INTEGRATOR` lists one's settings: every key with its default, type and doc \
                     (the keys of --set, of --settings files and of Python's settings dict); `--markdown` prints the reference \
                     page of all of them (docs/guide/settings.md).",
                    octolux::integrators::IntegratorSettings::NAMES.join(", ")
                ),
            };
            print_out(text.trim_end())?;
            Ok(std::process::ExitCode::SUCCESS)
        }
        Command::Scenes => {
            print_out(&octolux_io::builtin::NAMES.join("\n"))?;
            Ok(std::process::ExitCode::SUCCESS)
        }
    }
}

/// `compare`: reads EXR, HDR, PNG and JPEG (the last two decoded from sRGB to linear, as
/// textures are); refuses images holding NaN or infinite values (a metric over them would be NaN,
/// printed as `null`), saying how many each holds.
fn cmd_compare(image: &std::path::Path, reference: &std::path::Path) -> Result<()> {
    let a = octolux_io::image_io::read_image(image).context("cannot read the image")?;
    let r = octolux_io::image_io::read_image(reference).context("cannot read the reference")?;
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
