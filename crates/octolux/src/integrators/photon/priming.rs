//! The priming pass shared by the irradiance-cache baselines (§9: Ward's cache, and
//! Christensen's configuration C), and the Ward-cache settings they share.
//!
//! Ward fills his cache lazily while rendering, which makes the result depend on the order of
//! the lookups. Here the cache is filled before rendering (`Primer`): camera paths traced like
//! the render's (specular chains followed with a per-path sampler), their first non-delta hits
//! taken as points — either one ray through the centre of each cell of a grid (default: one
//! per pixel), or the render's own first-pass samples ([`PrimePoints::RenderSamples`]: same seed,
//! spp and reconstruction as the render, drawn by the render's own
//! [`crate::film::camera_sample`], so the render's lookups happen exactly at primed points).
//! Pixels are ordered coarse to fine (stride 2^k, 2^(k-1), …, 1) and samples sample-major, so
//! each batch is spread over the image, and [`WardCache::prime_batch`] inserts samples batch by
//! batch (parallel computation, in-order insertion): the cache is identical for any thread
//! count. `SampleRecipe` says how a sample is computed, for priming and for the render's
//! temporary samples alike.

use super::{ShadeCtx, Shading, Vertex};
use crate::caches::kdtree::{SceneLength, SettingsError};
use crate::caches::ward::{IrradianceSample, PrimeStats, WardCache};
use crate::film::{camera_sample, Pixel, Reconstruction};
use crate::integrators::common::{walk_specular, RayCounters};
use crate::math::{Color, Ray};
use crate::sampling::{Sampler, SamplerKind};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Stream of the priming pass's camera paths.
pub const PRIME_STREAM: u64 = 0x0050_5249_4d45; // "PRIME"
/// Stream of the priming pass's sample computations (final gathering).
pub const PRIME_SAMPLE_STREAM: u64 = 0x0050_5249_4d46;

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
#[serde(default, deny_unknown_fields)]
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

/// Which camera samples prime the cache.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum PrimePoints {
    /// One ray through the centre of each cell of a grid of `columns` columns (rows from the
    /// film's aspect); `None`: the film width, one ray per pixel.
    Grid { columns: Option<u32> },
    /// The render's own first-pass camera samples: give the render's `spp`, `seed` and
    /// `reconstruction` (default: splatting, the render's default), and every lookup of a
    /// render with those settings finds the cache sufficient (no temporary sample; later
    /// passes of a time-budget render may still compute some). Worth it with
    /// `final_gather`, whose samples shrink to `q_min` in corners, below a pixel: on
    /// `cornell-box` 128², 64 spp, the grid left 22 826 temporary samples (t_v 21.7 s), this
    /// none (t_v 0.6 s; priming 12.3 s instead of 2.6 s).
    RenderSamples {
        spp: u32,
        seed: u64,
        #[serde(default)]
        reconstruction: Reconstruction,
        /// The render's sampler kind (default: independent).
        #[serde(default)]
        sampler: SamplerKind,
    },
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
        let pixel = Pixel { x, y, width: self.w };
        let (mut sampler, film) = match self.points {
            PrimePoints::Grid { .. } => {
                let (sx, sy) = (self.scene.film.width.max(1) as f32 / self.w as f32, self.scene.film.height.max(1) as f32 / self.h as f32);
                (Sampler::new(self.photon_seed, pixel.index(), PRIME_STREAM), Vec2::new((x as f32 + 0.5) * sx, (y as f32 + 0.5) * sy))
            }
            // The render's own rule: uniform positions with splatting, filter samples otherwise.
            PrimePoints::RenderSamples { seed, reconstruction, sampler, .. } => {
                camera_sample(sampler, seed, pixel, sample, self.scene.film.filter, reconstruction)
            }
        };
        let (o, d, tmin) = self.scene.camera.generate_ray(film);
        let ray = Ray { o, d, tmin, tmax: f32::INFINITY };
        walk_specular(self.scene, ray, None, self.shading.max_depth, false, &mut sampler, &mut RayCounters::default()).vertex
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

    pub fn compute(&self, sh: &Shading, cx: &mut ShadeCtx, v: &Vertex) -> Option<IrradianceSample> {
        if cx.scratch.capacity() == 0 {
            *cx.scratch = sh.scratch();
        }
        let (e, r) = match self.mode {
            WardSampleMode::Photons => {
                let d = sh.irradiance_estimate(&sh.global, sh.global_density, v.hit.p, v.n, cx.scratch, cx.counters);
                (d.e, self.photon_radius(d.r, sh))
            }
            WardSampleMode::FinalGather => sh.gather_irradiance(cx, &v.hit, v.n, self.gather_rays),
        };
        self.make(v, e, r)
    }
}
