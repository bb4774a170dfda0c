//! Photon records (paper §2) and the photon pass that makes them ([`trace`]).
//!
//! A [`Photon`] is one stored surface hit of a light path: where it landed, the direction
//! it came from, the power it carries and the geometric normal of the surface it hit on the
//! side it arrived from. The paper stores hits on *every* surface, diffuse or not.
//!
//! Invariants expected by the consumers (the octree of `caches::octree`):
//! - `wi` and `ng` are unit vectors and `wi · ng > 0` (the photon arrived on the `ng` side);
//! - `power` is the photon's share of the emitted flux in watts, already divided by the
//!   number of emitted light paths, so that `Σ power` over a map estimates the flux that
//!   reaches the stored surfaces (the emitted count, [`trace::PhotonMaps::emitted`], is
//!   bookkeeping only).
//!
//! Photons that break these rules (NaN, infinite) are dropped by the octree build, not
//! trusted.

pub mod guide;
pub mod paths;
pub mod trace;

use crate::math::Color;
use glam::Vec3;

/// One stored photon hit (f32 storage, 48 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Photon {
    /// Hit position (world space).
    pub p: Vec3,
    /// Unit direction towards where the light came from (points away from the surface).
    pub wi: Vec3,
    /// RGB power in W (already divided by the number of emitted paths).
    pub power: Color,
    /// Unit geometric normal of the surface hit, on the side the photon came from.
    pub ng: Vec3,
}

// The memory budget counts photons at `budget::PHOTON_BYTES` each: keep it honest.
const _: () = assert!(2 * std::mem::size_of::<Photon>() + 16 <= crate::budget::PHOTON_BYTES as usize);

impl Photon {
    /// True when every field is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.p.is_finite() && self.wi.is_finite() && self.power.is_finite() && self.ng.is_finite()
    }
}
