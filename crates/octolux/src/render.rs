//! The render loop: pixels in tiles over rayon, samples per pixel with deterministic
//! samplers, per-pixel accumulation in f64, and the reconstruction filter realised in one of
//! two ways ([`Reconstruction`]):
//!
//! - **splatting** (the default, as Mitsuba 3 and pbrt-v3 do): a sample's position is uniform
//!   in its pixel and its value is added, weighted by the filter, to every pixel whose centre
//!   lies within the filter's radius; a pixel's value is Σ wᵢ·Lᵢ / Σ wᵢ. A tent of radius 1
//!   spreads each sample over up to 3x3 pixels, which cuts per-pixel variance by about
//!   (∫w)²/∫w² = 2.25x against
//! - **filter importance sampling**: the sample position is drawn from the filter and the
//!   sample goes to its own pixel with weight 1 (unbiased, independent pixels, noisier).
//!
//! Both converge to the same image ∫w(x−p)L(x)dx / ∫w.
//!
//! Positions and samplers come from [`crate::film::camera_sample`], the rule the priming
//! passes of the irradiance-cache baselines replay.
//!
//! Mitsuba 3's `sample_border` ([`crate::scene::FilmDesc::sample_border`]): with a splatting
//! filter, the band of pixels outside the film that the filter reaches from the edge pixels
//! (`margin` pixels: 1 for a tent) is sampled too, as if the film were that much larger, and
//! those samples splat into the edge pixels; the edge pixels then weigh as many samples as
//! the others. Without it (the default) the edge pixels' filter support is cut at the edge.
//!
//! Determinism: pixel `(x, y)` sample `s` uses `Sampler::with_kind(kind, seed, y·width + x, s)`
//! (`kind` from [`RenderSettings::sampler`]; with `sample_border`, `x`, `y` and `width` are
//! those of the enlarged grid); each tile splats into its own buffer (the tile
//! plus a margin of the filter's radius) and the buffers are added to the image in tile order,
//! so the image is bit-identical for any thread count.
//! With a time budget, whole passes of `spp` samples are added until the budget is spent (the
//! result then depends on the machine's speed).
//!
//! Interrupts: [`render_cancellable`] takes a flag (set from a signal handler, say) checked
//! before each tile and every few samples inside it; once it is set the pass under way is dropped and the loop stops, so the
//! image holds the whole passes done so far ([`RenderStats::interrupted`], `passes`, `spp`).

use crate::film::{camera_sample_into, Pixel};
use crate::film::{filter_radius, FilterWeights, Reconstruction};
use crate::image::Image;
use crate::integrators::{Integrator, RayCounters};
use crate::math::{Color, Ray};
use crate::sampling::{Sampler, SamplerKind};
use crate::scene::PixelFilter;
use crate::scene::Scene;
use glam::Vec2;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Settings of the render loop.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct RenderSettings {
    /// Samples per pixel (per pass when `time_budget_s` is set).
    pub spp: u32,
    pub seed: u64,
    /// Optional wall-clock budget in seconds: passes of `spp` samples repeat until it is spent
    /// (at least one pass always runs).
    pub time_budget_s: Option<f64>,
    /// Tile edge in pixels.
    pub tile: u32,
    pub reconstruction: Reconstruction,
    /// Independent numbers or padded Sobol' points for every sample's dimensions.
    pub sampler: SamplerKind,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            spp: 64,
            seed: 0,
            time_budget_s: None,
            tile: 16,
            reconstruction: Reconstruction::Splat,
            sampler: SamplerKind::default(),
        }
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
    /// The render stopped early on its cancel flag: the image holds `passes` whole passes
    /// (none when `passes` is 0, and the image is black).
    #[serde(default)]
    pub interrupted: bool,
}

/// The widest splat margin in pixels (a Gaussian of stddev up to 2 px); a wider filter is cut
/// at this margin, its weights renormalised per pixel as always.
const MAX_MARGIN: i32 = 8;

/// One tile's contribution: rgb sums and weight sums over the tile plus its margin.
struct TileBuffer {
    /// Pixel coordinates of the buffer's first element (may be negative at the image's edge).
    x0: i32,
    y0: i32,
    w: i32,
    h: i32,
    acc: Vec<[f64; 4]>,
    counters: RayCounters,
}

/// Render a `w`x`h` film whose samples come from `li(film_position, sampler, counters)`, where
/// the film position is in pixels (x right, y down) and the sampler has already given the
/// position its first two dimensions. `progress(done_pixels, total_pixels)` is called after each
/// tile (from worker threads). This is the loop behind [`render`], usable with any radiance
/// function.
pub fn render_film<F>(
    w: u32,
    h: u32,
    filter: PixelFilter,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
    li: F,
) -> (Image, RenderStats)
where
    F: Fn(Vec2, &mut Sampler, &mut RayCounters) -> Color + Sync,
{
    render_film_cancellable(w, h, filter, false, settings, progress, None, li)
}

/// Samples between two looks at the cancel flag inside a pixel (and at every pixel's first).
const CANCEL_EVERY: u32 = 16;

/// [`render_film`] that stops when `cancel` becomes true (checked before each tile and every
/// `CANCEL_EVERY` samples of each pixel, so a signal stops even one long tile): the pass
/// under way is dropped, and the image and statistics are those of the whole passes done.
/// `sample_border`: sample the pixels outside the film that the filter reaches (module docs).
#[allow(clippy::too_many_arguments)]
pub fn render_film_cancellable<F>(
    w: u32,
    h: u32,
    filter: PixelFilter,
    sample_border: bool,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: Option<&AtomicBool>,
    li: F,
) -> (Image, RenderStats)
where
    F: Fn(Vec2, &mut Sampler, &mut RayCounters) -> Color + Sync,
{
    let cancelled = || cancel.is_some_and(|c| c.load(Ordering::Relaxed));
    let spp = settings.spp.max(1);
    // A box filter splats each sample into its own pixel with weight 1: the importance-sampled
    // path does that without the margin (its positions are the same, see `camera_sample`).
    let splat = settings.reconstruction == Reconstruction::Splat && filter != PixelFilter::Box;
    let reconstruction = settings.reconstruction;
    let radius = filter_radius(filter);
    let weights = FilterWeights::new(filter);
    let margin = if splat { ((radius + 0.5).ceil() as i32 - 1).clamp(0, MAX_MARGIN) } else { 0 };
    // The sampled grid: the film, plus `border` pixels on each side with `sample_border`.
    let border = if sample_border { margin } else { 0 };
    let (gw, gh) = (w + 2 * border as u32, h + 2 * border as u32);
    let tile = settings.tile.max(1);
    let tiles_x = gw.div_ceil(tile);
    let tiles_y = gh.div_ceil(tile);
    let n_tiles = (tiles_x * tiles_y) as usize;
    let mut accum = vec![[0.0f64; 4]; (w * h) as usize];
    let mut counters = RayCounters::default();
    let start = Instant::now();
    let mut passes = 0u32;
    let total_pixels = (gw as u64) * (gh as u64);
    let mut interrupted = false;
    loop {
        let done = std::sync::atomic::AtomicU64::new(0);
        let pass = passes;
        let results: Vec<Option<TileBuffer>> = (0..n_tiles as u32)
            .into_par_iter()
            .map(|ti| {
                if cancelled() {
                    return None;
                }
                let (tx, ty) = (ti % tiles_x, ti / tiles_x);
                // grid coordinates (film coordinates plus `border`)
                let (x0, y0) = (tx * tile, ty * tile);
                let (x1, y1) = ((x0 + tile).min(gw), (y0 + tile).min(gh));
                let mut buf = TileBuffer {
                    x0: x0 as i32 - border - margin,
                    y0: y0 as i32 - border - margin,
                    w: (x1 - x0) as i32 + 2 * margin,
                    h: (y1 - y0) as i32 + 2 * margin,
                    acc: Vec::new(),
                    counters: RayCounters::default(),
                };
                buf.acc = vec![[0.0; 4]; (buf.w * buf.h) as usize];
                let taps = (2 * margin + 1) as usize;
                let (mut wx, mut wy) = (vec![0.0f32; taps], vec![0.0f32; taps]);
                // restarted for every sample (`camera_sample_into`)
                let mut sampler = Sampler::with_kind(settings.sampler, settings.seed, 0, 0);
                for y in y0..y1 {
                    for x in x0..x1 {
                        let pixel = Pixel { x, y, width: gw };
                        for s in 0..spp {
                            // inside the tile too: one tile of 10^8 samples must stop at once
                            if s % CANCEL_EVERY == 0 && cancelled() {
                                return None;
                            }
                            let sample_index = pass as u64 * spp as u64 + s as u64;
                            let pos = camera_sample_into(
                                &mut sampler,
                                (settings.sampler, settings.seed),
                                pixel,
                                sample_index,
                                filter,
                                reconstruction,
                            );
                            let pos = pos - Vec2::splat(border as f32);
                            let l = li(pos, &mut sampler, &mut buf.counters);
                            // A non-finite sample is a bug; drop it rather than poison pixels.
                            if !l.is_finite() {
                                continue;
                            }
                            let l = [l.x as f64, l.y as f64, l.z as f64];
                            if !splat {
                                let a = &mut buf.acc[((y - y0) * (x1 - x0) + (x - x0)) as usize];
                                a[0] += l[0];
                                a[1] += l[1];
                                a[2] += l[2];
                                a[3] += 1.0;
                                continue;
                            }
                            // Pixels i with |i + 0.5 - pos| < radius, within the margin and image.
                            let (px, py) = (x as i32 - border, y as i32 - border);
                            let lo_x = (px - margin).max(0);
                            let hi_x = (px + margin).min(w as i32 - 1);
                            let lo_y = (py - margin).max(0);
                            let hi_y = (py + margin).min(h as i32 - 1);
                            for i in lo_x..=hi_x {
                                wx[(i - lo_x) as usize] = weights.at(i as f32 + 0.5 - pos.x);
                            }
                            for j in lo_y..=hi_y {
                                wy[(j - lo_y) as usize] = weights.at(j as f32 + 0.5 - pos.y);
                            }
                            for j in lo_y..=hi_y {
                                let fy = wy[(j - lo_y) as usize];
                                if fy == 0.0 {
                                    continue;
                                }
                                let row = ((j - buf.y0) * buf.w - buf.x0) as isize;
                                for i in lo_x..=hi_x {
                                    let f = (fy * wx[(i - lo_x) as usize]) as f64;
                                    if f == 0.0 {
                                        continue;
                                    }
                                    let a = &mut buf.acc[(row + i as isize) as usize];
                                    a[0] += f * l[0];
                                    a[1] += f * l[1];
                                    a[2] += f * l[2];
                                    a[3] += f;
                                }
                            }
                        }
                    }
                }
                let n = ((x1 - x0) * (y1 - y0)) as u64;
                let d = done.fetch_add(n, std::sync::atomic::Ordering::Relaxed) + n;
                progress(d, total_pixels);
                Some(buf)
            })
            .collect();
        // A pass cut short by the cancel flag is dropped whole.
        let Some(results) = results.into_iter().collect::<Option<Vec<TileBuffer>>>() else {
            interrupted = true;
            break;
        };
        // In tile order, whatever the threads did: the sums are bit-identical for any count.
        for buf in results {
            counters += buf.counters;
            for j in 0..buf.h {
                let y = buf.y0 + j;
                if y < 0 || y >= h as i32 {
                    continue;
                }
                for i in 0..buf.w {
                    let x = buf.x0 + i;
                    if x < 0 || x >= w as i32 {
                        continue;
                    }
                    let s = &buf.acc[(j * buf.w + i) as usize];
                    let a = &mut accum[(y as u32 * w + x as u32) as usize];
                    for k in 0..4 {
                        a[k] += s[k];
                    }
                }
            }
        }
        passes += 1;
        match settings.time_budget_s {
            Some(_) if cancelled() => {
                interrupted = true;
                break;
            }
            Some(b) if start.elapsed().as_secs_f64() < b => continue,
            _ => break,
        }
    }
    let render_s = start.elapsed().as_secs_f64();
    let total_spp = spp * passes;
    let data = accum
        .iter()
        .map(|a| {
            let inv = if a[3] > 0.0 { 1.0 / a[3] } else { 0.0 };
            Color::new((a[0] * inv) as f32, (a[1] * inv) as f32, (a[2] * inv) as f32)
        })
        .collect();
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
        interrupted,
    };
    (Image { width: w, height: h, data }, stats)
}

/// Render the scene's film with `integrator`. `progress(done_pixels, total_pixels)` is called
/// after each tile (from worker threads).
pub fn render(
    scene: &Scene,
    integrator: &Integrator,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> (Image, RenderStats) {
    render_cancellable(scene, integrator, settings, progress, None)
}

/// [`render`] that stops when `cancel` becomes true (see [`render_film_cancellable`]).
pub fn render_cancellable(
    scene: &Scene,
    integrator: &Integrator,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
    cancel: Option<&AtomicBool>,
) -> (Image, RenderStats) {
    let f = &scene.film;
    // Mitsuba 0.6 (`SamplingIntegrator::renderBlock`) scales the camera ray's differentials by
    // 1/sqrt(samples per pixel): a texture footprint of about one sample's share of the pixel.
    let diff_scale = 1.0 / (settings.spp.max(1) as f32).sqrt();
    render_film_cancellable(f.width, f.height, f.filter, f.sample_border, settings, progress, cancel, |film, sampler, c| {
        let (o, d, tmin) = scene.camera.generate_ray(film);
        let ray = Ray { o, d, tmin, tmax: f32::INFINITY };
        let diff = scene.camera.ray_differential(film, diff_scale);
        integrator.li(scene, ray, Some(&diff), sampler, c)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film(filter: PixelFilter, rec: Reconstruction, n: u32, spp: u32, f: impl Fn(Vec2, &mut Sampler) -> Color + Sync) -> Image {
        // Independent numbers: the variance test below counts on them.
        let settings =
            RenderSettings { spp, seed: 3, reconstruction: rec, tile: 5, sampler: SamplerKind::Independent, ..Default::default() };
        render_film(n, n, filter, &settings, &|_, _| {}, |p, s, _| f(p, s)).0
    }

    #[test]
    fn splatting_a_constant_gives_the_constant_everywhere_even_at_the_edges() {
        for filter in [PixelFilter::Box, PixelFilter::Tent, PixelFilter::Gaussian { stddev: 0.5 }] {
            let img = film(filter, Reconstruction::Splat, 13, 3, |_, _| Color::new(0.25, 1.0, 4.0));
            for c in &img.data {
                assert!((c.x - 0.25).abs() < 1e-6 && (c.y - 1.0).abs() < 1e-6 && (c.z - 4.0).abs() < 1e-6, "{filter:?}: {c:?}");
            }
        }
    }

    #[test]
    fn splatting_a_linear_ramp_returns_its_value_at_interior_pixel_centres() {
        // A symmetric filter reproduces a linear function at the pixel centre; a bug in the
        // weights' offsets or signs shifts the image by a fraction of a pixel.
        for filter in [PixelFilter::Tent, PixelFilter::Gaussian { stddev: 0.5 }] {
            // Noise per pixel: about 0.23/sqrt(2.25 spp) = 1.2e-3; a 1/16-pixel shift is 3e-2.
            let n = 9;
            let img = film(filter, Reconstruction::Splat, n, 16384, |p, _| Color::splat(1.0 + 0.5 * p.x - 0.25 * p.y));
            let m = filter_radius(filter).ceil() as u32;
            for y in m..n - m {
                for x in m..n - m {
                    let expect = 1.0 + 0.5 * (x as f32 + 0.5) - 0.25 * (y as f32 + 0.5);
                    let got = img.data[(y * n + x) as usize].x;
                    assert!((got - expect).abs() < 6e-3, "{filter:?} pixel ({x},{y}): {got} vs {expect}");
                }
            }
        }
    }

    /// Without `sample_border` an edge pixel's filter support is cut at the film's edge: a ramp
    /// splatted there averages to more than its value at the pixel centre (the missing samples
    /// are those from outside). With it, the edge pixels reproduce the ramp like the others,
    /// every sample position stays within the filter's reach of the film, and one more ring of
    /// pixels is sampled (Mitsuba 3's `sample_border`).
    #[test]
    fn sample_border_gives_edge_pixels_their_whole_filter_support() {
        let n = 6u32;
        let settings = RenderSettings { spp: 16384, seed: 2, tile: 4, sampler: SamplerKind::Independent, ..Default::default() };
        let min_x = std::sync::Mutex::new(f32::INFINITY);
        let ramp = |p: Vec2, _: &mut Sampler, _: &mut RayCounters| {
            let mut m = min_x.lock().unwrap();
            *m = m.min(p.x);
            Color::splat(p.x)
        };
        let (cut, _) = render_film_cancellable(n, n, PixelFilter::Tent, false, &settings, &|_, _| {}, None, ramp);
        assert!(*min_x.lock().unwrap() >= 0.0);
        let (whole, stats) = render_film_cancellable(n, n, PixelFilter::Tent, true, &settings, &|_, _| {}, None, ramp);
        assert!(*min_x.lock().unwrap() < -0.9 && *min_x.lock().unwrap() >= -1.0, "{}", min_x.lock().unwrap());
        assert_eq!(stats.samples, ((n + 2) * (n + 2)) as u64 * 16384, "the ring of border pixels is sampled");
        assert_eq!((whole.width, whole.height), (n, n));
        // noise per pixel about 0.3 / sqrt(2.25 x 16384) = 1.6e-3
        let (c0, w0) = (cut.data[(2 * n) as usize].x, whole.data[(2 * n) as usize].x);
        assert!(c0 > 0.5 + 0.05, "cut support: the edge pixel sees only samples right of its centre: {c0}");
        assert!((w0 - 0.5).abs() < 8e-3, "whole support: {w0} vs 0.5");
        for y in 0..n {
            for x in 0..n {
                let got = whole.data[(y * n + x) as usize].x;
                assert!((got - (x as f32 + 0.5)).abs() < 8e-3, "pixel ({x}, {y}): {got}");
            }
        }
    }

    #[test]
    fn tent_splatting_cuts_pixel_variance_by_about_2_25_against_importance_sampling() {
        // Pure noise of variance 1/12 per sample; interior pixels only.
        let noise = |_: Vec2, s: &mut Sampler| Color::splat(s.next_1d());
        let n = 64;
        let var = |img: &Image| {
            let v: Vec<f64> =
                (2..n - 2).flat_map(|y| (2..n - 2).map(move |x| (y * n + x) as usize)).map(|i| img.data[i].x as f64).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            v.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64
        };
        let fis = var(&film(PixelFilter::Tent, Reconstruction::ImportanceSampled, n, 4, noise));
        let splat = var(&film(PixelFilter::Tent, Reconstruction::Splat, n, 4, noise));
        assert!((fis * 48.0 - 1.0).abs() < 0.1, "importance sampled: variance {fis} vs 1/48");
        let ratio = fis / splat;
        assert!((1.9..2.6).contains(&ratio), "variance ratio {ratio}, expected about 2.25");
    }

    #[test]
    fn a_degenerate_gaussian_given_to_the_render_loop_directly_ends() {
        // Scene validation refuses such filters; the loop must still end without them.
        for stddev in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            for rec in [Reconstruction::Splat, Reconstruction::ImportanceSampled] {
                let img = film(PixelFilter::Gaussian { stddev }, rec, 5, 2, |_, _| Color::ONE);
                assert!(img.data.iter().all(|c| c.is_finite()), "stddev {stddev}, {rec:?}");
            }
        }
    }

    #[test]
    fn a_cancel_flag_drops_the_pass_under_way_and_keeps_the_whole_ones() {
        // 64 tiles: the flag goes up while most tiles of the pass have not started, on any
        // machine with fewer threads than that.
        let (n, spp) = (32u32, 2u32);
        let per_pass = (n * n * spp) as u64;
        let settings = RenderSettings { spp, seed: 1, tile: 4, time_budget_s: Some(1e6), ..Default::default() };
        let cancel = AtomicBool::new(false);
        let calls = std::sync::atomic::AtomicU64::new(0);
        // The flag goes up at the first sample of the fourth pass.
        let (img, stats) = render_film_cancellable(n, n, PixelFilter::Box, false, &settings, &|_, _| {}, Some(&cancel), |_, _, _| {
            if calls.fetch_add(1, Ordering::Relaxed) == 3 * per_pass {
                cancel.store(true, Ordering::Relaxed);
            }
            Color::splat(0.5)
        });
        assert!(stats.interrupted);
        assert_eq!((stats.passes, stats.spp, stats.samples), (3, 3 * spp, 3 * per_pass));
        assert!(img.data.iter().all(|c| *c == Color::splat(0.5)), "every pixel holds whole passes only");

        // Raised before the first pass: nothing rendered, said so.
        let (_, stats) = render_film_cancellable(n, n, PixelFilter::Box, false, &settings, &|_, _| {}, Some(&cancel), |_, _, _| Color::ONE);
        assert!(stats.interrupted);
        assert_eq!((stats.passes, stats.samples), (0, 0));
        // Without a flag (or never raised) nothing changes.
        let once = RenderSettings { time_budget_s: None, ..settings };
        let (_, stats) = render_film_cancellable(n, n, PixelFilter::Box, false, &once, &|_, _| {}, None, |_, _, _| Color::ONE);
        assert!(!stats.interrupted);
        assert_eq!(stats.passes, 1);
    }
}
