//! The memory budget refuses photon counts before the photon pass allocates anything (the
//! issue's `--photons 1000000000000` aborted on allocation).

use octolux::accel::BackendKind;
use octolux::budget;
use octolux::glam::Vec3;
use octolux::photon::trace::{trace_photons, PhotonError, PhotonSettings};
use octolux::scene::material::{Material, Texture};
use octolux::scene::{Geometry, Light, Scene, SceneDesc, ShapeDesc};
use octolux::Color;

#[test]
fn photon_count_beyond_budget_is_refused_before_tracing() {
    budget::set_memory_limit(1 << 30);
    let desc = SceneDesc {
        shapes: vec![ShapeDesc {
            name: "ball".into(),
            geometry: Geometry::Sphere { center: Vec3::ZERO, radius: 1.0 },
            material: 0,
            emission: None,
            flip_normals: false,
        }],
        materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }],
        lights: vec![Light::Constant { radiance: Color::ONE }],
        ..Default::default()
    };
    let scene = Scene::prepare(desc, BackendKind::Bvh).expect("valid scene");
    let settings = PhotonSettings { photons: 1_000_000_000_000, ..Default::default() };
    let t = std::time::Instant::now();
    let e = trace_photons(&scene, &settings).unwrap_err();
    assert!(matches!(e, PhotonError::Budget(_)), "{e:?}");
    assert_eq!(
        e.to_string(),
        format!(
            "1000000000000 photons would need {} of memory, more than the limit of 1.0 GiB (set OCTOLUX_MEMORY_LIMIT to change the limit)",
            budget::format_bytes(1_000_000_000_000 * budget::PHOTON_BYTES)
        )
    );
    assert!(t.elapsed().as_secs_f64() < 1.0, "refused after {:?}", t.elapsed());
    // Within the budget the pass runs.
    let settings = PhotonSettings { photons: 1000, ..Default::default() };
    assert_eq!(trace_photons(&scene, &settings).unwrap().emitted, 1000);
}
