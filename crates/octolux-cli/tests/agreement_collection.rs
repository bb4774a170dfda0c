//! Agreement of the `path` integrator with Mitsuba 3 on the research-scene collection
//! (`../shared/scenes/bitterli-collection`, Mitsuba 0.6 files) and on the generated test scenes
//! (`tests/scenes/{envmap,mirrored,wrappers}`, written by `tools/make_testdata.py`).
//!
//! The references are `tests/refs/collection/*.exr`, made by
//! `tools/mitsuba/make_refs.py --collection` (320 pixels wide, the file's aspect ratio and max
//! depth); `tests/refs/collection/manifest.json` says how each was made, which of the scene's
//! plugins Mitsuba 3 only approximates (phong, ward, sunsky: see `translation.approximations`),
//! and the reference's own noise `σ²_ref` (`self_noise.ref_rel_mse`: a quarter of the relMSE
//! between its two independent half-spp renders).
//!
//! For each scene we render the same file at the reference's size and the file's max depth twice
//! (seeds 1 and 2, `SPP` samples each), average the two, and check, as `agreement_mitsuba.rs`
//! does:
//! 1. every channel's image mean is within 1% of the reference's, plus three standard errors of
//!    the difference of the means (ours from the spread between our two seeds, the reference's
//!    from its two halves): caustic-heavy scenes (`box`, `torus`) have means that a few dozen
//!    samples per pixel cannot pin to 1%, and the slack says by how much in the output;
//! 2. relMSE(ours, ref) ≤ 1.25 · (σ²_ours + σ²_ref) with relMSE = `mean((a − b)² / (ref² + 0.01))`
//!    over pixels and channels and σ²_ours = relMSE(seed 1, seed 2) / 4 (the noise of the mean of
//!    two renders). For independent unbiased images the expected relMSE is the sum of both noise
//!    terms; any bias adds on top.
//!
//! A scene whose file is absent (no `../shared`, or `$OCTOLUX_SHARED` pointing elsewhere) prints
//! one `skip:` line and passes; so does a scene with no reference in the manifest yet.

use octolux::accel::BackendKind;
use octolux::integrators::{path::PathSettings, Integrator};
use octolux::metrics::{channel_means, rel_mse_with};
use octolux::render::{render, RenderSettings};
use octolux::scene::Scene;
use octolux_io::image_io::read_exr;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Samples per pixel of each of our two renders (so the whole test stays within a few minutes
/// on two cores; the references have 1024).
const SPP: u32 = 16;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The shared folder (it holds `scenes/`): `$OCTOLUX_SHARED`, else `<repo>/../shared`.
fn shared_dir() -> PathBuf {
    match std::env::var_os("OCTOLUX_SHARED") {
        Some(p) => PathBuf::from(p),
        None => repo_root().join("../shared"),
    }
}

/// The scene file a manifest entry names: `../shared/...` lies in the shared folder, anything
/// else in the repository.
fn scene_path(source: &str) -> PathBuf {
    match source.strip_prefix("../shared/") {
        Some(rel) => shared_dir().join(rel),
        None => repo_root().join(source),
    }
}

fn sci3(v: [f64; 3]) -> String {
    format!("[{:.1e}, {:.1e}, {:.1e}]", v[0], v[1], v[2])
}

fn check(name: &str) {
    let root = repo_root();
    let manifest_path = root.join("tests/refs/collection/manifest.json");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&manifest_path).expect("collection manifest")).expect("collection manifest is JSON");
    let entry = &manifest["references"][name];
    if !entry.is_object() {
        println!("skip: {name}: no reference in {} yet (tools/mitsuba/make_refs.py --collection --only {name})", manifest_path.display());
        return;
    }
    let scene_file = scene_path(entry["source_scene"].as_str().expect("source_scene"));
    if !scene_file.exists() {
        println!("skip: {name}: {} is absent (needs the shared folder at ../shared or $OCTOLUX_SHARED)", scene_file.display());
        return;
    }
    let reference = read_exr(&root.join("tests/refs/collection").join(entry["file"].as_str().expect("file"))).expect("reference EXR");
    let max_depth = entry["max_depth"].as_i64().expect("max_depth") as i32;
    let ref_noise = entry["self_noise"]["ref_rel_mse"].as_f64().expect("self_noise.ref_rel_mse");
    let approximations: Vec<&str> =
        entry["translation"]["approximations"].as_array().map(|a| a.iter().filter_map(|v| v.as_str()).collect()).unwrap_or_default();

    let t0 = Instant::now();
    let loaded = octolux_io::load_scene(&scene_file.to_string_lossy(), &[])
        .unwrap_or_else(|e| panic!("{name}: octolux does not load {}: {e}", scene_file.display()));
    for w in &loaded.warnings {
        println!("{name}: octolux warning: {w}");
    }
    let mut desc = loaded.desc;
    desc.film.width = reference.width;
    desc.film.height = reference.height;
    let scene = Scene::prepare(desc, BackendKind::Auto).unwrap_or_else(|e| panic!("{name}: scene does not prepare: {e}"));
    let load_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let integrator = Integrator::Path(PathSettings { max_depth, ..Default::default() });
    let run = |seed| render(&scene, &integrator, &RenderSettings { spp: SPP, seed, ..Default::default() }, &|_, _| {}).0;
    let (a, b) = (run(1), run(2));
    let render_s = t1.elapsed().as_secs_f64();
    let mut avg = a.clone();
    for (p, q) in avg.data.iter_mut().zip(&b.data) {
        *p = (*p + *q) * 0.5;
    }

    let ours_noise = rel_mse_with(&a, &b, &reference) / 4.0;
    let err = rel_mse_with(&avg, &reference, &reference);
    let bound = 1.25 * (ours_noise + ref_noise);
    let (mo, mr) = (channel_means(&avg), channel_means(&reference));
    // Standard errors of the image means: ours from the two seeds (Var(mean of avg) =
    // Σ E[(a−b)²] / (4 N²)), the reference's from its two halves (|m1 − m2| / 2).
    let n = avg.data.len() as f64;
    let mut ours_se = [0.0f64; 3];
    for (p, q) in a.data.iter().zip(&b.data) {
        for (c, s) in ours_se.iter_mut().enumerate() {
            *s += ((p[c] - q[c]) as f64).powi(2);
        }
    }
    let ours_se = ours_se.map(|s| s.sqrt() / (2.0 * n));
    let halves = entry["halves"].as_array().expect("halves");
    let ref_se: [f64; 3] = std::array::from_fn(|c| {
        let m = |h: &serde_json::Value| h["mean_rgb"][c].as_f64().unwrap_or(0.0);
        (m(&halves[0]) - m(&halves[1])).abs() / 2.0
    });
    println!(
        "{name}: {}x{} spp 2x{SPP} load {load_s:.1}s render {render_s:.1}s; relMSE {err:.3e} (bound {bound:.3e} = 1.25 x ({ours_noise:.3e} ours + {ref_noise:.3e} ref), ratio {:.2}); \
         means ours {mo:.5?} ref {mr:.5?} (rel. diff {:.4?}; mean SE ours {} ref {})",
        reference.width,
        reference.height,
        err / bound,
        std::array::from_fn::<f64, 3, _>(|c| (mo[c] - mr[c]) / mr[c].max(1e-12)),
        sci3(ours_se),
        sci3(ref_se),
    );
    for ap in &approximations {
        println!("{name}: the reference approximates: {ap}");
    }
    let mut failures = Vec::new();
    for c in 0..3 {
        let tol = 0.01 * mr[c] + 3.0 * (ours_se[c].powi(2) + ref_se[c].powi(2)).sqrt();
        if (mo[c] - mr[c]).abs() > tol {
            failures.push(format!("channel {c} mean {:.5} vs reference {:.5} (tolerance {tol:.5})", mo[c], mr[c]));
        }
    }
    if err > bound {
        failures.push(format!("relMSE {err:.4e} exceeds the noise bound {bound:.4e}"));
    }
    assert!(failures.is_empty(), "{name} disagrees with Mitsuba 3: {}", failures.join("; "));
}

/// `box` is lit only through glass (caustics only): at the test's 2x16 spp two octolux seeds
/// differ by ~15% and the reference's own halves by 6%, so this comparison cannot resolve a
/// difference of the size it looks for. Run it with `--ignored` and a larger spp budget.
#[test]
#[ignore = "caustics-only scene: noise at test spp exceeds the bound (see the doc comment)"]
fn path_agrees_with_mitsuba_on_box() {
    check("box");
}

#[test]
fn path_agrees_with_mitsuba_on_classroom() {
    check("classroom");
}

#[test]
fn path_agrees_with_mitsuba_on_dining_room() {
    check("dining-room");
}

#[test]
fn path_agrees_with_mitsuba_on_sponza() {
    check("sponza");
}

#[test]
fn path_agrees_with_mitsuba_on_torus() {
    check("torus");
}

#[test]
fn path_agrees_with_mitsuba_on_veach_lamp() {
    check("veach-lamp");
}

#[test]
fn path_agrees_with_mitsuba_on_generated_envmap_scene() {
    check("envmap");
}

#[test]
fn path_agrees_with_mitsuba_on_generated_mirrored_scene() {
    check("mirrored");
}

/// Mitsuba 3's `mask` (a cut-out leaf whose shadow rays stop at the quad), `bumpmap` and
/// `normalmap` (160 pixels wide).
#[test]
fn path_agrees_with_mitsuba_on_generated_wrappers_scene() {
    check("wrappers");
}
