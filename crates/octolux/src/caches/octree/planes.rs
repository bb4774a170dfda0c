//! Leaves around which the scene is a single plane (leak control, `docs/guide/octree.md` "Leak
//! control"; the blend is the paper's §7).
//!
//! The leak test casts rays from a query point `P` towards and along a leaf's sampled photons.
//! `P` meets the leaf only when it lies within the query box's half side `h` of the leaf's
//! cell, and every ray the test casts stays within `reach` of `P` or of the cell: all of them
//! lie in the cell grown by `h + reach` (a convex box holding `P`, the photons, the lifted
//! targets and the short direction rays). When every surface of the scene that meets that box
//! lies on a few planes (the middle of a wall: one; a room's edge or corner: two or three), a
//! segment whose ends lie on the same side of every plane crosses none, so no surface: it is
//! free without a ray. With a single plane, `P` lies on it, and a segment from `P` to the other
//! side crosses it at `P`, on its surface: blocked. Other segments are left to a ray.
//!
//! Built once per octree from all the scene's surfaces (specular and emitting ones included:
//! they block rays too): the triangles are binned into the leaves their bounding boxes meet
//! (compressed lists), then each valid leaf reads the lists of the leaves its grown box meets.
//! A surface meeting the grown box meets one of those leaves, and its bounding box does, so it
//! is seen; of the surfaces listed, those whose bounding box misses the grown box are skipped
//! (a large atmospheric leaf lists every surface crossing it). An extra surface only adds a
//! plane (or makes the leaf's planes unknown): the test then casts more rays, never fewer.

use super::{Octree, NO_VALUE};
use glam::Vec3;
use rayon::prelude::*;

/// A plane `normal · x = d` (unit `normal`) holding surfaces within reach of a valid leaf's
/// leak test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafPlane {
    pub normal: Vec3,
    pub d: f32,
}

/// Most planes kept per leaf; a leaf with more surfaces within reach is tested by rays.
pub const MAX_PLANES: usize = 4;

/// Per valid leaf (by index): the planes (at most [`MAX_PLANES`]) that hold every surface
/// within reach of its leak test, when there are such planes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LeafPlanes {
    /// Per valid leaf: the planes' range in `planes`, or `u32::MAX` (unknown: a sphere or more
    /// than [`MAX_PLANES`] planes within reach).
    first: Vec<(u32, u32)>,
    planes: Vec<LeafPlane>,
    /// Per valid leaf: the distance within which a point counts as on a plane (the
    /// coplanarity tolerance of its triangles).
    tol: Vec<f32>,
}

/// What the planes of a leaf say about a segment ([`LeafPlanes::segment`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Segment {
    /// No surface within reach can block it.
    Free,
    /// A surface within reach blocks it.
    Blocked,
    /// Cast a ray.
    Unknown,
}

impl LeafPlanes {
    /// The planes of valid leaf `index` (`None`: unknown, cast rays).
    #[inline]
    pub fn get(&self, index: u32) -> Option<&[LeafPlane]> {
        let &(a, b) = self.first.get(index as usize)?;
        (a != u32::MAX).then(|| &self.planes[a as usize..b as usize])
    }

    /// Whether the segment from `a` to `b` (both within reach of valid leaf `index`) meets a
    /// surface, from the leaf's planes alone. [`Segment::Free`] when `a` and `b` lie on the
    /// same side of every plane, farther than the tolerance (the segment crosses no plane, so
    /// no surface); [`Segment::Blocked`] when the leaf has one plane and they lie on opposite
    /// sides of it (the query point `a` lies on that plane, lifted off it by the ray offset:
    /// the segment crosses it where `a` is, on its surface); [`Segment::Unknown`] otherwise.
    #[inline]
    pub fn segment(&self, index: u32, a: Vec3, b: Vec3) -> Segment {
        let Some(planes) = self.get(index) else { return Segment::Unknown };
        let tol = self.tol[index as usize];
        let mut crossed = 0;
        for pl in planes {
            let (da, db) = (pl.normal.dot(a) - pl.d, pl.normal.dot(b) - pl.d);
            if da.abs() <= tol || db.abs() <= tol || !(da.is_finite() && db.is_finite()) {
                return Segment::Unknown;
            }
            if (da > 0.0) != (db > 0.0) {
                crossed += 1;
            }
        }
        match (crossed, planes.len()) {
            (0, _) => Segment::Free,
            (1, 1) => Segment::Blocked,
            _ => Segment::Unknown,
        }
    }

    /// Valid leaves whose planes are known.
    pub fn planar(&self) -> usize {
        self.first.iter().filter(|p| p.0 != u32::MAX).count()
    }

    /// Valid leaves.
    pub fn len(&self) -> usize {
        self.first.len()
    }

    pub fn is_empty(&self) -> bool {
        self.first.is_empty()
    }
}

/// Whether the points lie within `tol` of the plane.
#[inline]
fn on_plane(pl: &LeafPlane, pts: &[Vec3; 3], tol: f32) -> bool {
    pts.iter().all(|p| (pl.normal.dot(*p) - pl.d).abs() <= tol)
}

impl Octree {
    /// [`LeafPlanes`] of this tree for the scene's surfaces (`triangles`, and `spheres` as
    /// centre and radius), for a leak test whose rays stay within `reach_cells` cell edges of
    /// the query point or the cell (see the module docs). Deterministic.
    pub fn leaf_planes(&self, triangles: &[[Vec3; 3]], spheres: &[(Vec3, f32)], reach_cells: f32) -> LeafPlanes {
        let view = self.view();
        let n_nodes = self.nodes.len();
        let eps = 1e-6 * self.size;
        let tri_box = |t: &[Vec3; 3]| (t[0].min(t[1]).min(t[2]) - eps, t[0].max(t[1]).max(t[2]) + eps);
        let sph_box = |&(c, r): &(Vec3, f32)| (c - Vec3::splat(r.abs() + eps), c + Vec3::splat(r.abs() + eps));
        let boxes = || triangles.iter().map(tri_box).chain(spheres.iter().map(sph_box));
        // compressed lists: counts, prefix sums, fill (item order within a list = input order)
        let mut start = vec![0u32; n_nodes + 1];
        for (lo, hi) in boxes() {
            view.visit(lo, hi, |node, _, _, _| start[node as usize + 1] += 1);
        }
        for i in 0..n_nodes {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; start[n_nodes] as usize];
        for (k, (lo, hi)) in boxes().enumerate() {
            view.visit(lo, hi, |node, _, _, _| {
                items[fill[node as usize] as usize] = k as u32;
                fill[node as usize] += 1;
            });
        }
        drop(fill);
        let n_tri = triangles.len() as u32;
        // the valid leaves, in value order
        let mut leaves = vec![(0u32, [0u32; 3]); self.anchors.len()];
        let b = self.bounds();
        view.visit(b.min, b.max, |node, depth, ijk, _| {
            let v = self.nodes[node as usize].value();
            if v != NO_VALUE {
                leaves[v as usize] = (depth, ijk);
            }
        });
        let found: Vec<(Option<Vec<LeafPlane>>, f32)> = leaves
            .par_iter()
            .map(|&(depth, ijk)| {
                let s = self.cell_size[depth as usize];
                let grow = Vec3::splat(self.query_half + reach_cells * s + eps);
                let cmin = view.cell_min(depth, ijk);
                let tol = 1e-3 * s;
                let mut planes: Vec<LeafPlane> = Vec::new();
                let mut known = true;
                let (glo, ghi) = (cmin - grow, cmin + Vec3::splat(s) + grow);
                view.visit(glo, ghi, |node, _, _, _| {
                    if !known {
                        return;
                    }
                    for &k in &items[start[node as usize] as usize..start[node as usize + 1] as usize] {
                        // a large atmospheric leaf lists every surface in it: keep those whose
                        // bounding box meets the grown box
                        let (lo, hi) = if k < n_tri { tri_box(&triangles[k as usize]) } else { sph_box(&spheres[(k - n_tri) as usize]) };
                        if !(lo.cmple(ghi).all() && hi.cmpge(glo).all()) {
                            continue;
                        }
                        if k >= n_tri {
                            known = false;
                            return;
                        }
                        let t = &triangles[k as usize];
                        if planes.iter().any(|pl| on_plane(pl, t, tol)) {
                            continue;
                        }
                        let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
                        let pl = LeafPlane { normal: n, d: n.dot(t[0]) };
                        if n == Vec3::ZERO || !n.is_finite() || !on_plane(&pl, t, tol) || planes.len() == MAX_PLANES {
                            known = false;
                            return;
                        }
                        planes.push(pl);
                    }
                });
                (known.then_some(planes), tol)
            })
            .collect();
        let mut out = LeafPlanes::default();
        for (p, tol) in found {
            out.tol.push(tol);
            match p {
                Some(p) if !p.is_empty() => {
                    let a = out.planes.len() as u32;
                    out.planes.extend(p);
                    out.first.push((a, out.planes.len() as u32));
                }
                _ => out.first.push((u32::MAX, u32::MAX)),
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::Segment;
    use crate::caches::octree::{Depth, Octree, OctreeSettings};
    use crate::math::{Bounds3, Color};
    use crate::photon::Photon;
    use glam::Vec3;

    /// Photons on the floor `y = 0` of a unit box, a wall piece standing on it and a sphere:
    /// each leaf gets the planes of the surfaces its grown box meets (one, or two near the wall
    /// piece), none (rays) near the sphere; the segments' answers follow the sides.
    #[test]
    fn leaves_get_the_planes_within_reach() {
        let mut photons = Vec::new();
        let mut s = crate::sampling::Sampler::new(3, 0, 0);
        for _ in 0..20_000 {
            let u = s.next_2d();
            photons.push(Photon { p: Vec3::new(u.x, 0.0, u.y), wi: Vec3::Y, power: Color::ONE, ng: Vec3::Y });
        }
        let bounds = Bounds3 { min: Vec3::new(0.0, -0.5, 0.0), max: Vec3::new(1.0, 0.5, 1.0) };
        let settings = OctreeSettings { h_max: Depth::Fixed(4), n_max: 50, ..OctreeSettings::default() };
        let tree = Octree::build(&photons, bounds, &settings, None).unwrap();
        let floor = [
            [Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0)],
            [Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 0.0)],
        ];
        let only_floor = tree.leaf_planes(&floor, &[], 1.0);
        assert_eq!(only_floor.planar(), only_floor.len(), "a floor alone is one plane everywhere");
        for i in 0..only_floor.len() as u32 {
            let p = only_floor.get(i).unwrap();
            assert!(p.len() == 1 && (p[0].normal.y.abs() - 1.0).abs() < 1e-6 && p[0].d.abs() < 1e-6, "{p:?}");
        }
        let (above, below, above2) = (Vec3::new(0.5, 0.01, 0.5), Vec3::new(0.52, -0.01, 0.5), Vec3::new(0.45, 0.02, 0.52));
        assert_eq!(only_floor.segment(0, above, above2), Segment::Free);
        assert_eq!(only_floor.segment(0, above, below), Segment::Blocked);
        assert_eq!(only_floor.segment(0, above, Vec3::new(0.5, 0.0, 0.5)), Segment::Unknown, "on the plane");
        // a wall piece standing at x = 0.5 (a triangle in the plane x = 0.5)
        let mut tris = floor.to_vec();
        tris.push([Vec3::new(0.5, 0.0, 0.4), Vec3::new(0.5, 0.1, 0.5), Vec3::new(0.5, 0.0, 0.6)]);
        let with_wall = tree.leaf_planes(&tris, &[], 1.0);
        assert_eq!(with_wall.planar(), with_wall.len(), "two planes are known");
        // a leaf has the wall's plane exactly when its grown box meets the wall piece's box
        let q = tree.query_size() / 2.0;
        let meets = |l: &crate::caches::octree::LeafInfo, lo_o: Vec3, hi_o: Vec3| {
            let g = Vec3::splat(q + (l.bounds.max.x - l.bounds.min.x));
            let (lo, hi) = (l.bounds.min - g, l.bounds.max + g);
            lo.cmplt(hi_o).all() && hi.cmpgt(lo_o).all()
        };
        let valid: Vec<_> = tree.leaf_infos().into_iter().filter(|l| l.valid).collect();
        let near_wall = valid.iter().filter(|l| meets(l, Vec3::new(0.5, 0.0, 0.4), Vec3::new(0.5, 0.1, 0.6))).count();
        let two = (0..with_wall.len() as u32).filter(|&i| with_wall.get(i).unwrap().len() == 2).count();
        assert_eq!(two, near_wall);
        assert!(two > 0 && two < valid.len());
        let i = (0..with_wall.len() as u32).find(|&i| with_wall.get(i).unwrap().len() == 2).unwrap();
        assert_eq!(
            with_wall.segment(i, Vec3::new(0.45, 0.01, 0.5), Vec3::new(0.55, 0.01, 0.5)),
            Segment::Unknown,
            "crosses the wall's plane"
        );
        assert_eq!(with_wall.segment(i, Vec3::new(0.45, 0.01, 0.5), Vec3::new(0.4, 0.05, 0.45)), Segment::Free);
        // a sphere near the floor leaves its leaves to the rays
        let with_sphere = tree.leaf_planes(&floor, &[(Vec3::new(0.3, 0.05, 0.3), 0.05)], 1.0);
        let near_sphere = valid.iter().filter(|l| meets(l, Vec3::new(0.25, 0.0, 0.25), Vec3::new(0.35, 0.1, 0.35))).count();
        assert_eq!(with_sphere.len() - with_sphere.planar(), near_sphere);
        assert!(near_sphere > 0 && near_sphere < valid.len());
    }
}
