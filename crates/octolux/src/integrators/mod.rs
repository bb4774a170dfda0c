//! Integrators: closed set of rendering methods, each with one serde settings struct that
//! serves the CLI, files and tests.
//!
//! Every integrator estimates the radiance arriving at the camera along a primary ray; the
//! render loop ([`crate::render`]) handles pixels, samples and the reconstruction filter.

pub mod christensen;
pub mod octree;
pub mod path;
pub mod photonmap;
pub mod ward;

use crate::math::{Color, Ray};
use crate::sampling::Sampler;
use crate::scene::material::Material;
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Counters an integrator updates while tracing (per worker, summed at the end).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub struct RayCounters {
    /// Closest-hit rays (camera and continuation rays).
    pub rays: u64,
    /// Shadow (occlusion) rays.
    pub shadow_rays: u64,
    /// Radiance-cache lookups (octree and other caches).
    pub cache_queries: u64,
    /// Wall time spent inside cache lookups, nanoseconds (measured with `Instant`, whose own
    /// cost of ~20-40 ns per lookup is included).
    pub cache_query_ns: u64,
}

impl std::ops::AddAssign for RayCounters {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.cache_queries += o.cache_queries;
        self.cache_query_ns += o.cache_query_ns;
    }
}

/// A prepared integrator.
pub enum Integrator {
    Path(path::PathSettings),
    /// The paper's ray tracer over a built global + caustic octree.
    Octree(Box<octree::OctreeIntegrator>),
    /// Jensen's photon map with final gathering (baseline).
    PhotonMap(Box<photonmap::PhotonMapIntegrator>),
    /// Ward's irradiance cache with photon-computed samples (baseline).
    Ward(Box<ward::WardIntegrator>),
    /// Christensen's precomputed irradiance photons, optionally with a Ward cache (baseline).
    Christensen(Box<christensen::ChristensenIntegrator>),
}

impl Integrator {
    /// Short name used in stats and the CLI.
    pub fn name(&self) -> &'static str {
        match self {
            Integrator::Path(_) => "path",
            Integrator::Octree(_) => "octree",
            Integrator::PhotonMap(_) => "photonmap",
            Integrator::Ward(_) => "ward",
            Integrator::Christensen(_) => "christensen",
        }
    }

    /// Radiance along a primary ray.
    #[inline]
    pub fn li(&self, scene: &Scene, ray: Ray, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        match self {
            Integrator::Path(s) => path::li(s, scene, ray, sampler, counters),
            Integrator::Octree(o) => o.li(scene, ray, sampler, counters),
            Integrator::PhotonMap(o) => o.li(scene, ray, sampler, counters),
            Integrator::Ward(o) => o.li(scene, ray, sampler, counters),
            Integrator::Christensen(o) => o.li(scene, ray, sampler, counters),
        }
    }
}

/// Next-event estimation of direct light at a surface hit: one light sample (chosen by power),
/// one shadow ray, no MIS. Used by the cache integrators, whose indirect light comes from a
/// cache rather than a BSDF-sampled continuation to combine with.
pub fn direct_light(
    scene: &Scene,
    hit: &SurfaceHit,
    material: &Material,
    wo: Vec3,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    let u_sel = sampler.next_1d();
    let u = sampler.next_2d();
    let Some(ls) = scene.lights.sample_li(hit.p, u_sel, u) else { return Color::ZERO };
    if !(ls.pdf > 0.0) || ls.li == Color::ZERO {
        return Color::ZERO;
    }
    let f = material.eval(&scene.images, hit.uv, wo, hit.frame.to_local(ls.wi));
    if f == Color::ZERO {
        return Color::ZERO;
    }
    counters.shadow_rays += 1;
    if scene.occluded(&hit.spawn_to(ls.wi, ls.dist)) {
        return Color::ZERO;
    }
    f * ls.li / ls.pdf
}

/// Power heuristic (β = 2) for multiple importance sampling.
#[inline]
pub fn mis_power(pdf_a: f32, pdf_b: f32) -> f32 {
    let a2 = pdf_a * pdf_a;
    let b2 = pdf_b * pdf_b;
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else if a2.is_infinite() {
        1.0
    } else {
        0.0
    }
}
