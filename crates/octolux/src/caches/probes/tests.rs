//! Tests of the probe grids: SH projection and convolution, storage, the brick layout, the
//! blend, validity and dilation, the beam estimate.

use super::sh::{self, ShOrder, MAX_COEFFS};
use super::*;
use crate::math::{gauss_legendre, Color};
use crate::sampling::{square_to_uniform_disk_concentric, square_to_uniform_sphere, Sampler};
use std::f32::consts::PI;

/// Project `l(ω)` onto the SH by Gauss–Legendre in `cos θ` (16 nodes) times 32 uniform φ:
/// exact for the polynomials of degree ≤ 3 the tests use.
fn project(l: impl Fn(Vec3) -> Vec3) -> [Vec3; MAX_COEFFS] {
    let (mu, w) = gauss_legendre(16);
    let nphi = 32;
    let mut c = [Vec3::ZERO; MAX_COEFFS];
    for (&m, &wm) in mu.iter().zip(&w) {
        let s = (1.0 - m * m).max(0.0).sqrt();
        for k in 0..nphi {
            let phi = 2.0 * std::f64::consts::PI * (k as f64 + 0.5) / nphi as f64;
            let d = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, m as f32);
            let dw = (wm * 2.0 * std::f64::consts::PI / nphi as f64) as f32;
            let y = sh::basis(d);
            let v = l(d);
            for i in 0..MAX_COEFFS {
                c[i] += v * (y[i] * dw);
            }
        }
    }
    c
}

fn normals(n: usize) -> Vec<Vec3> {
    (0..n).map(|i| square_to_uniform_sphere(Sampler::new(3, i as u64, 0).next_2d())).collect()
}

/// A constant radiance `a` gives `E = π a` for every normal; a linear one `a + b ω·d` gives
/// `π a + (2π/3) b (d·n)` (the integral over the hemisphere), at order 1 and 2 alike.
#[test]
fn sh_projection_and_convolution_are_exact_for_constant_and_linear_fields() {
    let a = Vec3::new(0.7, 1.3, 0.2);
    let b = Vec3::new(0.5, -0.9, 0.15);
    let d = Vec3::new(0.3, -0.5, 0.8).normalize();
    let constant = project(|_| a);
    let linear = project(|w| a + b * w.dot(d));
    for order in [ShOrder::L1, ShOrder::L2] {
        for n in normals(64) {
            let e = sh::irradiance(&constant, order, n);
            assert!((e - a * PI).abs().max_element() < 1e-4, "{order:?} constant at {n}: {e} vs {}", a * PI);
            let want = a * PI + b * (2.0 * PI / 3.0 * d.dot(n));
            let e = sh::irradiance(&linear, order, n);
            assert!((e - want.max(Vec3::ZERO)).abs().max_element() < 1e-4, "{order:?} linear at {n}: {e} vs {want}");
        }
    }
    // the clamped cosine max(0, ω·z) (not band-limited): E(z) = 2π/3 exactly; order 1 misses
    // it by more than order 2 (Ramamoorthi & Hanrahan: order 2 is within a few percent)
    let lobe = project(|w| Vec3::splat(w.z.max(0.0)));
    let e1 = sh::irradiance(&lobe, ShOrder::L1, Vec3::Z).x;
    let e2 = sh::irradiance(&lobe, ShOrder::L2, Vec3::Z).x;
    let exact = 2.0 * PI / 3.0;
    assert!((e2 - exact).abs() < 0.05 * exact && (e1 - exact).abs() > (e2 - exact).abs(), "L1 {e1}, L2 {e2}, exact {exact}");
}

/// Storage: the decoded coefficients are within the quantisation steps (RGBE's 1/256 of the
/// largest channel, 1/127 of the bound for the ratios); black stays black.
#[test]
fn packing_round_trips_within_its_steps() {
    let c = project(|w| Vec3::new(1.0, 0.5, 0.25) * (1.2 + w.x * 0.7 - w.y * 0.3 + 0.4 * w.z * w.z));
    for order in [ShOrder::L1, ShOrder::L2] {
        let p = sh::pack(&c, order, true);
        let u = sh::unpack(&p, order);
        for i in 0..order.coefficients() {
            let step = if i == 0 { c[0].max_element() / 128.0 } else { c[0].max_element() * sh::RATIO_BOUND[sh::band(i)] / 127.0 };
            assert!((u[i] - c[i]).abs().max_element() <= step * 1.01, "{order:?} coefficient {i}: {} vs {}", u[i], c[i]);
        }
        assert!(u[order.coefficients()..].iter().all(|c| *c == Vec3::ZERO));
    }
    let black = sh::unpack(&sh::pack(&[Vec3::ZERO; MAX_COEFFS], ShOrder::L2, false), ShOrder::L2);
    assert!(black.iter().all(|c| *c == Vec3::ZERO));
}

fn unit_bounds() -> Bounds3 {
    Bounds3 { min: Vec3::ZERO, max: Vec3::ONE }
}

/// The bricks are refined where the geometry is and nowhere else, and every point finds the
/// brick whose cube holds it.
#[test]
fn layout_refines_near_geometry_and_finds_bricks() {
    let tri = [Vec3::new(0.05, 0.05, 0.05), Vec3::new(0.2, 0.05, 0.05), Vec3::new(0.05, 0.2, 0.05)];
    let s = ProbeSettings { base_level: 1, max_level: 3, ..ProbeSettings::default() };
    let l = BrickLayout::new(unit_bounds(), &[tri], &[], &s).unwrap();
    let fine: Vec<_> = l.bricks.iter().filter(|b| b.1 == 3).collect();
    assert!(!fine.is_empty() && fine.iter().all(|b| b.0.max_element() < 0.4), "{:?}", l.bricks);
    assert!(l.bricks.iter().any(|b| b.1 == 1), "coarse bricks away from the triangle");
    // the bricks tile the cube
    let vol: f32 = l.bricks.iter().map(|b| (l.size / (1u32 << b.1) as f32).powi(3)).sum();
    assert!((vol / l.size.powi(3) - 1.0).abs() < 1e-5, "{vol}");
    for i in 0..500 {
        let mut r = Sampler::new(5, i, 0);
        let p = l.origin + Vec3::new(r.next_1d(), r.next_1d(), r.next_1d()) * l.size;
        let b = l.brick_at(p);
        let (lo, level) = l.bricks[b];
        let e = l.size / (1u32 << level) as f32;
        assert!(p.cmpge(lo - 1e-6).all() && p.cmple(lo + e + 1e-6).all(), "{p} not in brick {b} {lo} {e}");
    }
    // bytes: the formula, and an exact small case (8 bricks of level 1 under a root node)
    assert_eq!(l.bytes(ShOrder::L1), l.probes() * 14 + 4 * l.nodes());
    assert_eq!(l.bytes(ShOrder::L2), l.probes() * 29 + 4 * l.nodes());
    let flat = BrickLayout::new(unit_bounds(), &[], &[], &ProbeSettings { base_level: 1, max_level: 1, ..s }).unwrap();
    assert_eq!((flat.bricks(), flat.nodes()), (8, 9));
    assert_eq!(flat.bytes(ShOrder::L1), 8 * 64 * 14 + 36);
    assert_eq!(flat.bytes(ShOrder::L2), 8 * 64 * 29 + 36);
}

fn grid_of(s: &ProbeSettings, l0: impl Fn(Vec3) -> f32, valid: impl Fn(Vec3) -> bool) -> ProbeGrid {
    let tri = [Vec3::new(0.05, 0.05, 0.05), Vec3::new(0.2, 0.05, 0.05), Vec3::new(0.05, 0.2, 0.05)];
    let l = BrickLayout::new(unit_bounds(), &[tri], &[], s).unwrap();
    let pos: Vec<Vec3> = (0..l.probes()).map(|i| l.probe_position(i / BRICK_PROBES, i % BRICK_PROBES)).collect();
    let values: Vec<_> = pos
        .iter()
        .map(|&p| {
            let mut c = [Vec3::ZERO; MAX_COEFFS];
            c[0] = Vec3::splat(l0(p));
            c
        })
        .collect();
    let valid: Vec<bool> = pos.iter().map(|&p| valid(p)).collect();
    let g = ProbeGrid::from_probes(l, s, &values, &valid).unwrap();
    assert_eq!(g.bytes(), g.layout().bytes(s.order));
    assert_eq!(g.stats().bytes, g.bytes());
    g
}

/// Trilinear interpolation reproduces a linear field exactly (up to RGBE's step), in bricks
/// of every level.
#[test]
fn trilinear_reproduces_a_linear_field() {
    let s = ProbeSettings { base_level: 1, max_level: 3, ..ProbeSettings::default() };
    let f = |p: Vec3| 1.0 + 2.0 * p.x - 0.5 * p.y + 0.75 * p.z;
    let g = grid_of(&s, f, |_| true);
    let k = PI * sh::basis(Vec3::Z)[0];
    for i in 0..500 {
        let mut r = Sampler::new(9, i, 0);
        let p = Vec3::new(r.next_1d(), r.next_1d(), r.next_1d());
        let e = g.irradiance(p, Vec3::Y).x / k;
        assert!((e - f(p)).abs() <= 0.006 * f(p), "{p}: {e} vs {}", f(p));
    }
}

/// An invalid probe is left out of the blend (its weight renormalised away); without the
/// leak reduction it is blended in.
#[test]
fn invalid_probes_are_dropped_from_the_blend() {
    let s = ProbeSettings { base_level: 1, max_level: 1, ..ProbeSettings::default() };
    let bad = |p: Vec3| (p - Vec3::splat(0.5 / 3.0)).length() < 1e-3; // one interior probe per ... brick 0
    let g = grid_of(&s, |p| if bad(p) { 100.0 } else { 1.0 }, |p| !bad(p));
    assert_eq!(g.stats().invalid_probes, 1);
    let k = PI * sh::basis(Vec3::Z)[0];
    let near = Vec3::splat(0.5 / 3.0) + Vec3::new(0.01, -0.02, 0.015);
    let e = g.irradiance(near, Vec3::X).x / k;
    assert!((e - 1.0).abs() < 0.01, "dropped: {e}");
    let g = grid_of(&ProbeSettings { leak_reduction: false, ..s }, |p| if bad(p) { 100.0 } else { 1.0 }, |p| !bad(p));
    assert!(g.irradiance(near, Vec3::X).x / k > 10.0);
}

/// Photons of an isotropic radiance field: straight flights through a disc around `x` with
/// uniform directions. Radiance `N Φ / (π R² 4π)`.
fn isotropic_flights(x: Vec3, n: usize, big_r: f32, phi: f32) -> (Vec<crate::photon::Photon>, Vec<f32>) {
    let mut ph = Vec::with_capacity(n);
    for i in 0..n {
        let mut s = Sampler::new(11, i as u64, 0);
        let wi = square_to_uniform_sphere(s.next_2d());
        let f = crate::math::Frame::from_normal(wi);
        let d = square_to_uniform_disk_concentric(s.next_2d()) * big_r;
        let c = x + f.to_world(Vec3::new(d.x, d.y, 0.0));
        ph.push(crate::photon::Photon { p: c - wi * 2.0, wi, power: Color::splat(phi), ng: wi });
    }
    (ph, vec![4.0; n])
}

/// The beam estimate of an isotropic field gives `π L` for every normal (the field's
/// irradiance), and a build marks, dilates and counts the invalid probes.
#[test]
fn beam_estimate_of_an_isotropic_field_and_a_build_with_invalid_probes() {
    let x = Vec3::splat(0.5);
    let (n, big_r, phi) = (40_000, 0.6, 1e-3);
    let (ph, len) = isotropic_flights(x, n, big_r, phi);
    let radiance = n as f32 * phi / (PI * big_r * big_r * 4.0 * PI);
    let fl = Flights::new(&ph, &len, Vec3::ZERO, 1.0, 0.1);
    let (c, used) = fl.estimate(x, 0.15, ShOrder::L2);
    assert!(used > 1000, "{used}");
    for nrm in normals(16) {
        let e = sh::irradiance(&c, ShOrder::L2, nrm).x;
        assert!((e / (PI * radiance) - 1.0).abs() < 0.1, "{nrm}: {e} vs {}", PI * radiance);
    }
    // a grid over the field: probes with x < 0.3 are "inside geometry"
    let s = ProbeSettings { base_level: 1, max_level: 1, radius_scale: 1.5, ..ProbeSettings::default() };
    let layout = BrickLayout::new(unit_bounds(), &[], &[], &s).unwrap();
    let g = ProbeGrid::build(layout, ProbeInputs { photons: &ph, flight_lengths: &len }, &s, &|p: Vec3| if p.x < 0.3 { 0.6 } else { 0.0 })
        .unwrap();
    let st = g.stats().clone();
    assert_eq!(st.invalid_probes, 2 * 16 * 4, "{st:?}"); // x = 0 and 1/6 (2 × 16 probes) in the 4 left bricks
    assert!(st.dilated_probes > 0 && st.dilated_probes <= st.invalid_probes, "{st:?}");
    let (probe, valid) = g.probe(BRICK); // brick 0, x = 0, y = 1/6: invalid, dilated from x = 1/3
    assert!(!valid && probe[0].x > 0.0, "{probe:?}");
    let e = g.irradiance(x, Vec3::Y).x;
    assert!((e / (PI * radiance) - 1.0).abs() < 0.15, "grid at the centre: {e} vs {}", PI * radiance);
}

#[test]
fn bad_settings_are_refused() {
    let l = |s: ProbeSettings| BrickLayout::new(unit_bounds(), &[], &[], &s).map(|_| ());
    assert!(l(ProbeSettings { base_level: 3, max_level: 2, ..ProbeSettings::default() }).is_err());
    assert!(l(ProbeSettings { root_scale: 0.5, ..ProbeSettings::default() }).is_err());
    assert!(l(ProbeSettings { radius_scale: f32::NAN, ..ProbeSettings::default() }).is_err());
    assert!(l(ProbeSettings { max_level: 20, ..ProbeSettings::default() }).is_err());
    let empty = Bounds3 { min: Vec3::ONE, max: Vec3::ZERO };
    assert!(BrickLayout::new(empty, &[], &[], &ProbeSettings::default()).is_err());
}
