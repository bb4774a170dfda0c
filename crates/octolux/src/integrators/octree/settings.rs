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
/// see the leaf's photons (`leak.rs`; `docs/guide/octree.md`, "Leak control").
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum LeakTest {
    /// The mode's own: `none` with `mode = terminate` and `unbiased` (one bounce from the camera a leak is a
    /// twentieth of the direct read's, and the test cost 10–35% of the render for no measured
    /// gain on the ten benchmark scenes), `visible_sample` with `mode = paper`.
    #[default]
    Auto,
    /// The paper's blend: every valid leaf met by the query box counts.
    None,
    /// A leaf counts when a ray from the query point reaches any of its sampled photons
    /// ([`crate::caches::octree::LeafAnchors`]), each lifted by [`super::ANCHOR_LIFT`] cell
    /// edges along its incident direction. One to four rays per valid leaf met (the first
    /// visible one ends the test), most of them answered by the planes around the leaf
    /// ([`crate::caches::octree::LeafPlanes`]).
    VisibleSample,
}

impl LeakTest {
    /// The test a query runs in `mode` ([`LeakTest::Auto`] resolved).
    pub fn resolved(self, mode: Mode) -> LeakTest {
        match (self, mode) {
            (LeakTest::Auto, Mode::Terminate | Mode::Unbiased) => LeakTest::None,
            (LeakTest::Auto, Mode::Paper) => LeakTest::VisibleSample,
            (t, _) => t,
        }
    }
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
    /// this many times as wide as the global octree's leaf there (docs/guide/octree.md, "Ending
    /// paths in the cache"). A huge value ends no path: the image is the path tracer's.
    pub footprint: f32,
    /// With `mode = terminate`: the roughness (microfacet alpha) from which a lobe's light may
    /// come from the cache; narrower lobes keep tracing (`scene::material::split`).
    pub min_alpha: f32,
    /// With `mode = terminate`: the caustic octree is read where the leaf holding the point has
    /// at least this many photons; elsewhere the caustic light is path-traced. Measured (1M
    /// photons, 64 spp): cornell-spheres relMSE 6.9e-4 with 0, 7.0e-4 with 4, 2.6e-3 with 16,
    /// 1.8e-2 never (path-traced caustics); cbox 9.3e-4, 9.3e-4, 4.0e-3, 1.8e-2. On the ten
    /// time-to-error scenes (docs/lab/2026-12-04-time-to-error.md) 0 against 4: torus 4.6e-3
    /// against 5.0e-2 and veach-lamp 0.12 against 0.70 at 1.6M photons and 256 spp (with 4,
    /// two path-traced caustic samples through the glass carried 87% of torus' error), every
    /// other scene and rung within 6%. Default 0: the caustic octree is always read.
    pub caustic_photons: u32,
    /// With `mode = unbiased`: how readily a path ending in the cache is traced on to correct
    /// the cache's value (the residual estimator, docs/guide/octree.md "Without bias"). A path goes
    /// on with probability `min(1, 2 q s)`, at least [`Q_MIN`], where `s` is the share of the
    /// path's estimated light that the cache puts beyond the vertex: `q` where the cache
    /// holds half of it. 1 (the default) measured best of 0.5, 1 and 2 on three scenes; 20 traces
    /// (nearly) every path on, the cache then a pure control variate.
    pub q: f32,
    /// Where a path ends at a vertex whose lobes are all the cache's: `true` samples the BSDF
    /// once more for the emitter its ray meets (MIS with the light sample), `false` takes the
    /// light sample alone.
    pub tail: bool,
    pub view: OctreeView,
    /// Leak control of the octree queries.
    pub leak: LeakTest,
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
    /// `terminate`'s rule without its bias: where a path ends, the cache's value `C` is
    /// corrected by a path-traced continuation taken with probability `q`,
    /// `C + [u < q] (L − Ĉ) / q` (`Ĉ`: the cache's value for the sampled direction, of mean
    /// `C`), so that the image converges to the path tracer's (docs/guide/octree.md "Without bias").
    Unbiased,
    /// The paper's renderer (§8): the cache is read at the first vertex with a non-delta lobe
    /// after a specular chain from the camera, every lobe shaded from it.
    Paper,
}

impl Mode {
    /// The one vertex at which a path may end when `max_depth` is bounded (photons then bounce
    /// at most `max_depth - 1 - end_vertex` times, so that no path is longer than the path
    /// tracer's): 2 for `terminate` and `unbiased` (one bounce from the camera), 1 for `paper`.
    pub fn end_vertex(self) -> u32 {
        match self {
            Mode::Terminate | Mode::Unbiased => 2,
            Mode::Paper => 1,
        }
    }
}

/// Default of [`OctreeIntegratorSettings::footprint`]. Measured in one time-to-error run per
/// value (docs/lab/2026-12-04-time-to-error.md): at the lowest target each scene reached, 0.25
/// took at most the CPU time of 1 on nine of the ten reference scenes (bitterli 0.114 s
/// against 0.139 s to relMSE 0.01, sponza 3.59 s against 3.76 s) and 10% more on torus. At
/// 0.25 a camera vertex ends in the cache where its pixel is a quarter of a leaf wide (low
/// resolutions, small leaves); 0 ends every path at the camera vertex where `max_depth` is
/// unbounded (the paper's read, with its bias: cornell-box levels off near relMSE 5e-5).
pub const DEFAULT_FOOTPRINT: f32 = 0.25;
/// Default of [`OctreeIntegratorSettings::min_alpha`].
pub const DEFAULT_MIN_ALPHA: f32 = 0.3;
/// Default of [`OctreeIntegratorSettings::q`].
pub const DEFAULT_Q: f32 = 1.0;
/// The least probability with which `mode = unbiased` traces a path on: weights stay at most
/// 20x the path's.
pub const Q_MIN: f32 = 0.05;
/// Default of [`OctreeIntegratorSettings::caustic_photons`].
pub const DEFAULT_CAUSTIC_PHOTONS: u32 = 0;

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
            q: DEFAULT_Q,
            tail: true,
            view: OctreeView::Render,
            leak: LeakTest::default(),
        }
    }
}

impl OctreeIntegratorSettings {
    /// The photon pass's settings as traced: `max_depth`, as Mitsuba counts it, bounds the
    /// photons' bounces so that renders stay comparable with `path` at the same value. A path
    /// camera -> x1 ... -> x_n -> y_b ... -> y_1 -> light has n + b surface vertices and must
    /// have at most max_depth - 1, so photons read at vertex n may have bounced at most
    /// max_depth - 1 - n times; the cache then serves that vertex only (`Mode::end_vertex`).
    pub fn traced_photons(&self) -> crate::photon::trace::PhotonSettings {
        let mut p = self.photons;
        if self.max_depth >= 0 {
            let n = self.mode.end_vertex() as i32;
            p.max_bounces = p.max_bounces.min((self.max_depth - 1 - n).max(0) as u32);
        }
        p
    }

    /// Check the settings that the octrees' own validation does not see.
    pub fn validate(&self) -> Result<(), String> {
        if self.max_depth < -1 {
            return Err(format!("max_depth must be -1 (unbounded) or at least 0, not {}", self.max_depth));
        }
        if !(self.footprint >= 0.0) {
            return Err(format!("footprint must be a number at least 0, not {}", self.footprint));
        }
        if !(self.q > 0.0 && self.q <= 20.0) {
            return Err(format!("q must lie in (0, 20], not {}", self.q));
        }
        if !(0.0..=1.0).contains(&self.min_alpha) {
            return Err(format!("min_alpha must lie in [0, 1], not {}", self.min_alpha));
        }
        Ok(())
    }
}
