//! Catalogue of hostile inputs (issue 12): each case is a file a careless or malicious user could
//! give, and the exact error it must produce — never an abort, a panic or an allocation the
//! memory budget refuses. `docs/errors.md` lists the same cases.
//!
//! Every test sets the same process-wide memory limit ([`LIMIT`]) so that messages are exact
//! whatever the machine.

use flate2::write::ZlibEncoder;
use octolux::budget;
use octolux::image::Image;
use octolux::math::Color;
use octolux_io::fuzzing;
use octolux_io::image_io::{decode_image, read_exr, write_exr};
use octolux_io::mesh::{parse_obj_mesh, parse_ply, parse_serialized};
use octolux_io::mitsuba::load_str;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The memory limit of these tests: 1 GiB.
const LIMIT: u64 = 1 << 30;

fn setup() {
    budget::set_memory_limit(LIMIT);
}

fn tmp_dir(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("hostile_input").join(test);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn ply_err(bytes: &[u8]) -> String {
    setup();
    parse_ply(Path::new("h.ply"), bytes).unwrap_err().to_string()
}

fn xml_err(text: &str) -> String {
    setup();
    load_str(text, Path::new("h.xml"), &[]).unwrap_err().to_string()
}

/// The reproduction: a 252-byte PLY file whose header claims 4,000,000,000 vertices
/// (it aborted with "memory allocation of 48000000000 bytes failed").
#[test]
fn ply_vertex_count_beyond_file_size() {
    let text = "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    assert_eq!(
        ply_err(text.as_bytes()),
        "h.ply: element 'vertex' claims 4000000000 entries, but the file has only 0 bytes after its header (each entry needs at least 3)"
    );
}

/// A count of 2^64 - 1 (it panicked with "capacity overflow").
#[test]
fn ply_count_of_u64_max() {
    let text = "ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    assert_eq!(
        ply_err(text.as_bytes()),
        "h.ply: element 'vertex' claims 18446744073709551615 entries, but the file has only 0 bytes after its header (each entry needs at least 12)"
    );
    // One more than 2^64 - 1 is not a count at all.
    let text = text.replace("18446744073709551615", "18446744073709551616");
    assert_eq!(ply_err(text.as_bytes()), "h.ply:3: element 'vertex' has no valid count");
}

/// An element without properties may claim any count: nothing is read for it.
#[test]
fn ply_propertyless_element_with_huge_count_is_skipped() {
    setup();
    let text = "ply\nformat ascii 1.0\nelement junk 18446744073709551615\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let m = parse_ply(Path::new("h.ply"), text.as_bytes()).unwrap();
    assert_eq!(m.mesh.indices.len(), 1);
}

/// Counts the file could hold but the memory budget cannot afford.
#[test]
fn ply_counts_beyond_memory_budget() {
    setup();
    // 20M faces of one-byte (empty) lists fit in the file's 20 MB, but not in 1 GiB of mesh.
    let n = 20_000_000u64;
    let mut bytes = format!("ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face {n}\nproperty list uchar int vertex_indices\nend_header\n").into_bytes();
    bytes.resize(bytes.len() + n as usize, 0);
    let expected = format!(
        "h.ply: a mesh of 0 vertices and {n} triangles would need {} of memory, more than the limit of 1.0 GiB (set OCTOLUX_MEMORY_LIMIT to change the limit)",
        budget::format_bytes(n * budget::TRIANGLE_BYTES)
    );
    assert_eq!(ply_err(&bytes), expected);
}

#[test]
fn ply_list_length_beyond_file_is_truncation() {
    let bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n\xff\xff\xff\xff";
    assert_eq!(ply_err(bytes), "h.ply: face 0: unexpected end of file");
}

fn nested(open: &str, close: &str, n: usize) -> String {
    format!("<scene version=\"3.0.0\">\n{}{}</scene>\n", open.repeat(n), close.repeat(n))
}

/// 20,000 nested `<shape>` (a 581 KB file that overflowed the stack).
#[test]
fn xml_deeply_nested_shapes() {
    let t = Instant::now();
    let e = xml_err(&nested("<shape type=\"obj\">", "</shape>", 20_000));
    assert_eq!(e, "h.xml:2: elements are nested more than 256 levels deep");
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
}

/// 100,000 nested `<transform>`, one per line: the line of the first one too deep is named.
#[test]
fn xml_deeply_nested_transforms() {
    let e = xml_err(&nested("<transform name=\"to_world\">\n", "</transform>", 100_000));
    assert_eq!(e, "h.xml:257: elements are nested more than 256 levels deep");
}

/// Nesting is counted across `<include>`d files too (each file alone is shallow enough).
#[test]
fn xml_nesting_counts_across_includes() {
    setup();
    let dir = tmp_dir("xml_nesting_includes");
    std::fs::write(dir.join("deep.xml"), nested("<bsdf type=\"twosided\">", "</bsdf>", 200)).unwrap();
    let main = format!(
        "<scene version=\"3.0.0\">{}<include filename=\"deep.xml\"/>{}</scene>",
        "<shape type=\"sphere\">".repeat(100),
        "</shape>".repeat(100)
    );
    let e = load_str(&main, &dir.join("main.xml"), &[]).unwrap_err().to_string();
    assert_eq!(e, format!("{}:2: elements are nested more than 256 levels deep (included files count)", dir.join("deep.xml").display()));
}

/// 1k–10k nested or sibling elements load in time linear in their number (line numbers were
/// found by scanning the text from its start for every element: quadratic).
#[test]
fn xml_many_elements_load_in_linear_time() {
    setup();
    let mut text = String::from("<scene version=\"3.0.0\">\n");
    for i in 0..20_000 {
        text.push_str(&format!("<bsdf type=\"diffuse\" id=\"b{i}\"><rgb name=\"reflectance\" value=\"0.5\"/></bsdf>\n"));
    }
    text.push_str("<bsdf type=\"$nope\"/>\n</scene>\n");
    let t = Instant::now();
    let e = xml_err(&text);
    assert!(e.starts_with("h.xml:20002: undefined parameter \"$nope\""), "{e}");
    assert!(t.elapsed() < Duration::from_secs(3), "{:?}", t.elapsed());
    // 250 levels (just inside the bound) of nested transforms.
    let e = xml_err(&format!(
        "<scene version=\"3.0.0\">\n<shape type=\"sphere\">{}{}</shape><bad/></scene>",
        "<transform name=\"to_world\">".repeat(250),
        "</transform>".repeat(250)
    ));
    assert!(!e.contains("nested"), "{e}");
}

/// A film the memory budget cannot afford (the issue's `32768x32768`, allowed by the range check).
#[test]
fn xml_film_beyond_memory_budget() {
    let text = "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<film type=\"hdrfilm\">\n<integer name=\"width\" value=\"32768\"/>\n<integer name=\"height\" value=\"32768\"/>\n</film>\n</sensor>\n</scene>\n";
    assert_eq!(
        xml_err(text),
        "h.xml:3: <film type=\"hdrfilm\">: a 32768x32768 film would need 64.0 GiB of memory, more than the limit of 1.0 GiB (set OCTOLUX_MEMORY_LIMIT to change the limit)"
    );
}

/// Six bytes that are not six characters (it panicked slicing inside a character).
#[test]
fn xml_hex_colour_with_multibyte_characters() {
    let text = "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\">\n<srgb name=\"reflectance\" value=\"#ééé\"/>\n</bsdf>\n</scene>\n";
    assert_eq!(xml_err(text), "h.xml:3: <srgb name=\"reflectance\">: could not parse the colour \"#ééé\"");
}

#[test]
fn obj_index_beyond_u64_is_an_error() {
    setup();
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n";
    let e = parse_obj_mesh(Path::new("h.obj"), text.as_bytes()).unwrap_err().to_string();
    assert_eq!(e, "h.obj:4: invalid vertex index '99999999999999999999'");
}

/// A serialized mesh (version 4) whose stream holds `flags`, an empty name and the counts only.
fn serialized_header(nv: u64, nf: u64) -> Vec<u8> {
    let mut z = ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    z.write_all(&0x1000u32.to_le_bytes()).unwrap();
    z.write_all(&[0]).unwrap();
    z.write_all(&nv.to_le_bytes()).unwrap();
    z.write_all(&nf.to_le_bytes()).unwrap();
    let mut bytes = vec![0x1C, 0x04, 4, 0];
    bytes.extend(z.finish().unwrap());
    bytes
}

#[test]
fn serialized_counts_beyond_memory_budget() {
    setup();
    let e = parse_serialized(Path::new("h.serialized"), &serialized_header(4_000_000_000, 1), 0).unwrap_err().to_string();
    assert_eq!(
        e,
        format!(
            "h.serialized: mesh 0: a mesh of 4000000000 vertices and 1 triangles would need {} of memory, more than the limit of 1.0 GiB (set OCTOLUX_MEMORY_LIMIT to change the limit)",
            budget::format_bytes(4_000_000_000 * budget::VERTEX_BYTES + budget::TRIANGLE_BYTES)
        )
    );
    let e = parse_serialized(Path::new("h.serialized"), &serialized_header(u64::MAX, 1), 0).unwrap_err().to_string();
    assert_eq!(e, "h.serialized: mesh 0: 18446744073709551615 vertices are more than octolux supports (2^32 - 1)");
    // Within the budget, the missing data is a truncation.
    let e = parse_serialized(Path::new("h.serialized"), &serialized_header(1000, 10), 0).unwrap_err().to_string();
    assert_eq!(e, "h.serialized: mesh 0: truncated data while reading the vertex positions");
}

/// A PNG of `w` x `h` pixels: a real IHDR chunk, then an empty IDAT chunk.
fn png_header(w: u32, h: u32) -> Vec<u8> {
    let mut bytes = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    for chunk in [ihdr, b"IDAT".to_vec()] {
        let mut crc = flate2::Crc::new();
        crc.update(&chunk);
        bytes.extend((chunk.len() as u32 - 4).to_be_bytes());
        bytes.extend(&chunk);
        bytes.extend(crc.sum().to_be_bytes());
    }
    bytes
}

#[test]
fn image_headers_beyond_memory_budget() {
    setup();
    let expected = |w: u64, h: u64, file: &str| {
        format!(
            "{file}: a {w}x{h} image would need {} of memory, more than the limit of 1.0 GiB (set OCTOLUX_MEMORY_LIMIT to change the limit)",
            budget::format_bytes(w * h * budget::TEXEL_BYTES)
        )
    };
    let e = decode_image(Path::new("h.png"), &png_header(100_000, 100_000)).unwrap_err().to_string();
    assert_eq!(e, expected(100_000, 100_000, "h.png"));
    let hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\n";
    let e = decode_image(Path::new("h.hdr"), hdr).unwrap_err().to_string();
    assert_eq!(e, expected(100_000, 100_000, "h.hdr"));
}

/// An EXR file whose data window is patched to 100000x100000 pixels.
#[test]
fn exr_header_beyond_memory_budget() {
    setup();
    let dir = tmp_dir("exr_header");
    let path = dir.join("small.exr");
    write_exr(&path, &Image { width: 2, height: 2, data: vec![Color::ONE; 4] }).unwrap();
    let mut bytes = std::fs::read(&path).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
    bytes[at + 8..at + 12].copy_from_slice(&99_999i32.to_le_bytes());
    bytes[at + 12..at + 16].copy_from_slice(&99_999i32.to_le_bytes());
    let e = decode_image(Path::new("h.exr"), &bytes).unwrap_err().to_string();
    assert_eq!(
        e,
        format!(
            "h.exr: a 100000x100000 image would need {} of memory, more than the limit of 1.0 GiB (set OCTOLUX_MEMORY_LIMIT to change the limit)",
            budget::format_bytes(100_000 * 100_000 * budget::TEXEL_BYTES)
        )
    );
}

/// Equal images give byte-identical EXR files (blocks in increasing line order), and they read
/// back exactly.
#[test]
fn exr_bytes_are_deterministic() {
    let dir = tmp_dir("exr_deterministic");
    let (w, h) = (300u32, 257u32);
    let data = (0..w * h).map(|i| Color::new(i as f32 * 0.001, (i % 7) as f32, ((i * 31) % 1000) as f32 * 1e-3)).collect();
    let img = Image { width: w, height: h, data };
    let mut files = Vec::new();
    for k in 0..4 {
        let p = dir.join(format!("{k}.exr"));
        write_exr(&p, &img).unwrap();
        files.push(std::fs::read(&p).unwrap());
    }
    assert!(files.windows(2).all(|f| f[0] == f[1]), "EXR bytes differ between writes");
    let back = read_exr(&dir.join("0.exr")).unwrap();
    assert_eq!(back.data, img.data);
}

#[test]
fn memory_limit_environment_value_is_checked() {
    // Only the parser: the environment of the test process is left alone.
    assert_eq!(budget::parse_bytes("12G"), Some(12 << 30));
    assert_eq!(budget::parse_bytes("lots"), None);
}

/// Every fuzz target returns (an error) on empty and on random input.
#[test]
fn fuzz_targets_survive_trivial_input() {
    setup();
    for t in fuzzing::TARGETS {
        for data in [
            &b""[..],
            b"\0",
            b"\xff\xfe\xfd garbage \x00\x01",
            b"<scene><shape type=\"ply\"><string name=\"filename\" value=\"\"/></shape></scene>",
        ] {
            assert!(fuzzing::run_target(t, data).is_some());
        }
    }
    assert!(fuzzing::run_target("nope", b"").is_none());
}

/// Warnings of a scene whose line 2 is `shape` (a shape element on one line).
fn shape_warnings(dir: &Path, shape: &str) -> (Vec<String>, usize) {
    setup();
    let text = format!("<scene version=\"3.0.0\">\n{shape}\n</scene>\n");
    let s = load_str(&text, &dir.join("h.xml"), &[]).unwrap_or_else(|e| panic!("{shape}: {e}"));
    // Only this scene's warnings (the default sensor's is always there).
    let w = s.warnings.into_iter().filter(|w| !w.contains("no usable sensor")).collect();
    (w, s.desc.shapes.len())
}

const AREA: &str = "<emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter>";

/// A shape with a singular `to_world` (a zero scale) left with zero area, and its area emitter:
/// one warning each (they vanished with only a mesh warning, the emitter without a word).
#[test]
fn singular_transform_and_zero_area_emitter_warn() {
    let dir = Path::new("");
    for scale in ["<scale value=\"0\"/>", "<scale y=\"0\"/>"] {
        let shape = format!("<shape type=\"rectangle\"><transform name=\"to_world\">{scale}</transform>{AREA}</shape>");
        let (w, n) = shape_warnings(dir, &shape);
        assert_eq!(
            w,
            [
                "h.xml:2: <shape type=\"rectangle\">: to_world is singular (determinant 0): the shape has zero area and is skipped",
                "h.xml:2: <emitter type=\"area\">: its shape has zero area: the emitter emits nothing",
            ],
            "{scale}"
        );
        assert_eq!(n, 0);
    }
    // A sphere scaled to a point, and one of radius 0 (an error before: Mitsuba loads both).
    let (w, n) =
        shape_warnings(dir, &format!("<shape type=\"sphere\"><transform name=\"to_world\"><scale value=\"0\"/></transform>{AREA}</shape>"));
    assert_eq!(w[0], "h.xml:2: <shape type=\"sphere\">: to_world is singular (determinant 0): the shape has zero area and is skipped");
    assert_eq!(w[1], "h.xml:2: <emitter type=\"area\">: its shape has zero area: the emitter emits nothing");
    assert_eq!((w.len(), n), (2, 0));
    let (w, n) = shape_warnings(dir, &format!("<shape type=\"sphere\"><float name=\"radius\" value=\"0\"/>{AREA}</shape>"));
    assert_eq!(
        w,
        [
            "h.xml:2: <shape type=\"sphere\">: the sphere has radius 0: the shape has zero area and is skipped",
            "h.xml:2: <emitter type=\"area\">: its shape has zero area: the emitter emits nothing",
        ]
    );
    assert_eq!(n, 0);
    // Without an emitter, only the shape's warning.
    let (w, _) = shape_warnings(dir, "<shape type=\"disk\"><transform name=\"to_world\"><scale x=\"0\"/></transform></shape>");
    assert_eq!(w, ["h.xml:2: <shape type=\"disk\">: to_world is singular (determinant 0): the shape has zero area and is skipped"]);
    // Tiny but regular scales are not singular (the determinant is taken in f64: 1e-60 is 0 in f32).
    let (w, n) = shape_warnings(
        dir,
        &format!("<shape type=\"sphere\"><transform name=\"to_world\"><scale value=\"1e-20\"/></transform>{AREA}</shape>"),
    );
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(n, 1);
}

/// A singular `to_world` that leaves area (a rectangle flattened along its normal, an OBJ
/// flattened to a plane) keeps the shape, with one warning; where Mitsuba 3 transforms the
/// shape's normals by the (missing) inverse, the warning says it renders differently.
#[test]
fn singular_transform_that_keeps_area_warns() {
    let dir = tmp_dir("singular_flattened");
    let (w, n) =
        shape_warnings(&dir, &format!("<shape type=\"rectangle\"><transform name=\"to_world\"><scale z=\"0\"/></transform>{AREA}</shape>"));
    let loc = dir.join("h.xml").display().to_string();
    assert_eq!(
        w,
        [format!(
            "{loc}:2: <shape type=\"rectangle\">: to_world is singular (determinant 0): the shape is flattened (Mitsuba 3 cannot \
             transform its normals by a singular matrix: it renders it black or refuses the file)"
        )]
    );
    assert_eq!(n, 1);
    std::fs::write(dir.join("m.obj"), "v -1 -1 0.5\nv 1 -1 0\nv 1 1 0.5\nv -1 1 0\nf 1 2 3\nf 1 3 4\n").unwrap();
    let obj =
        "<shape type=\"obj\"><string name=\"filename\" value=\"m.obj\"/><transform name=\"to_world\"><scale z=\"0\"/></transform></shape>";
    let (w, n) = shape_warnings(&dir, obj);
    assert_eq!(w, [format!("{loc}:2: <shape type=\"obj\">: to_world is singular (determinant 0): the shape is flattened")]);
    assert_eq!(n, 1);
}

/// An area emitter on a mesh file of only degenerate triangles: the mesh's warning, then the
/// emitter's.
#[test]
fn zero_area_mesh_emitter_warns() {
    let dir = tmp_dir("zero_area_mesh");
    std::fs::write(dir.join("flat.obj"), "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap();
    let (w, n) = shape_warnings(&dir, &format!("<shape type=\"obj\"><string name=\"filename\" value=\"flat.obj\"/>{AREA}</shape>"));
    let loc = dir.join("h.xml").display().to_string();
    assert_eq!(
        w,
        [
            format!("{loc}:2: <shape type=\"obj\">: the mesh has only degenerate triangles (1); the shape is skipped"),
            format!("{loc}:2: <emitter type=\"area\">: its shape has zero area: the emitter emits nothing"),
        ]
    );
    assert_eq!(n, 0);
}

/// An area emitter defined at scene level and referenced by a shape is read there, without the
/// "must be nested in a shape" warning (it said "ignored" while the shape emitted); one that no
/// shape references still warns (Mitsuba 3 renders nothing of it either).
#[test]
fn referenced_scene_level_area_emitter_is_used_without_warning() {
    setup();
    let text = "<scene version=\"3.0.0\">\n<emitter type=\"area\" id=\"e\"><rgb name=\"radiance\" value=\"2\"/></emitter>\n\
                <shape type=\"rectangle\"><ref id=\"e\"/></shape>\n</scene>\n";
    let s = load_str(text, Path::new("h.xml"), &[]).unwrap();
    assert!(s.warnings.iter().all(|w| !w.contains("emitter")), "{:?}", s.warnings);
    assert_eq!(s.desc.shapes[0].emission, Some(Color::splat(2.0)));
    let text = text.replace("<ref id=\"e\"/>", "");
    let s = load_str(&text, Path::new("h.xml"), &[]).unwrap();
    assert_eq!(s.warnings[0], "h.xml:2: <emitter type=\"area\" id=\"e\">: an area emitter must be nested in a shape; ignored");
    assert_eq!(s.desc.shapes[0].emission, None);
}
