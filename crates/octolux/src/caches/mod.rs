//! Radiance caches built from photons, independent of scene, materials and lights.
//!
//! - [`octree`]: the photon-built incident-radiance octree of Pacanowski, Granier & Schlick
//!   (AFIG 2005, §3–§7): six 3x3 irradiance-vector matrices per leaf, compressed to 36
//!   bytes, queried with an overlap-volume blend.
//! - [`probes`]: adaptive grids of SH irradiance probes (Unreal's volumetric lightmap,
//!   Unity's Adaptive Probe Volumes) from the same photons, for the bytes-against-error
//!   comparison (`docs/guide/baking.md`).
//! - [`sh`]: real spherical harmonics to band 2 and their quantised storage, shared by the
//!   probes and the octree's free-space values.
//! - [`kdtree`], [`ward`], [`christensen`]: the k-nearest-neighbour photon search and the
//!   paper's baselines (§9: Ward's irradiance cache, Christensen's irradiance photons).

pub mod christensen;
pub mod kdtree;
pub mod octree;
pub mod probes;
pub mod sh;
pub mod ward;

pub use octree::{Enlarge, Estimator, LeafInfo, Octree, OctreeError, OctreeSettings, OctreeStats, Split, Storage};
