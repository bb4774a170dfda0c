//! Geometry inside a cell for the `GeometryArea` estimator: triangle–box clipping and the
//! *lit projected area* `A⊥(w)` of the surfaces in a cell.
//!
//! Why a projected area. Photons landing on a surface piece of area `A_t`, normal `n_t`, from
//! a direction `w` on its lit side arrive with flux density `L(w) (n_t·w) dω` per unit
//! area; summed over the lit pieces of a cell, the flux arriving from `dω` is
//! `L(w) A⊥(w) dω` with `A⊥(w) = Σ_t A_t max(0, σ_t n_t·w)` (`σ_t` = lit side; a piece lit
//! from both sides counts `A_t |n_t·w|`). Hence `Σ_p Φ_p w_p / A⊥(w_p)` estimates
//! `∫ L(w) w dω` exactly when `L` is constant over the cell, whatever the number and the
//! orientation of the surfaces. For a single plane lit from one side `A⊥(w) = A cos θ`: the
//! `Σ Φ_p w_p / (A cos θ_p)` of the module docs. Counting each piece once per *lit side*
//! is what makes the estimate right for:
//! - a two-sided sheet lit from both sides: each direction meets exactly one lit side, so
//!   the sheet counts once, not twice;
//! - a corner (floor + wall): a direction seen by the floor only is divided by the floor's
//!   projected area only (the naive "total area" average would darken it, to 3/4 of the
//!   truth for a diffuse field in a right-angle corner);
//! - a closed object (the paper's sphere, fig. 3): only the outer side is lit, so a
//!   direction is divided by the object's silhouette `πr²`, not by `2πr²` (two-sided count)
//!   nor by the cell face `ΔA` (the paper's dark artefacts).
//!
//! Which side is lit. Triangles are grouped by oriented plane (coplanar, same winding). A
//! side of a group is *detected* lit when a photon of the enlarged cell lies on one of its
//! triangles (plane distance and barycentric tolerances) with its `ng` on that side. A
//! group's lit sides are the detected ones; when none is detected the front side (the
//! winding normal, Mitsuba's convention) is assumed, so that sparsely hit or unlit pieces
//! of closed meshes still count for the directions facing them. Known limits:
//! occluded parts of a lit surface (under an object standing on it) still count as lit;
//! a back-lit, finely tessellated two-sided surface with fewer photons than triangles falls
//! back to its front side.

use crate::math::Bounds3;
use glam::{DVec3, Vec3};
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::ops::RangeInclusive;

/// Hasher of [`NormalGrid`]'s small integer keys: the multiply–rotate hash of rustc's
/// `FxHasher`, several times cheaper than SipHash. The grid's answers do not depend on it.
#[derive(Clone, Copy, Default)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for c in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..c.len()].copy_from_slice(c);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    #[inline]
    fn write_i32(&mut self, v: i32) {
        self.write_u64(v as u32 as u64);
    }
    #[inline]
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
}

/// Unit vectors indexed by a coarse grid over their components and an integer *slot* (a
/// plane offset's bucket for the plane groups, 0 otherwise), so that the first of them
/// (lowest index) within a small distance of a query is found without scanning them all: a
/// leaf of a curved, finely tessellated mesh holds tens of thousands of distinct normals, and
/// a room's furniture thousands of parallel planes; linear scans made [`lit_areas`] quadratic
/// in them. The answer is exactly a linear scan's (`Iterator::find` in index order) for
/// predicates that hold only within the given component radius and slot range.
struct NormalGrid {
    cells: HashMap<[i32; 4], Vec<u32>, BuildHasherDefault<KeyHasher>>,
}

impl NormalGrid {
    /// Grid step in normal components.
    const STEP: f32 = 1e-2;

    fn new() -> NormalGrid {
        NormalGrid { cells: HashMap::default() }
    }

    /// The cell of component `c` (monotone in `c`; `as` saturates).
    #[inline]
    fn cell(c: f32) -> i32 {
        (c / Self::STEP).floor() as i32
    }

    fn insert(&mut self, n: Vec3, slot: i32, index: u32) {
        self.cells.entry([Self::cell(n.x), Self::cell(n.y), Self::cell(n.z), slot]).or_default().push(index);
    }

    /// The lowest index whose entry satisfies `matches` among those whose normal lies within
    /// `radius` of `n` in every component and whose slot is in `slots` (`matches` must hold
    /// only there).
    fn first(&self, n: Vec3, radius: f32, slots: RangeInclusive<i32>, mut matches: impl FnMut(u32) -> bool) -> Option<u32> {
        let (lo, hi) = (n - Vec3::splat(radius), n + Vec3::splat(radius));
        let mut best: Option<u32> = None;
        for x in Self::cell(lo.x)..=Self::cell(hi.x) {
            for y in Self::cell(lo.y)..=Self::cell(hi.y) {
                for z in Self::cell(lo.z)..=Self::cell(hi.z) {
                    for s in slots.clone() {
                        let Some(list) = self.cells.get(&[x, y, z, s]) else { continue };
                        // lists grow in index order: the first match is the list's lowest
                        if let Some(&i) = list.iter().take_while(|&&i| best.is_none_or(|b| i < b)).find(|&&i| matches(i)) {
                            best = Some(i);
                        }
                    }
                }
            }
        }
        best
    }
}

/// Component radius holding every unit vector `m` with `m·n > 1 − 1e-5` (plane groups):
/// `|m − n| < (2e-5)^½ ≈ 4.47e-3`, with a margin for rounding.
const GROUP_RADIUS: f32 = 5e-3;
/// The same for `m·n > 1 − 1e-6` (merged output normals): `(2e-6)^½ ≈ 1.41e-3`.
const MERGE_RADIUS: f32 = 1.6e-3;

/// A triangle clipped to a cell: area inside the cell and which sides are lit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct OrientedArea {
    /// Unit normal of the lit side (a two-sided piece gives two entries).
    pub n: Vec3,
    /// Area (scene units²) inside the cell.
    pub area: f32,
}

/// Area of the part of triangle `t` inside the box `b` (Sutherland–Hodgman, f64).
pub(crate) fn clipped_area(t: &[Vec3; 3], b: &Bounds3) -> f64 {
    // a triangle clipped by 6 planes has at most 9 vertices
    let mut poly = [DVec3::ZERO; 12];
    let mut tmp = [DVec3::ZERO; 12];
    let mut n = 3usize;
    for k in 0..3 {
        poly[k] = t[k].as_dvec3();
    }
    let (bmin, bmax) = (b.min.as_dvec3(), b.max.as_dvec3());
    for axis in 0..3 {
        for side in 0..2 {
            // keep points with s * (p[axis] - bound) >= 0
            let (bound, s) = if side == 0 { (bmin[axis], 1.0) } else { (bmax[axis], -1.0) };
            let mut m = 0usize;
            for i in 0..n {
                let a = poly[i];
                let c = poly[(i + 1) % n];
                let da = s * (a[axis] - bound);
                let dc = s * (c[axis] - bound);
                if da >= 0.0 {
                    tmp[m] = a;
                    m += 1;
                }
                if (da >= 0.0) != (dc >= 0.0) {
                    let f = da / (da - dc);
                    tmp[m] = a + (c - a) * f;
                    m += 1;
                }
            }
            n = m;
            if n < 3 {
                return 0.0;
            }
            poly[..n].copy_from_slice(&tmp[..n]);
        }
    }
    let mut s = DVec3::ZERO;
    for i in 1..n - 1 {
        s += (poly[i] - poly[0]).cross(poly[i + 1] - poly[0]);
    }
    0.5 * s.length()
}

/// Precomputed data of a triangle for the "does this photon lie on it" test.
#[derive(Clone, Debug)]
struct OnTriangle {
    v0: Vec3,
    n: Vec3,
    // dual basis: for q = p - v0 in the plane, u = q·du, v = q·dv
    du: Vec3,
    dv: Vec3,
}

impl OnTriangle {
    fn new(t: &[Vec3; 3]) -> Option<Self> {
        let e1 = t[1] - t[0];
        let e2 = t[2] - t[0];
        let c = e1.cross(e2);
        let l2 = c.length_squared();
        if !(l2 > 0.0) || !l2.is_finite() {
            return None;
        }
        let n = c / l2.sqrt();
        // u = ((q × e2)·c) / |c|², v = ((e1 × q)·c) / |c|²  ->  u = q·(e2 × c)/|c|², v = q·(c × e1)/|c|²
        Some(OnTriangle { v0: t[0], n, du: e2.cross(c) / l2, dv: c.cross(e1) / l2 })
    }

    #[inline]
    fn contains(&self, p: Vec3, plane_tol: f32) -> bool {
        const BARY_TOL: f32 = 1e-4;
        let q = p - self.v0;
        if q.dot(self.n).abs() > plane_tol {
            return false;
        }
        let u = q.dot(self.du);
        let v = q.dot(self.dv);
        u >= -BARY_TOL && v >= -BARY_TOL && u + v <= 1.0 + BARY_TOL
    }
}

/// Triangles of a cell sharing one oriented plane (same winding normal, same offset).
#[derive(Clone, Debug)]
struct PlaneGroup {
    n: Vec3,
    d: f32,
    area: f32,
    tris: Vec<OnTriangle>,
    /// The bounds of its triangles' vertices.
    lo: Vec3,
    hi: Vec3,
}

impl PlaneGroup {
    /// The side of the group the photon at `p` of normal `g` lights, when it lies on one of its
    /// triangles with `g·n ≥ 0.9`: `Some(true)`, its front; with `−g·n ≥ 0.9`: `Some(false)`, its
    /// back; one test of the plane and triangles for both.
    #[inline]
    fn side(&self, p: Vec3, g: Vec3, plane_tol: f32) -> Option<bool> {
        let s = g.dot(self.n);
        let front = s >= 0.9;
        if !(front || -s >= 0.9) {
            return None;
        }
        ((p.dot(self.n) - self.d).abs() <= plane_tol && self.tris.iter().any(|t| t.contains(p, plane_tol))).then_some(front)
    }

    /// Whether some photon lies on a triangle of the group with `sign · ng·n ≥ 0.9`.
    fn hit_from(&self, sign: f32, pos: &[Vec3], ng: &[Vec3], plane_tol: f32) -> bool {
        pos.iter().zip(ng).any(|(&p, &g)| self.side(p, g, plane_tol) == Some(sign > 0.0))
    }
}

/// A group of coplanar triangles of a leaf with the photons that light each of its sides
/// (`lit_areas`: lit on its back when a photon arrived from behind, on its front unless lit on
/// its back alone), for an incremental update (`incremental.rs`): the counts follow the photons
/// that come and go, and the lit sides change only when a count reaches or leaves zero.
#[derive(Clone, Debug)]
pub(crate) struct GroupHits {
    group: PlaneGroup,
    plane_tol: f32,
    front: u32,
    back: u32,
    /// The sides lit when the leaf was estimated: (front, back).
    lit: (bool, bool),
}

impl GroupHits {
    fn sides(front: u32, back: u32) -> (bool, bool) {
        (back == 0 || front > 0, back > 0)
    }

    /// Count the photon at `p` of normal `ng` in (`sign` +1) or out (−1).
    pub fn count(&mut self, p: Vec3, ng: Vec3, sign: i32) {
        let step = |c: u32| (c as i64 + sign as i64).max(0) as u32;
        match self.group.side(p, ng, self.plane_tol) {
            Some(true) => self.front = step(self.front),
            Some(false) => self.back = step(self.back),
            None => {}
        }
    }

    /// Whether the sides the counts light differ from those lit when the leaf was estimated.
    pub fn changed(&self) -> bool {
        Self::sides(self.front, self.back) != self.lit
    }
}

/// The lit oriented areas of `triangles` inside `cell`, given the photons of the cell
/// (positions and geometric normals). Sides are detected per group of coplanar triangles
/// with the same winding (a photon anywhere on the group's triangles lights the side for
/// the whole group: robust to photons sparser than triangles on planar surfaces, while an
/// object's face resting on a floor, coplanar but of opposite winding and without photons
/// of its own, stays a separate group). Entries with equal normals are merged.
/// With `hits`, each group of triangles comes back with its photons counted per side
/// ([`GroupHits`]).
#[allow(clippy::too_many_arguments)] // the cell's surfaces, its photons and the two outputs
pub(crate) fn lit_areas(
    triangles: &[[Vec3; 3]],
    tri_ids: &[u32],
    spheres: &[AnalyticSphere],
    cell: &Bounds3,
    photon_pos: &[Vec3],
    photon_ng: &[Vec3],
    out: &mut Vec<OrientedArea>,
    mut hits: Option<&mut Vec<GroupHits>>,
) {
    out.clear();
    if let Some(h) = hits.as_deref_mut() {
        h.clear();
    }
    let edge = cell.extent().max_element();
    let plane_tol = 1e-4 * edge + 1e-5 * (1.0 + cell.min.abs().max(cell.max.abs()).max_element());
    let mut groups: Vec<PlaneGroup> = Vec::new();
    let mut group_grid = NormalGrid::new();
    // plane offsets in buckets of 4 tolerances: a group within the tolerance of `d` lies in
    // the buckets of [d − 2 tol, d + 2 tol] (`as` saturates; NaN offsets match nothing)
    let slot_step = 4.0 * plane_tol;
    let slot = |d: f32| (d / slot_step).floor() as i32;
    for &ti in tri_ids {
        let t = &triangles[ti as usize];
        let area = clipped_area(t, cell);
        if !(area > 0.0) {
            continue;
        }
        let Some(on) = OnTriangle::new(t) else { continue };
        let d = on.n.dot(on.v0);
        let same = |gi: u32| {
            let g = &groups[gi as usize];
            g.n.dot(on.n) > 1.0 - 1e-5 && (g.d - d).abs() <= plane_tol
        };
        match group_grid.first(on.n, GROUP_RADIUS, slot(d - 2.0 * plane_tol)..=slot(d + 2.0 * plane_tol), same) {
            Some(gi) => {
                let g = &mut groups[gi as usize];
                g.area += area as f32;
                g.tris.push(on);
                g.lo = g.lo.min(t[0].min(t[1]).min(t[2]));
                g.hi = g.hi.max(t[0].max(t[1]).max(t[2]));
            }
            None => {
                group_grid.insert(on.n, slot(d), groups.len() as u32);
                let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                groups.push(PlaneGroup { n: on.n, d, area: area as f32, tris: vec![on], lo, hi });
            }
        }
    }
    let mut out_grid = NormalGrid::new();
    let mut push = |n: Vec3, area: f32| {
        if let Some(i) = out_grid.first(n, MERGE_RADIUS, 0..=0, |i| out[i as usize].n.dot(n) > 1.0 - 1e-6) {
            out[i as usize].area += area;
        } else {
            out_grid.insert(n, 0, out.len() as u32);
            out.push(OrientedArea { n, area });
        }
    };
    // with `hits`, every photon counted (the sides are those `hit_from` finds)
    let counts = if hits.is_some() { side_counts(&groups, cell, photon_pos, photon_ng, plane_tol) } else { Vec::new() };
    for (gi, g) in groups.into_iter().enumerate() {
        let counts = counts.get(gi).copied();
        let (front, back) = match counts {
            Some((nf, nb)) => GroupHits::sides(nf, nb),
            None => {
                let back = g.hit_from(-1.0, photon_pos, photon_ng, plane_tol);
                (!back || g.hit_from(1.0, photon_pos, photon_ng, plane_tol), back)
            }
        };
        if front {
            push(g.n, g.area);
        }
        if back {
            push(-g.n, g.area);
        }
        if let (Some(h), Some((nf, nb))) = (hits.as_deref_mut(), counts) {
            h.push(GroupHits { group: g, plane_tol, front: nf, back: nb, lit: (front, back) });
        }
    }
    for s in spheres {
        sphere_lit_areas(s, cell, photon_pos, photon_ng, plane_tol, out);
    }
}

/// Per group, its photons counted per side (front, back: [`PlaneGroup::side`]). With many
/// groups and photons, each photon is tested only against the groups whose bounds, widened by
/// the containment test's margins, meet its cell of an 8³ grid over `cell` (a point outside
/// it counting in the nearest border cell): the same counts.
fn side_counts(groups: &[PlaneGroup], cell: &Bounds3, pos: &[Vec3], ng: &[Vec3], plane_tol: f32) -> Vec<(u32, u32)> {
    let mut counts = vec![(0u32, 0u32); groups.len()];
    let mut count = |gi: usize, p: Vec3, g: Vec3| match groups[gi].side(p, g, plane_tol) {
        Some(true) => counts[gi].0 += 1,
        Some(false) => counts[gi].1 += 1,
        None => {}
    };
    if groups.len() * pos.len() <= 4096 || !(cell.min.is_finite() && cell.max.is_finite()) {
        for gi in 0..groups.len() {
            pos.iter().zip(ng).for_each(|(&p, &g)| count(gi, p, g));
        }
        return counts;
    }
    const R: usize = 8;
    let scale = R as f32 / cell.extent().max(Vec3::splat(f32::MIN_POSITIVE));
    let at = |p: Vec3| ((p - cell.min) * scale).clamp(Vec3::ZERO, Vec3::splat((R - 1) as f32)).as_uvec3();
    let index = |c: glam::UVec3| c.x as usize + R * (c.y as usize + R * c.z as usize);
    // a photon a group's triangle contains lies within its bounds widened by 3 × 1e-4 of
    // their extent (the barycentric tolerance of `OnTriangle::contains`) and the plane's
    let ranges: Vec<(glam::UVec3, glam::UVec3)> = groups
        .iter()
        .map(|g| {
            let m = (g.hi - g.lo) * 1e-3 + Vec3::splat(2.0 * plane_tol);
            (at(g.lo - m), at(g.hi + m))
        })
        .collect();
    let mut start = vec![0u32; R * R * R + 1];
    let each = |(a, b): &(glam::UVec3, glam::UVec3), f: &mut dyn FnMut(usize)| {
        for z in a.z..=b.z {
            for y in a.y..=b.y {
                for x in a.x..=b.x {
                    f(index(glam::UVec3::new(x, y, z)));
                }
            }
        }
    };
    for r in &ranges {
        each(r, &mut |c| start[c + 1] += 1);
    }
    for c in 0..R * R * R {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut lists = vec![0u32; start[R * R * R] as usize];
    for (gi, r) in ranges.iter().enumerate() {
        each(r, &mut |c| {
            lists[fill[c] as usize] = gi as u32;
            fill[c] += 1;
        });
    }
    for (&p, &g) in pos.iter().zip(ng) {
        if !p.is_finite() {
            continue;
        }
        let c = index(at(p));
        for &gi in &lists[start[c] as usize..start[c + 1] as usize] {
            count(gi as usize, p, g);
        }
    }
    counts
}

/// An analytic sphere as the geometry-area estimator sees it (world space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalyticSphere {
    pub center: Vec3,
    /// Radius (scene units).
    pub radius: f32,
    /// The front side (Mitsuba's, the one assumed lit when no photon says otherwise) faces
    /// the centre (`flip_normals`).
    pub inward: bool,
}

/// Angular step (radians) of the patches a sphere is cut into when its whole extent lies in
/// the box: 15°, 12 x 24 patches for a whole sphere.
const SPHERE_STEP: f64 = std::f64::consts::PI / 12.0;
/// Least number of patches along θ and along φ, whatever the angular extent in the box.
const SPHERE_MIN_PATCHES: usize = 4;

/// The lit oriented areas of the part of sphere `s` inside `cell`, appended to `out`.
///
/// The part of the sphere in the box is bounded in θ (from +z, exactly by the box's z
/// range) and φ (by the angles of the box's xy rectangle seen from the centre). That window
/// is cut into patches; patch `i` gets its **exact** spherical area
/// `r² (cos θ_a − cos θ_b) Δφ` times the fraction of its chord quad (two triangles, clipped by
/// [`clipped_area`]) inside the box, and the unit normal at its centre. The fraction is
/// exact for patches wholly in or out of the box, and for the patches the box cuts it is
/// wrong only by the chord's sagitta against the patch size (`1 − cos(Δ/2)` of a patch
/// at most 1/4 of the window, ~0.1–1%, and only on the cut patches). A⊥(w) is then the
/// midpoint rule over patches of at most 15° (error under 1% of `πr²` for the whole sphere).
/// The side detection is that of a plane group: a photon within the plane tolerance of the
/// sphere (hit points are re-projected onto it) with `ng` outward lights the outside, inward
/// the inside; without any, the front side is assumed.
fn sphere_lit_areas(s: &AnalyticSphere, cell: &Bounds3, pos: &[Vec3], ng: &[Vec3], plane_tol: f32, out: &mut Vec<OrientedArea>) {
    let (c, r) = (s.center.as_dvec3(), s.radius as f64);
    if !(r > 0.0) || !c.is_finite() || !r.is_finite() {
        return;
    }
    let (bmin, bmax) = (cell.min.as_dvec3(), cell.max.as_dvec3());
    // the surface meets the box iff the nearest point is within r and the farthest beyond
    let near = c.clamp(bmin, bmax) - c;
    let far = DVec3::new(
        (bmin.x - c.x).abs().max((bmax.x - c.x).abs()),
        (bmin.y - c.y).abs().max((bmax.y - c.y).abs()),
        (bmin.z - c.z).abs().max((bmax.z - c.z).abs()),
    );
    if near.length_squared() > r * r || far.length_squared() < r * r {
        return;
    }
    let tol = plane_tol.max(1e-5 * (s.radius + s.center.abs().max_element())) as f64;
    let (mut lit_out, mut lit_in) = (false, false);
    for (&p, &g) in pos.iter().zip(ng) {
        let d = p.as_dvec3() - c;
        let l = d.length();
        if (l - r).abs() <= tol && l > 0.0 {
            let cosn = g.as_dvec3().dot(d) / l;
            lit_out |= cosn >= 0.9;
            lit_in |= cosn <= -0.9;
        }
    }
    if !lit_out && !lit_in {
        if s.inward {
            lit_in = true;
        } else {
            lit_out = true;
        }
    }
    use std::f64::consts::PI;
    // θ window from the z range
    let th0 = ((bmax.z - c.z) / r).clamp(-1.0, 1.0).acos();
    let th1 = ((bmin.z - c.z) / r).clamp(-1.0, 1.0).acos();
    // φ window from the xy rectangle seen from the centre
    let (x0, x1, y0, y1) = (bmin.x - c.x, bmax.x - c.x, bmin.y - c.y, bmax.y - c.y);
    let (ph0, ph1) = if x0 <= 0.0 && x1 >= 0.0 && y0 <= 0.0 && y1 >= 0.0 {
        (0.0, 2.0 * PI)
    } else {
        let mid = (0.5 * (y0 + y1)).atan2(0.5 * (x0 + x1));
        let (mut lo, mut hi) = (0.0f64, 0.0f64);
        for (x, y) in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
            let mut d = y.atan2(x) - mid;
            if d > PI {
                d -= 2.0 * PI;
            } else if d < -PI {
                d += 2.0 * PI;
            }
            lo = lo.min(d);
            hi = hi.max(d);
        }
        (mid + lo, mid + hi)
    };
    if !(th1 > th0) || !(ph1 > ph0) {
        return;
    }
    let nt = (((th1 - th0) / SPHERE_STEP).ceil() as usize).max(SPHERE_MIN_PATCHES);
    let np = (((ph1 - ph0) / SPHERE_STEP).ceil() as usize).max(SPHERE_MIN_PATCHES);
    let (dt, dp) = ((th1 - th0) / nt as f64, (ph1 - ph0) / np as f64);
    let dir = |t: f64, p: f64| DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
    let tri_area = |a: DVec3, b: DVec3, e: DVec3| 0.5 * (b - a).cross(e - a).length();
    for i in 0..nt {
        let (ta, tb) = (th0 + dt * i as f64, th0 + dt * (i + 1) as f64);
        let ring = r * r * (ta.cos() - tb.cos()) * dp;
        for j in 0..np {
            let (pa, pb) = (ph0 + dp * j as f64, ph0 + dp * (j + 1) as f64);
            let q = [c + r * dir(ta, pa), c + r * dir(tb, pa), c + r * dir(tb, pb), c + r * dir(ta, pb)];
            let t1 = [q[0].as_vec3(), q[1].as_vec3(), q[2].as_vec3()];
            let t2 = [q[0].as_vec3(), q[2].as_vec3(), q[3].as_vec3()];
            let chord = tri_area(q[0], q[1], q[2]) + tri_area(q[0], q[2], q[3]);
            if !(chord > 0.0) {
                continue;
            }
            let inside = (clipped_area(&t1, cell) + clipped_area(&t2, cell)) / chord;
            let area = (ring * inside.min(1.0)) as f32;
            if !(area > 0.0) {
                continue;
            }
            let n = dir(0.5 * (ta + tb), 0.5 * (pa + pb)).as_vec3();
            if lit_out {
                out.push(OrientedArea { n, area });
            }
            if lit_in {
                out.push(OrientedArea { n: -n, area });
            }
        }
    }
}

/// `A⊥(w) = Σ_e A_e max(0, n_e·w)` over the lit oriented areas.
#[inline]
pub(crate) fn projected_lit_area(areas: &[OrientedArea], w: Vec3) -> f32 {
    areas.iter().map(|e| e.area * e.n.dot(w).max(0.0)).sum()
}

#[cfg(test)]
mod tests;
