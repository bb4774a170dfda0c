//! The photon-built octree of incident radiance (Pacanowski, Granier & Schlick, AFIG 2005,
//! §3–§7 of the paper).
//!
//! # Structure (§3)
//! A cubic octree over the photon hit positions. A cell with more than `n_max` photons is
//! split until `h_max`; a leaf with photons is *valid* and holds six 3x3 matrices, one per
//! axis normal `+X, −X, +Y, −Y, +Z, −Z`; a leaf without photons is *atmospheric* and holds
//! nothing. Each leaf gathers the photons of its cell enlarged by `1+ε` (same centre).
//! Invariants: every kept photon belongs to exactly one leaf (cells are half-open
//! `[min, max)` through the Morton quantisation); a leaf holds more than `n_max` photons only
//! at depth `h_max` (or when `split_respects_n_min` refused the split).
//!
//! Build (`build.rs`, `cells.rs`, `sort.rs`, `estimate.rs`): Morton keys at depth `h_max`, a stable parallel sort of
//! the photon records by key, a top-down split over the sorted ranges, then the per-leaf
//! estimates in parallel (each leaf sums its photons sequentially in a fixed order, f32
//! blocks flushed into f64): the result is bit-identical for any thread count.
//!
//! # What a matrix estimates (§4, eq. 5.1–5.4)
//! Arvo's irradiance vector `M(x) = ∫ L(x,w) w dω`, one column per colour channel (rows x,
//! y, z; columns r, g, b), gives the irradiance on a surface of normal `N` as `E = Mᵀ N`.
//! The matrix of normal `±N_a` sums only photons with `±w_a > 0`, so it estimates the
//! irradiance vector of the hemisphere around `±N_a`.
//!
//! Photons as a flux sample. Take a surface piece of area `A` and normal `n` in the gathering
//! box, incident radiance `L(w)` constant over the box. The photons landing on it sample the
//! incident flux, so for any weight `g`:
//! `E[Σ_p Φ_p g(w_p)] = ∫_A ∫_{H(n)} L(w) (n·w) g(w) dω dA = A ∫_H L(w) cosθ g(w) dω`.
//! - `g(w) = w / (A cos θ)` gives exactly `∫_H L(w) w dω`: hence
//!   **`M ≈ Σ_p Φ_p w_p / (A cos θ_p)`** estimates the irradiance vector on the surface.
//! - The paper's `g(w) = w / ΔA` ([`Estimator::Paper`], eq. 5.4) estimates instead
//!   `(A/ΔA) ∫_H L(w) cosθ w dω`, with two biases: (i) an extra `cos θ`: the normal
//!   irradiance comes out as `(A/ΔA) ∫ L cos²θ dω` instead of `∫ L cosθ dω`, i.e. a factor
//!   `cos θ` for a beam at incidence θ (dark at grazing light) and `2/3` for a uniform
//!   (diffuse) incident field; (ii) the area ratio `A/ΔA`: 1 for one plane crossing the box
//!   parallel to a face, up to `√2` for a diagonal plane, 2 or 3 in edges and corners where
//!   several surfaces share the box, and `≪ 1` for geometry small against the cell (the dark
//!   front of the sphere in the paper's fig. 3).
//! - [`Estimator::Cosine`] divides each photon by `max(|w_p·ng_p|, min_cos)` and keeps `ΔA`:
//!   it removes (i), keeps (ii).
//! - [`Estimator::GeometryArea`] removes both: each photon is divided by the lit projected
//!   area `A⊥(w_p)` of the given triangles clipped to the gathering box (`geometry.rs`
//!   derives why, and what is counted for two-sided sheets, corners and closed objects).
//!   Analytic spheres are clipped exactly, not tessellated ([`Surfaces`]). No photon is
//!   divided by less than `min_cos π δ²` (δ = the enlargement margin `ε s / 2`), the least
//!   area a surface crossing the cell has in the box (`estimate.rs`): a leaf's estimate is
//!   bounded by its photons' flux whatever geometry it finds.
//!   A valid leaf whose box contains no surface falls back to `Cosine` (counted in
//!   [`OctreeStats::geometry_fallback_leaves`]).
//!
//! # Normal interpolation (§5.2) and query (§7)
//! `M(N) = Σ_a M_a^{s(N_a)} N_a²` (three of the six matrices), `E(N) = M(N)ᵀ N`.
//! A query at `P` blends the leaves meeting the box `V` of side `alpha × (smallest leaf
//! edge)` centred on `P`, weighted by the overlap volumes `γ_k`; atmospheric leaves are left
//! out of both sums (they carry no value and must not pull the result towards zero);
//! negative irradiance channels are clamped to 0 after the blend. The blend is `C0`: the
//! weights are continuous in `P`.
//!
//! Storage (§5.3): see `compress.rs` (36 bytes per valid leaf) or full f32 matrices; plus
//! 1 byte of facing bits and 30 bytes of [`LeafAnchors`] per valid leaf (a cache file keeps
//! the 24 bytes of sampled photons only when the leak test needs them). As plain data for
//! cache files: `parts.rs` ([`Octree::to_parts`], [`Octree::from_parts`], docs/guide/baking.md).
//!
//! # Depth from the scene's scale
//! `h_max = auto` ([`Depth::Auto`], the `octree` integrator's default for its global tree)
//! derives the depth limit from the photon count, `n_max` and the scene's surface area
//! ([`auto_depth`]): the same leaves relative to the scene at any scale, finer with more
//! photons.
//!
//! # Leak control
//! A leaf's value is light on the surfaces its photons landed on. Across a wall thinner than
//! a leaf (or the query box), the blend would hand that light to the other side. Each valid
//! leaf keeps [`LeafAnchors`] (mean photon position and normal, four photons with their
//! incident directions), and [`Octree::irradiance_where`] lets the caller drop the leaves it
//! cannot see from the query point, or scale down the light it cannot receive (the `octree`
//! integrator casts rays to and along the sampled photons, `docs/guide/octree.md`). [`LeafPlanes`]
//! (`planes.rs`) keeps, per leaf, the few planes that hold every surface within reach of
//! those rays, when there are such planes: most rays are then answered without casting them.

mod atmosphere;
mod build;
mod cells;
pub mod compress;
mod estimate;
mod flat;
mod flights;
#[cfg(test)]
mod free_space_tests;
mod geometry;
mod incremental;
mod parts;
mod planes;
mod query;
mod refine;
mod refit;
mod settings;
mod sort;
mod stream;
#[cfg(test)]
mod test_photons;
#[cfg(test)]
mod tests;

/// Every matrix of the leaf carries a value.
pub(crate) const ALL_FACING: u8 = 0b11_1111;

pub use atmosphere::{AtmosphereStats, FREE_SPACE_BYTES, NO_ANCHOR, PROBE_LIFT, SMOOTHING_SWEEPS};
pub use flights::{FlightSums, Flights, FLIGHT_MIN};
pub use geometry::AnalyticSphere;
pub use incremental::LeafSums;
pub use parts::{AtmosphereParts, LeafValueParts, OctreeParts, PartsError, ATMOSPHERIC, LEAF_LINK};
pub use planes::{LeafPlane, LeafPlanes, Segment, MAX_PLANES};
pub use refine::{OctantSums, RefineStats, FREE_SPACE_BASE_DEPTH, REFINE_FLOOR, REFINE_TAU};
pub use refit::{Changes, RefitStats};
pub use settings::{auto_depth, Depth, Enlarge, Estimator, OctreeSettings, Split, Storage, AUTO_HEADROOM, MAX_DEPTH};
pub use stream::{Stream, StreamKind, StreamNode, StreamSplit};

/// The surfaces the geometry-area estimator clips to each gathering box (world space).
#[derive(Clone, Copy, Debug, Default)]
pub struct Surfaces<'a> {
    pub triangles: &'a [[Vec3; 3]],
    pub spheres: &'a [AnalyticSphere],
}

use crate::math::Bounds3;
use compress::{CompressedLeaf, FullLeaf};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Errors of the octree build.
#[derive(Debug, thiserror::Error)]
pub enum OctreeError {
    #[error("invalid octree settings: {0}")]
    InvalidSettings(String),
    #[error("invalid octree bounds: {0}")]
    InvalidBounds(String),
    #[error("the geometry_area estimator needs the scene triangles, none were given")]
    MissingGeometry,
    #[error("too many photons for one octree: {0} (at most {max})", max = u32::MAX)]
    TooManyPhotons(usize),
}

/// Statistics of a built octree (the paper's tables 1 and 3).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OctreeStats {
    /// Build time (sorting, subdivision, estimates, compression), seconds (`t_c`).
    pub t_build_s: f64,
    /// Bytes of the structure as stored: nodes + leaf values (`F_m`).
    pub bytes: usize,
    /// `bytes / valid_leaves`.
    pub bytes_per_valid_leaf: f64,
    /// All leaves, atmospheric included.
    pub leaves: usize,
    /// Leaves with a value (`m_v`).
    pub valid_leaves: usize,
    /// Mean photon count of the valid leaves' own cells (`n̄_p`).
    pub mean_photons_per_leaf: f64,
    /// Mean photon count gathered by a valid leaf (enlarged cell).
    pub mean_gathered_photons: f64,
    /// Mean edge length of the valid leaves, scene units (`s̄`).
    pub mean_cell_size: f64,
    /// Valid leaves per depth (index = depth, length `h_max + 1`).
    pub depth_histogram: Vec<u32>,
    /// Photons stored in the octree.
    pub photons: usize,
    /// Photons dropped: non-finite fields or outside the bounds.
    pub photons_dropped: usize,
    /// Octree nodes (internal + leaves).
    pub nodes: usize,
    /// Deepest leaf depth.
    pub max_depth: u32,
    /// Edge of the smallest leaf (scene units): the query box is `alpha` times it.
    pub min_leaf_size: f32,
    /// Valid leaves that found no triangle with `Estimator::GeometryArea` (fell back to `Cosine`).
    pub geometry_fallback_leaves: usize,
    /// The depth limit used: `h_max` as set, or the automatic one ([`auto_depth`]).
    pub h_max: u32,
    /// Surface area (scene units²) the automatic depth was derived from: the given surfaces,
    /// else the root cube's six faces.
    pub surface_area: f64,
}

/// Debug view of one leaf (for visualisation).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LeafInfo {
    /// The cell (not enlarged).
    pub bounds: Bounds3,
    pub depth: u32,
    /// Whether the leaf holds a value (false: atmospheric).
    pub valid: bool,
    /// Photons in the cell (not enlarged).
    pub photons: u32,
}

/// Where the photons of a valid leaf lie, for the leak test of the query
/// ([`Octree::irradiance_where`]; `docs/guide/octree.md`, "Leak control"). 6 bytes per valid leaf,
/// plain data (a cache file stores it as is).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct Anchor {
    /// Mean position of the photons in the leaf's own cell, in 256ths of the cell edge from
    /// its minimum corner (the value `q` stands for `(q + 0.5) / 256`).
    pub pos: [u8; 3],
    /// Mean geometric normal of those photons (their incident direction when the normals are
    /// not known), in 127ths (snorm8), not normalised: short when the photons lie on
    /// surfaces facing opposite ways.
    pub normal: [i8; 3],
}

impl Anchor {
    /// Quantise a mean position (clamped to the cell) and a mean normal.
    pub fn encode(mean: Vec3, normal: Vec3, cell_min: Vec3, cell_size: f32) -> Anchor {
        let rel = ((mean - cell_min) / cell_size * 256.0).floor();
        let q = |v: f32| if v.is_finite() { v.clamp(0.0, 255.0) as u8 } else { 128 };
        let n = |v: f32| if v.is_finite() { (v.clamp(-1.0, 1.0) * 127.0).round() as i8 } else { 0 };
        Anchor { pos: [q(rel.x), q(rel.y), q(rel.z)], normal: [n(normal.x), n(normal.y), n(normal.z)] }
    }

    /// World position of the anchor, for the cell at `cell_min` of edge `cell_size`.
    #[inline]
    pub fn position(&self, cell_min: Vec3, cell_size: f32) -> Vec3 {
        let q = Vec3::new(self.pos[0] as f32, self.pos[1] as f32, self.pos[2] as f32) + 0.5;
        cell_min + q * (cell_size / 256.0)
    }

    /// The mean normal (length at most 1).
    #[inline]
    pub fn normal(&self) -> Vec3 {
        Vec3::new(self.normal[0] as f32, self.normal[1] as f32, self.normal[2] as f32) / 127.0
    }
}

/// Photons sampled per leaf for the leak test ([`LeafAnchors::samples`]).
pub const ANCHOR_SAMPLES: usize = 4;

/// Where the photons of a valid leaf lie: their mean, and [`ANCHOR_SAMPLES`] of them spread
/// over the cell (the photons at the middle of each quarter of the leaf's Morton-sorted range,
/// so in different sub-cells when the photons allow it), each with its own incident direction
/// (stored in [`Anchor::normal`]: unit, pointing away from the surface towards where the light
/// came from). 30 bytes per valid leaf, plain data.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct LeafAnchors {
    pub mean: Anchor,
    pub samples: [Anchor; ANCHOR_SAMPLES],
}

/// A valid leaf met by a query, for the leak test: its anchors in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryLeaf {
    /// Mean position of the leaf's photons.
    pub position: Vec3,
    /// Their mean normal (length at most 1; see [`Anchor::normal`]).
    pub normal: Vec3,
    /// Edge of the leaf's cell.
    pub cell_size: f32,
    /// Sampled photons of the leaf: position and incident direction (see [`LeafAnchors`]).
    pub samples: [(Vec3, Vec3); ANCHOR_SAMPLES],
    /// Index of the valid leaf (for per-leaf data the caller keeps, e.g. [`LeafPlanes`]).
    pub index: u32,
}

/// High bit of `Node::link`: the node is a leaf.
const LEAF_BIT: u32 = 1 << 31;
/// Value index of an atmospheric leaf.
const NO_VALUE: u32 = LEAF_BIT - 1;

/// One octree node, 8 bytes. Children of an internal node are 8 consecutive nodes, child
/// `c` covering the octant `(c & 1, (c >> 1) & 1, (c >> 2) & 1)` of its parent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
struct Node {
    /// Internal: index of the first child. Leaf: `LEAF_BIT | value index` (`NO_VALUE`: atmospheric).
    link: u32,
    /// Photons in the cell.
    photons: u32,
}

impl Node {
    #[inline]
    fn is_leaf(self) -> bool {
        self.link & LEAF_BIT != 0
    }
    #[inline]
    fn value(self) -> u32 {
        self.link & !LEAF_BIT
    }
}

/// The leaf values, in the order of the valid leaves.
#[derive(Clone, Debug)]
enum LeafValues {
    Compressed(Vec<CompressedLeaf>),
    Full(Vec<FullLeaf>),
}

impl LeafValues {
    fn bytes(&self) -> usize {
        match self {
            LeafValues::Compressed(v) => std::mem::size_of_val(v.as_slice()),
            LeafValues::Full(v) => std::mem::size_of_val(v.as_slice()),
        }
    }
}

/// A built, read-only incident-radiance octree (`Send + Sync`).
#[derive(Clone, Debug)]
pub struct Octree {
    /// Minimum corner of the root cube.
    origin: Vec3,
    /// Edge of the root cube.
    size: f32,
    /// Edge of a cell per depth, `size / 2^d`.
    cell_size: [f32; MAX_DEPTH as usize + 1],
    /// `2^h_max / size`: Morton quantisation scale.
    inv_quant: f32,
    h_max: u32,
    nodes: Vec<Node>,
    values: LeafValues,
    /// Per valid leaf: which of its six matrices describe surfaces in the cell (bit `k` in
    /// the order `+X, −X, +Y, −Y, +Z, −Z`). With [`Split::Normal`] and the geometry known, a
    /// matrix whose half-axis no surface of the cell faces carries no value, not a zero, and
    /// the query leaves it out of that axis's blend (the paper's rule for atmospheric cells,
    /// per matrix). Empty otherwise: every matrix then carries a value.
    facing: Vec<u8>,
    /// Per valid leaf: where its photons lie (the leak test of [`Octree::irradiance_where`]).
    anchors: Vec<LeafAnchors>,
    /// Whether `anchors` hold the sampled photons ([`LeafAnchors::samples`]); a tree read from
    /// a cache that kept only the means ([`OctreeParts::leak_samples`]) has each mean there.
    leak_samples: bool,
    /// Half side of the query box: `alpha * min_leaf_size / 2`.
    query_half: f32,
    /// Values diffused into the leaves that lack them (`atmosphere.rs`); none until
    /// [`Octree::fill_atmosphere`].
    atmosphere: Option<atmosphere::Atmosphere>,
    /// The query's flat lists (`flat.rs`): render-time data derived from the nodes, built at
    /// the first query or by [`Octree::prepare_query`].
    flat: std::sync::OnceLock<flat::FlatQuery>,
    settings: OctreeSettings,
    stats: OctreeStats,
}

impl Octree {
    /// Build from photons. `bounds` is made a cube (same centre, largest extent, padded by
    /// 1e-5 of it); photons outside it or with non-finite fields are dropped (counted in the
    /// stats). `geometry` (triangles, world space) is needed by `Estimator::GeometryArea`
    /// and ignored otherwise.
    pub fn build(
        photons: &[crate::photon::Photon],
        bounds: Bounds3,
        settings: &OctreeSettings,
        geometry: Option<&[[Vec3; 3]]>,
    ) -> Result<Octree, OctreeError> {
        build::build(photons, bounds, settings, geometry.map(|triangles| Surfaces { triangles, spheres: &[] }))
    }

    /// [`Octree::build`] with analytic spheres besides the triangles (`geometry.rs` clips
    /// both exactly; tessellating a sphere would leave its photons off the triangles).
    pub fn build_with_surfaces(
        photons: &[crate::photon::Photon],
        bounds: Bounds3,
        settings: &OctreeSettings,
        surfaces: Option<Surfaces<'_>>,
    ) -> Result<Octree, OctreeError> {
        build::build(photons, bounds, settings, surfaces)
    }

    pub fn stats(&self) -> &OctreeStats {
        &self.stats
    }

    pub fn settings(&self) -> &OctreeSettings {
        &self.settings
    }

    /// The root cube.
    pub fn bounds(&self) -> Bounds3 {
        Bounds3 { min: self.origin, max: self.origin + Vec3::splat(self.size) }
    }

    /// Edge of the smallest leaf.
    pub fn min_leaf_size(&self) -> f32 {
        self.stats.min_leaf_size
    }

    /// Side of the query box (`alpha × min_leaf_size`).
    pub fn query_size(&self) -> f32 {
        2.0 * self.query_half
    }

    /// The depth limit the tree was built with (resolved when `h_max` is `auto`).
    pub fn h_max(&self) -> u32 {
        self.h_max
    }

    /// Whether the valid leaves hold their sampled photons ([`LeafAnchors::samples`]), which
    /// the `visible_sample` leak test casts its rays to. A built tree does; one read from a cache
    /// that kept only the mean anchors ([`OctreeParts::leak_samples`]) does not.
    pub fn has_leak_samples(&self) -> bool {
        self.leak_samples
    }

    /// The anchors of every valid leaf in world space, in value order (`QueryLeaf::index`
    /// is the position in the result): what a caller precomputes per leaf for its leak test.
    /// Those the query decodes once per tree (`flat.rs`).
    pub fn valid_leaves(&self) -> &[QueryLeaf] {
        &self.flat().leaves
    }
}

// The octree is shared by the render threads.
const _: () = {
    const fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<Octree>();
};
