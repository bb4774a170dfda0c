//! Catalogue of hostile inputs (issue 12): each case is a file a careless or malicious user could
//! give, and the exact error it must produce — never an abort, a panic or an allocation the
//! memory budget refuses. `docs/guide/errors.md` lists the same cases.
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

/// The issue's reproduction: a 252-byte PLY file whose header claims 4,000,000,000 vertices
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

// ---------------------------------------------------------------------------------------------
// Round 3 (issue 27): amplification, reference cycles, files that are not regular, glTF
// ---------------------------------------------------------------------------------------------

/// The issue's one-line scene: a bsdf that holds a reference to itself overflowed the stack
/// (SIGABRT). A cycle is an error naming its ids at the `<ref>` that closes it.
#[test]
fn ref_cycles_are_errors_naming_ids_and_line() {
    assert_eq!(
        xml_err(r#"<scene version="3.0.0"><bsdf type="twosided" id="x"><ref id="x"/></bsdf></scene>"#),
        "h.xml:1: <ref id=\"x\">: the references make a cycle: x -> x (an object cannot hold itself)"
    );
    let two = "<scene version=\"3.0.0\">\n<bsdf type=\"twosided\" id=\"a\"><ref id=\"b\"/></bsdf>\n\
               <bsdf type=\"twosided\" id=\"b\">\n<bsdf type=\"mask\"><ref id=\"a\"/></bsdf></bsdf>\n</scene>";
    assert_eq!(xml_err(two), "h.xml:2: <ref id=\"b\">: the references make a cycle: b -> a -> b (an object cannot hold itself)");
    // through an alias
    let alias = "<scene version=\"3.0.0\">\n<bsdf type=\"twosided\" id=\"a\"><ref id=\"z\"/></bsdf>\n<alias id=\"a\" as=\"z\"/>\n</scene>";
    assert_eq!(xml_err(alias), "h.xml:2: <ref id=\"z\">: the references make a cycle: z -> z (an object cannot hold itself)");
    // a chain of 300 objects, each holding the next: nested too deep through references
    let mut chain = String::from("<scene version=\"3.0.0\">\n");
    for i in 0..300 {
        chain.push_str(&format!("<bsdf type=\"twosided\" id=\"b{i}\"><ref id=\"b{}\"/></bsdf>\n", i + 1));
    }
    chain.push_str("<bsdf type=\"diffuse\" id=\"b300\"/>\n</scene>");
    let e = xml_err(&chain);
    assert!(e.ends_with("objects are nested more than 256 levels deep through references"), "{e}");
    // a shared object referenced many times is fine
    let mut shared = String::from("<scene version=\"3.0.0\"><bsdf type=\"diffuse\" id=\"m\"/>");
    for _ in 0..2000 {
        shared.push_str("<shape type=\"sphere\"><ref id=\"m\"/></shape>");
    }
    shared.push_str("</scene>");
    setup();
    assert_eq!(load_str(&shared, Path::new("h.xml"), &[]).unwrap().desc.shapes.len(), 2000);
}

/// The issue's 1 KB chain of `<default>`s, each value ten copies of the one before: it asked
/// for 9.6 GB and aborted (six levels gave a 12 MB error line). The value's length is known
/// before each substitution and refused past 64 KiB.
#[test]
fn default_chains_that_multiply_are_refused() {
    let mut text = String::from("<scene version=\"3.0.0\">\n<default name=\"a0\" value=\"0123456789\"/>\n");
    for i in 1..10 {
        text.push_str(&format!("<default name=\"a{i}\" value=\"{}\"/>\n", format!("$a{}", i - 1).repeat(10)));
    }
    text.push_str("<integrator type=\"path\"><string name=\"x\" value=\"$a9\"/></integrator>\n</scene>");
    assert_eq!(
        xml_err(&text),
        "h.xml:6: the value of <default> would grow to 100000 bytes once $a3 is substituted, more than 65536 \
         (<default>s whose values repeat each other multiply)"
    );
    // many values each under the cap, but all together too much
    let mut text = String::from("<scene version=\"3.0.0\">\n");
    text.push_str(&format!("<default name=\"big\" value=\"{}\"/>\n", "x".repeat(60_000)));
    for _ in 0..1200 {
        text.push_str("<integrator type=\"path\"><string name=\"x\" value=\"$big\"/></integrator>\n");
    }
    text.push_str("</scene>");
    let e = xml_err(&text);
    assert!(e.ends_with("$name substitution has produced more than 67108864 bytes in this scene"), "{e}");
}

/// 12 files with 4 `<include>`s each of the next (4^11 includes) ran for minutes; the includes
/// of a scene are counted, all files together.
#[test]
fn includes_that_multiply_are_counted() {
    setup();
    let dir = tmp_dir("includes_multiply");
    for i in 0..12 {
        let body =
            if i == 11 { "<bsdf type=\"diffuse\"/>".to_string() } else { format!("<include filename=\"f{}.xml\"/>", i + 1).repeat(4) };
        std::fs::write(dir.join(format!("f{i}.xml")), format!("<scene version=\"3.0.0\">{body}</scene>")).unwrap();
    }
    let main = dir.join("f0.xml");
    let e = octolux_io::mitsuba::load(&main, &[]).unwrap_err().to_string();
    assert!(e.ends_with("<include>: more than 10000 files included in all (files that include each other several times multiply)"), "{e}");
    assert!(e.starts_with(&dir.display().to_string()), "names the file: {e}");
}

/// A folder or a device given as an include, a bitmap or a mesh: it was "not found"; now the
/// message says what it is. A device is never read (`/dev/zero` would fill the memory).
#[test]
fn inputs_that_are_not_regular_files_say_what_they_are() {
    setup();
    let dir = tmp_dir("not_regular");
    std::fs::create_dir_all(dir.join("inc.xml")).unwrap();
    std::fs::create_dir_all(dir.join("tex.png")).unwrap();
    let load = |body: &str| {
        let p = dir.join("h.xml");
        std::fs::write(&p, format!("<scene version=\"3.0.0\">\n{body}\n</scene>")).unwrap();
        octolux_io::mitsuba::load(&p, &[]).unwrap_err().to_string()
    };
    let h = dir.join("h.xml").display().to_string();
    let d = dir.display().to_string();
    assert_eq!(
        load("<include filename=\"inc.xml\"/>"),
        format!("{h}:2: cannot read included file {d}/inc.xml: this is a folder, not a file")
    );
    assert_eq!(
        load("<include filename=\"/dev/zero\"/>"),
        format!(
            "{h}:2: cannot read included file /dev/zero: this is a character device, not a regular file: octolux reads only regular files"
        )
    );
    let bitmap = |f: &str| {
        format!(
            "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">\
             <string name=\"filename\" value=\"{f}\"/></texture></bsdf></shape>"
        )
    };
    assert_eq!(load(&bitmap("tex.png")), format!("{d}/tex.png: this is a folder, not a file"));
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.png")).unwrap();
    assert_eq!(
        load(&bitmap("zero.png")),
        format!("{d}/zero.png: this is a character device, not a regular file: octolux reads only regular files")
    );
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.ply")).unwrap();
    let e = load("<shape type=\"ply\"><string name=\"filename\" value=\"zero.ply\"/></shape>");
    assert!(e.ends_with("zero.ply: this is a character device, not a regular file: octolux reads only regular files"), "{e}");
    let e = octolux_io::cache::read(Path::new("/dev/zero")).err().expect("refused").to_string();
    assert_eq!(e, "/dev/zero: this is a character device, not a regular file: octolux reads only regular files");
    let e = read_exr(Path::new("/dev/zero")).unwrap_err().to_string();
    assert_eq!(e, "/dev/zero: this is a character device, not a regular file: octolux reads only regular files");
    // a FIFO is never opened (opening one blocks until a writer comes)
    let fifo = dir.join("pipe.obj");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let e = octolux_io::load_scene(&fifo.display().to_string(), &[]).unwrap_err().to_string();
    assert_eq!(e, format!("{}: this is a FIFO (named pipe), not a regular file: octolux reads only regular files", fifo.display()));
}

/// Standard base64 (RFC 4648, padded), for the `data:` URIs of the glTF cases.
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for ch in bytes.chunks(3) {
        let n = (ch[0] as u32) << 16 | (*ch.get(1).unwrap_or(&0) as u32) << 8 | *ch.get(2).unwrap_or(&0) as u32;
        for i in 0..4 {
            s.push(if i <= ch.len() { A[(n >> (18 - 6 * i) & 63) as usize] as char } else { '=' });
        }
    }
    s
}

/// One triangle's buffer: 3 positions (36 bytes), 3 u16 indices (6 bytes), padding (2).
fn triangle_buffer() -> Vec<u8> {
    let mut b = Vec::new();
    for v in [0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b.extend_from_slice(&[0, 0]);
    b
}

/// A glTF document of one triangle mesh (accessor 0: positions, 1: indices of `index_count`),
/// with `nodes` (JSON) and scene roots `roots`, and the buffer at `uri` (default: a data URI).
fn gltf_doc(nodes: &str, roots: &str, index_count: u64, uri: Option<&str>) -> String {
    let data = format!("data:application/octet-stream;base64,{}", base64(&triangle_buffer()));
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": {roots}}}], "nodes": {nodes},
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
    {{"bufferView": 1, "componentType": 5123, "count": {index_count}, "type": "SCALAR"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": 6}}],
  "buffers": [{{"byteLength": 44, "uri": "{}"}}]}}"#,
        uri.unwrap_or(&data)
    )
}

fn gltf_err(text: &str) -> String {
    setup();
    octolux_io::gltf_scene::load_bytes(Path::new("h.gltf"), text.as_bytes()).unwrap_err().to_string()
}

/// A 3-node cycle said "more than a million nodes"; nodes that list the next one twice made
/// 262,144 instances of a mesh and aborted on allocation: the instances and the triangles
/// after instancing are counted before any mesh is read.
#[test]
fn gltf_node_cycles_and_instancing_are_bounded() {
    let cycle = r#"[{"children": [1]}, {"children": [2]}, {"children": [0], "mesh": 0}]"#;
    assert_eq!(
        gltf_err(&gltf_doc(cycle, "[0]", 3, None)),
        "h.gltf: node 0 is its own ancestor: the node tree has a cycle (0 -> 1 -> 2 -> 0)"
    );
    // 18 nodes, each listing the next twice; the last holds a mesh of 2,000 triangles
    let doubling = |levels: usize| {
        let mut nodes: Vec<String> = (0..levels - 1).map(|i| format!("{{\"children\": [{0}, {0}]}}", i + 1)).collect();
        nodes.push("{\"mesh\": 0}".into());
        format!("[{}]", nodes.join(", "))
    };
    assert_eq!(
        gltf_err(&gltf_doc(&doubling(18), "[0]", 6000, None)),
        format!(
            "h.gltf: the node tree, once instanced: a mesh of 393216 vertices and 262144000 triangles would need {} of memory, \
             more than the limit of 1.0 GiB (set OCTOLUX_MEMORY_LIMIT to change the limit)",
            budget::format_bytes(393216 * budget::VERTEX_BYTES + 262144000 * budget::TRIANGLE_BYTES)
        )
    );
    assert_eq!(
        gltf_err(&gltf_doc(&doubling(21), "[0]", 3, None)),
        "h.gltf: the node tree makes 2097151 node instances, more than 1000000 (a node listed as a child several times is copied each time)"
    );
    // a few instances are fine
    setup();
    let s = octolux_io::gltf_scene::load_bytes(Path::new("h.gltf"), gltf_doc(&doubling(3), "[0]", 3, None).as_bytes()).unwrap();
    assert_eq!(s.desc.shapes.len(), 4);
}

/// An index accessor of 3,000,000 over 6 bytes was ignored and the primitive drawn without
/// indices; a bad position accessor said "has no positions". Each names the accessor now.
#[test]
fn gltf_accessors_outside_their_buffer_are_errors() {
    assert_eq!(
        gltf_err(&gltf_doc(r#"[{"mesh": 0}]"#, "[0]", 3_000_000, None)),
        "h.gltf: mesh 0: primitive 0: its index accessor 1 (3000000 values of 2 bytes from offset 0) lies outside its buffer view 1 \
         (6 bytes from offset 36 of a 44-byte buffer)"
    );
    let doc = gltf_doc(r#"[{"mesh": 0}]"#, "[0]", 3, None).replace(r#""count": 3, "type": "VEC3""#, r#""count": 30, "type": "VEC3""#);
    assert_eq!(
        gltf_err(&doc),
        "h.gltf: mesh 0: primitive 0: its POSITION accessor 0 (30 values of 12 bytes from offset 0) lies outside its buffer view 0 \
         (36 bytes from offset 0 of a 44-byte buffer)"
    );
    let doc = gltf_doc(r#"[{"mesh": 0}]"#, "[0]", 3, None).replace(r#""componentType": 5123"#, r#""componentType": 5126"#);
    assert_eq!(
        gltf_err(&doc),
        "h.gltf: mesh 0: primitive 0: its index accessor 1 holds Scalar of F32, expected Scalar of U8 or U16 or U32"
    );
    // a POSITION naming an accessor the file lacks: the gltf crate's validation indexed it
    // before checking it (a panic the fuzz target found)
    let doc = gltf_doc(r#"[{"mesh": 0}]"#, "[0]", 3, None).replace(r#""POSITION": 0"#, r#""POSITION": 5"#);
    assert_eq!(gltf_err(&doc), "h.gltf: mesh 0: primitive 0: POSITION names accessor 5, but the file has 2");
    // a .glb whose header gives a length below the header's own 12 bytes: the gltf crate's
    // splitter subtracted before checking (an overflow panic the fuzz target found)
    assert_eq!(
        gltf_err("glTF\u{2}\0\0\0\u{4}\0\0\0"),
        "h.gltf: not a valid .glb file: the header gives a length of 4 bytes, but the file has 12"
    );
    let json = gltf_doc(r#"[{"mesh": 0}]"#, "[0]", 3, None);
    let chunk = json.len() as u32 + 100;
    let glb = [&b"glTF\x02\0\0\0"[..], &(20 + json.len() as u32).to_le_bytes(), &chunk.to_le_bytes(), b"JSON", json.as_bytes()].concat();
    setup();
    assert_eq!(
        octolux_io::gltf_scene::load_bytes(Path::new("h.glb"), &glb).unwrap_err().to_string(),
        format!("h.glb: not a valid .glb file: chunk 0 of {chunk} bytes passes the end of the file")
    );
    let glb =
        [&b"glTF\x02\0\0\0"[..], &(20 + json.len() as u32).to_le_bytes(), &(json.len() as u32).to_le_bytes(), b"JSON", json.as_bytes()]
            .concat();
    assert_eq!(octolux_io::gltf_scene::load_bytes(Path::new("h.glb"), &glb).unwrap().desc.shapes.len(), 1);
    // a buffer shorter than its byteLength
    let short = format!("data:application/octet-stream;base64,{}", base64(&triangle_buffer()[..40]));
    assert_eq!(
        gltf_err(&gltf_doc(r#"[{"mesh": 0}]"#, "[0]", 3, Some(&short))),
        "h.gltf: buffer 0 holds 40 bytes, less than its byteLength 44"
    );
}

/// `extras` may hold any JSON value (an array was refused), and URIs stay in the file's folder.
#[test]
fn gltf_extras_of_any_kind_and_uris_inside_the_folder() {
    setup();
    let doc = gltf_doc(r#"[{"mesh": 0, "extras": [1, 2, {"a": "b"}]}]"#, "[0]", 3, None);
    let s = octolux_io::gltf_scene::load_bytes(Path::new("h.gltf"), doc.as_bytes()).unwrap();
    assert_eq!(s.desc.shapes.len(), 1);
    for uri in ["/dev/zero", "../../../../etc/hostname", "file:///etc/hostname"] {
        assert_eq!(
            gltf_err(&gltf_doc(r#"[{"mesh": 0}]"#, "[0]", 3, Some(uri))),
            format!("h.gltf: buffer 0: URI \"{uri}\" names a file outside the glTF file's folder (allow it with --allow-outside-uris)")
        );
    }
    // a buffer file beside it (also through `sub/..`) is read
    let dir = tmp_dir("gltf_uris");
    std::fs::write(dir.join("tri.bin"), triangle_buffer()).unwrap();
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    for uri in ["tri.bin", "sub/../tri.bin"] {
        let p = dir.join("h.gltf");
        std::fs::write(&p, gltf_doc(r#"[{"mesh": 0}]"#, "[0]", 3, Some(uri))).unwrap();
        assert_eq!(octolux_io::gltf_scene::load(&p).unwrap().desc.shapes.len(), 1, "{uri}");
    }
    // a folder named as a buffer
    let p = dir.join("h.gltf");
    std::fs::write(&p, gltf_doc(r#"[{"mesh": 0}]"#, "[0]", 3, Some("sub"))).unwrap();
    assert_eq!(
        octolux_io::gltf_scene::load(&p).unwrap_err().to_string(),
        format!("{}: buffer 0: {}/sub: this is a folder, not a file", p.display(), dir.display())
    );
}

/// Valid files that were refused: a Radiance file with Mitsuba's `#?RGBE` header ("format
/// could not be determined"; these are the bytes Mitsuba 3.9.1 writes for a 3x2 image of 0.5),
/// and a one-channel EXR (Mitsuba's `Y` format), as a texture and as `compare` reads it.
#[test]
fn mitsuba_hdr_and_one_channel_exr_are_read() {
    setup();
    let mut hdr = b"#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 3\n".to_vec();
    hdr.extend_from_slice(&[0x80; 24]);
    let img = decode_image(Path::new("mi.hdr"), &hdr).unwrap();
    assert_eq!((img.width, img.height), (3, 2));
    // RGBE (128, 128, 128, e 128) is (128 + 0.5) / 256: the decoder's rounding
    assert!(img.data.iter().all(|c| (c.x - 0.5).abs() < 4e-3 && c.x == c.y && c.y == c.z), "{:?}", img.data[0]);

    let dir = tmp_dir("one_channel_exr");
    for name in ["Y", "L"] {
        let path = dir.join(format!("{name}.exr"));
        let channel = exr::prelude::AnyChannel::new(name, exr::prelude::FlatSamples::F32(vec![0.25, 0.5, 0.75, 1.0, 1.25, 1.5]));
        let layer = exr::prelude::Layer::new(
            (3, 2),
            exr::prelude::LayerAttributes::default(),
            exr::prelude::Encoding::FAST_LOSSLESS,
            exr::prelude::AnyChannels::sort(vec![channel].into()),
        );
        use exr::prelude::WritableImage;
        exr::prelude::Image::from_layer(layer).write().to_file(&path).unwrap();
        let img = read_exr(&path).unwrap();
        assert_eq!((img.width, img.height), (3, 2));
        assert_eq!(img.data.iter().map(|c| c.x).collect::<Vec<_>>(), [0.25, 0.5, 0.75, 1.0, 1.25, 1.5], "{name}");
        assert!(img.data.iter().all(|c| c.x == c.y && c.y == c.z));
        assert_eq!(octolux_io::image_io::read_image(&path).unwrap().data, img.data, "as a texture");
    }
}

/// Texels are checked as colours are: NaN or infinity is an error naming the file and the
/// first texel; negative texels are clamped to 0 with a warning.
#[test]
fn texels_are_checked_as_colours() {
    setup();
    let dir = tmp_dir("texels");
    let px = |v: f32| Color::new(v, v, v);
    let scene = |tex: &str| {
        format!(
            "<scene version=\"3.0.0\"><shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">\
             <string name=\"filename\" value=\"{tex}\"/></texture></bsdf></shape></scene>"
        )
    };
    let nan = Image { width: 2, height: 2, data: vec![px(0.5), px(0.5), Color::new(0.1, f32::NAN, 0.1), px(f32::INFINITY)] };
    write_exr(&dir.join("nan.exr"), &nan).unwrap();
    let p = dir.join("h.xml");
    std::fs::write(&p, scene("nan.exr")).unwrap();
    assert_eq!(
        octolux_io::mitsuba::load(&p, &[]).unwrap_err().to_string(),
        format!(
            "{}/nan.exr: 2 texels hold NaN or infinite values (the first at x 0, y 1); a texture's values must be finite",
            dir.display()
        )
    );
    let neg = Image { width: 2, height: 1, data: vec![px(0.5), Color::new(0.2, -0.25, 0.0)] };
    write_exr(&dir.join("neg.exr"), &neg).unwrap();
    std::fs::write(&p, scene("neg.exr")).unwrap();
    let s = octolux_io::mitsuba::load(&p, &[]).unwrap();
    assert!(
        s.warnings.contains(&format!("{}/neg.exr: 1 texels have negative values (the lowest -0.25); clamped to 0", dir.display())),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.desc.images[0].data[1], Color::new(0.2, 0.0, 0.0));
}

/// Values far out of range: a reflectance of 5 and a mask opacity of 2 warn (they passed
/// silently); a `-D` given twice keeps the last value, with a warning (it kept the first).
#[test]
fn out_of_range_colours_warn_and_repeated_defines_take_the_last() {
    setup();
    let text = "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"a\">\n<rgb name=\"reflectance\" value=\"5\"/></bsdf>\n\
                <bsdf type=\"mask\" id=\"b\">\n<float name=\"opacity\" value=\"2\"/><bsdf type=\"diffuse\"/></bsdf>\n\
                <shape type=\"sphere\"><ref id=\"a\"/></shape><shape type=\"sphere\"><ref id=\"b\"/></shape>\n</scene>";
    let s = load_str(text, Path::new("h.xml"), &[]).unwrap();
    let above = |line: u32, what: &str, c: &str| {
        format!("h.xml:{line}: {what}: {c} is above 1: a reflectance over 1 creates light (an opacity or a blend weight is read as 1); kept as given")
    };
    assert!(s.warnings.contains(&above(3, "<rgb name=\"reflectance\">", "5")), "{:?}", s.warnings);
    assert!(s.warnings.contains(&above(5, "<float name=\"opacity\">", "2")), "{:?}", s.warnings);
    let text = "<scene version=\"3.0.0\"><default name=\"r\" value=\"0.1\"/>\
                <shape type=\"sphere\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"$r\"/></bsdf></shape></scene>";
    let defines = [("r".to_string(), "0.2".to_string()), ("r".to_string(), "0.3".to_string())];
    let s = load_str(text, Path::new("h.xml"), &defines).unwrap();
    assert_eq!(s.warnings[0], "-D r=0.3 repeats -D r=0.2: the last value wins");
    let octolux::scene::material::Material::Diffuse { reflectance: octolux::scene::material::Texture::Const(c) } = &s.desc.materials[0]
    else {
        panic!("{:?}", s.desc.materials[0])
    };
    assert_eq!(*c, Color::splat(0.3));
}

/// A binary PLY grid of `nx` x `ny` quads (two triangles each) in the plane z = 0, written row
/// by row: `(nx + 1)(ny + 1)` vertices, `2 nx ny` triangles.
fn write_ply_grid(path: &Path, nx: u32, ny: u32) {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let (v, t) = ((nx + 1) * (ny + 1), 2 * nx * ny);
    write!(
        f,
        "ply\nformat binary_little_endian 1.0\nelement vertex {v}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {t}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    .unwrap();
    for j in 0..=ny {
        for i in 0..=nx {
            for c in [i as f32 / nx as f32, j as f32 / ny as f32, 0.0] {
                f.write_all(&c.to_le_bytes()).unwrap();
            }
        }
    }
    for j in 0..ny {
        for i in 0..nx {
            let a = j * (nx + 1) + i;
            let (b, c, d) = (a + 1, a + nx + 1, a + nx + 2);
            for tri in [[a, b, d], [a, d, c]] {
                f.write_all(&[3]).unwrap();
                for k in tri {
                    f.write_all(&(k as i32).to_le_bytes()).unwrap();
                }
            }
        }
    }
    f.flush().unwrap();
}

/// A 1 KB scene naming one mesh file in many shapes read it once per shape: each read passed
/// the budget alone, and 10 shapes of a 2-million-triangle PLY loaded under a 1 GiB limit
/// (3.3 GB peak). The meshes of a scene are counted together, at the shape that passes.
#[test]
fn one_mesh_file_named_by_many_shapes_is_counted_once_per_shape() {
    setup();
    let dir = tmp_dir("many_shapes");
    // 250,000 triangles and 125,751 vertices: within the limit alone
    let (nx, ny) = (500, 250);
    write_ply_grid(&dir.join("g.ply"), nx, ny);
    let (v, t) = (((nx + 1) * (ny + 1)) as u64, (2 * nx * ny) as u64);
    let one = v * budget::VERTEX_BYTES + t * budget::TRIANGLE_BYTES;
    assert!(one < LIMIT);
    let fit = LIMIT / one; // shapes that fit; the next one passes the limit
    let shape = "<shape type=\"ply\"><string name=\"filename\" value=\"g.ply\"/></shape>\n";
    let p = dir.join("h.xml");
    std::fs::write(&p, format!("<scene version=\"3.0.0\">\n{}</scene>", shape.repeat(fit as usize + 5))).unwrap();
    let line = fit + 2;
    let n = fit + 1;
    assert_eq!(
        octolux_io::mitsuba::load(&p, &[]).unwrap_err().to_string(),
        format!(
            "{}:{line}: <shape type=\"ply\">: the scene's meshes together, with this one: a mesh of {} vertices and {} triangles \
             would need {} of memory, more than the limit of 1.0 GiB (set OCTOLUX_MEMORY_LIMIT to change the limit)",
            p.display(),
            n * v,
            n * t,
            budget::format_bytes(n * one)
        )
    );
    // as many shapes as fit are read
    std::fs::write(&p, format!("<scene version=\"3.0.0\">\n{}</scene>", shape.repeat(fit as usize))).unwrap();
    assert_eq!(octolux_io::mitsuba::load(&p, &[]).unwrap().desc.shapes.len(), fit as usize);
}

/// `/dev/zero` (or a FIFO) named directly as a bitmap, a mesh or a scene said "unsupported
/// image format '.'" ("unknown mesh format", "unknown scene format"): what the file is comes
/// first now; a regular file without an extension says that it has none.
#[test]
fn a_device_named_as_a_bitmap_or_mesh_says_what_it_is() {
    setup();
    let dir = tmp_dir("device_by_name");
    let p = dir.join("h.xml");
    let load = |body: &str| {
        std::fs::write(&p, format!("<scene version=\"3.0.0\">\n{body}\n</scene>")).unwrap();
        octolux_io::mitsuba::load(&p, &[]).unwrap_err().to_string()
    };
    let dev = "/dev/zero: this is a character device, not a regular file: octolux reads only regular files";
    let bitmap = |f: &str| {
        format!(
            "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">\
             <string name=\"filename\" value=\"{f}\"/></texture></bsdf></shape>"
        )
    };
    assert_eq!(load(&bitmap("/dev/zero")), dev);
    assert_eq!(load("<emitter type=\"envmap\"><string name=\"filename\" value=\"/dev/zero\"/></emitter>"), dev);
    assert_eq!(load("<shape type=\"ply\"><string name=\"filename\" value=\"/dev/zero\"/></shape>"), dev);
    assert_eq!(octolux_io::load_scene("/dev/zero", &[]).unwrap_err().to_string(), dev);
    let fifo = dir.join("pipe");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    assert_eq!(
        load(&bitmap("pipe")),
        format!("{}: this is a FIFO (named pipe), not a regular file: octolux reads only regular files", fifo.display())
    );
    // a regular file without an extension: the message says so (it said "format '.'")
    std::fs::write(dir.join("tex"), b"not an image").unwrap();
    assert_eq!(
        load(&bitmap("tex")),
        format!(
            "{}/tex: the image format is chosen by the file's extension, and this name has none (expected png, jpg, exr or hdr)",
            dir.display()
        )
    );
    assert_eq!(
        load("<shape type=\"ply\"><string name=\"filename\" value=\"tex\"/></shape>"),
        format!("{}/tex: the mesh format is chosen by the file's extension, and this name has none (expected .obj or .ply)", dir.display())
    );
    std::fs::write(dir.join("t.tga"), b"not an image").unwrap();
    assert_eq!(load(&bitmap("t.tga")), format!("{}/t.tga: unsupported image format '.tga' (expected png, jpg, exr or hdr)", dir.display()));
}

/// Issue 30: a misspelt bsdf type was a warning and rendered grey 0.5; a type that is no
/// Mitsuba bsdf is an error naming the file, the line and the type, with the closest name.
#[test]
fn xml_unknown_bsdf_type_is_an_error_with_the_closest_name() {
    let scene = |ty: &str| format!("<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<bsdf type=\"{ty}\"/>\n</shape>\n</scene>");
    assert_eq!(xml_err(&scene("difuse")), "h.xml:3: <bsdf type=\"difuse\">: unknown bsdf type \"difuse\" (did you mean \"diffuse\"?)");
    assert_eq!(
        xml_err(&scene("roughconductr")),
        "h.xml:3: <bsdf type=\"roughconductr\">: unknown bsdf type \"roughconductr\" (did you mean \"roughconductor\"?)"
    );
    let e = xml_err(&scene("glass"));
    assert!(e.starts_with("h.xml:3: <bsdf type=\"glass\">: unknown bsdf type \"glass\": no bsdf of Mitsuba 3 or 0.6 has that name"), "{e}");
    assert!(e.contains("(octolux reads diffuse, dielectric, "), "{e}");
    // at scene level, used by nothing: Mitsuba instantiates it and refuses the file too
    let top = "<scene version=\"3.0.0\">\n<bsdf type=\"plastik\" id=\"p\"/>\n<shape type=\"sphere\"/>\n</scene>";
    assert!(
        xml_err(top).starts_with("h.xml:2: <bsdf type=\"plastik\" id=\"p\">: unknown bsdf type \"plastik\" (did you mean \"plastic\"?)")
    );
    // a real Mitsuba plugin octolux does not read: a warning, the default diffuse
    setup();
    for ty in ["hair", "principled", "roughdiffuse", "coating"] {
        let s = load_str(&scene(ty), Path::new("h.xml"), &[]).expect("loads");
        assert!(s.warnings.iter().any(|w| w.contains(&format!("unsupported bsdf type \"{ty}\""))), "{ty}: {:?}", s.warnings);
    }
}
