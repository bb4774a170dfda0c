//! Image error metrics used by tests, benchmarks and experiments.
//!
//! `rel_mse(a, r) = mean over pixels and channels of (a − r)² / (r² + 0.01)` (the form used by
//! the rendering literature and by `tools/mitsuba/compare.py`; the 0.01 keeps black pixels from
//! dominating), `rmse = sqrt(mean (a − r)²)`. Sums in f64.

use crate::image::Image;
use crate::math::Color;
use serde::Serialize;

/// Regulariser of the relative MSE denominator.
pub const REL_EPS: f64 = 1e-2;

/// Errors of an image against a reference.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct ImageErrors {
    pub rel_mse: f64,
    pub rmse: f64,
    /// Mean of each channel of the test image and of the reference.
    pub mean: [f64; 3],
    pub mean_reference: [f64; 3],
}

/// Mean of each channel.
pub fn channel_means(img: &Image) -> [f64; 3] {
    let mut m = [0.0f64; 3];
    for p in &img.data {
        for (c, mc) in m.iter_mut().enumerate() {
            *mc += p[c] as f64;
        }
    }
    m.map(|v| v / img.data.len().max(1) as f64)
}

/// One term of the relMSE: `(a − b)² / (r² + ε)` for one channel value.
#[inline]
fn rel_term(a: f32, b: f32, r: f32) -> f64 {
    let d = (a - b) as f64;
    d * d / ((r as f64).powi(2) + REL_EPS)
}

/// The relMSE of one pixel `a` against the reference pixel `r` (its channels' mean term).
pub fn rel_se(a: Color, r: Color) -> f64 {
    (0..3).map(|c| rel_term(a[c], r[c], r[c])).sum::<f64>() / 3.0
}

/// `mean((a − b)² / (r² + ε))` with the denominator from a third image `r` (the reference).
pub fn rel_mse_with(a: &Image, b: &Image, r: &Image) -> f64 {
    let mut s = 0.0f64;
    for ((x, y), z) in a.data.iter().zip(&b.data).zip(&r.data) {
        for c in 0..3 {
            s += rel_term(x[c], y[c], z[c]);
        }
    }
    s / (3 * a.data.len().max(1)) as f64
}

/// Errors of `img` against `reference`; `None` when the sizes differ.
pub fn compare(img: &Image, reference: &Image) -> Option<ImageErrors> {
    if img.width != reference.width || img.height != reference.height || img.data.len() != reference.data.len() {
        return None;
    }
    let mut se = 0.0f64;
    for (x, y) in img.data.iter().zip(&reference.data) {
        for c in 0..3 {
            let d = (x[c] - y[c]) as f64;
            se += d * d;
        }
    }
    Some(ImageErrors {
        rel_mse: rel_mse_with(img, reference, reference),
        rmse: (se / (3 * img.data.len().max(1)) as f64).sqrt(),
        mean: channel_means(img),
        mean_reference: channel_means(reference),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Color;

    #[test]
    fn metrics_of_a_known_difference() {
        let r = Image { width: 2, height: 1, data: vec![Color::splat(1.0), Color::splat(0.0)] };
        let a = Image { width: 2, height: 1, data: vec![Color::splat(1.1), Color::splat(0.1)] };
        let e = compare(&a, &r).unwrap();
        let expect = (0.01 / 1.01 + 0.01 / 0.01) / 2.0;
        assert!((e.rel_mse - expect).abs() < 1e-6, "{}", e.rel_mse);
        assert!((e.rmse - 0.1).abs() < 1e-6);
        assert!((e.mean[0] - 0.6).abs() < 1e-6 && (e.mean_reference[0] - 0.5).abs() < 1e-9);
        assert!(compare(&a, &Image { width: 1, height: 1, data: vec![Color::ONE] }).is_none());
    }
}
