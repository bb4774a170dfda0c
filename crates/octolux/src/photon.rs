//! Photon records and the photon-map container (paper §2).
//!
//! A [`Photon`] is one stored surface hit of a light path: where it landed, the direction
//! it came from, the power it carries and the geometric normal of the surface it hit on the
//! side it arrived from. The paper stores hits on *every* surface, diffuse or not.
//!
//! Invariants expected by the consumers (the octree of `caches::octree`):
//! - `wi` and `ng` are unit vectors and `wi · ng > 0` (the photon arrived on the `ng` side);
//! - `power` is the photon's share of the emitted flux in watts, already divided by the
//!   number of emitted light paths, so that `Σ power` over a map estimates the flux that
//!   reaches the stored surfaces (this is why [`PhotonMap::emitted`] is bookkeeping only).
//!
//! Photons that break these rules (NaN, infinite) are dropped by the octree build, not
//! trusted.

use crate::math::{Bounds3, Color};
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

impl Photon {
    /// True when every field is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.p.is_finite() && self.wi.is_finite() && self.power.is_finite() && self.ng.is_finite()
    }
}

/// Which light paths a map holds (paper §2: a global map and a caustic map).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PhotonMapKind {
    /// Indirect light: paths with at least one diffuse/glossy bounce before the stored hit.
    #[default]
    Global,
    /// Paths light -> specular+ -> surface.
    Caustic,
}

/// A set of photons plus the number of light paths that were emitted to produce it.
#[derive(Clone, Debug, Default)]
pub struct PhotonMap {
    pub kind: PhotonMapKind,
    pub photons: Vec<Photon>,
    /// Number of light paths emitted (including the ones that stored nothing).
    pub emitted: u64,
}

impl PhotonMap {
    pub fn new(kind: PhotonMapKind) -> Self {
        PhotonMap { kind, photons: Vec::new(), emitted: 0 }
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// Bounding box of the photon positions (empty box for an empty map; non-finite
    /// positions are ignored).
    pub fn bounds(&self) -> Bounds3 {
        let mut b = Bounds3::EMPTY;
        for ph in &self.photons {
            if ph.p.is_finite() {
                b.extend(ph.p);
            }
        }
        b
    }

    /// Sum of the photon powers, accumulated in f64 (W).
    pub fn total_power(&self) -> [f64; 3] {
        let mut s = [0.0f64; 3];
        for ph in &self.photons {
            s[0] += ph.power.x as f64;
            s[1] += ph.power.y as f64;
            s[2] += ph.power.z as f64;
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_bounds_and_power() {
        let mut m = PhotonMap::new(PhotonMapKind::Global);
        assert!(m.is_empty() && m.bounds().is_empty());
        let ph = |p: Vec3, c: f32| Photon { p, wi: Vec3::Z, power: Color::splat(c), ng: Vec3::Z };
        m.photons.push(ph(Vec3::new(1.0, 2.0, 3.0), 0.5));
        m.photons.push(ph(Vec3::new(-1.0, 0.0, 5.0), 0.25));
        m.photons.push(ph(Vec3::new(f32::NAN, 0.0, 0.0), 0.0));
        let b = m.bounds();
        assert_eq!(b.min, Vec3::new(-1.0, 0.0, 3.0));
        assert_eq!(b.max, Vec3::new(1.0, 2.0, 5.0));
        assert_eq!(m.total_power(), [0.75; 3]);
        assert!(!m.photons[2].is_finite() && m.photons[0].is_finite());
    }
}
