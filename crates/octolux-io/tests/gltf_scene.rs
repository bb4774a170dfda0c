//! glTF 2.0 scenes (issue 15, item 3): a scene built and exported by Blender
//! (`tests/scenes/gltf/scene.glb`, made by `tools/blender/make_gltf_scene.py`) loads with its
//! camera, meshes, materials, texture, emissive panel and point light, and renders the image
//! of the same scene written as Mitsuba XML from Blender's data (`scene.xml`): the difference
//! between the two renders is the renders' noise, measured between two seeds of the XML.

use octolux::accel::BackendKind;
use octolux::integrators::{build, IntegratorSettings};
use octolux::metrics::{channel_means, rel_mse_with};
use octolux::render::{render, RenderSettings};
use octolux::scene::material::Material;
use octolux::scene::{Light, Scene};
use octolux_io::load_scene;
use std::path::PathBuf;

fn scene_file(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes/gltf").join(name).display().to_string()
}

#[test]
fn blender_gltf_loads_every_part() {
    let l = load_scene(&scene_file("scene.glb"), &[]).unwrap();
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let d = &l.desc;
    assert_eq!(d.shapes.len(), 10, "room (6), panel, sphere, two cubes");
    assert_eq!(d.shapes.iter().filter(|s| s.emission.is_some()).count(), 1, "the emissive panel");
    let e = d.shapes.iter().find_map(|s| s.emission).unwrap();
    assert!((e.x - 12.0).abs() < 1e-3 && (e.z - 9.6).abs() < 1e-3, "panel radiance {e}");
    assert_eq!(d.images.len(), 1, "the checker texture");
    assert!(d.materials.iter().any(|m| matches!(m, Material::TwoSided { front, .. } if matches!(**front, Material::Blend { .. }))));
    match d.lights.as_slice() {
        [Light::Point { intensity, .. }] => {
            let expect = 60.0 / (4.0 * std::f32::consts::PI); // Blender's 60 W point light, in W/sr
            assert!((intensity.x - expect).abs() < 1e-3 * expect, "{intensity} vs {expect}");
        }
        other => panic!("expected one point light, got {other:?}"),
    }
    assert_eq!(l.sensors.len(), 1);
    assert_eq!((d.film.width, d.film.height), (640, 480), "the camera's 4:3 aspect ratio");
    let x = load_scene(&scene_file("scene.xml"), &[]).unwrap();
    let (a, b) = (d.camera.to_world, x.desc.camera.to_world);
    assert!(a.abs_diff_eq(b, 1e-5), "cameras differ:\n{a}\n{b}");
    assert!((d.camera.fov_deg - x.desc.camera.fov_deg).abs() < 1e-4);
}

#[test]
fn blender_gltf_renders_as_the_same_scene_in_mitsuba_xml() {
    let render_scene = |name: &str, seed: u64| {
        let mut desc = load_scene(&scene_file(name), &[]).unwrap().desc;
        desc.film.width = 96;
        desc.film.height = 72;
        let scene = Scene::prepare(desc, BackendKind::Bvh).unwrap();
        let integrator = build(&IntegratorSettings::default_for("path").unwrap(), &scene).unwrap();
        render(&scene, &integrator, &RenderSettings { spp: 64, seed, ..Default::default() }, &|_, _| {}).0
    };
    let g = render_scene("scene.glb", 1);
    let x1 = render_scene("scene.xml", 2);
    let x2 = render_scene("scene.xml", 3);
    let noise = rel_mse_with(&x1, &x2, &x1);
    let err = rel_mse_with(&g, &x1, &x1);
    let (mg, mx) = (channel_means(&g), channel_means(&x1));
    println!("glTF vs XML relMSE {err:.4e}, XML seed-to-seed {noise:.4e}; means {mg:?} vs {mx:?}");
    assert!(err <= 1.3 * noise, "glTF vs XML relMSE {err:.4e} exceeds the noise between two XML renders {noise:.4e}");
    for c in 0..3 {
        assert!((mg[c] / mx[c] - 1.0).abs() < 0.02, "channel {c}: mean {} vs {}", mg[c], mx[c]);
    }
}

/// Truncated and corrupted copies of the Blender file give an error or a scene, never a panic.
#[test]
fn damaged_gltf_files_are_refused_without_panicking() {
    let bytes = std::fs::read(scene_file("scene.glb")).unwrap();
    let dir = std::env::temp_dir().join(format!("octolux-gltf-damage-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("damaged.glb");
    let mut refused = 0;
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let cases = (0..bytes.len()).step_by(211).map(|n| bytes[..n].to_vec()).chain((0..300).map(|_| {
        let mut b = bytes.clone();
        for _ in 0..1 + next() % 8 {
            let i = (next() % b.len() as u64) as usize;
            b[i] = next() as u8;
        }
        b
    }));
    for case in cases {
        std::fs::write(&file, &case).unwrap();
        match load_scene(&file.display().to_string(), &[]) {
            Err(e) => {
                assert!(e.to_string().contains("damaged.glb"), "the error names the file: {e}");
                refused += 1;
            }
            Ok(l) => {
                let _ = Scene::prepare(l.desc, BackendKind::Bvh);
            }
        }
    }
    assert!(refused > 300, "only {refused} damaged files refused");
    let _ = std::fs::remove_dir_all(&dir);
}
