//! Unidirectional path tracer with next-event estimation and multiple importance sampling
//! (power heuristic), Russian roulette, and Mitsuba 3's `max_depth` semantics — the ground
//! truth every cache is measured against.
//!
//! `max_depth` counts path vertices as Mitsuba 3 does: 1 = only emitters seen directly,
//! 2 = direct illumination, -1 = unbounded. Russian roulette starts at depth `rr_depth`
//! (Mitsuba: 5) with continuation probability `min(max(throughput) · η², 0.95)`.
//!
//! As in Mitsuba 3's `path.cpp`: a `mask`'s pass-through ([`Lobe::Null`]) is a delta vertex
//! (it counts towards `max_depth`, and the emitter it reaches gets no MIS weight); shadow rays
//! stop at masks whatever their opacity; bump- and normal-mapped hits scale BSDF values and
//! sample weights by [`crate::scene::SurfaceHit::shading_factor`] (side check, terminator
//! shadowing).

use super::common::{mis_power, RayCounters};
use crate::math::{max_component, Color, Ray, RayDifferential};
use crate::sampling::Sampler;
use crate::scene::material::Lobe;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};

/// Settings of the `path` integrator.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct PathSettings {
    /// Longest path in vertices (Mitsuba's meaning); -1 = unbounded.
    pub max_depth: i32,
    /// Depth from which Russian roulette may end paths.
    pub rr_depth: u32,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings { max_depth: -1, rr_depth: 5 }
    }
}

/// Radiance along `ray`.
pub fn li(
    settings: &PathSettings,
    scene: &Scene,
    mut ray: Ray,
    diff: Option<&RayDifferential>,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    // Only the camera ray carries a differential (Mitsuba 0.6): the first hit's lookups.
    let mut diff = diff;
    let max_depth = if settings.max_depth < 0 { u32::MAX } else { settings.max_depth as u32 };
    let mut result = Color::ZERO;
    let mut throughput = Color::ONE;
    let mut eta = 1.0f32;
    let mut depth = 0u32;
    let mut prev_pdf = 1.0f32;
    let mut prev_delta = true;
    let mut prev_p = ray.o;
    if max_depth == 0 {
        return result;
    }
    loop {
        counters.rays += 1;
        let Some(mut hit) = scene.intersect(&ray) else {
            // Escaped: environment emission.
            let le = scene.lights.env_le(ray.d);
            if le != Color::ZERO {
                let w = if prev_delta { 1.0 } else { mis_power(prev_pdf, scene.lights.pdf_li_env(ray.d)) };
                result += throughput * le * w;
            }
            break;
        };
        if let Some(d) = diff.take() {
            // Only MIP-mapped textures read the partials: skip them for the others.
            if scene.materials[hit.material as usize].reads_uv_partials() {
                hit.set_ray_differential(d);
            }
        }
        // Emission from an area light hit by the ray.
        if let Some(light) = hit.light {
            let le = scene.lights.area_le(light, hit.ng, -ray.d);
            if le != Color::ZERO {
                let w = if prev_delta { 1.0 } else { mis_power(prev_pdf, scene.lights.pdf_li_area(light, prev_p, hit.p, hit.ng)) };
                result += throughput * le * w;
            }
        }
        if depth + 1 >= max_depth {
            break;
        }
        let material = &scene.materials[hit.material as usize];
        material.prefetch(&scene.images, hit.uv);
        let wo = hit.frame.to_local(-ray.d);

        // Next-event estimation.
        if material.has_smooth_lobe() {
            let u_sel = sampler.next_1d();
            let u = sampler.next_2d();
            // An environment sample's radiance is looked up only once the shadow ray is clear
            // (`sample_li_deferred`): the same sum, without the sky model for occluded samples.
            if let Some((mut ls, env)) = scene.lights.sample_li_deferred(hit.p, u_sel, u) {
                if ls.pdf > 0.0 && (env || ls.li != Color::ZERO) {
                    let wi = hit.frame.to_local(ls.wi);
                    let f = material.eval(&scene.images, hit.uv, wo, wi) * hit.shading_factor(ls.wi);
                    if f != Color::ZERO {
                        counters.shadow_rays += 1;
                        if !scene.occluded(&hit.spawn_to(ls.wi, ls.dist)) {
                            if env {
                                ls.li = scene.lights.env_le(ls.wi);
                            }
                            if ls.li != Color::ZERO {
                                let w = if ls.delta { 1.0 } else { mis_power(ls.pdf, material.pdf(&scene.images, hit.uv, wo, wi)) };
                                result += throughput * f * ls.li * (w / ls.pdf);
                            }
                        }
                    }
                }
            }
        } else {
            // Keep the random-number stream aligned whatever the material.
            sampler.next_1d();
            sampler.next_2d();
        }

        // BSDF sampling.
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = material.sample(&scene.images, hit.uv, wo, u_lobe, u) else { break };
        if bs.weight == Color::ZERO || !bs.weight.is_finite() {
            break;
        }
        let wi = hit.frame.to_world(bs.wi);
        let k = if bs.lobe == Lobe::Null { 1.0 } else { hit.shading_factor(wi) };
        if k == 0.0 {
            break;
        }
        throughput *= bs.weight * k;
        eta *= bs.eta;
        prev_pdf = bs.pdf;
        prev_delta = bs.lobe.is_delta();
        prev_p = hit.p;
        ray = hit.spawn(wi);
        depth += 1;

        // Russian roulette.
        let tmax = max_component(throughput);
        if depth >= settings.rr_depth {
            let q = (tmax * eta * eta).min(0.95);
            if sampler.next_1d() >= q {
                break;
            }
            throughput /= q;
        }
        if tmax <= 0.0 {
            break;
        }
    }
    result
}

/// Path-traced *indirect* irradiance (W m⁻², per channel) at a free point `p` for the normal
/// `n`: `rays` cosine-distributed directions around `n` (streams of `Sampler::new(seed,
/// index, k)`), the light reflected towards `p` by the surface each one meets (a ray meeting
/// an emitter counts 0: only reflected light, as the photon maps' global octree holds it),
/// times π. Returns the estimate and the standard error of its channel mean. The truth of the
/// free-space comparisons (`docs/baking.md`, "Bytes against error").
pub fn indirect_irradiance(
    settings: &PathSettings,
    scene: &Scene,
    p: glam::Vec3,
    n: glam::Vec3,
    rays: u32,
    seed: u64,
    index: u64,
) -> (Color, f64) {
    let mut counters = RayCounters::default();
    let (mut sum, mut sum_m, mut sum_m2) = (glam::DVec3::ZERO, 0.0f64, 0.0f64);
    for k in 0..rays {
        let mut s = Sampler::new(seed, index, k as u64);
        let d = crate::sampling::around(n, crate::sampling::square_to_cosine_hemisphere(s.next_2d()));
        let ray = Ray::new(p, d);
        if let Some(h) = scene.intersect(&ray) {
            if h.light.is_none() {
                let l = li(settings, scene, ray, None, &mut s, &mut counters);
                if l.is_finite() {
                    let m = l.element_sum() as f64 / 3.0;
                    sum += l.as_dvec3();
                    sum_m += m;
                    sum_m2 += m * m;
                }
            }
        }
    }
    let n_f = rays.max(1) as f64;
    let mean = sum_m / n_f;
    let var = (sum_m2 / n_f - mean * mean).max(0.0) / n_f;
    ((sum * (std::f64::consts::PI / n_f)).as_vec3(), std::f64::consts::PI * var.sqrt())
}
