//! `octolux bake` (docs/guide/baking.md): the command line turned into the library's bake job
//! ([`octolux_io::job::run_bake`]: the octrees, their volumetric values, the cache file and its
//! JSON report), and the checks `render` shares with it (threads, memory limit). As before
//! `render`'s loop, a signal exits at once (status 130), removing the staged cache file: a
//! cache under the final name is the previous run's, untouched.

use crate::args::BakeArgs;
use crate::{interrupt, scene_spec, Log};
use anyhow::{bail, Context, Result};
use octolux::budget;
use octolux_io::job::{self, BakeJob, IntegratorRequest};

/// Most worker threads per core `--threads` may start: more only adds switching (and 100,000
/// threads hung the start).
pub const MAX_THREADS_PER_CORE: usize = 8;

/// Checks shared by `render` and `bake` before any work: max depth, threads, memory limit.
/// Returns the warnings (a `--threads` above [`MAX_THREADS_PER_CORE`] times the cores is
/// lowered to that).
pub fn check_run_flags(threads: Option<usize>, memory_limit: Option<&str>, max_depth: Option<i32>) -> Result<Vec<String>> {
    let mut warnings = Vec::new();
    job::check_max_depth(max_depth, "--max-depth")?;
    if let Some(mut n) = threads {
        if n == 0 {
            bail!("--threads must be at least 1");
        }
        let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
        let most = cores.saturating_mul(MAX_THREADS_PER_CORE);
        if n > most {
            let w = format!("--threads {n} is more than {MAX_THREADS_PER_CORE} per core on this machine's {cores} cores; using {most}");
            say!("warning: {w}");
            warnings.push(w);
            n = most;
        }
        rayon::ThreadPoolBuilder::new().num_threads(n).build_global().context("cannot start the worker threads")?;
    }
    if let Some(m) = memory_limit {
        let bytes = budget::parse_bytes(m)
            .with_context(|| format!("--memory-limit {m}: expected a memory size (bytes with an optional K, M, G or T suffix)"))?;
        budget::set_memory_limit(bytes);
    }
    Ok(warnings)
}

pub fn cmd_bake(args: &BakeArgs) -> Result<std::process::ExitCode> {
    let _ = check_run_flags(args.threads, args.memory_limit.as_deref(), args.max_depth)?;
    let bake = BakeJob {
        scene: scene_spec(&args.scene)?,
        settings: IntegratorRequest {
            integrator: None,
            settings_file: args.settings.clone(),
            flags: args.keys.settings(),
            sets: args.set.clone(),
            seed: args.seed,
            spelling: Default::default(),
        },
        max_depth: args.max_depth,
        backend: args.backend,
        output: args.output.clone(),
        volume: args.volume,
        command_line: std::env::args().collect(),
    };
    interrupt::install()?;
    job::run_bake(&bake, &Log::new(args.quiet))?;
    Ok(std::process::ExitCode::SUCCESS)
}
