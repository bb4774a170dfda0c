//! Radiance caches built from photons, independent of scene, materials and lights.
//!
//! - [`octree`]: the photon-built incident-radiance octree of Pacanowski, Granier & Schlick
//!   (AFIG 2005, §3–§7): six 3x3 irradiance-vector matrices per leaf, compressed to 36
//!   bytes, queried with an overlap-volume blend.

pub mod christensen;
pub mod kdtree;
pub mod octree;
pub mod ward;

pub use octree::{Enlarge, Estimator, LeafInfo, Octree, OctreeError, OctreeSettings, OctreeStats, Storage};
