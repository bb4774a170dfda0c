//! `envmap` and `sunsky` from Mitsuba XML, both syntaxes: parameters, frames (Mitsuba 0.6's
//! `+y`-up sky against Mitsuba 3's `+z`), images decoded as Mitsuba decodes them, warnings for
//! the 0.6 parameters that have no equivalent, and the collection's three `sunsky` scenes
//! (skipped with one line each when `../shared` is absent).

use glam::{Mat3, Vec3};
use octolux::image::Image;
use octolux::math::Color;
use octolux::scene::sunsky::{SolarTime, SunSkyDesc, SUN_APERTURE_DEG};
use octolux::scene::Light;
use octolux_io::mitsuba::load_str;
use octolux_io::shared::shared_scene;
use std::path::PathBuf;

const SHAPE: &str = r#"<sensor type="perspective"><float name="fov" value="45"/></sensor>
    <shape type="sphere"><float name="radius" value="1"/></shape>"#;

fn scene(version: &str, body: &str) -> String {
    format!("<scene version=\"{version}\">{SHAPE}{body}</scene>")
}

fn tmp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("octolux-env-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn sunsky_of(lights: &[Light]) -> &SunSkyDesc {
    lights.iter().find_map(|l| if let Light::Sunsky(d) = l { Some(d) } else { None }).expect("a sunsky light")
}

#[test]
fn envmap_reads_exr_and_png_with_scale_and_frame() {
    let dir = tmp_dir("envmap");
    let img = Image { width: 4, height: 2, data: (0..8).map(|i| Color::new(i as f32, 0.5, 2.0)).collect() };
    octolux_io::image_io::write_exr(&dir.join("env.exr"), &img).unwrap();
    let xml = scene(
        "3.0.0",
        r#"<emitter type="envmap"><string name="filename" value="env.exr"/><float name="scale" value="2.5"/>
           <transform name="to_world"><rotate y="1" angle="90"/><scale value="3"/></transform></emitter>"#,
    );
    let s = load_str(&xml, &dir.join("a.xml"), &[]).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let Some(Light::Envmap { image, scale, to_world }) = s.desc.lights.first() else { panic!("{:?}", s.desc.lights) };
    assert_eq!(*scale, 2.5);
    let want = Mat3::from_rotation_y(90f32.to_radians());
    assert!((*to_world - want).to_cols_array().iter().all(|v| v.abs() < 1e-5), "{to_world}");
    assert_eq!(s.desc.images[*image as usize].data, img.data);

    // 8-bit images are decoded from sRGB, unless raw
    let png = image::RgbImage::from_raw(2, 1, vec![128, 128, 128, 255, 0, 64]).unwrap();
    png.save(dir.join("env.png")).unwrap();
    for (raw, want) in [(false, 0.2158605f32), (true, 128.0 / 255.0)] {
        let xml = scene(
            "3.0.0",
            &format!(r#"<emitter type="envmap"><string name="filename" value="env.png"/><boolean name="raw" value="{raw}"/></emitter>"#),
        );
        let s = load_str(&xml, &dir.join("a.xml"), &[]).unwrap();
        let Some(Light::Envmap { image, .. }) = s.desc.lights.first() else { panic!() };
        let got = s.desc.images[*image as usize].data[0].x;
        assert!((got - want).abs() < 1e-4, "raw {raw}: {got} vs {want}");
    }
    // a missing file is an error naming it
    let xml = scene("3.0.0", r#"<emitter type="envmap"><string name="filename" value="nope.exr"/></emitter>"#);
    let e = load_str(&xml, &dir.join("a.xml"), &[]).unwrap_err().to_string();
    assert!(e.contains("nope.exr"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mitsuba3_sunsky_parameters() {
    let xml = scene(
        "3.0.0",
        r#"<emitter type="sunsky"><vector name="sun_direction" x="0" y="0.6" z="0.8"/><float name="turbidity" value="4"/>
           <rgb name="albedo" value="0.1, 0.2, 0.3"/><float name="sun_scale" value="2"/><float name="sky_scale" value="0.5"/>
           <float name="sun_aperture" value="1.5"/></emitter>"#,
    );
    let s = load_str(&xml, &PathBuf::from("a.xml"), &[]).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let d = sunsky_of(&s.desc.lights);
    assert!((d.sun_direction - Vec3::new(0.0, 0.6, 0.8)).length() < 1e-6);
    assert_eq!((d.turbidity, d.sun_scale, d.sky_scale, d.sun_aperture_deg), (4.0, 2.0, 0.5, 1.5));
    assert!((d.albedo - Color::new(0.1, 0.2, 0.3)).abs().max_element() < 1e-6);
    assert_eq!(d.to_world, Mat3::IDENTITY);

    // the sun placed by date and place, in the local frame turned by to_world
    let xml = scene(
        "3.0.0",
        r#"<emitter type="sunsky"><float name="hour" value="10.5"/><float name="latitude" value="48.8"/>
           <transform name="to_world"><rotate x="1" angle="-90"/></transform></emitter>"#,
    );
    let s = load_str(&xml, &PathBuf::from("a.xml"), &[]).unwrap();
    let d = sunsky_of(&s.desc.lights);
    let local = SolarTime { hour: 10.5, latitude: 48.8, ..Default::default() }.sun_direction();
    assert!((d.sun_direction - d.to_world * local).length() < 1e-5);
    assert!((d.to_world * Vec3::Z - Vec3::Y).length() < 1e-5, "rotated zenith");

    // both a direction and a time: an error; out-of-range turbidity: an error
    for bad in [
        r#"<emitter type="sunsky"><vector name="sun_direction" x="0" y="0" z="1"/><float name="hour" value="9"/></emitter>"#,
        r#"<emitter type="sunsky"><float name="turbidity" value="12"/></emitter>"#,
    ] {
        assert!(load_str(&scene("3.0.0", bad), &PathBuf::from("a.xml"), &[]).is_err(), "{bad}");
    }
}

#[test]
fn mitsuba06_sunsky_is_y_up_with_its_parameter_names() {
    let xml = scene(
        "0.6.0",
        r#"<emitter type="sunsky"><float name="turbidity" value="3"/><vector name="sunDirection" x="0.3" y="0.9" z="0.1"/>
           <float name="skyScale" value="6"/><float name="sunScale" value="10"/><float name="sunRadiusScale" value="4"/></emitter>"#,
    );
    let s = load_str(&xml, &PathBuf::from("a.xml"), &[]).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let d = sunsky_of(&s.desc.lights);
    assert!((d.to_world * Vec3::Z - Vec3::Y).length() < 1e-6, "0.6 skies have +y up");
    assert!((d.sun_direction - Vec3::new(0.3, 0.9, 0.1).normalize()).length() < 1e-6);
    assert_eq!((d.sky_scale, d.sun_scale), (6.0, 10.0));
    assert!((d.sun_aperture_deg - 4.0 * SUN_APERTURE_DEG).abs() < 1e-5);
    assert!((d.albedo - Color::splat(0.2)).abs().max_element() < 1e-6, "0.6's default albedo (its code's)");

    // a 0.6 sun placed by time: Mitsuba 0.6's toSphere(θ, φ) = (sin φ sin θ, cos θ, -cos φ sin θ)
    let xml = scene("0.6.0", r#"<emitter type="sunsky"><float name="hour" value="9"/><float name="scale" value="3"/></emitter>"#);
    let s = load_str(&xml, &PathBuf::from("a.xml"), &[]).unwrap();
    let d = sunsky_of(&s.desc.lights);
    let m3 = SolarTime { hour: 9.0, ..Default::default() }.sun_direction();
    let (theta, phi) = (m3.z.acos(), m3.y.atan2(m3.x) + std::f32::consts::PI);
    let v06 = Vec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin());
    assert!((d.sun_direction - v06).length() < 1e-4, "{} vs {v06}", d.sun_direction);
    assert_eq!((d.sun_scale, d.sky_scale), (3.0, 3.0), "scale is the default of both");

    // parameters without an equivalent: one warning each, saying what was done
    let xml =
        scene("0.6.0", r#"<emitter type="sunsky"><float name="stretch" value="1.5"/><integer name="resolution" value="1024"/></emitter>"#);
    let s = load_str(&xml, &PathBuf::from("a.xml"), &[]).unwrap();
    assert_eq!(s.warnings.len(), 2, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("stretch") && s.warnings[0].contains("ignored"), "{}", s.warnings[0]);
    assert!(s.warnings[1].contains("resolution") && s.warnings[1].contains("evaluated"), "{}", s.warnings[1]);

    // sunRadiusScale = 0: the sun becomes a directional light (as in 0.6)
    let xml = scene(
        "0.6.0",
        r#"<emitter type="sunsky"><vector name="sunDirection" x="0" y="1" z="0"/><float name="sunRadiusScale" value="0"/></emitter>"#,
    );
    let s = load_str(&xml, &PathBuf::from("a.xml"), &[]).unwrap();
    assert_eq!(sunsky_of(&s.desc.lights).sun_scale, 0.0);
    let dir = s.desc.lights.iter().find_map(|l| {
        if let Light::Directional { direction, irradiance } = l {
            Some((*direction, *irradiance))
        } else {
            None
        }
    });
    let (direction, irradiance) = dir.expect("a directional sun");
    assert!((direction + Vec3::Y).length() < 1e-6 && irradiance.min_element() > 0.0);

    // 0.6's separate sky and sun plugins
    let xml = scene("0.6.0", r#"<emitter type="sky"><vector name="sunDirection" x="0" y="1" z="1"/></emitter>"#);
    let s = load_str(&xml, &PathBuf::from("a.xml"), &[]).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(sunsky_of(&s.desc.lights).sun_scale, 0.0);
}

#[test]
#[cfg_attr(
    all(
        missing = "scenes/bitterli-collection/classroom",
        missing = "scenes/bitterli-collection/dining-room",
        missing = "scenes/bitterli-collection/torus"
    ),
    ignore = "needs ../shared/scenes/bitterli-collection (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn collection_sunsky_scenes_load_without_sunsky_warnings() {
    for name in ["classroom", "dining-room", "torus"] {
        let Some(path) = shared_scene(&format!("bitterli-collection/{name}/scene.xml")) else { continue };
        let s = octolux_io::load_scene(&path.to_string_lossy(), &[]).unwrap_or_else(|e| panic!("{name}: {e}"));
        let d = sunsky_of(&s.desc.lights);
        println!("{name}: sun direction {} (world), zenith {}, aperture {}°", d.sun_direction, d.to_world * Vec3::Z, d.sun_aperture_deg);
        for w in &s.warnings {
            assert!(!w.contains("sunsky"), "{name}: {w}");
        }
        assert!(d.sun_direction.dot(d.to_world * Vec3::Z) > 0.0, "{name}: the sun is above the horizon");
    }
}
