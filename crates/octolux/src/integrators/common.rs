//! Pieces every integrator shares, written once: the render-time counters and the one rule
//! for timing cache queries, next-event estimation of direct light, the MIS power heuristic,
//! the "facing" normal, and the walk along a specular chain to the first vertex with a
//! non-delta lobe (the paper's §9 baselines and the octree's debug views; the integrators
//! that trace paths share `pathloop`).
//!
//! Conventions: `wo`/`wi` point away from the surface; radiance in W/(m² sr), irradiance in
//! W/m².

pub use crate::math::facing;

use crate::math::{Color, Ray, RayDifferential};
use crate::sampling::Sampler;
use crate::scene::lights::LightSelection;
use crate::scene::material::{Lobe, Material};
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Counters an integrator updates while tracing (per worker, summed at the end).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize, PartialEq, Eq)]
pub struct RayCounters {
    /// Closest-hit rays (camera and continuation rays).
    pub rays: u64,
    /// Shadow (occlusion) rays.
    pub shadow_rays: u64,
    /// Radiance-cache lookups (octree and other caches).
    pub cache_queries: u64,
    /// Wall time spent inside cache lookups, nanoseconds, estimated the same way for every
    /// cache: one lookup in [`QUERY_TIMING_STRIDE`] is timed (with `Instant`) and stands for
    /// the stride (see [`RayCounters::time_query`]).
    pub cache_query_ns: u64,
    /// Paths that ended in a cache (`integrators::pathloop`), by the vertex they ended at:
    /// the first surface, the second, the third, the fourth or later.
    pub cache_ends: [u64; 4],
}

/// One cache query in this many is timed (a clock read per query cost ~3% of an octree
/// render); every cache uses the same stride, so `cache_query_ns` compares across methods.
pub const QUERY_TIMING_STRIDE: u64 = 16;

impl RayCounters {
    /// Run the cache query `f`, count it, and time it when it is the
    /// [`QUERY_TIMING_STRIDE`]-th of this counter set (its time then counts for the stride):
    /// the one timer of every cache lookup.
    #[inline]
    pub fn time_query<T>(&mut self, f: impl FnOnce() -> T) -> T {
        self.cache_queries += 1;
        if !self.cache_queries.is_multiple_of(QUERY_TIMING_STRIDE) {
            return f();
        }
        let t = Instant::now();
        let r = f();
        self.cache_query_ns += t.elapsed().as_nanos() as u64 * QUERY_TIMING_STRIDE;
        r
    }
}

impl std::ops::AddAssign for RayCounters {
    fn add_assign(&mut self, o: Self) {
        self.rays += o.rays;
        self.shadow_rays += o.shadow_rays;
        self.cache_queries += o.cache_queries;
        self.cache_query_ns += o.cache_query_ns;
        for (a, b) in self.cache_ends.iter_mut().zip(o.cache_ends) {
            *a += b;
        }
    }
}

/// Next-event estimation of direct light at a surface hit: one light sample (chosen by the
/// light tree, [`LightSelection::Tree`]), one shadow ray, no MIS. Used by the cache integrators, whose indirect light comes from a
/// cache rather than a BSDF-sampled continuation to combine with. `wo` is local.
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
    let Some(ls) = scene.lights.sample_li(LightSelection::Tree, hit.p, hit.frame.n, u_sel, u) else { return Color::ZERO };
    if !(ls.pdf > 0.0) || ls.li == Color::ZERO {
        return Color::ZERO;
    }
    let f = material.eval(&scene.images, hit.uv, wo, hit.frame.to_local(ls.wi)) * hit.shading_factor(ls.wi);
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

/// The first vertex with a non-delta lobe at the end of a specular chain.
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    pub hit: SurfaceHit,
    /// Direction to the previous vertex (the viewer), local shading frame.
    pub wo: Vec3,
    /// Shading normal on the viewer's side (world).
    pub n: Vec3,
    /// Product of the specular weights along the chain.
    pub throughput: Color,
    /// Specular bounces taken before this vertex (0: the ray's first hit).
    pub bounces: u32,
}

/// Where a specular walk ended.
#[derive(Clone, Copy, Debug)]
pub struct SpecularWalk {
    /// The first vertex with a non-delta lobe, if the chain reached one.
    pub vertex: Option<Vertex>,
    /// With `emission`: `Σ throughput · Le` of the emitters met on the way (the end vertex's
    /// own emission and the environment on escape included).
    pub emitted: Color,
    /// Distance to the first surface hit (`INFINITY` when the ray escapes).
    pub first_t: f32,
}

/// Follow `ray` through purely specular vertices to the first vertex with a non-delta lobe,
/// taking at most `max_vertices - 1` specular bounces (a chain of `max_vertices` surface
/// vertices; `u32::MAX`: unbounded). The chain ends without a vertex when the ray escapes,
/// the bound is reached, or the sampled lobe is not a delta (or has a zero or non-finite
/// weight). `diff`, the camera ray's differential when `ray` is one, gives the first hit's
/// texture lookups their footprint (later hits have none, as in Mitsuba 0.6). Each bounce draws `next_1d`, `next_2d` from `sampler`; each ray is counted.
pub fn walk_specular(
    scene: &Scene,
    mut ray: Ray,
    diff: Option<&RayDifferential>,
    max_vertices: u32,
    emission: bool,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> SpecularWalk {
    let mut walk = SpecularWalk { vertex: None, emitted: Color::ZERO, first_t: f32::INFINITY };
    let mut throughput = Color::ONE;
    let mut bounces = 0u32;
    loop {
        counters.rays += 1;
        let Some(mut hit) = scene.intersect(&ray) else {
            if emission {
                walk.emitted += throughput * scene.lights.env_le(ray.d);
            }
            return walk;
        };
        if bounces == 0 {
            walk.first_t = hit.t;
            if let Some(d) = diff {
                hit.set_ray_differential(d);
            }
        }
        if let (Some(light), true) = (hit.light, emission) {
            walk.emitted += throughput * scene.lights.area_le(light, hit.ng, -ray.d);
        }
        // A mask passes the ray with probability 1 - opacity (a delta vertex, as in the path
        // tracer), else the vertex is its nested material.
        if matches!(scene.materials[hit.material as usize], Material::Mask { .. }) && scene.resolve_mask(&mut hit, sampler.next_1d()) {
            if bounces + 1 >= max_vertices {
                return walk;
            }
            ray = hit.spawn(ray.d);
            bounces += 1;
            continue;
        }
        let material = &scene.materials[hit.material as usize];
        let wo = hit.frame.to_local(-ray.d);
        if material.has_smooth_lobe() {
            let n = facing(hit.frame.n, -ray.d);
            walk.vertex = Some(Vertex { hit, wo, n, throughput, bounces });
            return walk;
        }
        if bounces + 1 >= max_vertices {
            return walk;
        }
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = material.sample(&scene.images, hit.uv, wo, u_lobe, u) else { return walk };
        if !bs.lobe.is_delta() || !bs.weight.is_finite() {
            return walk;
        }
        let d = hit.frame.to_world(bs.wi);
        let k = if bs.lobe == Lobe::Null { 1.0 } else { hit.shading_factor(d) };
        throughput *= bs.weight * k;
        if throughput == Color::ZERO {
            return walk;
        }
        ray = hit.spawn(d);
        bounces += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn facing_turns_the_normal_to_the_side_of_w() {
        assert_eq!(facing(Vec3::Z, Vec3::new(0.3, 0.0, 0.5)), Vec3::Z);
        assert_eq!(facing(Vec3::Z, Vec3::new(0.3, 0.0, -0.5)), -Vec3::Z);
        assert_eq!(facing(-Vec3::Z, Vec3::new(0.3, 0.0, -0.5)), -Vec3::Z);
    }

    #[test]
    fn one_query_in_the_stride_is_timed_and_every_query_counted() {
        let mut c = RayCounters::default();
        for _ in 0..QUERY_TIMING_STRIDE - 1 {
            c.time_query(|| std::thread::sleep(std::time::Duration::from_micros(50)));
        }
        assert_eq!((c.cache_queries, c.cache_query_ns), (QUERY_TIMING_STRIDE - 1, 0));
        c.time_query(|| std::thread::sleep(std::time::Duration::from_micros(50)));
        assert_eq!(c.cache_queries, QUERY_TIMING_STRIDE);
        // the timed query stands for the whole stride
        assert!(c.cache_query_ns >= 50_000 * QUERY_TIMING_STRIDE, "{}", c.cache_query_ns);
    }
}
