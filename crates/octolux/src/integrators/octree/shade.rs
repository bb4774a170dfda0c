//! Where the `octree` integrator's paths end, and what the octrees give there: the policy of
//! the path loop ([`Ending`], `integrators::pathloop`; docs/octree.md "Ending paths in the
//! cache").
//!
//! **The termination rule** (`mode = terminate`). A path ends at a vertex `x` when
//! - `x` has a lobe at least `min_alpha` rough ([`Material::has_wide_lobe`]);
//! - the path's ray cone at `x` is at least `footprint` times as wide as the global octree's
//!   leaf holding `x`: after a diffuse bounce, a segment at least half a leaf long (the cone's
//!   rules are in `integrators::pathloop`);
//! - with a bounded `max_depth`, `x` is the path's second vertex ([`Mode::end_vertex`]);
//! - the global octree has a value there (some valid leaf passes the leak test).
//!
//! **The cache's light at `x`**: the global octree's, shaded with the lobes at least `min_alpha`
//! wide ([`shade_matrix`]; the irradiance query when they are Lambertian), plus the caustic
//! octree's where the caustic leaf holding `x` has at least `caustic_photons` photons; elsewhere
//! the loop traces the caustic light itself (a caustic leaf with few photons carries a large
//! value of large variance: fireflies). With `mode = paper` the path ends at the first vertex
//! with a non-delta lobe after a specular chain, every lobe is the cache's and the caustic
//! octree is always read.

use super::leak::keep_leaf;
use super::reach::LeakData;
use super::{LeakTest, Mode, OctreeIntegrator};
use crate::caches::Octree;
use crate::integrators::common::RayCounters;
use crate::integrators::pathloop::{CacheEnd, CacheVertex, Ending};
use crate::math::Color;
use crate::sampling::Sampler;
use crate::scene::material::Material;
use crate::scene::{Scene, SurfaceHit};
use glam::{Mat3, Vec3};

impl Ending for OctreeIntegrator {
    const FOOTPRINT: bool = true;

    fn end(&self, scene: &Scene, v: &CacheVertex, sampler: &mut Sampler, counters: &mut RayCounters) -> Option<CacheEnd> {
        let s = &self.settings;
        let bounded = s.max_depth >= 0;
        let (min_alpha, caustics) = match s.mode {
            Mode::Paper => {
                if !v.specular_chain {
                    return None;
                }
                (0.0, true)
            }
            Mode::Terminate => {
                if bounded && v.index != Mode::Terminate.end_vertex() {
                    return None;
                }
                if !v.material.has_wide_lobe(&scene.images, v.hit.uv, s.min_alpha) {
                    return None;
                }
                let leaf = self.global.leaf_at(v.hit.p)?;
                if !(v.footprint >= s.footprint * leaf.bounds.extent().x) {
                    return None;
                }
                (s.min_alpha, self.caustic_trusted(v.hit.p))
            }
        };
        let radiance = self.cache_radiance(scene, v, min_alpha, caustics, sampler, counters);
        match (radiance, s.mode) {
            (Some(radiance), _) => Some(CacheEnd { radiance, min_alpha, caustics }),
            // the paper's renderer reads nothing where the octree has nothing
            (None, Mode::Paper) => Some(CacheEnd { radiance: Color::ZERO, min_alpha, caustics }),
            (None, Mode::Terminate) => None,
        }
    }
}

impl OctreeIntegrator {
    /// Whether the caustic octree's value at `p` is used ([`OctreeIntegrator::cache_radiance`]):
    /// no caustic photon was stored at all (the caustic light is negligible), or the caustic
    /// leaf holding `p` has at least `caustic_photons` photons.
    #[inline]
    fn caustic_trusted(&self, p: Vec3) -> bool {
        match &self.caustic {
            None => true,
            Some(c) => c.leaf_at(p).is_some_and(|l| l.photons >= self.settings.caustic_photons),
        }
    }

    /// The indirect light the octrees give at `v`, reflected towards `v.wo` by the lobes at
    /// least `min_alpha` wide: the global octree's, and the caustic octree's with `caustics`.
    /// `None` when the global octree has no value there. On an inserted object the global
    /// octree's volume query, near one the ambient-occlusion correction (`insert.rs`).
    pub(super) fn cache_radiance(
        &self,
        scene: &Scene,
        v: &CacheVertex,
        min_alpha: f32,
        caustics: bool,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
    ) -> Option<Color> {
        if self.inserted.shapes.contains(&v.hit.shape) {
            return self.inserted_indirect(scene, v, min_alpha, counters);
        }
        let mut l = self.tree_radiance(scene, &self.global, v, min_alpha, counters)?;
        if caustics {
            if let Some(c) = &self.caustic {
                l += self.tree_radiance(scene, c, v, min_alpha, counters).unwrap_or(Color::ZERO);
            }
        }
        Some(match self.inserted.ao {
            Some(ao) if ao.rays > 0 && !self.inserted.shapes.is_empty() && l != Color::ZERO => {
                l * self.unoccluded_by_inserted(scene, v, ao, sampler, counters)
            }
            _ => l,
        })
    }

    /// `tree`'s light at `v` reflected by the lobes at least `min_alpha` wide (module docs).
    fn tree_radiance(&self, scene: &Scene, tree: &Octree, v: &CacheVertex, min_alpha: f32, counters: &mut RayCounters) -> Option<Color> {
        let (hit, n) = (v.hit, v.n);
        // Lambertian: ρ/π E(N) is what shade_matrix returns, from the cheaper irradiance query.
        match v.material.lambertian_albedo(&scene.images, hit.uv, v.wo) {
            Some(rho) => {
                let e = self.irradiance_at(scene, tree, hit, n, counters)?;
                Some(rho * e * std::f32::consts::FRAC_1_PI)
            }
            None => {
                let m = self.incident_matrix(scene, tree, hit, n, counters)?;
                Some(shade_matrix(scene, hit, v.material, v.wo, &m, min_alpha))
            }
        }
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
    pub(super) fn incident_matrix(
        &self,
        scene: &Scene,
        tree: &Octree,
        hit: &SurfaceHit,
        n: Vec3,
        counters: &mut RayCounters,
    ) -> Option<Mat3> {
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
}

/// `Σ_c f_c(wo, d_c) cos θ(d_c) |m_c|` with `m_c` the columns of the blended matrix and `f` the
/// lobes at least `min_alpha` wide (module docs of `octree`).
#[inline]
pub(crate) fn shade_matrix(scene: &Scene, hit: &SurfaceHit, material: &Material, wo: Vec3, m: &Mat3, min_alpha: f32) -> Color {
    let mut out = Color::ZERO;
    for c in 0..3 {
        let col = m.col(c);
        let len = col.length();
        if !(len > 0.0) || !len.is_finite() {
            continue;
        }
        let wi = hit.frame.to_local(col / len);
        let f = material.eval_split(&scene.images, hit.uv, wo, wi, min_alpha).wide;
        out[c] += f[c] * len;
    }
    out
}
