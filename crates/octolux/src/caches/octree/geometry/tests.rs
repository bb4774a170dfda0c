//! Clipped areas, lit sides and the analytic sphere's pieces.

use super::*;

fn unit_box() -> Bounds3 {
    Bounds3 { min: Vec3::ZERO, max: Vec3::ONE }
}

#[test]
fn clipping_gives_exact_areas() {
    let b = unit_box();
    // triangle fully inside
    let t = [Vec3::new(0.1, 0.1, 0.5), Vec3::new(0.9, 0.1, 0.5), Vec3::new(0.1, 0.9, 0.5)];
    assert!((clipped_area(&t, &b) - 0.32).abs() < 1e-6);
    // big triangle covering the whole z = 0.5 section: area 1
    let t = [Vec3::new(-5.0, -5.0, 0.5), Vec3::new(20.0, -5.0, 0.5), Vec3::new(-5.0, 20.0, 0.5)];
    assert!((clipped_area(&t, &b) - 1.0).abs() < 1e-9);
    // diagonal plane x + y = 1 through the box: a rectangle sqrt(2) x 1
    let t = [Vec3::new(-4.0, 5.0, -4.0), Vec3::new(5.0, -4.0, -4.0), Vec3::new(0.5, 0.5, 9.0)];
    assert!((clipped_area(&t, &b) - 2f64.sqrt()).abs() < 1e-6);
    // outside
    let t = [Vec3::new(2.0, 2.0, 2.0), Vec3::new(3.0, 2.0, 2.0), Vec3::new(2.0, 3.0, 2.0)];
    assert_eq!(clipped_area(&t, &b), 0.0);
    // half inside: right triangle with legs 2 on z=0.5 from (0.5,0.5) -> clipped to a unit-ish shape
    let t = [Vec3::new(0.5, 0.5, 0.5), Vec3::new(2.5, 0.5, 0.5), Vec3::new(0.5, 2.5, 0.5)];
    // inside part: the square [0.5,1]² minus nothing (hypotenuse x + y = 3 is outside) = 0.25
    assert!((clipped_area(&t, &b) - 0.25).abs() < 1e-7);
}

/// The sphere's pieces in boxes add up to its area, and its projected lit area is its
/// silhouette `πr²` from any direction (the outside lit) or the inside's `πr²` too.
#[test]
fn sphere_areas_are_exact() {
    let s = AnalyticSphere { center: Vec3::new(0.1, -0.2, 0.3), radius: 0.7, inward: false };
    let r2 = (0.7f32 * 0.7) as f64;
    let mut out = Vec::new();
    // whole sphere in one box
    let b = Bounds3 { min: Vec3::splat(-2.0), max: Vec3::splat(2.0) };
    sphere_lit_areas(&s, &b, &[], &[], 1e-4, &mut out);
    let total: f64 = out.iter().map(|e| e.area as f64).sum();
    assert!((total / (4.0 * std::f64::consts::PI * r2) - 1.0).abs() < 1e-4, "{total}");
    for w in [Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize(), -Vec3::Z] {
        let a = projected_lit_area(&out, w) as f64;
        assert!((a / (std::f64::consts::PI * r2) - 1.0).abs() < 0.01, "{w}: {a}");
    }
    // a grid of 7³ boxes covering the sphere ([-1, 1.1]³): the pieces add up to the whole
    // area (1%: only cut patches err)
    let mut sum = 0.0f64;
    let (lo, h) = (-1.0f32, 0.3f32);
    for i in 0..7 {
        for j in 0..7 {
            for k in 0..7 {
                let min = Vec3::new(lo + h * i as f32, lo + h * j as f32, lo + h * k as f32);
                out.clear();
                sphere_lit_areas(&s, &Bounds3 { min, max: min + Vec3::splat(h) }, &[], &[], 1e-4, &mut out);
                sum += out.iter().map(|e| e.area as f64).sum::<f64>();
            }
        }
    }
    let rel = sum / (4.0 * std::f64::consts::PI * r2) - 1.0;
    assert!(rel.abs() < 0.01, "sum of pieces off by {rel}");
    // a photon on the inside lights the inside only: every entry points inwards
    let p = s.center + Vec3::new(0.0, 0.0, 0.7);
    let mut v = Vec::new();
    sphere_lit_areas(&s, &b, &[p], &[-Vec3::Z], 1e-4, &mut v);
    assert!(!v.is_empty());
    let top = v.iter().min_by(|a, b| a.n.z.total_cmp(&b.n.z)).unwrap();
    assert!(top.n.z < -0.9, "{top:?}");
    // one entry per patch, each the outward default's negated
    let mut outward = Vec::new();
    sphere_lit_areas(&s, &b, &[], &[], 1e-4, &mut outward);
    assert_eq!(v.len(), outward.len());
    assert!(v.iter().zip(&outward).all(|(x, y)| (x.n + y.n).length() < 1e-6 && x.area == y.area));
    // an inward (flipped) sphere without photons assumes its inside lit
    let mut w = Vec::new();
    sphere_lit_areas(&AnalyticSphere { inward: true, ..s }, &b, &[], &[], 1e-4, &mut w);
    assert_eq!(v.len(), w.len());
    for (x, y) in v.iter().zip(&w) {
        assert!((x.n - y.n).length() < 1e-6 && x.area == y.area);
    }
    // a box inside the sphere, or away from it, holds none of it
    v.clear();
    sphere_lit_areas(&s, &Bounds3 { min: s.center - 0.1, max: s.center + 0.1 }, &[], &[], 1e-4, &mut v);
    sphere_lit_areas(&s, &Bounds3 { min: Vec3::splat(1.5), max: Vec3::splat(2.0) }, &[], &[], 1e-4, &mut v);
    assert!(v.is_empty());
}

#[test]
fn lit_sides_follow_the_photons() {
    let b = unit_box();
    // floor z = 0.3 (front +z) as two triangles
    let tris = vec![
        [Vec3::new(-1.0, -1.0, 0.3), Vec3::new(2.0, -1.0, 0.3), Vec3::new(2.0, 2.0, 0.3)],
        [Vec3::new(-1.0, -1.0, 0.3), Vec3::new(2.0, 2.0, 0.3), Vec3::new(-1.0, 2.0, 0.3)],
    ];
    let ids = [0u32, 1];
    let (mut out, mut back) = (Vec::new(), Vec::new());
    // no photons: front assumed
    lit_areas(&tris, &ids, &[], &b, &[], &[], &mut out, Some(&mut back));
    assert_eq!(out.len(), 1);
    assert!((out[0].area - 1.0).abs() < 1e-5 && out[0].n == Vec3::Z);
    assert!(back.len() == 1 && (back[0].front, back[0].back, back[0].lit) == (0, 0, (true, false)));
    // photons on the back only: back side only, and the group said lit on its back alone
    let pos = [Vec3::new(0.5, 0.5, 0.3)];
    lit_areas(&tris, &ids, &[], &b, &pos, &[-Vec3::Z], &mut out, Some(&mut back));
    assert_eq!(out.len(), 1);
    assert!(out[0].n == -Vec3::Z);
    assert!(back.len() == 1 && (back[0].front, back[0].back, back[0].lit) == (0, 1, (false, true)), "{back:?}");
    // the photon gone, the front is lit again; another from behind changes nothing
    let mut g = back[0].clone();
    g.count(pos[0], -Vec3::Z, -1);
    assert!(g.changed() && g.back == 0);
    g.count(pos[0], -Vec3::Z, 1);
    g.count(Vec3::new(0.1, 0.9, 0.3), -Vec3::Z, 1);
    assert!(!g.changed() && g.back == 2);
    g.count(Vec3::new(0.1, 0.9, 0.3), Vec3::Z, 1);
    assert!(g.changed() && g.front == 1, "a photon from the front lights it too");
    // both sides
    let pos = [Vec3::new(0.5, 0.5, 0.3), Vec3::new(0.2, 0.7, 0.3)];
    lit_areas(&tris, &ids, &[], &b, &pos, &[-Vec3::Z, Vec3::Z], &mut out, Some(&mut back));
    assert_eq!(out.len(), 2);
    assert!(back.len() == 1 && (back[0].front, back[0].back) == (1, 1));
    // a sheet lit from both sides counts once for every direction
    let w = Vec3::new(0.3, -0.2, -0.7).normalize();
    assert!((projected_lit_area(&out, w) - w.z.abs()).abs() < 1e-5);
    assert!((projected_lit_area(&out, -w) - w.z.abs()).abs() < 1e-5);
    // one back photon lights the back of the whole coplanar group (both triangles)
    let pos = [Vec3::new(0.7, 0.2, 0.3), Vec3::new(0.2, 0.7, 0.3)];
    lit_areas(&tris, &ids, &[], &b, &pos, &[-Vec3::Z, Vec3::Z], &mut out, Some(&mut back));
    assert!((projected_lit_area(&out, -Vec3::Z) - 1.0).abs() < 1e-5 && (projected_lit_area(&out, Vec3::Z) - 1.0).abs() < 1e-5);
    // an object's bottom face resting on the floor (coplanar, wound -z, no photons on
    // it): floor photons around it do not light its upper side
    let mut with_box = tris.clone();
    with_box.push([Vec3::new(0.4, 0.4, 0.3), Vec3::new(0.4, 0.6, 0.3), Vec3::new(0.6, 0.6, 0.3)]);
    with_box.push([Vec3::new(0.4, 0.4, 0.3), Vec3::new(0.6, 0.6, 0.3), Vec3::new(0.6, 0.4, 0.3)]);
    let pos = [Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.8, 0.9, 0.3)];
    lit_areas(&with_box, &[0, 1, 2, 3], &[], &b, &pos, &[Vec3::Z, Vec3::Z], &mut out, Some(&mut back));
    let w = Vec3::new(0.1, 0.2, 0.9).normalize();
    assert!((projected_lit_area(&out, w) - w.z).abs() < 1e-5, "{out:?}");
    assert!((projected_lit_area(&out, -Vec3::Z) - 0.04).abs() < 1e-5, "{out:?}");
    // a back-facing photon off the plane does not count
    let pos = [Vec3::new(0.5, 0.5, 0.6)];
    lit_areas(&tris, &ids, &[], &b, &pos, &[-Vec3::Z], &mut out, Some(&mut back));
    assert_eq!(out.len(), 1);
    assert!(out[0].n == Vec3::Z);
}

/// The grid finds what a linear scan finds (lowest matching index), for normals closer and
/// farther than both tolerances of `lit_areas`, across grid-cell boundaries.
#[test]
fn normal_grid_answers_as_a_linear_scan() {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut rand = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 40) as f32) / (1u64 << 24) as f32
    };
    let mut normals: Vec<Vec3> = Vec::new();
    for _ in 0..300 {
        let base = Vec3::new(rand() - 0.5, rand() - 0.5, rand() - 0.5).normalize_or(Vec3::Z);
        normals.push(base);
        // neighbours from 0 to 6e-3 away: both sides of both tolerances (1.4e-3, 4.5e-3)
        for _ in 0..4 {
            let off = Vec3::new(rand() - 0.5, rand() - 0.5, rand() - 0.5) * (0.012 * rand());
            normals.push((base + off).normalize());
        }
    }
    for (cos_min, radius) in [(1.0 - 1e-6, MERGE_RADIUS), (1.0 - 1e-5, GROUP_RADIUS)] {
        let mut grid = NormalGrid::new();
        let mut kept: Vec<Vec3> = Vec::new();
        let mut merged = 0;
        for &n in &normals {
            let linear = kept.iter().position(|k| k.dot(n) > cos_min).map(|i| i as u32);
            let found = grid.first(n, radius, 0..=0, |i| kept[i as usize].dot(n) > cos_min);
            assert_eq!(found, linear, "normal {n}");
            if found.is_none() {
                grid.insert(n, 0, kept.len() as u32);
                kept.push(n);
            } else {
                merged += 1;
            }
        }
        assert!(merged > 50 && kept.len() > 300, "the case should exercise both answers ({merged} merged, {} kept)", kept.len());
    }
}

/// With plane offsets in slots (as `lit_areas` groups planes): the same answer as a linear
/// scan over (normal, offset) pairs, for offsets on both sides of the tolerance and across
/// slot boundaries.
#[test]
fn normal_grid_with_offset_slots_answers_as_a_linear_scan() {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rand = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 40) as f32) / (1u64 << 24) as f32
    };
    let tol = 1e-3f32;
    let step = 4.0 * tol;
    let slot = |d: f32| (d / step).floor() as i32;
    let mut planes: Vec<(Vec3, f32)> = Vec::new();
    for _ in 0..200 {
        let n = if rand() < 0.5 { Vec3::Y } else { Vec3::new(rand() - 0.5, rand() - 0.5, rand() - 0.5).normalize_or(Vec3::Z) };
        let d = (rand() - 0.5) * 0.2;
        planes.push((n, d));
        for _ in 0..4 {
            planes.push((n, d + (rand() - 0.5) * 5.0 * tol));
        }
    }
    let mut grid = NormalGrid::new();
    let mut kept: Vec<(Vec3, f32)> = Vec::new();
    let (mut merged, mut new) = (0, 0);
    for &(n, d) in &planes {
        let same = |k: &(Vec3, f32)| k.0.dot(n) > 1.0 - 1e-5 && (k.1 - d).abs() <= tol;
        let linear = kept.iter().position(same).map(|i| i as u32);
        let found = grid.first(n, GROUP_RADIUS, slot(d - 2.0 * tol)..=slot(d + 2.0 * tol), |i| same(&kept[i as usize]));
        assert_eq!(found, linear, "plane {n} {d}");
        if found.is_none() {
            grid.insert(n, slot(d), kept.len() as u32);
            kept.push((n, d));
            new += 1;
        } else {
            merged += 1;
        }
    }
    assert!(merged > 100 && new > 300, "both answers exercised ({merged} merged, {new} new)");
}

/// The grid of `side_counts` against testing every photon on every group: random small
/// triangles (one group each) in and across a cell, photons on them from both sides, on their
/// edges (within the containment test's tolerance), off their planes, and outside the cell.
#[test]
fn side_counts_by_grid_equal_every_photon_tested() {
    let mut s = crate::sampling::Sampler::new(9, 0, 0);
    let cell = Bounds3 { min: Vec3::new(1.0, -2.0, 0.5), max: Vec3::new(1.5, -1.5, 1.0) };
    let mut r3 = || Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
    let mut groups = Vec::new();
    let mut tris = Vec::new();
    for _ in 0..300 {
        let c = cell.min + (r3() * 1.4 - Vec3::splat(0.2)) * cell.extent();
        let t = [c, c + (r3() - Vec3::splat(0.5)) * 0.1, c + (r3() - Vec3::splat(0.5)) * 0.1];
        let Some(on) = OnTriangle::new(&t) else { continue };
        let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        groups.push(PlaneGroup { n: on.n, d: on.n.dot(on.v0), area: 1.0, tris: vec![on], lo, hi });
        tris.push(t);
    }
    let plane_tol = 1e-4 * 0.5;
    let (mut pos, mut ng) = (Vec::new(), Vec::new());
    for (k, t) in tris.iter().enumerate() {
        let n = groups[k].n;
        for i in 0..6 {
            let (mut u, mut v) = (r3().x, r3().y);
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            if i == 0 {
                (u, v) = (1.0 + 5e-5 - v, v); // just past an edge, within the tolerance
            }
            let off = if i == 1 { n * 3.0 * plane_tol } else { Vec3::ZERO };
            pos.push(t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v + off);
            ng.push(if i % 2 == 0 { n } else { -n });
        }
    }
    pos.push(Vec3::NAN);
    ng.push(Vec3::Y);
    let naive: Vec<(u32, u32)> = groups
        .iter()
        .map(|g| {
            pos.iter().zip(&ng).fold((0, 0), |(f, b), (&p, &n)| match g.side(p, n, plane_tol) {
                Some(true) => (f + 1, b),
                Some(false) => (f, b + 1),
                None => (f, b),
            })
        })
        .collect();
    assert!(groups.len() * pos.len() > 4096, "the grid is used");
    assert_eq!(side_counts(&groups, &cell, &pos, &ng, plane_tol), naive);
    let lit = naive.iter().filter(|c| c.0 > 0 && c.1 > 0).count();
    assert!(lit > groups.len() / 2, "{lit} of {} groups lit on both sides", groups.len());
}
