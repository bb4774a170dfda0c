//! A scene's acceleration structure in two parts: one over the triangles of a base scene,
//! shared by every scene made from it by adding triangles after them, and one over the added
//! triangles. An object inserted into a baked scene and moved frame by frame (docs/guide/
//! baking.md "Inserted objects") then costs each frame a structure over the object alone,
//! not over the whole scene again.
//!
//! A hit is the closest of the two parts' (the added part's on a tie), its `prim` the index in
//! the whole list, as [`Accel`] gives it for one list.

use super::{Accel, AccelError, BackendKind, TriHit};
use crate::math::Ray;
use glam::Vec3;
use std::sync::Arc;

/// See the module docs.
pub struct LayeredAccel {
    base: Arc<Accel>,
    /// The base's triangle count and the structure over the triangles after them.
    added: Option<(u32, Accel)>,
}

impl LayeredAccel {
    /// One part over all of `triangles` ([`Accel::build`]).
    pub fn build(vertices: &[Vec3], triangles: &[[u32; 3]], kind: BackendKind) -> Result<LayeredAccel, AccelError> {
        Ok(LayeredAccel { base: Arc::new(Accel::build(vertices, triangles, kind)?), added: None })
    }

    /// `triangles` over `vertices`, whose first `base_len` triangles are those `base` was built
    /// over (the caller checked it, with the vertices they use): `base`'s structure shared,
    /// a new one over the rest. `base` must be a single part.
    pub fn adding(
        base: &LayeredAccel,
        base_len: usize,
        vertices: &[Vec3],
        triangles: &[[u32; 3]],
        kind: BackendKind,
    ) -> Result<LayeredAccel, AccelError> {
        debug_assert!(base.added.is_none(), "a base of one part");
        let rest = &triangles[base_len.min(triangles.len())..];
        let first = u32::try_from(base_len).map_err(|_| AccelError::Geometry(format!("{base_len} triangles")))?;
        // the added triangles over their own span of the vertices (an appended mesh's)
        let (lo, hi) = rest.iter().flatten().fold((u32::MAX, 0u32), |(lo, hi), &k| (lo.min(k), hi.max(k)));
        let added = if rest.is_empty() {
            None
        } else {
            let span = vertices.get(lo as usize..=hi as usize).ok_or_else(|| {
                AccelError::Geometry(format!("a triangle uses vertex {hi}, but there are only {} vertices", vertices.len()))
            })?;
            let local: Vec<[u32; 3]> = rest.iter().map(|t| t.map(|k| k - lo)).collect();
            Some((first, Accel::build(span, &local, kind)?))
        };
        Ok(LayeredAccel { base: Arc::clone(&base.base), added })
    }

    /// Whether the structure is of one part (nothing added).
    pub fn is_single(&self) -> bool {
        self.added.is_none()
    }

    /// The base part.
    pub fn base(&self) -> &Accel {
        &self.base
    }

    /// Closest hit with `t` in `[ray.tmin, ray.tmax]`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<TriHit> {
        let hit = self.base.intersect(ray);
        let Some((first, added)) = &self.added else {
            return hit;
        };
        let nearer = Ray { tmax: hit.map_or(ray.tmax, |h| h.t), ..*ray };
        match added.intersect(&nearer) {
            Some(h) => Some(TriHit { prim: h.prim + first, ..h }),
            None => hit,
        }
    }

    /// Whether any triangle is hit with `t` in `[ray.tmin, ray.tmax]`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.base.occluded(ray) || self.added.as_ref().is_some_and(|(_, a)| a.occluded(ray))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    /// Random triangles, the last quarter added over the first three: every ray's hit (its
    /// triangle, `t`, `u`, `v`) and occlusion equal those of one structure over all of them.
    #[test]
    fn two_parts_hit_what_one_structure_hits() {
        let mut s = Sampler::new(5, 0, 0);
        let p = |s: &mut Sampler| Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 4.0 - 2.0;
        let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
        for i in 0..400u32 {
            let c = p(&mut s);
            vertices.extend([c, c + p(&mut s) * 0.3, c + p(&mut s) * 0.3]);
            triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
        }
        let base_len = 300;
        for kind in [BackendKind::Bvh, BackendKind::Auto] {
            let one = Accel::build(&vertices, &triangles, kind).unwrap();
            let base = LayeredAccel::build(&vertices[..900], &triangles[..base_len], kind).unwrap();
            let two = LayeredAccel::adding(&base, base_len, &vertices, &triangles, kind).unwrap();
            assert!(!two.is_single() && base.is_single());
            let (mut hits, mut added) = (0, 0);
            for _ in 0..20_000 {
                let (o, d) = (p(&mut s) * 1.5, p(&mut s).normalize_or(Vec3::X));
                let ray = Ray { o, d, tmin: 0.0, tmax: if s.next_1d() < 0.5 { f32::INFINITY } else { 3.0 } };
                let (a, b) = (one.intersect(&ray), two.intersect(&ray));
                assert_eq!(a, b, "{ray:?}");
                assert_eq!(one.occluded(&ray), two.occluded(&ray), "{ray:?}");
                hits += a.is_some() as u32;
                added += a.is_some_and(|h| h.prim as usize >= base_len) as u32;
            }
            assert!(hits > 2_000 && added > 200, "{hits} hits, {added} on the added triangles");
        }
        // nothing added: the base alone
        let base = LayeredAccel::build(&vertices, &triangles, BackendKind::Bvh).unwrap();
        let same = LayeredAccel::adding(&base, triangles.len(), &vertices, &triangles, BackendKind::Bvh).unwrap();
        assert!(same.is_single());
    }
}
