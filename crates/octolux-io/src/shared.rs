//! Where the shared scenes folder is: the scenes that tests, benchmarks and tools read but that
//! are never copied into the repository (see `docs/guide/benchmarks.md`), and the one table of
//! scene aliases of the benches and examples ([`scene_alias`], `bench/scenes.json`).
//!
//! The shared folder is the one that contains `scenes/`. It is `$OCTOLUX_SHARED` when that
//! variable is set (and not empty), else `../shared` relative to the root of the source tree
//! this crate was compiled from (the repository root when the crate is built from its
//! workspace, which is how tests, benches and tools use it; no path of a particular machine is
//! written anywhere).
//!
//! Tests that need a scene are marked `#[cfg_attr(missing = "scenes/<folder>", ignore = ...)]`
//! (the folder probed by the crate's `build.rs`, `crates/octolux-probe`), and call
//! [`shared_scene`]: when the scene is absent it prints exactly one line, `skip: <scene>
//! (<path> not found; set OCTOLUX_SHARED)`, and returns `None` (for a test that loops over
//! several scenes, some of them present); with `OCTOLUX_REQUIRE_SCENES=1` it panics.

use std::path::{Path, PathBuf};

/// Environment variable naming the shared folder (the one containing `scenes/`).
pub use octolux_probe::SHARED_ENV;

/// Root of the source tree this crate was compiled from (two levels above its manifest,
/// `crates/octolux-io`). Meaningful for tests, benches and tools built from the repository.
pub fn repo_root() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().and_then(Path::parent).map(Path::to_path_buf).unwrap_or_else(|| manifest.join("../.."))
}

/// The shared folder: `$OCTOLUX_SHARED`, else `<repository root>/../shared` (the one rule,
/// `octolux_probe::shared_dir`, that the build scripts' probes use too).
pub fn shared_dir() -> PathBuf {
    octolux_probe::shared_dir()
}

/// The shared scenes folder, `<shared>/scenes`.
pub fn scenes_dir() -> PathBuf {
    shared_dir().join("scenes")
}

/// The path of `rel` inside the shared scenes folder (`"stanford-bunny/bun_zipper.ply"`), or
/// `None` after printing one line `skip: <rel> (<path> not found; set OCTOLUX_SHARED)` when it
/// does not exist. With `OCTOLUX_REQUIRE_SCENES=1` a missing scene panics instead.
pub fn shared_scene(rel: &str) -> Option<PathBuf> {
    let path = scenes_dir().join(rel);
    if path.exists() {
        Some(path)
    } else {
        skip_scene(rel, &path);
        None
    }
}

/// Prints the line [`skip_line`] for the missing scene `what` at `path`, or panics with it
/// under `OCTOLUX_REQUIRE_SCENES=1`.
pub fn skip_scene(what: &str, path: &Path) {
    let line = skip_line(what, path);
    octolux_probe::skip("scenes/", line.strip_prefix("skip: ").unwrap_or(&line));
}

/// The line [`shared_scene`] prints for a missing scene.
pub fn skip_line(what: &str, path: &Path) -> String {
    format!("skip: {what} ({} not found; set {SHARED_ENV})", path.display())
}

/// One entry of the scene aliases of the benches and examples (`bench/scenes.json`, the one
/// table both read; the Python benches through `bench/scenes.py`).
#[derive(Clone, Debug, PartialEq, serde::Deserialize)]
pub struct SceneAlias {
    /// A built-in scene name, `shared:PATH` inside the shared scenes folder, or a path from the
    /// repository root.
    pub scene: String,
    /// The `max_depth` every renderer uses on it (Mitsuba's meaning).
    pub max_depth: i32,
    /// The resolution of its reference image, `[width, height]`.
    pub resolution: [u32; 2],
    /// Its reference image, from the repository root.
    pub reference: String,
}

impl SceneAlias {
    /// What a loader takes: the built-in name or the file's path; `None` after one `skip:` line
    /// when a shared scene is absent ([`shared_scene`]).
    pub fn spec(&self) -> Option<String> {
        match self.scene.strip_prefix("shared:") {
            Some(rel) => shared_scene(rel).map(|p| p.to_string_lossy().into_owned()),
            None if self.scene.contains('/') => Some(repo_root().join(&self.scene).to_string_lossy().into_owned()),
            None => Some(self.scene.clone()),
        }
    }
}

/// The alias table's file, `bench/scenes.json` in the repository.
pub fn aliases_file() -> PathBuf {
    repo_root().join("bench").join("scenes.json")
}

/// The scene called `name` in the alias table (`None`: not an alias; a built-in name or a path
/// is then taken as it is).
pub fn scene_alias(name: &str) -> Result<Option<SceneAlias>, crate::IoError> {
    #[derive(serde::Deserialize)]
    struct Table {
        scenes: std::collections::BTreeMap<String, SceneAlias>,
    }
    let path = aliases_file();
    let text = crate::files::read_to_string(&path)?;
    let mut table: Table = serde_json::from_str(&text).map_err(|e| crate::IoError::invalid(&path, e.to_string()))?;
    Ok(table.scenes.remove(name))
}

/// What a loader takes for `name`: an alias's scene ([`SceneAlias::spec`]), else `name` itself;
/// `None` when the alias names an absent shared scene (a `skip:` line was printed).
pub fn scene_spec(name: &str) -> Result<Option<String>, crate::IoError> {
    Ok(match scene_alias(name)? {
        Some(a) => a.spec(),
        None => Some(name.to_string()),
    })
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
    fn the_alias_table_names_the_references_and_the_built_ins() {
        let a = scene_alias("cbox").expect("the table reads").expect("cbox is an alias");
        assert_eq!((a.scene.as_str(), a.max_depth, a.resolution), ("shared:mitsuba-tutorials-cbox/cbox.xml", 6, [128, 128]));
        let b = scene_alias("cornell-box").unwrap().unwrap();
        assert_eq!(b.spec().as_deref(), Some("cornell-box"));
        assert_eq!(scene_alias("no-such-alias").unwrap(), None);
        assert_eq!(scene_spec("model.obj").unwrap().as_deref(), Some("model.obj"));
        // every reference the table names is committed
        let text = std::fs::read_to_string(aliases_file()).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        for (name, e) in v["scenes"].as_object().unwrap() {
            let r = repo_root().join(e["reference"].as_str().unwrap());
            assert!(r.is_file(), "{name}: {} is not a file", r.display());
        }
    }

    /// The scenes this crate's build probed as absent (its tests compiled as ignored) are
    /// still absent and not required.
    #[test]
    fn the_build_probe_still_holds() {
        octolux_probe::check_build_probe(env!("OCTOLUX_PROBE_MISSING"), env!("CARGO_MANIFEST_DIR"));
    }

    #[test]
    fn a_missing_scene_is_none_and_names_the_path() {
        let rel = "no-such-scene-folder/none.xml";
        if !octolux_probe::required("scenes/") {
            assert_eq!(shared_scene(rel), None);
        }
        let line = skip_line(rel, &scenes_dir().join(rel));
        assert!(line.starts_with("skip: no-such-scene-folder/none.xml ("), "{line}");
        assert!(line.ends_with("not found; set OCTOLUX_SHARED)"), "{line}");
    }
}
