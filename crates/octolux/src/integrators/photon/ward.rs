//! Ward's irradiance cache as the paper adapted it (the paper's §9, "Ward, configuration A"):
//! irradiance samples computed **from the photons** instead of by hemisphere sampling, cached
//! with Ward's weights ([`crate::caches::ward`]), over the same ray tracer as the `octree`
//! integrator (specular chains from the camera; at the first non-delta vertex direct light by
//! NEE, indirect light `f(wo, n) E` from the cache, caustics from the caustic photon map).
//!
//! # Irradiance samples ([`WardSampleMode`])
//! - `photons` (the paper's adaptation): `E` is the global map's density estimate at `x`
//!   (`n_max` photons within `r_max`, [`crate::caches::kdtree`]); the validity radius `R_i` is
//!   the radius of the disk the estimate gathered (the distance to the `n_max`-th photon, or
//!   `r_max`): the scale on which the estimate itself is smoothed, so samples are spaced in
//!   proportion to the photon density's resolution (dense where photons are dense). Option
//!   [`PhotonRadius::SearchRadius`](super::priming::PhotonRadius::SearchRadius) uses `r_max` for every sample instead (see its docs for
//!   the measured difference).
//! - `final_gather` (Ward 1988's own form): `E = π/N Σ L_i` over `gather_rays`
//!   cosine-distributed rays, `L_i` the radiance leaving each gather hit (NEE there + global
//!   and caustic radiance estimates, see `photonmap`), and `R_i` the harmonic mean distance of
//!   the gather hits.
//!
//! Either way `R_i` is clamped to `[q_min / a, max_radius]`: `q_min / a` makes `q_min` the least
//! distance between two samples on a flat surface (a sample covers its neighbourhood up to
//! `a R_i ≥ q_min`); `max_radius` bounds the reach of samples in open space.
//! Caustic photons are not in the cache: caustics are rendered from the caustic map.
//!
//! # Filling the cache deterministically
//! A priming pass before rendering ([`super::priming`], [`PrimePoints`](super::priming::PrimePoints)) fills the cache from
//! an ordered list of camera samples — a grid of pixel centres, or the render's own samples —
//! batch by batch, the same for any thread count. The render then only reads the cache; a lookup that finds it insufficient (a
//! point the priming did not see, e.g. jittered inside a pixel with the grid priming) computes
//! a temporary sample with the same recipe and does not store it
//! ([`WardIntegrator::temporary_samples`] counts them: 0 with `render_samples` priming and the
//! render's settings). Images are identical for any thread count.
//!
//! `F_m` = bytes of the cache (samples, octree, index lists) + the global map (needed for
//! temporary samples) + the caustic map (caustics).

use super::priming::{Primer, SampleRecipe, PRIME_SAMPLE_STREAM};

#[cfg(test)]
use super::priming::PhotonRadius;
use super::priming::{WardCacheSettings, WardSampleMode};
use super::{check_max_depth, render_vertex, validate_common, BaselineError, CacheView, PhotonMapStats, ShadeCtx, Shading, Vertex};
use crate::caches::kdtree::{scene_size, DensitySettings, SettingsError};
use crate::caches::ward::{PrimeStats, WardCache, WardCacheStats};
use crate::integrators::common::RayCounters;
use crate::math::{Color, Ray, RayDifferential};
use crate::photon::trace::{trace_photons, PhotonSettings};
use crate::sampling::Sampler;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Settings of the `ward` integrator.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct WardSettings {
    pub photons: PhotonSettings,
    /// Global-map density estimate of the samples (paper's table 2: n_max 205, r_max 31).
    pub density: DensitySettings,
    /// Caustic-map radiance estimate.
    pub caustic: DensitySettings,
    pub cache: WardCacheSettings,
    pub sample: WardSampleMode,
    /// Rays per sample in `final_gather` mode.
    pub gather_rays: u32,
    /// Longest specular chain followed (vertices, Mitsuba-like; -1 unbounded).
    pub max_depth: i32,
    pub view: CacheView,
}

impl Default for WardSettings {
    fn default() -> Self {
        WardSettings {
            photons: PhotonSettings::default(),
            density: DensitySettings::default(),
            caustic: DensitySettings::default(),
            cache: WardCacheSettings::default(),
            sample: WardSampleMode::Photons,
            gather_rays: 64,
            max_depth: 16,
            view: CacheView::Render,
        }
    }
}

impl WardSettings {
    pub fn validate(&self) -> Result<(), SettingsError> {
        validate_common(&self.photons, &[("density", &self.density), ("caustic", &self.caustic)])?;
        self.cache.validate("cache", self.sample)?;
        if self.sample == WardSampleMode::FinalGather && self.gather_rays == 0 {
            return Err(SettingsError::new("gather_rays", "final gathering needs at least one ray (got 0)"));
        }
        check_max_depth(self.max_depth)
    }
}

/// Build statistics of the `ward` integrator (the paper's tables 2 and 3).
#[derive(Clone, Debug, Default, Serialize)]
pub struct WardBuildStats {
    pub photons: PhotonMapStats,
    /// Priming points (first non-delta hits of the grid's camera rays).
    pub prime_points: usize,
    /// Priming pass (camera rays + samples), seconds.
    pub t_prime_s: f64,
    /// `t_c`: photon tracing + kd-trees + priming, seconds.
    pub t_c_s: f64,
    pub prime: PrimeStats,
    pub cache: WardCacheStats,
    /// `m_e`: samples in the cache.
    pub m_e: usize,
    /// The accuracy `a` used.
    pub a: f32,
    /// Resolved `r_max` of the density estimate, and `[R_min, R_max]`, scene units.
    pub r_max: f32,
    pub radius_min: f32,
    pub radius_max: f32,
    /// `F_m`: cache + global map + caustic map, bytes.
    pub bytes: usize,
}

/// A built `ward` integrator: photon maps and a primed, read-only cache.
pub struct WardIntegrator {
    pub settings: WardSettings,
    pub shading: Shading,
    pub cache: WardCache,
    pub stats: WardBuildStats,
    recipe: SampleRecipe,
    temporaries: AtomicU64,
}

impl WardIntegrator {
    /// Trace the photons, build the maps, prime the cache (module docs).
    pub fn build(scene: &Scene, settings: WardSettings) -> Result<WardIntegrator, BaselineError> {
        settings.validate()?;
        let maps = trace_photons(scene, &settings.photons)?;
        let shading = Shading::new(scene, &maps, &settings.density, &settings.caustic, settings.max_depth);
        drop(maps);
        let size = scene_size(&scene.bounds);
        let a = settings.cache.accuracy(settings.sample);
        let (radius_min, radius_max) = settings.cache.radius_range(size, a);
        let recipe = SampleRecipe {
            mode: settings.sample,
            gather_rays: settings.gather_rays,
            photon_radius: settings.cache.photon_radius,
            radius_min,
            radius_max,
        };
        let t0 = Instant::now();
        let seed = settings.photons.seed;
        let mut cache = WardCache::new(scene.bounds, a, settings.cache.min_weight);
        let primer = Primer::new(scene, &shading, settings.cache.prime, seed);
        let prime = primer.prime(&mut cache, settings.cache.batch as usize, |i, v| {
            let mut sampler = Sampler::new(seed, i, PRIME_SAMPLE_STREAM);
            let mut scratch = shading.scratch();
            let mut counters = RayCounters::default();
            recipe.compute(&shading, &mut ShadeCtx { scene, sampler: &mut sampler, counters: &mut counters, scratch: &mut scratch }, v)
        });
        drop(primer);
        let t_prime_s = t0.elapsed().as_secs_f64();
        let cs = cache.stats();
        let p = shading.stats.clone();
        let stats = WardBuildStats {
            prime_points: prime.points,
            t_prime_s,
            t_c_s: p.t_photons_s + p.t_kdtree_s + t_prime_s,
            prime,
            m_e: cs.samples,
            a,
            r_max: shading.global_density.r_max,
            radius_min,
            radius_max,
            bytes: cs.bytes + p.global_bytes + p.caustic_bytes,
            cache: cs,
            photons: p,
        };
        Ok(WardIntegrator { settings, shading, cache, stats, recipe, temporaries: AtomicU64::new(0) })
    }

    /// Temporary samples computed during rendering so far (lookups the cache could not serve).
    pub fn temporary_samples(&self) -> u64 {
        self.temporaries.load(Ordering::Relaxed)
    }

    /// Indirect irradiance at a vertex: the cache's interpolation, or a temporary sample.
    fn irradiance(&self, cx: &mut ShadeCtx, v: &Vertex) -> Color {
        let (ok, l) = cx.counters.time_query(|| self.cache.query(v.hit.p, v.n));
        if ok {
            return l.irradiance();
        }
        self.temporaries.fetch_add(1, Ordering::Relaxed);
        self.recipe.compute(&self.shading, cx, v).map_or(Color::ZERO, |s| s.e)
    }

    /// Radiance along a primary ray.
    pub fn li(&self, scene: &Scene, ray: Ray, diff: Option<&RayDifferential>, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        let mut scratch = Vec::new();
        let mut cx = ShadeCtx { scene, sampler, counters, scratch: &mut scratch };
        render_vertex(&self.shading, self.settings.view, &mut cx, ray, diff, |v, cx| self.irradiance(cx, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::caches::kdtree::SceneLength;
    use crate::film::Reconstruction;
    use crate::integrators::photon::priming::PrimePoints;
    use crate::integrators::test_scenes::{box_scene, box_scene_with, check_furnace, furnace_scene, image_mean};
    use crate::integrators::Integrator;
    use crate::render::{render, RenderSettings};
    use crate::scene::PixelFilter;

    fn small(photons: u64) -> WardSettings {
        let mut s = WardSettings::default();
        s.photons.photons = photons;
        s.density.n_max = 50;
        s.caustic.n_max = 50;
        s
    }

    #[test]
    fn bad_settings_are_refused_with_clear_messages() {
        let scene = box_scene(4);
        let cases: Vec<(WardSettings, &str)> = vec![
            (WardSettings { cache: WardCacheSettings { a: Some(0.0), ..Default::default() }, ..small(10) }, "cache.a"),
            (WardSettings { cache: WardCacheSettings { a: Some(f32::NAN), ..Default::default() }, ..small(10) }, "cache.a"),
            (
                WardSettings { cache: WardCacheSettings { q_min: SceneLength::Absolute(-1.0), ..Default::default() }, ..small(10) },
                "cache.q_min",
            ),
            (
                WardSettings {
                    cache: WardCacheSettings {
                        q_min: SceneLength::Relative(0.5),
                        max_radius: SceneLength::Relative(0.1),
                        ..Default::default()
                    },
                    ..small(10)
                },
                "cache.max_radius",
            ),
            (WardSettings { cache: WardCacheSettings { batch: 0, ..Default::default() }, ..small(10) }, "cache.batch"),
            (
                WardSettings {
                    cache: WardCacheSettings { prime: PrimePoints::Grid { columns: Some(0) }, ..Default::default() },
                    ..small(10)
                },
                "cache.prime",
            ),
            (WardSettings { density: DensitySettings { n_max: 0, ..Default::default() }, ..small(10) }, "density.n_max"),
            (WardSettings { sample: WardSampleMode::FinalGather, gather_rays: 0, ..small(10) }, "gather_rays"),
            (small(0), "photons"),
        ];
        for (s, field) in cases {
            let e = WardIntegrator::build(&scene, s).err().expect("refused");
            assert!(e.to_string().contains(field), "{e} should name {field}");
        }
    }

    /// The cache's irradiance matches the photon density estimate it interpolates (no bias
    /// with a fixed radius; a few percent dark with gathered radii, see [`PhotonRadius`]),
    /// samples respect `q_min`, and the render is lit and finite.
    #[test]
    fn cache_matches_the_density_estimate_and_spacing_holds() {
        let scene = box_scene(64);
        for (radius, tolerance) in [(PhotonRadius::SearchRadius, 0.03), (PhotonRadius::Gathered, 0.08)] {
            let mut s = small(100_000);
            s.view = CacheView::Irradiance;
            s.cache.photon_radius = radius;
            let w = WardIntegrator::build(&scene, s.clone()).unwrap();
            let st = &w.stats;
            assert!(st.m_e > 20 && st.m_e < st.prime_points, "{st:?}");
            assert_eq!(st.prime.inserted, st.m_e);
            // spacing: no two samples with the same normal closer than q_min
            let q_min = s.cache.q_min.resolve(2.0);
            let smp = w.cache.samples();
            for (i, a) in smp.iter().enumerate() {
                for b in &smp[i + 1..] {
                    if a.n.dot(b.n) > 0.999 {
                        assert!(a.p.distance(b.p) >= q_min * 0.999);
                    }
                }
            }
            // interpolated vs direct estimate at another grid's points
            let primer = Primer::new(&scene, &w.shading, PrimePoints::Grid { columns: Some(24) }, 0);
            let pts: Vec<Vertex> = (0..primer.len()).filter_map(|i| primer.vertex(i)).collect();
            let (mut diff, mut sum_i, mut sum_d, mut n) = (0.0f64, 0.0f64, 0.0f64, 0);
            let mut scratch = Vec::new();
            for p in &pts {
                let (ok, l) = w.cache.query(p.hit.p, p.n);
                let direct =
                    crate::caches::kdtree::photon_irradiance(&w.shading.global, p.hit.p, p.n, w.shading.global_density, &mut scratch).e;
                if ok {
                    n += 1;
                    diff += (l.irradiance() - direct).abs().element_sum() as f64;
                    sum_i += l.irradiance().element_sum() as f64;
                    sum_d += direct.element_sum() as f64;
                }
            }
            assert!(n * 10 > pts.len() * 8, "{radius:?}: only {n} of {} points covered", pts.len());
            assert!((sum_i / sum_d - 1.0).abs() < tolerance, "{radius:?}: interpolated / direct = {}", sum_i / sum_d);
            // of the order of the estimates' own noise (n_max 50: ~14%)
            assert!(diff / sum_d < 0.25, "{radius:?}: mean relative difference {}", diff / sum_d);
        }
        // the render mode: a lit, finite image
        let w = WardIntegrator::build(&scene, small(50_000)).unwrap();
        let (img, _) = render(&scene, &Integrator::Ward(Box::new(w)), &RenderSettings { spp: 1, ..Default::default() }, &|_, _| {});
        assert!(img.data.iter().all(|c| c.is_finite() && c.min_element() >= 0.0));
        assert!(img.data.iter().map(|c| c.y as f64).sum::<f64>() > 0.0);
    }

    #[test]
    fn furnace_is_analytic() {
        let scene = furnace_scene(0.5, 1.0);
        for (mode, tolerance) in [(WardSampleMode::Photons, 0.03), (WardSampleMode::FinalGather, 0.04)] {
            let mut means = Vec::new();
            for view in [CacheView::Render, CacheView::Irradiance] {
                let mut s = small(100_000);
                s.sample = mode;
                s.gather_rays = 32;
                s.view = view;
                let w = WardIntegrator::build(&scene, s).unwrap();
                assert!(w.stats.m_e > 0);
                let (img, _) = render(&scene, &Integrator::Ward(Box::new(w)), &RenderSettings { spp: 2, ..Default::default() }, &|_, _| {});
                means.push(image_mean(&img.data));
            }
            check_furnace(means[0], means[1], tolerance, &format!("ward {mode:?}"));
        }
    }

    /// Priming with the render's own samples serves every lookup of that render from the
    /// cache, whatever the filter and the reconstruction (the primer draws its positions with
    /// the render's `film::camera_sample`: with the default splatting film they are uniform in
    /// the pixel, not filter samples); another seed's lookups are not all covered.
    #[test]
    fn priming_with_the_render_samples_leaves_no_temporary() {
        for (filter, reconstruction) in [
            (PixelFilter::Box, Reconstruction::Splat),
            (PixelFilter::Tent, Reconstruction::Splat),
            (PixelFilter::Tent, Reconstruction::ImportanceSampled),
        ] {
            let scene = box_scene_with(32, filter);
            let mut s = small(20_000);
            s.cache.a = Some(0.5);
            s.cache.prime = PrimePoints::RenderSamples { spp: 2, seed: 7, reconstruction, sampler: Default::default() };
            let integ = Integrator::Ward(Box::new(WardIntegrator::build(&scene, s).unwrap()));
            let Integrator::Ward(w) = &integ else { unreachable!() };
            assert_eq!(w.stats.prime_points, 2 * 32 * 32);
            render(&scene, &integ, &RenderSettings { spp: 2, seed: 7, reconstruction, ..Default::default() }, &|_, _| {});
            assert_eq!(w.temporary_samples(), 0, "{filter:?}, {reconstruction:?}");
            render(&scene, &integ, &RenderSettings { spp: 2, seed: 8, reconstruction, ..Default::default() }, &|_, _| {});
            assert!(w.temporary_samples() > 0, "{filter:?}, {reconstruction:?}");
            assert_eq!(integ.render_report()["temporaries"], w.temporary_samples());
        }
    }

    #[test]
    fn images_are_identical_for_one_and_two_threads() {
        let scene = box_scene(16);
        for mode in [WardSampleMode::Photons, WardSampleMode::FinalGather] {
            let mut s = small(20_000);
            s.sample = mode;
            s.gather_rays = 8;
            s.cache.batch = 16;
            let run = |t| {
                rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap().install(|| {
                    let w = WardIntegrator::build(&scene, s.clone()).unwrap();
                    let samples = w.cache.samples().to_vec();
                    let (img, _) =
                        render(&scene, &Integrator::Ward(Box::new(w)), &RenderSettings { spp: 2, ..Default::default() }, &|_, _| {});
                    (samples, img.data)
                })
            };
            let (a, b) = (run(1), run(2));
            assert!(!a.0.is_empty());
            assert_eq!(a.0, b.0, "{mode:?}: caches differ");
            assert_eq!(a.1, b.1, "{mode:?}: images differ");
        }
    }
}
