//! Objects inserted into baked lighting with their effect on the scene: an incremental re-bake
//! (issue 26, item 2; docs/guide/baking.md "Inserted objects").
//!
//! The volume query (`insert.rs`) lights an inserted object from the baked values but leaves
//! the scene as baked: no indirect shadow under the object, no colour it bleeds, no light the
//! scene sends back to it. Here the object becomes part of the photon solution instead:
//! 1. [`PhotonPaths`] keeps the bake's photon pass path by path (traced once, in the baked
//!    scene: [`OctreeIntegrator::photon_paths`]).
//! 2. Per placement of the object, [`OctreeIntegrator::rebake`] finds the paths it can alter:
//!    those with a flight ending where the object was (it may have stopped them) and those
//!    with a flight its new shapes meet (they stop it now); any other path is the same in
//!    the new scene. It traces exactly those again, and replaces their photons.
//! 3. Each octree is updated on its own topology: the first time by
//!    [`crate::caches::Octree::refit_with_sums`] (every leaf estimated, its sums kept in the
//!    [`RebakeState`]), then by [`crate::caches::Octree::refit_incremental`] (the moved photons
//!    subtracted from and added to the sums of the leaves that gather them; the leaves around
//!    the object estimated from their photons; `caches/octree/incremental.rs`). With the
//!    `visible_sample` leak test, whose sampled photons the sums do not keep,
//!    [`crate::caches::Octree::refit`] re-estimates the leaves whose boxes meet a moved photon
//!    or the object's boxes instead.
//!
//! The result equals a re-bake of the scene with the object on the same topology up to the order
//! of the sums' additions (test `an_incremental_update_equals_a_rebake_on_the_same_topology`:
//! the same photons and nodes, values within 1e-5 of a leaf's largest); the cost grows with
//! the photons the object touches (the search is still a pass over the kept flight points).
//! The object is then shaded like any surface of the scene: its
//! leaves hold its own photons. What a re-bake on the same topology cannot give: finer leaves on
//! the object than the empty cells it sits in had (a small object in a large cell gets one
//! cell's six matrices), volumetric values (the refitted trees hold none), and a caustic
//! octree where the bake had none (caustic photons the object makes are then kept in the path
//! records but not rendered).

use super::{estimator_spheres, BuildError, LeakTest, OctreeIntegrator};
use crate::caches::octree::{Changes, Estimator, LeafSums, OctreeError, RefitStats, Surfaces};
use crate::caches::Octree;
use crate::math::Bounds3;
use crate::photon::paths::{MovedPhotons, PhotonPaths};
use crate::photon::Photon;
use crate::scene::material::Material;
use crate::scene::Scene;
use glam::Vec3;
use serde::Serialize;
use std::ops::Range;
use std::time::Instant;

/// An object moved in a scene (inserted: `was` empty; removed: `now` empty).
#[derive(Clone, Debug, Default)]
pub struct ObjectMove<'a> {
    /// Its bounds before (where it may have stopped photon flights).
    pub was: &'a [Bounds3],
    /// Its bounds now.
    pub now: &'a [Bounds3],
    /// Its shapes in the scene now (their triangles and spheres are tested against the
    /// flights crossing `now`).
    pub shapes: Range<u32>,
}

/// Whether the segment `a`–`b` meets the triangle, or nearly (Möller–Trumbore with a margin
/// of 1e-4 in the barycentric and segment coordinates; a segment in the triangle's plane
/// counts): a flight the scene's intersection might stop on it is never passed over.
fn segment_meets_triangle(a: Vec3, b: Vec3, t: &[Vec3; 3]) -> bool {
    const TOL: f32 = 1e-4;
    let d = b - a;
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let p = d.cross(e2);
    let det = e1.dot(p);
    let scale = d.length() * e1.length() * e2.length();
    if !(det.abs() > 1e-7 * scale) {
        // parallel to the plane (or degenerate): in doubt, when the boxes overlap
        let lo = t[0].min(t[1]).min(t[2]);
        let hi = t[0].max(t[1]).max(t[2]);
        return a.min(b).cmple(hi).all() && a.max(b).cmpge(lo).all();
    }
    let inv = 1.0 / det;
    let s = a - t[0];
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    let w = e2.dot(q) * inv;
    u >= -TOL && v >= -TOL && u + v <= 1.0 + TOL && (-TOL..=1.0 + TOL).contains(&w)
}

/// An object's triangles in clusters of [`TriangleClusters::SIZE`] near one another (by the
/// Morton order of their centroids), each cluster and triangle with its bounds padded by the
/// test's margin: a segment is tested against the triangles of the clusters whose bounds it
/// meets.
struct TriangleClusters {
    /// Triangle indices in cluster order.
    order: Vec<u32>,
    tri_boxes: Vec<Bounds3>,
    boxes: Vec<Bounds3>,
}

impl TriangleClusters {
    const SIZE: usize = 16;

    fn new(tris: &[[Vec3; 3]], pad: Vec3) -> TriangleClusters {
        let bound = |t: &[Vec3; 3]| {
            let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
            let m = Vec3::splat(1e-3 * (hi - lo).max_element()) + pad;
            Bounds3 { min: lo - m, max: hi + m }
        };
        let tri_boxes: Vec<Bounds3> = tris.iter().map(bound).collect();
        let mut all = Bounds3::EMPTY;
        tri_boxes.iter().for_each(|b| {
            all.extend(b.min);
            all.extend(b.max)
        });
        let key = |b: &Bounds3| {
            let q = ((b.center() - all.min) / (all.max - all.min).max(Vec3::splat(1e-30)) * 1023.0).clamp(Vec3::ZERO, Vec3::splat(1023.0));
            let spread = |v: f32| (0..10).fold(0u32, |k, i| k | ((((v as u32) >> i) & 1) << (3 * i)));
            spread(q.x) | (spread(q.y) << 1) | (spread(q.z) << 2)
        };
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        order.sort_by_key(|&i| (key(&tri_boxes[i as usize]), i));
        let boxes = order
            .chunks(Self::SIZE)
            .map(|c| {
                let mut b = Bounds3::EMPTY;
                c.iter().for_each(|&i| {
                    b.extend(tri_boxes[i as usize].min);
                    b.extend(tri_boxes[i as usize].max)
                });
                b
            })
            .collect();
        TriangleClusters { order, tri_boxes, boxes }
    }

    /// Whether the segment meets a triangle: a slab test against each cluster's padded box,
    /// then against each of its triangles' (a long flight's own bounding box overlaps most
    /// of them, its line few).
    fn meets(&self, tris: &[[Vec3; 3]], a: Vec3, b: Vec3) -> bool {
        self.boxes.iter().zip(self.order.chunks(Self::SIZE)).any(|(cb, c)| {
            cb.meets_segment(a, b)
                && c.iter().any(|&i| self.tri_boxes[i as usize].meets_segment(a, b) && segment_meets_triangle(a, b, &tris[i as usize]))
        })
    }
}

/// Whether the segment `a`–`b` meets the sphere (a margin of 1e-4 of the radius).
fn segment_meets_sphere(a: Vec3, b: Vec3, c: Vec3, r: f32) -> bool {
    let d = b - a;
    let l2 = d.length_squared();
    let t = if l2 > 0.0 { ((c - a).dot(d) / l2).clamp(0.0, 1.0) } else { 0.0 };
    // the closest point of the segment within the sphere, and an end outside it (a flight
    // from inside to inside meets nothing)
    let r = r * (1.0 + 1e-4);
    let inside = |p: Vec3| (p - c).length_squared() < r * r * (1.0 - 2e-4) * (1.0 - 2e-4);
    (a + d * t - c).length_squared() <= r * r && !(inside(a) && inside(b))
}

/// What a re-bake keeps between frames: the photon pass path by path and, per octree, the sums
/// behind its leaves ([`LeafSums`]: taken at the first update, then updated with the trees).
/// Made for one integrator from [`OctreeIntegrator::photon_paths`]; pass it only to that
/// integrator's [`OctreeIntegrator::rebake`].
pub struct RebakeState {
    paths: PhotonPaths,
    sums: [Option<LeafSums>; 2],
    /// The geometry-area estimator's triangles ([`estimator_surfaces`]) of the shapes before
    /// the object's, which no frame changes (the first shape after them, and their count):
    /// a frame appends the object's instead of listing the whole scene again.
    surfaces: Option<(u32, usize, Vec<[Vec3; 3]>)>,
}

impl RebakeState {
    pub fn new(paths: PhotonPaths) -> RebakeState {
        RebakeState { paths, sums: [None, None], surfaces: None }
    }

    /// The photon pass of the scene as last updated.
    pub fn paths(&self) -> &PhotonPaths {
        &self.paths
    }
}

/// `tree` refitted to `photons` after `moved`: from the sums in `sums` where the leak test
/// reads no sampled photons (`incremental`; sums taken by a full refit the first time),
/// by [`Octree::refit`] of the leaves around the changes otherwise.
fn refit_tree(
    tree: &Octree,
    sums: &mut Option<LeafSums>,
    photons: &[Photon],
    moved: &MovedPhotons,
    surfaces: Option<Surfaces<'_>>,
    changes: Changes<'_>,
    incremental: bool,
) -> Result<(Octree, RefitStats), OctreeError> {
    if !incremental {
        *sums = None;
        return tree.refit(photons, surfaces, Some(changes));
    }
    match sums {
        Some(s) => tree.refit_incremental(s, photons, &moved.removed, &moved.added, surfaces, changes.boxes),
        None => {
            let (t, st, s) = tree.refit_with_sums(photons, surfaces)?;
            *sums = Some(s);
            Ok((t, st))
        }
    }
}

/// What [`OctreeIntegrator::rebake`] did (out.json's `insert.rebake`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RebakeStats {
    /// Photon paths traced again, and all paths.
    pub paths_retraced: usize,
    pub paths: usize,
    /// Photons removed plus photons added (both maps).
    pub photons_moved: usize,
    /// Valid leaves estimated anew from their photons, updated by the photons that moved
    /// (their sums), and copied (both trees).
    pub leaves_estimated: usize,
    pub leaves_updated: usize,
    pub leaves_copied: usize,
    /// Seconds: finding the paths, tracing them, re-estimating the trees (with the query's
    /// lists), and all of it.
    pub t_find_s: f64,
    pub t_trace_s: f64,
    pub t_refit_s: f64,
    pub t_s: f64,
}

impl OctreeIntegrator {
    /// The photon pass of this integrator's settings traced in `scene` (the baked scene),
    /// kept path by path for [`OctreeIntegrator::rebake`]. The same paths as the bake's.
    pub fn photon_paths(&self, scene: &Scene) -> Result<PhotonPaths, BuildError> {
        Ok(PhotonPaths::trace(scene, &self.settings.traced_photons())?)
    }

    /// Update the octrees for `scene`, which differs from the scene of `state`'s paths (as
    /// kept so far) by the object `change` moves: retrace the paths it can alter, update the
    /// leaves the moved photons reach (module docs). `state` then holds `scene`'s pass.
    pub fn rebake(&mut self, state: &mut RebakeState, scene: &Scene, change: &ObjectMove<'_>) -> Result<RebakeStats, BuildError> {
        let t0 = Instant::now();
        let paths = &mut state.paths;
        // a hit on the object lies within float rounding of its bounds, maybe outside them
        let pad = Vec3::splat(1e-4 * paths.escape());
        let grow = |b: &[Bounds3]| -> Vec<Bounds3> {
            b.iter().filter(|b| !b.is_empty()).map(|b| Bounds3 { min: b.min - pad, max: b.max + pad }).collect()
        };
        let (was, now) = (grow(change.was), grow(change.now));
        let (tris, spheres) = scene.shapes_geometry(&change.shapes);
        let clusters = TriangleClusters::new(&tris, pad);
        let blocked = |a: Vec3, b: Vec3| clusters.meets(&tris, a, b) || spheres.iter().any(|&(c, r)| segment_meets_sphere(a, b, c, r));
        let ids = paths.paths_changed(&was, &now, &blocked);
        let boxes: Vec<Bounds3> = was.iter().chain(&now).copied().collect();
        let boxes = &boxes[..];
        let t_find_s = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let moved = paths.retrace(scene, &ids)?;
        let t_trace_s = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        let needs = |e: Estimator| e == Estimator::GeometryArea;
        let (tris, spheres) = if needs(self.settings.global.estimator) || needs(self.settings.caustic.estimator) {
            // `estimator_surfaces(scene)`, its part before the object kept from the last frame
            let first = change.shapes.start;
            let (_, kept, tris) = match &mut state.surfaces {
                Some(s) if s.0 == first => s,
                slot => {
                    let mut tris = Vec::new();
                    scene.mesh_triangles_into(0..first, Material::has_smooth_lobe, &mut tris);
                    slot.insert((first, tris.len(), tris))
                }
            };
            tris.truncate(*kept);
            scene.mesh_triangles_into(first..u32::MAX, Material::has_smooth_lobe, tris);
            (&tris[..], estimator_spheres(scene))
        } else {
            (&[][..], Vec::new())
        };
        let surfaces = Some(Surfaces { triangles: tris, spheres: &spheres });
        // the sums cannot follow the sampled photons the `visible_sample` test reads
        let incremental = self.leak() != LeakTest::VisibleSample;
        // the moved photons' positions: what the refit without sums looks around
        let points: Vec<Vec3> =
            if incremental { Vec::new() } else { moved.iter().flat_map(|m| m.removed.iter().chain(&m.added)).map(|p| p.p).collect() };
        let changes = Changes { boxes, points: &points };
        let [sg, sc] = &mut state.sums;
        let (global, g) =
            refit_tree(&self.global, sg, paths.global(), &moved[0], surfaces, changes, incremental).map_err(BuildError::Global)?;
        let mut st = RebakeStats {
            paths_retraced: ids.len(),
            paths: paths.len(),
            photons_moved: moved.iter().map(MovedPhotons::len).sum(),
            leaves_estimated: g.estimated,
            leaves_updated: g.updated,
            leaves_copied: g.copied,
            t_find_s,
            t_trace_s,
            ..Default::default()
        };
        self.global = global;
        if let Some(c) = &self.caustic {
            let (caustic, s) =
                refit_tree(c, sc, paths.caustic(), &moved[1], surfaces, changes, incremental).map_err(BuildError::Caustic)?;
            st.leaves_estimated += s.estimated;
            st.leaves_updated += s.updated;
            st.leaves_copied += s.copied;
            self.caustic = Some(caustic);
        }
        self.stats.global = self.global.stats().clone();
        self.stats.caustic = self.caustic.as_ref().map(|c| c.stats().clone());
        self.stats.global_photons = paths.global().len();
        self.stats.caustic_photons = paths.caustic().len();
        self.stats.bytes = self.global.stats().bytes + self.caustic.as_ref().map_or(0, |c| c.stats().bytes);
        self.prepare(scene);
        self.prepare_query();
        st.t_refit_s = t2.elapsed().as_secs_f64();
        st.t_s = t0.elapsed().as_secs_f64();
        Ok(st)
    }
}

#[cfg(test)]
mod tests;
