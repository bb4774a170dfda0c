//! octolux-io: everything that touches files — scene loaders (built-in scenes, Mitsuba 3 XML
//! including the 0.5/0.6 dialect, OBJ/MTL, PLY), image input/output (OpenEXR, PNG, textures),
//! the Mitsuba XML exporter and baked lighting files ([`cache`], docs/guide/baking.md).
//!
//! Errors name the file (and line where there is one); problems that can be skipped safely are
//! returned as warnings in [`LoadedScene::warnings`] instead.

pub mod builtin;
pub mod cache;
pub mod export;
pub mod files;
pub mod fuzzing;
pub mod gltf_scene;
pub mod image_io;
pub mod job;
pub mod mesh;
pub mod mitsuba;
pub mod paths;
pub mod settings;
pub mod shared;
pub mod view;

use octolux::scene::SceneDesc;
use std::path::{Path, PathBuf};

/// An error while reading or writing a file.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// A syntax or semantic error at a known place.
    #[error("{}:{line}: {msg}", file.display())]
    Parse { file: PathBuf, line: u32, msg: String },
    /// The operating system refused (missing file, permissions, ...). The cause is part of
    /// the message, so it is deliberately not also exposed as `source()` (which would print it
    /// twice in an error chain).
    #[error("{}: {error}", file.display())]
    Os { file: PathBuf, error: std::io::Error },
    /// The file was read but its content is unusable.
    #[error("{}: {msg}", file.display())]
    Invalid { file: PathBuf, msg: String },
    /// An output the rule of [`files`] refuses (the message names the path).
    #[error("{0}")]
    Output(String),
    #[error("unknown scene '{name}': not a file and not a built-in scene (built-in: {known})")]
    UnknownScene { name: String, known: String },
}

impl IoError {
    pub fn os(file: &Path, source: std::io::Error) -> Self {
        IoError::Os { file: file.to_path_buf(), error: source }
    }
    pub fn invalid(file: &Path, msg: impl Into<String>) -> Self {
        IoError::Invalid { file: file.to_path_buf(), msg: msg.into() }
    }
    pub fn parse(file: &Path, line: u32, msg: impl Into<String>) -> Self {
        IoError::Parse { file: file.to_path_buf(), line, msg: msg.into() }
    }
}

/// A loaded scene and the warnings collected while loading it (unsupported elements that were
/// skipped, degenerate triangles removed, ...), each naming file and line where known.
#[derive(Debug, Default)]
pub struct LoadedScene {
    pub desc: SceneDesc,
    pub warnings: Vec<String>,
    /// The camera of every usable `<sensor>` of a Mitsuba file, in file order (the first is
    /// `desc.camera`); empty for scenes without sensors (built-in scenes, meshes). Rendered as
    /// frames by `octolux render --sensors`.
    pub sensors: Vec<octolux::scene::camera::CameraDesc>,
    /// Milder lines than warnings: what the file says that Mitsuba ignores too (a parameter the
    /// plugin does not have), so octolux renders what Mitsuba renders. Each names file and line.
    pub notes: Vec<String>,
}

/// Load a scene from a built-in name (`cornell-box`, `cornell-spheres`) or a path (`.xml` is
/// Mitsuba XML, `.obj`/`.ply` a mesh rendered directly). `defines` are Mitsuba `-D name=value`
/// overrides of `<default>` parameters.
pub fn load_scene(spec: &str, defines: &[(String, String)]) -> Result<LoadedScene, IoError> {
    let mut loaded = load_any(spec, defines)?;
    let xml = Path::new(spec).extension().is_some_and(|e| e.eq_ignore_ascii_case("xml"));
    if !xml && !defines.is_empty() {
        // Only Mitsuba XML has parameters; a built-in scene or a mesh would drop them silently.
        loaded.warnings.push(format!("-D is ignored: '{spec}' is not a Mitsuba XML scene (it has no parameters)"));
    }
    Ok(loaded)
}

fn load_any(spec: &str, defines: &[(String, String)]) -> Result<LoadedScene, IoError> {
    let path = Path::new(spec);
    if !path.exists() {
        if let Some(desc) = builtin::scene(spec) {
            return Ok(LoadedScene { desc, ..Default::default() });
        }
        if path.extension().is_none() {
            return Err(IoError::UnknownScene { name: spec.to_string(), known: builtin::NAMES.join(", ") });
        }
        return Err(IoError::os(path, std::io::Error::new(std::io::ErrorKind::NotFound, "no such file")));
    }
    files::refuse_non_regular(path)?;
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default();
    match ext.as_str() {
        "xml" => mitsuba::load(path, defines),
        "obj" | "ply" => mesh::load_mesh_scene(path),
        "gltf" | "glb" => gltf_scene::load(path),
        _ => Err(IoError::invalid(path, "unknown scene format (expected .xml, .gltf, .glb, .obj or .ply, or a built-in scene name)")),
    }
}
