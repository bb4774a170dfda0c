//! Mitsuba `serialized` meshes: files written here with the format's layout (zlib streams made
//! with `flate2`), versions 3 and 4, every flag, the end-of-file dictionary, errors naming the
//! file and the problem, the `serialized` shape from both XML syntaxes, and the collection's
//! `box/box.serialized` when the shared folder is present.

use flate2::write::ZlibEncoder;
use flate2::Compression;
use glam::{Vec2, Vec3};
use octolux::scene::Geometry;
use octolux_io::mesh::{load_serialized, parse_serialized, serialized_shape_count};
use octolux_io::mitsuba::load_str;
use octolux_io::shared::shared_scene;
use std::io::Write;
use std::path::{Path, PathBuf};

/// One mesh to write.
#[derive(Clone, Default)]
struct Mesh {
    name: String,
    positions: Vec<[f64; 3]>,
    normals: Option<Vec<[f64; 3]>>,
    uvs: Option<Vec<[f64; 2]>>,
    colors: Option<Vec<[f64; 3]>>,
    face_normals: bool,
    double: bool,
    triangles: Vec<[u32; 3]>,
}

/// The compressed body of one mesh (after its 4-byte header).
fn body(m: &Mesh, version: u16) -> Vec<u8> {
    let mut raw = Vec::new();
    let mut flags = 0u32;
    flags |= if m.normals.is_some() { 0x1 } else { 0 };
    flags |= if m.uvs.is_some() { 0x2 } else { 0 };
    flags |= if m.colors.is_some() { 0x8 } else { 0 };
    flags |= if m.face_normals { 0x10 } else { 0 };
    flags |= if m.double { 0x2000 } else { 0x1000 };
    raw.extend(flags.to_le_bytes());
    if version == 4 {
        raw.extend(m.name.as_bytes());
        raw.push(0);
    }
    raw.extend((m.positions.len() as u64).to_le_bytes());
    raw.extend((m.triangles.len() as u64).to_le_bytes());
    let mut put = |v: f64| {
        if m.double {
            raw.extend(v.to_le_bytes());
        } else {
            raw.extend((v as f32).to_le_bytes());
        }
    };
    m.positions.iter().flatten().for_each(|&v| put(v));
    if let Some(n) = &m.normals {
        n.iter().flatten().for_each(|&v| put(v));
    }
    if let Some(t) = &m.uvs {
        t.iter().flatten().for_each(|&v| put(v));
    }
    if let Some(c) = &m.colors {
        c.iter().flatten().for_each(|&v| put(v));
    }
    for t in &m.triangles {
        for i in t {
            raw.extend(i.to_le_bytes());
        }
    }
    compress(&raw)
}

fn compress(raw: &[u8]) -> Vec<u8> {
    let mut z = ZlibEncoder::new(Vec::new(), Compression::default());
    z.write_all(raw).unwrap();
    z.finish().unwrap()
}

/// A whole file: the meshes one after the other, then the dictionary (u64 offsets in version
/// 4, u32 in version 3) and the count.
fn file(meshes: &[Mesh], version: u16) -> Vec<u8> {
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for m in meshes {
        offsets.push(out.len() as u64);
        out.extend(0x041Cu16.to_le_bytes());
        out.extend(version.to_le_bytes());
        out.extend(body(m, version));
    }
    for o in &offsets {
        if version == 4 {
            out.extend(o.to_le_bytes());
        } else {
            out.extend((*o as u32).to_le_bytes());
        }
    }
    out.extend((meshes.len() as u32).to_le_bytes());
    out
}

fn quad() -> Mesh {
    Mesh {
        name: "quad".into(),
        positions: vec![[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]],
        normals: Some(vec![[0.0, 0.0, 2.0]; 4]),
        uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
        triangles: vec![[0, 1, 2], [2, 3, 0]],
        ..Default::default()
    }
}

fn triangle_double() -> Mesh {
    Mesh {
        name: "tri".into(),
        positions: vec![[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 0.125, 1.0]],
        normals: Some(vec![[0.0, 0.0, 1.0]; 3]),
        colors: Some(vec![[1.0, 0.5, 0.25]; 3]),
        face_normals: true,
        double: true,
        triangles: vec![[0, 1, 2]],
        ..Default::default()
    }
}

fn tmp(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mesh_serialized");
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

#[test]
fn version_4_file_with_two_meshes_reads_every_field() {
    let path = tmp("two.serialized", &file(&[quad(), triangle_double()], 4));
    assert_eq!(serialized_shape_count(&path).unwrap(), 2);

    let a = load_serialized(&path, 0).unwrap();
    assert_eq!(a.name.as_deref(), Some("quad"));
    assert!(a.normals_from_file && !a.face_normals && a.warnings.is_empty());
    assert_eq!(a.mesh.positions[2], Vec3::new(1.0, 1.0, 0.0));
    assert_eq!(a.mesh.indices, vec![[0, 1, 2], [2, 3, 0]]);
    assert_eq!(a.mesh.uvs.as_ref().unwrap()[1], Vec2::new(1.0, 0.0), "uvs are not flipped");
    assert!(a.mesh.normals.as_ref().unwrap().iter().all(|n| *n == Vec3::Z), "normals are normalised");

    // Double precision, vertex colours skipped, the face-normals flag drops the normals.
    let b = load_serialized(&path, 1).unwrap();
    assert_eq!(b.name.as_deref(), Some("tri"));
    assert!(b.face_normals && !b.normals_from_file && b.mesh.normals.is_none() && b.mesh.uvs.is_none());
    assert_eq!(b.mesh.positions, vec![Vec3::new(0.0, 0.0, 1.0), Vec3::X + Vec3::Z, Vec3::new(0.0, 0.125, 1.0)]);
    assert_eq!(b.mesh.indices, vec![[0, 1, 2]]);
}

#[test]
fn version_3_file_has_no_names_and_u32_offsets() {
    let mut plain = quad();
    plain.normals = None;
    let path = tmp("v3.serialized", &file(&[triangle_double(), plain], 3));
    assert_eq!(serialized_shape_count(&path).unwrap(), 2);
    let m = load_serialized(&path, 1).unwrap();
    assert_eq!(m.name, None);
    assert!(!m.normals_from_file && m.mesh.normals.is_none(), "no normals in the file: the caller computes them");
    assert_eq!(m.mesh.positions.len(), 4);
    assert_eq!(load_serialized(&path, 0).unwrap().mesh.indices.len(), 1);
}

#[test]
fn errors_name_the_file_and_the_problem() {
    let good = file(&[quad(), triangle_double()], 4);
    let p = Path::new("mesh.serialized");
    let msg = |bytes: &[u8], index: u32| parse_serialized(p, bytes, index).unwrap_err().to_string();

    let e = msg(&good, 2);
    assert!(e.contains("mesh.serialized") && e.contains("shape index 2 is out of range") && e.contains("0..1"), "{e}");

    let mut bad_magic = good.clone();
    bad_magic[0] = 0;
    let e = msg(&bad_magic, 0);
    assert!(e.contains("not a Mitsuba serialized mesh"), "{e}");

    let mut bad_version = good.clone();
    bad_version[2] = 7;
    assert!(msg(&bad_version, 0).contains("unsupported serialized mesh version 7"));

    // Cut inside the first mesh's compressed data: no dictionary any more, mesh 0 is truncated.
    let cut = &good[..30];
    let e = msg(cut, 0);
    assert!(e.contains("mesh.serialized") && e.contains("mesh 0") && (e.contains("truncated") || e.contains("corrupt")), "{e}");
    assert!(msg(cut, 1).contains("no mesh dictionary"));
    assert!(msg(&good[..2], 0).contains("truncated"));

    // Corrupt compressed bytes.
    let mut corrupt = good.clone();
    for b in &mut corrupt[4..12] {
        *b ^= 0xA5;
    }
    let e = msg(&corrupt, 0);
    assert!(e.contains("mesh 0") && (e.contains("corrupt") || e.contains("truncated")), "{e}");

    // A triangle naming a vertex that does not exist.
    let mut m = quad();
    m.triangles[1] = [2, 3, 9];
    let e = msg(&file(&[m], 4), 0);
    assert!(e.contains("triangle 1") && e.contains("vertex index 9 is out of range"), "{e}");

    // Non-finite positions.
    let mut m = quad();
    m.positions[3][1] = f64::NAN;
    assert!(msg(&file(&[m], 4), 0).contains("vertex 3: position"));

    // A corrupt vertex count (2^20 vertices, then the data of 4: within the memory budget)
    // fails on the data, not by allocating it.
    let mut raw = Vec::new();
    raw.extend(0x1000u32.to_le_bytes());
    raw.push(0);
    raw.extend((1u64 << 20).to_le_bytes());
    raw.extend(0u64.to_le_bytes());
    raw.extend([0u8; 48]);
    let mut bytes = vec![0x1C, 0x04, 4, 0];
    bytes.extend(compress(&raw));
    let e = msg(&bytes, 0);
    assert!(e.contains("truncated data while reading the vertex positions"), "{e}");

    let e = load_serialized(Path::new("no/such/file.serialized"), 0).unwrap_err().to_string();
    assert!(e.contains("no/such/file.serialized"), "{e}");
}

/// A scene with one serialized shape, written next to the mesh file (the warning about the
/// missing sensor is dropped).
fn xml_scene(xml: &str, mesh_bytes: &[u8], name: &str) -> Result<octolux_io::LoadedScene, octolux_io::IoError> {
    let mesh = tmp(name, mesh_bytes);
    let scene_path = mesh.with_extension("xml");
    let mut s = load_str(xml, &scene_path, &[])?;
    s.warnings.retain(|w| !w.contains("no usable sensor"));
    Ok(s)
}

#[test]
fn the_shape_reads_both_syntaxes() {
    let bytes = file(&[quad(), triangle_double()], 4);
    // Mitsuba 3 names.
    let s = xml_scene(
        r#"<scene version="3.0.0">
            <shape type="serialized">
                <string name="filename" value="syntax.serialized"/>
                <integer name="shape_index" value="0"/>
                <transform name="to_world"><translate z="5"/></transform>
            </shape>
        </scene>"#,
        &bytes,
        "syntax.serialized",
    )
    .unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let shape = &s.desc.shapes[0];
    assert_eq!(shape.name, "syntax@0");
    let Geometry::Mesh(m) = &shape.geometry else { panic!("a mesh") };
    assert!(m.positions.iter().all(|p| p.z == 5.0));
    assert!(m.normals.as_ref().unwrap().iter().all(|n| *n == Vec3::Z));

    // Mitsuba 0.6 names: shapeIndex, faceNormals, flipNormals, toWorld.
    let s = xml_scene(
        r#"<scene version="0.6.0">
            <shape type="serialized">
                <string name="filename" value="syntax.serialized"/>
                <integer name="shapeIndex" value="0"/>
                <boolean name="faceNormals" value="true"/>
                <boolean name="flipNormals" value="true"/>
                <transform name="toWorld"><scale value="2"/></transform>
            </shape>
        </scene>"#,
        &bytes,
        "syntax.serialized",
    )
    .unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let shape = &s.desc.shapes[0];
    assert!(shape.flip_normals);
    let Geometry::Mesh(m) = &shape.geometry else { panic!("a mesh") };
    assert!(m.normals.is_none(), "faceNormals drops the normals");
    assert_eq!(m.positions[2], Vec3::new(2.0, 2.0, 0.0));

    // An index out of range is an error naming the scene line and the mesh file.
    let e = xml_scene(
        r#"<scene version="0.6.0">
            <shape type="serialized">
                <string name="filename" value="syntax.serialized"/>
                <integer name="shapeIndex" value="5"/>
            </shape>
        </scene>"#,
        &bytes,
        "syntax.serialized",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("syntax.xml:2") && e.contains("syntax.serialized") && e.contains("shape index 5 is out of range"), "{e}");
}

#[test]
fn max_smooth_angle_splits_creases_and_computed_normals_follow_the_transform() {
    // A roof: two triangles meeting at 90 degrees along the x axis, no normals in the file.
    let roof = Mesh {
        positions: vec![[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]],
        triangles: vec![[0, 1, 2], [1, 0, 3]],
        ..Default::default()
    };
    let bytes = file(&[roof], 4);
    let load = |extra: &str| {
        let xml = format!(
            r#"<scene version="0.6.0">
                <shape type="serialized">
                    <string name="filename" value="roof.serialized"/>
                    {extra}
                </shape>
            </scene>"#
        );
        let s = xml_scene(&xml, &bytes, "roof.serialized").unwrap();
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        let Geometry::Mesh(m) = s.desc.shapes[0].geometry.clone() else { panic!("a mesh") };
        m
    };
    // Smooth: the ridge vertices are shared and their normal is the bisector (0, 0, 1).
    let smooth = load("");
    assert_eq!(smooth.positions.len(), 4);
    assert!((smooth.normals.as_ref().unwrap()[0] - Vec3::Z).length() < 1e-5);
    // 30 degrees: the 90-degree ridge is a crease; 6 vertices with the faces' normals.
    let creased = load(r#"<float name="maxSmoothAngle" value="30"/>"#);
    assert_eq!(creased.positions.len(), 6);
    let n = creased.normals.as_ref().unwrap();
    let s = std::f32::consts::FRAC_1_SQRT_2;
    for t in &creased.indices {
        let p = |i: usize| creased.positions[t[i] as usize];
        let ng = (p(1) - p(0)).cross(p(2) - p(0)).normalize();
        assert!((ng.z - s).abs() < 1e-5, "{ng}");
        for &v in t {
            assert!((n[v as usize] - ng).length() < 1e-5);
        }
    }
    // 120 degrees: smoothed again.
    assert_eq!(load(r#"<float name="maxSmoothAngle" value="120"/>"#).positions.len(), 4);
    // Computed normals are computed after the transform (Mitsuba 3): a mirror of z flips the
    // winding and the normals together, so the two still agree.
    let mirrored = load(r#"<transform name="toWorld"><scale x="1" y="1" z="-1"/></transform>"#);
    let t = mirrored.indices[0];
    let p = |i: usize| mirrored.positions[t[i] as usize];
    let ng = (p(1) - p(0)).cross(p(2) - p(0));
    assert!(ng.dot(mirrored.normals.as_ref().unwrap()[t[0] as usize]) > 0.0);
}

#[test]
fn a_mesh_of_degenerate_triangles_is_skipped_with_one_warning() {
    let flat = Mesh {
        positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        triangles: vec![[0, 1, 2], [0, 0, 1]],
        ..Default::default()
    };
    let bytes = file(&[quad(), flat], 4);
    let s = xml_scene(
        r#"<scene version="0.6.0">
            <shape type="serialized">
                <string name="filename" value="flat.serialized"/>
                <integer name="shapeIndex" value="1"/>
            </shape>
            <shape type="serialized">
                <string name="filename" value="flat.serialized"/>
            </shape>
        </scene>"#,
        &bytes,
        "flat.serialized",
    )
    .unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("flat.xml:2") && s.warnings[0].contains("only degenerate triangles (2)"), "{:?}", s.warnings);
    assert_eq!(s.desc.shapes.len(), 1, "the degenerate mesh is skipped, the other loads");
}

#[test]
#[cfg_attr(
    missing = "scenes/bitterli-collection/box",
    ignore = "needs ../shared/scenes/bitterli-collection/box (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn collection_box_serialized_loads_every_shape() {
    let Some(path) = shared_scene("bitterli-collection/box/box.serialized") else { return };
    let count = serialized_shape_count(&path).unwrap();
    assert!(count >= 9, "the box scene uses shape indices 0..8, the file has {count}");
    let mut triangles = 0;
    for i in 0..count {
        let m = load_serialized(&path, i).unwrap_or_else(|e| panic!("shape {i}: {e}"));
        assert!(!m.mesh.indices.is_empty(), "shape {i} has no triangles");
        assert!(m.mesh.positions.iter().all(|p| p.is_finite()));
        triangles += m.mesh.indices.len();
    }
    println!("box.serialized: {count} meshes, {triangles} triangles");
    assert!(load_serialized(&path, count).unwrap_err().to_string().contains("out of range"));
}
