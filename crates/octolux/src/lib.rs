//! octolux core: scene data, ray intersection, materials, lights, integrators and the
//! photon-built incident-radiance octree of Pacanowski, Granier & Schlick (AFIG 2005).
//!
//! This crate holds no CLI, no Python and no file formats (see `octolux-io`).

pub mod accel;
pub mod budget;
pub mod caches;
pub mod film;
pub mod image;
pub mod integrators;
pub mod math;
pub mod metrics;
pub mod photon;
pub mod render;
pub mod sampling;
pub mod scene;
/// Chi-square test tooling for the crate's tests; outside them only with the `testing`
/// feature, which this crate's own dev-dependency on itself enables (never a user build).
#[cfg(any(test, feature = "testing"))]
pub mod testing;

pub use glam;
pub use math::Color;

/// TEMP-ALIAS: moved to [`scene::material`] (and `Image` to [`image`]).
pub mod material {
    pub use crate::image::Image; // TEMP-ALIAS
    pub use crate::scene::material::*; // TEMP-ALIAS
}
/// TEMP-ALIAS: moved to [`scene::lights`] (and the description enum `Light` to [`scene::desc`]).
pub mod light {
    pub use crate::scene::desc::Light; // TEMP-ALIAS
    pub use crate::scene::lights::*; // TEMP-ALIAS
}
/// TEMP-ALIAS: moved to [`scene::camera`].
pub mod camera {
    pub use crate::scene::camera::*; // TEMP-ALIAS
}
/// TEMP-ALIAS: the prepared scene moved to [`scene`].
pub mod prepared {
    pub use crate::scene::{intersect_sphere, Scene, SphereShape, SurfaceHit}; // TEMP-ALIAS
}
pub use photon::trace as photon_pass; // TEMP-ALIAS: moved to photon::trace
