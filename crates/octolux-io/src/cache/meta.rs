//! A cache file's metadata and statistics as JSON (`mod.rs`): the build's statistics without
//! their times, so that a cache's bytes depend only on the scene, the settings and the octolux
//! version.

use octolux::caches::OctreeStats;
use octolux::integrators::octree::{OctreeBuildStats, OctreeIntegratorSettings};
use serde::{Deserialize, Serialize};

/// Keys of the build statistics that hold times (seconds, or rates per second; the crate's
/// convention names them `*_s`): they change from run to run, so a file does not hold them and
/// reads them back as 0. A cache's bytes then depend only on the scene, the settings and the
/// octolux version (test `two_identical_bakes_give_identical_bytes`).
pub const TIMING_KEYS: [&str; 4] = ["t_photons_s", "t_octree_s", "t_c_s", "build_photons_per_s"];
/// The per-tree statistics' times ([`TIMING_KEYS`]).
pub const TREE_TIMING_KEYS: [&str; 1] = ["t_build_s"];

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Meta {
    pub(super) octolux_version: String,
    pub(super) scene: String,
    pub(super) backend: String,
    pub(super) settings: OctreeIntegratorSettings,
    /// [`OctreeBuildStats`] without [`TIMING_KEYS`] (nor the trees' [`TREE_TIMING_KEYS`]).
    pub(super) stats: serde_json::Value,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TreeMeta {
    /// [`OctreeStats`] without [`TREE_TIMING_KEYS`].
    pub(super) stats: serde_json::Value,
}

/// `stats` as JSON without the keys `keys` (the times).
pub(super) fn without_times(stats: &impl Serialize, keys: &[&str]) -> serde_json::Value {
    // plain numbers, strings and lists: serialising cannot fail
    let mut v = serde_json::to_value(stats).unwrap_or_default();
    if let serde_json::Value::Object(m) = &mut v {
        for k in keys {
            m.remove(*k);
        }
    }
    v
}

/// The statistics a file holds ([`without_times`]) back as the library's, times 0. A key
/// of `keys` present in the file is refused (it holds no times since version 5).
pub(super) fn with_zero_times<T: serde::de::DeserializeOwned>(mut v: serde_json::Value, keys: &[&str], what: &str) -> Result<T, String> {
    let serde_json::Value::Object(m) = &mut v else { return Err(format!("{what}: not a JSON object")) };
    for k in keys {
        if m.insert(k.to_string(), serde_json::json!(0.0)).is_some() {
            return Err(format!("{what}: `{k}` is a time, which a cache file does not hold"));
        }
    }
    serde_json::from_value(v).map_err(|e| format!("{what}: {e}"))
}

/// The build statistics as a file holds them: [`TIMING_KEYS`] and the trees' times left out.
pub(super) fn build_stats_json(stats: &OctreeBuildStats) -> serde_json::Value {
    let mut v = without_times(stats, &TIMING_KEYS);
    for tree in ["global", "caustic", "volume"] {
        if let Some(t) = v.get_mut(tree).filter(|t| t.is_object()) {
            *t = without_times(t, &TREE_TIMING_KEYS);
        }
    }
    v
}

pub(super) fn build_stats_from_json(mut v: serde_json::Value) -> Result<OctreeBuildStats, String> {
    for tree in ["global", "caustic", "volume"] {
        if let Some(t) = v.get_mut(tree).filter(|t| t.is_object()) {
            let s: OctreeStats = with_zero_times(t.take(), &TREE_TIMING_KEYS, &format!("metadata, {tree} statistics"))?;
            *t = serde_json::to_value(s).map_err(|e| e.to_string())?;
        }
    }
    with_zero_times(v, &TIMING_KEYS, "metadata, statistics")
}
