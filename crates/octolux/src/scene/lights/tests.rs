//! Tests of light sampling: chi² tests of every sampling routine against its pdf, emitted power
//! by formula and by Monte Carlo, delta and environment lights.

use super::*;
use crate::sampling::{square_to_cosine_hemisphere_pdf, Sampler};
use crate::scene::desc::TriMesh;
use crate::testing::{chi2_2d, chi2_sphere, direction_to_zphi, zphi_to_direction, Chi2Config};

/// Number of chi-square tests in this module (Šidák family size).
const CHI2_TESTS: usize = 6;

fn shape(geometry: Geometry, emission: Option<Color>, flip_normals: bool) -> ShapeDesc {
    ShapeDesc { name: "s".into(), geometry, material: 0, emission, flip_normals }
}

/// The rectangle [0,2]×[0,1] at height z, split into three triangles of areas 1, 1/4, 3/4
/// whose winding normal is +z.
fn split_rectangle(z: f32) -> TriMesh {
    TriMesh {
        positions: vec![
            Vec3::new(0.0, 0.0, z),
            Vec3::new(2.0, 0.0, z),
            Vec3::new(2.0, 1.0, z),
            Vec3::new(0.0, 1.0, z),
            Vec3::new(1.5, 1.0, z),
        ],
        indices: vec![[0, 1, 4], [1, 2, 4], [0, 4, 3]],
        ..Default::default()
    }
}

fn bounds_of(a: Vec3, b: Vec3) -> Bounds3 {
    let mut bb = Bounds3::EMPTY;
    bb.extend(a);
    bb.extend(b);
    bb
}

fn cfg() -> Chi2Config {
    Chi2Config { samples: 200_000, tests: CHI2_TESTS, bins_x: 32, bins_y: 32, ..Default::default() }
}

#[test]
fn mesh_light_sampling_matches_pdf() {
    // flipped: the light at z = 1 faces down, towards the shading point at z = 0; a point
    // light takes part of the selection probability.
    let radiance = Color::new(2.0, 3.0, 4.0);
    let shapes = [shape(Geometry::Mesh(split_rectangle(1.0)), Some(radiance), true)];
    let point = Light::Point { position: Vec3::new(0.0, 0.0, 3.0), intensity: Color::splat(1.0) };
    let set = LightSet::new(&[point], &shapes, bounds_of(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0)));
    assert_eq!(set.lights.len(), 2);
    let l = set.shape_light(0).unwrap();
    assert_eq!(l, 1);
    let area_power = std::f32::consts::PI * 2.0 * 3.0; // mean radiance 3, area 2
    let point_power = 4.0 * std::f32::consts::PI;
    let by_power = set.select_pmf(l);
    assert!((by_power - area_power / (area_power + point_power)).abs() < 1e-5, "selection by power: {by_power}");
    assert_eq!(set.select_pmf_at(LightSelection::Power, l, Vec3::ZERO, Vec3::Z), by_power);
    let p = Vec3::new(0.3, 0.8, 0.0);
    let n = Vec3::new(0.2, 0.1, 1.0).normalize();
    let ng = -Vec3::Z;
    for sel in [LightSelection::Tree, LightSelection::Power] {
        let psel = set.select_pmf_at(sel, l, p, n);
        assert!(psel > 0.0 && psel < 1.0, "{sel:?}: {psel}");
        let mut bad = None;
        let r = chi2_2d(
            &cfg(),
            Vec2::ZERO,
            Vec2::new(2.0, 1.0),
            |s| {
                let (us, u) = (s.next_1d(), s.next_2d());
                let ls = set.sample_li(sel, p, n, us, u)?;
                if ls.delta {
                    return None;
                }
                let q = p + ls.wi * ls.dist;
                let pdf = set.pdf_li_area(sel, l, p, n, q, ng);
                if (pdf - ls.pdf).abs() > 1e-3 * pdf || (q.z - 1.0).abs() > 1e-4 || ls.li != radiance {
                    bad = Some(format!("sample pdf {} vs pdf_li_area {pdf}, q {q}, li {}", ls.pdf, ls.li));
                }
                Some(Vec2::new(q.x, q.y))
            },
            |xy| {
                // density w.r.t. area on the plane: solid-angle pdf × cos / dist²
                let q = Vec3::new(xy.x, xy.y, 1.0);
                let d = q - p;
                let cos = d.z / d.length();
                (set.pdf_li_area(sel, l, p, n, q, ng) * cos / d.length_squared()) as f64
            },
        );
        assert!(bad.is_none(), "{sel:?}: {bad:?}");
        assert!(r.passed, "{sel:?}: {r:?}");
        assert!((r.pdf_integral - psel as f64).abs() < 1e-3, "{sel:?}: {} vs {psel}", r.pdf_integral);
        // behind the light: nothing (the light's back faces the point)
        let behind = Vec3::new(1.0, 0.5, 2.0);
        let mut s = Sampler::new(1, 2, 3);
        for _ in 0..1000 {
            if let Some(ls) = set.sample_li(sel, behind, Vec3::Z, s.next_1d(), s.next_2d()) {
                assert!(ls.delta, "only the point light is visible from behind");
            }
        }
        assert_eq!(set.pdf_li_area(sel, l, behind, Vec3::Z, Vec3::new(1.0, 0.5, 1.0), ng), 0.0);
    }
    assert_eq!(set.area_le(l, ng, Vec3::Z), Color::ZERO);
    assert_eq!(set.area_le(l, ng, -Vec3::Z), radiance);
    assert_eq!(set.area_le(0, ng, -Vec3::Z), Color::ZERO, "light 0 is the point light");
}

/// Nearest intersection of a ray with a sphere (`None` when missed).
fn hit_sphere(o: Vec3, d: Vec3, c: Vec3, r: f32) -> Option<Vec3> {
    let oc = (o - c).as_dvec3();
    let d64 = d.as_dvec3();
    let b = oc.dot(d64);
    let cc = oc.length_squared() - (r as f64) * (r as f64);
    let disc = b * b - cc;
    if disc < 0.0 {
        return None;
    }
    let t = if -b - disc.sqrt() > 0.0 { -b - disc.sqrt() } else { -b + disc.sqrt() };
    (t > 0.0).then(|| (oc + d64 * t).as_vec3() + c)
}

#[test]
fn sphere_light_sampling_matches_pdf_outside_and_inside() {
    let (c, r) = (Vec3::new(0.5, -0.2, 2.0), 0.7);
    let radiance = Color::splat(1.5);
    // outside: uniform in the subtended cone
    let set = LightSet::new(&[], &[shape(Geometry::Sphere { center: c, radius: r }, Some(radiance), false)], bounds_of(c - r, c + r));
    let p = Vec3::new(0.1, 0.3, -0.5);
    let axis = (c - p).normalize();
    let frame = Frame::from_normal(axis);
    let cos_max = (1.0 - r * r / (c - p).length_squared()).sqrt();
    let mut bad = None;
    let out = chi2_2d(
        &cfg(),
        Vec2::new(cos_max, 0.0),
        Vec2::new(1.0, std::f32::consts::TAU),
        |s| {
            let ls = set.sample_li(LightSelection::Tree, p, Vec3::ZERO, s.next_1d(), s.next_2d())?;
            let q = p + ls.wi * ls.dist;
            let n = (q - c) / r;
            if ((q - c).length() - r).abs() > 1e-4 || n.dot(ls.wi) >= 0.0 {
                bad = Some(format!("sampled point {q} is not on the near side of the sphere"));
            }
            if (set.pdf_li_area(LightSelection::Tree, 0, p, Vec3::ZERO, q, n) - ls.pdf).abs() > 1e-3 * ls.pdf {
                bad = Some(format!("pdf {} vs {}", ls.pdf, set.pdf_li_area(LightSelection::Tree, 0, p, Vec3::ZERO, q, n)));
            }
            Some(direction_to_zphi(frame.to_local(ls.wi)))
        },
        |zp| {
            let d = frame.to_world(zphi_to_direction(zp));
            hit_sphere(p, d, c, r).map_or(0.0, |q| set.pdf_li_area(LightSelection::Tree, 0, p, Vec3::ZERO, q, (q - c) / r) as f64)
        },
    );
    assert!(bad.is_none(), "{bad:?}");
    assert!(out.passed, "{out:?}");
    assert!((out.pdf_integral - 1.0).abs() < 1e-3);

    // inside a flipped sphere (emitting inwards): by area over the whole sphere
    let set = LightSet::new(&[], &[shape(Geometry::Sphere { center: c, radius: r }, Some(radiance), true)], bounds_of(c - r, c + r));
    let p = c + Vec3::new(0.2, -0.3, 0.25);
    let inside = chi2_2d(
        &cfg(),
        Vec2::new(-1.0, 0.0),
        Vec2::new(1.0, std::f32::consts::TAU),
        |s| {
            let ls = set.sample_li(LightSelection::Tree, p, Vec3::ZERO, s.next_1d(), s.next_2d())?;
            let q = p + ls.wi * ls.dist;
            Some(direction_to_zphi((q - c).normalize()))
        },
        |zp| {
            // density w.r.t. (cos θ, φ) of the point on the sphere: pdf_ω cos / d² · r²
            let n = zphi_to_direction(zp);
            let q = c + n * r;
            let d = q - p;
            let cos = (-n).dot(-d.normalize());
            (set.pdf_li_area(LightSelection::Tree, 0, p, Vec3::ZERO, q, -n) * cos / d.length_squared() * r * r) as f64
        },
    );
    assert!(inside.passed, "{inside:?}");
    assert!((inside.pdf_integral - 1.0).abs() < 1e-3);

    // inside a sphere that emits outwards: its inner side is its back, nothing arrives
    let set = LightSet::new(&[], &[shape(Geometry::Sphere { center: c, radius: r }, Some(radiance), false)], bounds_of(c - r, c + r));
    let mut s = Sampler::new(4, 0, 0);
    assert!((0..1000).all(|_| set.sample_li(LightSelection::Tree, p, Vec3::ZERO, s.next_1d(), s.next_2d()).is_none()));
}

#[test]
fn area_emission_is_cosine_weighted_and_carries_the_total_power() {
    let radiance = Color::new(1.0, 2.0, 0.5);
    let c = Vec3::new(0.0, 1.0, 0.0);
    let set = LightSet::new(&[], &[shape(Geometry::Sphere { center: c, radius: 0.5 }, Some(radiance), false)], bounds_of(c - 0.5, c + 0.5));
    let want = radiance * std::f32::consts::PI * 4.0 * std::f32::consts::PI * 0.25;
    assert!((set.total_power() - want).abs().max_element() < 1e-4 * want.max_element());
    let r = chi2_sphere(
        &cfg(),
        |s| {
            let e = set.sample_emission(s.next_1d(), s.next_2d(), s.next_2d())?;
            assert!(((e.p - c).length() - 0.5).abs() < 1e-4 && (e.n - (e.p - c) / 0.5).length() < 1e-4);
            assert!((e.power - want).abs().max_element() < 1e-3 * want.max_element());
            Some(Frame::from_normal(e.n).to_local(e.dir))
        },
        |d| square_to_cosine_hemisphere_pdf(d) as f64,
    );
    assert!(r.passed, "{r:?}");
    // a flipped triangle mesh emits downwards
    let set = LightSet::new(&[], &[shape(Geometry::Mesh(split_rectangle(1.0)), Some(radiance), true)], bounds_of(Vec3::ZERO, Vec3::ONE));
    let mut s = Sampler::new(9, 0, 0);
    for _ in 0..1000 {
        let e = set.sample_emission(s.next_1d(), s.next_2d(), s.next_2d()).unwrap();
        assert!(e.dir.z < 0.0 && e.n == -Vec3::Z && (e.p.z - 1.0).abs() < 1e-6);
        assert!((e.power - radiance * std::f32::consts::PI * 2.0).abs().max_element() < 1e-4);
    }
}

#[test]
fn mean_emitted_power_equals_total_power() {
    let spot_frame = Frame::from_normal(Vec3::new(0.0, -1.0, 0.0));
    let lights = vec![
        Light::Point { position: Vec3::new(0.0, 2.0, 0.0), intensity: Color::new(1.0, 0.5, 0.2) },
        Light::Spot {
            position: Vec3::new(1.0, 2.0, 0.0),
            frame: spot_frame,
            intensity: Color::splat(5.0),
            cos_cutoff: 30f32.to_radians().cos(),
            cos_falloff_start: 20f32.to_radians().cos(),
        },
        Light::Directional { direction: Vec3::new(0.0, -1.0, 0.0), irradiance: Color::splat(0.3) },
        Light::Constant { radiance: Color::new(0.1, 0.2, 0.3) },
    ];
    let shapes = [
        shape(Geometry::Mesh(split_rectangle(1.5)), Some(Color::splat(2.0)), false),
        shape(Geometry::Sphere { center: Vec3::new(-1.0, 0.5, 0.0), radius: 0.25 }, Some(Color::new(3.0, 1.0, 1.0)), false),
        shape(Geometry::Mesh(split_rectangle(0.0)), None, false),
    ];
    let bounds = bounds_of(Vec3::new(-2.0, -1.0, -1.0), Vec3::new(2.0, 2.0, 2.0));
    let set = LightSet::new(&lights, &shapes, bounds);
    assert_eq!(set.lights.len(), 6);
    assert_eq!(set.shape_light(2), None);
    assert_eq!(set.shape_light(1), Some(5));
    let (centre, radius) = set.scene_sphere();
    let n = 400_000;
    let mut s = Sampler::new(21, 0, 0);
    let mut acc = glam::DVec3::ZERO;
    let mut per_light = [0usize; 6];
    for _ in 0..n {
        let e = set.sample_emission(s.next_1d(), s.next_2d(), s.next_2d()).unwrap();
        assert!((e.dir.length() - 1.0).abs() < 1e-4 && e.power.is_finite() && e.power.min_element() >= 0.0);
        per_light[e.light as usize] += 1;
        match &set.lights[e.light as usize] {
            Light::Spot { frame, cos_cutoff, .. } => assert!(frame.n.dot(e.dir) >= cos_cutoff - 1e-5),
            Light::Directional { direction, .. } => assert!((e.dir - *direction).length() < 1e-6),
            _ => {}
        }
        if matches!(set.lights[e.light as usize], Light::Directional { .. } | Light::Constant { .. }) {
            // starts outside the bounding sphere, aimed through it
            let oc = e.p - centre;
            assert!(oc.length() >= radius * 0.999);
            let closest = oc - e.dir * oc.dot(e.dir);
            assert!(closest.length() <= radius * 1.0001 && oc.dot(e.dir) < 0.0);
        }
        acc += e.power.as_dvec3();
    }
    let mean = (acc / n as f64).as_vec3();
    let total = set.total_power();
    assert!((mean - total).abs().max_element() < 0.01 * total.max_element(), "mean {mean} vs total {total}");
    for (l, &count) in per_light.iter().enumerate() {
        let expect = set.select_pmf(l as u32) as f64 * n as f64;
        assert!((count as f64 - expect).abs() < 5.0 * expect.sqrt() + 1.0, "light {l}: {count} vs {expect}");
    }
    // each light's power by its formula
    let pi = std::f32::consts::PI;
    let checks = [
        (0u32, Color::new(1.0, 0.5, 0.2) * 4.0 * pi),
        (2, Color::splat(0.3) * pi * radius * radius),
        (3, Color::new(0.1, 0.2, 0.3) * 4.0 * pi * pi * radius * radius),
        (4, Color::splat(2.0) * pi * 2.0),
        (5, Color::new(3.0, 1.0, 1.0) * pi * 4.0 * pi * 0.0625),
    ];
    for (l, want) in checks {
        assert!((set.light_power(l) - want).abs().max_element() < 1e-4 * want.max_element(), "light {l}: {} vs {want}", set.light_power(l));
    }
}

#[test]
fn spot_power_integrates_the_falloff() {
    for &(cutoff, beam) in &[(30.0f32, 20.0f32), (20.0, 15.0), (60.0, 60.0), (90.0, 10.0)] {
        let (cc, cb) = (cutoff.to_radians().cos(), beam.to_radians().cos());
        let l = Light::Spot {
            position: Vec3::ZERO,
            frame: Frame::from_normal(Vec3::Z),
            intensity: Color::ONE,
            cos_cutoff: cc,
            cos_falloff_start: cb,
        };
        assert!(l.validate().is_ok());
        // midpoint rule in θ of 2π ∫ I(θ) sin θ dθ
        let n = 200_000;
        let dt = std::f64::consts::PI / n as f64;
        let numeric: f64 = (0..n)
            .map(|i| {
                let t = (i as f64 + 0.5) * dt;
                spot_falloff(t.cos() as f32, cc, cb) as f64 * t.sin() * dt
            })
            .sum::<f64>()
            * std::f64::consts::TAU;
        let p = light_power(&l, None, None, 1.0).x as f64;
        assert!((p - numeric).abs() < 1e-4 * numeric, "cutoff {cutoff} beam {beam}: {p} vs {numeric}");
        // for narrow transitions the approximation 2π(1 - (cos c + cos b)/2) is close
        let approx = std::f64::consts::TAU * (1.0 - (cc + cb) as f64 / 2.0);
        assert!(cutoff - beam > 10.0 || (p - approx).abs() < 0.03 * p, "{p} vs {approx}");
    }
    // falloff: full inside the beam, linear in angle, zero beyond the cutoff
    let (cc, cb) = (30f32.to_radians().cos(), 20f32.to_radians().cos());
    assert_eq!(spot_falloff(1.0, cc, cb), 1.0);
    assert!((spot_falloff(25f32.to_radians().cos(), cc, cb) - 0.5).abs() < 1e-4);
    assert_eq!(spot_falloff(31f32.to_radians().cos(), cc, cb), 0.0);
}

#[test]
fn delta_and_environment_lights() {
    let p = Vec3::new(0.0, 0.0, 0.0);
    let set = LightSet::new(&[Light::Point { position: Vec3::new(0.0, 3.0, 4.0), intensity: Color::splat(10.0) }], &[], Bounds3::EMPTY);
    // a single light ignores the selection number
    let a = set.sample_li(LightSelection::Tree, p, Vec3::ZERO, 0.1, Vec2::new(0.3, 0.3)).unwrap();
    let b = set.sample_li(LightSelection::Tree, p, Vec3::ZERO, 0.95, Vec2::new(0.7, 0.1)).unwrap();
    assert!(a.delta && a.pdf == 1.0 && (a.dist - 5.0).abs() < 1e-6 && (a.li - Color::splat(10.0 / 25.0)).abs().max_element() < 1e-6);
    assert_eq!((a.wi, a.li), (b.wi, b.li));
    assert!((a.wi - Vec3::new(0.0, 0.6, 0.8)).length() < 1e-6);

    let frame = Frame::from_normal(Vec3::new(0.0, 0.0, -1.0));
    let spot =
        Light::Spot { position: Vec3::new(0.0, 0.0, 2.0), frame, intensity: Color::splat(4.0), cos_cutoff: 0.9, cos_falloff_start: 0.95 };
    let set = LightSet::new(&[spot], &[], Bounds3::EMPTY);
    let ls = set.sample_li(LightSelection::Tree, p, Vec3::ZERO, 0.5, Vec2::ZERO).unwrap();
    assert!((ls.li - Color::splat(1.0)).abs().max_element() < 1e-6, "on axis: I / d²");
    assert!(set.sample_li(LightSelection::Tree, Vec3::new(5.0, 0.0, 0.0), Vec3::ZERO, 0.5, Vec2::ZERO).is_none(), "outside the cone");

    let dir = Vec3::new(1.0, -1.0, 0.0).normalize();
    let env = Color::new(0.5, 0.25, 1.0);
    let lights = [Light::Directional { direction: dir, irradiance: Color::splat(2.0) }, Light::Constant { radiance: env }];
    let set = LightSet::new(&lights, &[], bounds_of(Vec3::splat(-1.0), Vec3::splat(1.0)));
    assert_eq!(set.env_le(Vec3::X), env);
    let p_env = set.select_pmf(1);
    assert!((set.pdf_li_env(LightSelection::Tree, Vec3::Y) - p_env / (4.0 * std::f32::consts::PI)).abs() < 1e-7);
    let mut s = Sampler::new(2, 0, 0);
    let (mut n_env, n) = (0usize, 20_000);
    for _ in 0..n {
        let ls = set.sample_li(LightSelection::Tree, p, Vec3::ZERO, s.next_1d(), s.next_2d()).unwrap();
        assert!(ls.dist.is_infinite());
        if ls.delta {
            assert!((ls.wi + dir).length() < 1e-6 && ls.li == Color::splat(2.0) && (ls.pdf - set.select_pmf(0)).abs() < 1e-7);
        } else {
            n_env += 1;
            assert_eq!(ls.li, env);
            assert!((ls.pdf - set.pdf_li_env(LightSelection::Tree, ls.wi)).abs() < 1e-7);
        }
    }
    let expect = p_env as f64 * n as f64;
    assert!((n_env as f64 - expect).abs() < 5.0 * expect.sqrt());
    // an empty set samples nothing
    let empty = LightSet::new(&[], &[], Bounds3::EMPTY);
    assert!(
        empty.is_empty()
            && empty.sample_li(LightSelection::Tree, p, Vec3::ZERO, 0.5, Vec2::ZERO).is_none()
            && empty.sample_emission(0.5, Vec2::ZERO, Vec2::ZERO).is_none()
    );
    assert_eq!(empty.total_power(), Color::ZERO);
}

/// `sample_li_deferred` (the path tracer's light sampling, which looks up an environment
/// sample's radiance only once its shadow ray is clear) gives the samples of `sample_li`
/// bit for bit, with `li` left to `env_le(wi)` exactly for the environment lights; the
/// environment samples' radiance and density are those of `env_le` and `pdf_li_env` in the
/// sampled direction (the values the path tracer's MIS weights of escaped rays use).
#[test]
fn deferred_light_samples_are_sample_li_s_with_the_environment_radiance_left_out() {
    let image = Image {
        width: 8,
        height: 4,
        data: (0..32).map(|i| Color::new(0.2 + (i % 5) as f32, 0.5 + (i % 3) as f32, 1.0 + (i % 7) as f32 * 0.3)).collect(),
    };
    let rot = glam::Mat3::from_rotation_x(0.4) * glam::Mat3::from_rotation_z(1.1);
    let lights = [
        Light::Point { position: Vec3::new(0.5, 0.5, 3.0), intensity: Color::splat(3.0) },
        Light::Constant { radiance: Color::new(0.1, 0.2, 0.3) },
        Light::Sunsky(crate::scene::sunsky::SunSkyDesc { to_world: rot, ..Default::default() }),
        Light::Envmap { image: 0, scale: 0.7, to_world: rot.transpose() },
    ];
    let shapes = [shape(Geometry::Mesh(split_rectangle(1.0)), Some(Color::new(2.0, 3.0, 4.0)), true)];
    let set = LightSet::with_images(&lights, &shapes, &[image], bounds_of(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0)));
    let mut s = Sampler::new(5, 0, 0);
    let mut seen = [0usize; 2];
    let bits = |ls: &LightSample| {
        let mut v: Vec<u32> = [ls.wi.x, ls.wi.y, ls.wi.z, ls.dist, ls.li.x, ls.li.y, ls.li.z, ls.pdf].map(f32::to_bits).to_vec();
        v.push(ls.delta as u32);
        v
    };
    for k in 0..20_000 {
        let sel = if k % 2 == 0 { LightSelection::Tree } else { LightSelection::Power };
        let p = Vec3::new(s.next_1d() * 2.0, s.next_1d(), s.next_1d() * 0.9);
        let n = crate::sampling::square_to_uniform_sphere(s.next_2d());
        let (u_sel, u) = (s.next_1d(), s.next_2d());
        let eager = set.sample_li(sel, p, n, u_sel, u);
        let deferred = set.sample_li_deferred(sel, p, n, u_sel, u);
        assert_eq!(eager.is_some(), deferred.is_some());
        let (Some(eager), Some((mut ls, env))) = (eager, deferred) else { continue };
        seen[env as usize] += 1;
        if env {
            assert_eq!(ls.li, Color::ZERO);
            assert!(ls.dist.is_infinite() && !ls.delta);
            assert_eq!(ls.pdf.to_bits(), set.pdf_li_env(sel, ls.wi).to_bits());
            ls.li = set.env_le(ls.wi);
        }
        assert_eq!(bits(&ls), bits(&eager));
    }
    assert!(seen.iter().all(|&n| n > 2000), "area/point and environment samples: {seen:?}");
}
