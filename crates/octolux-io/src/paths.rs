//! Camera path and object path files (`render --camera-path`, `--insert-path`; docs/guide/baking.md):
//! read by the rule of [`crate::files`], parsed (camera paths as JSON or TOML by extension,
//! object paths as JSON) and validated, every frame's pose included
//! ([`CameraPath::validate`], [`ObjectPath::validate`]). Errors name the file. Shared by the
//! CLI and the fuzz targets ([`crate::fuzzing`]).

use crate::IoError;
use octolux::scene::camera_path::CameraPath;
use octolux::scene::object_path::ObjectPath;
use std::path::Path;

/// Parse and validate the text of a camera path file (`path` names it and gives the format).
pub fn parse_camera_path(path: &Path, text: &str) -> Result<CameraPath, IoError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let not_valid = |e: String| IoError::invalid(path, format!("not a valid camera path: {e}"));
    let p: CameraPath = match ext.as_str() {
        "json" => serde_json::from_str(text).map_err(|e| not_valid(e.to_string()))?,
        "toml" => toml::from_str(text).map_err(|e| not_valid(e.to_string()))?,
        _ => return Err(IoError::invalid(path, "a camera path must be a .json or .toml file")),
    };
    p.validate().map_err(|m| IoError::invalid(path, m))?;
    Ok(p)
}

/// Read a camera path file ([`parse_camera_path`]).
pub fn read_camera_path(path: &Path) -> Result<CameraPath, IoError> {
    parse_camera_path(path, &crate::files::read_to_string(path)?)
}

/// Parse and validate the text of an object path file (JSON).
pub fn parse_object_path(path: &Path, text: &str) -> Result<ObjectPath, IoError> {
    let p: ObjectPath = serde_json::from_str(text).map_err(|e| IoError::invalid(path, format!("not a valid object path: {e}")))?;
    p.validate().map_err(|m| IoError::invalid(path, m))?;
    Ok(p)
}

/// Read an object path file ([`parse_object_path`]).
pub fn read_object_path(path: &Path) -> Result<ObjectPath, IoError> {
    parse_object_path(path, &crate::files::read_to_string(path)?)
}
