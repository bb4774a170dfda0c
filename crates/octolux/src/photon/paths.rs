//! The photon pass kept path by path, so that the paths an object meets can be traced again
//! (issue 26, item 2: an object inserted into or moved in a baked solution;
//! `integrators/octree/insert.rs`, docs/guide/baking.md "Inserted objects").
//!
//! Photon path `i` draws its random numbers from `(seed, i)` alone (`trace.rs`), so tracing
//! path `i` again in a changed scene gives exactly the path a full pass in that scene would
//! trace: the same up to its first meeting with the change, its own continuation after. A path
//! that meets no change is the same path. [`PhotonPaths`] keeps, per path, its stored photons
//! (global and caustic, in path order) and the points of its flights (the light's point, each
//! surface hit, and for a flight leaving the scene a point [`PhotonPaths::escape`] away). The
//! paths a change can alter ([`PhotonPaths::paths_changed`]) are traced again and their
//! photons replaced in place ([`PhotonPaths::retrace`]): the maps then equal, photon for
//! photon and in the same order, those of a full pass in the changed scene with the disc
//! guide of the first one (a distant light's guide is a pilot pass of the scene it was made
//! in; it is kept, so that every path keeps its identity).

use super::guide::DiscGuide;
use super::trace::{check_pass, disc_guide, store, trace_path, PhotonError, PhotonSettings, CHUNK, PHOTON_STREAM};
use super::Photon;
use crate::math::Bounds3;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// The photons and flight points of consecutive paths in flat lists, with each path's ends
/// (one set of allocations per batch, not three per path).
#[derive(Default)]
struct Batch {
    global: Vec<Photon>,
    caustic: Vec<Photon>,
    points: Vec<Vec3>,
    /// Per path: where its global photons, caustic photons and flight points end.
    ends: Vec<[usize; 3]>,
    /// Per path: the cells of [`CellGrid`] its flights may cross.
    masks: Vec<u64>,
}

impl Batch {
    /// Path `k`'s global photons, caustic photons and flight points.
    fn path(&self, k: usize) -> (&[Photon], &[Photon], &[Vec3]) {
        let s = if k == 0 { [0; 3] } else { self.ends[k - 1] };
        let e = self.ends[k];
        (&self.global[s[0]..e[0]], &self.caustic[s[1]..e[1]], &self.points[s[2]..e[2]])
    }

    /// Every path of `batches`, in order.
    fn paths(batches: &[Batch]) -> impl Iterator<Item = (&[Photon], &[Photon], &[Vec3])> {
        batches.iter().flat_map(|b| (0..b.ends.len()).map(move |k| b.path(k)))
    }
}

/// The photon pass, path by path (module docs). Memory: the photons (48 bytes each), 12
/// bytes per flight point and 20 bytes per path; after a [`PhotonPaths::retrace`], up to
/// twice the photons and flight points (the lists it keeps for the next).
pub struct PhotonPaths {
    settings: PhotonSettings,
    guide: Option<DiscGuide>,
    global: Vec<Photon>,
    /// Per path `i`: `global[g_start[i]..g_start[i + 1]]`.
    g_start: Vec<u32>,
    caustic: Vec<Photon>,
    c_start: Vec<u32>,
    points: Vec<Vec3>,
    p_start: Vec<u32>,
    /// Per path: the cells of `grid` its flights' bounding boxes meet, so that
    /// [`PhotonPaths::paths_changed`] tests the flights of only the paths near a change.
    masks: Vec<u64>,
    grid: CellGrid,
    /// Length given to a flight that leaves the scene (scene units): twice the diameter of the
    /// bounding sphere of the scene the pass was traced in.
    escape: f32,
    /// The lists [`PhotonPaths::retrace`] replaced last, kept to be written over by the next:
    /// lists of tens of megabytes allocated afresh each frame cost their page faults again.
    spare: Spare,
}

/// Allocations kept for [`PhotonPaths::retrace`]'s next lists.
#[derive(Default)]
struct Spare {
    global: Vec<Photon>,
    caustic: Vec<Photon>,
    points: Vec<Vec3>,
}

/// Paths traced together in a [`PhotonPaths::retrace`] job.
const RETRACE_BATCH: usize = 512;

/// Offsets of the per-path lists, from their lengths.
fn offsets(lens: impl Iterator<Item = usize>) -> Option<Vec<u32>> {
    let mut out = vec![0u32];
    let mut total = 0u64;
    for l in lens {
        total += l as u64;
        out.push(u32::try_from(total).ok()?);
    }
    Some(out)
}

impl PhotonPaths {
    /// Trace the pass of `settings` in `scene`, keeping every path's photons and flight points.
    pub fn trace(scene: &Scene, settings: &PhotonSettings) -> Result<PhotonPaths, PhotonError> {
        check_pass(scene, settings)?;
        let guide = disc_guide(scene, settings).0;
        let (_, radius) = scene.lights.scene_sphere();
        let escape = (4.0 * radius).max(1e-3);
        let grid = CellGrid::new(scene.bounds);
        let mut paths = PhotonPaths {
            settings: *settings,
            guide,
            global: Vec::new(),
            g_start: vec![0],
            caustic: Vec::new(),
            c_start: vec![0],
            points: Vec::new(),
            p_start: vec![0],
            masks: Vec::new(),
            grid,
            escape,
            spare: Spare::default(),
        };
        let n = settings.photons;
        let batches: Vec<Batch> = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut b = Batch::default();
                (c * CHUNK..((c + 1) * CHUNK).min(n)).for_each(|i| paths.trace_into(scene, i, &mut b));
                b
            })
            .collect();
        paths.set(&batches)?;
        Ok(paths)
    }

    /// Path `i` traced in `scene`, appended to `b`.
    fn trace_into(&self, scene: &Scene, i: u64, b: &mut Batch) {
        let inv_n = 1.0 / self.settings.photons as f32;
        let escape = self.escape;
        let Batch { global, caustic, points, ends, masks } = b;
        let first = points.len();
        let mut mask = 0u64;
        let grid = self.grid;
        trace_path(
            scene,
            &self.settings,
            i,
            PHOTON_STREAM,
            inv_n,
            self.guide.as_ref(),
            |hit| store(&hit, global, caustic),
            |f| {
                if points.len() == first {
                    points.push(f.o);
                }
                let end = f.o + f.d * if f.t.is_finite() { f.t } else { escape };
                mask |= grid.mask(f.o.min(end), f.o.max(end));
                points.push(end);
            },
        );
        ends.push([global.len(), caustic.len(), points.len()]);
        masks.push(mask);
    }

    /// Replace every list by the paths of `batches` (in order).
    fn set(&mut self, batches: &[Batch]) -> Result<(), PhotonError> {
        self.g_start = offsets(Batch::paths(batches).map(|p| p.0.len())).ok_or(PhotonError::TooManyRecords)?;
        self.c_start = offsets(Batch::paths(batches).map(|p| p.1.len())).ok_or(PhotonError::TooManyRecords)?;
        self.p_start = offsets(Batch::paths(batches).map(|p| p.2.len())).ok_or(PhotonError::TooManyRecords)?;
        self.global = batches.iter().flat_map(|b| b.global.iter().copied()).collect();
        self.caustic = batches.iter().flat_map(|b| b.caustic.iter().copied()).collect();
        self.points = batches.iter().flat_map(|b| b.points.iter().copied()).collect();
        self.masks = batches.iter().flat_map(|b| b.masks.iter().copied()).collect();
        Ok(())
    }

    /// The pass's settings.
    pub fn settings(&self) -> &PhotonSettings {
        &self.settings
    }

    /// The global photons, in path order (what [`super::trace::trace_photons`] returns).
    pub fn global(&self) -> &[Photon] {
        &self.global
    }

    /// The caustic photons, in path order.
    pub fn caustic(&self) -> &[Photon] {
        &self.caustic
    }

    /// Paths kept.
    pub fn len(&self) -> usize {
        self.g_start.len() - 1
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Flight points kept (the memory of the path records).
    pub fn flight_points(&self) -> usize {
        self.points.len()
    }

    /// The length of a flight that leaves the scene (module docs).
    pub fn escape(&self) -> f32 {
        self.escape
    }

    /// The paths (ascending) that a change of the scene may alter: those one of whose flights
    /// ends in a box of `ends_in` (where a surface was removed: it may have stopped the flight),
    /// or crosses a box of `crosses` along a segment that `blocked(a, b)` says a new surface
    /// meets (it may stop the flight now). Any other path is the same path in the changed scene.
    /// `blocked` may say yes where in doubt; a path it passes over must be unchanged.
    pub fn paths_changed(&self, ends_in: &[Bounds3], crosses: &[Bounds3], blocked: &(dyn Fn(Vec3, Vec3) -> bool + Sync)) -> Vec<u32> {
        let keep = |b: &&Bounds3| !b.is_empty();
        let ends_in: Vec<Bounds3> = ends_in.iter().filter(keep).copied().collect();
        let crosses: Vec<Bounds3> = crosses.iter().filter(keep).copied().collect();
        if ends_in.is_empty() && crosses.is_empty() {
            return Vec::new();
        }
        let inside = |p: Vec3, b: &Bounds3| p.cmpge(b.min).all() && p.cmple(b.max).all();
        // a flight that ends in or crosses a box has a bounding box that meets it
        let near = ends_in.iter().chain(&crosses).fold(0u64, |m, b| m | self.grid.mask(b.min, b.max));
        let n = self.len() as u32;
        let chunk = CHUNK as u32;
        (0..n.div_ceil(chunk))
            .into_par_iter()
            .flat_map_iter(|c| {
                let (ends_in, crosses) = (&ends_in, &crosses);
                (c * chunk..((c + 1) * chunk).min(n)).filter(move |&i| {
                    if self.masks[i as usize] & near == 0 {
                        return false;
                    }
                    let pts = &self.points[self.p_start[i as usize] as usize..self.p_start[i as usize + 1] as usize];
                    pts.iter().skip(1).any(|&p| ends_in.iter().any(|b| inside(p, b)))
                        || pts.windows(2).any(|s| crosses.iter().any(|b| b.meets_segment(s[0], s[1])) && blocked(s[0], s[1]))
                })
            })
            .collect()
    }

    /// Trace the paths `ids` (ascending) again in `scene` and put their photons and flights in
    /// place of the old ones (module docs). Returns the photons removed and those added, of the
    /// global and of the caustic map: per path, those after the photons its old and new traces
    /// share, in the order of the paths.
    pub fn retrace(&mut self, scene: &Scene, ids: &[u32]) -> Result<[MovedPhotons; 2], PhotonError> {
        debug_assert!(ids.windows(2).all(|w| w[0] < w[1]), "path ids ascending");
        let new: Vec<Batch> = ids
            .par_chunks(RETRACE_BATCH)
            .map(|c| {
                let mut b = Batch::default();
                c.iter().for_each(|&i| self.trace_into(scene, i as u64, &mut b));
                b
            })
            .collect();
        let mut moved = [MovedPhotons::default(), MovedPhotons::default()];
        for (&i, m) in ids.iter().zip(new.iter().flat_map(|b| &b.masks)) {
            self.masks[i as usize] = *m;
        }
        for (&i, (new_g, new_c, _)) in ids.iter().zip(Batch::paths(&new)) {
            let i = i as usize;
            // a path is the same up to its first meeting with the change: only the photons
            // after the common prefix moved
            let old_g = &self.global[self.g_start[i] as usize..self.g_start[i + 1] as usize];
            let old_c = &self.caustic[self.c_start[i] as usize..self.c_start[i + 1] as usize];
            for ((old, new), m) in [(old_g, new_g), (old_c, new_c)].into_iter().zip(&mut moved) {
                let same = old.iter().zip(new).take_while(|(a, b)| a == b).count();
                m.removed.extend_from_slice(&old[same..]);
                m.added.extend_from_slice(&new[same..]);
            }
        }
        // every new list's length fits its offsets before anything changes
        let fits = |start: &[u32], len: fn(&Batch) -> usize| {
            let old: u64 = ids.iter().map(|&i| (start[i as usize + 1] - start[i as usize]) as u64).sum();
            let added: u64 = new.iter().map(|b| len(b) as u64).sum();
            *start.last().unwrap_or(&0) as u64 - old + added <= u32::MAX as u64
        };
        if !(fits(&self.g_start, |r| r.global.len()) && fits(&self.c_start, |r| r.caustic.len()) && fits(&self.p_start, |r| r.points.len()))
        {
            return Err(PhotonError::TooManyRecords);
        }
        let sp = &mut self.spare;
        splice(&mut self.global, &mut sp.global, &mut self.g_start, ids, Batch::paths(&new).map(|p| p.0));
        splice(&mut self.caustic, &mut sp.caustic, &mut self.c_start, ids, Batch::paths(&new).map(|p| p.1));
        splice(&mut self.points, &mut sp.points, &mut self.p_start, ids, Batch::paths(&new).map(|p| p.2));
        Ok(moved)
    }
}

/// A partition of the scene's box into 4×4×4 cells, one bit each of a `u64` (x fastest): the
/// cells a box meets, a point outside the scene's box counting in the border cell nearest to
/// it, so that two boxes that meet share a cell.
#[derive(Clone, Copy, Debug)]
struct CellGrid {
    min: Vec3,
    /// Cells per scene unit.
    scale: Vec3,
}

impl CellGrid {
    fn new(b: Bounds3) -> CellGrid {
        let scale = (4.0 / (b.max - b.min)).min(Vec3::splat(f32::MAX));
        if b.min.is_finite() && scale.is_finite() && scale.cmpgt(Vec3::ZERO).all() {
            CellGrid { min: b.min, scale }
        } else {
            // a degenerate scene: one cell
            CellGrid { min: Vec3::ZERO, scale: Vec3::ZERO }
        }
    }

    /// The cells the box `lo`..`hi` meets (every cell when it is not finite).
    #[inline]
    fn mask(&self, lo: Vec3, hi: Vec3) -> u64 {
        if !(lo.is_finite() && hi.is_finite()) {
            return u64::MAX;
        }
        // clamped before the truncation, which is then the floor
        let cell = |p: Vec3| ((p - self.min) * self.scale).clamp(Vec3::ZERO, Vec3::splat(3.0)).as_uvec3();
        let (a, b) = (cell(lo), cell(hi));
        let r = |axis: usize, a: u32, b: u32| RANGES[axis][a as usize][b as usize];
        r(0, a.x, b.x) & r(1, a.y, b.y) & r(2, a.z, b.z)
    }
}

/// Per axis, per first and last cell of a range along it: the bits of the cells in that range,
/// over every cell of the other two axes ([`CellGrid`]'s layout, x fastest).
const RANGES: [[[u64; 4]; 4]; 3] = [axis_ranges(0x1111_1111_1111_1111, 1), axis_ranges(0x000F_000F_000F_000F, 4), axis_ranges(0xFFFF, 16)];

/// [`RANGES`] of one axis: `one` holds the bits of its cell 0, `step` the shift to the next.
const fn axis_ranges(one: u64, step: u32) -> [[u64; 4]; 4] {
    let mut out = [[0u64; 4]; 4];
    let mut a = 0;
    while a < 4 {
        let mut b = a;
        let mut m = 0u64;
        while b < 4 {
            m |= one << (step * b as u32);
            out[a][b] = m;
            b += 1;
        }
        a += 1;
    }
    out
}

/// The photons a [`PhotonPaths::retrace`] took out of one map and put in.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MovedPhotons {
    pub removed: Vec<Photon>,
    pub added: Vec<Photon>,
}

impl MovedPhotons {
    /// How many moved: removed plus added.
    pub fn len(&self) -> usize {
        self.removed.len() + self.added.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// `list` (per-path ranges `start`) with the ranges of paths `ids` (ascending) replaced by
/// `new`, and `start` with them: the new list is written into `spare`'s allocation, which then
/// takes the old list's. The caller checked that the new offsets fit in `u32`.
fn splice<'a, T: Copy + 'a>(list: &mut Vec<T>, spare: &mut Vec<T>, start: &mut [u32], ids: &[u32], new: impl Iterator<Item = &'a [T]>) {
    spare.clear();
    let mut from = 0usize;
    // offsets before `shifted` already moved by `delta`
    let (mut delta, mut shifted) = (0i64, 0usize);
    for (&i, n) in ids.iter().zip(new) {
        let i = i as usize;
        let (s0, s1) = (start[i] as usize, start[i + 1] as usize);
        spare.extend_from_slice(&list[from..s0]);
        spare.extend_from_slice(n);
        from = s1;
        for o in &mut start[shifted..=i] {
            *o = (*o as i64 + delta) as u32;
        }
        delta += n.len() as i64 - (s1 - s0) as i64;
        shifted = i + 1;
    }
    spare.extend_from_slice(&list[from..]);
    for o in &mut start[shifted..] {
        *o = (*o as i64 + delta) as u32;
    }
    std::mem::swap(list, spare);
}

#[cfg(test)]
mod tests {
    use super::{offsets, splice, CellGrid};
    use crate::math::Bounds3;
    use crate::sampling::Sampler;
    use glam::Vec3;

    /// Random boxes within and around the grid's box (points, thin and wide ones, far outside):
    /// two that meet share a cell, and some that do not meet share none (the test can fail).
    #[test]
    fn boxes_that_meet_share_a_cell() {
        let mut s = Sampler::new(3, 0, 0);
        let grid = CellGrid::new(Bounds3 { min: Vec3::new(-1.0, 0.0, 2.0), max: Vec3::new(3.0, 0.5, 4.0) });
        let mut random_box = || {
            let c = Vec3::new(-3.0, -1.0, 0.0) + Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * Vec3::new(8.0, 2.5, 6.0);
            let h = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * Vec3::new(3.0, 1.0, 2.0) * s.next_1d();
            Bounds3 { min: c - h, max: c + h }
        };
        let (mut met, mut apart) = (0, 0);
        for _ in 0..20_000 {
            let (a, b) = (random_box(), random_box());
            let shared = grid.mask(a.min, a.max) & grid.mask(b.min, b.max) != 0;
            if a.min.cmple(b.max).all() && b.min.cmple(a.max).all() {
                assert!(shared, "{a:?} and {b:?} meet");
                met += 1;
            } else if !shared {
                apart += 1;
            }
        }
        assert!(met > 500 && apart > 1000, "{met} met, {apart} apart without a shared cell");
        assert_eq!(grid.mask(Vec3::NAN, Vec3::ONE), u64::MAX);
        assert_eq!(grid.mask(Vec3::splat(-1e30), Vec3::splat(1e30)), u64::MAX);
        // a scene without geometry: one cell for everything
        let none = CellGrid::new(Bounds3::EMPTY);
        assert_eq!(none.mask(Vec3::splat(-5.0), Vec3::splat(-4.0)), 1);
        assert_eq!(none.mask(Vec3::splat(4.0), Vec3::splat(5.0)), 1);
        // a scene flat along y (a floor alone): its cells along x and z, points off its plane
        // in a border cell of y
        let flat = CellGrid::new(Bounds3 { min: Vec3::ZERO, max: Vec3::new(1.0, 0.0, 1.0) });
        assert_eq!(flat.mask(Vec3::ZERO, Vec3::ZERO), 1);
        assert_eq!(flat.mask(Vec3::new(0.9, 0.0, 0.9), Vec3::new(0.9, 0.0, 0.9)), 1 << (3 + 16 * 3));
        assert_ne!(flat.mask(Vec3::new(0.5, -1.0, 0.5), Vec3::new(0.5, 1.0, 0.5)) & flat.mask(Vec3::splat(0.5), Vec3::splat(0.5)), 0);
    }

    /// `splice` against rebuilding the lists from per-path vectors: random path lengths (0 to
    /// 5), random ascending ids (the first and the last path among them at times), new lengths
    /// shorter, equal and longer, the spare reused from one round to the next.
    #[test]
    fn splice_equals_rebuilding_the_lists() {
        let mut s = Sampler::new(11, 0, 0);
        let mut pick = |n: u32| ((s.next_1d() * n as f32) as u32).min(n - 1);
        let mut paths: Vec<Vec<u32>> = (0..200).map(|i| (0..pick(6)).map(|k| i * 10 + k).collect()).collect();
        let mut list: Vec<u32> = paths.concat();
        let mut start = offsets(paths.iter().map(Vec::len)).unwrap();
        let mut spare = Vec::new();
        for round in 0..20u32 {
            let ids: Vec<u32> = (0..200).filter(|_| pick(4) == 0).collect();
            let new: Vec<Vec<u32>> = ids.iter().map(|&i| (0..pick(6)).map(|k| 100_000 * (round + 1) + i * 10 + k).collect()).collect();
            for (&i, n) in ids.iter().zip(&new) {
                paths[i as usize] = n.clone();
            }
            splice(&mut list, &mut spare, &mut start, &ids, new.iter().map(Vec::as_slice));
            assert_eq!(list, paths.concat(), "round {round}");
            assert_eq!(start, offsets(paths.iter().map(Vec::len)).unwrap(), "round {round}");
        }
    }
}
