//! Where the shared scenes folder is: the scenes that tests, benchmarks and tools read but that
//! are never copied into the repository (see `docs/guide/benchmarks.md`).
//!
//! The shared folder is the one that contains `scenes/`. It is `$OCTOLUX_SHARED` when that
//! variable is set (and not empty), else `../shared` relative to the root of the source tree
//! this crate was compiled from (the repository root when the crate is built from its
//! workspace, which is how tests, benches and tools use it; no path of a particular machine is
//! written anywhere).
//!
//! Tests that need a scene call [`shared_scene`]: when the scene is absent it prints exactly one
//! line, `skip: <scene> (<path> not found; set OCTOLUX_SHARED)`, and returns `None`, so that a
//! run that skipped everything says so instead of passing silently.

use std::path::{Path, PathBuf};

/// Environment variable naming the shared folder (the one containing `scenes/`).
pub const SHARED_ENV: &str = "OCTOLUX_SHARED";

/// Root of the source tree this crate was compiled from (two levels above its manifest,
/// `crates/octolux-io`). Meaningful for tests, benches and tools built from the repository.
pub fn repo_root() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().and_then(Path::parent).map(Path::to_path_buf).unwrap_or_else(|| manifest.join("../.."))
}

/// The shared folder: `$OCTOLUX_SHARED`, else `<repository root>/../shared`.
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

/// The shared scenes folder, `<shared>/scenes`.
pub fn scenes_dir() -> PathBuf {
    shared_dir().join("scenes")
}

/// The path of `rel` inside the shared scenes folder (`"stanford-bunny/bun_zipper.ply"`), or
/// `None` after printing one line `skip: <rel> (<path> not found; set OCTOLUX_SHARED)` when it
/// does not exist.
pub fn shared_scene(rel: &str) -> Option<PathBuf> {
    let path = scenes_dir().join(rel);
    if path.exists() {
        Some(path)
    } else {
        println!("{}", skip_line(rel, &path));
        None
    }
}

/// The line [`shared_scene`] prints for a missing scene.
pub fn skip_line(what: &str, path: &Path) -> String {
    format!("skip: {what} ({} not found; set {SHARED_ENV})", path.display())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repo_root_holds_the_workspace_manifest() {
        let root = repo_root();
        let manifest = std::fs::read_to_string(root.join("Cargo.toml")).expect("workspace Cargo.toml at the repository root");
        assert!(manifest.contains("[workspace]"), "{} is not the workspace root", root.display());
    }

    #[test]
    fn a_missing_scene_is_none_and_names_the_path() {
        let rel = "no-such-scene-folder/none.xml";
        assert_eq!(shared_scene(rel), None);
        let line = skip_line(rel, &scenes_dir().join(rel));
        assert!(line.starts_with("skip: no-such-scene-folder/none.xml ("), "{line}");
        assert!(line.ends_with("not found; set OCTOLUX_SHARED)"), "{line}");
    }
}
