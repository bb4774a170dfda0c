//! Tests of next-event light selection ([`LightSelection`], the light tree of [`super::tree`]):
//! the selection probabilities sum to one, a sampled light's probability is `select_pmf_at`'s
//! bit for bit, sampled lights follow the pmf (chi²), no light that can light a point gets
//! probability zero there, and next-event estimation with the tree is unbiased (z-tests
//! against analytic irradiance) and sees the small lights that selection by power starves.

use super::*;
use crate::sampling::{square_to_uniform_sphere, Sampler};
use crate::scene::desc::TriMesh;
use crate::testing::chi2_sf;
use glam::DVec3;

fn emitter(geometry: Geometry, radiance: Color) -> ShapeDesc {
    ShapeDesc { name: "light".into(), geometry, material: 0, emission: Some(radiance), flip_normals: false }
}

/// A one-sided quad light: centre `c`, half edges `u` and `v`, emitting towards `u × v`.
fn quad(c: Vec3, u: Vec3, v: Vec3, radiance: Color) -> ShapeDesc {
    let positions = vec![c - u - v, c + u - v, c + u + v, c - u + v];
    emitter(Geometry::Mesh(TriMesh { positions, indices: vec![[0, 1, 2], [0, 2, 3]], ..Default::default() }), radiance)
}

fn sphere(center: Vec3, radius: f32, radiance: Color) -> ShapeDesc {
    emitter(Geometry::Sphere { center, radius }, radiance)
}

const BIG_CENTRE: Vec3 = Vec3::new(0.0, 6.0, 0.0);
const BIG_RADIUS: f32 = 1.0;
const SMALL_RADIUS: f32 = 0.05;
const WALL_Z: f32 = -2.0;

fn small_centre(i: usize) -> Vec3 {
    Vec3::new(-1.2 + 0.8 * i as f32, 1.0, WALL_Z + 0.3)
}

/// The room: a large bright sphere overhead with 200x the power of each of four small
/// spheres hung in front of a wall (`z = WALL_Z`), plus quads facing several ways, a point
/// light and a spot; `infinite` adds a directional light and a constant environment.
fn many_lights(infinite: bool) -> LightSet {
    let big = Color::new(20.0, 19.0, 17.0);
    // equal power: L r² is the same up to the factor 200
    let small = big * (BIG_RADIUS * BIG_RADIUS / (SMALL_RADIUS * SMALL_RADIUS) / 200.0);
    let mut shapes = vec![sphere(BIG_CENTRE, BIG_RADIUS, big)];
    shapes.extend((0..4).map(|i| sphere(small_centre(i), SMALL_RADIUS, small * (0.5 + 0.25 * i as f32))));
    // a ceiling panel facing down, one facing up (away from the floor), a wall panel facing +x
    shapes.push(quad(Vec3::new(2.0, 3.0, 0.5), Vec3::new(0.4, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.3), Color::splat(5.0)));
    shapes.push(quad(Vec3::new(-2.0, 3.0, 0.5), Vec3::new(0.0, 0.0, 0.3), Vec3::new(0.4, 0.0, 0.0), Color::splat(5.0)));
    shapes.push(quad(Vec3::new(-3.0, 1.5, 0.0), Vec3::new(0.0, 0.3, 0.0), Vec3::new(0.0, 0.0, 0.3), Color::new(1.0, 3.0, 2.0)));
    let mut lights = vec![
        Light::Point { position: Vec3::new(1.5, 2.0, 1.0), intensity: Color::splat(2.0) },
        Light::Spot {
            position: Vec3::new(0.0, 2.5, 1.5),
            frame: Frame::from_normal(Vec3::new(0.0, -1.0, -0.3).normalize()),
            intensity: Color::splat(30.0),
            cos_cutoff: 25f32.to_radians().cos(),
            cos_falloff_start: 15f32.to_radians().cos(),
        },
    ];
    if infinite {
        lights.push(Light::Directional { direction: Vec3::new(0.3, -1.0, 0.2).normalize(), irradiance: Color::splat(0.5) });
        lights.push(Light::Constant { radiance: Color::new(0.05, 0.07, 0.1) });
    }
    let mut bounds = Bounds3::EMPTY;
    bounds.extend(Vec3::new(-4.0, 0.0, WALL_Z));
    bounds.extend(Vec3::new(4.0, 7.0, 3.0));
    LightSet::new(&lights, &shapes, bounds)
}

/// A random shading point in the room and a random unit normal.
fn random_point(s: &mut Sampler) -> (Vec3, Vec3) {
    let p = Vec3::new(-3.5 + 7.0 * s.next_1d(), 2.8 * s.next_1d(), WALL_Z + 4.5 * s.next_1d());
    (p, square_to_uniform_sphere(s.next_2d()))
}

#[test]
fn selection_pmf_sums_to_one_and_is_the_sampled_probability() {
    for infinite in [false, true] {
        let set = many_lights(infinite);
        let tree = set.tree().expect("positioned lights");
        let n_lights = set.lights.len() as u32;
        let mut s = Sampler::new(1, infinite as u64, 0);
        for _ in 0..300 {
            let (p, n) = random_point(&mut s);
            for sel in [LightSelection::Tree, LightSelection::Power] {
                let sum: f64 = (0..n_lights).map(|l| set.select_pmf_at(sel, l, p, n) as f64).sum();
                assert!((sum - 1.0).abs() < 1e-5, "{sel:?} at {p}, n {n}: pmf sums to {sum}");
            }
            let tree_sum: f64 = (0..n_lights).map(|l| tree.pmf(l, p, n) as f64).sum();
            assert!((tree_sum - 1.0).abs() < 1e-5, "tree pmf sums to {tree_sum}");
            for _ in 0..50 {
                let (l, pm) = tree.sample(p, n, s.next_1d()).expect("the big sphere lights every point");
                assert_eq!(pm.to_bits(), tree.pmf(l, p, n).to_bits(), "light {l} at {p}");
                // the set's sample carries select_pmf_at exactly (delta lights: pdf = selection)
                let u = s.next_1d();
                for sel in [LightSelection::Tree, LightSelection::Power] {
                    if let Some(ls) = set.sample_li(sel, p, n, u, Vec2::splat(0.5)).filter(|ls| ls.delta) {
                        let hit = (0..n_lights).filter(|&l| set.select_pmf_at(sel, l, p, n).to_bits() == ls.pdf.to_bits());
                        assert!(hit.count() >= 1, "{sel:?}: delta sample pdf {} is no light's selection probability", ls.pdf);
                    }
                }
            }
        }
        // infinite lights: a share n / (n + 1) under the tree, alike everywhere
        let p_inf: f32 = set
            .lights
            .iter()
            .enumerate()
            .filter(|(_, l)| matches!(l, Light::Directional { .. } | Light::Constant { .. }))
            .map(|(l, _)| set.select_pmf_at(LightSelection::Tree, l as u32, Vec3::ONE, Vec3::Y))
            .sum();
        let want = if infinite { 2.0 / 3.0 } else { 0.0 };
        assert!((p_inf - want).abs() < 1e-6, "infinite share {p_inf}");
    }
}

#[test]
fn sampled_lights_follow_the_pmf_chi2() {
    let set = many_lights(true);
    let n_lights = set.lights.len();
    let points = [
        (small_centre(1) + Vec3::new(0.1, -0.2, -0.29), Vec3::Z),
        (Vec3::new(0.5, 0.0, 0.0), Vec3::Y),
        (Vec3::new(-2.9, 1.4, 0.1), Vec3::new(-1.0, 0.2, 0.0).normalize()),
    ];
    for (k, (p, n)) in points.into_iter().enumerate() {
        for sel in [LightSelection::Tree, LightSelection::Power] {
            let draws = 200_000;
            let mut counts = vec![0usize; n_lights + 1];
            let mut s = Sampler::new(7, k as u64, sel as u64);
            for _ in 0..draws {
                match set.pick_at(sel, p, n, s.next_1d()) {
                    Some((l, pm)) => {
                        assert_eq!(pm.to_bits(), set.select_pmf_at(sel, l as u32, p, n).to_bits());
                        counts[l] += 1;
                    }
                    None => counts[n_lights] += 1,
                }
            }
            let mut expect: Vec<f64> = (0..n_lights).map(|l| set.select_pmf_at(sel, l as u32, p, n) as f64 * draws as f64).collect();
            let total: f64 = expect.iter().sum();
            expect.push(draws as f64 - total);
            // pool the cells expected below 5; a draw where none is expected fails outright
            let (mut stat, mut cells, mut pool_e, mut pool_o) = (0.0, 0usize, 0.0, 0usize);
            for (e, &o) in expect.iter().zip(&counts) {
                assert!(*e > 0.0 || o == 0, "{sel:?} at point {k}: {o} draws of a light of probability 0");
                if *e < 5.0 {
                    (pool_e, pool_o) = (pool_e + e, pool_o + o);
                } else {
                    stat += (o as f64 - e).powi(2) / e;
                    cells += 1;
                }
            }
            if pool_e > 0.0 {
                stat += (pool_o as f64 - pool_e).powi(2) / pool_e;
                cells += 1;
            }
            let p_value = chi2_sf(stat, cells.saturating_sub(1).max(1));
            let e: Vec<u64> = expect.iter().map(|e| e.round() as u64).collect();
            println!("{sel:?} at point {k}: chi² {stat:.1} over {cells} cells, p {p_value:.3}; counts {counts:?}, expected {e:?}");
            assert!(p_value > crate::testing::sidak(0.01, 6), "{sel:?} at point {k}: p {p_value}");
            // The choice is monotone in `u` (each light's `u` form one interval): a sweep of
            // evenly spaced `u` meets each light as often as its probability says, to within
            // the interval's two ends and f32 rounding.
            let sweep = 1usize << 20;
            let mut hits = vec![0usize; n_lights];
            for j in 0..sweep {
                if let Some((l, _)) = set.pick_at(sel, p, n, (j as f32 + 0.5) / sweep as f32) {
                    hits[l] += 1;
                }
            }
            for (l, &h) in hits.iter().enumerate() {
                let want = set.select_pmf_at(sel, l as u32, p, n) as f64 * sweep as f64;
                assert!(
                    (h as f64 - want).abs() <= 2.0 + 1e-5 * want,
                    "{sel:?} at point {k}: light {l} met {h} times in the sweep, pmf says {want:.1}"
                );
            }
        }
    }
}

/// Whether light `l` sends light to `p` through some of its points: a sphere always (from
/// outside), a quad when `p` lies in front of it, a point light always, a spot inside its
/// cutoff. The shading normal does not matter (a BSDF may transmit).
fn can_light(set: &LightSet, l: usize, p: Vec3) -> bool {
    match &set.lights[l] {
        Light::Area { .. } => match set.area[l].as_ref().unwrap() {
            AreaGeometry::Sphere { center, radius, .. } => (p - *center).length() > *radius,
            AreaGeometry::Triangles { tris, normals, .. } => tris.iter().zip(normals).any(|(t, n)| n.dot(p - t[0]) > 1e-4),
        },
        Light::Point { position, .. } => p != *position,
        Light::Spot { position, frame, cos_cutoff, .. } => frame.n.dot((p - *position).normalize()) > *cos_cutoff,
        _ => true,
    }
}

#[test]
fn no_light_that_can_light_a_point_gets_probability_zero() {
    let set = many_lights(false);
    let mut s = Sampler::new(3, 0, 0);
    let mut zero = 0;
    for _ in 0..5000 {
        let (p, n) = random_point(&mut s);
        for l in 0..set.lights.len() {
            let pmf = set.select_pmf_at(LightSelection::Tree, l as u32, p, n);
            if can_light(&set, l, p) {
                assert!(pmf > 0.0, "light {l} ({:?}) can light {p} (normal {n}) but has probability 0", set.lights[l]);
            } else {
                zero += (pmf == 0.0) as usize;
            }
        }
    }
    // the bound is not empty: lights facing away get nothing
    assert!(zero > 1000, "{zero} zero-probability lights where they cannot light the point");
}

/// Irradiance at `p` on a surface with normal `n` from the light set, analytically, for lights
/// that lie wholly on one side of the tangent plane (module docs of each light kind):
/// spheres `π L (r/d)² cos θ`, quads by Lambert's polygon formula, point and spot `I cos θ /
/// d²`, directional `E cos θ`, constant `π L`.
fn analytic_irradiance(set: &LightSet, p: Vec3, n: Vec3) -> DVec3 {
    let mut e = DVec3::ZERO;
    for (l, light) in set.lights.iter().enumerate() {
        let add = match light {
            Light::Area { radiance, .. } => match set.area[l].as_ref().unwrap() {
                AreaGeometry::Sphere { center, radius, .. } => {
                    let d = *center - p;
                    let cos = n.dot(d.normalize()) as f64;
                    assert!(cos * d.length() as f64 > *radius as f64 || cos < 0.0, "sphere {l} straddles the plane");
                    radiance.as_dvec3() * (std::f64::consts::PI * (*radius as f64 / d.length() as f64).powi(2) * cos.max(0.0))
                }
                AreaGeometry::Triangles { tris, normals, .. } => {
                    if normals[0].dot(p - tris[0][0]) <= 0.0 {
                        DVec3::ZERO
                    } else {
                        // the quad's corners in order: the first triangle and the third vertex of the second
                        let corners = [tris[0][0], tris[0][1], tris[0][2], tris[1][2]];
                        let v: Vec<DVec3> = corners.iter().map(|c| (*c - p).as_dvec3().normalize()).collect();
                        assert!(v.iter().all(|v| v.dot(n.as_dvec3()) > 0.0) || v.iter().all(|v| v.dot(n.as_dvec3()) < 0.0));
                        let sum: f64 = (0..4)
                            .map(|i| {
                                let (a, b) = (v[i], v[(i + 1) % 4]);
                                a.dot(b).clamp(-1.0, 1.0).acos() * a.cross(b).normalize().dot(n.as_dvec3())
                            })
                            .sum();
                        radiance.as_dvec3() * (0.5 * sum.abs()) * (v[0].dot(n.as_dvec3()) > 0.0) as u8 as f64
                    }
                }
            },
            Light::Point { position, intensity } => {
                let d = *position - p;
                intensity.as_dvec3() * (n.dot(d.normalize()).max(0.0) / d.length_squared()) as f64
            }
            Light::Spot { position, frame, intensity, cos_cutoff, cos_falloff_start } => {
                let d = *position - p;
                let fall = spot_falloff(frame.n.dot(-d.normalize()), *cos_cutoff, *cos_falloff_start);
                intensity.as_dvec3() * (fall * n.dot(d.normalize()).max(0.0) / d.length_squared()) as f64
            }
            Light::Directional { direction, irradiance } => irradiance.as_dvec3() * (-n.dot(*direction)).max(0.0) as f64,
            Light::Constant { radiance } => radiance.as_dvec3() * std::f64::consts::PI,
            Light::Envmap { .. } | Light::Sunsky(_) => unreachable!("not in the test scene"),
        };
        e += add;
    }
    e
}

/// Mean and standard error of the next-event estimate of the irradiance (mean over RGB) at
/// `(p, n)` with `draws` samples, without occlusion.
fn nee_irradiance(set: &LightSet, sel: LightSelection, p: Vec3, n: Vec3, draws: usize, seed: u64) -> (f64, f64) {
    let mut s = Sampler::new(seed, 0, sel as u64);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for _ in 0..draws {
        let (u_sel, u) = (s.next_1d(), s.next_2d());
        let x = set.sample_li(sel, p, n, u_sel, u).map_or(0.0, |ls| {
            let cos = n.dot(ls.wi).max(0.0) as f64;
            (ls.li.x + ls.li.y + ls.li.z) as f64 / 3.0 * cos / ls.pdf as f64
        });
        sum += x;
        sum2 += x * x;
    }
    let mean = sum / draws as f64;
    let var = (sum2 / draws as f64 - mean * mean).max(0.0);
    (mean, (var / draws as f64).sqrt())
}

#[test]
fn next_event_estimation_with_the_tree_is_unbiased_and_sees_small_lights() {
    // receivers whose tangent planes no light straddles: the floor, the wall behind the small
    // spheres
    let points = [
        (Vec3::new(0.3, 0.0, 0.2), Vec3::Y, "floor"),
        (Vec3::new(-1.0, 0.0, -1.0), Vec3::Y, "floor near the wall"),
        (Vec3::new(-0.4, 1.1, WALL_Z), Vec3::Z, "wall behind the small spheres"),
        (Vec3::new(0.1, 0.8, WALL_Z), Vec3::Z, "wall between the small spheres"),
    ];
    let draws = 300_000;
    for infinite in [false, true] {
        let set = many_lights(infinite);
        for (k, (p, n, what)) in points.into_iter().enumerate() {
            let want = analytic_irradiance(&set, p, n);
            let want = (want.x + want.y + want.z) / 3.0;
            let mut var = [0.0; 2];
            for (i, sel) in [LightSelection::Tree, LightSelection::Power].into_iter().enumerate() {
                let (mean, se) = nee_irradiance(&set, sel, p, n, draws, 10 + k as u64 + 100 * infinite as u64);
                let z = (mean - want) / se;
                var[i] = se * se * draws as f64;
                println!(
                    "{what} (infinite lights: {infinite}): {sel:?} E {mean:.5} ± {se:.5} vs analytic {want:.5} (z {z:+.2}), \
                     variance per sample {:.4}",
                    var[i]
                );
                assert!(z.abs() < 4.5, "{what}: {sel:?} estimate {mean} ± {se} vs {want}");
            }
            if what.starts_with("wall") && !infinite {
                // the case: selection by power starves the close small spheres
                assert!(var[0] * 4.0 < var[1], "{what}: tree variance {} not well below power's {}", var[0], var[1]);
            }
        }
    }
}

#[test]
fn the_tree_is_built_the_same_way_every_time_and_handles_degenerate_sets() {
    let a = many_lights(true);
    let b = many_lights(true);
    let (ta, tb) = (a.tree().unwrap(), b.tree().unwrap());
    assert_eq!(ta.node_count(), tb.node_count());
    assert_eq!(ta.node_count(), 2 * 10 - 1, "a binary tree over the 10 positioned lights");
    let mut s = Sampler::new(5, 0, 0);
    for _ in 0..1000 {
        let (p, n) = random_point(&mut s);
        let u = s.next_1d();
        assert_eq!(ta.sample(p, n, u).map(|(l, pm)| (l, pm.to_bits())), tb.sample(p, n, u).map(|(l, pm)| (l, pm.to_bits())));
    }
    // many point lights on one spot (every centroid equal): split by count, still sums to one
    let lights: Vec<Light> = (0..1000).map(|i| Light::Point { position: Vec3::ONE, intensity: Color::splat(1.0 + i as f32) }).collect();
    let set = LightSet::new(&lights, &[], Bounds3::EMPTY);
    let p = Vec3::new(0.0, 3.0, 0.0);
    let sum: f64 = (0..1000).map(|l| set.select_pmf_at(LightSelection::Tree, l, p, Vec3::ZERO) as f64).sum();
    assert!((sum - 1.0).abs() < 1e-4, "{sum}");
    // a point light at the shading point itself: no light, no NaN
    assert_eq!(set.select_pmf_at(LightSelection::Tree, 0, Vec3::ONE, Vec3::ZERO), 0.0);
    assert!(set.sample_li(LightSelection::Tree, Vec3::ONE, Vec3::ZERO, 0.3, Vec2::splat(0.5)).is_none());
    // lights in a line with exponentially growing gaps: a deep tree, ways still fit the bits
    let lights: Vec<Light> =
        (0..200).map(|i| Light::Point { position: Vec3::new(1.1f32.powi(i), 0.0, 0.0), intensity: Color::ONE }).collect();
    let set = LightSet::new(&lights, &[], Bounds3::EMPTY);
    let sum: f64 = (0..200).map(|l| set.select_pmf_at(LightSelection::Tree, l, Vec3::new(0.0, 1.0, 0.0), Vec3::Y) as f64).sum();
    assert!((sum - 1.0).abs() < 1e-4, "{sum}");
}
