//! Leaves around which the scene is a single plane (leak control, `docs/octree.md` "Leak
//! control"; the blend is the paper's §7).
//!
//! The leak test casts rays from a query point `P` towards and along a leaf's sampled photons.
//! `P` meets the leaf only when it lies within the query box's half side `h` of the leaf's
//! cell, and every ray the test casts stays within `reach` of `P` or of the cell: all of them
//! lie in the cell grown by `h + reach` (a convex box holding `P`, the photons, the lifted
//! targets and the short direction rays). When every surface of the scene that meets that box
//! lies in one plane (the middle of a wall, a floor away from objects), `P` and the photons lie
//! on that plane, and a ray between two points off the plane is blocked exactly when they lie
//! on opposite sides of it: the answer of every ray is known from signs, and none is cast.
//! On the Cornell boxes most of the walls' area is such a leaf (measured in `docs/octree.md`).
//!
//! Built once per octree from all the scene's surfaces (specular and emitting ones included:
//! they block rays too): the triangles are binned into the leaves their bounding boxes meet
//! (compressed lists), then each valid leaf reads the lists of the leaves its grown box meets.
//! A surface meeting the grown box meets one of those leaves, and its bounding box does, so it
//! is seen (extra surfaces only make a leaf "not a plane": the test then casts its rays).

use super::{Octree, NO_VALUE};
use glam::Vec3;
use rayon::prelude::*;

/// The plane `normal · x = d` (unit `normal`) that holds every surface within reach of a valid
/// leaf's leak test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafPlane {
    pub normal: Vec3,
    pub d: f32,
}

/// Per valid leaf (by index): the plane holding every surface within reach, if there is one.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LeafPlanes {
    planes: Vec<Option<LeafPlane>>,
}

impl LeafPlanes {
    /// The plane of valid leaf `index` (`None`: several surfaces, or a sphere, within reach).
    #[inline]
    pub fn get(&self, index: u32) -> Option<LeafPlane> {
        self.planes.get(index as usize).copied().flatten()
    }

    /// Valid leaves with a plane.
    pub fn planar(&self) -> usize {
        self.planes.iter().filter(|p| p.is_some()).count()
    }

    /// Valid leaves.
    pub fn len(&self) -> usize {
        self.planes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.planes.is_empty()
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
        let planes = leaves
            .par_iter()
            .map(|&(depth, ijk)| {
                let s = self.cell_size[depth as usize];
                let grow = Vec3::splat(self.query_half + reach_cells * s + eps);
                let cmin = view.cell_min(depth, ijk);
                let tol = 1e-3 * s;
                let mut plane: Option<LeafPlane> = None;
                let mut single = true;
                view.visit(cmin - grow, cmin + Vec3::splat(s) + grow, |node, _, _, _| {
                    if !single {
                        return;
                    }
                    for &k in &items[start[node as usize] as usize..start[node as usize + 1] as usize] {
                        if k >= n_tri {
                            single = false;
                            return;
                        }
                        let t = &triangles[k as usize];
                        match &plane {
                            Some(pl) => {
                                if !on_plane(pl, t, tol) {
                                    single = false;
                                    return;
                                }
                            }
                            None => {
                                let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
                                if n != Vec3::ZERO && n.is_finite() {
                                    let pl = LeafPlane { normal: n, d: n.dot(t[0]) };
                                    if on_plane(&pl, t, tol) {
                                        plane = Some(pl);
                                    }
                                }
                            }
                        }
                    }
                });
                plane.filter(|_| single)
            })
            .collect();
        LeafPlanes { planes }
    }
}

#[cfg(test)]
mod tests {
    use crate::caches::octree::{Depth, Octree, OctreeSettings};
    use crate::math::{Bounds3, Color};
    use crate::photon::Photon;
    use glam::Vec3;

    /// Photons on the floor `y = 0` of a unit box and on a small block standing on it: leaves
    /// far from the block (more than their reach) are planar with the floor's plane, leaves
    /// near it are not, and a degenerate triangle away from the floor breaks nothing.
    #[test]
    fn leaves_are_planar_only_away_from_other_surfaces() {
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
        let p = only_floor.get(0).unwrap();
        assert!((p.normal.y.abs() - 1.0).abs() < 1e-6 && p.d.abs() < 1e-6, "{p:?}");
        // a wall piece standing at x = 0.5 (a triangle in the plane x = 0.5)
        let mut tris = floor.to_vec();
        tris.push([Vec3::new(0.5, 0.0, 0.4), Vec3::new(0.5, 0.1, 0.5), Vec3::new(0.5, 0.0, 0.6)]);
        let with_wall = tree.leaf_planes(&tris, &[], 1.0);
        assert!(with_wall.planar() < with_wall.len() && with_wall.planar() > 0, "{} of {}", with_wall.planar(), with_wall.len());
        // a leaf is planar exactly when its grown box misses the other surface's bounding box
        let q = tree.query_size() / 2.0;
        let expected = |lo_o: Vec3, hi_o: Vec3| {
            tree.leaf_infos()
                .iter()
                .filter(|l| l.valid)
                .filter(|l| {
                    let g = Vec3::splat(q + (l.bounds.max.x - l.bounds.min.x));
                    let (lo, hi) = (l.bounds.min - g, l.bounds.max + g);
                    !(lo.cmplt(hi_o).all() && hi.cmpgt(lo_o).all())
                })
                .count()
        };
        assert_eq!(with_wall.planar(), expected(Vec3::new(0.5, 0.0, 0.4), Vec3::new(0.5, 0.1, 0.6)));
        // a sphere near the floor makes its leaves non-planar
        let with_sphere = tree.leaf_planes(&floor, &[(Vec3::new(0.3, 0.05, 0.3), 0.05)], 1.0);
        assert_eq!(with_sphere.planar(), expected(Vec3::new(0.25, 0.0, 0.25), Vec3::new(0.35, 0.1, 0.35)));
        assert!(with_sphere.planar() < with_sphere.len() && with_sphere.planar() > 0);
    }
}
