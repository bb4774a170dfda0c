//! Per-leaf density estimates (paper §4, eq. 5.4, and the estimators of
//! [`super::Estimator`]): each valid leaf gathers the photons of its cell enlarged by `1+ε`
//! (its own sorted range plus the neighbouring leaves the enlarged box meets), then sums the
//! six axis matrices sequentially in a fixed order (8 octant sums, f32 blocks flushed into
//! f64), so the result is bit-identical for any thread count. With
//! `Estimator::GeometryArea` each photon is divided by the lit projected area of the leaf's
//! triangles (`geometry.rs`).

use super::cells::{LeafBuild, TreeView};
use super::compress::FullLeaf;
use super::geometry::{lit_areas, projected_lit_area, AnalyticSphere, GroupHits, OrientedArea};
use super::settings::{Enlarge, Estimator, Split};
use super::sort::PhotonRec;
use super::{OctreeSettings, ALL_FACING};
use crate::math::Bounds3;
use glam::{DVec3, Mat3, Vec3, Vec3A};
/// Per-leaf scratch buffers (one set per rayon job).
#[derive(Default)]
pub(super) struct Scratch {
    /// Gathered photon ranges `[lo, hi)` (own cell and neighbours inside the box).
    segs: Vec<(u32, u32)>,
    /// Gathered single photons (from neighbours cut by the box).
    singles: Vec<u32>,
    pos: Vec<Vec3>,
    ng: Vec<Vec3>,
    areas: Vec<OrientedArea>,
    sides: SideAreas,
}

/// The lit areas of a leaf sorted by half-axis for [`Accumulator::add_by_surface`], built
/// once per leaf: half-axis `k` (order `+X, −X, +Y, −Y, +Z, −Z`) holds, in the order of the
/// areas, those whose normal has a non-zero component of its sign on its axis, with their
/// weights `n_a² A`, and the sum of the weights (f32, summed in that order).
#[derive(Clone, Debug, Default)]
struct SideAreas {
    /// Entries of half-axis `k`: `start[k]..start[k + 1]`.
    start: [usize; 7],
    g: Vec<f32>,
    n: Vec<Vec3>,
    total: [f32; 6],
}

impl SideAreas {
    fn fill(&mut self, areas: &[OrientedArea]) {
        self.g.clear();
        self.n.clear();
        for k in 0..6 {
            let (a, neg) = (k / 2, k % 2 == 1);
            self.start[k] = self.g.len();
            let mut total = 0.0f32;
            for e in areas {
                if e.n[a] != 0.0 && (e.n[a] < 0.0) == neg {
                    let g = e.n[a] * e.n[a] * e.area;
                    total += g;
                    self.g.push(g);
                    self.n.push(e.n);
                }
            }
            self.total[k] = total;
        }
        self.start[6] = self.g.len();
    }
}

/// Result of one leaf estimate.
pub(super) struct LeafEstimate {
    pub m: FullLeaf,
    pub gathered: u32,
    pub fallback: bool,
    /// Bit `k` (order `+X, −X, +Y, −Y, +Z, −Z`): the cell has surfaces facing that
    /// half-axis, so matrix `k` carries a value (see [`super::Octree::facing`]).
    pub facing: u8,
    /// Mean normal of the surfaces matrix `k` describes (weights `n_a² × area`), or the
    /// half-axis itself when the geometry is unknown: the compression keeps the irradiance
    /// exact for it.
    pub normals: [Vec3; 6],
    /// Mean position and normal of the photons of the leaf's own cell.
    pub anchor: super::LeafAnchors,
    /// What an incremental update needs (`incremental.rs`), when asked for.
    pub state: Option<Box<LeafState>>,
}

/// How a valid leaf weighs each photon it gathers: fixed by its gathering box, the settings and
/// the lit surfaces in the box (not by the other photons, as long as the lit sides stay).
#[derive(Clone, Debug)]
pub(super) struct LeafWeights {
    /// The estimator after the fallback (`Cosine` when the box holds no lit surface).
    estimator: Estimator,
    by_normal: bool,
    /// `1 / ΔA` of the gathering box (`Paper`, `Cosine`).
    inv_da: f32,
    min_cos: f32,
    /// Lower bound on the area a photon stands for (`EstimateCtx::estimate`).
    a_min: f32,
    lit_total: f32,
    /// The lit oriented areas in the box (`GeometryArea`).
    areas: Vec<OrientedArea>,
    /// The groups of coplanar triangles in the box with their photons counted per side
    /// (`GeometryArea`, when the estimate keeps its [`LeafState`]).
    groups: Vec<GroupHits>,
    sides: SideAreas,
}

impl LeafWeights {
    /// Add photon `r` to the sums (the estimate's loop).
    #[inline(always)]
    fn add<R: PhotonRec>(&self, acc: &mut Accumulator, r: &R) {
        if self.by_normal && self.estimator == Estimator::GeometryArea {
            add_by_surface(&mut acc.zero, r.w(), r.c(), r.ng(), &self.sides, self.min_cos, self.a_min, 1.0);
        } else {
            let w = r.w();
            let weight = self.weight(w);
            if self.by_normal {
                add_by_normal(&mut acc.zero, w, r.c(), weight, r.ng(), 1.0);
            } else {
                acc.add(w, r.c(), weight);
            }
        }
    }

    /// Add `sign` times photon `r`'s terms to the f64 axis sums `totals` (an incremental update:
    /// the same terms as [`LeafWeights::add`], summed in f64 in the update's order).
    pub fn add_signed<R: PhotonRec>(&self, totals: &mut [[DVec3; 3]; 6], r: &R, sign: f64) {
        if self.by_normal && self.estimator == Estimator::GeometryArea {
            add_by_surface(totals, r.w(), r.c(), r.ng(), &self.sides, self.min_cos, self.a_min, sign);
        } else {
            let w = r.w();
            let weight = self.weight(w);
            if self.by_normal {
                add_by_normal(totals, w, r.c(), weight, r.ng(), sign);
            } else {
                let wd = Vec3A::from(w) * weight;
                let cols = [wd * r.c().x, wd * r.c().y, wd * r.c().z];
                for a in 0..3 {
                    if w[a] != 0.0 {
                        let m = &mut totals[2 * a + (w[a] < 0.0) as usize];
                        for (mc, cc) in m.iter_mut().zip(&cols) {
                            *mc += DVec3::from(Vec3::from(*cc)) * sign;
                        }
                    }
                }
            }
        }
    }

    #[inline(always)]
    fn weight(&self, w: Vec3) -> f32 {
        match self.estimator {
            // `w` carries the cosine weight
            Estimator::Paper | Estimator::Cosine => self.inv_da,
            Estimator::GeometryArea => 1.0 / projected_lit_area(&self.areas, w).max(self.min_cos * self.lit_total.max(self.a_min)),
        }
    }

    /// Count the photon at `p` of normal `ng` in (`sign` +1) or out (−1) of the groups whose
    /// lit sides the geometry-area estimator reads (none for the other estimators).
    pub fn count_sides(&mut self, p: Vec3, ng: Vec3, sign: i32) {
        self.groups.iter_mut().for_each(|g| g.count(p, ng, sign));
    }

    /// Whether the sides the counted photons light differ from those of the estimate (its
    /// weights no longer hold).
    pub fn sides_changed(&self) -> bool {
        self.groups.iter().any(GroupHits::changed)
    }
}

/// A valid leaf's estimate kept as sums, for an incremental update (`incremental.rs`): what
/// the photons of its gathering box add up to, and how it weighs a photon.
#[derive(Clone, Debug)]
pub(super) struct LeafState {
    /// The six axis matrices' columns in f64, before the conversion to f32.
    pub totals: [[DVec3; 3]; 6],
    /// Sums of the positions and normals of the photons of the leaf's own cell, and their count.
    pub pos: DVec3,
    pub nrm: DVec3,
    pub own: u32,
    pub gathered: u32,
    pub weights: LeafWeights,
    pub facing: u8,
    pub normals: [Vec3; 6],
    pub fallback: bool,
}

impl LeafState {
    /// The leaf's estimate from the sums (no sampled photons: each sample is the mean).
    pub fn estimate(&self, cell_min: Vec3, cell_size: f32) -> LeafEstimate {
        let k = self.own.max(1) as f64;
        let mean = super::Anchor::encode((self.pos / k).as_vec3(), (self.nrm / k).as_vec3(), cell_min, cell_size);
        LeafEstimate {
            m: matrices(&self.totals),
            gathered: self.gathered,
            fallback: self.fallback,
            facing: self.facing,
            normals: self.normals,
            anchor: super::LeafAnchors { mean, samples: [mean; super::ANCHOR_SAMPLES] },
            state: None,
        }
    }
}

/// The matrices from their f64 columns.
fn matrices(totals: &[[DVec3; 3]; 6]) -> FullLeaf {
    std::array::from_fn(|k| Mat3::from_cols(totals[k][0].as_vec3(), totals[k][1].as_vec3(), totals[k][2].as_vec3()))
}

/// What every leaf estimate reads (shared by the rayon jobs).
pub(super) struct EstimateCtx<'a, R> {
    pub view: TreeView<'a>,
    /// Photon range start of every node, in the sorted order.
    pub start: &'a [u32],
    pub pos: &'a [Vec3],
    pub recs: &'a [R],
    pub settings: &'a OctreeSettings,
    pub triangles: &'a [[Vec3; 3]],
    /// Triangle indices per valid leaf (empty without geometry).
    pub tri_lists: &'a [Vec<u32>],
    /// Analytic spheres (each leaf tests them all against its box).
    pub spheres: &'a [AnalyticSphere],
}

/// The six 3x3 sums. Each photon adds `(w · weight) cᵀ` to one of 8 octant sums (by the
/// signs of `w`); the axis matrices are the sums of the 4 octants on their side. A photon
/// with a zero component belongs to no matrix of that axis: it goes to `zero` sums, one per
/// axis matrix. f32 blocks of at most `BLOCK` photons are flushed into f64 totals, so the
/// rounding error does not grow with the photon count of a leaf.
struct Accumulator {
    block: [[Vec3A; 3]; 8],
    total: [[DVec3; 3]; 8],
    /// Photons with a zero direction component, added directly to the axis matrices (f64).
    zero: [[DVec3; 3]; 6],
    count: u32,
}

impl Accumulator {
    const BLOCK: u32 = 64;

    fn new() -> Self {
        Accumulator { block: [[Vec3A::ZERO; 3]; 8], total: [[DVec3::ZERO; 3]; 8], zero: [[DVec3::ZERO; 3]; 6], count: 0 }
    }

    fn flush(&mut self) {
        for (t, b) in self.total.iter_mut().zip(self.block.iter_mut()) {
            for (tc, bc) in t.iter_mut().zip(b.iter_mut()) {
                *tc += DVec3::from(Vec3::from(*bc));
                *bc = Vec3A::ZERO;
            }
        }
        self.count = 0;
    }

    #[inline(always)]
    fn add(&mut self, w: Vec3, c: Vec3, weight: f32) {
        let wd = Vec3A::from(w) * weight;
        let cols = [wd * c.x, wd * c.y, wd * c.z];
        if w.x == 0.0 || w.y == 0.0 || w.z == 0.0 {
            // rare: straight into the matrices of the non-zero components
            for a in 0..3 {
                if w[a] != 0.0 {
                    let m = &mut self.zero[2 * a + (w[a] < 0.0) as usize];
                    for (mc, cc) in m.iter_mut().zip(&cols) {
                        *mc += DVec3::from(Vec3::from(*cc));
                    }
                }
            }
            return;
        }
        let o = (w.x < 0.0) as usize | ((w.y < 0.0) as usize) << 1 | ((w.z < 0.0) as usize) << 2;
        let m = &mut self.block[o];
        m[0] += cols[0];
        m[1] += cols[1];
        m[2] += cols[2];
        self.count += 1;
        if self.count == Self::BLOCK {
            self.flush();
        }
    }

    /// The six axis matrices' columns in f64: each the sum of its `zero` sums and of the 4
    /// octants on its side.
    fn totals(mut self) -> [[DVec3; 3]; 6] {
        self.flush();
        std::array::from_fn(|k| {
            let (axis, neg) = (k / 2, k % 2);
            let mut cols = self.zero[k];
            for (o, t) in self.total.iter().enumerate() {
                if (o >> axis) & 1 == neg {
                    for (cc, tc) in cols.iter_mut().zip(t) {
                        *cc += *tc;
                    }
                }
            }
            cols
        })
    }

    #[cfg(test)]
    fn finish(self) -> FullLeaf {
        matrices(&self.totals())
    }
}

/// [`Split::Normal`]: straight into the axis matrices on the side of `ng` (f64; the
/// weights differ per axis, so the octant sums do not apply).
#[inline]
fn add_by_normal(zero: &mut [[DVec3; 3]; 6], w: Vec3, c: Vec3, weight: f32, ng: Vec3, sign: f64) {
    let n2 = ng * ng;
    let norm = n2.dot(n2);
    if !(norm > 0.0) {
        return;
    }
    let wd = DVec3::from(w * weight) * sign;
    for a in 0..3 {
        if ng[a] != 0.0 {
            let g = (n2[a] / norm) as f64;
            let m = &mut zero[2 * a + (ng[a] < 0.0) as usize];
            m[0] += wd * (g * c.x as f64);
            m[1] += wd * (g * c.y as f64);
            m[2] += wd * (g * c.z as f64);
        }
    }
}

/// [`Split::Normal`] with [`Estimator::GeometryArea`]: matrix `(a, s)` estimates the
/// light on the surfaces facing the half-axis `(a, s)`, weighted by `n_a²`:
/// `M_a^s = Σ_p ng_a² Φ_p w_p / A⊥_a^s(w_p)` with `A⊥_a^s(w) = Σ_t n_{t,a}² A_t (n_t·w)₊`
/// over the lit pieces whose normal has the sign `s` on axis `a`. Each photon is thus
/// divided by the area of the surfaces it can have landed on in that matrix, not by all
/// the surfaces of the cell (which would average a dim face with the bright floor
/// beside it). For one plane of normal `N`: `M_a^{s(N_a)} = ∫ L w dω` for every axis, so
/// the query's `Σ_a N_a² = 1` returns it exactly.
#[allow(clippy::too_many_arguments)] // a photon's fields and the leaf's weights
#[inline(always)]
fn add_by_surface(zero: &mut [[DVec3; 3]; 6], w: Vec3, c: Vec3, ng: Vec3, sides: &SideAreas, min_cos: f32, a_min: f32, sign: f64) {
    for a in 0..3 {
        if ng[a] == 0.0 {
            continue;
        }
        let neg = ng[a] < 0.0;
        let k = 2 * a + neg as usize;
        let (lo, hi) = (sides.start[k], sides.start[k + 1]);
        let mut proj = 0.0f32;
        for (g, n) in sides.g[lo..hi].iter().zip(&sides.n[lo..hi]) {
            proj += g * n.dot(w).max(0.0);
        }
        // `ng_a² min_cos a_min`: the photon's own surface, of normal `ng`, has at least
        // `a_min` in the box (see `EstimateCtx::estimate`)
        let den = proj.max(min_cos * sides.total[k]).max(ng[a] * ng[a] * min_cos * a_min);
        if !(den > 0.0) {
            continue;
        }
        let f = (ng[a] * ng[a] / den) as f64 * sign;
        let wd = DVec3::from(w) * f;
        let m = &mut zero[k];
        m[0] += wd * c.x as f64;
        m[1] += wd * c.y as f64;
        m[2] += wd * c.z as f64;
    }
}

impl<R: PhotonRec> EstimateCtx<'_, R> {
    /// Box gathered by a leaf, whether it is enlarged, and the margin `δ = ε s / 2` between
    /// the cell and the box (0 when not enlarged).
    fn gather_box_margin(&self, leaf: &LeafBuild) -> (Bounds3, bool, f32) {
        let s = self.view.cell_size[leaf.depth as usize];
        let cmin = self.view.cell_min(leaf.depth, leaf.ijk);
        let eps = self.settings.epsilon;
        let enlarged = eps > 0.0
            && match self.settings.enlarge {
                Enlarge::All => true,
                Enlarge::UnderNMin => leaf.hi - leaf.lo < self.settings.n_min,
            };
        if enlarged {
            let c = cmin + Vec3::splat(0.5 * s);
            let half = Vec3::splat(0.5 * s * (1.0 + eps));
            (Bounds3 { min: c - half, max: c + half }, true, 0.5 * s * eps)
        } else {
            (Bounds3 { min: cmin, max: cmin + Vec3::splat(s) }, false, 0.0)
        }
    }

    /// The photons inside the gathering box: the own range, whole ranges of neighbours
    /// inside the box, single photons of neighbours cut by it (half-open box test).
    fn gather(&self, leaf: &LeafBuild, ebox: &Bounds3, enlarged: bool, segs: &mut Vec<(u32, u32)>, singles: &mut Vec<u32>) {
        segs.clear();
        singles.clear();
        segs.push((leaf.lo, leaf.hi));
        if !enlarged {
            return;
        }
        let (emin, emax) = (ebox.min, ebox.max);
        self.view.visit(emin, emax, |node, depth, ijk, _| {
            let n = self.view.nodes[node as usize];
            if node == leaf.node || n.photons == 0 {
                return;
            }
            let lo = self.start[node as usize];
            let hi = lo + n.photons;
            let cmin = self.view.cell_min(depth, ijk);
            let cmax = cmin + Vec3::splat(self.view.cell_size[depth as usize]);
            if cmin.cmpge(emin).all() && cmax.cmple(emax).all() {
                segs.push((lo, hi));
            } else {
                // test only the axes along which the neighbour sticks out of the box (one for
                // a face neighbour, the common case): a loop per axis set
                let base = singles.len();
                singles.resize(base + n.photons as usize, 0);
                let pos = &self.pos[lo as usize..hi as usize];
                let out = &mut singles[base..];
                let cut = (cmin.cmplt(emin) | cmax.cmpgt(emax)).bitmask();
                let (a, b) = (emin, emax);
                let k = match cut {
                    0b001 => compact(lo, pos, out, |p| (p.x >= a.x) & (p.x < b.x)),
                    0b010 => compact(lo, pos, out, |p| (p.y >= a.y) & (p.y < b.y)),
                    0b100 => compact(lo, pos, out, |p| (p.z >= a.z) & (p.z < b.z)),
                    0b011 => compact(lo, pos, out, |p| (p.x >= a.x) & (p.x < b.x) & (p.y >= a.y) & (p.y < b.y)),
                    0b101 => compact(lo, pos, out, |p| (p.x >= a.x) & (p.x < b.x) & (p.z >= a.z) & (p.z < b.z)),
                    0b110 => compact(lo, pos, out, |p| (p.y >= a.y) & (p.y < b.y) & (p.z >= a.z) & (p.z < b.z)),
                    _ => compact(lo, pos, out, |p| p.cmpge(a).all() & p.cmplt(b).all()),
                };
                singles.truncate(base + k);
            }
        });
    }

    /// Mean position and mean normal of the photons of the leaf's own cell (the incident
    /// directions stand for the normal when the records carry none), summed in f64, and
    /// [`super::ANCHOR_SAMPLES`] of its photons with their incident directions; and the sums
    /// of the positions and normals.
    fn anchor(&self, leaf: &LeafBuild) -> (super::LeafAnchors, DVec3, DVec3) {
        let normal = |i: u32| {
            let r = &self.recs[i as usize];
            let ng = r.ng();
            if ng == Vec3::ZERO {
                r.w().normalize_or_zero()
            } else {
                ng
            }
        };
        let (mut p, mut n) = (DVec3::ZERO, DVec3::ZERO);
        for i in leaf.lo..leaf.hi {
            p += self.pos[i as usize].as_dvec3();
            n += normal(i).as_dvec3();
        }
        let count = leaf.hi - leaf.lo;
        let k = count.max(1) as f64;
        let s = self.view.cell_size[leaf.depth as usize];
        let cmin = self.view.cell_min(leaf.depth, leaf.ijk);
        let mean = super::Anchor::encode((p / k).as_vec3(), (n / k).as_vec3(), cmin, s);
        // the sampled photons keep their incident direction (the leak test looks from the
        // query point where their light came from, docs/guide/octree.md "Leak control")
        let samples = std::array::from_fn(|j| {
            let i = leaf.lo + ((count as u64 * (2 * j as u64 + 1)) / (2 * super::ANCHOR_SAMPLES as u64)) as u32;
            super::Anchor::encode(self.pos[i as usize], self.recs[i as usize].w().normalize_or_zero(), cmin, s)
        });
        (super::LeafAnchors { mean, samples }, p, n)
    }

    /// The leaf's estimate; with `capture`, also its [`LeafState`].
    pub fn estimate(&self, leaf: &LeafBuild, value: usize, sc: &mut Scratch, capture: bool) -> LeafEstimate {
        let (ebox, enlarged, margin) = self.gather_box_margin(leaf);
        // Lower bound on the area the photons stand for. The leaf's photons lie in its own
        // cell, so some surface passes through a point q of the cell, and the ball of radius
        // δ (the margin) around q lies in the gathering box. A plane through q has area πδ²
        // in that ball, and so has any sphere of radius ≥ δ/2 (Archimedes: the part of a
        // sphere within chord distance δ of a point on it has area πδ², whatever the
        // radius). Surfaces that are not smaller than the margin therefore have at least
        // πδ² in the box, and no photon is divided by less than `min_cos πδ²`: a leaf
        // reports at most `Σ Φ_p / (min_cos π δ²)`, whatever the geometry found (too little
        // of it, a shape the estimator does not know, a sliver in a corner).
        let a_min = std::f32::consts::PI * margin * margin;
        self.gather(leaf, &ebox, enlarged, &mut sc.segs, &mut sc.singles);
        let photons = sc.segs.iter().map(|&(lo, hi)| (lo..hi).len()).sum::<usize>() + sc.singles.len();
        let edge = ebox.extent().x;
        let inv_da = 1.0 / (edge * edge);
        let min_cos = self.settings.min_cos;
        let mut estimator = self.settings.estimator;
        let mut fallback = false;
        let mut lit_total = 0.0f32;
        let mut groups = Vec::new();
        let recs = self.recs;
        if estimator == Estimator::GeometryArea {
            sc.pos.clear();
            sc.ng.clear();
            let all = sc.segs.iter().flat_map(|&(lo, hi)| lo..hi).chain(sc.singles.iter().copied());
            for i in all {
                sc.pos.push(self.pos[i as usize]);
                sc.ng.push(recs[i as usize].ng());
            }
            let ids = self.tri_lists.get(value).map(Vec::as_slice).unwrap_or(&[]);
            lit_areas(self.triangles, ids, self.spheres, &ebox, &sc.pos, &sc.ng, &mut sc.areas, capture.then_some(&mut groups));
            lit_total = sc.areas.iter().map(|a| a.area).sum();
            if !(lit_total > 0.0) {
                estimator = Estimator::Cosine;
                fallback = true;
            }
        }
        let by_normal = self.settings.split == Split::Normal;
        let mut sides = std::mem::take(&mut sc.sides);
        if by_normal && estimator == Estimator::GeometryArea {
            sides.fill(&sc.areas);
        }
        let areas = std::mem::take(&mut sc.areas);
        let weights = LeafWeights { estimator, by_normal, inv_da, min_cos, a_min, lit_total, areas, groups, sides };
        let mut acc = Accumulator::new();
        if by_normal && estimator == Estimator::GeometryArea {
            // per-matrix areas: no single weight
            let sides = &weights.sides;
            let mut add = |i: u32| {
                let r = &recs[i as usize];
                add_by_surface(&mut acc.zero, r.w(), r.c(), r.ng(), sides, min_cos, a_min, 1.0);
            };
            for &(lo, hi) in &sc.segs {
                (lo..hi).for_each(&mut add);
            }
            sc.singles.iter().for_each(|&i| add(i));
        } else {
            let mut add = |i: u32| weights.add(&mut acc, &recs[i as usize]);
            for &(lo, hi) in &sc.segs {
                (lo..hi).for_each(&mut add);
            }
            sc.singles.iter().for_each(|&i| add(i));
        }
        let areas = &weights.areas;
        let mut normals: [Vec3; 6] = std::array::from_fn(|k| {
            let mut v = Vec3::ZERO;
            v[k / 2] = if k % 2 == 0 { 1.0 } else { -1.0 };
            v
        });
        let facing = if by_normal && estimator == Estimator::GeometryArea {
            let mut bits = 0u8;
            let mut sums = [Vec3::ZERO; 6];
            for e in areas.iter() {
                for a in 0..3 {
                    if e.n[a] != 0.0 {
                        let k = 2 * a + (e.n[a] < 0.0) as usize;
                        bits |= 1 << k;
                        sums[k] += e.n * (e.n[a] * e.n[a] * e.area);
                    }
                }
            }
            for (n, s) in normals.iter_mut().zip(sums) {
                if let Some(u) = s.try_normalize() {
                    *n = u;
                }
            }
            bits
        } else {
            ALL_FACING
        };
        let totals = acc.totals();
        let (anchor, pos, nrm) = self.anchor(leaf);
        let state = if capture {
            let own = leaf.hi - leaf.lo;
            Some(Box::new(LeafState { totals, pos, nrm, own, gathered: photons as u32, weights, facing, normals, fallback }))
        } else {
            // the scratch keeps the allocations
            sc.areas = weights.areas;
            sc.sides = weights.sides;
            None
        };
        LeafEstimate { m: matrices(&totals), gathered: photons as u32, fallback, facing, normals, anchor, state }
    }
}

/// Branchless compaction: the indices `lo + j` of the positions `pos[j]` that pass `inside`
/// go to the front of `out` (as long as `pos`); returns their count.
#[inline(always)]
fn compact(lo: u32, pos: &[Vec3], out: &mut [u32], inside: impl Fn(Vec3) -> bool) -> usize {
    let mut k = 0usize;
    for (i, &p) in (lo..).zip(pos) {
        out[k] = i;
        k += inside(p) as usize;
    }
    k
}

#[cfg(test)]
mod tests;
