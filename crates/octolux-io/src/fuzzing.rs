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
pub const TARGETS: [&str; 9] = ["xml", "obj", "ply", "serialized", "image", "cache", "gltf", "settings", "paths"];

/// Run target `name` on `data`; `None` for an unknown target name.
pub fn run_target(name: &str, data: &[u8]) -> Option<Result<(), IoError>> {
    Some(match name {
        "xml" => xml(data),
        "obj" => obj(data),
        "ply" => ply(data),
        "serialized" => serialized(data),
        "image" => image(data),
        "cache" => cache(data),
        "gltf" => gltf(data),
        "settings" => settings(data),
        "paths" => paths(data),
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

/// A glTF scene (`.gltf` JSON or `.glb` binary, told apart by the bytes): buffers and images
/// are `data:` URIs or the GLB's chunk (a relative URI would name a file of the current folder,
/// where the budget and the rules of [`crate::files`] hold as for any file).
pub fn gltf(data: &[u8]) -> Result<(), IoError> {
    crate::gltf_scene::load_bytes(Path::new("fuzz.gltf"), data).map(|_| ())
}

/// A settings file (`--settings`): the first byte selects JSON or TOML, the rest is the text
/// (invalid UTF-8 replaced), resolved alone into an integrator's settings and checked.
pub fn settings(data: &[u8]) -> Result<(), IoError> {
    let (name, text) = match data.split_first() {
        Some((&i, rest)) => (if i % 2 == 0 { "fuzz.json" } else { "fuzz.toml" }, rest),
        None => ("fuzz.json", data),
    };
    let path = Path::new(name);
    crate::settings::resolve_file_text(path, &String::from_utf8_lossy(text)).map(|_| ()).map_err(|e| IoError::invalid(path, e.0))
}

/// A camera path (first byte even: JSON, odd: TOML) or, for a first byte of 2 or 3 modulo 4, an
/// object path (JSON); a valid path's frames are all made (cameras, transforms), as `render`
/// makes them.
pub fn paths(data: &[u8]) -> Result<(), IoError> {
    let (kind, text) = match data.split_first() {
        Some((&i, rest)) => (i % 4, String::from_utf8_lossy(rest)),
        None => (0, String::from_utf8_lossy(data)),
    };
    match kind {
        0 | 1 => {
            let path = Path::new(if kind == 0 { "fuzz.json" } else { "fuzz.toml" });
            let p = crate::paths::parse_camera_path(path, &text)?;
            let base = octolux::scene::camera::CameraDesc::default();
            for i in 1..=p.frame_count().min(10_000) {
                let cam = p.pose_at(p.frame_time(i)).camera(&base);
                cam.validate().map_err(|m| IoError::invalid(path, format!("frame {i}: {m}")))?;
                let _ = octolux::scene::camera::Camera::new(&cam, 16, 9);
            }
        }
        _ => {
            let path = Path::new("fuzz.json");
            let p = crate::paths::parse_object_path(path, &text)?;
            for i in 1..=p.frame_count().min(10_000) {
                let _ = p.transform_at(p.frame_time(i));
            }
        }
    }
    Ok(())
}
