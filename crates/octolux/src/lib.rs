//! octolux core: scene data, ray intersection, materials, lights, integrators and the
//! photon-built incident-radiance octree of Pacanowski, Granier & Schlick (AFIG 2005).
//!
//! This crate holds no CLI, no Python and no file formats (see `octolux-io`).

pub mod accel;
pub mod budget;
pub mod caches;
pub mod cpu;
pub mod film;
pub mod flicker;
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
pub mod type_docs;

pub use glam;
pub use math::Color;
