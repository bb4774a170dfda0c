//! The film's side of sampling: pixel reconstruction filters and the ONE rule that turns
//! `(seed, pixel, sample index)` into a sampler and a film position. The render loop
//! ([`crate::render`]) and the priming passes of the irradiance-cache baselines
//! (`integrators::photon::priming`) both call [`camera_sample`], so a priming pass that
//! replays "the render's own samples" replays exactly the positions the render will draw.
//!
//! Two ways to realise a filter ([`Reconstruction`]): **splatting** (uniform position in the
//! pixel, the sample's value added with the filter's weights to the pixels around it — Mitsuba
//! 3's and pbrt-v3's way) and **filter importance sampling** (position drawn from the filter,
//! weight 1 in its own pixel). The render module documents what each costs.
//!
//! Units: film positions and filter offsets are in pixels, x right, y down, pixel `(x, y)`
//! covering `[x, x+1) × [y, y+1)`.

use crate::sampling::{Sampler, SamplerKind};
use crate::scene::PixelFilter;
use glam::Vec2;
use serde::{Deserialize, Serialize};

/// How the reconstruction filter is applied (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reconstruction {
    /// Uniform positions in the pixel, splatted with the filter's weights (Mitsuba 3's way).
    #[default]
    Splat,
    /// Positions drawn from the filter, each sample in its own pixel (`importance` is the
    /// command line's former spelling).
    #[serde(alias = "importance")]
    ImportanceSampled,
}

/// A pixel of a film `width` pixels wide.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pixel {
    pub x: u32,
    pub y: u32,
    /// Width of the film (or of the grid the pixel belongs to), pixels.
    pub width: u32,
}

impl Pixel {
    /// Index of the pixel in row-major order: the sampler's `index` dimension.
    #[inline]
    pub fn index(self) -> u64 {
        self.y as u64 * self.width as u64 + self.x as u64
    }

    /// Centre of the pixel, film coordinates (pixels).
    #[inline]
    pub fn centre(self) -> Vec2 {
        Vec2::new(self.x as f32 + 0.5, self.y as f32 + 0.5)
    }
}

/// The sampler (of `kind`) of sample `sample` of `pixel` under `seed`, having drawn the film
/// position, and that position (pixels). With [`Reconstruction::Splat`] the position is uniform in the pixel;
/// with [`Reconstruction::ImportanceSampled`] it is the centre plus a filter sample. Either way
/// the position takes the sampler's first two dimensions, the integrator the rest.
#[inline]
pub fn camera_sample(
    kind: SamplerKind,
    seed: u64,
    pixel: Pixel,
    sample: u64,
    filter: PixelFilter,
    reconstruction: Reconstruction,
) -> (Sampler, Vec2) {
    let mut sampler = Sampler::with_kind(kind, seed, pixel.index(), sample);
    let pos = film_position(&mut sampler, pixel, filter, reconstruction);
    (sampler, pos)
}

/// [`camera_sample`] into a sampler the caller keeps: `sampler` is restarted
/// ([`Sampler::restart`]) for the sample, the same numbers, and the film position returned.
/// The render keeps one sampler for a tile's samples (a pixel's are consecutive), so that a
/// Sobol' sampler reuses its slots' keys.
#[inline]
pub fn camera_sample_into(
    sampler: &mut Sampler,
    (kind, seed): (SamplerKind, u64),
    pixel: Pixel,
    sample: u64,
    filter: PixelFilter,
    reconstruction: Reconstruction,
) -> Vec2 {
    sampler.restart(kind, seed, pixel.index(), sample);
    film_position(sampler, pixel, filter, reconstruction)
}

/// The film position (pixels) drawn from a sampler at its first dimensions ([`camera_sample`]).
#[inline]
fn film_position(sampler: &mut Sampler, pixel: Pixel, filter: PixelFilter, reconstruction: Reconstruction) -> Vec2 {
    let offset = match reconstruction {
        Reconstruction::Splat => sampler.next_2d() - Vec2::splat(0.5),
        Reconstruction::ImportanceSampled => sample_filter(filter, sampler),
    };
    pixel.centre() + offset
}

/// Offset from the pixel centre, in pixels, distributed as the reconstruction filter. A
/// Gaussian whose `stddev` is not finite and positive (refused by scene validation) gives the
/// centre rather than looping.
#[inline]
pub fn sample_filter(filter: PixelFilter, sampler: &mut Sampler) -> Vec2 {
    match filter {
        PixelFilter::Box => sampler.next_2d() - Vec2::splat(0.5),
        PixelFilter::Tent => {
            let u = sampler.next_2d();
            Vec2::new(sample_tent(u.x), sample_tent(u.y))
        }
        PixelFilter::Gaussian { stddev } => {
            if !(stddev > 0.0 && stddev.is_finite()) {
                return Vec2::ZERO;
            }
            let radius = 4.0 * stddev;
            // Truncated at 4 stddev: each draw is accepted with probability > 0.9993, so the
            // loop ends.
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
pub(crate) fn sample_tent(u: f32) -> f32 {
    if u < 0.5 {
        (2.0 * u).sqrt() - 1.0
    } else {
        1.0 - (2.0 - 2.0 * u).sqrt()
    }
}

/// Radius of the filter's support in pixels.
pub fn filter_radius(filter: PixelFilter) -> f32 {
    match filter {
        PixelFilter::Box => 0.5,
        PixelFilter::Tent => 1.0,
        PixelFilter::Gaussian { stddev } => 4.0 * stddev,
    }
}

/// The filter's 1D weight at offset `x` pixels (the filters are separable). The Gaussian is
/// shifted down to reach 0 at its radius, as Mitsuba 3's `gaussian` rfilter is.
#[inline]
pub fn filter_weight(filter: PixelFilter, x: f32) -> f32 {
    FilterWeights::new(filter).at(x)
}

/// [`filter_weight`] with the filter's constants computed once (the splatting loop evaluates
/// it at every tap of every sample): the same values, bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct FilterWeights {
    filter: PixelFilter,
    /// Gaussian: `-1 / (2 stddev²)` and the weight at the radius, `exp(alpha (4 stddev)²)`.
    alpha: f32,
    floor: f32,
}

impl FilterWeights {
    #[inline]
    pub fn new(filter: PixelFilter) -> Self {
        let (alpha, floor) = match filter {
            PixelFilter::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                let r = 4.0 * stddev;
                (alpha, (alpha * r * r).exp())
            }
            _ => (0.0, 0.0),
        };
        FilterWeights { filter, alpha, floor }
    }

    /// The weight at offset `x` pixels.
    #[inline]
    pub fn at(&self, x: f32) -> f32 {
        match self.filter {
            PixelFilter::Box => {
                if x.abs() <= 0.5 {
                    1.0
                } else {
                    0.0
                }
            }
            PixelFilter::Tent => (1.0 - x.abs()).max(0.0),
            PixelFilter::Gaussian { .. } => ((self.alpha * x * x).exp() - self.floor).max(0.0),
        }
    }
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

    #[test]
    fn filter_weights_vanish_at_the_radius() {
        for filter in [PixelFilter::Tent, PixelFilter::Gaussian { stddev: 0.5 }, PixelFilter::Gaussian { stddev: 1.3 }] {
            let r = filter_radius(filter);
            assert!(filter_weight(filter, r) == 0.0 && filter_weight(filter, -r - 0.1) == 0.0);
            assert!(filter_weight(filter, 0.0) > filter_weight(filter, 0.3 * r));
        }
    }

    #[test]
    fn splat_positions_are_uniform_in_the_pixel_and_filter_positions_follow_the_filter() {
        let px = Pixel { x: 3, y: 5, width: 10 };
        assert_eq!(px.index(), 53);
        let (mut inside, mut outside) = (0, 0);
        for s in 0..4000 {
            let (_, p) = camera_sample(SamplerKind::Independent, 1, px, s, PixelFilter::Tent, Reconstruction::Splat);
            assert!((3.0..4.0).contains(&p.x) && (5.0..6.0).contains(&p.y), "{p}");
            let (_, q) = camera_sample(SamplerKind::Independent, 1, px, s, PixelFilter::Tent, Reconstruction::ImportanceSampled);
            assert!((q - px.centre()).abs().max_element() <= 1.0);
            if (3.0..4.0).contains(&q.x) && (5.0..6.0).contains(&q.y) {
                inside += 1;
            } else {
                outside += 1;
            }
        }
        // A tent of radius 1 puts (3/4)² = 56% of its mass inside the pixel.
        let frac = inside as f64 / (inside + outside) as f64;
        assert!((frac - 0.5625).abs() < 0.03, "{frac}");
    }

    #[test]
    fn a_degenerate_gaussian_does_not_spin() {
        let mut s = Sampler::new(0, 0, 0);
        for stddev in [0.0, -1.0, f32::NAN] {
            assert_eq!(sample_filter(PixelFilter::Gaussian { stddev }, &mut s), Vec2::ZERO);
        }
    }
}
