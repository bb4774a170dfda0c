//! The one path loop of every integrator that traces paths: unidirectional path tracing with
//! next-event estimation and multiple importance sampling (power heuristic), Russian roulette
//! and Mitsuba 3's `max_depth`, plus a policy ([`Ending`]) that may end a path in a radiance
//! cache at a vertex. The path tracer ([`super::path`]) runs it with [`Never`]; the octree
//! integrator ([`super::octree`]) with its termination rule (docs/guide/octree.md, "Ending paths in
//! the cache").
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
//!
//! # Ending a path in a cache
//! At a vertex `x` with a non-delta lobe, [`Ending::end`] may answer with the cache's light
//! there ([`CacheEnd`]): the indirect light reflected by the lobes at least
//! [`CacheEnd::min_alpha`] wide (the *wide* lobes, [`Material::eval_split`]), and whether it
//! holds the caustic light too. The light arriving at `x` is then counted once, whatever its
//! kind:
//! - direct light (emitter to `x`): next-event estimation at `x` and the BSDF-sampled ray's
//!   emitter hit, MIS-weighted, as in the path tracer;
//! - indirect light through the wide lobes: the cache's value, and, when the cache does not
//!   hold the caustics, the wide lobes' share of the BSDF-sampled ray followed through delta
//!   bounces to an emitter (the *tail*, which gets no next-event estimation);
//! - indirect light through the narrow lobes and the delta lobes: the path goes on with the
//!   narrow lobes' share of the sampled direction's weight (a delta sample keeps all of it).
//!
//! A path that ends nowhere is the path tracer's, bit for bit: [`Ending::end`] may not draw
//! from the sampler unless it ends the path.
//!
//! # The residual
//! A policy may answer an ending with a [`Residual`]: the path is then traced on, its
//! continuation through the wide lobes weighed `1/q`, and the cache's value for it, `Ĉ`,
//! subtracted with the same weight, so that the vertex estimates `C + (L − Ĉ)/q` (and `C` when
//! the policy chose, with probability `1 − q`, to end). Its mean is `L`'s whatever the cache
//! holds, as long as `Ĉ`'s mean over the BSDF-sampled direction is `C`
//! ([`ControlVariate`]). What the continuation counts exactly once either way: the emitter its
//! first ray meets (direct light, MIS-weighted with the light sample) and, when the cache lacks
//! them, the caustics through delta bounces (the tail keeps weight `1 − 1/q` of them, the
//! path `1/q`). A path traced on from a residual does not end in the cache again: a second
//! level multiplies the variance by `1/q` once more.
//!
//! # Splitting
//! With [`Depths::split`] `k > 1`, a path splits once, at its first vertex with a smooth lobe
//! where it does not end in the cache: after that vertex's emission, cache read and light
//! sample, `k` continuations each sample the BSDF and go on with the path's weights times
//! `1/k` (Vorba & Křivánek's ADRRS with a fixed factor). Each draws from its own sampler
//! ([`Sampler::split`]): the `k` continuations of a pixel's samples are stratified together.
//! Russian roulette judges a continuation's weight times `k`, as it would the unsplit
//! path's. The estimate's mean is the unsplit path's; the camera ray, the first vertex's
//! emission and light sample are paid once for `k` continuations (measured in
//! docs/lab/2026-12-06-splitting-measured.md).
//!
//! # The ray cone
//! When the policy asks for it ([`Ending::FOOTPRINT`]), the loop carries the path's ray cone
//! (as NVIDIA SHaRC and neural radiance caching do): width `w` at the current vertex and
//! spread `s` (width gained per unit of distance). A camera ray starts with `w = 0` and `s` the
//! pixel's angle ([`crate::scene::camera::Camera::pixel_spread`]; a ray without differentials
//! with `s = 0`); a segment of length `t` adds `s t` to `w`; a bounce adds the sampled lobe's
//! spread to `s`: 0 for a delta lobe, [`SPREAD_DIFFUSE`] for a diffuse one, and for a glossy
//! lobe of roughness `α` the width of its cone, `2 sqrt(α² / (2 (1 − α²)))` (SHaRC's rule), at
//! most [`SPREAD_DIFFUSE`].

use super::common::{mis_power, RayCounters};
use crate::math::{max_component, Color, Ray, RayDifferential};
use crate::sampling::Sampler;
use crate::scene::lights::LightSelection;
use crate::scene::material::{Lobe, Material, TexCoord};
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;

mod ending;
pub use ending::{CacheEnd, CacheVertex, ControlVariate, Ending, Never, Residual};

/// Cone spread of a diffuse bounce (width per unit distance): a cone of half-angle 45°, the
/// widest a bounce gives. After a diffuse bounce the footprint at the next vertex is about
/// twice the segment's length.
pub const SPREAD_DIFFUSE: f32 = 2.0;

/// Path length limits (Mitsuba's meaning, see the module docs) and the light selection of
/// next-event estimation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Depths {
    /// Longest path in vertices; -1 = unbounded.
    pub max_depth: i32,
    /// Depth from which Russian roulette may end paths.
    pub rr_depth: u32,
    /// How next-event estimation picks a light (and what the MIS weights take as its pdf).
    pub lights: LightSelection,
    /// Continuations traced from the path's first vertex with a smooth lobe, each weighing
    /// `1/split` (module docs, "Splitting"); 1: none.
    pub split: u32,
}

/// The cone spread a sampled lobe adds (module docs).
#[inline]
pub fn lobe_spread(lobe: Lobe, material: &Material, scene: &Scene, uv: TexCoord) -> f32 {
    match lobe {
        Lobe::Specular | Lobe::Null => 0.0,
        Lobe::Diffuse => SPREAD_DIFFUSE,
        Lobe::Glossy => glossy_spread(material.glossy_alpha(&scene.images, uv)),
    }
}

/// The cone spread of a glossy lobe of roughness `alpha`: `2 sqrt(α² / (2 (1 − α²)))`, at most
/// [`SPREAD_DIFFUSE`].
#[inline]
pub fn glossy_spread(alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    if !(a2 < 1.0) {
        return SPREAD_DIFFUSE;
    }
    (2.0 * (0.5 * a2 / (1.0 - a2)).sqrt()).min(SPREAD_DIFFUSE)
}

/// Radiance along `ray` (module docs). `diff`, the camera ray's differential, gives the first
/// hit's texture lookups their footprint and marks `ray` as a camera ray (for the cone).
pub fn li<E: Ending>(
    ending: &E,
    depths: Depths,
    scene: &Scene,
    ray: Ray,
    diff: Option<&RayDifferential>,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    let max_depth = if depths.max_depth < 0 { u32::MAX } else { depths.max_depth as u32 };
    if max_depth == 0 {
        return Color::ZERO;
    }
    let lp = Loop { ending, depths, max_depth, scene };
    let start = Walk {
        ray,
        throughput: Color::ONE,
        alive: true,
        tail: Color::ZERO,
        tail_on: false,
        tail_traces: false,
        skip: Color::ZERO,
        skip_on: false,
        eta: 1.0,
        depth: 0,
        prev_pdf: 1.0,
        prev_delta: true,
        prev_p: ray.o,
        prev_n: Vec3::ZERO,
        specular_chain: true,
        residual_on: false,
        cone_width: 0.0,
        cone_spread: if E::FOOTPRINT && diff.is_some() { scene.camera.pixel_spread() } else { 0.0 },
        split: depths.split.max(1),
        rr_scale: 1.0,
    };
    walk::<E, false>(&lp, start, diff, None, sampler, counters)
}

/// What the loop reads and never changes.
struct Loop<'a, E> {
    ending: &'a E,
    depths: Depths,
    max_depth: u32,
    scene: &'a Scene,
}

/// A vertex whose light sample is taken, its BSDF still to be sampled: where a path splits.
#[derive(Clone, Copy)]
struct Vertex {
    hit: SurfaceHit,
    wo: Vec3,
    end: Option<CacheEnd>,
}

/// A path's state from one vertex to the next (the loop's variables): what a continuation
/// starts from where the path splits.
#[derive(Clone, Copy)]
struct Walk {
    ray: Ray,
    /// Weight of the path going on (all lobes after a vertex that did not end).
    throughput: Color,
    /// The path goes on (false once it ended in a cache with no narrow lobe left).
    alive: bool,
    /// The tail (module docs): its weight, whether there is one, and whether it follows delta
    /// bounces beyond its first hit (the cache lacked the caustics).
    tail: Color,
    tail_on: bool,
    tail_traces: bool,
    /// The part of `throughput` whose caustic light the cache gave at the last non-delta
    /// vertex: emitters reached from there through delta bounces count without it.
    skip: Color,
    skip_on: bool,
    eta: f32,
    depth: u32,
    prev_pdf: f32,
    prev_delta: bool,
    prev_p: Vec3,
    /// The shading normal at `prev_p`: the light selection's there, for the MIS weight.
    prev_n: Vec3,
    specular_chain: bool,
    /// Traced on from a residual: no further vertex ends in the cache (module docs).
    residual_on: bool,
    cone_width: f32,
    cone_spread: f32,
    /// Continuations at the next vertex that may split ([`Depths::split`]; 1 once split).
    split: u32,
    /// What splitting divided the weights by: Russian roulette judges a continuation's weight
    /// times this, as it would the unsplit path's.
    rr_scale: f32,
}

/// The light of `k` continuations of `base` from `v` (each weighed by `base`), the samplers
/// split from `sampler`. Kept out of line: the loop stays one function, inlined into its caller.
#[inline(never)]
fn split_walk<E: Ending>(lp: &Loop<'_, E>, base: Walk, v: Vertex, k: u32, sampler: &Sampler, counters: &mut RayCounters) -> Color {
    (0..k).fold(Color::ZERO, |sum, j| sum + walk::<E, true>(lp, base, None, Some(v), &mut sampler.split(j, k), counters))
}

/// The loop (module docs): the light gathered by the path `w` from `pending`, a vertex whose
/// light sample is taken, else from `w.ray`. `RESUME`: whether `pending` may be `Some` (a
/// continuation; the unsplit path's loop is compiled without the test).
#[inline]
fn walk<E: Ending, const RESUME: bool>(
    lp: &Loop<'_, E>,
    w: Walk,
    diff: Option<&RayDifferential>,
    mut pending: Option<Vertex>,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    let (ending, depths, max_depth, scene) = (lp.ending, lp.depths, lp.max_depth, lp.scene);
    let Walk {
        mut ray,
        mut throughput,
        mut alive,
        mut tail,
        mut tail_on,
        mut tail_traces,
        mut skip,
        mut skip_on,
        mut eta,
        mut depth,
        mut prev_pdf,
        mut prev_delta,
        mut prev_p,
        mut prev_n,
        mut specular_chain,
        mut residual_on,
        mut cone_width,
        mut cone_spread,
        split,
        rr_scale,
    } = w;
    // Only the camera ray carries a differential (Mitsuba 0.6): the first hit's lookups.
    let mut diff = diff;
    let mut result = Color::ZERO;
    let sel = depths.lights;
    // The record of the ray's hit, one for every bounce (`Scene::intersect_into`).
    let mut found: Option<SurfaceHit> = None;
    loop {
        // The vertex, in place (a SurfaceHit is not moved on the unsplit path).
        let mut resumed: Option<Vertex> = None;
        let (hit, wo, end): (&SurfaceHit, Vec3, Option<CacheEnd>) = match if RESUME { pending.take() } else { None } {
            Some(v) => {
                let v = resumed.insert(v);
                (&v.hit, v.wo, v.end)
            }
            None => {
                counters.rays += 1;
                // The weight emission found by this ray is counted with.
                let mut weight = if tail_on { throughput + tail } else { throughput };
                if skip_on && prev_delta {
                    weight = (weight - skip).max(Color::ZERO);
                }
                scene.intersect_into(&ray, &mut found);
                let Some(hit) = found.as_mut() else {
                    // Escaped: environment emission.
                    let le = scene.lights.env_le(ray.d);
                    if le != Color::ZERO {
                        let w = if prev_delta { 1.0 } else { mis_power(prev_pdf, scene.lights.pdf_li_env(sel, ray.d)) };
                        result += weight * le * w;
                    }
                    break;
                };
                if E::FOOTPRINT {
                    cone_width += hit.t * cone_spread;
                }
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
                        let w = if prev_delta {
                            1.0
                        } else {
                            mis_power(prev_pdf, scene.lights.pdf_li_area(sel, light, prev_p, prev_n, hit.p, hit.ng))
                        };
                        result += weight * le * w;
                    }
                }
                if tail_on && !tail_traces {
                    // the cache holds what lies beyond the tail's first hit
                    tail_on = false;
                }
                if !alive && !tail_on {
                    break;
                }
                if depth + 1 >= max_depth {
                    break;
                }
                let material = &scene.materials[hit.material as usize];
                material.prefetch(&scene.images, hit.uv);
                let wo = hit.frame.to_local(-ray.d);

                // The cache's say, then next-event estimation.
                let mut end = None;
                if alive && material.has_smooth_lobe() {
                    let v = CacheVertex {
                        hit: &*hit,
                        material,
                        wo,
                        n: crate::math::facing(hit.frame.n, -ray.d),
                        index: depth + 1,
                        footprint: cone_width,
                        specular_chain,
                        throughput,
                        gathered: result,
                    };
                    if let Some(e) = if residual_on { None } else { ending.end(scene, &v, sampler, counters) } {
                        result += throughput * e.radiance;
                        if let Some(Residual { q, cv: ControlVariate::Constant(c) }) = e.residual {
                            result -= throughput * c / q;
                        }
                        end = Some(e);
                        if e.ends {
                            counters.cache_ends[(depth as usize).min(3)] += 1;
                        }
                    }
                    let only = end.is_some_and(|e| e.light_sample_only);
                    let u_sel = sampler.next_1d();
                    let u = sampler.next_2d();
                    // An environment sample's radiance is looked up only once the shadow ray is clear
                    // (`sample_li_deferred`): the same sum, without the sky model for occluded samples.
                    if let Some((mut ls, env)) = scene.lights.sample_li_deferred(sel, hit.p, hit.frame.n, u_sel, u) {
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
                                        let w = if ls.delta || only {
                                            1.0
                                        } else {
                                            mis_power(ls.pdf, material.pdf(&scene.images, hit.uv, wo, wi))
                                        };
                                        result += throughput * f * ls.li * (w / ls.pdf);
                                    }
                                }
                            }
                        }
                    }
                    if only && !tail_on {
                        // every lobe is the cache's and its direct light the light sample's
                        break;
                    }
                } else {
                    // Keep the random-number stream aligned whatever the material (and on the tail,
                    // which takes no light sample).
                    sampler.next_1d();
                    sampler.next_2d();
                }

                (&*hit, wo, end)
            }
        };
        let material = &scene.materials[hit.material as usize];
        if split > 1 && alive && end.is_none_or(|e| !e.ends || e.residual.is_some()) && material.has_smooth_lobe() {
            // Split (module docs, "Splitting"): `split` continuations of weight 1/split each,
            // with random numbers of their own.
            let k = split;
            let c = 1.0 / k as f32;
            let base = Walk {
                ray,
                throughput: throughput * c,
                alive,
                tail: tail * c,
                tail_on,
                tail_traces,
                skip: skip * c,
                skip_on,
                eta,
                depth,
                prev_pdf,
                prev_delta,
                prev_p,
                prev_n,
                specular_chain,
                residual_on,
                cone_width,
                cone_spread,
                split: 1,
                rr_scale: rr_scale * k as f32,
            };
            result += split_walk(lp, base, Vertex { hit: *hit, wo, end }, k, sampler, counters);
            break;
        }

        // BSDF sampling.
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = material.sample(&scene.images, hit.uv, wo, u_lobe, u) else { break };
        if bs.weight == Color::ZERO || !bs.weight.is_finite() {
            break;
        }
        let wi = hit.frame.to_world(bs.wi);
        // A linear control variate is weighed by the sample's f cos θ / pdf before the shading
        // factor: its mean is then the integral over the whole shading hemisphere.
        let linear = end.and_then(|e| match e.residual?.cv {
            ControlVariate::Linear(a) => Some((e.residual?.q, a)),
            ControlVariate::Constant(_) => None,
        });
        // the lobes split at the ending's width, evaluated once for the control variate and the weights
        let parts = match end {
            Some(e) if !bs.lobe.is_delta() => Some(material.eval_split(&scene.images, hit.uv, wo, bs.wi, e.min_alpha)),
            _ => None,
        };
        if let (Some((q, a)), Some(s)) = (linear, parts) {
            result -= throughput * s.wide * ControlVariate::linear_radiance(&a, wi) / (bs.pdf * q);
        }
        let k = if bs.lobe == Lobe::Null { 1.0 } else { hit.shading_factor(wi) };
        if k == 0.0 {
            break;
        }
        if bs.lobe.is_delta() {
            // a delta bounce carries the path, the tail and the caustic skip alike
            throughput *= bs.weight * k;
            if tail_on {
                tail *= bs.weight * k;
            }
            if skip_on {
                skip *= bs.weight * k;
            }
        } else if let (Some(e), Some(s)) = (end, parts) {
            // The wide lobes' share of the sample: the tail when the path ended here, else the
            // share whose caustic light the cache gave.
            let g = k / bs.pdf;
            if let (true, Some(r)) = (e.ends, e.residual) {
                // traced on: the wide lobes' continuation weighs 1/q, its first emitter 1
                let wide = throughput * s.wide * g;
                (tail, tail_on, tail_traces) = (wide * (1.0 - 1.0 / r.q), true, !e.caustics);
                throughput = throughput * s.narrow * g + wide / r.q;
                residual_on = true;
                skip_on = false;
            } else if e.ends {
                (tail, tail_on, tail_traces) = (throughput * s.wide * g, true, !e.caustics);
                throughput *= s.narrow * g;
                alive = alive && throughput.max_element() > 0.0;
                skip_on = false;
            } else {
                (skip, skip_on) = (throughput * s.wide * g, e.caustics);
                throughput *= bs.weight * k;
                tail_on = false;
            }
        } else {
            throughput *= bs.weight * k;
            // a non-delta bounce ends the tail and the skip: the cache held that light
            (tail_on, skip_on) = (false, false);
        }
        if !alive && !tail_on {
            break;
        }
        eta *= bs.eta;
        prev_pdf = bs.pdf;
        prev_delta = bs.lobe.is_delta();
        prev_p = hit.p;
        prev_n = hit.frame.n;
        specular_chain &= prev_delta;
        if E::FOOTPRINT && !residual_on {
            // (traced on from a residual, no vertex ends in the cache: the cone is not read)
            cone_spread += lobe_spread(bs.lobe, material, scene, hit.uv);
        }
        ray = hit.spawn(wi);
        depth += 1;

        // Russian roulette.
        let tmax = max_component(if tail_on { throughput + tail } else { throughput });
        if depth >= depths.rr_depth {
            let q = (tmax * rr_scale * eta * eta).min(0.95);
            if sampler.next_1d() >= q {
                break;
            }
            throughput /= q;
            tail /= q;
            skip /= q;
        }
        if tmax <= 0.0 {
            break;
        }
    }
    result
}
