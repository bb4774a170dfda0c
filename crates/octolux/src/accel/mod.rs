//! Ray–triangle intersection backends behind one closed enum.
//!
//! All triangles of a scene go into one backend; `TriHit::prim` is the global triangle index
//! in the order given to [`Accel::build`]. Barycentrics `(u, v)` weight vertices 1 and 2:
//! `p = (1-u-v) p0 + u p1 + v p2`. Hits with `t` in `[ray.tmin, ray.tmax]` count.
//!
//! Backends: Embree 3 (loaded at run time when `libembree3.so.3` is present) and a pure-Rust
//! BVH fallback. `BackendKind::Auto` picks Embree when it loads.

use crate::math::Ray;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// A ray–triangle hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

/// Which backend to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum BackendKind {
    #[default]
    Auto,
    Embree,
    Bvh,
}

#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error("Embree is not available: {0}")]
    EmbreeUnavailable(String),
    #[error("Embree error: {0}")]
    Embree(String),
    #[error("bad geometry: {0}")]
    Geometry(String),
}

/// A built acceleration structure.
pub enum Accel {
    /// Temporary brute-force backend (replaced by the BVH and Embree backends).
    Brute { v: Vec<Vec3>, t: Vec<[u32; 3]> },
}

impl Accel {
    pub fn build(vertices: &[Vec3], triangles: &[[u32; 3]], _kind: BackendKind) -> Result<Accel, AccelError> {
        Ok(Accel::Brute { v: vertices.to_vec(), t: triangles.to_vec() })
    }

    /// Human-readable backend name for logs and stats.
    pub fn name(&self) -> String {
        "brute".into()
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<TriHit> {
        match self {
            Accel::Brute { v, t } => {
                let mut best: Option<TriHit> = None;
                let mut tmax = ray.tmax;
                for (i, tri) in t.iter().enumerate() {
                    if let Some((tt, u, w)) = intersect_triangle(ray, v[tri[0] as usize], v[tri[1] as usize], v[tri[2] as usize]) {
                        if tt >= ray.tmin && tt <= tmax {
                            tmax = tt;
                            best = Some(TriHit { t: tt, prim: i as u32, u, v: w });
                        }
                    }
                }
                best
            }
        }
    }

    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.intersect(ray).is_some()
    }
}

/// Möller–Trumbore ray/triangle test; returns `(t, u, v)` for any `t` (caller checks range).
#[inline]
pub fn intersect_triangle(ray: &Ray, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<(f32, f32, f32)> {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let pv = ray.d.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let tv = ray.o - p0;
    let u = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = ray.d.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(qv) * inv, u, v))
}
