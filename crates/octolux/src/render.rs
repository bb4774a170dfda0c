//! The render loop: pixels in tiles over rayon, samples per pixel with deterministic
//! samplers, the reconstruction filter realised by filter importance sampling, per-pixel
//! accumulation in f64.
//!
//! Determinism: pixel `(x, y)` sample `s` uses `Sampler::new(seed, y·width + x, s)`, and the
//! pixel's value is the mean of its own samples, so the image is bit-identical for any
//! thread count and tile order. With a time budget, whole passes of `spp` samples are added
//! until the budget is spent (the result then depends on the machine's speed).

use crate::integrators::{Integrator, RayCounters};
use crate::material::Image;
use crate::math::{Color, Ray};
use crate::prepared::Scene;
use crate::sampling::Sampler;
use crate::scene::PixelFilter;
use glam::Vec2;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Settings of the render loop.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct RenderSettings {
    /// Samples per pixel (per pass when `time_budget_s` is set).
    pub spp: u32,
    pub seed: u64,
    /// Optional wall-clock budget in seconds: passes of `spp` samples repeat until it is spent
    /// (at least one pass always runs).
    pub time_budget_s: Option<f64>,
    /// Tile edge in pixels.
    pub tile: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings { spp: 64, seed: 0, time_budget_s: None, tile: 16 }
    }
}

/// Statistics of one render.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct RenderStats {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel actually taken.
    pub spp: u32,
    pub passes: u32,
    pub samples: u64,
    pub render_s: f64,
    pub samples_per_second: f64,
    pub counters: RayCounters,
    pub rays_per_second: f64,
}

/// Offset from the pixel centre, in pixels, distributed as the reconstruction filter.
#[inline]
pub fn sample_filter(filter: PixelFilter, sampler: &mut Sampler) -> Vec2 {
    match filter {
        PixelFilter::Box => sampler.next_2d() - Vec2::splat(0.5),
        PixelFilter::Tent => {
            let u = sampler.next_2d();
            Vec2::new(sample_tent(u.x), sample_tent(u.y))
        }
        PixelFilter::Gaussian { stddev } => {
            let radius = 4.0 * stddev;
            loop {
                let u = sampler.next_2d();
                let r = stddev * (-2.0 * (1.0 - u.x).ln()).sqrt();
                let (s, c) = (std::f32::consts::TAU * u.y).sin_cos();
                let v = Vec2::new(r * c, r * s);
                if v.x.abs() <= radius && v.y.abs() <= radius {
                    break v;
                }
            }
        }
    }
}

/// Tent of radius 1 on [-1, 1] by inversion.
#[inline]
fn sample_tent(u: f32) -> f32 {
    if u < 0.5 {
        (2.0 * u).sqrt() - 1.0
    } else {
        1.0 - (2.0 - 2.0 * u).sqrt()
    }
}

/// Render the scene's film with `integrator`. `progress(done_pixels, total_pixels)` is called
/// after each tile (from worker threads).
pub fn render(
    scene: &Scene,
    integrator: &Integrator,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> (Image, RenderStats) {
    let (w, h) = (scene.film.width, scene.film.height);
    let tile = settings.tile.max(1);
    let tiles_x = w.div_ceil(tile);
    let tiles_y = h.div_ceil(tile);
    let n_tiles = (tiles_x * tiles_y) as usize;
    let spp = settings.spp.max(1);
    let mut accum = vec![[0.0f64; 3]; (w * h) as usize];
    let mut counters = RayCounters::default();
    let start = Instant::now();
    let mut passes = 0u32;
    let total_pixels = (w as u64) * (h as u64);
    loop {
        let done = std::sync::atomic::AtomicU64::new(0);
        let pass = passes;
        let results: Vec<(u32, Vec<[f64; 3]>, RayCounters)> = (0..n_tiles as u32)
            .into_par_iter()
            .map(|ti| {
                let (tx, ty) = (ti % tiles_x, ti / tiles_x);
                let (x0, y0) = (tx * tile, ty * tile);
                let (x1, y1) = ((x0 + tile).min(w), (y0 + tile).min(h));
                let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
                let mut c = RayCounters::default();
                for y in y0..y1 {
                    for x in x0..x1 {
                        let pixel = (y * w + x) as u64;
                        let mut sum = [0.0f64; 3];
                        for s in 0..spp {
                            let sample_index = pass as u64 * spp as u64 + s as u64;
                            let mut sampler = Sampler::new(settings.seed, pixel, sample_index);
                            let off = sample_filter(scene.film.filter, &mut sampler);
                            let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + off;
                            let (o, d, tmin) = scene.camera.generate_ray(film);
                            let ray = Ray { o, d, tmin, tmax: f32::INFINITY };
                            let l = integrator.li(scene, ray, &mut sampler, &mut c);
                            // A non-finite sample is a bug; drop it rather than poison the pixel.
                            if l.is_finite() {
                                sum[0] += l.x as f64;
                                sum[1] += l.y as f64;
                                sum[2] += l.z as f64;
                            }
                        }
                        out.push(sum);
                    }
                }
                let n = out.len() as u64;
                let d = done.fetch_add(n, std::sync::atomic::Ordering::Relaxed) + n;
                progress(d, total_pixels);
                (ti, out, c)
            })
            .collect();
        for (ti, out, c) in results {
            counters += c;
            let (tx, ty) = (ti % tiles_x, ti / tiles_x);
            let (x0, y0) = (tx * tile, ty * tile);
            let x1 = (x0 + tile).min(w);
            let tw = x1 - x0;
            for (i, s) in out.iter().enumerate() {
                let (x, y) = (x0 + i as u32 % tw, y0 + i as u32 / tw);
                let a = &mut accum[(y * w + x) as usize];
                a[0] += s[0];
                a[1] += s[1];
                a[2] += s[2];
            }
        }
        passes += 1;
        match settings.time_budget_s {
            Some(b) if start.elapsed().as_secs_f64() < b => continue,
            _ => break,
        }
    }
    let render_s = start.elapsed().as_secs_f64();
    let total_spp = spp * passes;
    let inv = 1.0 / total_spp as f64;
    let data = accum.iter().map(|a| Color::new((a[0] * inv) as f32, (a[1] * inv) as f32, (a[2] * inv) as f32)).collect();
    let samples = total_pixels * total_spp as u64;
    let stats = RenderStats {
        width: w,
        height: h,
        spp: total_spp,
        passes,
        samples,
        render_s,
        samples_per_second: samples as f64 / render_s.max(1e-9),
        counters,
        rays_per_second: (counters.rays + counters.shadow_rays) as f64 / render_s.max(1e-9),
    };
    (Image { width: w, height: h, data }, stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tent_sampling_matches_the_tent_density() {
        // Histogram of tent samples vs the density 1 - |x| on [-1, 1].
        let n = 200_000;
        let bins = 20;
        let mut h = vec![0usize; bins];
        for i in 0..n {
            let x = sample_tent((i as f32 + 0.5) / n as f32);
            assert!((-1.0..=1.0).contains(&x));
            h[(((x + 1.0) / 2.0 * bins as f32) as usize).min(bins - 1)] += 1;
        }
        for (b, &c) in h.iter().enumerate() {
            let (a, z) = (-1.0 + 2.0 * b as f64 / bins as f64, -1.0 + 2.0 * (b + 1) as f64 / bins as f64);
            let cdf = |x: f64| if x < 0.0 { 0.5 * (1.0 + x).powi(2) } else { 1.0 - 0.5 * (1.0 - x).powi(2) };
            let expect = (cdf(z) - cdf(a)) * n as f64;
            assert!((c as f64 - expect).abs() < 0.01 * n as f64 / bins as f64 + 2.0, "bin {b}: {c} vs {expect}");
        }
    }
}
