//! What the collection tests (`agreement_collection.rs`, `integrators_collection.rs`) share:
//! where the repository, the shared folder and each reference's scene file are, and the
//! references' manifest (`tests/refs/collection/manifest.json`, written by
//! `tools/mitsuba/make_refs.py --collection`).

#![allow(dead_code)] // each test binary uses a different part

use octolux::image::Image;
use octolux_io::image_io::read_exr;
use std::path::{Path, PathBuf};

pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The shared folder (it holds `scenes/`): `$OCTOLUX_SHARED`, else `<repo>/../shared`.
pub fn shared_dir() -> PathBuf {
    octolux_io::shared::shared_dir()
}

/// The scene file a manifest entry names: `../shared/...` lies in the shared folder, anything
/// else in the repository.
pub fn scene_path(source: &str) -> PathBuf {
    match source.strip_prefix("../shared/") {
        Some(rel) => shared_dir().join(rel),
        None => repo_root().join(source),
    }
}

/// One reference of the collection whose scene file is present.
pub struct Reference {
    /// The manifest's entry (how the reference was made, its noise, its halves' means).
    pub entry: serde_json::Value,
    pub scene_file: PathBuf,
    pub image: Image,
    /// The file's max depth, as the reference was rendered with it.
    pub max_depth: i32,
}

/// The reference called `name` with its scene file, or `None` after printing one `skip:` line
/// (no entry in the manifest yet, or the scene file absent: no `../shared`; a panic with
/// `OCTOLUX_REQUIRE_SCENES=1`).
pub fn reference(name: &str) -> Option<Reference> {
    let root = repo_root();
    let manifest_path = root.join("tests/refs/collection/manifest.json");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&manifest_path).expect("collection manifest")).expect("collection manifest is JSON");
    let entry = manifest["references"][name].clone();
    if !entry.is_object() {
        println!("skip: {name}: no reference in {} yet (tools/mitsuba/make_refs.py --collection --only {name})", manifest_path.display());
        return None;
    }
    let scene_file = scene_path(entry["source_scene"].as_str().expect("source_scene"));
    if !scene_file.exists() {
        octolux_io::shared::skip_scene(name, &scene_file);
        return None;
    }
    let image = read_exr(&root.join("tests/refs/collection").join(entry["file"].as_str().expect("file"))).expect("reference EXR");
    let max_depth = entry["max_depth"].as_i64().expect("max_depth") as i32;
    Some(Reference { entry, scene_file, image, max_depth })
}

/// `img` averaged over `k`x`k` pixel blocks (a box-filter downsample; the size must divide).
pub fn downsample(img: &Image, k: u32) -> Image {
    assert!(k >= 1 && img.width.is_multiple_of(k) && img.height.is_multiple_of(k), "{}x{} is not a multiple of {k}", img.width, img.height);
    let (w, h) = (img.width / k, img.height / k);
    let mut data = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut s = [0.0f64; 3];
            for dy in 0..k {
                for dx in 0..k {
                    let p = img.data[((y * k + dy) * img.width + x * k + dx) as usize];
                    for (c, sc) in s.iter_mut().enumerate() {
                        *sc += p[c] as f64;
                    }
                }
            }
            let n = (k * k) as f64;
            data.push(octolux::math::Color::new((s[0] / n) as f32, (s[1] / n) as f32, (s[2] / n) as f32));
        }
    }
    Image { width: w, height: h, data }
}
