//! The leak test of the octree queries ([`LeakTest`]; `docs/octree.md`, "Leak control"; paper
//! §7's blend is what leaks): which leaves met by a query at a shading point keep their light,
//! decided by visibility rays from the point to where the leaves' photons lie, most of them
//! answered by the planes around each leaf ([`crate::caches::octree::LeafPlanes`]) without casting a ray.

use super::reach::{LeakData, SampleReach};
use super::LeakTest;
use crate::caches::octree::{QueryLeaf, Segment, ANCHOR_SAMPLES};
use crate::caches::Octree;
use crate::math::Ray;
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;

/// How far (in cell edges) the anchor of a leaf is lifted off its photons' surface, along
/// their mean normal, before the visibility ray of [`LeakTest::Visibility`]: the mean position
/// of photons on a curved surface lies below it (by `s²/8R` for a cap of chord `s` on a
/// sphere of radius `R`), and a thin wall must lie between the query point and the lifted
/// anchor, not behind it.
pub const ANCHOR_LIFT: f32 = 0.25;

/// How far (in cell edges) [`LeakTest::VisibleLight`] lifts a sampled photon's target along its
/// incident direction: far enough to leave a slit narrower than a leaf (the fixture gap of
/// Bitterli's box: 0.02 under leaves of 0.03–0.07), no farther than the planes' reach.
pub const LIGHT_LIFT: f32 = 1.0;

/// Where [`LeakTest::VisibleOrigin`] puts a sample's light origin, as a share of its reach:
/// short of the surface that lit it, so that a ray from a point that sees that surface
/// reaches it.
pub const ORIGIN_SHARE: f32 = 0.9;

/// [`LeakTest::VisibleOrigin`] counts a sample when the normal of its surface and the query
/// point's make an angle under ~37° (cosine 0.8): the query reads the matrices of the
/// half-axes its normal points to, weighted by the squared components (§5.2), and the split by
/// normal files a photon under its normal's. Measured (`docs/octree.md`): 0.5 (60°) gave the
/// same fixture gap and Bitterli's box, sponza 1.35e-2 instead of 1.22e-2 (1M photons).
pub const SAME_FACING: f32 = 0.8;

/// Length of the direction rays of [`LeakTest::OpenDirections`], in cell edges of the leaf: the
/// occluders that matter are those near the query point that were not near the photons.
pub const DIRECTION_REACH: f32 = 1.0;

/// The segment from `a` to `b` (within reach of valid leaf `q`) is unblocked: from the planes
/// around the leaf when they tell (`caches::octree::planes`), else by a ray (`rays` counts
/// them); a segment shorter than 1e-4 of the cell is clear.
#[inline]
fn segment_clear(scene: &Scene, planes: Option<&LeakData>, q: &QueryLeaf, a: Vec3, b: Vec3, rays: &mut u64) -> bool {
    if let Some(p) = planes {
        match p.planes.segment(q.index, a, b) {
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

/// [`LeakTest::VisibleSample`]'s rule: `o` sees one of leaf `q`'s sampled photons lifted by
/// [`ANCHOR_LIFT`] cell edges along its incident direction ([`segment_clear`]).
pub(super) fn keep_sample_seen(scene: &Scene, planes: Option<&LeakData>, o: Vec3, q: &QueryLeaf, rays: &mut u64) -> bool {
    let lift = ANCHOR_LIFT * q.cell_size;
    q.samples.iter().any(|&(p, w)| segment_clear(scene, planes, q, o, p + w * lift, rays))
}

/// Whether the light of a leaf met by a query at `hit` (normal `n`, on the viewer's side) can
/// reach it ([`LeakTest`]): `None` drops the leaf, `Some(f)` keeps it with its value scaled by
/// `f`. `planes`: the [`LeafPlanes`] and sample reaches of `tree` for the tests that use them
/// (without them, segments and reaches are found by rays); `rays` counts the visibility rays
/// cast.
#[allow(clippy::too_many_arguments)]
pub(super) fn keep_leaf(
    scene: &Scene,
    tree: &Octree,
    planes: Option<&LeakData>,
    hit: &SurfaceHit,
    n: Vec3,
    leak: LeakTest,
    q: QueryLeaf,
    rays: &mut u64,
) -> Option<f32> {
    let keep = |b: bool| b.then_some(1.0);
    // leave from the viewer's side of the surface, whatever side the target is on
    let ngf = crate::math::facing(hit.ng, n);
    let o = crate::math::offset_origin(hit.p, ngf, ngf);
    // the segment from `a` to `b` is unblocked
    let clear = |a: Vec3, b: Vec3, rays: &mut u64| segment_clear(scene, planes, &q, a, b, rays);
    // the query point sees `target`
    let free = |target: Vec3, rays: &mut u64| clear(o, target, rays);
    let lift = ANCHOR_LIFT * q.cell_size;
    match leak {
        LeakTest::None => Some(1.0),
        LeakTest::Plane => keep((q.position - hit.p).dot(n).abs() <= 0.5 * q.cell_size),
        LeakTest::Visibility => keep(free(q.position + q.normal * lift, rays)),
        LeakTest::VisibleSample => keep(keep_sample_seen(scene, planes, o, &q, rays)),
        LeakTest::VisibleLight => {
            // the leaf keeps its weight when the query point sees any of its photons
            // (`VisibleSample`); its value is scaled by the share of its sampled photons whose
            // light arrived on the query's side and whose light's origin (LIGHT_LIFT cells back
            // along the incident direction) the query point sees, among those whose light's
            // origin the photon itself sees (a photon lit by a surface closer than that says
            // nothing: its origin lies behind the surface)
            let (mut told, mut seen) = (0u32, 0u32);
            for &(p, w) in &q.samples {
                if w.dot(n) > 0.0 {
                    let origin = p + w * (LIGHT_LIFT * q.cell_size);
                    if clear(p + w * lift, origin, rays) {
                        told += 1;
                        if free(origin, rays) {
                            seen += 1;
                        }
                    }
                }
            }
            if seen == 0 && !q.samples.iter().any(|&(p, w)| free(p + w * lift, rays)) {
                return None;
            }
            Some(if told == 0 { 1.0 } else { seen as f32 / told as f32 })
        }
        LeakTest::VisibleOrigin => {
            // the reach and normal of each sample: precomputed per leaf, else by rays
            let reach: [SampleReach; ANCHOR_SAMPLES] = match planes.and_then(|d| d.samples(q.index)) {
                Some(r) => *r,
                None => q.samples.map(|(p, w)| SampleReach::new(scene, p, w, q.cell_size)),
            };
            // of the samples on surfaces facing like the query point's (those the matrices it
            // reads hold) lit from its side, those whose light's origin (0.9 of the way to the
            // surface that lit them) the query point sees
            let (mut facing, mut seen) = (0u32, 0u32);
            for (&(p, w), r) in q.samples.iter().zip(&reach) {
                if w.dot(n) > 0.0 && r.normal.dot(n) > SAME_FACING {
                    facing += 1;
                    if free(p + w * (ORIGIN_SHARE * r.reach), rays) {
                        seen += 1;
                    }
                }
            }
            // the leaf keeps its weight when the query point sees any of its photons or origins
            if seen == 0 && !q.samples.iter().zip(reach).any(|(&(p, w), r)| free(p + w * lift.min(0.5 * r.reach), rays)) {
                return None;
            }
            Some(if facing == 0 { 1.0 } else { seen as f32 / facing as f32 })
        }
        LeakTest::OpenDirections => {
            // the share of the leaf's light (in the matrices the query reads: light arriving
            // on the query's side of its tangent plane) that reaches the query point: of the
            // samples whose light arrived on that side, those visible whose direction is open
            let reach = DIRECTION_REACH * q.cell_size;
            let mut tested = [false; ANCHOR_SAMPLES];
            let (mut any, mut facing, mut open) = (false, 0u32, 0u32);
            for (k, &(p, w)) in q.samples.iter().enumerate() {
                if w.dot(n) <= 0.0 {
                    continue;
                }
                facing += 1;
                if !free(o + w * reach, rays) {
                    continue;
                }
                tested[k] = true;
                if free(p + w * lift, rays) {
                    any = true;
                    open += 1;
                }
            }
            // the leaf keeps its weight when the query point sees any of its photons
            if !any {
                any = q.samples.iter().zip(tested).any(|(&(p, w), t)| !t && free(p + w * lift, rays));
            }
            if !any {
                None
            } else if facing == 0 {
                Some(1.0)
            } else {
                Some(open as f32 / facing as f32)
            }
        }
        LeakTest::VisibilityAndDirection => {
            keep_leaf(scene, tree, None, hit, n, LeakTest::Visibility, q, rays)?;
            let d = tree.leaf_direction(q.index, n);
            if d.dot(n) <= 0.0 {
                return Some(1.0);
            }
            *rays += 1;
            keep(!scene.occluded(&Ray::segment(o, d, q.cell_size)))
        }
    }
}
