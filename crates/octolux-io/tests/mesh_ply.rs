//! PLY loading: ascii and binary (both endiannesses, several scalar types), attribute names,
//! polygons, errors with file and line, and the shared Stanford bunny / Bitterli meshes.

use glam::{Vec2, Vec3};
use octolux::math::Color;
use octolux::scene::material::{Material, Texture};
use octolux::scene::{Geometry, TriMesh};
use octolux_io::mesh::{load_mesh_checked, load_mesh_scene, load_ply_mesh};
use octolux_io::shared::shared_scene;
use octolux_io::IoError;
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mesh").join(name)
}

fn tmp(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mesh_ply");
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The quad of `quad_ascii.ply`, written as binary with doubles for positions, floats for
/// normals and uvs, a ushort extra property, and faces as `uchar`/`uint` lists.
fn write_binary_quad(path: &Path, big_endian: bool) {
    let mut out = Vec::new();
    out.extend_from_slice(
        format!(
            "ply\nformat {} 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty ushort quality\nproperty float u\nproperty float v\nelement face 1\nproperty list uchar uint vertex_indices\nproperty short flags\nend_header\n",
            if big_endian { "binary_big_endian" } else { "binary_little_endian" }
        )
        .as_bytes(),
    );
    let put = |out: &mut Vec<u8>, le: &[u8]| {
        let mut b = le.to_vec();
        if big_endian {
            b.reverse();
        }
        out.extend_from_slice(&b);
    };
    for (x, y) in [(0.0f64, 0.0f64), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
        put(&mut out, &x.to_le_bytes());
        put(&mut out, &y.to_le_bytes());
        put(&mut out, &0.0f64.to_le_bytes());
        for n in [0.0f32, 0.0, 1.0] {
            put(&mut out, &n.to_le_bytes());
        }
        put(&mut out, &7u16.to_le_bytes());
        put(&mut out, &(x as f32).to_le_bytes());
        put(&mut out, &(y as f32).to_le_bytes());
    }
    out.push(4);
    for i in [0u32, 1, 2, 3] {
        put(&mut out, &i.to_le_bytes());
    }
    put(&mut out, &(-5i16).to_le_bytes());
    std::fs::write(path, out).unwrap();
}

fn check_quad(m: &TriMesh) {
    assert_eq!(m.positions, vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)]);
    assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]], "quad split as a fan");
    assert_eq!(m.normals.as_ref().unwrap(), &vec![Vec3::Z; 4]);
    // PLY texture coordinates are not flipped (Mitsuba's PLY default).
    assert_eq!(m.uvs.as_ref().unwrap(), &vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]);
}

#[test]
fn ascii_quad_with_extra_properties_and_elements() {
    check_quad(&load_ply_mesh(&data("quad_ascii.ply")).unwrap());
}

#[test]
fn binary_little_and_big_endian_read_the_same_mesh() {
    for big in [false, true] {
        let path = tmp(if big { "quad_be.ply" } else { "quad_le.ply" });
        write_binary_quad(&path, big);
        check_quad(&load_ply_mesh(&path).unwrap());
    }
}

#[test]
fn truncated_binary_file_is_an_error() {
    let path = tmp("quad_truncated.ply");
    write_binary_quad(&path, false);
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() - 6]).unwrap();
    match load_ply_mesh(&path) {
        Err(IoError::Invalid { file, msg }) => {
            assert_eq!(file, path);
            assert!(msg.contains("face 0") && msg.contains("end of file"), "{msg}");
        }
        other => panic!("expected an error, got {other:?}"),
    }
}

#[test]
fn st_texture_names_double_positions_and_vertex_index_lists() {
    let m = load_ply_mesh(&data("st_names.ply")).unwrap();
    assert_eq!(m.indices, vec![[0, 1, 2]]);
    assert_eq!(m.uvs.as_ref().unwrap()[2], Vec2::new(0.5, 0.6));
    // No normals in the file: computed ones, here the face normal.
    for n in m.normals.as_ref().unwrap() {
        assert!((*n - Vec3::Z).length() < 1e-6);
    }
}

#[test]
fn errors_name_the_file_and_line() {
    match load_ply_mesh(&data("nan_vertex.ply")) {
        Err(IoError::Parse { file, line, msg }) => {
            assert_eq!(file, data("nan_vertex.ply"));
            assert_eq!(line, 12, "{msg}");
            assert!(msg.contains("not finite"), "{msg}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    match load_ply_mesh(&data("bad_index.ply")) {
        Err(IoError::Parse { line, msg, .. }) => {
            assert_eq!(line, 14, "{msg}");
            assert!(msg.contains("out of range"), "{msg}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    match load_ply_mesh(&data("no_faces_list.ply")) {
        Err(IoError::Invalid { msg, .. }) => assert!(msg.contains("vertex_indices"), "{msg}"),
        other => panic!("expected an error, got {other:?}"),
    }
    match load_ply_mesh(&data("quad_uv_normals.obj")) {
        Err(IoError::Parse { line: 1, .. }) => {}
        other => panic!("an OBJ file is not a PLY file: {other:?}"),
    }
}

/// Independent reading of an ascii PLY with `n` vertices whose first three properties are x y z.
fn naive_ascii_positions(text: &str, n: usize) -> Vec<Vec3> {
    let body = text.split("end_header").nth(1).unwrap();
    body.lines()
        .filter(|l| !l.trim().is_empty())
        .take(n)
        .map(|l| {
            let v: Vec<f32> = l.split_whitespace().take(3).map(|t| t.parse().unwrap()).collect();
            Vec3::new(v[0], v[1], v[2])
        })
        .collect()
}

fn header_count(text: &str, element: &str) -> usize {
    let key = format!("element {element} ");
    let line = text.lines().find(|l| l.starts_with(&key)).unwrap();
    line[key.len()..].trim().parse().unwrap()
}

#[test]
#[cfg_attr(
    missing = "scenes/stanford-bunny",
    ignore = "needs ../shared/scenes/stanford-bunny (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn stanford_bunny_loads_with_smooth_outward_normals() {
    let Some(path) = shared_scene("stanford-bunny/bun_zipper.ply") else { return };
    let path = path.as_path();
    let text = std::fs::read_to_string(path).unwrap();
    let nv = header_count(&text, "vertex");
    let nf = header_count(&text, "face");
    let raw = load_ply_mesh(path).unwrap();
    assert_eq!(raw.positions.len(), nv);
    assert_eq!(raw.indices.len(), nf, "the bunny's faces are triangles");
    assert_eq!(raw.positions, naive_ascii_positions(&text, nv));
    let (m, _) = load_mesh_checked(path).unwrap();
    assert!(m.indices.len() <= nf && m.indices.len() > nf * 99 / 100);
    // Computed normals are unit length and mostly agree with the faces they touch.
    let normals = m.normals.as_ref().unwrap();
    assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4));
    let agree = m
        .indices
        .iter()
        .filter(|t| {
            let p = |i: u32| m.positions[i as usize];
            let ng = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0]));
            t.iter().all(|&i| normals[i as usize].dot(ng) > 0.0)
        })
        .count();
    assert!(agree as f64 > 0.97 * m.indices.len() as f64, "{agree} of {}", m.indices.len());
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-cornell-box",
    ignore = "needs ../shared/scenes/bitterli-cornell-box (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn bitterli_binary_meshes_match_a_direct_decoding() {
    let Some(dir) = shared_scene("bitterli-cornell-box/ply") else { return };
    for name in ["Floor", "Ceiling", "BackWall", "LeftWall", "RightWall", "Light", "ShortBox", "TallBox"] {
        let path = dir.join(format!("{name}.ply"));
        let bytes = std::fs::read(&path).unwrap();
        let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let header = std::str::from_utf8(&bytes[..end]).unwrap();
        let nv = header_count(header, "vertex");
        let nf = header_count(header, "face");
        let f = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        let expect: Vec<Vec3> = (0..nv).map(|i| Vec3::new(f(end + 12 * i), f(end + 12 * i + 4), f(end + 12 * i + 8))).collect();
        let m = load_ply_mesh(&path).unwrap();
        assert_eq!(m.positions, expect, "{name}");
        assert_eq!(m.indices.len(), nf, "{name}: triangles");
    }
    // The floor faces up, into the box.
    let floor = load_ply_mesh(&dir.join("Floor.ply")).unwrap();
    for t in &floor.indices {
        let p = |i: u32| floor.positions[i as usize];
        assert!((p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).y > 0.0);
    }
}

#[test]
fn ply_scene_is_one_white_diffuse_under_a_constant_sky() {
    let scene = load_mesh_scene(&data("quad_ascii.ply")).unwrap();
    scene.desc.validate().unwrap();
    assert_eq!(scene.desc.shapes.len(), 1);
    assert!(matches!(scene.desc.shapes[0].geometry, Geometry::Mesh(_)));
    let m = match &scene.desc.materials[0] {
        Material::TwoSided { front, .. } => (**front).clone(),
        other => other.clone(),
    };
    assert_eq!(m, Material::Diffuse { reflectance: Texture::Const(Color::splat(octolux_io::mesh::DEFAULT_REFLECTANCE)) });
    assert_eq!(scene.desc.lights, vec![octolux::scene::Light::Constant { radiance: Color::ONE }]);
}
