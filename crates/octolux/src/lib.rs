//! octolux core: scene data, ray intersection, materials, lights, integrators and the
//! photon-built incident-radiance octree of Pacanowski, Granier & Schlick (AFIG 2005).
//!
//! This crate holds no CLI, no Python and no file formats (see `octolux-io`).

pub mod accel;
pub mod caches;
pub mod camera;
pub mod envmap;
pub mod integrators;
pub mod light;
pub mod material;
pub mod math;
pub mod metrics;
pub mod photon;
pub mod photon_pass;
pub mod prepared;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod sunsky;
#[doc(hidden)]
pub mod testing;

pub use glam;
pub use math::Color;
