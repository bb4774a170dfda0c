//! The paper's renderer (Pacanowski, Granier & Schlick 2005, §8): a ray tracer whose indirect
//! light comes from a global octree and whose caustics come from a caustic octree.
//!
//! Per primary ray: follow specular chains (mirror reflection, refraction) recursively; at
//! the first vertex with a non-delta lobe
//! - direct light by next-event estimation with shadow rays (area lights sampled by area),
//! - indirect light from the octrees, from their blended incident-radiance matrix `M(N)`.
//!
//! **How the cache shades a surface.** Column `c` of `M(N)` is the irradiance vector `m_c`
//! of colour channel `c` (§4): its direction `d_c = m_c/|m_c|` is the mean incident direction
//! and `|m_c|` its strength. We treat each channel's incident light as arriving from `d_c`:
//! `L_o,c = f_c(wo, d_c) cos θ(d_c) |m_c|` — exactly what `Material::eval` returns times
//! `|m_c|`. For a Lambertian surface this is `ρ/π (m_c·N) = ρ E_c / π`, the paper's formula;
//! for glossy surfaces (rough conductor, rough plastic) it evaluates the lobe in the mean
//! incident direction, which the paper's representation allows and a pure irradiance cache
//! cannot. Global and caustic octrees are evaluated separately and summed.
//!
//! An emitter seen directly or through a specular chain adds its emission; emission reached
//! otherwise is already in the direct term.
//!
//! **Leak control** ([`LeakTest`], `docs/octree.md` "Leak control"): every octree read drops
//! the leaves whose photons the shading point cannot see (default: none of four sampled
//! photons per leaf is visible; `visible_light` and `visible_origin` also scale a leaf by the
//! share of its light whose origin the point sees), so light does not pass through walls
//! thinner than the query box. The global tree's depth limit is automatic by default (`caches::octree::auto_depth`).

use super::common::{direct_light, facing, walk_specular, RayCounters, Vertex};
use super::octree_reach::{LeakData, SampleReach, REACH_MAX};
use crate::caches::octree::{AnalyticSphere, Depth, LeafPlanes, OctreeParts, PartsError, QueryLeaf, Segment, Surfaces, ANCHOR_SAMPLES};
use crate::caches::{Octree, OctreeError, OctreeSettings, OctreeStats};
use crate::math::{Color, Frame, Ray, RayDifferential};
use crate::photon::trace::{trace_photons, PhotonError, PhotonSettings};
use crate::sampling::Sampler;
use crate::scene::material::Material;
use crate::scene::{Scene, SurfaceHit};
use glam::{Mat3, Vec3};
use serde::{Deserialize, Serialize};
use std::time::Instant;

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

/// Settings of the `octree` integrator.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct OctreeIntegratorSettings {
    pub photons: PhotonSettings,
    /// Octree of the global (indirect) photons.
    pub global: OctreeSettings,
    /// Octree of the caustic photons.
    pub caustic: OctreeSettings,
    /// Mitsuba's `max_depth` (path vertices; -1 = unbounded): it bounds the specular chain
    /// followed from the camera and, as `max_depth - 2`, the photons' bounces, so that a render
    /// compares with `path` at the same value. Unbounded chains stop after
    /// [`MAX_SPECULAR_CHAIN`] vertices.
    pub max_depth: i32,
    pub view: OctreeView,
    /// Gather the global octree one bounce away instead of reading it where the camera path
    /// lands (see `OctreeIntegrator::gathered_global`): one BSDF-sampled ray per sample, and
    /// the cache's bias is averaged over the hemisphere instead of showing directly.
    pub gather: bool,
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
    /// (`integrators/octree_corners.rs`); the exact query where no table applies. With
    /// `leak = none` or `visible_sample` only (the other tests take the exact query).
    Corners,
}

/// Safety bound on specular chains from the camera when `max_depth` is unbounded (a closed
/// mirror box would otherwise never end).
pub const MAX_SPECULAR_CHAIN: u32 = 64;

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
            view: OctreeView::Render,
            gather: false,
            leak: LeakTest::default(),
            query: QueryMode::default(),
        }
    }
}

/// Errors while building the octrees.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error(transparent)]
    Photons(#[from] PhotonError),
    #[error("global octree: {0}")]
    Global(OctreeError),
    #[error("caustic octree: {0}")]
    Caustic(OctreeError),
    /// Prebuilt octrees ([`OctreeIntegrator::from_parts`]) that do not make an integrator.
    #[error("{tree} octree: {source}")]
    Parts { tree: &'static str, source: PartsError },
}

/// Statistics of the build (the paper's tables 1 and 3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OctreeBuildStats {
    pub photons_emitted: u64,
    pub global_photons: usize,
    pub caustic_photons: usize,
    /// Photon tracing time, seconds.
    pub t_photons_s: f64,
    /// Octree build time (both octrees), seconds.
    pub t_octree_s: f64,
    /// `t_c`: photon tracing + octree build, seconds.
    pub t_c_s: f64,
    /// Octree build rate, photons per second (both octrees).
    pub build_photons_per_s: f64,
    pub global: OctreeStats,
    pub caustic: Option<OctreeStats>,
    /// `F_m`: bytes of both octrees as stored.
    pub bytes: usize,
}

/// A built `octree` integrator: settings plus the two octrees (read-only while rendering).
pub struct OctreeIntegrator {
    pub settings: OctreeIntegratorSettings,
    pub global: Octree,
    pub caustic: Option<Octree>,
    pub stats: OctreeBuildStats,
    /// [`LeafPlanes`] of the global and the caustic tree for the leak test, computed from the
    /// scene at the first query (or by [`OctreeIntegrator::prepare_leak`]).
    planes: [std::sync::OnceLock<LeakData>; 2],
    /// Corner tables of the global and the caustic tree ([`QueryMode::Corners`]), computed at
    /// preparation or at the first query.
    pub(super) corners: [std::sync::OnceLock<crate::caches::octree::CornerTables>; 2],
    /// Objects inserted into the baked lighting (`octree_insert.rs`); none by default.
    pub inserted: super::octree_insert::Inserted,
}

/// A built `octree` integrator as plain data: what a cache file holds (docs/baking.md).
/// Extend [`OctreeParts`] for per-leaf data, this struct for per-integrator data.
#[derive(Clone, Debug, PartialEq)]
pub struct OctreeIntegratorParts {
    pub settings: OctreeIntegratorSettings,
    pub global: OctreeParts,
    pub caustic: Option<OctreeParts>,
    pub stats: OctreeBuildStats,
}

impl OctreeIntegrator {
    /// The integrator as plain data ([`Octree::to_parts`] of both octrees).
    pub fn to_parts(&self) -> OctreeIntegratorParts {
        OctreeIntegratorParts {
            settings: self.settings.clone(),
            global: self.global.to_parts(),
            caustic: self.caustic.as_ref().map(Octree::to_parts),
            stats: self.stats.clone(),
        }
    }

    /// The integrator from prebuilt octrees, without tracing a photon: every octree invariant
    /// is checked ([`Octree::from_parts`]) and each octree's settings must be the integrator's.
    /// Renders are bit-identical to those of the integrator the parts came from.
    pub fn from_parts(parts: OctreeIntegratorParts) -> Result<OctreeIntegrator, BuildError> {
        let OctreeIntegratorParts { settings, global, caustic, mut stats } = parts;
        let tree = |name: &'static str, want: &OctreeSettings, p: OctreeParts| {
            let err = |source| BuildError::Parts { tree: name, source };
            if p.settings != *want {
                return Err(err(PartsError(format!("its settings {:?} are not the integrator's {want:?}", p.settings))));
            }
            Octree::from_parts(p).map_err(err)
        };
        let global = tree("global", &settings.global, global)?;
        let caustic = caustic.map(|c| tree("caustic", &settings.caustic, c)).transpose()?;
        stats.global = global.stats().clone();
        stats.caustic = caustic.as_ref().map(|c| c.stats().clone());
        stats.bytes = global.stats().bytes + caustic.as_ref().map_or(0, |c| c.stats().bytes);
        let o = OctreeIntegrator {
            settings,
            global,
            caustic,
            stats,
            planes: Default::default(),
            corners: Default::default(),
            inserted: Default::default(),
        };
        o.prepare_query();
        Ok(o)
    }

    /// Build the octrees' flat query lists now (render-time data, `caches/octree/flat.rs`)
    /// instead of at the first query.
    pub fn prepare_query(&self) {
        self.global.prepare_query();
        if let Some(c) = &self.caustic {
            c.prepare_query();
        }
    }

    /// Compute what the leak test needs from the scene ([`LeafPlanes`] of both trees) now
    /// instead of at the first query; the scene must be the one the octrees were built for.
    pub fn prepare_leak(&self, scene: &Scene) {
        if matches!(
            self.settings.leak,
            LeakTest::Visibility | LeakTest::VisibleSample | LeakTest::VisibleLight | LeakTest::VisibleOrigin | LeakTest::OpenDirections
        ) {
            self.planes_of(scene, &self.global);
            // the caustic tree's too: built at its first query, they counted as query time
            if let Some(c) = &self.caustic {
                self.planes_of(scene, c);
            }
        }
        if self.uses_corners() {
            self.corners_of(scene, &self.global);
            if let Some(c) = &self.caustic {
                self.corners_of(scene, c);
            }
        }
    }

    /// What the leak test found (for out.json's `render_report`): per tree that computed them,
    /// the valid leaves around which the scene is one plane ([`LeafPlanes`], tested without a
    /// ray) and all valid leaves.
    pub fn leak_report(&self) -> serde_json::Value {
        let count = |p: &std::sync::OnceLock<LeakData>| {
            p.get().map(|p| serde_json::json!({ "planar": p.planes.planar(), "valid": p.planes.len() }))
        };
        let lists = |t: &Octree| {
            let (entries, bytes) = t.query_lists();
            serde_json::json!({ "entries": entries, "bytes": bytes })
        };
        let corners = |c: &std::sync::OnceLock<crate::caches::octree::CornerTables>| {
            c.get().map(|c| {
                let (tables, bytes) = c.size();
                serde_json::json!({ "tables": tables, "bytes": bytes })
            })
        };
        serde_json::json!({
            "corner_tables_global": corners(&self.corners[0]),
            "corner_tables_caustic": corners(&self.corners[1]),
            "leak_planes_global": count(&self.planes[0]),
            "leak_planes_caustic": count(&self.planes[1]),
            "query_lists_global": lists(&self.global),
            "query_lists_caustic": self.caustic.as_ref().map(lists),
        })
    }

    /// The [`LeafPlanes`] and sample reaches of `tree` (one of this integrator's octrees) for `scene`.
    pub fn planes_of(&self, scene: &Scene, tree: &Octree) -> &LeakData {
        let i = if std::ptr::eq(tree, &self.global) { 0 } else { 1 };
        self.planes[i].get_or_init(|| {
            let tris = scene.mesh_triangles_where(|_| true);
            let spheres: Vec<_> = scene.analytic_spheres_where(|_| true).into_iter().map(|(c, r, _)| (c, r)).collect();
            let planes: LeafPlanes = tree.leaf_planes(&tris, &spheres, DIRECTION_REACH.max(ANCHOR_LIFT).max(LIGHT_LIFT).max(REACH_MAX));
            LeakData::new(scene, tree, planes, self.settings.leak == LeakTest::VisibleOrigin)
        })
    }

    /// Trace the photons and build both octrees over the scene's bounds.
    pub fn build(scene: &Scene, settings: OctreeIntegratorSettings) -> Result<OctreeIntegrator, BuildError> {
        settings.global.validate().map_err(BuildError::Global)?;
        settings.caustic.validate().map_err(BuildError::Caustic)?;
        // Honour max_depth as Mitsuba counts it, so renders stay comparable with `path` at the
        // same value: a path camera -> x1 -> y_b ... -> y_1 -> light has b + 1 surface
        // vertices and must have at most max_depth - 1, so photons stored at x1 may have
        // bounced at most max_depth - 2 times.
        let mut photon_settings = settings.photons;
        if settings.max_depth >= 0 {
            photon_settings.max_bounces = photon_settings.max_bounces.min((settings.max_depth - 2).max(0) as u32);
        }
        let maps = trace_photons(scene, &photon_settings)?;
        let t0 = Instant::now();
        let needs_geometry = |s: &OctreeSettings| s.estimator == crate::caches::Estimator::GeometryArea;
        // Meshes as triangles, spheres analytic: a tessellated sphere would leave its photons
        // off the triangles, its lit side undetected (docs/octree.md, "Analytic shapes").
        let (tris, spheres) = if needs_geometry(&settings.global) || needs_geometry(&settings.caustic) {
            estimator_surfaces(scene)
        } else {
            (Vec::new(), Vec::new())
        };
        let surfaces = Some(Surfaces { triangles: &tris, spheres: &spheres });
        let global = Octree::build_with_surfaces(&maps.global, scene.bounds, &settings.global, surfaces).map_err(BuildError::Global)?;
        let caustic = if maps.caustic.is_empty() {
            None
        } else {
            Some(Octree::build_with_surfaces(&maps.caustic, scene.bounds, &settings.caustic, surfaces).map_err(BuildError::Caustic)?)
        };
        let t_octree_s = t0.elapsed().as_secs_f64();
        let n = maps.global.len() + maps.caustic.len();
        let stats = OctreeBuildStats {
            photons_emitted: maps.emitted,
            global_photons: maps.global.len(),
            caustic_photons: maps.caustic.len(),
            t_photons_s: maps.time_s,
            t_octree_s,
            t_c_s: maps.time_s + t_octree_s,
            build_photons_per_s: n as f64 / t_octree_s.max(1e-9),
            global: global.stats().clone(),
            caustic: caustic.as_ref().map(|c| c.stats().clone()),
            bytes: global.stats().bytes + caustic.as_ref().map_or(0, |c| c.stats().bytes),
        };
        let o = OctreeIntegrator {
            settings,
            global,
            caustic,
            stats,
            planes: Default::default(),
            corners: Default::default(),
            inserted: Default::default(),
        };
        o.prepare_leak(scene);
        o.prepare_query();
        Ok(o)
    }

    /// Radiance along a primary ray.
    pub fn li(&self, scene: &Scene, ray: Ray, diff: Option<&RayDifferential>, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        let max_depth = if self.settings.max_depth < 0 { MAX_SPECULAR_CHAIN } else { self.settings.max_depth as u32 };
        let view = self.settings.view;
        if view == OctreeView::Leaves {
            counters.rays += 1;
            return scene.intersect(&ray).map_or(Color::ZERO, |hit| self.leaf_colour(&hit, ray.d));
        }
        let walk = walk_specular(scene, ray, diff, max_depth, view == OctreeView::Render, sampler, counters);
        let mut result = walk.emitted;
        let Some(v) = walk.vertex else { return result };
        let material = &scene.materials[v.hit.material as usize];
        match view {
            OctreeView::Render if self.settings.gather => {
                let mut l = direct_light(scene, &v.hit, material, v.wo, sampler, counters);
                l += self.indirect_from(scene, &v, material, counters, false, true);
                l += self.gathered_global(scene, &v, material, v.bounces + 1, max_depth, sampler, counters);
                result += v.throughput * l;
            }
            OctreeView::Render => {
                result += v.throughput
                    * (direct_light(scene, &v.hit, material, v.wo, sampler, counters)
                        + self.indirect_render(scene, &v, material, sampler, counters));
            }
            OctreeView::Irradiance | OctreeView::IrradianceAll => {
                let mut e = self.irradiance(scene, &self.global, &v, counters);
                if view == OctreeView::IrradianceAll {
                    if let Some(c) = &self.caustic {
                        e += self.irradiance(scene, c, &v, counters);
                    }
                }
                result += v.throughput * e.max(Color::ZERO);
            }
            OctreeView::Leaves => unreachable!("handled above"),
        }
        result
    }

    /// Irradiance `M(N)ᵀ N` from `tree` at a vertex (normal on the viewer's side), W/m².
    fn irradiance(&self, scene: &Scene, tree: &Octree, v: &Vertex, counters: &mut RayCounters) -> Color {
        self.incident_matrix(scene, tree, &v.hit, v.n, counters).map_or(Color::ZERO, |m| m.transpose() * v.n)
    }

    /// The planes the leak test `leak` uses for `tree` (none for the tests that do not use them).
    #[inline]
    fn leak_planes(&self, scene: &Scene, tree: &Octree, leak: LeakTest) -> Option<&LeakData> {
        matches!(
            leak,
            LeakTest::Visibility | LeakTest::VisibleSample | LeakTest::VisibleLight | LeakTest::VisibleOrigin | LeakTest::OpenDirections
        )
        .then(|| self.planes_of(scene, tree))
    }

    /// `tree`'s irradiance at `hit` for normal `n` (on the viewer's side), leak control applied.
    pub fn irradiance_at(&self, scene: &Scene, tree: &Octree, hit: &SurfaceHit, n: Vec3, counters: &mut RayCounters) -> Option<Color> {
        let mut rays = 0u64;
        let e = counters.time_query(|| {
            if self.uses_corners() {
                if let Some((table, t)) = self.corner_table(scene, tree, hit, n, &mut rays) {
                    return tree.irradiance_from(table, t, n);
                }
            }
            match self.settings.leak {
                LeakTest::None => tree.irradiance(hit.p, n),
                leak => {
                    let planes = self.leak_planes(scene, tree, leak);
                    tree.irradiance_where(hit.p, n, |q| keep_leaf(scene, tree, planes, hit, n, leak, q, &mut rays))
                }
            }
        });
        counters.shadow_rays += rays;
        e
    }

    /// `tree`'s incident matrix at `hit` for normal `n`, leak control applied.
    fn incident_matrix(&self, scene: &Scene, tree: &Octree, hit: &SurfaceHit, n: Vec3, counters: &mut RayCounters) -> Option<Mat3> {
        let mut rays = 0u64;
        let m = counters.time_query(|| {
            if self.uses_corners() {
                if let Some((table, t)) = self.corner_table(scene, tree, hit, n, &mut rays) {
                    return tree.incident_matrix_from(table, t, n);
                }
            }
            match self.settings.leak {
                LeakTest::None => tree.incident_matrix(hit.p, n),
                leak => {
                    let planes = self.leak_planes(scene, tree, leak);
                    tree.incident_matrix_where(hit.p, n, |q| keep_leaf(scene, tree, planes, hit, n, leak, q, &mut rays))
                }
            }
        });
        counters.shadow_rays += rays;
        m
    }

    /// Reflected light from the global and/or the caustic octree at `v` (see the module docs).
    pub(super) fn indirect_from(
        &self,
        scene: &Scene,
        v: &Vertex,
        material: &Material,
        counters: &mut RayCounters,
        global: bool,
        caustic: bool,
    ) -> Color {
        // The octree stores incident light on the side the photons came from; query with the
        // shading normal on the side of the viewer.
        let (hit, n) = (&v.hit, v.n);
        let trees = global.then_some(&self.global).into_iter().chain(self.caustic.as_ref().filter(|_| caustic));
        let mut l = Color::ZERO;
        // Lambertian: ρ/π E(N) is what shade_matrix returns, from the cheaper irradiance query.
        let albedo = material.lambertian_albedo(&scene.images, hit.uv, v.wo);
        for tree in trees {
            match albedo {
                Some(rho) => {
                    if rho != Color::ZERO {
                        if let Some(e) = self.irradiance_at(scene, tree, hit, n, counters) {
                            l += rho * e * std::f32::consts::FRAC_1_PI;
                        }
                    }
                }
                None => {
                    if let Some(m) = self.incident_matrix(scene, tree, hit, n, counters) {
                        l += shade_matrix(scene, hit, material, v.wo, &m);
                    }
                }
            }
        }
        l
    }

    /// The global (indirect) light reflected at `v`, gathered one bounce away: a BSDF-sampled
    /// ray follows specular vertices to the first vertex `z` with a non-delta lobe, where the
    /// light leaving `z` towards `v` is direct (shadow ray) + global + caustic octrees.
    /// Emission met on the way is skipped: it is direct light at `v` (next-event estimation)
    /// or a caustic at `v` (caustic octree). The paths counted are therefore exactly those
    /// of the global photon map — light that met at least one non-specular surface before
    /// `v` — so direct + caustic + gathered global still partition the light at `v`.
    /// `vertex` is `v`'s index along the camera path (1 = first surface).
    #[allow(clippy::too_many_arguments)]
    fn gathered_global(
        &self,
        scene: &Scene,
        v: &Vertex,
        material: &Material,
        vertex: u32,
        max_depth: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
    ) -> Color {
        // Surface vertices must stay below max_depth (Mitsuba's count, the light is the last).
        if vertex + 2 > max_depth {
            return Color::ZERO;
        }
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = material.sample(&scene.images, v.hit.uv, v.wo, u_lobe, u) else { return Color::ZERO };
        if !bs.weight.is_finite() {
            return Color::ZERO;
        }
        let ray = v.hit.spawn(v.hit.frame.to_world(bs.wi));
        // `z` is vertex `vertex + 1 + bounces`: the chain may hold max_depth - vertex - 1 of them.
        let first = vertex + 1;
        let walk = walk_specular(scene, ray, None, max_depth - first, false, sampler, counters);
        let Some(z) = walk.vertex else { return Color::ZERO };
        let mz = &scene.materials[z.hit.material as usize];
        let mut l = self.indirect_from(scene, &z, mz, counters, true, true);
        if first + z.bounces < max_depth {
            l += direct_light(scene, &z.hit, mz, z.wo, sampler, counters);
        }
        bs.weight * z.throughput * l
    }

    fn leaf_colour(&self, hit: &SurfaceHit, d: Vec3) -> Color {
        let Some(leaf) = self.global.leaf_at(hit.p) else { return Color::ZERO };
        if !leaf.valid {
            return Color::splat(0.02);
        }
        let h_max = self.global.h_max().max(1) as f32;
        let hue = leaf.depth as f32 / h_max;
        let base = hsv(hue * 0.8, 0.7, 0.9);
        // Darken near cell borders (in units of the cell edge).
        let e = leaf.bounds.extent().x.max(1e-12);
        let rel = ((hit.p - leaf.bounds.min) / e).clamp(Vec3::ZERO, Vec3::ONE);
        let edge = rel.min(Vec3::ONE - rel);
        // Ignore the axis the surface is flat along (the one most aligned with the normal).
        let n = facing(hit.frame.n, -d).abs();
        let dist = if n.x >= n.y && n.x >= n.z {
            edge.y.min(edge.z)
        } else if n.y >= n.z {
            edge.x.min(edge.z)
        } else {
            edge.x.min(edge.y)
        };
        if dist < 0.02 {
            base * 0.15
        } else {
            base
        }
    }
}

/// The surfaces the geometry-area estimator clips its gathering boxes to (`caches::octree`'s
/// [`Surfaces`]): the meshes' triangles and the analytic spheres of the materials with a smooth
/// lobe (those that store photons), world space.
pub fn estimator_surfaces(scene: &Scene) -> (Vec<[Vec3; 3]>, Vec<AnalyticSphere>) {
    let spheres = scene
        .analytic_spheres_where(Material::has_smooth_lobe)
        .into_iter()
        .map(|(center, radius, inward)| AnalyticSphere { center, radius, inward })
        .collect();
    (scene.mesh_triangles_where(Material::has_smooth_lobe), spheres)
}

/// `Σ_c f_c(wo, d_c) cos θ(d_c) |m_c|` with `m_c` the columns of the blended matrix.
#[inline]
pub(super) fn shade_matrix(scene: &Scene, hit: &SurfaceHit, material: &Material, wo: Vec3, m: &Mat3) -> Color {
    let frame: &Frame = &hit.frame;
    let mut out = Color::ZERO;
    for c in 0..3 {
        let col = m.col(c);
        let len = col.length();
        if !(len > 0.0) || !len.is_finite() {
            continue;
        }
        let wi = frame.to_local(col / len);
        let f = material.eval(&scene.images, hit.uv, wo, wi);
        out[c] += f[c] * len;
    }
    out
}

fn hsv(h: f32, s: f32, v: f32) -> Color {
    let h6 = (h.fract() * 6.0).max(0.0);
    let i = h6.floor() as i32;
    let f = h6 - i as f32;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    match i % 6 {
        0 => Color::new(v, t, p),
        1 => Color::new(q, v, p),
        2 => Color::new(p, v, t),
        3 => Color::new(p, q, v),
        4 => Color::new(t, p, v),
        _ => Color::new(v, p, q),
    }
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::test_scenes::{check_furnace, furnace_box_scene, furnace_scene, image_mean, sky_plane_scene};
    use crate::integrators::Integrator;
    use crate::render::{render, RenderSettings};

    fn render_mean(scene: &Scene, s: OctreeIntegratorSettings, spp: u32) -> (f64, OctreeBuildStats, RayCounters) {
        let o = OctreeIntegrator::build(scene, s).unwrap();
        let stats = o.stats.clone();
        let (img, st) = render(scene, &Integrator::Octree(Box::new(o)), &RenderSettings { spp, ..Default::default() }, &|_, _| {});
        assert!(img.data.iter().all(|c| c.is_finite() && c.min_element() >= 0.0));
        (image_mean(&img.data), stats, st.counters)
    }

    /// The furnace: a closed cube emitting Le = 1 with albedo ρ = 0.5 has radiance 2 and
    /// indirect irradiance π everywhere (`test_scenes::furnace_box_scene`). The incident field
    /// is uniform, so an octree leaf's estimate is unbiased wherever its gathering box holds
    /// only planar walls whose triangles it clips (the geometry-area estimator); what is left
    /// is photon noise. The image (the middle of one wall) reads a few dozen leaves, so its
    /// mean carries the noise of a few thousand photons: measured over photon seeds 0–3 with
    /// 200 000 photons, the irradiance mean spread over 3.145–3.213 (σ ≈ 1%), with 1 000 000
    /// 3.117 and 3.153. With 400 000 photons σ ≈ 0.7%; the render adds the next-event
    /// estimate's noise (256 pixels x 16 spp, on a quarter of the radiance: ~0.5%). The bound,
    /// 3%, is 4σ.
    #[test]
    fn furnace_is_analytic() {
        let scene = furnace_box_scene(0.5, 1.0);
        let mut means = Vec::new();
        for view in [OctreeView::Render, OctreeView::Irradiance] {
            let mut s = OctreeIntegratorSettings { view, ..Default::default() };
            s.photons.photons = 400_000;
            let (mean, stats, counters) = render_mean(&scene, s, 16);
            assert_eq!(stats.caustic_photons, 0);
            assert!(stats.global.valid_leaves > 8 && counters.cache_queries > 0, "{stats:?}");
            means.push(mean);
        }
        check_furnace(means[0], means[1], 0.03, "octree");
        // Gathering one bounce away reads the same octree where the gather rays land.
        let mut s = OctreeIntegratorSettings { gather: true, ..Default::default() };
        s.photons.photons = 400_000;
        let (gathered, _, _) = render_mean(&scene, s, 16);
        eprintln!("octree --gather: furnace render {gathered:.4} (2)");
        assert!((gathered - 2.0).abs() < 2.0 * 0.03, "gathered render {gathered}, expected 2");
    }

    /// The furnace in an analytic sphere (`test_scenes::furnace_scene`: closed, emitting
    /// Le = 1 inwards, ρ = 0.5, camera at the centre; radiance 2 everywhere). Before the
    /// sphere was clipped exactly, the geometry-area estimator saw it as a tessellation its
    /// photons did not lie on: mean 71.5 (`--gather`: 461,040). The octree carries a quarter
    /// of the radiance (ρ E / π = 0.5 of 2), so the render's error is a quarter of the
    /// irradiance's: with 400 000 photons the irradiance mean's photon noise is ~0.7% (as in
    /// the cube's furnace), the render's ~0.2% plus the direct light's ~0.3% (256 pixels x 16
    /// spp): the bound, 1%, is about 3σ; the irradiance view keeps the cube's 3%. No pixel may
    /// exceed 1.5x the truth (the blow-ups were 700x).
    #[test]
    fn furnace_in_an_analytic_sphere_is_analytic() {
        let scene = furnace_scene(0.5, 1.0);
        for gather in [false, true] {
            let mut means = Vec::new();
            for view in [OctreeView::Render, OctreeView::Irradiance] {
                let mut s = OctreeIntegratorSettings { view, gather, ..Default::default() };
                s.photons.photons = 400_000;
                let o = OctreeIntegrator::build(&scene, s).unwrap();
                assert_eq!(o.stats.global.geometry_fallback_leaves, 0, "{:?}", o.stats.global);
                let (img, _) =
                    render(&scene, &Integrator::Octree(Box::new(o)), &RenderSettings { spp: 16, ..Default::default() }, &|_, _| {});
                let max = img.data.iter().map(|c| c.max_element()).fold(0.0f32, f32::max);
                let truth = if view == OctreeView::Render { 2.0 } else { std::f32::consts::PI };
                assert!(max < 1.5 * truth, "gather {gather}, {view:?}: pixel {max}");
                means.push(image_mean(&img.data));
            }
            eprintln!("octree sphere furnace, gather {gather}: render {:.4} (2), irradiance {:.4} (π)", means[0], means[1]);
            assert!((means[0] - 2.0).abs() < 0.01 * 2.0, "gather {gather}: render {}", means[0]);
            if !gather {
                check_furnace(means[0], means[1], 0.03, "octree, analytic sphere");
            }
        }
    }

    /// A Lambertian plane under a constant sky: all its light is direct (`ρ L_sky`), so the
    /// photon pass stores nothing, the octree adds nothing (direct light is never counted
    /// twice) and the render is the NEE estimate alone. Noise: one light sample per camera
    /// sample, `4 ρ L cos θ` on the upper half of a uniform sphere of directions, of relative
    /// standard deviation √(8/3 − 1) = 1.29; 256 pixels x 256 spp make it 0.5% for the image
    /// mean; the bound is 2% (4σ).
    #[test]
    fn plane_under_a_constant_sky_gets_direct_light_only() {
        let (rho, sky) = (0.5, 2.0);
        let scene = sky_plane_scene(rho, sky);
        let mut s = OctreeIntegratorSettings::default();
        s.photons.photons = 50_000;
        let (render_mean_, stats, _) = render_mean(&scene, s.clone(), 256);
        assert_eq!((stats.global_photons, stats.caustic_photons), (0, 0), "{stats:?}");
        let expect = (rho * sky) as f64;
        eprintln!("octree: plane under a constant sky {render_mean_:.4} ({expect})");
        assert!((render_mean_ / expect - 1.0).abs() < 0.02, "render {render_mean_}, expected {expect}");
        s.view = OctreeView::Irradiance;
        let (irradiance, _, _) = render_mean(&scene, s, 4);
        assert_eq!(irradiance, 0.0, "indirect irradiance under an open sky");
    }
}
