//! `octolux report`: one self-contained HTML page that compares renders (issue 15, item 4).
//!
//! The page (`report.html`, filled here) shows every image side by side under one exposure
//! control, a split view with a slider between any two of them, false-colour error maps
//! against the reference (per-pixel relative squared error, the relMSE's terms, and FLIP),
//! a table of relMSE, RMSE, FLIP mean and channel means, and, given benchmark results,
//! error-against-time plots (SVG, log-log).
//!
//! Images travel as RGBE (Ward's shared-exponent bytes, 4 per pixel, base64) so the exposure
//! control works on the HDR values in the browser. FLIP is NVIDIA's LDR-FLIP (the `nv-flip`
//! crate binds the published C++ code) on both images developed as the PNG output is, at
//! exposure 0 (clamped, sRGB), 67 pixels per degree; the metrics are octolux's (`compare`).
//! Every input is read and checked (same size as the reference, finite values) before the
//! page is written, staged and renamed like every output.

use anyhow::{bail, Context, Result};
use octolux::image::Image;
use octolux::{budget, metrics};
use octolux_io::image_io::{encode_png_rgb8, read_image, srgb8_bytes};
use serde::Deserialize;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

const TEMPLATE: &str = include_str!("report.html");

/// Bytes per pixel of one FLIP comparison (the C++ code's float images: both inputs in several
/// colour spaces, the filtered and feature images, the error map). Measured peak resident
/// sizes, 2048x2048 images: one image without reference 194 MB (46 B per pixel: the image and
/// its page), an image and a reference with FLIP 545 MB (130 B per pixel); so FLIP about 38
/// B per pixel beyond the two pages. Rounded up with margin, as the budget's estimates are.
pub const FLIP_BYTES_PER_PIXEL: u64 = 96;
/// Bytes per pixel of each image on the page and while it is made (the image, its base64 RGBE
/// text, the error maps as PNG and base64, the JSON and HTML copies): 46 measured, see above.
pub const PAGE_BYTES_PER_PIXEL: u64 = 56;

/// The report's memory, checked against the budget ([`octolux::budget`]) once the images are
/// read and before FLIP runs (two 8192x8192 images segfaulted in FLIP at an 8 GB limit).
fn check_budget(images: &[(&PathBuf, Image)], reference: Option<&Image>) -> Result<()> {
    let pixels = |img: &Image| img.width as u64 * img.height as u64;
    let all: u64 = images.iter().map(|(_, i)| pixels(i)).chain(reference.map(pixels)).sum();
    let flip = reference.map_or(0, pixels).saturating_mul(FLIP_BYTES_PER_PIXEL);
    let bytes = all.saturating_mul(PAGE_BYTES_PER_PIXEL).saturating_add(flip);
    let (w, h) = images.first().map_or((0, 0), |(_, i)| (i.width, i.height));
    budget::check_bytes(
        || format!("the report of {} images of {w}x{h} (FLIP and the page)", all.div_ceil((w as u64 * h as u64).max(1))),
        bytes,
    )
    .map_err(anyhow::Error::msg)
}

/// Benchmark results for the error-against-time plot: one plot per file.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Bench {
    #[serde(default)]
    title: String,
    series: Vec<Series>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Series {
    name: String,
    /// Seconds (photon pass and build included where there are any).
    time_s: Vec<f64>,
    rel_mse: Vec<f64>,
}

/// Ward's RGBE: a shared exponent byte and three 8-bit mantissas.
fn rgbe(c: [f32; 3]) -> [u8; 4] {
    let m = c[0].max(c[1]).max(c[2]);
    if !(m > 1e-32) {
        return [0; 4];
    }
    let e = m.log2().floor() as i32 + 1;
    let scale = 256.0 / 2f32.powi(e);
    let q = |v: f32| (v.max(0.0) * scale).min(255.0) as u8;
    [q(c[0]), q(c[1]), q(c[2]), (e + 128).clamp(0, 255) as u8]
}

/// Standard base64 (RFC 4648, padded).
fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for ch in bytes.chunks(3) {
        let n = (ch[0] as u32) << 16 | (*ch.get(1).unwrap_or(&0) as u32) << 8 | *ch.get(2).unwrap_or(&0) as u32;
        for i in 0..4 {
            if i <= ch.len() {
                s.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A value in [0, 1] through the magma colour map as PNG bytes, base64.
fn false_colour(w: u32, h: u32, values: &[f32], lut: &[u8]) -> Result<String> {
    let n = lut.len() / 3;
    let rgb = values
        .iter()
        .flat_map(|&v| {
            let i = ((v.clamp(0.0, 1.0) * (n - 1) as f32).round() as usize).min(n - 1);
            [lut[3 * i], lut[3 * i + 1], lut[3 * i + 2]]
        })
        .collect();
    Ok(base64(&encode_png_rgb8(w, h, rgb).map_err(anyhow::Error::msg)?))
}

fn read_checked(path: &Path) -> Result<Image> {
    let img = read_image(path).context("cannot read the image")?;
    let bad = img.data.iter().filter(|c| !c.is_finite()).count();
    if bad > 0 {
        bail!("{} holds non-finite values (NaN or infinity) in {bad} pixels", path.display());
    }
    Ok(img)
}

/// The decades `[lo, hi]` of a log axis holding every value (positive, finite): `10^lo` at or
/// below the least, `10^hi` at or above the greatest, and `hi > lo`. The page draws the axis
/// from them (computed here, not in the page's script: `Math.ceil(-0.3)` is `-0`, which the
/// script's `|| lo + 1` took for "none" and drew a series peaking in (0.1, 1] off the plot).
fn decades<'a>(values: impl IntoIterator<Item = &'a f64>) -> [i32; 2] {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        let l = v.log10();
        lo = lo.min(l);
        hi = hi.max(l);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return [0, 1];
    }
    // integers: the `-0` of `ceil(-0.3)` is `0` here
    let (lo, hi) = (lo.floor() as i32, hi.ceil() as i32);
    [lo, hi.max(lo + 1)]
}

fn name_of(p: &Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
}

/// Write the report of `images` (against `reference` when given) to `output`.
pub fn cmd_report(images: &[PathBuf], reference: Option<&Path>, bench: &[PathBuf], output: &Path) -> Result<()> {
    if images.is_empty() {
        bail!("report: give at least one image");
    }
    crate::note_inputs(images.iter().map(PathBuf::as_path).chain(reference).chain(bench.iter().map(PathBuf::as_path)));
    crate::output_folder(output)?;
    octolux_io::job::output::check_file(output)?;
    let reference = reference.map(|p| Ok::<_, anyhow::Error>((p, read_checked(p)?))).transpose()?;
    let mut loaded = Vec::new();
    for p in images {
        let img = read_checked(p)?;
        if let Some((rp, r)) = &reference {
            if (img.width, img.height) != (r.width, r.height) {
                bail!("{} is {}x{} but the reference {} is {}x{}", p.display(), img.width, img.height, rp.display(), r.width, r.height);
            }
        }
        loaded.push((p, img));
    }
    check_budget(&loaded, reference.as_ref().map(|(_, r)| r))?;
    let mut benches = Vec::new();
    for p in bench {
        let text = octolux_io::files::read_to_string(p).map_err(|e| anyhow::anyhow!("cannot read benchmark results {e}"))?;
        let b: Bench = serde_json::from_str(&text).with_context(|| format!("benchmark results {} are not valid", p.display()))?;
        for s in &b.series {
            if s.time_s.len() != s.rel_mse.len() || s.time_s.iter().chain(&s.rel_mse).any(|v| !(v.is_finite() && *v > 0.0)) {
                bail!("benchmark results {}: series '{}' needs as many positive time_s as rel_mse values", p.display(), s.name);
            }
        }
        let title = if b.title.is_empty() { name_of(p) } else { b.title };
        let x = decades(b.series.iter().flat_map(|s| &s.time_s));
        let y = decades(b.series.iter().flat_map(|s| &s.rel_mse));
        let series: Vec<Value> = b.series.iter().map(|s| json!({"name": s.name, "time_s": s.time_s, "rel_mse": s.rel_mse})).collect();
        benches.push(json!({ "title": title, "series": series, "x_decades": x, "y_decades": y }));
    }

    let lut = nv_flip::magma_lut().to_vec();
    let encode = |name: String, img: &Image| {
        let bytes: Vec<u8> = img.data.iter().flat_map(|c| rgbe([c.x, c.y, c.z])).collect();
        json!({ "name": name, "width": img.width, "height": img.height, "rgbe": base64(&bytes), "means": metrics::channel_means(img) })
    };
    // the reference as FLIP reads it, once for every image
    let reference_srgb = reference.as_ref().map(|(_, r)| srgb8_bytes(r));
    let mut entries: Vec<Value> = Vec::new();
    if let Some((rp, r)) = &reference {
        let mut e = encode(format!("{} (reference)", name_of(rp)), r);
        e["reference"] = json!(true);
        entries.push(e);
    }
    for (p, img) in &loaded {
        let mut e = encode(name_of(p), img);
        if let (Some((_, r)), Some(r_srgb)) = (&reference, &reference_srgb) {
            let m = metrics::compare(img, r).context("image sizes")?;
            let (w, h) = (img.width, img.height);
            // relative squared error per pixel (the relMSE's terms), on a log scale 1e-4 .. 10
            let rel: Vec<f32> =
                img.data.iter().zip(&r.data).map(|(&a, &b)| ((metrics::rel_se(a, b).max(1e-4).log10() + 4.0) / 5.0) as f32).collect();
            let flip_map = nv_flip::flip(
                nv_flip::FlipImageRgb8::with_data(w, h, r_srgb),
                nv_flip::FlipImageRgb8::with_data(w, h, &srgb8_bytes(img)),
                nv_flip::DEFAULT_PIXELS_PER_DEGREE,
            );
            let flip_mean = nv_flip::FlipPool::from_image(&flip_map).mean();
            e["metrics"] = json!({ "rel_mse": m.rel_mse, "rmse": m.rmse, "flip_mean": flip_mean });
            e["relse_png"] = json!(false_colour(w, h, &rel, &lut)?);
            e["flip_png"] = json!(false_colour(w, h, &flip_map.to_vec(), &lut)?);
        }
        entries.push(e);
    }
    let data = json!({ "images": entries, "benches": benches, "octolux_version": env!("CARGO_PKG_VERSION") });
    // `</` cannot close the script element from inside the JSON
    let html = TEMPLATE.replace("\"__OCTOLUX_DATA__\"", &data.to_string().replace("</", "<\\/"));
    octolux_io::job::output::write_file_atomic(output, html.as_bytes())?;
    say!("report: {} images -> {} ({} bytes)", entries.len(), output.display(), html.len());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (i, o) in
            [("", ""), ("f", "Zg=="), ("fo", "Zm8="), ("foo", "Zm9v"), ("foob", "Zm9vYg=="), ("fooba", "Zm9vYmE="), ("foobar", "Zm9vYmFy")]
        {
            assert_eq!(base64(i.as_bytes()), o);
        }
    }

    #[test]
    fn log_axes_hold_every_value() {
        // the series the page drew off its plot: a greatest relMSE in (0.1, 1]
        assert_eq!(decades(&[0.5, 0.05]), [-2, 0]);
        assert_eq!(decades(&[1.0, 0.01]), [-2, 0]);
        assert_eq!(decades(&[0.2]), [-1, 0]);
        // one value on a decade, or all in one: still an axis one decade long
        assert_eq!(decades(&[1.0]), [0, 1]);
        assert_eq!(decades(&[100.0, 100.0]), [2, 3]);
        assert_eq!(decades(&[3.0, 7.0]), [0, 1]);
        assert_eq!(decades(&[0.001, 20.0]), [-3, 2]);
        assert_eq!(decades(&[]), [0, 1]);
        for vals in [vec![0.5, 0.05], vec![0.9], vec![1e-7, 0.99], vec![1.5, 9.5, 11.0], vec![0.1, 0.05]] {
            let [lo, hi] = decades(&vals);
            assert!(hi > lo, "{vals:?}");
            for v in &vals {
                assert!((lo as f64..=hi as f64).contains(&v.log10()), "{v} outside 1e{lo}..1e{hi}");
            }
        }
        // the JSON of a zero decade is `0`, not `-0` (a script reading `-0` is where it went wrong)
        assert_eq!(json!(decades(&[0.5])).to_string(), "[-1,0]");
    }

    #[test]
    fn rgbe_round_trips_within_its_precision() {
        for c in [[0.5f32, 0.25, 0.125], [1000.0, 1.0, 0.0], [1e-3, 2e-3, 3e-3]] {
            let [r, g, b, e] = rgbe(c);
            let f = 2f32.powi(e as i32 - 128 - 8);
            for (v, q) in c.iter().zip([r, g, b]) {
                let back = (q as f32 + 0.5) * f;
                assert!((back - v).abs() <= 0.5 * f * 2.0 + 1e-6, "{c:?} -> {back}");
            }
        }
        assert_eq!(rgbe([0.0; 3]), [0; 4]);
    }
}
