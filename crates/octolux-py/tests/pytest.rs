//! Builds the Python module into a virtual environment and runs its pytest suite
//! (`tests/test_octolux.py`, `tests/test_dask.py`), so that `cargo test --workspace` covers the
//! bindings too.
//!
//! The environment is `$OCTOLUX_PYTHON_VENV`, else `<repo>/.venv-py`; it needs what
//! `crates/octolux-py/requirements-test.txt` lists (`.ci/run` creates it; by hand: `python3 -m
//! venv .venv-py && .venv-py/bin/pip install -r crates/octolux-py/requirements-test.txt`). Without it the test is ignored
//! (probed when this crate is built, `crates/octolux-probe`), unless `OCTOLUX_REQUIRE_PYTHON=1`
//! (set by `.ci/run`), where it runs and fails. The module
//! is compiled by `maturin develop --release` into its own target folder (`target/python`), so
//! that it does not wait for the lock of the folder this test runs from.

use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").canonicalize().expect("the repository root")
}

/// What this crate's build probed as absent (the test below compiled as ignored) is still
/// absent and not required (`crates/octolux-probe`).
#[test]
fn the_build_probe_still_holds() {
    octolux_probe::check_build_probe(env!("OCTOLUX_PROBE_MISSING"), env!("CARGO_MANIFEST_DIR"));
}

#[test]
#[cfg_attr(missing = "python", ignore = "needs .venv-py with crates/octolux-py/requirements-test.txt (or $OCTOLUX_PYTHON_VENV)")]
fn python_module_pytest_suite() {
    let root = repo();
    let venv = octolux_probe::python_venv();
    let python = venv.join("bin").join("python");
    let required = octolux_probe::required("python");
    if !octolux_probe::python_ready() {
        let why = format!("python module tests: no virtual environment with maturin, numpy, pytest and distributed at {}", venv.display());
        octolux_probe::skip("python", &why);
        return;
    }
    let manifest = root.join("crates/octolux-py/Cargo.toml");
    let status = Command::new(&python)
        .args(["-m", "maturin", "develop", "--release", "--quiet", "-m"])
        .arg(&manifest)
        .env("VIRTUAL_ENV", &venv)
        .env("CARGO_TARGET_DIR", root.join("target/python"))
        .status()
        .expect("cannot run maturin");
    assert!(status.success(), "maturin develop failed: {status}");
    // the CLI binary cargo built beside this test (`cargo test --workspace` builds it), for the
    // Dask tests, which run it on the workers
    let mut cmd = Command::new(&python);
    if let Some(bin) = std::env::current_exe().ok().and_then(|t| Some(t.parent()?.parent()?.join("octolux"))).filter(|b| b.is_file()) {
        cmd.env("OCTOLUX_BIN", bin);
    } else {
        assert!(!required, "OCTOLUX_REQUIRE_PYTHON=1 but the octolux binary was not built (run `cargo test --workspace`)");
        println!("skip: the Dask tests: no octolux binary beside this test (run `cargo test --workspace`)");
    }
    let status = cmd
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(root.join("crates/octolux-py/tests"))
        .current_dir(&root)
        .status()
        .expect("cannot run pytest");
    assert!(status.success(), "the pytest suite failed: {status}");
}
