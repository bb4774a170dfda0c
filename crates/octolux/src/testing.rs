//! Statistical test helpers shared by the crate's tests: a chi-square goodness-of-fit test of
//! a sampling routine against the density it claims (in the spirit of Mitsuba 3's `chi2.py`).
//!
//! The test bins a 2D domain into a regular grid of cells, integrates the claimed density over
//! every cell numerically (composite Simpson rule on a finer grid), draws `N` samples and
//! compares the observed cell counts with the expected counts `N ∫_cell pdf`. A routine that
//! may fail to produce a sample (absorption, a sample outside the support) gets one more cell:
//! "no sample", expected `N (1 - ∫ pdf)`. Cells expected to receive fewer than 5 samples are
//! pooled (cells sorted by expectation, the smallest merged until the pool reaches 5). The
//! statistic `Σ (O - E)² / E` is compared with the chi-square distribution with
//! `cells - 1` degrees of freedom; the null hypothesis ("the samples follow the pdf") is rejected
//! when the p-value falls below the Šidák-corrected significance `1 - (1 - α)^(1 / tests)`.
//! A sample in a cell whose expected count is 0 fails the test outright.
//!
//! For directions, [`chi2_sphere`] uses the domain `(cos θ, φ) ∈ [-1, 1] × [0, 2π)` in which
//! the solid-angle measure is `dz dφ`, so a solid-angle pdf is integrated as is.
//! [`check_bsdf`] additionally checks, for every sample, that `sample`'s `pdf` equals `pdf()`
//! and its `weight` equals `eval / pdf`.
//!
//! Numerical integration assumes the pdf is smooth inside each cell: choose a domain whose
//! cell boundaries follow the discontinuities of the pdf (for example the horizon `z = 0`,
//! which is a cell boundary when `cos_bins` is even).

use crate::image::Image;
use crate::math::Color;
use crate::sampling::Sampler;
use crate::scene::material::Material;
use glam::{Vec2, Vec3};

/// Settings of one chi-square test.
#[derive(Clone, Debug)]
pub struct Chi2Config {
    /// Cells along the first coordinate (`cos θ` for [`chi2_sphere`]).
    pub bins_x: usize,
    /// Cells along the second coordinate (`φ` for [`chi2_sphere`]).
    pub bins_y: usize,
    /// Number of draws.
    pub samples: usize,
    /// Simpson sub-intervals per cell and axis (rounded up to even).
    pub subdiv: usize,
    /// Family-wise significance level (0.01).
    pub significance: f64,
    /// Number of tests in the family (Šidák correction).
    pub tests: usize,
    pub seed: u64,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Chi2Config { bins_x: 20, bins_y: 40, samples: 200_000, subdiv: 8, significance: 0.01, tests: 1, seed: 1 }
    }
}

/// Outcome of a chi-square test.
#[derive(Clone, Debug)]
pub struct Chi2Outcome {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Numerical integral of the pdf over the whole domain.
    pub pdf_integral: f64,
    /// Fraction of draws that produced a sample.
    pub valid_fraction: f64,
    pub passed: bool,
    /// Why the test failed (empty when it passed).
    pub message: String,
}

/// Šidák-corrected per-test significance for a family of `tests` tests at level `alpha`.
pub fn sidak(alpha: f64, tests: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / tests.max(1) as f64)
}

/// `ln Γ(x)` for `x > 0` (Lanczos approximation, g = 7, 9 terms; relative error ~1e-15).
pub fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // reflection formula
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma function `Q(a, x) = Γ(a, x) / Γ(a)` for `a > 0`:
/// series for `x < a + 1`, Lentz's continued fraction otherwise.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let log_prefix = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        let mut ap = a;
        let mut del = 1.0 / a;
        let mut sum = del;
        for _ in 0..100_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * log_prefix.exp()).clamp(0.0, 1.0)
    } else {
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..100_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (log_prefix.exp() * h).clamp(0.0, 1.0)
    }
}

/// Survival function (p-value) of the chi-square distribution with `dof` degrees of freedom.
pub fn chi2_sf(statistic: f64, dof: usize) -> f64 {
    gamma_q(dof as f64 * 0.5, statistic * 0.5)
}

/// Chi-square test of a sampler on the rectangle `[lo.x, hi.x] × [lo.y, hi.y]`.
///
/// `sample` returns a point of the domain, or `None` when the routine produced nothing;
/// `pdf` is the claimed density with respect to `dx dy`. A sample outside the domain or not
/// finite fails the test.
pub fn chi2_2d(
    cfg: &Chi2Config,
    lo: Vec2,
    hi: Vec2,
    sample: impl FnMut(&mut Sampler) -> Option<Vec2>,
    pdf: impl Fn(Vec2) -> f64,
) -> Chi2Outcome {
    chi2_2d_impl(cfg, lo, hi, sample, pdf, false)
}

/// [`chi2_2d`] for a pdf that jumps on the test's cell edges (piecewise-constant
/// distributions whose cells the test cells refine): each cell is integrated on its own nodes,
/// moved inside the cell by a relative `1e-4` of its size, so that no node falls on an edge.
pub fn chi2_2d_piecewise(
    cfg: &Chi2Config,
    lo: Vec2,
    hi: Vec2,
    sample: impl FnMut(&mut Sampler) -> Option<Vec2>,
    pdf: impl Fn(Vec2) -> f64,
) -> Chi2Outcome {
    chi2_2d_impl(cfg, lo, hi, sample, pdf, true)
}

fn chi2_2d_impl(
    cfg: &Chi2Config,
    lo: Vec2,
    hi: Vec2,
    mut sample: impl FnMut(&mut Sampler) -> Option<Vec2>,
    pdf: impl Fn(Vec2) -> f64,
    inset: bool,
) -> Chi2Outcome {
    let (nx, ny) = (cfg.bins_x.max(1), cfg.bins_y.max(1));
    let s = (cfg.subdiv.max(2) + 1) & !1;
    let (lo64, hi64) = (lo.as_dvec2(), hi.as_dvec2());
    let (hx, hy) = ((hi64.x - lo64.x) / (nx * s) as f64, (hi64.y - lo64.y) / (ny * s) as f64);
    // pdf on the fine grid
    let (gx, gy) = (nx * s + 1, ny * s + 1);
    let mut grid = vec![0.0f64; gx * gy];
    for i in 0..if inset { 0 } else { gx } {
        for j in 0..gy {
            let p = glam::DVec2::new(lo64.x + i as f64 * hx, lo64.y + j as f64 * hy).as_vec2();
            let v = pdf(p);
            grid[i * gy + j] = if v.is_finite() { v } else { f64::NAN };
        }
    }
    let simpson = |k: usize| -> f64 {
        if k == 0 || k == s {
            1.0
        } else if k % 2 == 1 {
            4.0
        } else {
            2.0
        }
    };
    let mut expected_mass = vec![0.0f64; nx * ny];
    for ci in 0..nx {
        for cj in 0..ny {
            let mut acc = 0.0;
            for a in 0..=s {
                let row = (ci * s + a) * gy + cj * s;
                let wa = simpson(a);
                for b in 0..=s {
                    let v = if inset {
                        // node (a, b) of this cell, moved off the cell's edges
                        let e = 1e-4;
                        let fx = (a as f64 / s as f64).clamp(e, 1.0 - e);
                        let fy = (b as f64 / s as f64).clamp(e, 1.0 - e);
                        let p = glam::DVec2::new(lo64.x + (ci as f64 + fx) * hx * s as f64, lo64.y + (cj as f64 + fy) * hy * s as f64);
                        let v = pdf(p.as_vec2());
                        if v.is_finite() {
                            v
                        } else {
                            f64::NAN
                        }
                    } else {
                        grid[row + b]
                    };
                    acc += wa * simpson(b) * v;
                }
            }
            expected_mass[ci * ny + cj] = acc * hx * hy / 9.0;
        }
    }
    let pdf_integral: f64 = expected_mass.iter().sum();
    let mut out =
        Chi2Outcome { statistic: 0.0, dof: 0, p_value: 0.0, pdf_integral, valid_fraction: 0.0, passed: false, message: String::new() };
    if !pdf_integral.is_finite() || expected_mass.iter().any(|&m| m < 0.0) {
        out.message = format!("the pdf is negative or not finite somewhere (integral {pdf_integral})");
        return out;
    }

    // draw
    let mut observed = vec![0u64; nx * ny];
    let mut none = 0u64;
    let mut sampler = Sampler::new(cfg.seed, 0x5eed, 0);
    for _ in 0..cfg.samples {
        match sample(&mut sampler) {
            None => none += 1,
            Some(p) => {
                if !p.is_finite() || p.x < lo.x || p.x > hi.x || p.y < lo.y || p.y > hi.y {
                    out.message = format!("sample {p} lies outside the domain [{lo}, {hi}]");
                    return out;
                }
                let ix = (((p.x - lo.x) / (hi.x - lo.x) * nx as f32) as usize).min(nx - 1);
                let iy = (((p.y - lo.y) / (hi.y - lo.y) * ny as f32) as usize).min(ny - 1);
                observed[ix * ny + iy] += 1;
            }
        }
    }
    let n = cfg.samples as f64;
    out.valid_fraction = (n - none as f64) / n;

    // cells: (observed, expected), plus the "no sample" cell
    let mut cells: Vec<(f64, f64)> = observed.iter().zip(&expected_mass).map(|(&o, &m)| (o as f64, m * n)).collect();
    cells.push((none as f64, (1.0 - pdf_integral).max(0.0) * n));
    for (k, &(o, e)) in cells.iter().enumerate() {
        if e <= 0.0 && o > 0.0 {
            out.message = if k == nx * ny {
                format!("{o} draws produced no sample although the pdf integrates to {pdf_integral}")
            } else {
                format!("{o} samples fell in cell ({}, {}) where the pdf is zero", k / ny, k % ny)
            };
            return out;
        }
    }
    cells.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (mut pool_o, mut pool_e) = (0.0f64, 0.0f64);
    let (mut chi2, mut used) = (0.0f64, 0usize);
    for &(o, e) in &cells {
        if e <= 0.0 {
            continue;
        }
        if e < 5.0 || (pool_e > 0.0 && pool_e < 5.0) {
            pool_o += o;
            pool_e += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            used += 1;
        }
    }
    if pool_e > 0.0 {
        chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        used += 1;
    }
    out.statistic = chi2;
    out.dof = used.saturating_sub(1).max(1);
    out.p_value = chi2_sf(chi2, out.dof);
    let level = sidak(cfg.significance, cfg.tests);
    out.passed = out.p_value >= level;
    if !out.passed {
        out.message = format!("chi-square {chi2:.1} with {} dof: p-value {:.3e} < {level:.3e}", out.dof, out.p_value);
    }
    out
}

/// `(cos θ, φ)` coordinates of a unit direction, `φ ∈ [0, 2π)`.
#[inline]
pub fn direction_to_zphi(d: Vec3) -> Vec2 {
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += std::f32::consts::TAU;
    }
    Vec2::new(d.z.clamp(-1.0, 1.0), phi.min(std::f32::consts::TAU))
}

/// Unit direction of `(cos θ, φ)` coordinates.
#[inline]
pub fn zphi_to_direction(zp: Vec2) -> Vec3 {
    let r = (1.0 - zp.x * zp.x).max(0.0).sqrt();
    let (s, c) = zp.y.sin_cos();
    Vec3::new(r * c, r * s, zp.x)
}

/// Chi-square test of a direction sampler against its solid-angle pdf over the whole sphere.
pub fn chi2_sphere(cfg: &Chi2Config, mut sample: impl FnMut(&mut Sampler) -> Option<Vec3>, pdf: impl Fn(Vec3) -> f64) -> Chi2Outcome {
    chi2_2d(
        cfg,
        Vec2::new(-1.0, 0.0),
        Vec2::new(1.0, std::f32::consts::TAU),
        |s| sample(s).map(direction_to_zphi),
        |zp| pdf(zphi_to_direction(zp)),
    )
}

/// Chi-square test of `material.sample` from `wo` (local frame) against `material.pdf`, plus
/// per-sample consistency: `sample.pdf == pdf(wo, wi)` and `weight == eval / pdf` (relative
/// tolerance `1e-3`). Specular samples count as "no sample" (their mass is not in `pdf`).
pub fn check_bsdf(cfg: &Chi2Config, material: &Material, images: &[Image], uv: Vec2, wo: Vec3) -> Chi2Outcome {
    let mut inconsistency: Option<String> = None;
    let close = |a: f32, b: f32| (a - b).abs() <= 1e-3 * a.abs().max(b.abs()) + 1e-6;
    let close_c = |a: Color, b: Color| close(a.x, b.x) && close(a.y, b.y) && close(a.z, b.z);
    let mut out = chi2_sphere(
        cfg,
        |s| {
            let u_lobe = s.next_1d();
            let u = s.next_2d();
            let bs = material.sample(images, uv, wo, u_lobe, u)?;
            if bs.lobe.is_delta() {
                return None;
            }
            if inconsistency.is_none() {
                let pdf = material.pdf(images, uv, wo, bs.wi);
                let f = material.eval(images, uv, wo, bs.wi);
                if !close(bs.pdf, pdf) {
                    inconsistency = Some(format!("sample pdf {} but pdf() {} at wi {}", bs.pdf, pdf, bs.wi));
                } else if !close_c(bs.weight, f / pdf) {
                    inconsistency = Some(format!("sample weight {} but eval/pdf {} at wi {}", bs.weight, f / pdf, bs.wi));
                } else if !bs.weight.is_finite() || bs.weight.min_element() < 0.0 {
                    inconsistency = Some(format!("weight {} is negative or not finite", bs.weight));
                }
            }
            Some(bs.wi)
        },
        |wi| material.pdf(images, uv, wo, wi) as f64,
    );
    if let Some(m) = inconsistency {
        out.passed = false;
        out.message = if out.message.is_empty() { m } else { format!("{m}; {}", out.message) };
    }
    out
}

/// The cache integrators with test-sized photon counts, `octree` twice (`mode = terminate`,
/// the default, and `mode = paper`): `octree_photons` for the octree, `photons` and `n_max` 50 for the baselines,
/// `gather_rays` for the photon map's final gathering. The furnace tests and the random-scene
/// property test run them all.
pub fn cache_integrators(
    octree_photons: u64,
    photons: u64,
    gather_rays: u32,
) -> Vec<(&'static str, crate::integrators::IntegratorSettings)> {
    use crate::integrators::octree::{Mode, OctreeIntegratorSettings};
    use crate::integrators::photon::{christensen::ChristensenSettings, photonmap::PhotonMapSettings, ward::WardSettings};
    use crate::integrators::IntegratorSettings;
    let mut octree = OctreeIntegratorSettings::default();
    octree.photons.photons = octree_photons;
    let paper = OctreeIntegratorSettings { mode: Mode::Paper, ..octree.clone() };
    let mut pm = PhotonMapSettings { gather_rays, ..Default::default() };
    pm.photons.photons = photons;
    pm.global.n_max = 50;
    let mut ward = WardSettings::default();
    ward.photons.photons = photons;
    ward.density.n_max = 50;
    ward.caustic.n_max = 50;
    let mut chr = ChristensenSettings::default();
    chr.photons.photons = photons;
    chr.density.n_max = 50;
    chr.caustic.n_max = 50;
    vec![
        ("octree", IntegratorSettings::Octree(octree)),
        ("octree mode=paper", IntegratorSettings::Octree(paper)),
        ("photonmap", IntegratorSettings::Photonmap(pm)),
        ("ward", IntegratorSettings::Ward(ward)),
        ("christensen", IntegratorSettings::Christensen(chr)),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf, square_to_uniform_hemisphere, UNIFORM_SPHERE_PDF};

    #[test]
    fn gamma_functions_match_closed_forms() {
        // Γ(n) = (n-1)!, Γ(1/2) = √π
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
        assert!((ln_gamma(101.0) - (1..=100).map(|k| (k as f64).ln()).sum::<f64>()).abs() < 1e-9);
        for &x in &[0.01, 0.5, 1.0, 3.0, 10.0, 40.0] {
            // dof 2: exp(-x/2); dof 4: exp(-x/2)(1 + x/2); dof 1: erfc(sqrt(x/2))
            assert!((chi2_sf(x, 2) - (-x / 2.0).exp()).abs() < 1e-12, "x={x}");
            assert!((chi2_sf(x, 4) - (-x / 2.0).exp() * (1.0 + x / 2.0)).abs() < 1e-12, "x={x}");
        }
        // large dof: the median of chi2(k) is about k (1 - 2/(9k))³
        let k = 1000.0f64;
        let median = k * (1.0 - 2.0 / (9.0 * k)).powi(3);
        assert!((chi2_sf(median, 1000) - 0.5).abs() < 1e-3);
        assert!((sidak(0.01, 1) - 0.01).abs() < 1e-15);
        assert!(sidak(0.01, 10) < 0.01 / 9.9 && sidak(0.01, 10) > 0.01 / 10.0);
    }

    #[test]
    fn harness_accepts_correct_samplers_and_rejects_wrong_ones() {
        let cfg = Chi2Config { samples: 100_000, tests: 3, ..Default::default() };
        let ok = chi2_sphere(&cfg, |s| Some(square_to_cosine_hemisphere(s.next_2d())), |d| square_to_cosine_hemisphere_pdf(d) as f64);
        assert!(ok.passed, "{ok:?}");
        assert!((ok.pdf_integral - 1.0).abs() < 1e-4, "{}", ok.pdf_integral);
        // uniform hemisphere samples claimed to be cosine-distributed
        let bad = chi2_sphere(&cfg, |s| Some(square_to_uniform_hemisphere(s.next_2d())), |d| square_to_cosine_hemisphere_pdf(d) as f64);
        assert!(!bad.passed, "{bad:?}");
        // a sampler that drops 10% of its samples while claiming a normalised pdf
        let lossy = chi2_sphere(
            &cfg,
            |s| {
                let d = crate::sampling::square_to_uniform_sphere(s.next_2d());
                (s.next_1d() > 0.1).then_some(d)
            },
            |_| UNIFORM_SPHERE_PDF as f64,
        );
        assert!(!lossy.passed, "{lossy:?}");
        // ... and is accepted when the pdf says so
        let honest = chi2_sphere(
            &cfg,
            |s| {
                let d = crate::sampling::square_to_uniform_sphere(s.next_2d());
                (s.next_1d() > 0.1).then_some(d)
            },
            |_| 0.9 * UNIFORM_SPHERE_PDF as f64,
        );
        assert!(honest.passed, "{honest:?}");
        assert!((honest.valid_fraction - 0.9).abs() < 0.01);
    }
}
