//! Built-in scenes.
use octolux::scene::SceneDesc;

/// Names of the built-in scenes; the first is the default.
pub const NAMES: &[&str] = &["cornell-box", "cornell-spheres"];

/// The built-in scene of that name.
pub fn scene(name: &str) -> Option<SceneDesc> {
    let _ = name;
    None
}
