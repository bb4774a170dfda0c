//! The Mitsuba scene language: `$param` / `<default>` / defines, `<include>`, references, the
//! 0.5 dialect, warnings for unsupported content, and errors that name the file and line.

use glam::Vec3;
use octolux::math::Color;
use octolux::scene::material::{Material, Texture};
use octolux::scene::Light;
use octolux::scene::{Geometry, PixelFilter};
use octolux_io::mitsuba::{load, load_str};
use octolux_io::IoError;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/xml").join(name)
}

fn defs(pairs: &[(&str, &str)]) -> Vec<(String, String)> {
    pairs.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect()
}

const PARAM_SCENE: &str = r#"<scene version="3.0.0">
    <default name="res" value="64"/>
    <default name="spp" value="16"/>
    <default name="filter" value="gaussian"/>
    <default name="res" value="999"/>
    <integrator type="path"><integer name="max_depth" value="$depth"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="$fov"/>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="$res"/>
            <integer name="height" value="$res$res"/>
            <rfilter type="$filter"/>
        </film>
    </sensor>
    <default name="depth" value="7"/>
</scene>"#;

#[test]
fn parameters_defaults_and_overrides() {
    let path = Path::new("/virtual/params.xml");
    // $depth is used before its <default>: an error, as in Mitsuba (document order).
    let err = load_str(PARAM_SCENE, path, &defs(&[("fov", "30")])).unwrap_err().to_string();
    assert!(err.contains("/virtual/params.xml:6:") && err.contains("$depth"), "{err}");

    let s = load_str(PARAM_SCENE, path, &defs(&[("fov", "30"), ("depth", "3")])).unwrap();
    assert_eq!(s.desc.film.width, 64, "first <default> wins over a later one");
    assert_eq!(s.desc.film.height, 6464, "substitution inside a longer value");
    assert_eq!(s.desc.hints.spp, Some(16));
    assert_eq!(s.desc.hints.max_depth, Some(3));
    assert_eq!(s.desc.camera.fov_deg, 30.0);
    assert_eq!(s.desc.film.filter, PixelFilter::Gaussian { stddev: 0.5 });

    // Defines override defaults; longer names are substituted first ($res vs $resx is not an issue here).
    let s = load_str(PARAM_SCENE, path, &defs(&[("fov", "30"), ("depth", "3"), ("res", "12"), ("filter", "box")])).unwrap();
    assert_eq!((s.desc.film.width, s.desc.film.height), (12, 1212));
    assert_eq!(s.desc.film.filter, PixelFilter::Box);

    // An undefined parameter is an error naming it.
    let err = load_str(PARAM_SCENE, path, &defs(&[("depth", "3")])).unwrap_err().to_string();
    assert!(err.contains("/virtual/params.xml:8:") && err.contains("$fov"), "{err}");
}

#[test]
fn longer_parameter_names_are_replaced_first() {
    let xml = r#"<scene version="3.0.0">
        <default name="a" value="1"/>
        <default name="ab" value="2"/>
        <shape type="sphere"><float name="radius" value="$ab"/></shape>
    </scene>"#;
    let s = load_str(xml, Path::new("/virtual/ab.xml"), &[]).unwrap();
    match s.desc.shapes[0].geometry {
        Geometry::Sphere { radius, .. } => assert_eq!(radius, 2.0),
        _ => panic!("not a sphere"),
    }
}

#[test]
fn include_references_and_dialect() {
    let path = data("include_main.xml");
    let s = load(&path, &[]).unwrap();
    assert!(s.warnings.iter().all(|w| !w.contains("roughconductor")), "{:?}", s.warnings);
    assert_eq!(s.desc.shapes.len(), 3);
    let (floor, bx, ball) = (&s.desc.shapes[0], &s.desc.shapes[1], &s.desc.shapes[2]);
    assert_eq!((floor.name.as_str(), bx.name.as_str()), ("floor", "box"));
    // Both references resolve to the one included material (instantiated once).
    assert_eq!(floor.material, bx.material);
    match &s.desc.materials[floor.material as usize] {
        Material::RoughConductor { distribution, eta, specular_reflectance, .. } => {
            assert_eq!(distribution.constant().map(|d| (d.alpha_u, d.alpha_v)), Some((0.25, 0.25)), "$roughness from the including file");
            assert!((eta.x - 0.143036).abs() < 1e-5, "Au preset: {eta}");
            assert_eq!(*specular_reflectance, Color::splat(0.9), "camelCase name of the 0.5 dialect");
        }
        m => panic!("wrong material {m:?}"),
    }
    // A shape without bsdf gets Mitsuba's default diffuse 0.5.
    assert_eq!(s.desc.materials[ball.material as usize], Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) });
    // The spot light of the included 0.5 file (toWorld, lookAt, cutoffAngle).
    let [Light::Spot { position, frame, intensity, cos_cutoff, cos_falloff_start }] = s.desc.lights.as_slice() else {
        panic!("lights: {:?}", s.desc.lights)
    };
    assert!(position.abs_diff_eq(Vec3::new(1.0, 2.0, 3.0), 1e-6));
    assert!(frame.n.abs_diff_eq(-Vec3::new(1.0, 2.0, 3.0).normalize(), 1e-6));
    assert!((frame.s.cross(frame.t) - frame.n).length() < 1e-5);
    assert_eq!(*intensity, Color::new(5.0, 6.0, 7.0));
    assert!((cos_cutoff - 30f32.to_radians().cos()).abs() < 1e-6);
    assert!((cos_falloff_start - 22.5f32.to_radians().cos()).abs() < 1e-6, "beam_width defaults to 3/4 of the cutoff");
    // The cube was scaled by 0.5.
    match &bx.geometry {
        Geometry::Mesh(m) => assert!((m.area() - 6.0).abs() < 1e-5),
        _ => panic!("cube is a mesh"),
    }
    // Overriding a parameter used inside the included file.
    let s = load(&path, &defs(&[("light_x", "-4")])).unwrap();
    let Light::Spot { position, .. } = &s.desc.lights[0] else { panic!() };
    assert_eq!(position.x, -4.0);
}

#[test]
fn missing_include_and_unknown_reference_are_errors() {
    let xml = "<scene version=\"3.0.0\">\n<include filename=\"nowhere.xml\"/>\n</scene>";
    let err = load_str(xml, Path::new("/virtual/inc.xml"), &[]).unwrap_err().to_string();
    assert!(err.starts_with("/virtual/inc.xml:2:") && err.contains("nowhere.xml"), "{err}");

    let xml = "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<ref id=\"ghost\"/>\n</shape>\n</scene>";
    let err = load_str(xml, Path::new("/virtual/ref.xml"), &[]).unwrap_err().to_string();
    assert!(err.starts_with("/virtual/ref.xml:3:") && err.contains("\"ghost\""), "{err}");

    let xml = "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"a\"/>\n<bsdf type=\"diffuse\" id=\"a\"/>\n</scene>";
    let err = load_str(xml, Path::new("/virtual/dup.xml"), &[]).unwrap_err().to_string();
    assert!(err.starts_with("/virtual/dup.xml:3:") && err.contains("duplicate id"), "{err}");
}

#[test]
fn unsupported_content_warns_with_file_and_line() {
    let path = data("unsupported.xml");
    let s = load(&path, &[]).unwrap();
    let file = path.display().to_string();
    let expect = [(3, "cylinder"), (4, "projector"), (8, "hair"), (10, "teapot")];
    for (line, word) in expect {
        let prefix = format!("{file}:{line}:");
        assert!(s.warnings.iter().any(|w| w.starts_with(&prefix) && w.contains(word)), "no warning {prefix} {word} in {:#?}", s.warnings);
    }
    assert_eq!(s.warnings.len(), expect.len() + 1, "one warning each, plus the missing sensor: {:#?}", s.warnings);
    // Loading went on: the sphere is there, with the default material for the hair bsdf.
    assert_eq!(s.desc.shapes.len(), 1);
    assert!(s.desc.lights.is_empty());
}

#[test]
fn ignored_parameters_warn_once_each() {
    let xml = r#"<scene version="0.5.0">
    <integrator type="path">
        <integer name="maxDepth" value="4"/>
        <boolean name="strictNormals" value="true"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <film type="ldrfilm">
            <float name="gamma" value="2.2"/>
            <float name="exposure" value="1"/>
            <string name="tonemapMethod" value="gamma"/>
            <integer name="width" value="32"/>
        </film>
        <sampler type="sobol"><integer name="sampleCount" value="8"/><integer name="scramble" value="3"/></sampler>
    </sensor>
</scene>"#;
    let s = load_str(xml, Path::new("/virtual/old.xml"), &[]).unwrap();
    assert_eq!(s.desc.hints.max_depth, Some(4));
    assert_eq!(s.desc.hints.spp, Some(8));
    assert_eq!((s.desc.film.width, s.desc.film.height), (32, 576), "Mitsuba's default height");
    assert_eq!(s.desc.film.filter, PixelFilter::Gaussian { stddev: 0.5 }, "Mitsuba 3's default filter");
    let expect = [(4, "strict_normals"), (9, "gamma"), (10, "exposure"), (11, "tonemap_method")];
    for (line, name) in expect {
        let prefix = format!("/virtual/old.xml:{line}:");
        assert!(s.warnings.iter().any(|w| w.starts_with(&prefix) && w.contains(name)), "{prefix} {name}: {:#?}", s.warnings);
    }
    assert_eq!(s.warnings.len(), expect.len(), "{:#?}", s.warnings);
}

#[test]
fn bad_input_errors_name_the_file() {
    // Malformed XML: the file and the line of the problem.
    let path = data("malformed.xml");
    let err = load(&path, &[]).unwrap_err();
    assert!(matches!(err, IoError::Parse { line: 5, .. }), "{err:?}");
    assert!(err.to_string().contains("malformed.xml"), "{err}");

    // NaN is not a number Mitsuba scenes may use.
    let path = data("nan.xml");
    let err = load(&path, &[]).unwrap_err().to_string();
    assert!(err.contains("nan.xml:4:") && err.contains("NaN"), "{err}");

    // A missing scene file.
    let path = data("no_such_scene.xml");
    let err = load(&path, &[]).unwrap_err();
    assert!(matches!(err, IoError::Os { .. }), "{err:?}");
    assert!(err.to_string().contains("no_such_scene.xml"), "{err}");

    // A missing mesh file names the XML file and line.
    let xml = "<scene version=\"3.0.0\">\n<shape type=\"ply\">\n<string name=\"filename\" value=\"gone.ply\"/>\n</shape>\n</scene>";
    let err = load_str(xml, Path::new("/virtual/mesh.xml"), &[]).unwrap_err().to_string();
    assert!(err.starts_with("/virtual/mesh.xml:2:") && err.contains("gone.ply"), "{err}");

    // Other bad values.
    let cases = [
        ("<integer name=\"width\" value=\"-3\"/>", "width"),
        ("<integer name=\"width\" value=\"12abc\"/>", "12abc"),
        ("<float name=\"width\" value=\"1e40\"/>", "1e40"),
    ];
    for (prop, word) in cases {
        let xml = format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<film type=\"hdrfilm\">\n{prop}\n</film>\n</sensor>\n</scene>"
        );
        let err = load_str(&xml, Path::new("/virtual/film.xml"), &[]).unwrap_err().to_string();
        assert!(err.starts_with("/virtual/film.xml:") && err.contains(word), "{prop}: {err}");
    }
}

#[test]
fn materials_and_colours() {
    let xml = r##"<scene version="3.0.0">
    <bsdf type="dielectric" id="water">
        <string name="int_ior" value="water"/>
        <float name="ext_ior" value="1.0"/>
    </bsdf>
    <bsdf type="thindielectric" id="thin"/>
    <bsdf type="conductor" id="mirror"/>
    <bsdf type="conductor" id="custom">
        <rgb name="eta" value="0.2 0.9 1.1"/>
        <rgb name="k" value="3.9, 2.4, 2.1"/>
    </bsdf>
    <bsdf type="roughplastic" id="plastic">
        <string name="distribution" value="ggx"/>
        <float name="alpha" value="0.3"/>
        <srgb name="diffuse_reflectance" value="#808080"/>
    </bsdf>
    <bsdf type="twosided" id="two">
        <bsdf type="diffuse"><spectrum name="reflectance" value="0.25"/></bsdf>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </bsdf>
    <bsdf type="dielectric" id="bad"><float name="int_ior" value="1"/><float name="ext_ior" value="1"/></bsdf>
</scene>"##;
    let err = load_str(xml, Path::new("/virtual/mat.xml"), &[]).unwrap_err().to_string();
    assert!(err.starts_with("/virtual/mat.xml:21:") && err.contains("must differ"), "{err}");
    let xml =
        xml.replace(r#"<bsdf type="dielectric" id="bad"><float name="int_ior" value="1"/><float name="ext_ior" value="1"/></bsdf>"#, "");
    let s = load_str(&xml, Path::new("/virtual/mat.xml"), &[]).unwrap();
    let m = &s.desc.materials;
    assert_eq!(m.len(), 6, "top-level bsdfs in document order");
    assert!(matches!(m[0], Material::Dielectric { eta, .. } if eta == 1.333));
    assert!(matches!(m[1], Material::ThinDielectric { eta, .. } if (eta - 1.5046 / 1.000277).abs() < 1e-6));
    assert_eq!(m[2], Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::ONE });
    assert_eq!(
        m[3],
        Material::Conductor { eta: Color::new(0.2, 0.9, 1.1), k: Color::new(3.9, 2.4, 2.1), specular_reflectance: Color::ONE }
    );
    match &m[4] {
        Material::RoughPlastic { diffuse_reflectance: Texture::Const(c), distribution, eta, .. } => {
            assert!((c.x - 0.215861).abs() < 1e-5, "sRGB 128 decoded to linear: {c}");
            assert_eq!(distribution.alpha_u, 0.3);
            assert!((eta - 1.49 / 1.000277).abs() < 1e-6, "polypropylene / air");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        m[5],
        Material::TwoSided {
            front: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.25)) }),
            back: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }),
        }
    );
    assert!(s.warnings.iter().all(|w| !w.contains("bsdf")), "{:#?}", s.warnings);
}

#[test]
fn emitters_and_spheres() {
    let xml = r#"<scene version="3.0.0">
    <emitter type="point"><point name="position" x="1" y="2" z="3"/><rgb name="intensity" value="10"/></emitter>
    <emitter type="directional"><vector name="direction" value="0, -2, 0"/><rgb name="irradiance" value="1 2 3"/></emitter>
    <emitter type="constant"><spectrum name="radiance" value="0.5"/></emitter>
    <shape type="sphere">
        <transform name="to_world"><scale value="0.5"/><translate x="-0.3" y="-0.5" z="0.2"/></transform>
        <emitter type="area"><rgb name="radiance" value="4, 5, 6"/></emitter>
    </shape>
    <shape type="sphere">
        <point name="center" value="1 0 0"/><float name="radius" value="2"/>
        <transform name="to_world"><rotate y="1" angle="90"/><scale value="3"/></transform>
    </shape>
</scene>"#;
    let s = load_str(xml, Path::new("/virtual/em.xml"), &[]).unwrap();
    assert_eq!(s.desc.lights[0], Light::Point { position: Vec3::new(1.0, 2.0, 3.0), intensity: Color::splat(10.0) });
    assert_eq!(s.desc.lights[1], Light::Directional { direction: -Vec3::Y, irradiance: Color::new(1.0, 2.0, 3.0) });
    // A single-valued emitter spectrum is equal-energy white, which Mitsuba 3.9.1 renders as
    // (1.2048, 0.9483, 0.9089) per unit (reddish in sRGB), not grey.
    let Light::Constant { radiance } = s.desc.lights[2] else { panic!("{:?}", s.desc.lights[2]) };
    assert!(radiance.abs_diff_eq(Color::new(1.2048, 0.9483, 0.9089) * 0.5, 2e-3), "{radiance}");
    let Geometry::Sphere { center, radius } = s.desc.shapes[0].geometry else { panic!() };
    assert!(center.abs_diff_eq(Vec3::new(-0.3, -0.5, 0.2), 1e-6) && (radius - 0.5).abs() < 1e-6);
    assert_eq!(s.desc.shapes[0].emission, Some(Color::new(4.0, 5.0, 6.0)));
    // to_world * translate(center) * scale(radius): centre (1,0,0) rotated about y to (0,0,-1), scaled by 3.
    let Geometry::Sphere { center, radius } = s.desc.shapes[1].geometry else { panic!() };
    assert!(center.abs_diff_eq(Vec3::new(0.0, 0.0, -3.0), 1e-5), "{center}");
    assert!((radius - 6.0).abs() < 1e-5);

    let xml = "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<transform name=\"to_world\"><scale x=\"1\" y=\"2\"/></transform>\n</shape>\n</scene>";
    let err = load_str(xml, Path::new("/virtual/sph.xml"), &[]).unwrap_err().to_string();
    assert!(err.starts_with("/virtual/sph.xml:2:") && err.contains("uniformly"), "{err}");
}

#[test]
fn mitsuba_05_names_are_upgraded() {
    let xml = r#"<scene version="0.5.0">
    <bsdf type="diffuse" id="old"><rgb name="diffuseReflectance" value="0.3"/></bsdf>
    <bsdf type="plastic" id="shiny"><float name="intIOR" value="1.6"/><float name="extIOR" value="1.1"/></bsdf>
    <sensor type="perspective">
        <string name="focalLength" value="35mm"/>
        <float name="nearClip" value="0.5"/>
        <transform name="toWorld"><lookAt origin="0 0 0" target="0 0 1" up="0 1 0"/></transform>
    </sensor>
</scene>"#;
    let s = load_str(xml, Path::new("/virtual/v05.xml"), &[]).unwrap();
    assert_eq!(s.desc.materials[0], Material::Diffuse { reflectance: Texture::Const(Color::splat(0.3)) });
    match s.desc.materials[1] {
        Material::Plastic { eta, nonlinear, .. } => {
            assert!(!nonlinear, "Mitsuba's default");
            assert!((eta - 1.6 / 1.1).abs() < 1e-6);
        }
        ref m => panic!("{m:?}"),
    }
    // 35 mm focal length: diagonal field of view 2 atan(43.27 / 70).
    let cam = &s.desc.camera;
    assert_eq!(cam.fov_axis, octolux::scene::camera::FovAxis::Diagonal);
    assert!((cam.fov_deg - 63.4399).abs() < 1e-3, "{}", cam.fov_deg);
    assert_eq!(cam.near_clip, 0.5);
    // Smooth plastic is exact now: nothing to report.
    assert!(s.warnings.is_empty(), "{:#?}", s.warnings);
}

#[test]
fn another_methods_integrator_parameters_are_one_line() {
    let xml = r#"<scene version="0.6.0">
    <integrator type="sppm">
        <integer name="maxDepth" value="7"/>
        <integer name="photonCount" value="1000"/>
        <boolean name="dualBuffer" value="true"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <film type="hdrfilm">
            <boolean name="banner" value="false"/>
            <boolean name="attachLog" value="false"/>
            <string name="fileFormat" value="openexr"/>
        </film>
    </sensor>
</scene>"#;
    // sppm converges to a path tracer's image: its tuning parameters are a note, one line.
    let s = load_str(xml, Path::new("/virtual/sppm.xml"), &[]).unwrap();
    assert_eq!(s.desc.hints.max_depth, Some(7));
    assert!(s.warnings.is_empty(), "{:#?}", s.warnings);
    assert_eq!(s.notes.len(), 1, "{:#?}", s.notes);
    let n = &s.notes[0];
    assert!(n.starts_with("/virtual/sppm.xml:2:") && n.ends_with("photon_count, dual_buffer"), "{n}");
    // A type that is no Mitsuba light-transport method: a warning.
    let s = load_str(&xml.replace("sppm", "whitted"), Path::new("/virtual/whitted.xml"), &[]).unwrap();
    assert!(s.notes.is_empty(), "{:#?}", s.notes);
    assert_eq!(s.warnings.len(), 1, "{:#?}", s.warnings);
    assert!(s.warnings[0].ends_with("photon_count, dual_buffer"), "{}", s.warnings[0]);
}

/// Mitsuba 0.6's path guiding (`guided_path`) converges to a path tracer's image, like `sppm`:
/// its parameters are one note, its integrator a note from the settings (not a warning), and
/// its `maxDepth` a path tracer's.
#[test]
fn path_guiding_gets_the_note_of_the_methods_that_converge_to_a_path_tracer() {
    let xml = r#"<scene version="0.6.0">
    <integrator type="guided_path">
        <integer name="maxDepth" value="12"/>
        <integer name="budget" value="60"/>
        <string name="budgetType" value="seconds"/>
    </integrator>
    <sensor type="perspective"/>
</scene>"#;
    let s = load_str(xml, Path::new("/virtual/guided.xml"), &[]).unwrap();
    assert_eq!(s.desc.hints.max_depth, Some(12));
    assert!(s.warnings.is_empty(), "{:#?}", s.warnings);
    assert_eq!(s.notes.len(), 1, "{:#?}", s.notes);
    assert!(s.notes[0].starts_with("/virtual/guided.xml:2:") && s.notes[0].ends_with("budget, budget_type"), "{}", s.notes[0]);
    use octolux_io::settings::{scene_integrator_remark, IntegratorRemark};
    for ty in octolux_io::mitsuba::SAME_IMAGE {
        let remark = scene_integrator_remark(Some(ty), "s.xml", "path", false);
        assert!(matches!(&remark, Some(IntegratorRemark::Note(n)) if n.contains(&format!("\"{ty}\""))), "{ty}: {remark:?}");
    }
    // without maxDepth: Mitsuba's unbounded default
    let s = load_str(&xml.replace(r#"<integer name="maxDepth" value="12"/>"#, ""), Path::new("/virtual/guided.xml"), &[]).unwrap();
    assert_eq!(s.desc.hints.max_depth, Some(-1));
}

/// Mitsuba 3's `sampling_weight` only changes how often an emitter is sampled, not the image:
/// octolux's light tree chooses instead, and a weight other than 1 is said to be ignored, on
/// area emitters and on the others alike.
#[test]
fn an_emitters_sampling_weight_is_said_to_be_ignored() {
    let xml = r#"<scene version="3.0.0">
    <sensor type="perspective"/>
    <shape type="sphere">
        <emitter type="area">
            <rgb name="radiance" value="1, 1, 1"/>
            <float name="sampling_weight" value="200"/>
        </emitter>
    </shape>
    <emitter type="point">
        <float name="sampling_weight" value="0.5"/>
    </emitter>
    <emitter type="constant">
        <float name="sampling_weight" value="1"/>
    </emitter>
</scene>"#;
    let s = load_str(xml, Path::new("/virtual/weights.xml"), &[]).unwrap();
    assert_eq!(s.warnings.len(), 2, "{:#?}", s.warnings);
    assert!(
        s.warnings[0].starts_with("/virtual/weights.xml:4:") && s.warnings[0].contains("sampling_weight 200 is ignored"),
        "{}",
        s.warnings[0]
    );
    assert!(
        s.warnings[1].starts_with("/virtual/weights.xml:9:") && s.warnings[1].contains("sampling_weight 0.5 is ignored"),
        "{}",
        s.warnings[1]
    );
    assert!(s.warnings.iter().all(|w| w.contains("light tree")));
}
