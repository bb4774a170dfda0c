//! A static kd-tree for k-nearest-neighbour queries (photon maps, irradiance photons), and the
//! photon density estimate shared by the paper's baselines (the paper's §9: Ward's cache with
//! photon-computed samples, Christensen's irradiance photons, Jensen's photon map).
//!
//! # Tree
//! An implicit, balanced kd-tree over a reordered item array (Bentley 1975; the layout of
//! Jensen's photon map): the range `[lo, hi)` is a leaf when it holds at most [`LEAF_SIZE`]
//! items, otherwise its median item `mid = lo + (hi - lo) / 2` splits it along the axis of
//! largest extent of the range's bounding box; `[lo, mid)` lies at or below the split
//! coordinate, `(mid, hi)` at or above. No pointers are stored: one byte of split axis per item.
//! Built once (parallel over disjoint sub-ranges with `select_nth_unstable`, which is
//! deterministic, so the tree is identical for any thread count), then read-only and `Sync`.
//!
//! Query [`KdTree::knn`]: the `k` nearest items within `r_max` that pass a filter, kept in a
//! max-heap so the current `k`-th distance prunes the descent. An item is accepted when
//! `d² ≤ r_max²` while fewer than `k` are held, and when `d²` is smaller than the largest held
//! distance afterwards.
//!
//! # Photon irradiance estimate (Jensen 2001, eq. 7.6 with a constant BRDF factored out)
//! At `x` with unit normal `n`: `E ≈ Σ_p Φ_p / (π r²)` over the `n_max` nearest photons
//! within `r_max` whose incident direction is on the side of `n` (`w_p · n > 0`; photons
//! arriving from behind belong to the other side of a sheet). `r` is the distance to the
//! `n_max`-th photon when `n_max` were found, and `r_max` otherwise: then every photon of the
//! disk of radius `r_max` was gathered and `π r_max²` is the area they were collected from
//! (using the farthest found photon instead would overestimate sparse regions). For a
//! Poisson field of density `λ` the `k`-nearest estimate has mean `λ k / (k − 1)` (0.5% high
//! for `k` = 205), the usual photon-map convention.
//!
//! # Settings in scene units
//! The paper's `r_max = 31` is in the units of its scene (a Cornell box of about 559 mm).
//! [`SceneLength::Relative`] expresses a length as a fraction of the scene's largest bounding
//! box extent so the same defaults fit a scene in metres; the defaults are the paper's values
//! divided by 559 (the built-in `cornell-box` is 559.2 mm deep).

use crate::math::{Bounds3, Color};
use crate::photon::Photon;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;

/// Largest range scanned linearly instead of split.
pub const LEAF_SIZE: usize = 8;
/// Ranges above this size are built in parallel.
const PARALLEL_BUILD: usize = 1 << 15;
/// The paper's scene size (mm) behind its table-2 lengths.
pub const PAPER_SCENE_SIZE: f32 = 559.0;

/// Errors of the baselines' settings.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SettingsError {
    #[error("invalid setting `{field}`: {problem}")]
    Invalid { field: String, problem: String },
}

impl SettingsError {
    pub fn new(field: &str, problem: impl Into<String>) -> Self {
        SettingsError::Invalid { field: field.to_string(), problem: problem.into() }
    }
}

/// A length either in scene units or relative to the scene's largest bounding-box extent.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum SceneLength {
    /// Scene units.
    Absolute(f32),
    /// Fraction of the largest extent of the scene's bounding box.
    Relative(f32),
}

impl SceneLength {
    /// The paper's length `v` (in its ~559 mm scene) as a relative length.
    pub fn paper(v: f32) -> Self {
        SceneLength::Relative(v / PAPER_SCENE_SIZE)
    }

    /// The length in scene units for a scene of size `scene_size` (see [`scene_size`]).
    #[inline]
    pub fn resolve(self, scene_size: f32) -> f32 {
        match self {
            SceneLength::Absolute(v) => v,
            SceneLength::Relative(v) => v * scene_size,
        }
    }

    /// Check that the value is finite and positive (or zero when `allow_zero`).
    pub fn check(self, field: &str, allow_zero: bool) -> Result<(), SettingsError> {
        let v = match self {
            SceneLength::Absolute(v) | SceneLength::Relative(v) => v,
        };
        if !v.is_finite() || v < 0.0 || (v == 0.0 && !allow_zero) {
            let want = if allow_zero { "finite and non-negative" } else { "finite and positive" };
            return Err(SettingsError::new(field, format!("{self:?} must be {want}")));
        }
        Ok(())
    }
}

/// Size of a scene for [`SceneLength::Relative`]: the largest extent of its bounding box
/// (1 for an empty or non-finite box).
pub fn scene_size(bounds: &Bounds3) -> f32 {
    let e = bounds.extent().max_element();
    if e.is_finite() && e > 0.0 {
        e
    } else {
        1.0
    }
}

/// Parameters of a photon density estimate (the paper's table 2: `n_max`, `r_max`).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct DensitySettings {
    /// Most photons per estimate.
    pub n_max: u32,
    /// Largest search radius.
    pub r_max: SceneLength,
}

impl Default for DensitySettings {
    fn default() -> Self {
        DensitySettings { n_max: 205, r_max: SceneLength::paper(31.0) }
    }
}

impl DensitySettings {
    /// `prefix` names the settings in messages (e.g. `density`, `caustic`).
    pub fn validate(&self, prefix: &str) -> Result<(), SettingsError> {
        if self.n_max == 0 {
            return Err(SettingsError::new(&format!("{prefix}.n_max"), "at least one photon per estimate is needed (got 0)"));
        }
        self.r_max.check(&format!("{prefix}.r_max"), false)
    }

    /// `(n_max, r_max in scene units)` for a scene of size `scene_size`.
    pub fn resolve(&self, scene_size: f32) -> Density {
        Density { n_max: self.n_max as usize, r_max: self.r_max.resolve(scene_size) }
    }
}

/// Resolved density-estimate parameters (scene units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Density {
    pub n_max: usize,
    pub r_max: f32,
}

/// Something with a position, storable in a [`KdTree`].
pub trait KdItem {
    fn position(&self) -> Vec3;
}

impl KdItem for Photon {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

/// One neighbour found by a query: squared distance and index into [`KdTree::items`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbor {
    pub d2: f32,
    pub index: u32,
}

/// A static kd-tree (see the module docs).
#[derive(Clone, Debug)]
pub struct KdTree<T> {
    items: Vec<T>,
    /// The items' positions, same order (compact for the traversal: 12 bytes per item).
    points: Vec<Vec3>,
    /// Split axis of the item at the median of each internal range.
    axes: Vec<u8>,
    dropped: usize,
}

impl<T: KdItem + Send> KdTree<T> {
    /// Build over `items`; items with a non-finite position are dropped (see [`Self::dropped`]).
    /// More than `u32::MAX` items are truncated to `u32::MAX` (counted as dropped).
    pub fn build(mut items: Vec<T>) -> Self {
        let before = items.len();
        items.retain(|it| it.position().is_finite());
        items.truncate(u32::MAX as usize);
        let dropped = before - items.len();
        let mut axes = vec![0u8; items.len()];
        build_range(&mut items, &mut axes);
        let points = items.iter().map(|it| it.position()).collect();
        KdTree { items, points, axes, dropped }
    }
}

fn build_range<T: KdItem + Send>(items: &mut [T], axes: &mut [u8]) {
    let n = items.len();
    if n <= LEAF_SIZE {
        return;
    }
    let mut b = Bounds3::EMPTY;
    for it in items.iter() {
        b.extend(it.position());
    }
    let e = b.extent();
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let mid = n / 2;
    items.select_nth_unstable_by(mid, |a, b| a.position()[axis].total_cmp(&b.position()[axis]));
    axes[mid] = axis as u8;
    let (left, rest) = items.split_at_mut(mid);
    let (axes_left, axes_rest) = axes.split_at_mut(mid);
    let right = &mut rest[1..];
    let axes_right = &mut axes_rest[1..];
    if n > PARALLEL_BUILD {
        rayon::join(|| build_range(left, axes_left), || build_range(right, axes_right));
    } else {
        build_range(left, axes_left);
        build_range(right, axes_right);
    }
}

impl<T: KdItem> KdTree<T> {
    /// The items, in tree order (indices of [`Neighbor::index`]).
    #[inline]
    pub fn items(&self) -> &[T] {
        &self.items
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.items.len()
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Items dropped at build time (non-finite positions).
    pub fn dropped(&self) -> usize {
        self.dropped
    }

    /// Bytes of the structure: the items, their positions and one axis byte each.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.items.as_slice()) + std::mem::size_of_val(self.points.as_slice()) + self.axes.len()
    }

    /// The `k` nearest items to `q` within distance `r_max` that pass `filter`, written to
    /// `out` (cleared first; as a max-heap on `d2`, not sorted). Returns the squared radius of
    /// the gathered disk: the `k`-th distance² when `k` items were found, `r_max²` otherwise.
    pub fn knn(&self, q: Vec3, k: usize, r_max: f32, filter: impl Fn(&T) -> bool, out: &mut Vec<Neighbor>) -> f32 {
        out.clear();
        let r_max2 = r_max * r_max;
        if k == 0 || self.items.is_empty() || !(r_max2 >= 0.0) || !q.is_finite() {
            return r_max2.max(0.0);
        }
        let limit = |out: &Vec<Neighbor>| if out.len() == k { out[0].d2 } else { r_max2 };
        let points = self.points.as_slice();
        let consider = |i: usize, out: &mut Vec<Neighbor>| {
            let d2 = (points[i] - q).length_squared();
            if out.len() < k {
                if d2 <= r_max2 && filter(&self.items[i]) {
                    heap_push(out, Neighbor { d2, index: i as u32 });
                }
            } else if d2 < out[0].d2 && filter(&self.items[i]) {
                heap_replace_top(out, Neighbor { d2, index: i as u32 });
            }
        };
        // Explicit stack of (lo, hi, lower bound of d² to the range).
        let mut stack: [(u32, u32, f32); 64] = [(0, 0, 0.0); 64];
        let mut top = 1usize;
        stack[0] = (0, self.items.len() as u32, 0.0);
        while top > 0 {
            top -= 1;
            let (mut lo, mut hi, bound) = stack[top];
            if bound > limit(out) {
                continue;
            }
            loop {
                let (l, h) = (lo as usize, hi as usize);
                if h - l <= LEAF_SIZE {
                    for i in l..h {
                        consider(i, out);
                    }
                    break;
                }
                let mid = l + (h - l) / 2;
                let axis = self.axes[mid] as usize;
                let diff = q[axis] - points[mid][axis];
                consider(mid, out);
                let (near, far) =
                    if diff <= 0.0 { ((lo, mid as u32), (mid as u32 + 1, hi)) } else { ((mid as u32 + 1, hi), (lo, mid as u32)) };
                let d2 = diff * diff;
                if d2 <= limit(out) && far.0 < far.1 && top < stack.len() {
                    stack[top] = (far.0, far.1, d2);
                    top += 1;
                }
                (lo, hi) = near;
            }
        }
        if out.len() == k {
            out[0].d2
        } else {
            r_max2
        }
    }

    /// The nearest item within `r_max` that passes `filter`: `(index, distance²)`.
    pub fn nearest(&self, q: Vec3, r_max: f32, filter: impl Fn(&T) -> bool) -> Option<(usize, f32)> {
        let mut out = Vec::with_capacity(1);
        self.knn(q, 1, r_max, filter, &mut out);
        out.first().map(|n| (n.index as usize, n.d2))
    }
}

#[inline]
fn heap_push(h: &mut Vec<Neighbor>, n: Neighbor) {
    h.push(n);
    let mut i = h.len() - 1;
    while i > 0 {
        let p = (i - 1) / 2;
        if h[p].d2 >= h[i].d2 {
            break;
        }
        h.swap(p, i);
        i = p;
    }
}

#[inline]
fn heap_replace_top(h: &mut [Neighbor], n: Neighbor) {
    h[0] = n;
    let len = h.len();
    let mut i = 0;
    loop {
        let (l, r) = (2 * i + 1, 2 * i + 2);
        let mut m = i;
        if l < len && h[l].d2 > h[m].d2 {
            m = l;
        }
        if r < len && h[r].d2 > h[m].d2 {
            m = r;
        }
        if m == i {
            break;
        }
        h.swap(i, m);
        i = m;
    }
}

/// A photon map as a kd-tree.
pub type PhotonTree = KdTree<Photon>;

/// Result of a photon density estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DensityEstimate {
    /// Irradiance `Σ Φ_p / (π r²)` (W/m² in scene units², per RGB channel).
    pub e: Color,
    /// Radius of the gathered disk (the `n_max`-th distance, or `r_max`).
    pub r: f32,
    /// Photons gathered.
    pub count: usize,
}

/// Gather the photons of the irradiance estimate at `x` (normal `n`) into `scratch`;
/// returns the squared radius of the gathered disk (see the module docs).
#[inline]
pub fn gather_photons(tree: &PhotonTree, x: Vec3, n: Vec3, d: Density, scratch: &mut Vec<Neighbor>) -> f32 {
    tree.knn(x, d.n_max, d.r_max, |p| p.wi.dot(n) > 0.0, scratch)
}

/// The photon irradiance estimate at `x` with normal `n` (module docs).
pub fn photon_irradiance(tree: &PhotonTree, x: Vec3, n: Vec3, d: Density, scratch: &mut Vec<Neighbor>) -> DensityEstimate {
    let r2 = gather_photons(tree, x, n, d, scratch);
    let mut sum = Color::ZERO;
    for nb in scratch.iter() {
        sum += tree.items()[nb.index as usize].power;
    }
    let e = if scratch.is_empty() || !(r2 > 0.0) { Color::ZERO } else { sum / (PI * r2) };
    DensityEstimate { e, r: r2.sqrt(), count: scratch.len() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    #[derive(Clone, Copy, Debug)]
    struct P(Vec3, u32);
    impl KdItem for P {
        fn position(&self) -> Vec3 {
            self.0
        }
    }

    fn brute(items: &[P], q: Vec3, k: usize, r: f32, f: impl Fn(&P) -> bool) -> Vec<(f32, u32)> {
        let mut v: Vec<(f32, u32)> =
            items.iter().filter(|p| f(p)).map(|p| ((p.0 - q).length_squared(), p.1)).filter(|x| x.0 <= r * r).collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        v.truncate(k);
        v
    }

    #[test]
    fn knn_matches_brute_force() {
        let mut s = Sampler::new(3, 1, 0);
        // Clustered points (on planes, like photons) plus a uniform cloud, with duplicates.
        let mut items = Vec::new();
        for i in 0..3000u32 {
            let p = match i % 3 {
                0 => Vec3::new(s.next_1d(), 0.0, s.next_1d()),
                1 => Vec3::new(0.0, s.next_1d(), s.next_1d()),
                _ => Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()),
            };
            items.push(P(p, i));
        }
        items.push(P(items[5].0, 3000));
        items.push(P(Vec3::new(f32::NAN, 0.0, 0.0), 3001));
        let tree = KdTree::build(items.clone());
        assert_eq!(tree.len(), 3001);
        assert_eq!(tree.dropped(), 1);
        let mut out = Vec::new();
        for t in 0..300 {
            let q = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 1.2 - 0.1;
            let k = [1usize, 5, 50, 205][t % 4];
            let r = [0.05f32, 0.2, 10.0][t % 3];
            let filt = |p: &P| !p.1.is_multiple_of(7);
            let r2 = tree.knn(q, k, r, filt, &mut out);
            let mut got: Vec<(f32, u32)> = out.iter().map(|n| (n.d2, tree.items()[n.index as usize].1)).collect();
            got.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let want = brute(&items[..3001], q, k, r, filt);
            assert_eq!(got.len(), want.len(), "query {t}");
            for (g, w) in got.iter().zip(&want) {
                // Same distances (ties may swap equal-distance items).
                assert_eq!(g.0, w.0, "query {t}");
            }
            if want.len() == k {
                assert_eq!(r2, want[k - 1].0);
            } else {
                assert_eq!(r2, r * r);
            }
        }
        // nearest with a filter
        let q = Vec3::splat(0.5);
        let (i, d2) = tree.nearest(q, 10.0, |p| p.1 % 2 == 1).unwrap();
        let want = brute(&items[..3001], q, 1, 10.0, |p| p.1 % 2 == 1);
        assert_eq!(d2, want[0].0);
        assert_eq!(tree.items()[i].1 % 2, 1);
        assert!(tree.nearest(Vec3::splat(5.0), 0.1, |_| true).is_none());
    }

    #[test]
    fn tree_is_identical_for_one_and_two_threads() {
        let mut s = Sampler::new(9, 2, 0);
        let items: Vec<P> = (0..100_000u32).map(|i| P(Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()), i)).collect();
        let build = |t| rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap().install(|| KdTree::build(items.clone()));
        let (a, b) = (build(1), build(2));
        assert!(a.items().iter().zip(b.items()).all(|(x, y)| x.1 == y.1));
        assert_eq!(a.axes, b.axes);
    }

    /// A uniform photon field of known flux density on a plane gives the analytic irradiance,
    /// and photons arriving from behind are ignored.
    #[test]
    fn density_estimate_of_a_uniform_field_is_analytic() {
        let mut s = Sampler::new(5, 3, 0);
        let (side, n) = (10.0f32, 400_000usize);
        let e_true = 2.5f32; // W per unit area
        let power = e_true * side * side / n as f32;
        let mut photons = Vec::with_capacity(n + 1000);
        for i in 0..n {
            // stratified jitter on a grid: low variance, still uniform
            let g = (n as f32).sqrt() as usize;
            let (gx, gy) = (i % g, i / g);
            let p = Vec3::new((gx as f32 + s.next_1d()) / g as f32 * side, 0.0, (gy as f32 + s.next_1d()) / g as f32 * side);
            let wi = Vec3::new(0.3, 0.8, -0.2).normalize();
            photons.push(Photon { p, wi, power: Color::new(power, 0.5 * power, 0.0), ng: Vec3::Y });
        }
        // Photons on the back side of the sheet carry lots of power but must not count.
        for i in 0..1000 {
            let p = Vec3::new(5.0 + 0.001 * i as f32, -1e-4, 5.0);
            photons.push(Photon { p, wi: -Vec3::Y, power: Color::splat(100.0), ng: -Vec3::Y });
        }
        let tree = PhotonTree::build(photons);
        let mut scratch = Vec::new();
        let d = Density { n_max: 205, r_max: 1.0 };
        let est = photon_irradiance(&tree, Vec3::new(5.0, 0.0, 5.0), Vec3::Y, d, &mut scratch);
        assert_eq!(est.count, 205);
        // r such that π r² λ ≈ 205
        let lambda = n as f32 / (side * side);
        assert!((est.r - (205.0 / (PI * lambda)).sqrt()).abs() < 0.05 * est.r, "{est:?}");
        assert!((est.e.x - e_true).abs() < 0.03 * e_true, "{est:?}");
        assert!((est.e.y - 0.5 * e_true).abs() < 0.03 * e_true, "{est:?}");
        // Few photons within r_max: the disk of radius r_max is the area.
        let d_small = Density { n_max: 100_000, r_max: 0.5 };
        let est = photon_irradiance(&tree, Vec3::new(3.0, 0.0, 3.0), Vec3::Y, d_small, &mut scratch);
        assert_eq!(est.r, 0.5);
        assert!((est.e.x - e_true).abs() < 0.02 * e_true, "{est:?}");
        // Seen from below, only the back photons count.
        let est = photon_irradiance(&tree, Vec3::new(5.0, 0.0, 5.0), -Vec3::Y, d, &mut scratch);
        assert!(est.count <= 1000 && est.e.y > 0.0);
        // Nothing within reach: zero.
        let est = photon_irradiance(&tree, Vec3::new(50.0, 0.0, 5.0), Vec3::Y, d, &mut scratch);
        assert_eq!((est.count, est.e), (0, Color::ZERO));
    }

    #[test]
    fn settings_are_checked() {
        assert!(DensitySettings::default().validate("density").is_ok());
        let e = DensitySettings { n_max: 0, ..Default::default() }.validate("density").unwrap_err();
        assert!(e.to_string().contains("density.n_max"), "{e}");
        for bad in [SceneLength::Relative(-1.0), SceneLength::Absolute(f32::NAN), SceneLength::Absolute(0.0)] {
            let e = DensitySettings { r_max: bad, ..Default::default() }.validate("caustic").unwrap_err();
            assert!(e.to_string().contains("caustic.r_max"), "{e}");
        }
        assert!((SceneLength::paper(31.0).resolve(559.0) - 31.0).abs() < 1e-4);
        assert_eq!(SceneLength::Absolute(2.0).resolve(559.0), 2.0);
        assert_eq!(scene_size(&Bounds3::EMPTY), 1.0);
        let json = serde_json::to_string(&DensitySettings::default()).unwrap();
        assert!(json.contains("relative"), "{json}");
    }
}
