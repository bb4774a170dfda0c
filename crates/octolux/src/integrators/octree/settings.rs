//! The `octree` integrator's settings: the photon pass, the two octrees, where paths end in
//! them ([`Mode`]), the leak test and the debug views. [`OctreeIntegratorSettings::validate`]
//! checks every value and combination before any work.

use crate::caches::octree::Depth;
use crate::caches::OctreeSettings;
use crate::photon::trace::PhotonSettings;
use serde::{Deserialize, Serialize};

/// What the integrator writes into the image.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum OctreeView {
    /// The full render (direct + indirect from the octrees + caustics).
    #[default]
    Render,
    /// Irradiance `E` from the global octree at the first non-specular hit (paper fig. 2).
    Irradiance,
    /// Irradiance from global + caustic octrees at the first non-specular hit.
    IrradianceAll,
    /// Leaves as colours: depth as hue, atmospheric black, borders darkened.
    Leaves,
}

/// How a query keeps the light of a leaf from leaking through a wall to a point that cannot
/// see the leaf's photons (`docs/octree.md`, "Leak control").
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum LeakTest {
    /// The paper's blend: every valid leaf met by the query box counts.
    None,
    /// A leaf counts when the mean position of its photons lies within half a cell edge of the
    /// query point's tangent plane (no ray; catches surfaces in front of or behind the query's,
    /// not coplanar ones across a wall).
    Plane,
    /// A leaf counts when a ray from the query point reaches its anchor: the mean position of
    /// its photons, lifted by [`ANCHOR_LIFT`] cell edges along their mean normal. One shadow
    /// ray per valid leaf met.
    Visibility,
    /// A leaf counts when a ray from the query point reaches any of its sampled photons
    /// ([`crate::caches::octree::LeafAnchors`]), each lifted by [`ANCHOR_LIFT`] cell edges along
    /// its own normal. One to four shadow rays per valid leaf met (the first visible one
    /// ends the test). The default: `VisibleLight` and `VisibleOrigin` remove most of the
    /// light-fixture leak but cost relMSE elsewhere (`VisibleLight` on the Cornell boxes,
    /// `VisibleOrigin` on sponza; `docs/octree.md`).
    #[default]
    VisibleSample,
    /// [`LeakTest::VisibleSample`] for keeping a leaf, and its value scaled by the share of its
    /// light whose origin the query point sees: of the sampled photons whose light arrived on
    /// the query's side and that see their light's origin (the photon moved [`LIGHT_LIFT`] cell
    /// edges along its incident direction, towards where its light came from), the fraction
    /// whose origin the query point sees. A point in a gap
    /// (above a light fixture hung under the ceiling) sees the lit ceiling photons outside
    /// through the gap's opening, but not the room below them, where their light came from.
    /// One to twelve rays per leaf, fewer where the planes around the leaf answer them
    /// ([`LeafPlanes`]).
    VisibleLight,
    /// Each sampled photon's light origin: the photon moved along its incident direction by
    /// 0.9 of its reach (the distance to the surface that lit it, at most
    /// [`super::octree_reach::REACH_MAX`] cell edges, [`super::octree_reach`]). The leaf
    /// keeps its weight when the query point sees one of those origins or one of its photons
    /// (each lifted by [`ANCHOR_LIFT`] cell edges, at most half its reach, along its incident
    /// direction); its value is scaled by the share of its samples lit from the query's side
    /// and lying on surfaces facing like the query point's ([`SAME_FACING`]; their normals are
    /// found from the scene) whose origin the query point sees. A point in a gap (above a light fixture hung under
    /// the ceiling) sees the lit ceiling photons outside through the gap's opening, but not
    /// the room below them, where their light came from; a floor photon lit by a wall a few
    /// millimetres away has its origin in front of that wall, not behind it. One to eight rays
    /// per leaf, fewer where the planes around the leaf answer them ([`LeafPlanes`]).
    VisibleOrigin,
    /// [`LeakTest::VisibleSample`] for keeping a leaf, and its value scaled by the share of its
    /// light that reaches the query point: of the sampled photons whose light arrived on the
    /// query's side, the fraction visible whose incident direction is open from the query point
    /// over [`DIRECTION_REACH`] cell edges. Removes the fixture gap's leak, but an occluder is
    /// not a dark one: near every corner and object the blocked directions bring light
    /// reflected by the occluder, and the image darkens (measured in `docs/octree.md`). Up to
    /// eight rays per leaf.
    OpenDirections,
    /// [`LeakTest::Visibility`], and a second ray from the query point along the leaf's mean
    /// incident direction must travel one cell edge unblocked: a point in a gap (above a light
    /// fixture hung under the ceiling) sees its anchor through the gap's opening, but the
    /// light the leaf's photons received arrived from where the gap is closed. It also darkens
    /// the floor where an object touches it (measured in `docs/octree.md`): not the default.
    VisibilityAndDirection,
}

/// Settings of the `octree` integrator.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct OctreeIntegratorSettings {
    pub photons: PhotonSettings,
    /// Octree of the global (indirect) photons.
    pub global: OctreeSettings,
    /// Octree of the caustic photons.
    pub caustic: OctreeSettings,
    /// Mitsuba's `max_depth` (path vertices; -1 = unbounded), as the path tracer counts it.
    /// When bounded it also bounds the photons' bounces, so that a render compares with `path`
    /// at the same value: the cache then serves one vertex only ([`Mode::end_vertex`]).
    pub max_depth: i32,
    /// Depth from which Russian roulette may end paths (the path tracer's `rr_depth`).
    pub rr_depth: u32,
    /// Where paths end in the cache ([`Mode`]).
    pub mode: Mode,
    /// With `mode = terminate`: a path ends in the cache at a vertex whose ray cone is at least
    /// this many times as wide as the global octree's leaf there (docs/octree.md, "Ending
    /// paths in the cache"). A huge value ends no path: the image is the path tracer's.
    pub footprint: f32,
    /// With `mode = terminate`: the roughness (microfacet alpha) from which a lobe's light may
    /// come from the cache; narrower lobes keep tracing (`scene::material::split`).
    pub min_alpha: f32,
    /// With `mode = terminate`: the caustic octree is read where the leaf holding the point has
    /// at least this many photons; elsewhere the caustic light is path-traced.
    pub caustic_photons: u32,
    pub view: OctreeView,
    /// Leak control of the octree queries.
    pub leak: LeakTest,
    /// How a query blends the leaves ([`QueryMode`]).
    pub query: QueryMode,
}

/// How the `octree` integrator evaluates the §7 blend at a shading point.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum QueryMode {
    /// The paper's query: the leaves the box around the point meets, blended by overlap
    /// volume, each passed through the leak test from the point.
    #[default]
    Blend,
    /// The same blend precomputed at the corners of each valid leaf per query class and
    /// interpolated trilinearly, with the leak test decided from the leaf's photons
    /// (`integrators/octree/corners.rs`); the exact query where no table applies. With
    /// `leak = none` or `visible_sample` only (the other tests take the exact query).
    Corners,
}

/// Safety bound on specular chains from the camera in the debug views when `max_depth` is
/// unbounded (a closed mirror box would otherwise never end).
pub const MAX_SPECULAR_CHAIN: u32 = 64;

/// Where the `octree` integrator's paths end in the cache.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// The path tracer's loop, ended in the cache where the path's footprint is wide enough
    /// and the lobe rough enough (`footprint`, `min_alpha`): never at a glossy camera vertex.
    #[default]
    Terminate,
    /// The paper's renderer (§8): the cache is read at the first vertex with a non-delta lobe
    /// after a specular chain from the camera, every lobe shaded from it.
    Paper,
}

impl Mode {
    /// The one vertex at which a path may end when `max_depth` is bounded (photons then bounce
    /// at most `max_depth - 1 - end_vertex` times, so that no path is longer than the path
    /// tracer's): 2 for `terminate` (one bounce from the camera), 1 for `paper`.
    pub fn end_vertex(self) -> u32 {
        match self {
            Mode::Terminate => 2,
            Mode::Paper => 1,
        }
    }
}

/// Default of [`OctreeIntegratorSettings::footprint`].
pub const DEFAULT_FOOTPRINT: f32 = 1.0;
/// Default of [`OctreeIntegratorSettings::min_alpha`].
pub const DEFAULT_MIN_ALPHA: f32 = 0.3;
/// Default of [`OctreeIntegratorSettings::caustic_photons`].
pub const DEFAULT_CAUSTIC_PHOTONS: u32 = 16;

/// Caustics are sharp, so the caustic octree is finer than the global one. Measured on
/// cornell-spheres (128², 64 spp, 1M photons, relMSE vs Mitsuba 3): caustic (h_max, n_max) =
/// (6, 400) as the global tree 3.2e-2 — 95% of it in the 1% of pixels around the glass sphere's
/// caustic —, (8, 100) 4.0e-3, (10, 50) 2.9e-3, (10, 20) 3.1e-3 (noisier).
pub const CAUSTIC_H_MAX: u32 = 10;
/// See [`CAUSTIC_H_MAX`].
pub const CAUSTIC_N_MAX: u32 = 50;

impl Default for OctreeIntegratorSettings {
    /// The paper's octree configuration, except the estimator: `GeometryArea` (the paper's own
    /// proposed fix) is the default because it measured closest to the path-traced reference
    /// (cornell-box 128², 64 spp, 1M photons, relMSE vs Mitsuba 3: paper 8.2e-3 — 8% too dark —,
    /// cosine 1.4e-3, geometry-area 8.5e-4; `--estimator paper` restores the paper's).
    fn default() -> Self {
        let tree = OctreeSettings {
            h_max: Depth::Auto,
            estimator: crate::caches::Estimator::GeometryArea,
            split: crate::caches::Split::Normal,
            ..OctreeSettings::default()
        };
        OctreeIntegratorSettings {
            photons: PhotonSettings::default(),
            global: tree.clone(),
            caustic: OctreeSettings { h_max: Depth::Fixed(CAUSTIC_H_MAX), n_max: CAUSTIC_N_MAX, ..tree },
            max_depth: -1,
            rr_depth: 5,
            mode: Mode::default(),
            footprint: DEFAULT_FOOTPRINT,
            min_alpha: DEFAULT_MIN_ALPHA,
            caustic_photons: DEFAULT_CAUSTIC_PHOTONS,
            view: OctreeView::Render,
            leak: LeakTest::default(),
            query: QueryMode::default(),
        }
    }
}

impl OctreeIntegratorSettings {
    /// Check the settings that the octrees' own validation does not see.
    pub fn validate(&self) -> Result<(), String> {
        if self.max_depth < -1 {
            return Err(format!("max_depth must be -1 (unbounded) or at least 0, not {}", self.max_depth));
        }
        if !(self.footprint >= 0.0) {
            return Err(format!("footprint must be a number at least 0, not {}", self.footprint));
        }
        if !(0.0..=1.0).contains(&self.min_alpha) {
            return Err(format!("min_alpha must lie in [0, 1], not {}", self.min_alpha));
        }
        Ok(())
    }
}
