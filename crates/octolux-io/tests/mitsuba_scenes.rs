//! The shared reference scenes load with the right camera, film, materials and lights. Each
//! test passes with one `skip:` line when its scene is absent (see `octolux_io::shared`).

use glam::Vec3;
use octolux::math::Color;
use octolux::scene::camera::FovAxis;
use octolux::scene::material::{Material, Texture};
use octolux::scene::{Geometry, PixelFilter};
use octolux_io::mitsuba::load;
use std::path::PathBuf;

/// The scene `rel` of the shared folder, or `None` after one skip line.
fn shared(rel: &str) -> Option<PathBuf> {
    octolux_io::shared::shared_scene(rel)
}

fn defs(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
    pairs.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect()
}

#[test]
#[cfg_attr(
    missing = "scenes/mitsuba-tutorials-cbox",
    ignore = "needs ../shared/scenes/mitsuba-tutorials-cbox (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn mitsuba_tutorial_cornell_box() {
    let Some(path) = shared("mitsuba-tutorials-cbox/cbox.xml") else { return };
    let s = load(&path, &[]).unwrap();
    assert!(s.warnings.is_empty(), "{:#?}", s.warnings);
    let d = &s.desc;
    d.validate().unwrap();
    assert_eq!((d.film.width, d.film.height, d.film.filter), (256, 256, PixelFilter::Tent));
    assert_eq!(d.hints.spp, Some(128));
    assert_eq!(d.hints.max_depth, Some(6));
    assert_eq!(d.hints.integrator.as_deref(), Some("path"));
    assert_eq!((d.camera.fov_deg, d.camera.fov_axis, d.camera.near_clip), (39.3077, FovAxis::Smaller, 0.001));
    assert!(d.camera.to_world.transform_point3(Vec3::ZERO).abs_diff_eq(Vec3::new(0.0, 0.0, 4.0), 1e-6));
    assert_eq!(d.shapes.len(), 8);
    let light = &d.shapes[0];
    assert_eq!(light.name, "light");
    assert_eq!(light.emission, Some(Color::new(18.387, 13.9873, 6.75357)));
    let by_name = |n: &str| d.shapes.iter().find(|s| s.name == n).unwrap_or_else(|| panic!("no shape {n}"));
    assert_eq!(
        d.materials[by_name("redwall").material as usize],
        Material::Diffuse { reflectance: Texture::Const(Color::new(0.570068, 0.0430135, 0.0443706)) }
    );
    let Geometry::Sphere { center, radius } = by_name("mirrorsphere").geometry else { panic!("mirror sphere is analytic") };
    assert!(center.abs_diff_eq(Vec3::new(-0.3, -0.5, 0.2), 1e-6) && (radius - 0.5).abs() < 1e-6);
    assert_eq!(
        d.materials[by_name("mirrorsphere").material as usize],
        Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::ONE }
    );
    match d.materials[by_name("glasssphere").material as usize] {
        Material::Dielectric { eta, .. } => assert!((eta - 1.5046 / 1.000277).abs() < 1e-6),
        ref m => panic!("{m:?}"),
    }
    // The luminaire was moved down by 1 cm; the room spans [-1, 1]^3.
    let b = d.bounds();
    assert!(b.min.abs_diff_eq(Vec3::splat(-1.0), 0.02) && b.max.abs_diff_eq(Vec3::splat(1.0), 0.02), "{b:?}");
    let Geometry::Mesh(m) = &light.geometry else { panic!() };
    assert!(m.positions.iter().all(|p| (p.y - 0.99).abs() < 1e-3), "luminaire translated to y = 0.99");
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-cornell-box",
    ignore = "needs ../shared/scenes/bitterli-cornell-box (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn bitterli_cornell_box_mitsuba_05() {
    let Some(path) = shared("bitterli-cornell-box/scene_mitsuba.xml") else { return };
    let s = load(&path, &[]).unwrap();
    let d = &s.desc;
    d.validate().unwrap();
    assert_eq!((d.film.width, d.film.height, d.film.filter), (1024, 1024, PixelFilter::Tent));
    assert_eq!((d.hints.spp, d.hints.max_depth), (Some(64), Some(65)));
    assert_eq!((d.camera.fov_deg, d.camera.fov_axis), (19.5, FovAxis::X));
    assert!(d.camera.to_world.transform_point3(Vec3::ZERO).abs_diff_eq(Vec3::new(0.0, 1.0, 6.8), 1e-6));
    assert!(d.camera.to_world.transform_vector3(Vec3::Z).abs_diff_eq(-Vec3::Z, 1e-6));
    assert_eq!(d.shapes.len(), 8);
    assert_eq!(d.materials.len(), 8, "the eight top-level twosided bsdfs");
    let light = d.shapes.last().unwrap();
    assert_eq!(light.emission, Some(Color::new(17.0, 12.0, 4.0)));
    assert!(
        matches!(&d.materials[light.material as usize], Material::TwoSided { front, .. } if **front == Material::Diffuse { reflectance: Texture::Const(Color::ZERO) })
    );
    // Bitterli's box: floor at y = 0, ceiling at y = 2, walls at x = +-1, back wall at z = -1.
    let b = d.bounds();
    assert!(b.min.abs_diff_eq(Vec3::new(-1.0, 0.0, -1.0), 1e-4) && b.max.abs_diff_eq(Vec3::new(1.0, 2.0, 1.0), 1e-4), "{b:?}");
    // One warning per ignored 0.5 setting that could change the image, each naming the file
    // and line (`banner` and `file_format` only change the output file: accepted silently).
    let file = path.display().to_string();
    for (line, name) in [(6, "strict_normals"), (23, "exposure"), (25, "gamma"), (28, "tonemap_method")] {
        let prefix = format!("{file}:{line}:");
        assert!(s.warnings.iter().any(|w| w.starts_with(&prefix) && w.contains(name)), "{prefix} {name}: {:#?}", s.warnings);
    }
    assert_eq!(s.warnings.len(), 4, "{:#?}", s.warnings);
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-cornell-box",
    ignore = "needs ../shared/scenes/bitterli-cornell-box (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn bitterli_cornell_box_parametrised_variants() {
    let Some(path) = shared("bitterli-cornell-box/scene_mi3.xml") else { return };
    let s = load(&path, &[]).unwrap();
    assert!(s.warnings.is_empty(), "{:#?}", s.warnings);
    assert_eq!((s.desc.film.width, s.desc.film.filter, s.desc.hints.spp), (512, PixelFilter::Box, Some(64)));
    let s = load(&path, &defs(&[("res", "32"), ("spp", "4"), ("rfilter", "gaussian"), ("max_depth", "3")])).unwrap();
    assert_eq!((s.desc.film.width, s.desc.film.height), (32, 32));
    assert_eq!(s.desc.film.filter, PixelFilter::Gaussian { stddev: 0.5 });
    assert_eq!((s.desc.hints.spp, s.desc.hints.max_depth), (Some(4), Some(3)));

    // The PLY variant describes the same room.
    let Some(ply) = shared("bitterli-cornell-box/scene_mi3_ply.xml") else { return };
    let p = load(&ply, &[]).unwrap();
    assert!(p.warnings.is_empty(), "{:#?}", p.warnings);
    p.desc.validate().unwrap();
    assert_eq!(p.desc.shapes.len(), 8);
    let (a, b) = (s.desc.bounds(), p.desc.bounds());
    assert!(a.min.abs_diff_eq(b.min, 1e-4) && a.max.abs_diff_eq(b.max, 1e-4), "{a:?} vs {b:?}");
    let area = |d: &octolux::scene::SceneDesc| -> f64 {
        d.shapes.iter().map(|s| if let Geometry::Mesh(m) = &s.geometry { m.area() } else { 0.0 }).sum()
    };
    assert!((area(&s.desc) - area(&p.desc)).abs() < 1e-3 * area(&s.desc), "{} vs {}", area(&s.desc), area(&p.desc));
    assert!(
        p.desc.shapes.iter().all(|s| matches!(&s.geometry, Geometry::Mesh(m) if m.normals.is_none())),
        "face_normals drops vertex normals"
    );
}
