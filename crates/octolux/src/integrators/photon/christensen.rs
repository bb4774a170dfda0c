//! Christensen's precomputed irradiance photon map (JGT 1999/2000) as the paper's baseline
//! (the paper's §9, table 2 column "Christensen": `m_e` irradiance photons, `m_a` samples added
//! during rendering; table 3 "Ward-Christensen (configuration C)").
//!
//! Same ray tracer as `octree` and `ward`: specular chains from the camera, and at the first
//! non-delta vertex direct light by NEE, caustics from the caustic map (radiance estimate), and
//! indirect light `f(wo, n) E` with `E` from the cache:
//! - **irradiance photons** ([`ChristensenCache`]): irradiance precomputed at every `every`-th
//!   global photon (`m_e` of them; Christensen used every 4th, the paper's `m_e` = 378 is about
//!   every 2700th of 1M photons in the built-in `cornell-box`); a lookup takes the nearest one
//!   within `lookup_radius` (default `r_max`) whose normal satisfies `n·n_p > normal_cos`;
//! - **configuration C** (`added` ≠ `none`): a Ward cache ([`crate::caches::ward`]) over the
//!   irradiance photons, filled by the same deterministic priming pass as the `ward`
//!   integrator (it stands for "samples added during rendering": the render itself stays
//!   read-only) — its `m_a` samples take their irradiance from the nearest irradiance photon
//!   (`precomputed`, cheap: the reading we give to table 3, where configuration C builds 3.7×
//!   faster than configuration A) or from a full density estimate (`density`), and their
//!   radius from [`super::priming::PhotonRadius`] (the irradiance photon's gathered disk, or `r_max`). A
//!   lookup uses Ward's interpolation where that cache is sufficient, the nearest irradiance
//!   photon otherwise.
//!
//! A lookup that finds no irradiance photon (none with a compatible normal within `r_max`)
//! falls back to the global map's density estimate at the point (counted in
//! [`ChristensenIntegrator::misses`]); with no photon there either it is 0.
//!
//! `F_m` = irradiance photons + Ward cache (configuration C) + global map (the fallback) +
//! caustic map.

use super::priming::{Primer, SampleRecipe, WardCacheSettings, WardSampleMode, PRIME_SAMPLE_STREAM};
use super::{check_max_depth, render_vertex, validate_common, BaselineError, CacheView, PhotonMapStats, ShadeCtx, Shading, Vertex};
use crate::caches::christensen::{ChristensenCache, ChristensenStats};
use crate::caches::kdtree::{scene_size, DensitySettings, Neighbor, SceneLength, SettingsError};
use crate::caches::ward::{IrradianceSample, PrimeStats, WardCache, WardCacheStats};
use crate::integrators::common::RayCounters;
use crate::math::{Color, Ray, RayDifferential};
use crate::photon::trace::{trace_photons, PhotonSettings};
use crate::sampling::Sampler;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Where the samples of configuration C's Ward cache get their irradiance.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum AddedSamples {
    /// No Ward cache: the irradiance photons alone (Christensen's method).
    #[default]
    None,
    /// Configuration C, sample = the nearest irradiance photon's value.
    Precomputed,
    /// Configuration C, sample = the global map's density estimate at the point.
    Density,
}

/// Settings of the `christensen` integrator.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct ChristensenSettings {
    pub photons: PhotonSettings,
    /// Density estimate of the irradiance photons (paper's table 2: n_max 205, r_max 31); its
    /// `r_max` is also the lookup radius.
    pub density: DensitySettings,
    /// Caustic-map radiance estimate.
    pub caustic: DensitySettings,
    /// Irradiance at every `every`-th global photon (Christensen: 4).
    pub every: u32,
    /// Least `n·n_p` for an irradiance photon to serve a lookup.
    pub normal_cos: f32,
    /// Search radius of a lookup; `None`: the density estimate's `r_max`. Sparse irradiance
    /// photons (large `every`) need a larger one, or most lookups fall back to the map.
    pub lookup_radius: Option<SceneLength>,
    /// Configuration C's Ward cache.
    pub added: AddedSamples,
    /// Ward cache and priming settings for configuration C (ignored otherwise).
    pub cache: WardCacheSettings,
    /// Longest specular chain followed (vertices, Mitsuba-like; -1 unbounded).
    pub max_depth: i32,
    pub view: CacheView,
}

impl Default for ChristensenSettings {
    fn default() -> Self {
        ChristensenSettings {
            photons: PhotonSettings::default(),
            density: DensitySettings::default(),
            caustic: DensitySettings::default(),
            every: 4,
            normal_cos: 0.9,
            lookup_radius: None,
            added: AddedSamples::None,
            cache: WardCacheSettings::default(),
            max_depth: 16,
            view: CacheView::Render,
        }
    }
}

impl ChristensenSettings {
    pub fn validate(&self) -> Result<(), SettingsError> {
        validate_common(&self.photons, &[("density", &self.density), ("caustic", &self.caustic)])?;
        if self.every == 0 {
            return Err(SettingsError::new("every", "irradiance is precomputed at every k-th photon, k ≥ 1 (got 0)"));
        }
        if !(self.normal_cos.is_finite() && (-1.0..1.0).contains(&self.normal_cos)) {
            return Err(SettingsError::new("normal_cos", format!("{} must lie in [-1, 1)", self.normal_cos)));
        }
        if let Some(r) = self.lookup_radius {
            r.check("lookup_radius", false)?;
        }
        if self.added != AddedSamples::None {
            self.cache.validate("cache", WardSampleMode::Photons)?;
        }
        check_max_depth(self.max_depth)
    }
}

/// Build statistics of the `christensen` integrator (the paper's tables 2 and 3).
#[derive(Clone, Debug, Default, Serialize)]
pub struct ChristensenBuildStats {
    pub photons: PhotonMapStats,
    pub precompute: ChristensenStats,
    /// `m_e`: irradiance photons.
    pub m_e: usize,
    /// `m_a`: Ward samples of configuration C (0 without it).
    pub m_a: usize,
    /// Priming pass of configuration C, seconds (0 without it).
    pub t_prime_s: f64,
    /// `t_c`: photons + kd-trees + precomputation + priming, seconds.
    pub t_c_s: f64,
    pub prime: Option<PrimeStats>,
    pub ward_cache: Option<WardCacheStats>,
    /// Resolved `r_max` of the estimates and lookup radius, scene units.
    pub r_max: f32,
    pub lookup_radius: f32,
    /// `F_m`: irradiance photons + Ward cache + global map + caustic map, bytes.
    pub bytes: usize,
}

/// A built `christensen` integrator (read-only while rendering).
pub struct ChristensenIntegrator {
    pub settings: ChristensenSettings,
    pub shading: Shading,
    pub cache: ChristensenCache,
    /// Configuration C's Ward cache.
    pub ward: Option<WardCache>,
    pub stats: ChristensenBuildStats,
    misses: AtomicU64,
}

/// Irradiance from the irradiance photons at `v`, or the density-estimate fallback.
fn christensen_irradiance(
    cache: &ChristensenCache,
    sh: &Shading,
    v: &Vertex,
    counters: &mut RayCounters,
    scratch: &mut Vec<Neighbor>,
    misses: Option<&AtomicU64>,
) -> (Color, f32) {
    let found = counters.time_query(|| cache.lookup(v.hit.p, v.n).map(|s| (s.e, s.r)));
    if let Some(found) = found {
        return found;
    }
    if let Some(m) = misses {
        m.fetch_add(1, Ordering::Relaxed);
    }
    let d = sh.irradiance_estimate(&sh.global, sh.global_density, v.hit.p, v.n, scratch, counters);
    (d.e, d.r)
}

impl ChristensenIntegrator {
    /// Trace the photons, build the maps, precompute the irradiance photons, and in
    /// configuration C prime the Ward cache.
    pub fn build(scene: &Scene, settings: ChristensenSettings) -> Result<ChristensenIntegrator, BaselineError> {
        settings.validate()?;
        let maps = trace_photons(scene, &settings.photons)?;
        let shading = Shading::new(scene, &maps, &settings.density, &settings.caustic, settings.max_depth);
        let lookup_radius = settings.lookup_radius.map_or(shading.global_density.r_max, |r| r.resolve(scene_size(&scene.bounds)));
        let cache = ChristensenCache::build(
            &maps.global,
            &shading.global,
            settings.every,
            shading.global_density,
            lookup_radius,
            settings.normal_cos,
        );
        drop(maps);
        let (mut ward, mut prime, mut t_prime_s) = (None, None, 0.0);
        if settings.added != AddedSamples::None {
            let t0 = Instant::now();
            let a = settings.cache.accuracy(WardSampleMode::Photons);
            let (radius_min, radius_max) = settings.cache.radius_range(scene_size(&scene.bounds), a);
            let recipe = SampleRecipe {
                mode: WardSampleMode::Photons,
                gather_rays: 0,
                photon_radius: settings.cache.photon_radius,
                radius_min,
                radius_max,
            };
            let seed = settings.photons.seed;
            let mut w = WardCache::new(scene.bounds, a, settings.cache.min_weight);
            let added = settings.added;
            let primer = Primer::new(scene, &shading, settings.cache.prime, seed);
            let st = primer.prime(&mut w, settings.cache.batch as usize, |i, v| -> Option<IrradianceSample> {
                let mut scratch = shading.scratch();
                let mut counters = RayCounters::default();
                match added {
                    AddedSamples::Precomputed => {
                        let (e, r) = christensen_irradiance(&cache, &shading, v, &mut counters, &mut scratch, None);
                        recipe.make(v, e, recipe.photon_radius(r, &shading))
                    }
                    _ => {
                        let mut sampler = Sampler::new(seed, i, PRIME_SAMPLE_STREAM);
                        recipe.compute(
                            &shading,
                            &mut ShadeCtx { scene, sampler: &mut sampler, counters: &mut counters, scratch: &mut scratch },
                            v,
                        )
                    }
                }
            });
            t_prime_s = t0.elapsed().as_secs_f64();
            prime = Some(st);
            ward = Some(w);
        }
        let p = shading.stats.clone();
        let pre = cache.stats().clone();
        let ward_cache = ward.as_ref().map(|w| w.stats());
        let stats = ChristensenBuildStats {
            m_e: pre.samples,
            m_a: ward_cache.as_ref().map_or(0, |w| w.samples),
            t_prime_s,
            t_c_s: p.t_photons_s + p.t_kdtree_s + pre.t_precompute_s + t_prime_s,
            prime,
            r_max: shading.global_density.r_max,
            lookup_radius,
            bytes: pre.bytes + ward_cache.as_ref().map_or(0, |w| w.bytes) + p.global_bytes + p.caustic_bytes,
            ward_cache,
            precompute: pre,
            photons: p,
        };
        Ok(ChristensenIntegrator { settings, shading, cache, ward, stats, misses: AtomicU64::new(0) })
    }

    /// Lookups during rendering that found no irradiance photon (density-estimate fallback).
    pub fn misses(&self) -> u64 {
        self.misses.load(Ordering::Relaxed)
    }

    fn irradiance(&self, v: &Vertex, counters: &mut RayCounters, scratch: &mut Vec<Neighbor>) -> Color {
        if let Some(w) = &self.ward {
            let (ok, l) = counters.time_query(|| w.query(v.hit.p, v.n));
            if ok {
                return l.irradiance();
            }
        }
        christensen_irradiance(&self.cache, &self.shading, v, counters, scratch, Some(&self.misses)).0
    }

    /// Radiance along a primary ray.
    pub fn li(&self, scene: &Scene, ray: Ray, diff: Option<&RayDifferential>, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        let mut scratch = Vec::new();
        let mut cx = ShadeCtx { scene, sampler, counters, scratch: &mut scratch };
        render_vertex(&self.shading, self.settings.view, &mut cx, ray, diff, |v, cx| self.irradiance(v, cx.counters, cx.scratch))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::test_scenes::{box_scene, check_furnace, furnace_scene, image_mean};
    use crate::integrators::Integrator;
    use crate::render::{render, RenderSettings};

    fn small(photons: u64) -> ChristensenSettings {
        let mut s = ChristensenSettings::default();
        s.photons.photons = photons;
        s.density.n_max = 50;
        s.caustic.n_max = 50;
        s
    }

    #[test]
    fn bad_settings_are_refused_with_clear_messages() {
        let scene = box_scene(4);
        let cases: Vec<(ChristensenSettings, &str)> = vec![
            (ChristensenSettings { every: 0, ..small(10) }, "every"),
            (ChristensenSettings { normal_cos: 1.0, ..small(10) }, "normal_cos"),
            (ChristensenSettings { normal_cos: f32::NAN, ..small(10) }, "normal_cos"),
            (ChristensenSettings { max_depth: -2, ..small(10) }, "max_depth"),
            (ChristensenSettings { lookup_radius: Some(SceneLength::Absolute(0.0)), ..small(10) }, "lookup_radius"),
            (
                ChristensenSettings {
                    added: AddedSamples::Precomputed,
                    cache: WardCacheSettings { a: Some(-1.0), ..Default::default() },
                    ..small(10)
                },
                "cache.a",
            ),
            (small(0), "photons"),
        ];
        for (s, field) in cases {
            let e = ChristensenIntegrator::build(&scene, s).err().expect("refused");
            assert!(e.to_string().contains(field), "{e} should name {field}");
        }
        // the Ward settings are not checked when configuration C is off
        assert!(ChristensenSettings { cache: WardCacheSettings { a: Some(-1.0), ..Default::default() }, ..small(10) }.validate().is_ok());
    }

    #[test]
    fn counts_and_irradiance_view() {
        let scene = box_scene(32);
        let mut s = small(50_000);
        s.view = CacheView::Irradiance;
        let c = ChristensenIntegrator::build(&scene, s.clone()).unwrap();
        assert_eq!(c.stats.m_e, c.stats.photons.global_photons.div_ceil(4));
        assert_eq!(c.stats.m_a, 0);
        let (img_a, _) =
            render(&scene, &Integrator::Christensen(Box::new(c)), &RenderSettings { spp: 1, ..Default::default() }, &|_, _| {});
        s.added = AddedSamples::Precomputed;
        let c = ChristensenIntegrator::build(&scene, s.clone()).unwrap();
        assert!(c.stats.m_a > 10 && c.stats.m_a <= c.stats.prime.unwrap().points, "{:?}", c.stats);
        let (img_c, _) =
            render(&scene, &Integrator::Christensen(Box::new(c)), &RenderSettings { spp: 1, ..Default::default() }, &|_, _| {});
        // Same photons, same irradiance photons: configuration C only interpolates them.
        let mean = |img: &[Color]| img.iter().map(|c| c.element_sum() as f64).sum::<f64>() / img.len() as f64;
        let (a, c) = (mean(&img_a.data), mean(&img_c.data));
        assert!(a > 0.0 && (c / a - 1.0).abs() < 0.1, "{a} vs {c}");
    }

    #[test]
    fn furnace_is_analytic() {
        let scene = furnace_scene(0.5, 1.0);
        for added in [AddedSamples::None, AddedSamples::Precomputed] {
            let mut means = Vec::new();
            for view in [CacheView::Render, CacheView::Irradiance] {
                let mut s = small(100_000);
                s.added = added;
                s.view = view;
                let c = ChristensenIntegrator::build(&scene, s).unwrap();
                let (img, _) =
                    render(&scene, &Integrator::Christensen(Box::new(c)), &RenderSettings { spp: 2, ..Default::default() }, &|_, _| {});
                means.push(image_mean(&img.data));
            }
            check_furnace(means[0], means[1], 0.03, &format!("christensen {added:?}"));
        }
    }

    #[test]
    fn images_are_identical_for_one_and_two_threads() {
        let scene = box_scene(16);
        for added in [AddedSamples::None, AddedSamples::Precomputed, AddedSamples::Density] {
            let mut s = small(20_000);
            s.added = added;
            s.cache.batch = 16;
            let run = |t| {
                rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap().install(|| {
                    let c = ChristensenIntegrator::build(&scene, s.clone()).unwrap();
                    let samples = c.cache.samples().to_vec();
                    let (img, _) =
                        render(&scene, &Integrator::Christensen(Box::new(c)), &RenderSettings { spp: 2, ..Default::default() }, &|_, _| {});
                    (samples, img.data)
                })
            };
            let (a, b) = (run(1), run(2));
            assert_eq!(a.0, b.0, "{added:?}: irradiance photons differ");
            assert_eq!(a.1, b.1, "{added:?}: images differ");
        }
    }
}
