//! OBJ loading: Mitsuba 3 conventions (v flip, normals, fans, negative indices, merged groups),
//! errors with file and line, degenerate removal, and OBJ/MTL files rendered as scenes.

use glam::{Vec2, Vec3};
use octolux::math::Color;
use octolux::scene::material::{Material, Texture};
use octolux::scene::Light;
use octolux::scene::{Geometry, TriMesh};
use octolux_io::mesh::{load_mesh_checked, load_mesh_scene, load_obj_mesh, phong_exponent_to_alpha};
use octolux_io::shared::shared_scene;
use octolux_io::IoError;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mesh").join(name)
}

fn tri_normal(m: &TriMesh, t: [u32; 3]) -> Vec3 {
    let p = |i: u32| m.positions[i as usize];
    (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]))
}

#[test]
fn quad_flips_v_uses_file_normals_and_is_a_fan() {
    let m = load_obj_mesh(&data("quad_uv_normals.obj")).unwrap();
    assert_eq!(m.positions.len(), 4);
    assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]], "fan (v0, v1, v2), (v0, v2, v3)");
    let uvs = m.uvs.as_ref().expect("texture coordinates");
    // vt 0 0.25 of the 4th corner becomes (0, 0.75): Mitsuba's flip_tex_coords = true.
    assert_eq!(uvs[3], Vec2::new(0.0, 0.75));
    assert_eq!(uvs[2], Vec2::new(1.0, 0.0));
    let normals = m.normals.as_ref().expect("normals");
    for n in normals {
        assert!((*n - Vec3::Z).length() < 1e-6, "the file's normal (0,0,2) normalised, got {n}");
    }
    assert!((m.area() - 1.0).abs() < 1e-6);
}

#[test]
fn negative_indices_and_groups_are_merged_into_one_mesh() {
    let m = load_obj_mesh(&data("pentagon_negative.obj")).unwrap();
    // The pentagon's fan gives 3 triangles, the second group one more; vertices are shared
    // across groups because the corner keys (position, no uv, no normal) are identical.
    assert_eq!(m.indices.len(), 4);
    assert_eq!(m.positions.len(), 5);
    assert_eq!(m.positions[0], Vec3::new(0.0, 0.0, 0.0));
    assert_eq!(m.positions[4], Vec3::new(-1.0, 1.0, 0.0));
    for t in &m.indices {
        assert!(tri_normal(&m, *t).z > 0.0, "all triangles keep the counter-clockwise winding");
    }
    assert!(m.uvs.is_none());
    // Polygon area by the shoelace formula: the fan must cover it exactly.
    let poly = [(0.0, 0.0), (2.0, 0.0), (3.0, 1.0), (1.0, 2.0), (-1.0, 1.0)];
    let mut shoelace = 0.0f64;
    for i in 0..5 {
        let (a, b) = (poly[i], poly[(i + 1) % 5]);
        shoelace += a.0 * b.1 - b.0 * a.1;
    }
    let tri4 = 0.5 * ((2.0f64) * 2.0 - 0.0 * 1.0); // (0,0),(2,0),(1,2)
    assert!((m.area() - (0.5 * shoelace + tri4)).abs() < 1e-5, "area {}", m.area());
}

#[test]
fn missing_normals_are_computed_angle_weighted() {
    let m = load_obj_mesh(&data("cube_shared.obj")).unwrap();
    assert_eq!(m.positions.len(), 8);
    assert_eq!(m.indices.len(), 12);
    let center = Vec3::splat(0.5);
    for t in &m.indices {
        let c = (m.positions[t[0] as usize] + m.positions[t[1] as usize] + m.positions[t[2] as usize]) / 3.0;
        assert!(tri_normal(&m, *t).dot(c - center) > 0.0, "cube faces point outwards");
    }
    // Each corner touches three faces with a total angle of 90 degrees each, so the weighted
    // normal is the normalised diagonal direction from the centre.
    let normals = m.normals.as_ref().unwrap();
    for (p, n) in m.positions.iter().zip(normals) {
        let expect = (*p - center).normalize();
        assert!((*n - expect).length() < 1e-5, "corner {p}: normal {n}, expected {expect}");
    }
}

#[test]
fn non_finite_vertex_is_an_error_with_its_line() {
    let path = data("nan_vertex.obj");
    match load_obj_mesh(&path) {
        Err(IoError::Parse { file, line, msg }) => {
            assert_eq!(file, path);
            assert_eq!(line, 3);
            assert!(msg.contains("not finite"), "{msg}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn out_of_range_and_zero_indices_are_errors_with_their_line() {
    match load_obj_mesh(&data("bad_index.obj")) {
        Err(IoError::Parse { line, msg, .. }) => {
            assert_eq!(line, 5);
            assert!(msg.contains("out of range"), "{msg}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    match load_obj_mesh(&data("zero_index.obj")) {
        Err(IoError::Parse { line, .. }) => assert_eq!(line, 4),
        other => panic!("expected a parse error, got {other:?}"),
    }
    let err = load_obj_mesh(&data("bad_index.obj")).unwrap_err().to_string();
    assert!(err.contains("bad_index.obj:5:"), "message names file and line: {err}");
}

#[test]
fn missing_file_is_an_os_error_naming_it() {
    let path = data("no_such_file.obj");
    match load_obj_mesh(&path) {
        Err(IoError::Os { file, error: source }) => {
            assert_eq!(file, path);
            assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
        }
        other => panic!("expected an OS error, got {other:?}"),
    }
}

#[test]
fn checked_loading_removes_degenerate_triangles_with_a_warning() {
    let raw = load_obj_mesh(&data("degenerate.obj")).unwrap();
    assert_eq!(raw.indices.len(), 2);
    let (m, warnings) = load_mesh_checked(&data("degenerate.obj")).unwrap();
    assert_eq!(m.indices.len(), 1);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].contains("degenerate.obj") && warnings[0].contains("1 degenerate"), "{warnings:?}");
    assert!(load_mesh_checked(&data("materials.mtl")).is_err(), "unknown extension");
}

#[test]
#[cfg_attr(
    missing = "scenes/mitsuba-tutorials-cbox",
    ignore = "needs ../shared/scenes/mitsuba-tutorials-cbox (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn mitsuba_cbox_small_box_keeps_its_file_normals() {
    let Some(path) = shared_scene("mitsuba-tutorials-cbox/meshes/cbox_smallbox.obj") else { return };
    let (m, warnings) = load_mesh_checked(&path).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(m.positions.len(), 24);
    assert_eq!(m.indices.len(), 12);
    // Each face uses one `vn`; the shading normal must be that normal and agree with the
    // winding of the triangle (the file is consistently oriented, outwards).
    let normals = m.normals.as_ref().unwrap();
    for t in &m.indices {
        let ng = tri_normal(&m, *t).normalize();
        for &i in t {
            assert!(normals[i as usize].dot(ng) > 0.99, "vertex normal {} vs face normal {ng}", normals[i as usize]);
        }
    }
}

fn unwrap_two_sided(m: &Material) -> &Material {
    match m {
        Material::TwoSided { front, back } => {
            assert_eq!(front, back);
            front
        }
        other => other,
    }
}

#[test]
fn obj_scene_maps_mtl_materials_and_emission() {
    let scene = load_mesh_scene(&data("materials.obj")).unwrap();
    let desc = &scene.desc;
    desc.validate().unwrap();
    let by_name = |n: &str| desc.shapes.iter().find(|s| s.name == n).unwrap_or_else(|| panic!("shape {n} in {:?}", names(desc)));
    fn names(d: &octolux::scene::SceneDesc) -> Vec<String> {
        d.shapes.iter().map(|s| s.name.clone()).collect()
    }
    assert_eq!(desc.shapes.len(), 7, "{:?}", names(desc));
    let mat = |n: &str| unwrap_two_sided(&desc.materials[by_name(n).material as usize]).clone();

    assert_eq!(mat("materials:red"), Material::Diffuse { reflectance: Texture::Const(Color::new(0.8, 0.1, 0.1)) });
    let lamp = by_name("materials:lamp");
    assert_eq!(lamp.emission, Some(Color::new(10.0, 8.0, 6.0)));
    match &lamp.geometry {
        Geometry::Mesh(m) => assert_eq!(m.indices.len(), 2),
        g => panic!("lamp should be a mesh, got {g:?}"),
    }
    assert_eq!(mat("materials:mirror"), Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::splat(0.9) });
    assert_eq!(
        desc.materials[by_name("materials:glass").material as usize],
        Material::Dielectric { eta: 1.33, specular_reflectance: Color::ONE, specular_transmittance: Color::ONE }
    );
    match mat("materials:plastic") {
        Material::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, eta, nonlinear } => {
            assert_eq!(diffuse_reflectance, Texture::Const(Color::new(0.2, 0.3, 0.4)));
            assert_eq!(specular_reflectance, Color::splat(0.5));
            assert!(!nonlinear && distribution.is_isotropic());
            assert!((distribution.alpha_u - (2.0f32 / 100.0).sqrt()).abs() < 1e-6);
            assert_eq!(eta, 1.5);
        }
        other => panic!("expected rough plastic, got {other:?}"),
    }
    // Faces before any usemtl and faces naming an undefined material get the default.
    let default = Material::Diffuse { reflectance: Texture::Const(Color::splat(octolux_io::mesh::DEFAULT_REFLECTANCE)) };
    assert_eq!(mat("materials"), default);
    assert_eq!(mat("materials:undefined"), default);
    assert!(scene.warnings.iter().any(|w| w.contains("undefined")), "{:?}", scene.warnings);
    // An emitter exists, so no environment light is added.
    assert!(desc.lights.is_empty(), "{:?}", desc.lights);
    assert!(desc.shapes.iter().all(|s| s.material < desc.materials.len() as u32));
}

#[test]
fn obj_scene_without_emitter_gets_an_environment_and_a_framing_camera() {
    let scene = load_mesh_scene(&data("missing_mtl.obj")).unwrap();
    assert!(scene.warnings.iter().any(|w| w.contains("does_not_exist.mtl")), "{:?}", scene.warnings);
    assert_eq!(scene.desc.lights, vec![Light::Constant { radiance: Color::ONE }]);
    let scene = load_mesh_scene(&data("cube_shared.obj")).unwrap();
    let desc = &scene.desc;
    desc.validate().unwrap();
    let cam = octolux::scene::camera::Camera::new(&desc.camera, desc.film.width, desc.film.height);
    let b = desc.bounds();
    for i in 0..8 {
        let corner = Vec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        );
        let f = cam.project(corner).expect("corner in front of the camera");
        assert!(f.x > 0.0 && f.y > 0.0 && f.x < desc.film.width as f32 && f.y < desc.film.height as f32, "corner {corner} -> {f}");
    }
    assert!((desc.camera.fov_deg - 39.3).abs() < 1e-4);
}

#[test]
fn phong_exponent_mapping_is_monotone_and_clamped() {
    assert_eq!(phong_exponent_to_alpha(0.0), 1.0);
    assert!(phong_exponent_to_alpha(10.0) > phong_exponent_to_alpha(100.0));
    assert!(phong_exponent_to_alpha(1e9) >= 1e-3);
    assert_eq!(phong_exponent_to_alpha(f32::NAN), 1.0);
}

/// Mitsuba scenes read their OBJ files ahead, in parallel: each shape still gets its own mesh
/// and warnings (a file used twice is read twice), and errors come in document order (a shape
/// whose file is missing is reported before a later shape's bad file, read ahead already).
#[test]
fn mesh_files_read_ahead_keep_document_order() {
    let scene = |shapes: &str| format!("<scene version=\"3.0.0\">{shapes}</scene>");
    let obj = |file: &str| format!("<shape type=\"obj\"><string name=\"filename\" value=\"{file}\"/></shape>");
    let at = data("scene.xml");
    let twice = scene(&[obj("degenerate.obj"), obj("quad_uv_normals.obj"), obj("degenerate.obj")].concat());
    let loaded = octolux_io::mitsuba::load_str(&twice, &at, &[]).unwrap();
    let meshes: Vec<&TriMesh> = loaded
        .desc
        .shapes
        .iter()
        .map(|s| match &s.geometry {
            Geometry::Mesh(m) => m,
            other => panic!("expected a mesh, got {other:?}"),
        })
        .collect();
    assert_eq!(meshes.len(), 3);
    let same = |a: &TriMesh, b: &TriMesh| a.positions == b.positions && a.normals == b.normals && a.uvs == b.uvs && a.indices == b.indices;
    assert!(same(meshes[0], meshes[2]), "the same file gives the same mesh each time");
    let alone = octolux_io::mitsuba::load_str(&scene(&obj("quad_uv_normals.obj")), &at, &[]).unwrap();
    assert!(matches!(&alone.desc.shapes[0].geometry, Geometry::Mesh(m) if same(m, meshes[1])), "the mesh of a scene of its own");
    let degenerate = loaded.warnings.iter().filter(|w| w.contains("degenerate triangle")).count();
    assert_eq!(degenerate, 2, "one warning per shape that reads the file: {:?}", loaded.warnings);
    // the first error in document order, though the later bad file was read first
    let bad = scene(&[obj("quad_uv_normals.obj"), obj("no_such_file.obj"), obj("bad_index.obj")].concat());
    let err = octolux_io::mitsuba::load_str(&bad, &at, &[]).unwrap_err().to_string();
    assert!(err.contains("no_such_file.obj") && err.contains("not found"), "{err}");
    let bad = scene(&[obj("quad_uv_normals.obj"), obj("bad_index.obj")].concat());
    let err = octolux_io::mitsuba::load_str(&bad, &at, &[]).unwrap_err().to_string();
    assert!(err.contains("bad_index.obj:5:"), "{err}");
}
