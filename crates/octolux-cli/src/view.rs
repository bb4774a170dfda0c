//! `octolux view` (docs/guide/viewer.md): the command line turned into the library's view job
//! ([`octolux_io::view::run_view`]), the page opened in the default browser unless `--no-open`.

use crate::args::ViewArgs;
use crate::{interrupt, scene_spec, Log};
use anyhow::{bail, Result};
use octolux_io::job::IntegratorRequest;
use octolux_io::settings::{keys, FlagSetting};
use octolux_io::view::{run_view, ViewJob};
use serde_json::json;
use std::net::SocketAddr;

pub fn cmd_view(args: &ViewArgs) -> Result<std::process::ExitCode> {
    if args.cache.is_some() && (args.settings.is_some() || !args.set.is_empty() || args.photons.is_some()) {
        bail!("--cache holds the octrees to show: --settings, --set and --photons shape a new one and do not apply");
    }
    if args.width == Some(0) {
        bail!("--width must be at least 1");
    }
    let mut flags = Vec::new();
    if let Some(n) = args.photons {
        flags.push(FlagSetting { flag: "--photons", only: None, keys: vec![keys::PHOTON_COUNT.into()], value: json!(n), at_most: false });
    }
    let job = ViewJob {
        scene: scene_spec(&args.scene)?,
        settings: IntegratorRequest {
            integrator: None,
            settings_file: args.settings.clone(),
            flags,
            sets: args.set.clone(),
            seed: args.seed,
            spelling: Default::default(),
        },
        cache: args.cache.clone(),
        allow_stale_cache: args.allow_stale_cache,
        backend: args.backend,
        bind: SocketAddr::new(args.bind, args.port),
        compare_cpu: args.compare_cpu,
        exit_when_done: args.exit_when_done,
        width: args.width,
    };
    interrupt::install()?;
    let open = !args.no_open;
    let log = Log::new(args.quiet);
    let on_listen = move |addr: SocketAddr| {
        // the address for scripts and tests, whatever the log level
        println!("http://{addr}/");
        if open {
            let url = format!("http://{addr}/");
            let opener = if cfg!(target_os = "macos") { "open" } else { "xdg-open" };
            if std::process::Command::new(opener).arg(&url).spawn().is_err() {
                eprintln!("note: could not start {opener}: open {url} in a browser");
            }
        }
    };
    let report = run_view(&job, &log, &on_listen)?;
    if report.as_deref().is_some_and(|r| r.starts_with("error=")) {
        bail!("the page failed: {}", report.unwrap_or_default());
    }
    Ok(std::process::ExitCode::SUCCESS)
}
