//! The `octree` integrator: the path tracer's loop ([`super::pathloop`]) ending paths in the
//! paper's incident-radiance octrees (Pacanowski, Granier & Schlick 2005): a global octree for
//! the indirect light and a caustic octree for the light that reached a surface through
//! specular bounces only (§8; `docs/guide/octree.md`).
//!
//! **Where a path ends** ([`Mode`], docs/guide/octree.md "Ending paths in the cache"). With
//! `mode = terminate` (the default) a path ends at a vertex when its ray cone is at least
//! `footprint` times as wide as the global octree's leaf there and the vertex has a lobe at
//! least `min_alpha` rough (`shade.rs`): a glossy camera vertex, or a vertex close to the one
//! before it (a corner), is traced on, as NVIDIA SHaRC and neural radiance caching do. With
//! `mode = paper` the path ends at the first vertex with a non-delta lobe after a specular
//! chain from the camera, as the paper's ray tracer does (§8).
//!
//! **How the cache shades a surface** (`shade.rs`). Column `c` of the blended matrix `M(N)` is
//! the irradiance vector `m_c` of colour channel `c` (§4): its direction `d_c = m_c/|m_c|` is
//! the mean incident direction and `|m_c|` its strength. Each channel's incident light is
//! taken as arriving from `d_c`: `L_o,c = f_c(wo, d_c) cos θ(d_c) |m_c|`. For a Lambertian
//! surface this is `ρ/π (m_c·N) = ρ E_c / π`, the paper's formula; for a glossy lobe it
//! evaluates the lobe in the mean incident direction, which is why only lobes at least
//! `min_alpha` rough are shaded from the cache.
//!
//! **Leak control** ([`LeakTest`], `leak.rs`, `docs/guide/octree.md` "Leak control"): every octree
//! read drops the leaves whose photons the shading point cannot see, so light does not pass
//! through walls thinner than the query box. The global tree's depth limit is automatic by
//! default (`caches::octree::auto_depth`).
//!
//! Rooms: `settings.rs` (the settings and their checks), `shade.rs` (the termination rule and
//! the cache's light at a vertex), `leak.rs` (the leak test), `insert.rs` (objects inserted
//! into baked lighting), `views.rs` (the irradiance and leaf views).

mod direct;
pub mod insert;
mod leak;
#[cfg(test)]
pub(crate) mod leak_tests;
pub mod rebake;
mod settings;
mod shade;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod unbiased_tests;
mod views;

pub use leak::{ANCHOR_LIFT, PLANES_REACH};

pub use settings::{
    LeakTest, Mode, OctreeIntegratorSettings, OctreeView, CAUSTIC_H_MAX, CAUSTIC_N_MAX, DEFAULT_CAUSTIC_PHOTONS, DEFAULT_FOOTPRINT,
    DEFAULT_MIN_ALPHA, DEFAULT_Q, MAX_SPECULAR_CHAIN, Q_MIN,
};
pub(super) use shade::shade_matrix;

use super::common::RayCounters;
use super::pathloop::{self, Depths};
use crate::caches::octree::{AnalyticSphere, LeafPlanes, OctreeParts, PartsError, Surfaces};
use crate::caches::{Octree, OctreeError, OctreeSettings, OctreeStats};
use crate::math::{Color, Ray, RayDifferential};
use crate::photon::trace::{trace_photons, PhotonError};
use crate::sampling::Sampler;
use crate::scene::lights::LightSelection;
use crate::scene::material::Material;
use crate::scene::Scene;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Errors while building the octrees.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error(transparent)]
    Photons(#[from] PhotonError),
    #[error("global octree: {0}")]
    Global(OctreeError),
    #[error("caustic octree: {0}")]
    Caustic(OctreeError),
    #[error("{0}")]
    Settings(String),
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
    /// The free-space tree's, if baked ([`OctreeIntegrator::volume`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume: Option<OctreeStats>,
    /// `F_m`: bytes of the octrees as stored (the free-space tree's included).
    pub bytes: usize,
}

/// One of the integrator's two octrees.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tree {
    /// The global octree (indirect light).
    Global,
    /// The caustic octree (light through delta bounces only).
    Caustic,
}

/// A built `octree` integrator: settings plus the two octrees (read-only while rendering).
pub struct OctreeIntegrator {
    pub settings: OctreeIntegratorSettings,
    pub global: Octree,
    pub caustic: Option<Octree>,
    /// The volumetric solution (`bake --volume`; [`OctreeIntegrator::fill_atmosphere`]): a
    /// free-space tree over the global octree's root cube, every leaf atmospheric
    /// (`caches/octree/refine.rs`, "The free-space tree"). The volume query of an inserted
    /// object reads it; without it, the global octree's.
    pub volume: Option<Octree>,
    pub stats: OctreeBuildStats,
    /// [`LeafPlanes`] of the global and the caustic tree for the leak test (index 0 and 1),
    /// derived from the scene by [`OctreeIntegrator::prepare`]: without them every segment of
    /// the test is a ray.
    planes: [Option<LeafPlanes>; 2],
    /// Objects inserted into the baked lighting (`insert.rs`); none by default.
    pub inserted: insert::Inserted,
}

/// A built `octree` integrator as plain data: what a cache file holds (docs/guide/baking.md).
/// Extend [`OctreeParts`] for per-leaf data, this struct for per-integrator data.
#[derive(Clone, Debug, PartialEq)]
pub struct OctreeIntegratorParts {
    pub settings: OctreeIntegratorSettings,
    pub global: OctreeParts,
    pub caustic: Option<OctreeParts>,
    /// The free-space tree, if baked (its settings are the global octree's).
    pub volume: Option<OctreeParts>,
    pub stats: OctreeBuildStats,
}

impl OctreeIntegrator {
    /// The integrator as plain data ([`Octree::to_parts`] of both octrees).
    pub fn to_parts(&self) -> OctreeIntegratorParts {
        OctreeIntegratorParts {
            settings: self.settings.clone(),
            global: self.global.to_parts(),
            caustic: self.caustic.as_ref().map(Octree::to_parts),
            volume: self.volume.as_ref().map(Octree::to_parts),
            stats: self.stats.clone(),
        }
    }

    /// The integrator from prebuilt octrees, without tracing a photon: every octree invariant
    /// is checked ([`Octree::from_parts`]) and each octree's settings must be the integrator's.
    /// Renders are bit-identical to those of the integrator the parts came from.
    pub fn from_parts(parts: OctreeIntegratorParts) -> Result<OctreeIntegrator, BuildError> {
        let OctreeIntegratorParts { settings, global, caustic, volume, mut stats } = parts;
        settings.validate().map_err(BuildError::Settings)?;
        let tree = |name: &'static str, want: &OctreeSettings, p: OctreeParts| {
            let err = |source| BuildError::Parts { tree: name, source };
            if p.settings != *want {
                return Err(err(PartsError(format!("its settings {:?} are not the integrator's {want:?}", p.settings))));
            }
            Octree::from_parts(p).map_err(err)
        };
        let global = tree("global", &settings.global, global)?;
        let caustic = caustic.map(|c| tree("caustic", &settings.caustic, c)).transpose()?;
        let volume = volume.map(|v| tree("volume", &settings.global, v)).transpose()?;
        stats.global = global.stats().clone();
        stats.caustic = caustic.as_ref().map(|c| c.stats().clone());
        stats.volume = volume.as_ref().map(|v| v.stats().clone());
        let mut o = OctreeIntegrator { settings, global, caustic, volume, stats, planes: [None, None], inserted: Default::default() };
        o.stats.bytes = o.bytes();
        if let Some(why) = o.missing_leak_samples(&o.settings, false) {
            return Err(BuildError::Settings(why));
        }
        o.prepare_query();
        Ok(o)
    }

    /// Bytes of the octrees as stored: global, caustic and free-space.
    pub fn bytes(&self) -> usize {
        [Some(&self.global), self.caustic.as_ref(), self.volume.as_ref()].into_iter().flatten().map(|t| t.stats().bytes).sum()
    }

    /// Why the queries of `settings` cannot run on these octrees, if they cannot: the
    /// `visible_sample` leak test (`leak`, or `mode = paper`'s own) casts its rays to the
    /// leaves' sampled photons, and so does an inserted object's volume query
    /// (`insert_volume`) unless `leak = none`; a tree read from a cache that kept only the
    /// mean anchors lacks them ([`Octree::has_leak_samples`]).
    pub fn missing_leak_samples(&self, settings: &OctreeIntegratorSettings, insert_volume: bool) -> Option<String> {
        let visible_sample = settings.leak.resolved(settings.mode) == LeakTest::VisibleSample;
        let needs = visible_sample || (insert_volume && settings.leak != LeakTest::None && self.volume.is_none());
        let lacking = !self.global.has_leak_samples() || self.caustic.as_ref().is_some_and(|c| !c.has_leak_samples());
        (needs && lacking).then(|| {
            let what = if !visible_sample {
                "the leak test of an inserted object's volume query"
            } else {
                "the visible_sample leak test (leak = visible_sample, or mode = paper's own)"
            };
            format!(
                "{what} casts rays to the leaves' sampled photons, and these octrees hold only their means (a cache baked for \
                 another leak test): bake with the leak test used here (for an inserted object's volume query, or with \
                 --volume), or render with leak = none"
            )
        })
    }

    /// Build the octrees' flat query lists now (render-time data, `caches/octree/flat.rs`)
    /// instead of at the first query. Under `mode = unbiased` only what a read of one leaf
    /// needs: its endings read no blend ([`Octree::prepare_leaf_query`]; an inserted object's
    /// query builds the rest at its first read).
    pub fn prepare_query(&self) {
        for t in [Some(&self.global), self.caustic.as_ref()].into_iter().flatten() {
            if self.settings.mode == Mode::Unbiased {
                t.prepare_leaf_query();
            } else {
                t.prepare_query();
            }
        }
    }

    /// Derive what the queries need from `scene` (the one the octrees were built for, or a
    /// render scene with the same lighting): the leak test's [`LeafPlanes`] of both trees when the
    /// settings' test uses them (none otherwise). [`OctreeIntegrator::build`] does it; an
    /// integrator made [`OctreeIntegrator::from_parts`] needs it, and again after its settings'
    /// `leak` or `mode` change, for its renders to be the bake's bit for bit.
    pub fn prepare(&mut self, scene: &Scene) {
        let uses = self.leak() == LeakTest::VisibleSample;
        self.planes = [uses.then(|| leak::leaf_planes(scene, &self.global)), None];
        if let (true, Some(c)) = (uses, &self.caustic) {
            self.planes[1] = Some(leak::leaf_planes(scene, c));
        }
    }

    /// The leak test the queries run (`leak`, resolved for the mode).
    #[inline]
    pub fn leak(&self) -> LeakTest {
        self.settings.leak.resolved(self.settings.mode)
    }

    /// What the leak test found (for out.json's `render_report`): per tree, the valid leaves
    /// around which the scene is one plane ([`LeafPlanes`], tested without a ray) and all valid
    /// leaves; the sizes of the query's flat lists (null where no blend was read: `mode =
    /// unbiased` reads single leaves).
    pub fn leak_report(&self) -> serde_json::Value {
        let count = |p: &Option<LeafPlanes>| p.as_ref().map(|p| serde_json::json!({ "planar": p.planar(), "valid": p.len() }));
        let lists = |t: &Octree| t.query_lists().map(|(entries, bytes)| serde_json::json!({ "entries": entries, "bytes": bytes }));
        serde_json::json!({
            "leak_planes_global": count(&self.planes[0]),
            "leak_planes_caustic": count(&self.planes[1]),
            "query_lists_global": lists(&self.global),
            "query_lists_caustic": self.caustic.as_ref().map(lists),
        })
    }

    /// The octree `tree` (`None`: no caustic photon was stored).
    #[inline]
    pub fn tree(&self, tree: Tree) -> Option<&Octree> {
        match tree {
            Tree::Global => Some(&self.global),
            Tree::Caustic => self.caustic.as_ref(),
        }
    }

    /// The leak test's planes of the global (`caustic = false`) or the caustic tree.
    #[inline]
    pub(super) fn planes(&self, caustic: bool) -> Option<&LeafPlanes> {
        self.planes[caustic as usize].as_ref()
    }

    /// Trace the photons and build both octrees over the scene's bounds.
    pub fn build(scene: &Scene, settings: OctreeIntegratorSettings) -> Result<OctreeIntegrator, BuildError> {
        settings.validate().map_err(BuildError::Settings)?;
        settings.global.validate().map_err(BuildError::Global)?;
        settings.caustic.validate().map_err(BuildError::Caustic)?;
        // max_depth bounds the photons' bounces (`traced_photons`)
        let maps = trace_photons(scene, &settings.traced_photons())?;
        let t0 = Instant::now();
        let needs_geometry = |s: &OctreeSettings| s.estimator == crate::caches::Estimator::GeometryArea;
        // Meshes as triangles, spheres analytic: a tessellated sphere would leave its photons
        // off the triangles, its lit side undetected (docs/lab/2026-11-30-octree.md, "Analytic shapes").
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
            volume: None,
            bytes: 0,
        };
        let mut o = OctreeIntegrator { settings, global, caustic, volume: None, stats, planes: [None, None], inserted: Default::default() };
        o.stats.bytes = o.bytes();
        o.prepare(scene);
        o.prepare_query();
        Ok(o)
    }

    /// The path loop's limits.
    fn depths(&self) -> Depths {
        Depths { max_depth: self.settings.max_depth, rr_depth: self.settings.rr_depth, lights: LightSelection::Tree, split: 1 }
    }

    /// Radiance along a primary ray: the path loop ending in the octrees, or a debug view.
    pub fn li(&self, scene: &Scene, ray: Ray, diff: Option<&RayDifferential>, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        match self.settings.view {
            OctreeView::Render => pathloop::li(self, self.depths(), scene, ray, diff, sampler, counters),
            view => self.view(view, scene, ray, diff, sampler, counters),
        }
    }
}

/// The surfaces the geometry-area estimator clips its gathering boxes to (`caches::octree`'s
/// [`Surfaces`]): the meshes' triangles and the analytic spheres of the materials with a smooth
/// lobe (those that store photons), world space.
pub fn estimator_surfaces(scene: &Scene) -> (Vec<[Vec3; 3]>, Vec<AnalyticSphere>) {
    (scene.mesh_triangles_where(Material::has_smooth_lobe), estimator_spheres(scene))
}

/// The analytic spheres of [`estimator_surfaces`].
pub fn estimator_spheres(scene: &Scene) -> Vec<AnalyticSphere> {
    scene
        .analytic_spheres_where(Material::has_smooth_lobe)
        .into_iter()
        .map(|(center, radius, inward)| AnalyticSphere { center, radius, inward })
        .collect()
}
