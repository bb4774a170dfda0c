//! Degenerate geometry (issue 12, item 8): a mesh of a million coincident copies of one
//! triangle renders as fast as the triangle alone, and gives the same image. Before the BVH
//! dropped duplicates, every ray through the triangle visited a tree of a million overlapping
//! boxes to the bottom (13 ms per sample).

use octolux::accel::BackendKind;
use octolux::glam::Vec3;
use octolux::integrators::{path::PathSettings, Integrator};
use octolux::render::{render, RenderSettings};
use octolux::scene::camera::{look_at, CameraDesc, FovAxis};
use octolux::scene::material::{Material, Texture};
use octolux::scene::{FilmDesc, Geometry, Light, PixelFilter, Scene, SceneDesc, ShapeDesc, TriMesh};
use octolux::Color;
use std::time::{Duration, Instant};

const COPIES: usize = 1_000_000;

/// A triangle (repeated `copies` times, sharing its vertices when `shared`, else each copy with
/// vertices of its own) under a constant sky, seen from the front.
fn scene(copies: usize, shared: bool) -> SceneDesc {
    let tri = [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
    let (positions, indices) = if shared {
        (tri.to_vec(), vec![[0, 1, 2]; copies])
    } else {
        let positions = (0..copies).flat_map(|_| tri).collect();
        let indices = (0..copies as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        (positions, indices)
    };
    let normals = Some(vec![Vec3::Z; positions.len()]);
    SceneDesc {
        shapes: vec![ShapeDesc {
            name: "coincident".into(),
            geometry: Geometry::Mesh(TriMesh { positions, normals, uvs: None, indices }),
            material: 0,
            emission: None,
            flip_normals: false,
        }],
        materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }],
        lights: vec![Light::Constant { radiance: Color::ONE }],
        camera: CameraDesc {
            to_world: look_at(Vec3::new(0.3, 0.2, 4.0), Vec3::ZERO, Vec3::Y),
            fov_deg: 40.0,
            fov_axis: FovAxis::X,
            near_clip: 1e-3,
        },
        film: FilmDesc { width: 32, height: 32, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    }
}

fn render_scene(desc: SceneDesc, backend: BackendKind) -> (octolux::image::Image, Duration) {
    let scene = Scene::prepare(desc, backend).expect("valid scene");
    let integrator = Integrator::Path(PathSettings { max_depth: 3, ..Default::default() });
    let settings = RenderSettings { spp: 8, seed: 7, ..Default::default() };
    let t = Instant::now();
    let img = render(&scene, &integrator, &settings, &|_, _| {}).0;
    (img, t.elapsed())
}

/// Embree when it can be loaded (a `skip:` line otherwise, a failure with
/// `OCTOLUX_REQUIRE_EMBREE=1`).
fn embree_available() -> bool {
    if octolux::accel::Accel::embree_available() {
        return true;
    }
    octolux_probe::skip("embree", "Embree cannot be loaded; the Embree case is not run");
    false
}

/// What this crate's build probed as absent (Embree: the test below compiled as ignored) is
/// still absent and not required (`crates/octolux-probe`).
#[test]
fn the_build_probe_still_holds() {
    octolux_probe::check_build_probe(env!("OCTOLUX_PROBE_MISSING"), env!("CARGO_MANIFEST_DIR"));
}

#[test]
fn million_coincident_triangles_render_in_seconds() {
    check_backend(BackendKind::Bvh);
}

#[test]
#[cfg_attr(missing = "embree", ignore = "needs Embree 3 (Debian's libembree3-3, or $OCTOLUX_EMBREE_LIB)")]
fn million_coincident_triangles_render_in_seconds_with_embree() {
    if embree_available() {
        check_backend(BackendKind::Embree);
    }
}

fn check_backend(backend: BackendKind) {
    let (reference, _) = render_scene(scene(1, true), backend);
    // The triangle covers the middle of the image, the sky (radiance 1) the corners.
    let (centre, corner) = (reference.data[16 * 32 + 16], reference.data[0]);
    assert!(centre.x < 0.9 && corner.x == 1.0, "centre {centre}, corner {corner}");
    for shared in [true, false] {
        let t = Instant::now();
        let (img, render_time) = render_scene(scene(COPIES, shared), backend);
        let total = t.elapsed();
        println!("{backend:?}: {COPIES} coincident triangles (shared vertices: {shared}): render {render_time:?}, with build {total:?}");
        // 32x32 pixels x 8 samples: one triangle takes milliseconds; without deduplication
        // each of the 8192 camera rays alone visits a million triangles.
        assert!(render_time < Duration::from_secs(2), "render took {render_time:?}");
        assert!(total < Duration::from_secs(20), "build and render took {total:?}");
        assert_eq!(img.data, reference.data, "the copies must look like the single triangle");
    }
}
