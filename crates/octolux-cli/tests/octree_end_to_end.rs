//! End-to-end checks of the `octree` integrator against the Mitsuba 3 path-traced references
//! (`tests/refs/*.exr`; the renders are deterministic).
//!
//! The paper's renderer (`mode = paper`: the cache read at the first vertex) on the built-in
//! `cornell-box` (128², 32 spp, 300k photons, the default octree settings = geometry-area
//! estimator, split by surface normal, compression exact for the surfaces' normals): relMSE
//! 3.87e-4 (6.05e-4 before its direct light had MIS), channel means within 0.2%. The paper's
//! configuration (its estimator, split and factors) gives 7.9e-3 with an image 8% too dark (its
//! `ΔA` = cell face area ignores the 1/cos of the photon's incidence and the cell's real
//! surface). We assert relMSE ≤ 8e-4, every channel mean within 0.5%, and that the corrected
//! estimator beats the paper's.

use octolux::accel::BackendKind;
use octolux::caches::{Estimator, Split};
use octolux::integrators::octree::{Mode, OctreeIntegrator, OctreeIntegratorSettings};
use octolux::integrators::Integrator;
use octolux::metrics::compare;
use octolux::render::{render, RenderSettings};
use octolux::scene::Scene;
use std::path::Path;

fn octree_render(estimator: Option<Estimator>) -> octolux::metrics::ImageErrors {
    octree_render_of("cornell-box", -1, estimator, Mode::Paper)
}

fn octree_render_of(name: &str, max_depth: i32, estimator: Option<Estimator>, mode: Mode) -> octolux::metrics::ImageErrors {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let reference = octolux_io::image_io::read_exr(&root.join(format!("tests/refs/{name}.exr"))).expect("reference");
    let mut desc = octolux_io::builtin::scene(name).expect("built-in scene");
    desc.film.width = reference.width;
    desc.film.height = reference.height;
    let scene = Scene::prepare(desc, BackendKind::Auto).expect("scene");
    let mut s = OctreeIntegratorSettings::default();
    s.photons.photons = 300_000;
    s.max_depth = max_depth;
    s.mode = mode;
    if let Some(e) = estimator {
        s.global.estimator = e;
        s.caustic.estimator = e;
        if e == Estimator::Paper {
            // the paper's configuration whole: its split of the photons by direction too
            s.global.split = Split::Direction;
            s.caustic.split = Split::Direction;
        }
    }
    let integrator = Integrator::Octree(Box::new(OctreeIntegrator::build(&scene, s).expect("octree builds")));
    let (img, _) = render(&scene, &integrator, &RenderSettings { spp: 32, seed: 0, ..Default::default() }, &|_, _| {});
    compare(&img, &reference).expect("same size")
}

#[test]
fn octree_render_of_cornell_box_matches_the_path_traced_reference() {
    let e = octree_render(None);
    println!("octree (default estimator): {e:?}");
    assert!(e.rel_mse <= 8.0e-4, "relMSE {:.4e} above the measured bound 8.0e-4", e.rel_mse);
    assert_means_within(&e, 0.005);
    let paper = octree_render(Some(Estimator::Paper));
    println!("octree (paper's estimator): {paper:?}");
    assert!(paper.rel_mse > e.rel_mse, "the corrected estimator should be closer to the reference than the paper's");
}

fn assert_means_within(e: &octolux::metrics::ImageErrors, tol: f64) {
    for c in 0..3 {
        assert!(
            (e.mean[c] - e.mean_reference[c]).abs() <= tol * e.mean_reference[c],
            "channel {c}: mean {} vs {}",
            e.mean[c],
            e.mean_reference[c]
        );
    }
}

/// Caustics: cornell-spheres (mirror and glass spheres, max_depth 8 as its reference), default
/// mode: the caustic octree read where its leaves hold photons, the rest path-traced. Measured
/// here: 2.23e-3 (with the paper's direct read before this mode: 1.18e-3, mostly the cache's
/// bias, against this one's noise); bound 3e-3.
#[test]
fn octree_render_of_cornell_spheres_matches_the_path_traced_reference() {
    let e = octree_render_of("cornell-spheres", 8, None, Mode::Terminate);
    println!("cornell-spheres octree: {e:?}");
    assert!(e.rel_mse <= BOUND_SPHERES, "relMSE {:.4e} above the bound {BOUND_SPHERES:.1e}", e.rel_mse);
    assert_means_within(&e, 0.03);
}

/// The default mode (`terminate`) reads the cache one bounce from the camera where the path is
/// wide enough; its error at 32 spp is mostly noise. Measured 8.72e-4, bound 1.2e-3.
#[test]
fn terminated_octree_render_of_cornell_box_matches_the_path_traced_reference() {
    let e = octree_render_of("cornell-box", -1, None, Mode::Terminate);
    println!("cornell-box octree, mode=terminate: {e:?}");
    assert!(e.rel_mse <= BOUND_TERMINATE, "relMSE {:.4e} above the bound {BOUND_TERMINATE:.1e}", e.rel_mse);
    assert_means_within(&e, 0.01);
}

const BOUND_SPHERES: f64 = 3.0e-3;
const BOUND_TERMINATE: f64 = 1.2e-3;

/// Photons land on cornell-spheres' mirror and glass spheres, but are stored there only when
/// asked (`store_on_specular`, the paper's "every hit").
#[test]
fn photons_are_not_stored_on_purely_specular_surfaces_by_default() {
    use octolux::photon::trace::{trace_photons, PhotonSettings};
    use octolux::scene::Geometry;
    let desc = octolux_io::builtin::scene("cornell-spheres").expect("built-in scene");
    let spheres: Vec<(glam::Vec3, f32)> = desc
        .shapes
        .iter()
        .filter_map(|s| match s.geometry {
            Geometry::Sphere { center, radius } => Some((center, radius)),
            _ => None,
        })
        .collect();
    assert_eq!(spheres.len(), 2, "cornell-spheres has a mirror and a glass sphere");
    let scene = Scene::prepare(desc, BackendKind::Auto).expect("scene");
    let on_spheres = |store_on_specular: bool| {
        let maps = trace_photons(&scene, &PhotonSettings { photons: 50_000, store_on_specular, ..Default::default() }).expect("photons");
        maps.global
            .iter()
            .chain(&maps.caustic)
            .filter(|p| {
                // On a sphere: at its radius and above the floor it rests on (y = 0).
                spheres.iter().any(|&(c, r)| ((p.p - c).length() - r).abs() < 1e-3 * r && p.p.y > 1e-2)
            })
            .count()
    };
    assert_eq!(on_spheres(false), 0);
    assert!(on_spheres(true) > 100, "with store_on_specular the spheres get photons");
}
