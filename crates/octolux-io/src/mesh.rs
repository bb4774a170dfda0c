//! OBJ and PLY meshes.
use crate::{IoError, LoadedScene};
use std::path::Path;

/// Load an OBJ or PLY file as a scene of its own (default camera and light).
pub fn load_mesh_scene(path: &Path) -> Result<LoadedScene, IoError> {
    Err(IoError::invalid(path, "not implemented yet"))
}
