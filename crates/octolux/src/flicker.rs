//! Temporal stability ("flicker") of a rendered frame sequence against a reference sequence of
//! the same frames (issue 13, item 3; the method's case for a view-independent solution, paper
//! §1 and §3; measurements in docs/guide/baking.md).
//!
//! Two measures, both relative like [`crate::metrics`]'s relMSE (`ε` = [`REL_EPS`]), sums in f64:
//!
//! * **Temporal relMSE** of consecutive-frame differences against the reference's:
//!   `mean over pairs (f, f+1), pixels and channels of ((a_{f+1} − a_f) − (r_{f+1} − r_f))² /
//!   (r̄² + ε)`, with `r̄ = (r_f + r_{f+1}) / 2`. The differences of a moving camera (what
//!   *should* change) cancel; what is left is `e_{f+1} − e_f`, the change of the error
//!   `e = a − r`. For errors independent from frame to frame it is twice the per-frame relMSE,
//!   for an error that stays put it is 0: [`FlickerReport::temporal_ratio`] is their quotient
//!   (1: every frame's error is new, it flickers; 0: stable).
//! * **Static points.** A world point of a static scene keeps its value in every frame. Given
//!   its film position in each frame (a [`Track`]: the caller reprojects the point, the CLI's
//!   `flicker` command through the scene and the camera path), the luminance is read
//!   bilinearly in each frame where the point is seen, and
//!   `static_rel_std = sqrt(mean over points of var_f(L(a_f) − L(r_f)) / (mean_f L(r_f)² + ε))`:
//!   the standard deviation over frames of a static point's error, relative to its value.
//!   Subtracting the reference removes what reprojection itself varies (a point between
//!   pixels, a texture under the filter); [`FlickerReport::static_rel_std_reference`] is that
//!   part, measured on the reference alone, for scale.

use crate::image::Image;
use crate::math::luminance;
use crate::metrics::{rel_mse_with, REL_EPS};
use glam::Vec2;
use serde::Serialize;
use thiserror::Error;

/// Film positions (pixels, (0, 0) the image's top-left corner, pixel centres at `i + 0.5`) of
/// one static world point in each frame; `None` where it is hidden or outside the film.
pub type Track = Vec<Option<Vec2>>;

/// Why a sequence cannot be measured.
#[derive(Debug, Error, PartialEq)]
pub enum FlickerError {
    #[error("a flicker measure needs at least 2 frames, got {0}")]
    TooFewFrames(usize),
    #[error("{frames} frames but {references} reference frames")]
    ReferenceCount { frames: usize, references: usize },
    #[error("frame {index} is {w}x{h}, the first frame {w0}x{h0} (reference frames included)")]
    Size { index: usize, w: u32, h: u32, w0: u32, h0: u32 },
    #[error("a track has {len} positions for {frames} frames")]
    TrackLength { len: usize, frames: usize },
    #[error("border {border} leaves no pixel of a {w}x{h} film")]
    Border { border: u32, w: u32, h: u32 },
}

/// The measures of one sequence (see the module documentation).
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct FlickerReport {
    pub frames: usize,
    /// Mean over frames of each frame's relMSE against its reference.
    pub frame_rel_mse: f64,
    /// Mean over consecutive pairs of the relMSE of the frame difference against the
    /// reference's frame difference.
    pub temporal_rel_mse: f64,
    /// `temporal_rel_mse / (2 frame_rel_mse)` (0 when `frame_rel_mse` is 0).
    pub temporal_ratio: f64,
    /// Tracks seen in at least two frames.
    pub points: usize,
    /// Relative standard deviation over frames of a static point's error, RMS over points.
    pub static_rel_std: f64,
    /// The same measure of the reference's own values (no subtraction): what reprojection and
    /// the reference's noise vary.
    pub static_rel_std_reference: f64,
}

/// Luminance at film position `p` (pixels), bilinear between pixel centres; `None` when the
/// four taps are not all inside the film shrunk by `border` pixels.
pub fn sample_luminance(img: &Image, p: Vec2, border: u32) -> Option<f64> {
    let (x, y) = (p.x - 0.5, p.y - 0.5);
    if !(x.is_finite() && y.is_finite()) {
        return None;
    }
    let (x0, y0) = (x.floor(), y.floor());
    let b = border as f32;
    if x0 < b || y0 < b || x0 + 1.0 >= img.width as f32 - b || y0 + 1.0 >= img.height as f32 - b {
        return None;
    }
    let (fx, fy) = ((x - x0) as f64, (y - y0) as f64);
    let (i, j, w) = (x0 as usize, y0 as usize, img.width as usize);
    let l = |i: usize, j: usize| luminance(img.data[j * w + i]) as f64;
    let top = l(i, j) * (1.0 - fx) + l(i + 1, j) * fx;
    let bottom = l(i, j + 1) * (1.0 - fx) + l(i + 1, j + 1) * fx;
    Some(top * (1.0 - fy) + bottom * fy)
}

fn cropped(img: &Image, border: u32) -> Image {
    let (w, h) = (img.width - 2 * border, img.height - 2 * border);
    let mut data = Vec::with_capacity((w * h) as usize);
    for y in border..border + h {
        let row = (y * img.width + border) as usize;
        data.extend_from_slice(&img.data[row..row + w as usize]);
    }
    Image { width: w, height: h, data }
}

fn diff(a: &Image, b: &Image) -> Image {
    Image { width: a.width, height: a.height, data: a.data.iter().zip(&b.data).map(|(x, y)| *x - *y).collect() }
}

fn mean_of(a: &Image, b: &Image) -> Image {
    Image { width: a.width, height: a.height, data: a.data.iter().zip(&b.data).map(|(x, y)| (*x + *y) * 0.5).collect() }
}

/// Measure `frames` against `reference` (the same frames, converged), ignoring `border`
/// pixels on every side (a peer whose film is shifted by a row, for instance); `tracks` are
/// the static points (may be empty).
pub fn measure(frames: &[Image], reference: &[Image], tracks: &[Track], border: u32) -> Result<FlickerReport, FlickerError> {
    let n = frames.len();
    if n < 2 {
        return Err(FlickerError::TooFewFrames(n));
    }
    if reference.len() != n {
        return Err(FlickerError::ReferenceCount { frames: n, references: reference.len() });
    }
    let (w0, h0) = (frames[0].width, frames[0].height);
    for (index, img) in frames.iter().chain(reference).enumerate() {
        if img.width != w0 || img.height != h0 || img.data.len() != (w0 as usize) * (h0 as usize) {
            return Err(FlickerError::Size { index: index % n, w: img.width, h: img.height, w0, h0 });
        }
    }
    if 2 * border >= w0 || 2 * border >= h0 {
        return Err(FlickerError::Border { border, w: w0, h: h0 });
    }
    if let Some(t) = tracks.iter().find(|t| t.len() != n) {
        return Err(FlickerError::TrackLength { len: t.len(), frames: n });
    }
    let a: Vec<Image> = frames.iter().map(|i| cropped(i, border)).collect();
    let r: Vec<Image> = reference.iter().map(|i| cropped(i, border)).collect();
    let frame_rel_mse = a.iter().zip(&r).map(|(a, r)| rel_mse_with(a, r, r)).sum::<f64>() / n as f64;
    let mut temporal = 0.0f64;
    for f in 0..n - 1 {
        temporal += rel_mse_with(&diff(&a[f + 1], &a[f]), &diff(&r[f + 1], &r[f]), &mean_of(&r[f], &r[f + 1]));
    }
    let temporal_rel_mse = temporal / (n - 1) as f64;
    let temporal_ratio = if frame_rel_mse > 0.0 { temporal_rel_mse / (2.0 * frame_rel_mse) } else { 0.0 };

    let (mut points, mut var_err, mut var_ref) = (0usize, 0.0f64, 0.0f64);
    for t in tracks {
        let seen: Vec<(f64, f64)> = t
            .iter()
            .zip(frames.iter().zip(reference))
            .filter_map(|(p, (a, r))| {
                let p = (*p)?;
                Some((sample_luminance(a, p, border)?, sample_luminance(r, p, border)?))
            })
            .collect();
        if seen.len() < 2 {
            continue;
        }
        let k = seen.len() as f64;
        let mean_r = seen.iter().map(|s| s.1).sum::<f64>() / k;
        let mean_e = seen.iter().map(|s| s.0 - s.1).sum::<f64>() / k;
        let ve = seen.iter().map(|s| (s.0 - s.1 - mean_e).powi(2)).sum::<f64>() / k;
        let vr = seen.iter().map(|s| (s.1 - mean_r).powi(2)).sum::<f64>() / k;
        let denom = mean_r * mean_r + REL_EPS;
        var_err += ve / denom;
        var_ref += vr / denom;
        points += 1;
    }
    let rms = |v: f64| if points > 0 { (v / points as f64).sqrt() } else { 0.0 };
    Ok(FlickerReport {
        frames: n,
        frame_rel_mse,
        temporal_rel_mse,
        temporal_ratio,
        points,
        static_rel_std: rms(var_err),
        static_rel_std_reference: rms(var_ref),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Color;

    const W: u32 = 48;
    const H: u32 = 32;

    /// A smooth "world" seen by a camera translated by `shift` pixels to the right per frame.
    fn world(x: f32, y: f32) -> Color {
        let v = 0.5 + 0.3 * (0.11 * x).sin() * (0.07 * y).cos();
        Color::new(v, 0.8 * v, 0.6 * v)
    }

    fn frame(f: u32, shift: f32, err: impl Fn(f32, f32, u32, u32) -> f32) -> Image {
        let mut data = Vec::new();
        for y in 0..H {
            for x in 0..W {
                let wx = x as f32 + 0.5 + shift * f as f32;
                let wy = y as f32 + 0.5;
                data.push(world(wx, wy) * (1.0 + err(wx, wy, x + y * W, f)));
            }
        }
        Image { width: W, height: H, data }
    }

    fn seq(n: u32, shift: f32, err: impl Fn(f32, f32, u32, u32) -> f32 + Copy) -> Vec<Image> {
        (0..n).map(|f| frame(f, shift, err)).collect()
    }

    /// Uniform in [-a, a] from (pixel or world cell, frame): deterministic.
    fn noise(key: u32, f: u32, a: f32) -> f32 {
        // splitmix64 of (key, frame): the test needs no sampler, only fixed numbers.
        let mut z = ((key as u64) << 32 | f as u64).wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        a * (2.0 * (z >> 40) as f32 / (1u64 << 24) as f32 - 1.0)
    }

    /// Tracks of world points on the integer grid, moving `shift` pixels left per frame.
    fn tracks(n: u32, shift: f32) -> Vec<Track> {
        let mut t = Vec::new();
        for y in (4..H - 4).step_by(3) {
            for x in (4..W - 4).step_by(3) {
                t.push((0..n).map(|f| Some(Vec2::new(x as f32 + 0.5 - shift * f as f32, y as f32 + 0.5))).collect());
            }
        }
        t
    }

    #[test]
    fn a_perfect_sequence_has_no_flicker() {
        // Half a pixel per frame: the points fall between pixel centres every other frame.
        let r = seq(6, 0.5, |_, _, _, _| 0.0);
        let m = measure(&r, &r, &tracks(6, 0.5), 0).unwrap();
        assert_eq!((m.frame_rel_mse, m.temporal_rel_mse, m.static_rel_std, m.temporal_ratio), (0.0, 0.0, 0.0, 0.0));
        assert!(m.points > 50);
        assert!(m.static_rel_std_reference > 0.0, "bilinear reads between centres vary along the motion: {m:?}");
    }

    #[test]
    fn independent_noise_per_frame_gives_ratio_one() {
        // Static camera, a new ±10% uniform error in every frame: temporal = 2 * frame relMSE.
        let r = seq(8, 0.0, |_, _, _, _| 0.0);
        let a = seq(8, 0.0, |_, _, p, f| noise(p, f, 0.1));
        let m = measure(&a, &r, &tracks(8, 0.0), 0).unwrap();
        assert!((m.temporal_ratio - 1.0).abs() < 0.1, "{m:?}");
        // var of U(-a, a) is a²/3; relative to the value: static_rel_std ≈ 0.1/√3 (ε shrinks it a little).
        assert!((m.static_rel_std - 0.1 / 3f64.sqrt()).abs() < 0.01, "{m:?}");
        assert_eq!(m.static_rel_std_reference, 0.0);
    }

    #[test]
    fn an_error_fixed_in_the_world_does_not_flicker() {
        // The same error attached to world cells (a baked solution) under a moving camera: every
        // frame is wrong by as much as above, but static points keep their error exactly and the
        // frame differences change only where the cells move across pixels.
        let cell_err = |wx: f32, wy: f32, _: u32, _: u32| noise((wx / 8.0) as u32 + 100 * (wy / 8.0) as u32, 0, 0.1);
        let r = seq(8, 1.0, |_, _, _, _| 0.0);
        let baked = seq(8, 1.0, cell_err);
        let per_frame = seq(8, 1.0, |wx, wy, _, f| noise((wx / 8.0) as u32 + 100 * (wy / 8.0) as u32, f + 1, 0.1));
        let t = tracks(8, 1.0);
        let mb = measure(&baked, &r, &t, 0).unwrap();
        let mp = measure(&per_frame, &r, &t, 0).unwrap();
        assert!(mb.frame_rel_mse > 0.5 * mp.frame_rel_mse && mb.frame_rel_mse < 2.0 * mp.frame_rel_mse, "{mb:?} {mp:?}");
        // Points inside a cell keep their error; those on a cell border blend two under the filter.
        assert!(mb.static_rel_std < 0.1 * mp.static_rel_std, "{mb:?} {mp:?}");
        assert!(mb.temporal_rel_mse < 0.25 * mp.temporal_rel_mse, "{mb:?} {mp:?}");
        assert!(mp.temporal_ratio > 0.8 && mb.temporal_ratio < 0.25, "{mb:?} {mp:?}");
    }

    #[test]
    fn alternating_frames_have_the_analytic_flicker() {
        // A grey wall of value 1, frames alternately 1 + d and 1 − d.
        let d = 0.2f32;
        let grey = |v: f32| Image { width: 8, height: 8, data: vec![Color::splat(v); 64] };
        let r: Vec<Image> = (0..4).map(|_| grey(1.0)).collect();
        let a: Vec<Image> = (0..4).map(|f| grey(if f % 2 == 0 { 1.0 + d } else { 1.0 - d })).collect();
        let t = vec![vec![Some(Vec2::new(4.0, 4.0)); 4]];
        let m = measure(&a, &r, &t, 1).unwrap();
        let eps = REL_EPS;
        let dd = d as f64;
        assert!((m.frame_rel_mse - dd * dd / (1.0 + eps)).abs() < 1e-6, "{m:?}");
        assert!((m.temporal_rel_mse - 4.0 * dd * dd / (1.0 + eps)).abs() < 1e-6, "{m:?}");
        assert!((m.temporal_ratio - 2.0).abs() < 1e-6, "anti-correlated errors: ratio 2, {m:?}");
        assert!((m.static_rel_std - dd / (1.0 + eps).sqrt()).abs() < 1e-6, "{m:?}");
        assert_eq!(m.points, 1);
    }

    #[test]
    fn bad_sequences_are_refused() {
        let img = |w, h| Image { width: w, height: h, data: vec![Color::ONE; (w * h) as usize] };
        let one = vec![img(4, 4)];
        assert_eq!(measure(&one, &one, &[], 0), Err(FlickerError::TooFewFrames(1)));
        let two = vec![img(4, 4), img(4, 4)];
        assert!(matches!(measure(&two, &one, &[], 0), Err(FlickerError::ReferenceCount { .. })));
        let odd = vec![img(4, 4), img(4, 3)];
        assert!(matches!(measure(&odd, &two, &[], 0), Err(FlickerError::Size { index: 1, .. })));
        assert!(matches!(measure(&two, &two, &[vec![None]], 0), Err(FlickerError::TrackLength { len: 1, frames: 2 })));
        assert!(matches!(measure(&two, &two, &[], 2), Err(FlickerError::Border { .. })));
        // Hidden points and points off the film are skipped, not read.
        let t = vec![vec![None, Some(Vec2::new(2.0, 2.0))], vec![Some(Vec2::new(-5.0, 1.0)), Some(Vec2::new(f32::NAN, 1.0))]];
        assert_eq!(measure(&two, &two, &t, 0).unwrap().points, 0);
    }

    #[test]
    fn bilinear_sampling_between_centres() {
        let img = Image { width: 2, height: 1, data: vec![Color::splat(0.0), Color::splat(1.0)] };
        let img2 = Image { width: 2, height: 2, data: [img.data.clone(), img.data.clone()].concat() };
        let v = sample_luminance(&img2, Vec2::new(0.75, 1.0), 0).unwrap();
        assert!((v - 0.25).abs() < 1e-6, "{v}");
        assert!(sample_luminance(&img2, Vec2::new(0.25, 1.0), 0).is_none());
    }
}
