//! The unidirectional path tracer, ground truth: the one path loop ([`super::pathloop`]) with
//! no path ending in a cache ([`Never`]). Next-event estimation and multiple importance sampling
//! (power heuristic), Russian roulette from `rr_depth`, Mitsuba 3's `max_depth` semantics and
//! its handling of masks and bump maps: see the loop's module docs.

use super::common::RayCounters;
use super::pathloop::{self, Depths, Never};
use crate::caches::kdtree::SettingsError;
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
    /// Continuations traced from the path's first vertex with a smooth lobe, each weighing
    /// `1/split` and with random numbers of its own: the camera ray, the first vertex's
    /// emission and light sample are shared by `split` paths. 1 = no splitting (1 to 256).
    /// Measured at equal time: 1.25x on sponza with 4 or 8, 0.95x on classroom, no gain
    /// shown on the dining-room or veach-lamp (docs/lab/2026-12-06-splitting-measured.md).
    pub split: u32,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings { max_depth: -1, rr_depth: 5, light_selection: LightSelection::Tree, split: 1 }
    }
}

impl PathSettings {
    /// Splitting beyond this many continuations is refused (a typo would multiply the cost).
    pub const MAX_SPLIT: u32 = 256;

    /// `max_depth` -1 or at least 0 (Mitsuba 3's rule: 0 renders nothing), `split` in
    /// 1..=[`Self::MAX_SPLIT`].
    pub fn validate(&self) -> Result<(), SettingsError> {
        if self.max_depth < -1 {
            return Err(SettingsError::new("max_depth", format!("{} must be -1 (unbounded) or at least 0", self.max_depth)));
        }
        if !(1..=Self::MAX_SPLIT).contains(&self.split) {
            return Err(SettingsError::new("split", format!("{} must be 1 (no splitting) to {}", self.split, Self::MAX_SPLIT)));
        }
        Ok(())
    }

    /// The loop's path length limits.
    pub fn depths(&self) -> Depths {
        Depths { max_depth: self.max_depth, rr_depth: self.rr_depth, lights: self.light_selection, split: self.split }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::test_scenes::{box_scene, furnace_box_scene, image_mean};
    use crate::integrators::Integrator;
    use crate::render::{render, RenderSettings};
    use crate::sampling::SamplerKind;

    /// Per render seed `0..k`: the image, as f64 channels.
    fn renders(scene: &Scene, split: u32, spp: u32, k: u64, sampler: SamplerKind) -> Vec<Vec<f64>> {
        let integrator = Integrator::Path(PathSettings { split, ..Default::default() });
        (0..k)
            .map(|seed| {
                let (img, _) = render(scene, &integrator, &RenderSettings { spp, seed, sampler, ..Default::default() }, &|_, _| {});
                assert!(img.data.iter().all(|c| c.is_finite()), "a non-finite pixel");
                img.data.iter().flat_map(|c| c.to_array().map(f64::from)).collect()
            })
            .collect()
    }

    /// Mean and standard error of the image means.
    fn mean_se(imgs: &[Vec<f64>]) -> (f64, f64) {
        let m: Vec<f64> = imgs.iter().map(|i| i.iter().sum::<f64>() / i.len() as f64).collect();
        let mean = m.iter().sum::<f64>() / m.len() as f64;
        let var = m.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (m.len() - 1) as f64;
        (mean, (var / m.len() as f64).sqrt())
    }

    /// Mean over pixels and channels of the variance over the renders.
    fn pixel_variance(imgs: &[Vec<f64>]) -> f64 {
        let n = imgs.len() as f64;
        let len = imgs[0].len();
        (0..len)
            .map(|i| {
                let m = imgs.iter().map(|x| x[i]).sum::<f64>() / n;
                imgs.iter().map(|x| (x[i] - m) * (x[i] - m)).sum::<f64>() / (n - 1.0)
            })
            .sum::<f64>()
            / len as f64
    }

    #[test]
    fn splitting_keeps_the_mean_and_divides_the_continuations_variance() {
        // The test box at 8²: split 4 against no split over 24 seeds each, both samplers: the
        // means agree. In the furnace box nearly all the variance is the continuations' (the
        // first vertex's emission is constant): split 4 divides it by about 4 (measured 0.22
        // and 0.23 of the unsplit variance); continuations drawn alike would keep it.
        let scene = box_scene(8);
        let furnace = furnace_box_scene(0.5, 1.0);
        for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
            let (a, b) = (mean_se(&renders(&scene, 1, 4, 24, sampler)), mean_se(&renders(&scene, 4, 4, 24, sampler)));
            let z = (a.0 - b.0) / (a.1 * a.1 + b.1 * b.1).sqrt();
            assert!(z.abs() < 4.0, "{sampler:?}: mean {} ± {} split 4 against {} ± {} (z {z:.2})", b.0, b.1, a.0, a.1);
            let (v1, v4) = (pixel_variance(&renders(&furnace, 1, 4, 24, sampler)), pixel_variance(&renders(&furnace, 4, 4, 24, sampler)));
            assert!(v4 < 0.4 * v1, "{sampler:?}: per-pixel variance {v4:.3e} with split 4 against {v1:.3e}");
        }
    }

    #[test]
    fn split_furnace_is_exact() {
        // Radiance le / (1 - rho) = 2 everywhere inside the closed box.
        let scene = furnace_box_scene(0.5, 1.0);
        let integrator = Integrator::Path(PathSettings { split: 8, ..Default::default() });
        let (img, _) = render(&scene, &integrator, &RenderSettings { spp: 16, ..Default::default() }, &|_, _| {});
        let m = image_mean(&img.data);
        assert!((m - 2.0).abs() < 0.02, "furnace mean {m} with split 8");
    }

    #[test]
    fn split_is_validated() {
        for (split, ok) in [(0, false), (1, true), (PathSettings::MAX_SPLIT, true), (PathSettings::MAX_SPLIT + 1, false)] {
            let s = PathSettings { split, ..Default::default() };
            assert_eq!(s.validate().is_ok(), ok, "split {split}");
        }
        let e = PathSettings { split: 0, ..Default::default() }.validate().unwrap_err().to_string();
        assert!(e.contains("split") && e.contains("0 must be 1"), "{e}");
        for (max_depth, ok) in [(-2, false), (-1, true), (0, true), (1, true)] {
            assert_eq!(PathSettings { max_depth, ..Default::default() }.validate().is_ok(), ok, "max_depth {max_depth}");
        }
    }
}
