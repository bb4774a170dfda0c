//! Entry points of the fuzz targets (`fuzz/`, run with `cargo +nightly fuzz`), kept here as
//! plain functions so that the corpus replay test (`tests/fuzz_corpus.rs`) runs the very same
//! code on stable. Each takes arbitrary bytes and returns the loader's result, which must be
//! `Ok` or a clear error: never a panic, an abort or an allocation beyond the memory budget
//! ([`octolux::budget`]).
//!
//! The names given to the data (`fuzz.xml`, `fuzz.obj`, ...) only appear in messages and
//! anchor relative file names (the XML target's `<include>`s and meshes resolve against the
//! current folder).

use crate::IoError;
use std::path::Path;

/// Memory limit the fuzz targets and the replay test set (bytes): small enough that what the
/// budget accepts fits in libFuzzer's default 2 GiB RSS limit.
pub const FUZZ_MEMORY_LIMIT: u64 = 256 << 20;

/// Names of the targets, which are also the folders under `fuzz/corpus/`.
pub const TARGETS: [&str; 6] = ["xml", "obj", "ply", "serialized", "image", "cache"];

/// Run target `name` on `data`; `None` for an unknown target name.
pub fn run_target(name: &str, data: &[u8]) -> Option<Result<(), IoError>> {
    Some(match name {
        "xml" => xml(data),
        "obj" => obj(data),
        "ply" => ply(data),
        "serialized" => serialized(data),
        "image" => image(data),
        "cache" => cache(data),
        _ => return None,
    })
}

/// Mitsuba XML (text decoded as UTF-8, invalid sequences replaced), without `-D` defines.
pub fn xml(data: &[u8]) -> Result<(), IoError> {
    let text = String::from_utf8_lossy(data);
    crate::mitsuba::load_str(&text, Path::new("fuzz.xml"), &[]).map(|_| ())
}

/// An OBJ mesh (materials not read).
pub fn obj(data: &[u8]) -> Result<(), IoError> {
    crate::mesh::parse_obj_mesh(Path::new("fuzz.obj"), data).map(|_| ())
}

/// A PLY mesh.
pub fn ply(data: &[u8]) -> Result<(), IoError> {
    crate::mesh::parse_ply(Path::new("fuzz.ply"), data).map(|_| ())
}

/// A serialized mesh file: the first byte selects the shape index (0..=3), the rest is the file.
pub fn serialized(data: &[u8]) -> Result<(), IoError> {
    let (index, bytes) = match data.split_first() {
        Some((&i, rest)) => ((i % 4) as u32, rest),
        None => (0, data),
    };
    crate::mesh::parse_serialized(Path::new("fuzz.serialized"), bytes, index).map(|_| ())
}

/// A texture as octolux decodes it: the first byte selects the format (by the extension the
/// loader would see: exr, png, jpg, hdr), the rest is the file.
pub fn image(data: &[u8]) -> Result<(), IoError> {
    let (ext, bytes) = match data.split_first() {
        Some((&i, rest)) => (["exr", "png", "jpg", "hdr"][(i % 4) as usize], rest),
        None => ("png", data),
    };
    crate::image_io::decode_image(Path::new(&format!("fuzz.{ext}")), bytes).map(|_| ())
}

/// A baked lighting file (`.oxc`): parsed and its octrees checked as `render --cache` does,
/// except the CRC, which is not compared so that mutated inputs reach the parser (the
/// checksum's own refusals are tested in `tests/cache.rs`).
pub fn cache(data: &[u8]) -> Result<(), IoError> {
    crate::cache::load_bytes(data, false).map(|_| ()).map_err(|m| IoError::invalid(Path::new("fuzz.oxc"), m))
}
