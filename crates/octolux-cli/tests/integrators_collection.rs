//! Every cache integrator (`octree`, `ward`, `christensen`, `photonmap`) loads and renders every
//! research scene of the collection (`../shared/scenes/bitterli-collection`; issue 10, item 5).
//!
//! Each scene is rendered small (the reference's size divided by `SHRINK`: 64 pixels wide) with
//! few photons and samples, with the file's max depth, and we check:
//! - every pixel is finite (no NaN, no infinity);
//! - every channel whose reference mean is non-zero has a non-zero mean (the image is not black);
//! - no pixel exceeds `MAX_PIXEL_FACTOR` times the reference's brightest pixel (issue 11's bound
//!   for the cache integrators; the reference at its full 320-pixel width).
//!
//! Accuracy is not asserted here (few photons: that is issue 11's work), but each line printed
//! gives it: image means against the reference's, relMSE against the reference box-filtered to
//! the same size, and the brightest pixel against the reference's.
//!
//! A scene whose file is absent (no `../shared`) prints one `skip:` line and passes.

mod common;

use octolux::accel::BackendKind;
use octolux::integrators::{build, IntegratorSettings};
use octolux::metrics::{channel_means, rel_mse_with};
use octolux::render::{render, RenderSettings};
use octolux::scene::Scene;
use std::time::Instant;

/// The render is the reference's size divided by this (320 wide -> 64).
const SHRINK: u32 = 5;
/// Photon paths per render: enough to light every scene, few enough to keep each integrator's
/// build within a second or two on two cores.
const PHOTONS: u64 = 20_000;
const SPP: u32 = 4;
/// No pixel above this many times the reference's maximum (issue 11).
const MAX_PIXEL_FACTOR: f32 = 10.0;
const CACHE_INTEGRATORS: [&str; 4] = ["octree", "ward", "christensen", "photonmap"];

fn max_channel(img: &octolux::image::Image) -> f32 {
    img.data.iter().map(|p| p.max_element()).fold(0.0, f32::max)
}

fn settings_for(name: &str, max_depth: i32) -> IntegratorSettings {
    let mut s = IntegratorSettings::default_for(name).expect("known integrator");
    match &mut s {
        IntegratorSettings::Path(p) => p.max_depth = max_depth,
        IntegratorSettings::Octree(o) => {
            o.photons.photons = PHOTONS;
            o.max_depth = max_depth;
        }
        IntegratorSettings::Photonmap(o) => {
            o.photons.photons = PHOTONS;
            o.max_depth = max_depth;
        }
        IntegratorSettings::Ward(o) => {
            o.photons.photons = PHOTONS;
            o.max_depth = max_depth;
        }
        IntegratorSettings::Christensen(o) => {
            o.photons.photons = PHOTONS;
            o.max_depth = max_depth;
        }
    }
    s
}

fn check(scene_name: &str) {
    let Some(r) = common::reference(scene_name) else { return };
    let loaded = octolux_io::load_scene(&r.scene_file.to_string_lossy(), &[])
        .unwrap_or_else(|e| panic!("{scene_name}: octolux does not load {}: {e}", r.scene_file.display()));
    let small_ref = common::downsample(&r.image, SHRINK);
    let mut desc = loaded.desc;
    desc.film.width = small_ref.width;
    desc.film.height = small_ref.height;
    let scene = Scene::prepare(desc, BackendKind::Auto).unwrap_or_else(|e| panic!("{scene_name}: scene does not prepare: {e}"));
    let ref_max = max_channel(&r.image);
    let ref_means = channel_means(&small_ref);
    let mut failures = Vec::new();
    for name in CACHE_INTEGRATORS {
        let t0 = Instant::now();
        let integrator = match build(&settings_for(name, r.max_depth), &scene) {
            Ok(i) => i,
            Err(e) => {
                failures.push(format!("{name} does not build: {e}"));
                continue;
            }
        };
        let build_s = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let (img, _) = render(&scene, &integrator, &RenderSettings { spp: SPP, seed: 1, ..Default::default() }, &|_, _| {});
        let render_s = t1.elapsed().as_secs_f64();
        let non_finite = img.data.iter().filter(|p| !p.is_finite()).count();
        let means = channel_means(&img);
        let max = max_channel(&img);
        let above = img.data.iter().filter(|p| p.max_element() > MAX_PIXEL_FACTOR * ref_max).count();
        let err = if non_finite == 0 { rel_mse_with(&img, &small_ref, &small_ref) } else { f64::NAN };
        println!(
            "{scene_name} {name}: {}x{} {PHOTONS} photons {SPP} spp, build {build_s:.2}s render {render_s:.2}s; \
             means {means:.4?} ref {ref_means:.4?}; relMSE {err:.3e}; max pixel {max:.3e} = {:.2}x the reference's max {ref_max:.3e} \
             ({above} pixels above {MAX_PIXEL_FACTOR}x); {non_finite} non-finite pixels",
            img.width,
            img.height,
            max / ref_max,
        );
        if non_finite > 0 {
            failures.push(format!("{name}: {non_finite} non-finite pixels"));
        }
        for c in 0..3 {
            if ref_means[c] > 0.0 && means[c] <= 0.0 {
                failures.push(format!("{name}: channel {c} is black (reference mean {:.4})", ref_means[c]));
            }
        }
        if above > 0 {
            failures.push(format!("{name}: {above} pixels above {MAX_PIXEL_FACTOR}x the reference's max (max {:.1}x)", max / ref_max));
        }
    }
    assert!(failures.is_empty(), "{scene_name}: {}", failures.join("; "));
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-collection/box",
    ignore = "needs ../shared/scenes/bitterli-collection/box (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn cache_integrators_render_box() {
    check("box");
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-collection/classroom",
    ignore = "needs ../shared/scenes/bitterli-collection/classroom (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn cache_integrators_render_classroom() {
    check("classroom");
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-collection/dining-room",
    ignore = "needs ../shared/scenes/bitterli-collection/dining-room (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn cache_integrators_render_dining_room() {
    check("dining-room");
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-collection/sponza",
    ignore = "needs ../shared/scenes/bitterli-collection/sponza (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn cache_integrators_render_sponza() {
    check("sponza");
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-collection/torus",
    ignore = "needs ../shared/scenes/bitterli-collection/torus (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn cache_integrators_render_torus() {
    check("torus");
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-collection/veach-lamp",
    ignore = "needs ../shared/scenes/bitterli-collection/veach-lamp (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn cache_integrators_render_veach_lamp() {
    check("veach-lamp");
}
