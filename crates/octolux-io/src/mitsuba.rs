//! Mitsuba XML loader.
use crate::{IoError, LoadedScene};
use std::path::Path;

/// Load a Mitsuba XML scene.
pub fn load(path: &Path, defines: &[(String, String)]) -> Result<LoadedScene, IoError> {
    let _ = defines;
    Err(IoError::invalid(path, "not implemented yet"))
}
