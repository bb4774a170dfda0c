//! Radiance caches built from photons, independent of scene, materials and lights.
//!
//! - [`octree`]: the photon-built incident-radiance octree of Pacanowski, Granier & Schlick
//!   (AFIG 2005, §3–§7): six 3x3 irradiance-vector matrices per leaf, compressed to 36
//!   bytes, queried with an overlap-volume blend.
//! - [`kdtree`], [`ward`], [`christensen`]: the k-nearest-neighbour photon search and the
//!   paper's baselines (§9: Ward's irradiance cache, Christensen's irradiance photons).

pub mod christensen;
pub mod kdtree;
pub mod octree;
pub mod ward;

pub use octree::{Enlarge, Estimator, LeafInfo, Octree, OctreeError, OctreeSettings, OctreeStats, Split, Storage};
