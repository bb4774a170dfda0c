//! End-to-end check of the paper's renderer: an `octree` render of the built-in `cornell-box`
//! against the Mitsuba 3 path-traced reference (`tests/refs/cornell-box.exr`, max_depth -1).
//!
//! Bound (measured, 128², 32 spp, 300k photons, default settings = geometry-area estimator):
//! relMSE 1.31e-3 (seed 0) and 1.38e-3 (seed 5); the paper's own estimator gives 8.7e-3 with an
//! image 8% too dark (its `ΔA` = cell face area ignores the 1/cos of the photon's incidence and
//! the cell's real surface). We assert relMSE ≤ 2.0e-3 (about 1.5x the measured value, room for
//! the seed-to-seed spread, while the paper's estimator's bias is 4x above it), every channel
//! mean within 2% of the reference, and that the corrected estimator beats the paper's.

use octolux::accel::BackendKind;
use octolux::caches::Estimator;
use octolux::integrators::octree::{OctreeIntegrator, OctreeIntegratorSettings};
use octolux::integrators::Integrator;
use octolux::metrics::compare;
use octolux::prepared::Scene;
use octolux::render::{render, RenderSettings};
use std::path::Path;

fn octree_render(estimator: Option<Estimator>) -> octolux::metrics::ImageErrors {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let reference = octolux_io::image_io::read_exr(&root.join("tests/refs/cornell-box.exr")).expect("reference");
    let mut desc = octolux_io::builtin::scene("cornell-box").expect("built-in scene");
    desc.film.width = reference.width;
    desc.film.height = reference.height;
    let scene = Scene::prepare(desc, BackendKind::Auto).expect("scene");
    let mut s = OctreeIntegratorSettings::default();
    s.photons.photons = 300_000;
    if let Some(e) = estimator {
        s.global.estimator = e;
        s.caustic.estimator = e;
    }
    let integrator = Integrator::Octree(Box::new(OctreeIntegrator::build(&scene, s).expect("octree builds")));
    let (img, _) = render(&scene, &integrator, &RenderSettings { spp: 32, seed: 0, ..Default::default() }, &|_, _| {});
    compare(&img, &reference).expect("same size")
}

#[test]
fn octree_render_of_cornell_box_matches_the_path_traced_reference() {
    let e = octree_render(None);
    println!("octree (default estimator): {e:?}");
    assert!(e.rel_mse <= 2.0e-3, "relMSE {:.4e} above the measured bound 2.0e-3", e.rel_mse);
    for c in 0..3 {
        assert!(
            (e.mean[c] - e.mean_reference[c]).abs() <= 0.02 * e.mean_reference[c],
            "channel {c}: mean {} vs {}",
            e.mean[c],
            e.mean_reference[c]
        );
    }
    let paper = octree_render(Some(Estimator::Paper));
    println!("octree (paper's estimator): {paper:?}");
    assert!(paper.rel_mse > e.rel_mse, "the corrected estimator should be closer to the reference than the paper's");
}
