//! What the tests need from the machine, probed in one place: the shared scenes, Embree,
//! Chromium and the Python environment.
//!
//! A test that cannot run its check without one of these is *ignored* by `cargo test`, with its
//! reason, rather than reported as passed. The decision is made when the test's crate is
//! built: its `build.rs` calls [`build_script`] with the names its tests need, which sets
//! `cfg(missing = "NAME")` for each one that is absent, and the test says
//!
//! ```text
//! #[cfg_attr(missing = "chromium", ignore = "needs chromium (or $OCTOLUX_CHROMIUM)")]
//! ```
//!
//! The names are [`NAMES`] (rustc checks the spelling). A thing that is *required*
//! (`OCTOLUX_REQUIRE_<KIND>=1`, see [`require_var`]; `.ci/run` requires Embree, Python and
//! Chromium) is never marked missing: its test runs and fails, so a run told to require it
//! cannot pass without it.
//!
//! A thing that appears after the crate was built (scenes fetched later) is not noticed by
//! cargo, which can only watch paths that exist: each crate has one test that calls
//! [`check_build_probe`], which fails with the command that refreshes the probe.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Environment variable naming the shared folder (the one containing `scenes/`).
pub const SHARED_ENV: &str = "OCTOLUX_SHARED";

/// Every name a test may ask for. `scenes/...` are folders of the shared scenes folder.
pub const NAMES: &[&str] = &[
    "embree",
    "chromium",
    "python",
    "scenes/bitterli-collection/box",
    "scenes/bitterli-collection/classroom",
    "scenes/bitterli-collection/dining-room",
    "scenes/bitterli-collection/sponza",
    "scenes/bitterli-collection/torus",
    "scenes/bitterli-collection/veach-lamp",
    "scenes/bitterli-cornell-box",
    "scenes/mitsuba-tutorials-cbox",
    "scenes/stanford-bunny",
];

/// Root of the source tree this crate was compiled from (two levels above its manifest).
pub fn repo_root() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().and_then(Path::parent).map(Path::to_path_buf).unwrap_or_else(|| manifest.join("../.."))
}

/// The shared folder: `$OCTOLUX_SHARED` when set and not empty, else `<repository root>/../shared`.
pub fn shared_dir() -> PathBuf {
    match std::env::var_os(SHARED_ENV) {
        Some(v) if !v.is_empty() => PathBuf::from(v),
        _ => {
            let root = repo_root();
            match root.parent() {
                Some(parent) => parent.join("shared"),
                None => root.join("../shared"),
            }
        }
    }
}

/// The variable that makes `name` required: `OCTOLUX_REQUIRE_SCENES` for every `scenes/...`,
/// else `OCTOLUX_REQUIRE_<NAME>` (`OCTOLUX_REQUIRE_EMBREE`, `_CHROMIUM`, `_PYTHON`).
pub fn require_var(name: &str) -> String {
    let kind = if name.starts_with("scenes/") { "scenes" } else { name };
    format!("OCTOLUX_REQUIRE_{}", kind.to_ascii_uppercase())
}

/// Whether `name` is required now (its [`require_var`] is `1`).
pub fn required(name: &str) -> bool {
    std::env::var(require_var(name)).is_ok_and(|v| v == "1")
}

/// For a check that cannot run (part of) a test: prints `skip: <why>` when `name` is not
/// required, and panics with `<why>` when it is.
pub fn skip(name: &str, why: &str) {
    assert!(!required(name), "{}=1 but {why}", require_var(name));
    println!("skip: {why}");
}

/// The Chromium to drive: `$OCTOLUX_CHROMIUM` when set, else `chromium` or `chromium-browser`
/// on the `PATH`.
pub fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("OCTOLUX_CHROMIUM").filter(|p| !p.is_empty()) {
        return Some(PathBuf::from(p));
    }
    let paths = std::env::var_os("PATH")?;
    ["chromium", "chromium-browser"].iter().find_map(|n| std::env::split_paths(&paths).map(|d| d.join(n)).find(|p| p.is_file()))
}

/// The Python virtual environment of the module's tests: `$OCTOLUX_PYTHON_VENV`, else
/// `<repository root>/.venv-py`.
pub fn python_venv() -> PathBuf {
    std::env::var_os("OCTOLUX_PYTHON_VENV").filter(|p| !p.is_empty()).map(PathBuf::from).unwrap_or_else(|| repo_root().join(".venv-py"))
}

/// Whether [`python_venv`] has a Python that imports what the tests use.
pub fn python_ready() -> bool {
    let python = python_venv().join("bin").join("python");
    python.exists()
        && Command::new(&python)
            .args(["-c", "import maturin, numpy, pytest, distributed"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
}

/// Whether Embree 3 can be loaded, looked up as `octolux::accel` does: `$OCTOLUX_EMBREE_LIB`
/// alone when set, else the platform's usual names.
pub fn embree_loads() -> bool {
    let names: Vec<String> = match std::env::var("OCTOLUX_EMBREE_LIB") {
        Ok(p) if !p.is_empty() => vec![p],
        _ if cfg!(target_os = "macos") => vec!["libembree3.dylib".into(), "libembree3.3.dylib".into()],
        _ if cfg!(windows) => vec!["embree3.dll".into()],
        _ => vec!["libembree3.so.3".into(), "libembree3.so".into()],
    };
    // SAFETY: loading Embree runs its initialisers only, as `octolux::accel` does; the library
    // is dropped (unloaded) at once.
    names.iter().any(|n| unsafe { libloading::Library::new(n) }.is_ok())
}

/// Whether `name` (one of [`NAMES`]) is present now, and the paths whose change may change that.
pub fn probe(name: &str) -> (bool, Vec<PathBuf>) {
    match name {
        "embree" => (embree_loads(), Vec::new()),
        "chromium" => match chromium() {
            Some(p) if p.is_file() => (true, vec![p]),
            _ => (false, Vec::new()),
        },
        "python" => (python_ready(), vec![python_venv().join("bin")]),
        _ => match name.strip_prefix("scenes/") {
            Some(rel) => {
                let dir = shared_dir().join("scenes").join(rel);
                let present = std::fs::read_dir(&dir).is_ok_and(|mut d| d.next().is_some());
                (present, vec![dir])
            }
            None => panic!("octolux-probe: unknown name {name:?} (one of {NAMES:?})"),
        },
    }
}

/// The environment variables (besides [`require_var`]) that the probe of `name` reads.
fn probe_vars(name: &str) -> &'static [&'static str] {
    match name {
        "embree" => &["OCTOLUX_EMBREE_LIB"],
        "chromium" => &["OCTOLUX_CHROMIUM"],
        "python" => &["OCTOLUX_PYTHON_VENV"],
        _ => &[SHARED_ENV],
    }
}

/// For a crate's `build.rs`: probes `names` and prints what cargo needs. Each absent name
/// that is not required sets `cfg(missing = "NAME")`; the list of them goes to the crate as
/// `env!("OCTOLUX_PROBE_MISSING")` (comma-separated) for [`check_build_probe`]. Cargo reruns
/// the probe when a probed path that exists changes, or a variable it read changes; the
/// `OCTOLUX_REQUIRE_*` variable is watched only while its thing is absent (where it decides
/// the outcome), so that switching between `.ci/run` and a plain `cargo test` on a machine that
/// has everything rebuilds nothing.
pub fn build_script(names: &[&str]) {
    let list = NAMES.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ");
    println!("cargo:rustc-check-cfg=cfg(missing, values({list}))");
    let mut missing = Vec::new();
    for name in names {
        for var in probe_vars(name) {
            println!("cargo:rerun-if-env-changed={var}");
        }
        let (present, paths) = probe(name);
        if present {
            // Only existing paths: cargo reruns a build script that watches an absent path on
            // every build, and rebuilds the crate each time.
            for p in paths.iter().filter(|p| p.exists()) {
                println!("cargo:rerun-if-changed={}", p.display());
            }
        } else {
            println!("cargo:rerun-if-env-changed={}", require_var(name));
            if !required(name) {
                println!("cargo:rustc-cfg=missing=\"{name}\"");
                missing.push(*name);
            }
        }
    }
    println!("cargo:rustc-env=OCTOLUX_PROBE_MISSING={}", missing.join(","));
}

/// For one test of each probing crate: `built_missing` is its `env!("OCTOLUX_PROBE_MISSING")`.
/// Fails when a thing that was absent at build time (so its tests were compiled as ignored) is
/// present now, or is required now, naming the command that probes again.
pub fn check_build_probe(built_missing: &str, crate_dir: &str) {
    let build_rs = Path::new(crate_dir).join("build.rs");
    for name in built_missing.split(',').filter(|n| !n.is_empty()) {
        assert!(
            !required(name),
            "{}=1 but {name} was absent when this crate was built; `touch {}` and run again",
            require_var(name),
            build_rs.display()
        );
        assert!(
            !probe(name).0,
            "{name} was absent when this crate was built, so its tests were compiled as ignored, and is present now: \
             `touch {}` and run again",
            build_rs.display()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_probes_and_has_its_variable() {
        for name in NAMES {
            let _ = probe(name);
            assert!(require_var(name).starts_with("OCTOLUX_REQUIRE_"), "{name}");
        }
        assert_eq!(require_var("scenes/stanford-bunny"), "OCTOLUX_REQUIRE_SCENES");
        assert_eq!(require_var("chromium"), "OCTOLUX_REQUIRE_CHROMIUM");
    }

    #[test]
    fn repo_root_holds_the_workspace_manifest() {
        let manifest = std::fs::read_to_string(repo_root().join("Cargo.toml")).expect("workspace Cargo.toml");
        assert!(manifest.contains("[workspace]"));
    }

    #[test]
    #[should_panic(expected = "unknown name")]
    fn an_unknown_name_is_refused() {
        probe("scene-typo");
    }
}
