//! octolux core: scene data, ray intersection, materials, lights, integrators and the
//! photon-built incident-radiance octree of Pacanowski, Granier & Schlick (AFIG 2005).
//!
//! This crate holds no CLI, no Python and no file formats (see `octolux-io`).

pub mod accel;
pub mod camera;
pub mod light;
pub mod material;
pub mod math;
pub mod sampling;
pub mod scene;

pub use glam;
pub use math::Color;
