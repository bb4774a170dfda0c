//! The leak test of the octree queries ([`LeakTest::VisibleSample`]; `docs/guide/octree.md`, "Leak
//! control"; paper §7's blend is what leaks): a leaf met by a query at a shading point keeps its
//! light when the point sees one of the leaf's sampled photons. Most of the test's segments are
//! answered by the planes around each leaf ([`LeafPlanes`]) without casting a ray.

use crate::caches::octree::{LeafPlanes, QueryLeaf, Segment};
use crate::caches::Octree;
use crate::math::Ray;
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;

/// How far (in cell edges) a sampled photon is lifted off its surface, along its incident
/// direction, before the visibility ray: a photon's stored position is quantised to 1/256 of
/// the cell, and the mean position of photons on a curved surface lies below it (by `s²/8R`
/// for a cap of chord `s` on a sphere of radius `R`); a thin wall must lie between the query
/// point and the lifted photon, not behind it.
pub const ANCHOR_LIFT: f32 = 0.25;

/// How far (in cell edges) around each leaf the planes of [`LeafPlanes`] hold every surface:
/// the reach of the test's segments from a query point to a lifted photon of a nearby leaf.
pub const PLANES_REACH: f32 = 1.0;

/// The planes of `tree`'s leaves for the leak test, from every surface of `scene` (the scene
/// the octrees were built for).
pub fn leaf_planes(scene: &Scene, tree: &Octree) -> LeafPlanes {
    let tris = scene.mesh_triangles_where(|_| true);
    let spheres: Vec<_> = scene.analytic_spheres_where(|_| true).into_iter().map(|(c, r, _)| (c, r)).collect();
    tree.leaf_planes(&tris, &spheres, PLANES_REACH)
}

/// The segment from `a` to `b` (within reach of valid leaf `q`) is unblocked: from the planes
/// around the leaf when they tell (`caches::octree::planes`), else by a ray (`rays` counts
/// them); a segment shorter than 1e-4 of the cell is clear.
#[inline]
pub(super) fn segment_clear(scene: &Scene, planes: Option<&LeafPlanes>, q: &QueryLeaf, a: Vec3, b: Vec3, rays: &mut u64) -> bool {
    if let Some(p) = planes {
        match p.segment(q.index, a, b) {
            Segment::Free => return true,
            Segment::Blocked => return false,
            Segment::Unknown => {}
        }
    }
    let d = b - a;
    let len = d.length();
    if !(len > 1e-4 * q.cell_size) {
        return true;
    }
    *rays += 1;
    !scene.occluded(&Ray::segment(a, d / len, len))
}

/// Whether the light of leaf `q`, met by a query at `hit` (normal `n`, on the viewer's side),
/// can reach it: the point, leaving from the viewer's side of its surface, sees one of the
/// leaf's sampled photons lifted by [`ANCHOR_LIFT`] cell edges along its incident direction.
/// `planes`: [`leaf_planes`] of the tree (without them every segment is a ray); `rays` counts
/// the rays cast.
#[inline]
pub(super) fn keep_leaf(scene: &Scene, planes: Option<&LeafPlanes>, hit: &SurfaceHit, n: Vec3, q: &QueryLeaf, rays: &mut u64) -> bool {
    let ngf = crate::math::facing(hit.ng, n);
    let o = crate::math::offset_origin(hit.p, ngf, ngf);
    let lift = ANCHOR_LIFT * q.cell_size;
    q.samples.iter().any(|&(p, w)| segment_clear(scene, planes, q, o, p + w * lift, rays))
}
