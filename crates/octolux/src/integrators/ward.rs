//! Ward's irradiance cache as the paper adapted it (METHOD.md §9, "Ward, configuration A"):
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
//!   [`PhotonRadius::SearchRadius`] uses `r_max` for every sample instead (see its docs for
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
//! Priming pass before rendering ([`PrimePoints`]): camera paths traced like the render's (specular
//! chains followed with a per-path sampler), their first non-delta hits taken as points —
//! either one ray through the centre of each cell of a grid (default: one per pixel), or the
//! render's own first-pass samples (same seed and spp as the render, so the render's lookups
//! happen exactly at primed points). Pixels are ordered coarse to fine (stride 2^k, 2^(k-1),
//! …, 1) and samples sample-major, so each batch is spread over the image, and
//! [`WardCache::prime_batch`] inserts samples batch by batch (parallel computation, in-order
//! insertion). The render then only reads the cache; a lookup that finds it insufficient (a
//! point the priming did not see, e.g. jittered inside a pixel with the grid priming) computes
//! a temporary sample with the same recipe and does not store it
//! ([`WardIntegrator::temporary_samples`] counts them: 0 with `render_samples` priming and the
//! render's settings). Images are identical for any thread count.
//!
//! `F_m` = bytes of the cache (samples, octree, index lists) + the global map (needed for
//! temporary samples) + the caustic map (caustics).

use super::photonmap::{check_max_depth, shade_irradiance, BaselineError, CacheView, PhotonMapStats, Shading, Vertex};
use super::RayCounters;
use crate::caches::kdtree::{scene_size, DensitySettings, Neighbor, SceneLength, SettingsError};
use crate::caches::ward::{IrradianceSample, PrimeStats, WardCache, WardCacheStats};
use crate::math::{Color, Ray};
use crate::photon_pass::{trace_photons, PhotonSettings};
use crate::render::sample_filter;
use crate::sampling::Sampler;
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Stream of the priming pass's camera paths.
pub(crate) const PRIME_STREAM: u64 = 0x0050_5249_4d45; // "PRIME"
/// Stream of the priming pass's sample computations (final gathering).
pub(crate) const PRIME_SAMPLE_STREAM: u64 = 0x0050_5249_4d46;

/// How an irradiance sample is computed.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum WardSampleMode {
    /// Photon density estimate (the paper's adaptation).
    #[default]
    Photons,
    /// Hemisphere final gathering (Ward 1988).
    FinalGather,
}

/// The validity radius `R_i` of a photon-computed sample.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum PhotonRadius {
    /// The radius of the disk the estimate gathered (distance to the `n_max`-th photon, or
    /// `r_max`). Dense photons give small radii, so a dim sample reaches further than a bright
    /// one and borders between them are interpolated a little dark (measured: interpolated /
    /// direct estimate = 0.96 over the test box, against 0.99 with `search_radius`).
    #[default]
    Gathered,
    /// The estimate's search radius `r_max` for every sample (spacing independent of the light).
    SearchRadius,
}

/// Settings of a Ward cache and of its priming pass (shared with `christensen`'s
/// configuration C).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct WardCacheSettings {
    /// Ward's accuracy `a`: a sample is valid where `w_i > 1/a`; smaller is denser. `None`
    /// picks one per kind of `R_i` (see [`Self::accuracy`]), all with a reach `a R_i` of about
    /// 20–30 mm in the 559 mm `cornell-box`: 2 for gathered photon radii (`m_e` = 1789 with 1M
    /// photons there, close to the paper's 1824, table 2), 1 for `search_radius`, and 0.2 for
    /// final gathering (Radiance's usual 0.1–0.2 with harmonic mean distances of 100–200 mm).
    pub a: Option<f32>,
    /// Least distance between two samples (paper's table 2: 1.0 in its 559 mm scene).
    pub q_min: SceneLength,
    /// Largest validity radius `R_i`.
    pub max_radius: SceneLength,
    /// Least `Σ w_i` for the cache to be sufficient (0: Ward's rule, any valid sample).
    pub min_weight: f32,
    /// The camera samples that prime the cache.
    pub prime: PrimePoints,
    /// Points per priming batch.
    pub batch: u32,
    /// `R_i` of photon-computed samples.
    pub photon_radius: PhotonRadius,
}

impl Default for WardCacheSettings {
    fn default() -> Self {
        WardCacheSettings {
            a: None,
            q_min: SceneLength::paper(1.0),
            max_radius: SceneLength::Relative(0.25),
            min_weight: 0.0,
            prime: PrimePoints::Grid { columns: None },
            batch: 128,
            photon_radius: PhotonRadius::Gathered,
        }
    }
}

impl WardCacheSettings {
    /// The accuracy `a` for samples computed by `mode` (module docs of the defaults).
    pub fn accuracy(&self, mode: WardSampleMode) -> f32 {
        self.a.unwrap_or(match (mode, self.photon_radius) {
            (WardSampleMode::FinalGather, _) => 0.2,
            (WardSampleMode::Photons, PhotonRadius::Gathered) => 2.0,
            (WardSampleMode::Photons, PhotonRadius::SearchRadius) => 1.0,
        })
    }

    /// Check the settings for samples computed by `mode`; `prefix` names them in messages.
    pub fn validate(&self, prefix: &str, mode: WardSampleMode) -> Result<(), SettingsError> {
        let f = |name: &str| format!("{prefix}.{name}");
        let a = self.accuracy(mode);
        if !(a.is_finite() && a > 0.0) {
            return Err(SettingsError::new(&f("a"), format!("the accuracy {a} must be finite and positive")));
        }
        self.q_min.check(&f("q_min"), true)?;
        self.max_radius.check(&f("max_radius"), false)?;
        if !(self.min_weight.is_finite() && self.min_weight >= 0.0) {
            return Err(SettingsError::new(&f("min_weight"), format!("{} must be finite and non-negative", self.min_weight)));
        }
        match self.prime {
            PrimePoints::Grid { columns: Some(0) } => {
                return Err(SettingsError::new(&f("prime"), "the priming grid needs at least one column (got 0)"))
            }
            PrimePoints::RenderSamples { spp: 0, .. } => {
                return Err(SettingsError::new(&f("prime"), "priming with the render's samples needs spp ≥ 1 (got 0)"))
            }
            _ => {}
        }
        if self.batch == 0 {
            return Err(SettingsError::new(&f("batch"), "a priming batch holds at least one point (got 0)"));
        }
        // Both lengths of the same kind compare without a scene.
        if let (SceneLength::Relative(q), SceneLength::Relative(m)) | (SceneLength::Absolute(q), SceneLength::Absolute(m)) =
            (self.q_min, self.max_radius)
        {
            if q / a > m {
                return Err(SettingsError::new(&f("max_radius"), format!("{m} is below q_min / a = {}: no radius is allowed", q / a)));
            }
        }
        Ok(())
    }

    /// `[R_min, R_max]` in scene units for accuracy `a` (`R_min = q_min / a`; `R_max ≥ R_min`).
    pub fn radius_range(&self, scene_size: f32, a: f32) -> (f32, f32) {
        let lo = (self.q_min.resolve(scene_size) / a).max(1e-6 * scene_size);
        (lo, self.max_radius.resolve(scene_size).max(lo))
    }
}

/// Settings of the `ward` integrator.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default)]
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
        if self.photons.photons == 0 {
            return Err(SettingsError::new("photons.photons", "at least one photon must be emitted (got 0)"));
        }
        self.density.validate("density")?;
        self.caustic.validate("caustic")?;
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

/// Which camera samples prime the cache.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PrimePoints {
    /// One ray through the centre of each cell of a grid of `columns` columns (rows from the
    /// film's aspect); `None`: the film width, one ray per pixel.
    Grid { columns: Option<u32> },
    /// The render's own first-pass camera samples: give the render's `spp` and `seed`, and
    /// every lookup of a render with those settings finds the cache sufficient (no temporary
    /// sample; later passes of a time-budget render may still compute some). Worth it with
    /// `final_gather`, whose samples shrink to `q_min` in corners, below a pixel: on
    /// `cornell-box` 128², 64 spp, the grid left 22 826 temporary samples (t_v 21.7 s), this
    /// none (t_v 0.6 s; priming 12.3 s instead of 2.6 s).
    RenderSamples { spp: u32, seed: u64 },
}

impl Default for PrimePoints {
    fn default() -> Self {
        PrimePoints::Grid { columns: None }
    }
}

/// The priming pass: an ordered, lazily traced list of camera paths (module docs).
pub(crate) struct Primer<'a> {
    scene: &'a Scene,
    shading: &'a Shading,
    points: PrimePoints,
    /// Pixels (or grid cells) in coarse-to-fine order.
    order: Vec<(u32, u32)>,
    w: u32,
    h: u32,
    spp: u64,
    photon_seed: u64,
}

impl<'a> Primer<'a> {
    pub fn new(scene: &'a Scene, shading: &'a Shading, points: PrimePoints, photon_seed: u64) -> Self {
        let (fw, fh) = (scene.film.width.max(1), scene.film.height.max(1));
        let (w, h, spp) = match points {
            PrimePoints::Grid { columns } => {
                let w = columns.unwrap_or(fw).max(1);
                (w, ((w as f64 * fh as f64 / fw as f64).round() as u32).max(1), 1)
            }
            PrimePoints::RenderSamples { spp, .. } => (fw, fh, spp.max(1) as u64),
        };
        let mut order: Vec<(u32, u32)> = Vec::with_capacity((w as usize) * (h as usize));
        let top = w.max(h).next_power_of_two();
        let mut stride = top;
        while stride >= 1 {
            for y in (0..h).step_by(stride as usize) {
                for x in (0..w).step_by(stride as usize) {
                    if stride == top || x % (2 * stride) != 0 || y % (2 * stride) != 0 {
                        order.push((x, y));
                    }
                }
            }
            stride /= 2;
        }
        Primer { scene, shading, points, order, w, h, spp, photon_seed }
    }

    /// Camera paths: sample-major (all pixels of sample 0, then of sample 1, ...).
    pub fn len(&self) -> u64 {
        self.order.len() as u64 * self.spp
    }

    /// First non-delta vertex of camera path `i`, traced as the render traces it.
    pub fn vertex(&self, i: u64) -> Option<Vertex> {
        let n = self.order.len() as u64;
        let (sample, k) = (i / n, (i % n) as usize);
        let (x, y) = self.order[k];
        let pixel = y as u64 * self.w as u64 + x as u64;
        let (mut sampler, film) = match self.points {
            PrimePoints::Grid { .. } => {
                let (sx, sy) = (self.scene.film.width.max(1) as f32 / self.w as f32, self.scene.film.height.max(1) as f32 / self.h as f32);
                (Sampler::new(self.photon_seed, pixel, PRIME_STREAM), Vec2::new((x as f32 + 0.5) * sx, (y as f32 + 0.5) * sy))
            }
            PrimePoints::RenderSamples { seed, .. } => {
                let mut sampler = Sampler::new(seed, pixel, sample);
                let off = sample_filter(self.scene.film.filter, &mut sampler);
                (sampler, Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + off)
            }
        };
        let (o, d, tmin) = self.scene.camera.generate_ray(film);
        let ray = Ray { o, d, tmin, tmax: f32::INFINITY };
        let mut ignored = Color::ZERO;
        self.shading.first_vertex(self.scene, ray, &mut sampler, &mut RayCounters::default(), false, &mut ignored)
    }

    /// Prime `cache` in batches of `batch` camera paths; `compute(i, vertex)` makes the
    /// sample of path `i`.
    pub fn prime<F>(&self, cache: &mut WardCache, batch: usize, compute: F) -> PrimeStats
    where
        F: Fn(u64, &Vertex) -> Option<IrradianceSample> + Sync,
    {
        let batch = batch.max(1) as u64;
        let mut stats = PrimeStats::default();
        let mut start = 0u64;
        while start < self.len() {
            let end = (start + batch).min(self.len());
            let verts: Vec<(u64, Vertex)> = (start..end).into_par_iter().filter_map(|i| self.vertex(i).map(|v| (i, v))).collect();
            let pn: Vec<(Vec3, Vec3)> = verts.iter().map(|(_, v)| (v.hit.p, v.n)).collect();
            stats += cache.prime_batch(&pn, |j| compute(verts[j].0, &verts[j].1));
            start = end;
        }
        stats
    }
}

/// How Ward samples are computed, resolved to scene units.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SampleRecipe {
    pub mode: WardSampleMode,
    pub gather_rays: u32,
    pub photon_radius: PhotonRadius,
    pub radius_min: f32,
    pub radius_max: f32,
}

impl SampleRecipe {
    /// A sample at `v` with irradiance `e` and raw radius `r` (clamped here), if valid.
    pub fn make(&self, v: &Vertex, e: Color, r: f32) -> Option<IrradianceSample> {
        let r = if r.is_nan() { self.radius_max } else { r.clamp(self.radius_min, self.radius_max) };
        let s = IrradianceSample { p: v.hit.p, n: v.n, e: e.max(Color::ZERO), r };
        s.is_valid().then_some(s)
    }

    /// `R_i` of a photon-computed sample whose estimate gathered a disk of radius `gathered`.
    pub fn photon_radius(&self, gathered: f32, sh: &Shading) -> f32 {
        match self.photon_radius {
            PhotonRadius::Gathered => gathered,
            PhotonRadius::SearchRadius => sh.global_density.r_max,
        }
    }

    pub fn compute(
        &self,
        scene: &Scene,
        sh: &Shading,
        v: &Vertex,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Vec<Neighbor>,
    ) -> Option<IrradianceSample> {
        let (e, r) = match self.mode {
            WardSampleMode::Photons => {
                let d = sh.irradiance_estimate(&sh.global, sh.global_density, v.hit.p, v.n, scratch, counters);
                (d.e, self.photon_radius(d.r, sh))
            }
            WardSampleMode::FinalGather => sh.gather_irradiance(scene, &v.hit, v.n, self.gather_rays, sampler, counters, scratch),
        };
        self.make(v, e, r)
    }
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
            recipe.compute(scene, &shading, v, &mut sampler, &mut RayCounters::default(), &mut scratch)
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
    fn irradiance(
        &self,
        scene: &Scene,
        v: &Vertex,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Vec<Neighbor>,
    ) -> Color {
        let t = Instant::now();
        let (ok, l) = self.cache.query(v.hit.p, v.n);
        counters.cache_queries += 1;
        counters.cache_query_ns += t.elapsed().as_nanos() as u64;
        if ok {
            return l.irradiance();
        }
        self.temporaries.fetch_add(1, Ordering::Relaxed);
        self.recipe.compute(scene, &self.shading, v, sampler, counters, scratch).map_or(Color::ZERO, |s| s.e)
    }

    /// Radiance along a primary ray.
    pub fn li(&self, scene: &Scene, ray: Ray, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        render_vertex(&self.shading, self.settings.view, scene, ray, sampler, counters, |v, s, c, scratch| {
            self.irradiance(scene, v, s, c, scratch)
        })
    }
}

/// The common camera path of the irradiance-cache baselines: emission on the way, then at the
/// first non-delta vertex direct (NEE) + `f(wo, n) E` + caustics, or the irradiance views.
pub(crate) fn render_vertex(
    sh: &Shading,
    view: CacheView,
    scene: &Scene,
    ray: Ray,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
    irradiance: impl FnOnce(&Vertex, &mut Sampler, &mut RayCounters, &mut Vec<Neighbor>) -> Color,
) -> Color {
    let mut result = Color::ZERO;
    let Some(v) = sh.first_vertex(scene, ray, sampler, counters, view == CacheView::Render, &mut result) else { return result };
    let mut scratch = sh.scratch();
    let material = &scene.materials[v.hit.material as usize];
    match view {
        CacheView::Render => {
            let mut l = super::direct_light(scene, &v.hit, material, v.wo, sampler, counters);
            let e = irradiance(&v, sampler, counters, &mut scratch);
            l += shade_irradiance(scene, &v.hit, material, v.wo, e);
            l += sh.caustics(scene, &v, material, &mut scratch, counters);
            result += v.throughput * l;
        }
        CacheView::Irradiance | CacheView::IrradianceAll => {
            let mut e = irradiance(&v, sampler, counters, &mut scratch);
            if view == CacheView::IrradianceAll {
                e += sh.caustic_irradiance(&v, &mut scratch, counters);
            }
            result += v.throughput * e;
        }
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::photonmap::tests::box_scene;
    use crate::integrators::Integrator;
    use crate::render::{render, RenderSettings};

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
        use crate::integrators::photonmap::tests::{check_furnace, furnace_scene, image_mean};
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
    /// cache; another seed's lookups are not all covered.
    #[test]
    fn priming_with_the_render_samples_leaves_no_temporary() {
        let scene = box_scene(32);
        let mut s = small(20_000);
        s.cache.a = Some(0.5);
        s.cache.prime = PrimePoints::RenderSamples { spp: 2, seed: 7 };
        let integ = Integrator::Ward(Box::new(WardIntegrator::build(&scene, s).unwrap()));
        let Integrator::Ward(w) = &integ else { unreachable!() };
        assert_eq!(w.stats.prime_points, 2 * 32 * 32);
        render(&scene, &integ, &RenderSettings { spp: 2, seed: 7, ..Default::default() }, &|_, _| {});
        assert_eq!(w.temporary_samples(), 0);
        render(&scene, &integ, &RenderSettings { spp: 2, seed: 8, ..Default::default() }, &|_, _| {});
        assert!(w.temporary_samples() > 0);
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
