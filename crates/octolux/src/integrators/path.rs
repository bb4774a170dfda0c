//! The unidirectional path tracer, ground truth: the one path loop ([`super::pathloop`]) with
//! no path ending in a cache ([`Never`]). Next-event estimation and multiple importance sampling
//! (power heuristic), Russian roulette from `rr_depth`, Mitsuba 3's `max_depth` semantics and
//! its handling of masks and bump maps: see the loop's module docs.

use super::common::RayCounters;
use super::pathloop::{self, Depths, Never};
use crate::math::{Color, Ray, RayDifferential};
use crate::sampling::Sampler;
use crate::scene::lights::LightSelection;
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
    /// How next-event estimation picks a light: `tree` (the light tree, by importance at the
    /// shading point: power, distance and orientation) or `power` (by emitted power alone,
    /// kept for comparison). See `scene::lights`.
    pub light_selection: LightSelection,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings { max_depth: -1, rr_depth: 5, light_selection: LightSelection::Tree }
    }
}

impl PathSettings {
    /// The loop's path length limits.
    pub fn depths(&self) -> Depths {
        Depths { max_depth: self.max_depth, rr_depth: self.rr_depth, lights: self.light_selection }
    }
}

/// Radiance along `ray`.
pub fn li(
    settings: &PathSettings,
    scene: &Scene,
    ray: Ray,
    diff: Option<&RayDifferential>,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Color {
    pathloop::li(&Never, settings.depths(), scene, ray, diff, sampler, counters)
}

/// Path-traced *indirect* irradiance (W m⁻², per channel) at a free point `p` for the normal
/// `n`: `rays` cosine-distributed directions around `n` (streams of `Sampler::new(seed,
/// index, k)`), the light reflected towards `p` by the surface each one meets (a ray meeting
/// an emitter counts 0: only reflected light, as the photon maps' global octree holds it),
/// times π. Returns the estimate and the standard error of its channel mean. The truth of the
/// free-space comparisons (`docs/guide/baking.md`, "Bytes against error").
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
