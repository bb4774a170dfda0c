//! Where the `octree` integrator's paths end, and what the octrees give there: the policy of
//! the path loop ([`Ending`], `integrators::pathloop`; docs/guide/octree.md "Ending paths in the
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
//! value of large variance: fireflies). The caustic octree is read by the same rule at a vertex
//! where the path goes on (a camera vertex too, as the paper reads it), the loop then leaving
//! out the caustic light it would trace from there. With `mode = paper` the path ends at the first vertex
//! with a non-delta lobe after a specular chain, every lobe is the cache's and the caustic
//! octree is always read.

use super::leak::keep_leaf;
use super::{LeakTest, Mode, OctreeIntegrator, Tree, Q_MIN};
use crate::integrators::common::RayCounters;
use crate::integrators::pathloop::{CacheEnd, CacheVertex, ControlVariate, Ending, Residual};
use crate::math::Color;
use crate::sampling::Sampler;
use crate::scene::material::Material;
use crate::scene::{Scene, SurfaceHit};
use glam::{Mat3, Vec3};

impl Ending for OctreeIntegrator {
    const FOOTPRINT: bool = true;

    fn end(&self, scene: &Scene, v: &CacheVertex, sampler: &mut Sampler, counters: &mut RayCounters) -> Option<CacheEnd> {
        let s = &self.settings;
        let read = |ends: bool, min_alpha: f32, caustics: bool| CacheEnd {
            radiance: Color::ZERO,
            min_alpha,
            ends,
            caustics,
            light_sample_only: ends
                && caustics
                && !s.tail
                && s.mode != Mode::Unbiased
                && v.material.only_wide_lobes(&scene.images, v.hit.uv, min_alpha),
            residual: None,
        };
        match s.mode {
            Mode::Paper => {
                if !v.specular_chain {
                    return None;
                }
                // the paper's renderer reads nothing where the octree has nothing
                let radiance = self.cache_radiance(scene, v, 0.0, true, sampler, counters).unwrap_or(Color::ZERO);
                Some(CacheEnd { radiance, ..read(true, 0.0, true) })
            }
            Mode::Terminate | Mode::Unbiased => {
                let at_end = s.max_depth < 0 || v.index == s.mode.end_vertex();
                // without bias the cache is read only where the path may end
                if (!at_end && s.mode == Mode::Unbiased) || !v.material.has_wide_lobe(&scene.images, v.hit.uv, s.min_alpha) {
                    return None;
                }
                let caustics = self.caustic_trusted(v.hit.p);
                if s.mode == Mode::Unbiased && self.inserted.shapes.is_empty() {
                    // one descent gives the footprint rule's leaf and the control variate's matrix
                    let (edge, m) = counters.time_query(|| self.global.leaf_edge_and_matrix(v.hit.p, v.n))?;
                    if !(v.footprint >= s.footprint * edge) {
                        return None;
                    }
                    let (radiance, linear) = self.leaf_value(scene, v, m?, caustics, counters);
                    let residual = self.residual(v, radiance, linear, sampler);
                    return Some(CacheEnd { radiance, residual, ..read(true, s.min_alpha, caustics) });
                }
                let ends = at_end && self.global.leaf_at(v.hit.p).is_some_and(|leaf| v.footprint >= s.footprint * leaf.bounds.extent().x);
                if ends && s.mode == Mode::Unbiased {
                    // an inserted object's scene: the biased renderer's value, a constant variate
                    let radiance = self.cache_radiance(scene, v, s.min_alpha, caustics, sampler, counters)?;
                    let residual = self.residual(v, radiance, None, sampler);
                    return Some(CacheEnd { radiance, residual, ..read(true, s.min_alpha, caustics) });
                }
                if ends {
                    if let Some(radiance) = self.cache_radiance(scene, v, s.min_alpha, caustics, sampler, counters) {
                        return Some(CacheEnd { radiance, ..read(true, s.min_alpha, caustics) });
                    }
                }
                // the path goes on; the caustic octree gives the caustic light where it is
                // trusted (not without bias: the loop traces it then)
                if !caustics || s.mode == Mode::Unbiased || self.caustic.is_none() || self.inserted.shapes.contains(&v.hit.shape) {
                    return None;
                }
                let radiance = self.tree_radiance(scene, Tree::Caustic, v, s.min_alpha, counters).unwrap_or(Color::ZERO);
                Some(CacheEnd { radiance, ..read(false, s.min_alpha, true) })
            }
        }
    }
}

impl OctreeIntegrator {
    /// Whether the caustic octree's value at `p` is used ([`OctreeIntegrator::cache_radiance`]): no
    /// caustic photon was stored at all (the caustic light is negligible), or the caustic leaf
    /// holding `p` has at least `caustic_photons` photons. The footprint rule is not applied to
    /// it: its leaves are far finer than the global octree's, and reading them only where the
    /// cone was wider took cornell-spheres' relMSE (1M photons, 64 spp) from 7.0e-4 to 7.2e-3.
    #[inline]
    fn caustic_trusted(&self, p: Vec3) -> bool {
        match &self.caustic {
            None => true,
            Some(c) => c.leaf_at(p).is_some_and(|l| l.photons >= self.settings.caustic_photons),
        }
    }

    /// The cache's value `C` at an ending under `mode = unbiased` and, where the wide lobes
    /// are Lambertian, the linear field of its control variate (`integrators::pathloop`, "The
    /// residual"; docs/guide/octree.md "Without bias"). `m` is `M(N)` of the global octree's
    /// valid leaf holding `v` alone, without the §7 blend over its neighbours and without the
    /// leak test: any `C` independent of the continuation keeps the estimate unbiased, and the
    /// leaf alone correlates with the continuation as well as the blend does at a fraction of
    /// its cost (docs/lab/2026-12-07-unbiased-leaf-cv.md); the caustic octree's leaf is added
    /// with `caustics`. Where the wide lobes are Lambertian (of albedo `ρ`), the control variate
    /// is the linear incident field `L̃_c(ω) = 3/(2π) m_c · ω` of the matrix's columns `m_c`:
    /// over the hemisphere of `N` it has the irradiance vector `m_c` (`∫ ω ωᵀ dω = 2π/3 I`
    /// there), so its reflected mean is `ρ/π m_c · N = C` exactly. Elsewhere it is the
    /// constant `C` ([`shade_matrix`]).
    fn leaf_value(&self, scene: &Scene, v: &CacheVertex, mut m: Mat3, caustics: bool, counters: &mut RayCounters) -> (Color, Option<Mat3>) {
        if caustics {
            if let Some(mc) = self.caustic.as_ref().and_then(|c| counters.time_query(|| c.leaf_incident_matrix(v.hit.p, v.n))) {
                m += mc;
            }
        }
        match v.material.lambertian_albedo(&scene.images, v.hit.uv, v.wo) {
            Some(rho) => {
                let e = Color::new(m.col(0).dot(v.n), m.col(1).dot(v.n), m.col(2).dot(v.n));
                (rho * e * std::f32::consts::FRAC_1_PI, Some(m * (1.5 * std::f32::consts::FRAC_1_PI)))
            }
            None => (shade_matrix(scene, v.hit, v.material, v.wo, &m, self.settings.min_alpha), None),
        }
    }

    /// Whether the path is traced on from an ending of value `c` under `mode = unbiased`, drawn
    /// here: survival in proportion to the share of the path's light the cache puts beyond the
    /// vertex, scaled by the setting `q` (docs/guide/octree.md "Choosing q"): the cache drives
    /// the roulette. `linear`: the control variate's field ([`OctreeIntegrator::leaf_value`]),
    /// else the constant `c`.
    fn residual(&self, v: &CacheVertex, c: Color, linear: Option<Mat3>, sampler: &mut Sampler) -> Option<Residual> {
        let bc = crate::math::max_component(v.throughput * c);
        let share = bc / (crate::math::max_component(v.gathered) + bc);
        let q = if share.is_finite() { (2.0 * self.settings.q * share).clamp(Q_MIN, 1.0) } else { 1.0 };
        (sampler.next_1d() < q).then_some(Residual {
            q,
            cv: match linear {
                Some(a) => ControlVariate::Linear(a),
                None => ControlVariate::Constant(c),
            },
        })
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
        let mut l = self.tree_radiance(scene, Tree::Global, v, min_alpha, counters)?;
        if caustics {
            l += self.tree_radiance(scene, Tree::Caustic, v, min_alpha, counters).unwrap_or(Color::ZERO);
        }
        Some(match self.inserted.ao {
            Some(ao) if ao.rays > 0 && !self.inserted.shapes.is_empty() && l != Color::ZERO => {
                l * self.unoccluded_by_inserted(scene, v, ao, sampler, counters)
            }
            _ => l,
        })
    }

    /// `tree`'s light at `v` reflected by the lobes at least `min_alpha` wide (module docs).
    pub(super) fn tree_radiance(
        &self,
        scene: &Scene,
        tree: Tree,
        v: &CacheVertex,
        min_alpha: f32,
        counters: &mut RayCounters,
    ) -> Option<Color> {
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

    /// `tree`'s irradiance at `hit` for normal `n` (on the viewer's side), leak control applied;
    /// `None` where no valid leaf passes (or the tree is absent).
    pub fn irradiance_at(&self, scene: &Scene, tree: Tree, hit: &SurfaceHit, n: Vec3, counters: &mut RayCounters) -> Option<Color> {
        let (octree, planes) = (self.tree(tree)?, self.planes(tree == Tree::Caustic));
        let mut rays = 0u64;
        let e = counters.time_query(|| match self.leak() {
            LeakTest::VisibleSample => {
                octree.irradiance_where(hit.p, n, |q| keep_leaf(scene, planes, hit, n, &q, &mut rays).then_some(1.0))
            }
            _ => octree.irradiance(hit.p, n),
        });
        counters.shadow_rays += rays;
        e
    }

    /// `tree`'s incident matrix at `hit` for normal `n`, leak control applied.
    pub fn incident_matrix(&self, scene: &Scene, tree: Tree, hit: &SurfaceHit, n: Vec3, counters: &mut RayCounters) -> Option<Mat3> {
        let (octree, planes) = (self.tree(tree)?, self.planes(tree == Tree::Caustic));
        let mut rays = 0u64;
        let m = counters.time_query(|| match self.leak() {
            LeakTest::VisibleSample => {
                octree.incident_matrix_where(hit.p, n, |q| keep_leaf(scene, planes, hit, n, &q, &mut rays).then_some(1.0))
            }
            _ => octree.incident_matrix(hit.p, n),
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
