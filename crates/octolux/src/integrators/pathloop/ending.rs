//! The policy's side of the path loop (`integrators::pathloop`, "Ending a path in a cache",
//! "The residual"): the vertex a policy is offered, what a cache answers there, and the
//! path tracer's policy, which never ends a path.

use crate::integrators::common::RayCounters;
use crate::math::Color;
use crate::sampling::Sampler;
use crate::scene::material::Material;
use crate::scene::{Scene, SurfaceHit};
use glam::{Mat3, Vec3};

/// A surface vertex with a non-delta lobe, offered to [`Ending::end`].
pub struct CacheVertex<'a> {
    pub hit: &'a SurfaceHit,
    pub material: &'a Material,
    /// Direction to the previous vertex, local shading frame.
    pub wo: Vec3,
    /// Shading normal on the side of `wo` (world).
    pub n: Vec3,
    /// The vertex's place along the path: 1 = the first surface the camera ray meets.
    pub index: u32,
    /// Width of the path's ray cone at the vertex, scene units (0 without [`Ending::FOOTPRINT`]).
    pub footprint: f32,
    /// Every bounce before this vertex sampled a delta lobe (a specular chain from the camera).
    pub specular_chain: bool,
    /// The path's weight at the vertex (what its light is multiplied by).
    pub throughput: Color,
    /// What the path has gathered so far (its estimate before this vertex), W/(m² sr).
    pub gathered: Color,
}

/// What a cache gives at a vertex (`pathloop` docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheEnd {
    /// Light the cache gives there, reflected towards `wo` by the wide lobes, W/(m² sr): the
    /// indirect light when the path ends, and the caustic light when the cache holds it.
    pub radiance: Color,
    /// The roughness from which a lobe is the cache's (0: every non-delta lobe).
    pub min_alpha: f32,
    /// The path ends here: the cache holds the wide lobes' indirect light.
    pub ends: bool,
    /// The cache holds the wide lobes' caustic light (light from an emitter through delta
    /// bounces only); otherwise the loop traces it.
    pub caustics: bool,
    /// With `ends` and `caustics` at a vertex whose lobes are all wide: the vertex's direct
    /// light is its light sample alone (no MIS, no BSDF-sampled ray); otherwise the sampled
    /// ray's emitter hit is MIS-weighted with it (the tail).
    pub light_sample_only: bool,
    /// With `ends`: the path is traced on to correct the cache's value (`pathloop` docs, "The
    /// residual"); the policy drew the decision, of probability [`Residual::q`].
    pub residual: Option<Residual>,
}

/// A residual continuation where a path ends in a cache (`pathloop` docs, "The residual").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residual {
    /// The probability with which the policy chose to trace on, in (0, 1].
    pub q: f32,
    /// The cache's value for the continuation, subtracted from it.
    pub cv: ControlVariate,
}

/// What a residual continuation subtracts (`pathloop` docs, "The residual"): a control variate
/// whose mean over the BSDF-sampled direction is [`CacheEnd::radiance`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ControlVariate {
    /// The cache's value itself, W/(m² sr), whatever direction was sampled.
    Constant(Color),
    /// A linear incident-radiance field `L̃_c(ω) = a_c · ω` per colour channel (the columns
    /// of the matrix, world space, W/(m² sr)), weighed by the sampled direction's
    /// `f cos θ / pdf`: exact in mean where the wide lobes are Lambertian.
    Linear(Mat3),
}

impl ControlVariate {
    /// The linear field's radiance towards `-wi` (world direction `wi` from the vertex).
    #[inline]
    pub fn linear_radiance(a: &Mat3, wi: Vec3) -> Color {
        Color::new(a.col(0).dot(wi), a.col(1).dot(wi), a.col(2).dot(wi))
    }
}

/// The policy of the loop: where a path may end in a cache, and what the cache gives there.
pub trait Ending {
    /// Whether [`CacheVertex::footprint`] is needed (the loop tracks the ray cone only then).
    const FOOTPRINT: bool;
    /// `Some` reads the cache at `v` (and may end the path there). May draw from `sampler` only
    /// when it answers `Some`.
    fn end(&self, scene: &Scene, v: &CacheVertex, sampler: &mut Sampler, counters: &mut RayCounters) -> Option<CacheEnd>;
}

/// The path tracer's policy: no path ends in a cache.
pub struct Never;

impl Ending for Never {
    const FOOTPRINT: bool = false;
    #[inline]
    fn end(&self, _: &Scene, _: &CacheVertex, _: &mut Sampler, _: &mut RayCounters) -> Option<CacheEnd> {
        None
    }
}
