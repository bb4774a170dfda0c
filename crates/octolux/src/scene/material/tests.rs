//! Tests of the materials: chi² tests of every sampling routine, reciprocity, white-furnace
//! energy bounds, Fresnel against textbook formulas, validation.

use super::fresnel::*;
use super::microfacet::{Microfacet, MicrofacetKind};
use super::plastic::{plastic_tables, PlasticTables};
use super::*;
use crate::math::gauss_legendre;
use crate::sampling::Sampler;
use crate::testing::{check_bsdf, Chi2Config};
use std::f32::consts::FRAC_1_PI;

/// Number of chi-square tests run by `bsdf_sampling_matches_pdf` (Šidák family size).
const CHI2_TESTS: usize = 16;

pub(super) fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

pub(super) fn white(c: f32) -> Color {
    Color::splat(c)
}

fn ggx(alpha: f32) -> Microfacet {
    Microfacet::isotropic(MicrofacetKind::Ggx, alpha)
}

fn rough_conductor(alpha: f32) -> Material {
    // gold-like complex IOR
    Material::RoughConductor {
        distribution: ggx(alpha).into(),
        eta: Color::new(0.143, 0.374, 1.442),
        k: Color::new(3.983, 2.385, 1.603),
        specular_reflectance: white(1.0),
    }
}

fn rough_plastic(alpha: f32, kd: Color) -> Material {
    Material::RoughPlastic {
        diffuse_reflectance: Texture::Const(kd),
        specular_reflectance: white(1.0),
        distribution: ggx(alpha),
        eta: 1.49,
        nonlinear: false,
    }
}

#[test]
fn bsdf_sampling_matches_pdf() {
    let base = Chi2Config { samples: 200_000, tests: CHI2_TESTS, bins_x: 40, bins_y: 40, subdiv: 8, ..Default::default() };
    let fine = Chi2Config { bins_x: 80, subdiv: 16, ..base.clone() };
    let cases: Vec<(&str, Material, Vec3, &Chi2Config)> = vec![
        ("diffuse 0", Material::Diffuse { reflectance: Texture::Const(Color::new(0.8, 0.5, 0.2)) }, dir(0.0, 0.0), &base),
        ("diffuse 70", Material::Diffuse { reflectance: Texture::Const(white(0.5)) }, dir(70.0, 30.0), &base),
        ("roughconductor 0.1 @ 45", rough_conductor(0.1), dir(45.0, 10.0), &fine),
        ("roughconductor 0.1 @ 80", rough_conductor(0.1), dir(80.0, 200.0), &fine),
        ("roughconductor 0.3 @ 0", rough_conductor(0.3), dir(0.0, 0.0), &fine),
        ("roughconductor 0.3 @ 60", rough_conductor(0.3), dir(60.0, 90.0), &base),
        ("roughconductor 0.7 @ 20", rough_conductor(0.7), dir(20.0, 300.0), &base),
        ("roughconductor 0.7 @ 85", rough_conductor(0.7), dir(85.0, 45.0), &base),
        ("roughplastic 0.1 @ 30", rough_plastic(0.1, Color::new(0.2, 0.4, 0.8)), dir(30.0, 0.0), &fine),
        ("roughplastic 0.3 @ 0", rough_plastic(0.3, white(0.5)), dir(0.0, 0.0), &fine),
        ("roughplastic 0.5 @ 75", rough_plastic(0.5, white(0.9)), dir(75.0, 120.0), &base),
        ("roughplastic black 0.2 @ 50", rough_plastic(0.2, white(0.0)), dir(50.0, 0.0), &fine),
        (
            "twosided diffuse, back",
            Material::TwoSided {
                front: Box::new(Material::Diffuse { reflectance: Texture::Const(white(0.5)) }),
                back: Box::new(Material::Diffuse { reflectance: Texture::Const(white(0.7)) }),
            },
            -dir(35.0, 10.0),
            &base,
        ),
        (
            "twosided roughconductor, back",
            Material::TwoSided { front: Box::new(rough_conductor(0.3)), back: Box::new(rough_conductor(0.3)) },
            Vec3::new(0.3, -0.4, -0.866).normalize(),
            &base,
        ),
        (
            "twosided roughplastic, back",
            Material::TwoSided { front: Box::new(rough_plastic(0.3, white(0.5))), back: Box::new(rough_plastic(0.3, white(0.5))) },
            -dir(60.0, 250.0),
            &base,
        ),
        (
            "twosided roughplastic, front",
            Material::TwoSided {
                front: Box::new(rough_plastic(0.3, white(0.5))),
                back: Box::new(Material::Diffuse { reflectance: Texture::Const(white(0.5)) }),
            },
            dir(60.0, 250.0),
            &base,
        ),
    ];
    assert_eq!(cases.len(), CHI2_TESTS);
    let mut failures = Vec::new();
    for (name, m, wo, cfg) in &cases {
        let r = check_bsdf(cfg, m, &[], Vec2::ZERO, *wo);
        if !r.passed || r.pdf_integral > 1.0 + 2e-3 {
            failures.push(format!("{name}: {} (pdf integral {:.5}, valid fraction {:.5})", r.message, r.pdf_integral, r.valid_fraction));
        }
        // non-absorbing lobes at moderate incidence: the pdf is normalised
        if name.starts_with("diffuse") && (r.pdf_integral - 1.0).abs() > 1e-3 {
            failures.push(format!("{name}: pdf integrates to {}", r.pdf_integral));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn chi2_detects_a_wrong_roughness_or_a_biased_lobe_choice() {
    // samples of alpha 0.3 judged against the pdf of alpha 0.36: must be rejected
    let cfg = Chi2Config { samples: 200_000, bins_x: 40, bins_y: 40, ..Default::default() };
    let (a, b) = (rough_conductor(0.3), rough_conductor(0.36));
    let wo = dir(40.0, 0.0);
    let r = crate::testing::chi2_sphere(
        &cfg,
        |s| {
            let (ul, u) = (s.next_1d(), s.next_2d());
            a.sample(&[], Vec2::ZERO, wo, ul, u).map(|bs| bs.wi)
        },
        |wi| b.pdf(&[], Vec2::ZERO, wo, wi) as f64,
    );
    assert!(!r.passed, "{r:?}");
    // plastic samples whose lobe choice ignores the selection probability
    let m = rough_plastic(0.3, white(0.5));
    let r = crate::testing::chi2_sphere(
        &cfg,
        |s| {
            let (ul, u) = (s.next_1d(), s.next_2d());
            m.sample(&[], Vec2::ZERO, wo, 0.5 * ul + 0.5, u).map(|bs| bs.wi)
        },
        |wi| m.pdf(&[], Vec2::ZERO, wo, wi) as f64,
    );
    assert!(!r.passed, "{r:?}");
}

#[test]
fn visible_normal_pdf_integrates_to_one_over_normals() {
    // ∫ D(m) G1(v,m) max(0, v·m) / v.z dm = 1 (visible normal distribution)
    for &alpha in &[0.05f32, 0.3, 0.8] {
        for &theta in &[0.0f32, 45.0, 80.0] {
            let g = ggx(alpha);
            let v = dir(theta, 20.0);
            let (nodes, w) = gauss_legendre(256);
            let mut acc = 0.0f64;
            // integrate over the hemisphere of normals in (cos θ_m, φ): the integrand is
            // concentrated near the pole for small alpha, so substitute z = 1 - t² ... use
            // the D-sampling of slopes instead: m = normalize(-s, 1) with uniform grid in
            // angle θ_m ∈ [0, π/2] (integrand × sin θ_m).
            for (ti, wt) in nodes.iter().zip(&w) {
                let tm = (0.5 * ti + 0.5) * std::f64::consts::FRAC_PI_2;
                for (pi, wp) in nodes.iter().zip(&w) {
                    let ph = (0.5 * pi + 0.5) * std::f64::consts::TAU;
                    let m = Vec3::new((tm.sin() * ph.cos()) as f32, (tm.sin() * ph.sin()) as f32, tm.cos() as f32);
                    let f = g.d(m) as f64 * g.g1(v, m) as f64 * (v.dot(m).max(0.0) / v.z) as f64 * tm.sin();
                    acc += f * wt * wp * 0.25 * std::f64::consts::FRAC_PI_2 * std::f64::consts::TAU;
                }
            }
            assert!((acc - 1.0).abs() < 2e-2, "alpha {alpha} theta {theta}: {acc}");
        }
    }
}

/// Textbook Fresnel for a dielectric interface (f64, via Snell's law).
fn fresnel_reference(cos_i: f64, n1: f64, n2: f64) -> f64 {
    let sin_t = n1 / n2 * (1.0 - cos_i * cos_i).sqrt();
    if sin_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i);
    0.5 * (rs * rs + rp * rp)
}

#[test]
fn dielectric_probabilities_weights_and_directions() {
    let eta = 1.5f32;
    let m = Material::Dielectric { eta, specular_reflectance: white(1.0), specular_transmittance: white(1.0) };
    assert!(!m.has_smooth_lobe());
    // normal incidence: F = ((n-1)/(n+1))²
    let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    let r = m.sample(&[], Vec2::ZERO, Vec3::Z, 0.0, Vec2::splat(0.5)).unwrap();
    assert_eq!(r.lobe, Lobe::Specular);
    assert!((r.pdf - f0).abs() < 1e-6 && (r.wi - Vec3::Z).length() < 1e-6 && r.weight == white(1.0) && r.eta == 1.0);
    let t = m.sample(&[], Vec2::ZERO, Vec3::Z, f0 + 0.01, Vec2::splat(0.5)).unwrap();
    assert!((t.pdf - (1.0 - f0)).abs() < 1e-6 && (t.wi + Vec3::Z).length() < 1e-6);
    assert!((t.weight - white(1.0 / (eta * eta))).abs().max_element() < 1e-6, "radiance scaled by 1/eta²: {}", t.weight);
    assert_eq!(t.eta, eta);
    // from inside: transmission into air scales radiance by eta²
    let t_in = m.sample(&[], Vec2::ZERO, -Vec3::Z, 0.5, Vec2::splat(0.5)).unwrap();
    assert!((t_in.weight - white(eta * eta)).abs().max_element() < 1e-5 && (t_in.eta - 1.0 / eta).abs() < 1e-6);
    assert!((t_in.wi - Vec3::Z).length() < 1e-6);
    // oblique incidence from both sides: R matches the textbook formula, R + T = 1, Snell holds
    for &(theta, inside) in &[(30.0f32, false), (60.0, false), (89.0, false), (20.0, true), (41.0, true), (60.0, true)] {
        let wo = if inside { -dir(theta, 40.0) } else { dir(theta, 40.0) };
        let (n1, n2) = if inside { (eta as f64, 1.0) } else { (1.0, eta as f64) };
        let r_ref = fresnel_reference((theta as f64).to_radians().cos(), n1, n2) as f32;
        let rs = m.sample(&[], Vec2::ZERO, wo, 0.0, Vec2::ZERO).unwrap();
        assert!((rs.pdf - r_ref).abs() < 1e-5, "theta {theta} inside {inside}: {} vs {r_ref}", rs.pdf);
        assert!((rs.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
        if r_ref < 1.0 {
            let ts = m.sample(&[], Vec2::ZERO, wo, 0.999_999, Vec2::ZERO).unwrap();
            assert!((rs.pdf + ts.pdf - 1.0).abs() < 1e-6, "R + T = 1");
            assert!(ts.wi.z * wo.z < 0.0 && (ts.wi.length() - 1.0).abs() < 1e-5);
            let sin_i = (1.0 - wo.z * wo.z).sqrt() as f64;
            let sin_t = (1.0 - ts.wi.z * ts.wi.z).max(0.0).sqrt() as f64;
            assert!((n1 * sin_i - n2 * sin_t).abs() < 1e-4, "Snell: {n1} {sin_i} vs {n2} {sin_t}");
            // refracted direction stays in the plane of incidence, on the opposite azimuth
            assert!(ts.wi.x * wo.x <= 0.0 && ts.wi.y * wo.y <= 0.0);
            // energy: R·1 + T·(weight · eta_it²) = 1 for a white dielectric
            let energy = rs.pdf * rs.weight.x + ts.pdf * ts.weight.x * ts.eta * ts.eta;
            assert!((energy - 1.0).abs() < 1e-5, "energy {energy}");
        } else {
            // total internal reflection: reflection is certain
            assert!(inside && rs.pdf == 1.0);
            let again = m.sample(&[], Vec2::ZERO, wo, 0.999_999, Vec2::ZERO).unwrap();
            assert!((again.wi - rs.wi).length() < 1e-6);
        }
    }
    // index-matched interface: everything goes straight through, unscaled
    let matched = Material::Dielectric { eta: 1.0, specular_reflectance: white(1.0), specular_transmittance: white(1.0) };
    let s = matched.sample(&[], Vec2::ZERO, dir(50.0, 0.0), 0.0, Vec2::ZERO).unwrap();
    assert!((s.wi + dir(50.0, 0.0)).length() < 1e-5 && s.pdf == 1.0 && s.weight == white(1.0));
    assert_eq!(m.eval(&[], Vec2::ZERO, Vec3::Z, -Vec3::Z), Color::ZERO);
    assert_eq!(m.pdf(&[], Vec2::ZERO, Vec3::Z, -Vec3::Z), 0.0);
}

#[test]
fn thin_dielectric_includes_interreflections() {
    let eta = 1.5f32;
    let m = Material::ThinDielectric {
        eta,
        specular_reflectance: Color::new(1.0, 0.5, 0.25),
        specular_transmittance: Color::new(0.5, 1.0, 1.0),
    };
    let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    // R' = R + T²R/(1-R²) = 2R/(1+R)
    let r_thin = 2.0 * r0 / (1.0 + r0);
    let r = m.sample(&[], Vec2::ZERO, Vec3::Z, 0.0, Vec2::ZERO).unwrap();
    assert!((r.pdf - r_thin).abs() < 1e-6, "{} vs {r_thin}", r.pdf);
    assert_eq!(r.weight, Color::new(1.0, 0.5, 0.25));
    let wo = dir(40.0, 75.0);
    let t = m.sample(&[], Vec2::ZERO, wo, 0.9999, Vec2::ZERO).unwrap();
    assert!((t.wi + wo).length() < 1e-6, "straight through");
    assert_eq!(t.weight, Color::new(0.5, 1.0, 1.0));
    assert_eq!(t.eta, 1.0);
    let r40 = m.sample(&[], Vec2::ZERO, wo, 0.0, Vec2::ZERO).unwrap();
    assert!((r40.pdf + t.pdf - 1.0).abs() < 1e-6);
    let f = fresnel_reference(40f64.to_radians().cos(), 1.0, 1.5) as f32;
    assert!((r40.pdf - 2.0 * f / (1.0 + f)).abs() < 1e-5);
    // symmetric: same probabilities from the back
    let back = m.sample(&[], Vec2::ZERO, -wo, 0.0, Vec2::ZERO).unwrap();
    assert!((back.pdf - r40.pdf).abs() < 1e-6 && back.wi.z < 0.0);
}

/// Fresnel reflectance of a conductor with complex IOR, computed with complex arithmetic.
fn conductor_reference(cos_i: f64, eta: f64, k: f64) -> f64 {
    // complex helpers on (re, im)
    let mul = |a: (f64, f64), b: (f64, f64)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
    let div = |a: (f64, f64), b: (f64, f64)| {
        let d = b.0 * b.0 + b.1 * b.1;
        ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
    };
    let sqrt = |a: (f64, f64)| {
        let r = (a.0 * a.0 + a.1 * a.1).sqrt();
        let re = ((r + a.0) * 0.5).sqrt();
        let im = ((r - a.0) * 0.5).max(0.0).sqrt().copysign(a.1);
        (re, im)
    };
    let n = (eta, k);
    let n2 = mul(n, n);
    let sin2 = 1.0 - cos_i * cos_i;
    let ct = sqrt((n2.0 - sin2, n2.1)); // n cos θ_t
    let c = (cos_i, 0.0);
    let rs = div((c.0 - ct.0, -ct.1), (c.0 + ct.0, ct.1));
    let n2c = mul(n2, c);
    let rp = div((n2c.0 - ct.0, n2c.1 - ct.1), (n2c.0 + ct.0, n2c.1 + ct.1));
    0.5 * ((rs.0 * rs.0 + rs.1 * rs.1) + (rp.0 * rp.0 + rp.1 * rp.1))
}

#[test]
fn conductor_fresnel_matches_complex_formula() {
    for &(eta, k) in &[(0.143f32, 3.983f32), (1.5, 0.0), (2.9, 3.0), (0.2, 0.5)] {
        // normal incidence: ((n-1)² + k²) / ((n+1)² + k²)
        let f0 = ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k);
        assert!((fresnel_conductor_1(1.0, eta, k) - f0).abs() < 1e-5, "{eta} {k}");
        for &theta in &[0.0f64, 20.0, 45.0, 70.0, 85.0, 89.5] {
            let c = theta.to_radians().cos();
            let want = conductor_reference(c, eta as f64, k as f64) as f32;
            let got = fresnel_conductor_1(c as f32, eta, k);
            assert!((got - want).abs() < 2e-4, "eta {eta} k {k} theta {theta}: {got} vs {want}");
        }
    }
    // material "none": exactly 1 at every angle, so reflectance = specular_reflectance
    let none = Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::new(0.9, 0.8, 0.7) };
    for &theta in &[0.0f32, 30.0, 89.9] {
        let wo = dir(theta, 10.0);
        let s = none.sample(&[], Vec2::ZERO, wo, 0.3, Vec2::ZERO).unwrap();
        assert_eq!(s.weight, Color::new(0.9, 0.8, 0.7));
        assert_eq!(s.lobe, Lobe::Specular);
        assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
    }
    assert!(none.sample(&[], Vec2::ZERO, -Vec3::Z, 0.3, Vec2::ZERO).is_none(), "one-sided");
    let gold =
        Material::Conductor { eta: Color::new(0.143, 0.374, 1.442), k: Color::new(3.983, 2.385, 1.603), specular_reflectance: white(1.0) };
    let s = gold.sample(&[], Vec2::ZERO, Vec3::Z, 0.0, Vec2::ZERO).unwrap();
    assert!(s.weight.x > s.weight.z, "gold reflects red more than blue: {}", s.weight);
}

#[test]
fn reflection_lobes_are_reciprocal() {
    let materials = [
        Material::Diffuse { reflectance: Texture::Const(Color::new(0.3, 0.6, 0.9)) },
        rough_conductor(0.05),
        rough_conductor(0.4),
        rough_plastic(0.1, Color::new(0.5, 0.2, 0.1)),
        rough_plastic(0.6, white(0.8)),
    ];
    assert_reciprocal(&materials, true);
}

/// `f(a, b) / cos b == f(b, a) / cos a` over 2000 random pairs of directions above the surface
/// (most of them non-zero); with `one_sided`, nothing is reflected to or from below.
pub(super) fn assert_reciprocal(materials: &[Material], one_sided: bool) {
    let mut s = Sampler::new(3, 0, 0);
    for m in materials {
        let mut nonzero = 0;
        for _ in 0..2000 {
            let a = crate::sampling::square_to_uniform_hemisphere(s.next_2d());
            let b = crate::sampling::square_to_uniform_hemisphere(s.next_2d());
            if a.z < 1e-3 || b.z < 1e-3 {
                continue;
            }
            let fab = m.eval(&[], Vec2::ZERO, a, b) / b.z;
            let fba = m.eval(&[], Vec2::ZERO, b, a) / a.z;
            let scale = fab.max_element().max(fba.max_element());
            assert!((fab - fba).abs().max_element() <= 1e-3 * scale + 1e-7, "{m:?}: {fab} vs {fba}");
            nonzero += (scale > 0.0) as usize;
            if one_sided {
                assert_eq!(m.eval(&[], Vec2::ZERO, a, -b), Color::ZERO);
                assert_eq!(m.eval(&[], Vec2::ZERO, -a, b), Color::ZERO);
                assert_eq!(m.pdf(&[], Vec2::ZERO, a, -b), 0.0);
            }
        }
        assert!(nonzero > 1000, "{m:?}");
    }
}

/// Monte Carlo directional albedo: mean sample weight (0 for failed samples).
pub(super) fn albedo(m: &Material, wo: Vec3, n: usize) -> Color {
    let mut s = Sampler::new(11, 0, 0);
    let mut acc = glam::DVec3::ZERO;
    for _ in 0..n {
        let (ul, u) = (s.next_1d(), s.next_2d());
        if let Some(bs) = m.sample(&[], Vec2::ZERO, wo, ul, u) {
            acc += bs.weight.as_dvec3();
        }
    }
    (acc / n as f64).as_vec3()
}

/// `∫ eval(wo, wi) dwi` over the upper hemisphere by Gauss–Legendre quadrature in (θ, φ).
pub(super) fn hemisphere_integral(m: &Material, wo: Vec3) -> f64 {
    let (x, w) = gauss_legendre(256);
    let (hp, tp) = (std::f64::consts::FRAC_PI_2, std::f64::consts::TAU);
    let mut acc = 0.0;
    for (xt, wt) in x.iter().zip(&w) {
        let t = (0.5 * xt + 0.5) * hp;
        for (xp, wp) in x.iter().zip(&w) {
            let p = (0.5 * xp + 0.5) * tp;
            let wi = Vec3::new((t.sin() * p.cos()) as f32, (t.sin() * p.sin()) as f32, t.cos() as f32);
            acc += m.eval(&[], Vec2::ZERO, wo, wi).x as f64 * t.sin() * wt * wp;
        }
    }
    acc * 0.25 * hp * tp
}

#[test]
fn white_furnace_albedo_bounds() {
    let wo = dir(35.0, 0.0);
    let n = 100_000;
    // white diffuse and white mirror: exactly 1
    let a = albedo(&Material::Diffuse { reflectance: Texture::Const(white(1.0)) }, wo, n);
    assert!((a - white(1.0)).abs().max_element() < 1e-6, "{a}");
    let a = albedo(&Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: white(1.0) }, wo, n);
    assert!((a - white(1.0)).abs().max_element() < 1e-6, "{a}");
    // white dielectric: reflected + transmitted energy is 1 (undo the radiance scaling)
    let d = Material::Dielectric { eta: 1.33, specular_reflectance: white(1.0), specular_transmittance: white(1.0) };
    let mut s = Sampler::new(5, 0, 0);
    let mut e = 0.0f64;
    for _ in 0..n {
        let bs = d.sample(&[], Vec2::ZERO, wo, s.next_1d(), s.next_2d()).unwrap();
        e += (bs.weight.x * bs.eta * bs.eta) as f64;
    }
    assert!((e / n as f64 - 1.0).abs() < 1e-5);
    // white rough conductor: single scattering loses energy (more at high roughness); the
    // mean weight equals the hemispherical integral of eval (checked by quadrature)
    let mut prev = 1.0f32;
    for &alpha in &[0.2f32, 0.5, 0.8] {
        let m = Material::RoughConductor {
            distribution: ggx(alpha).into(),
            eta: Color::ZERO,
            k: Color::ZERO,
            specular_reflectance: white(1.0),
        };
        let a = albedo(&m, wo, n).x;
        let q = hemisphere_integral(&m, wo);
        assert!(a <= 1.0 + 1e-3 && a < prev, "alpha {alpha}: {a}");
        assert!((a as f64 - q).abs() < 5e-3, "alpha {alpha}: MC {a} vs quadrature {q}");
        prev = a;
    }
    // white rough plastic: at most 1; close to 1 when nearly smooth (rougher interfaces lose
    // energy to masking in the tabulated transmittance, as in Mitsuba)
    for &alpha in &[0.05f32, 0.3] {
        for &theta in &[0.0f32, 60.0] {
            let m = rough_plastic(alpha, white(1.0));
            let a = albedo(&m, dir(theta, 0.0), n).x;
            assert!(a <= 1.01, "alpha {alpha} theta {theta}: {a}");
            // nearly smooth: the layered model conserves energy up to the quadrature of
            // Mitsuba's internal-reflectance table
            assert!(alpha > 0.1 || a > 0.95, "alpha {alpha} theta {theta}: {a}");
            if alpha > 0.1 {
                let q = hemisphere_integral(&m, dir(theta, 0.0));
                assert!((a as f64 - q).abs() < 5e-3, "alpha {alpha} theta {theta}: MC {a} vs quadrature {q}");
            }
        }
    }
}

#[test]
fn plastic_tables_approach_smooth_fresnel() {
    let eta = 1.5f32;
    let t = PlasticTables::compute(MicrofacetKind::Ggx, 1e-3, eta);
    for i in (4..64).step_by(6) {
        let mu = i as f32 / 63.0;
        let smooth = 1.0 - fresnel_dielectric(mu, eta).0;
        assert!((t.external_transmittance[i] - smooth).abs() < 2e-3, "mu {mu}: {} vs {smooth}", t.external_transmittance[i]);
    }
    // internal reflectance of a nearly smooth interface: Mitsuba's estimate, the mean over
    // 64 equally spaced μ ∈ [0,1] of 2 μ F(μ, 1/η) ...
    let mitsuba: f64 = (0..64)
        .map(|i| {
            let mu = (i as f32 / 63.0).max(1e-6);
            2.0 * (mu * fresnel_dielectric(mu, 1.0 / eta).0) as f64
        })
        .sum::<f64>()
        / 64.0;
    assert!((t.internal_reflectance as f64 - mitsuba).abs() < 2e-3, "{} vs {mitsuba}", t.internal_reflectance);
    // ... which is within 2% of the exact hemispherical value 1 - (1 - Fdr_ext)/η²,
    // Fdr_ext = 2 ∫ F(μ, η) μ dμ
    let (x, w) = gauss_legendre(200);
    let fdr_ext: f64 = x
        .iter()
        .zip(&w)
        .map(|(x, w)| {
            let mu = 0.5 * x + 0.5;
            w * 0.5 * 2.0 * fresnel_dielectric(mu as f32, eta).0 as f64 * mu
        })
        .sum();
    let exact = 1.0 - (1.0 - fdr_ext) / (eta * eta) as f64;
    assert!((t.internal_reflectance as f64 - exact).abs() < 0.02 * exact, "{} vs {exact}", t.internal_reflectance);
    // rougher interfaces transmit less at grazing angles, tables stay in [0,1]
    let r = plastic_tables(MicrofacetKind::Ggx, 0.4, eta);
    assert!(r.external_transmittance.iter().all(|&v| (0.0..=1.0).contains(&v)));
    assert!(r.internal_reflectance > 0.0 && r.internal_reflectance < 1.0);
    assert!(std::ptr::eq(r, plastic_tables(MicrofacetKind::Ggx, 0.4, eta)), "cached");
}

/// Tables computed ahead (scene preparation, in parallel) are published for the lazy lookup and
/// hold the same bits as computed on first use. Alphas used by no other test, so that the
/// process-wide cache cannot hold them yet.
#[test]
fn precomputed_plastic_tables_are_the_lazy_ones() {
    let (a, b) = (0.3173, 0.2119);
    let nested = |alpha: f32| Material::TwoSided {
        front: Box::new(rough_plastic(alpha, white(0.5))),
        back: Box::new(rough_plastic(alpha, white(0.5))),
    };
    let materials =
        [nested(a), Material::Mask { opacity: Texture::Const(white(0.5)), nested: Box::new(nested(b)) }, rough_plastic(a, white(0.2))];
    super::plastic::precompute_plastic_tables(&materials);
    for alpha in [a, b] {
        let published = plastic_tables(MicrofacetKind::Ggx, alpha, 1.49);
        let fresh = PlasticTables::compute(MicrofacetKind::Ggx, alpha, 1.49);
        assert_eq!(published.external_transmittance.map(f32::to_bits), fresh.external_transmittance.map(f32::to_bits));
        assert_eq!(published.internal_reflectance.to_bits(), fresh.internal_reflectance.to_bits());
    }
    // a second call finds them all and publishes nothing new: the same table stays in use
    let before = plastic_tables(MicrofacetKind::Ggx, a, 1.49) as *const PlasticTables;
    super::plastic::precompute_plastic_tables(&materials);
    assert!(std::ptr::eq(before, plastic_tables(MicrofacetKind::Ggx, a, 1.49)));
}

#[test]
fn validation_rejects_bad_parameters() {
    assert!(Material::Diffuse { reflectance: Texture::Const(white(0.5)) }.validate(0).is_ok());
    assert!(Material::Diffuse { reflectance: Texture::Const(Color::new(-0.1, 0.0, 0.0)) }.validate(0).is_err());
    assert!(Material::Diffuse { reflectance: Texture::bitmap(1, Vec2::ONE) }.validate(1).is_err());
    assert!(Material::Diffuse { reflectance: Texture::bitmap(0, Vec2::ONE) }.validate(1).is_ok());
    assert!(Material::Dielectric { eta: f32::NAN, specular_reflectance: white(1.0), specular_transmittance: white(1.0) }
        .validate(0)
        .is_err());
    assert!(rough_plastic(-0.1, white(0.5)).validate(0).is_err());
    let matched = Material::RoughPlastic {
        diffuse_reflectance: Texture::Const(white(0.5)),
        specular_reflectance: white(1.0),
        distribution: ggx(0.1),
        eta: 1.0,
        nonlinear: false,
    };
    assert!(matched.validate(0).is_err());
    let nested = Material::TwoSided {
        front: Box::new(rough_conductor(0.2)),
        back: Box::new(Material::Conductor { eta: white(f32::INFINITY), k: white(0.0), specular_reflectance: white(1.0) }),
    };
    assert!(nested.validate(0).is_err());
    assert!(nested.has_smooth_lobe());
}

#[test]
fn lambertian_albedo_is_what_eval_returns_and_only_for_lambertian_sides() {
    let d = |c: f32| Material::Diffuse { reflectance: Texture::Const(white(c)) };
    let two = Material::TwoSided { front: Box::new(d(0.5)), back: Box::new(d(0.7)) };
    let glossy_back = Material::TwoSided { front: Box::new(d(0.5)), back: Box::new(rough_conductor(0.3)) };
    for (wo, wi) in [(dir(10.0, 0.0), dir(40.0, 120.0)), (dir(170.0, 30.0), dir(120.0, 200.0)), (dir(60.0, 0.0), dir(150.0, 0.0))] {
        for m in [d(0.6), two.clone()] {
            let rho = m.lambertian_albedo(&[], Vec2::ZERO, wo).expect("lambertian");
            let f = m.eval(&[], Vec2::ZERO, wo, wi);
            // same side: rho |cos| / pi; across the surface: nothing
            let expect = if wo.z * wi.z > 0.0 { rho * wi.z.abs() * FRAC_1_PI } else { Color::ZERO };
            assert!((f - expect).abs().max_element() < 1e-6, "{m:?} {wo:?} {wi:?}: {f:?} vs {expect:?}");
        }
    }
    assert_eq!(d(0.6).lambertian_albedo(&[], Vec2::ZERO, dir(120.0, 0.0)), Some(Color::ZERO), "one-sided, from behind");
    assert!(glossy_back.lambertian_albedo(&[], Vec2::ZERO, dir(10.0, 0.0)).is_some());
    assert!(glossy_back.lambertian_albedo(&[], Vec2::ZERO, dir(170.0, 0.0)).is_none());
    assert!(rough_conductor(0.3).lambertian_albedo(&[], Vec2::ZERO, dir(10.0, 0.0)).is_none());
}
