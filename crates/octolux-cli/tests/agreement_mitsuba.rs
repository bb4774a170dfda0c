//! Agreement of the `path` integrator with Mitsuba 3 on the committed references
//! (`tests/refs/*.exr`, made by `tools/mitsuba/make_refs.py`; `tests/refs/manifest.json` says
//! how each was made: scene, max_depth, spp, and the reference's own measured noise).
//!
//! For each reference we render the same scene at the same resolution and `max_depth` twice
//! (seeds 1 and 2) and check:
//! 1. the image mean of every channel is within 1% of the reference's;
//! 2. relMSE(ours, ref) ≤ 1.25 · (σ²_ours + σ²_ref), where the relMSE is
//!    `mean((a − b)² / (ref² + 0.01))` over pixels and channels.
//!
//! Why that bound: for independent unbiased images `a` and `b` of the same expectation,
//! `E[(a − b)²] = var(a) + var(b)`, so the expected relMSE is the sum of both images' noise
//! terms. Our noise `σ²_ours` is measured as half the relMSE between our two seeds, the
//! reference's `σ²_ref` as half the relMSE between Mitsuba's two seeds (recorded in the
//! manifest). Any bias (a systematic difference in any pixel) adds `bias²` on top and shows
//! up as an excess. Over 128·128·3 terms the estimate of the relMSE fluctuates by a few percent,
//! so 25% of slack keeps the test stable while a bias of about a quarter of the per-pixel noise
//! standard deviation already fails it.
//!
//! Scenes from the shared folder (`octolux_io::shared`) are skipped with one `skip:` line when absent.

use octolux::accel::BackendKind;
use octolux::integrators::{path::PathSettings, Integrator};
use octolux::metrics::{channel_means, rel_mse_with};
use octolux::render::{render, RenderSettings};
use octolux::scene::Scene;
use std::path::{Path, PathBuf};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Check one reference of the manifest; `Some` when skipped (after its `skip:` line).
fn check(name: &str, spp: u32) -> Option<()> {
    let root = repo_root();
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("tests/refs/manifest.json")).expect("manifest")).expect("json");
    let entry = &manifest["references"][name];
    assert!(entry.is_object(), "no reference '{name}' in the manifest");
    let reference = octolux_io::image_io::read_exr(&root.join("tests/refs").join(entry["file"].as_str().unwrap())).expect("reference exr");
    let source = entry["source_scene"].as_str().unwrap();
    let scene_spec = if let Some(rel) = source.strip_prefix("scenes/") {
        let p = octolux_io::shared::scenes_dir().join(rel);
        if !p.exists() {
            octolux_io::shared::skip_scene(name, &p);
            return Some(());
        }
        p.to_string_lossy().into_owned()
    } else {
        // Built-in scenes are keyed by their own name in the manifest.
        name.to_string()
    };
    let max_depth = entry["max_depth"].as_i64().unwrap() as i32;
    let ref_noise = entry["self_noise"]["rel_mse"].as_f64().unwrap() / 2.0;

    let mut desc = octolux_io::load_scene(&scene_spec, &[]).expect("scene loads").desc;
    desc.film.width = reference.width;
    desc.film.height = reference.height;
    let scene = Scene::prepare(desc, BackendKind::Auto).expect("scene prepares");
    let integrator = Integrator::Path(PathSettings { max_depth, ..Default::default() });
    let run = |seed| render(&scene, &integrator, &RenderSettings { spp, seed, ..Default::default() }, &|_, _| {}).0;
    let (a, b) = (run(1), run(2));

    let ours_noise = rel_mse_with(&a, &b, &reference) / 2.0;
    let err = rel_mse_with(&a, &reference, &reference);
    let bound = 1.25 * (ours_noise + ref_noise);
    let (ma, mr) = (channel_means(&a), channel_means(&reference));
    println!("{name}: relMSE {err:.3e} (bound {bound:.3e} = 1.25 x ({ours_noise:.3e} ours + {ref_noise:.3e} ref)); means ours {ma:.5?} ref {mr:.5?}");
    for c in 0..3 {
        assert!((ma[c] - mr[c]).abs() <= 0.01 * mr[c], "{name}: channel {c} mean {} vs reference {} (more than 1% apart)", ma[c], mr[c]);
    }
    assert!(err <= bound, "{name}: relMSE {err:.4e} exceeds the noise bound {bound:.4e}");
    None
}

fn run_check(name: &str) {
    let _ = check(name, 256);
}

#[test]
fn path_agrees_with_mitsuba_on_builtin_cornell_box() {
    run_check("cornell-box");
}

#[test]
#[cfg_attr(
    missing = "scenes/mitsuba-tutorials-cbox",
    ignore = "needs ../shared/scenes/mitsuba-tutorials-cbox (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn path_agrees_with_mitsuba_on_mitsuba_cbox() {
    run_check("cbox");
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-cornell-box",
    ignore = "needs ../shared/scenes/bitterli-cornell-box (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn path_agrees_with_mitsuba_on_bitterli_cornell_box() {
    run_check("bitterli");
}
