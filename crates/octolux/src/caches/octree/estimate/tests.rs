//! The estimates' sums against direct loops.

use super::*;

/// The half-axis lists give `add_by_surface` the same sums, bit for bit, as the loop over
/// all the lit areas that tests each normal's sign per photon (the form before the lists),
/// with normals of both signs and with zero components, in the areas and in `ng`.
#[test]
fn side_lists_give_the_sums_of_the_loop_over_all_areas() {
    use crate::sampling::square_to_uniform_sphere;
    let mut s = crate::sampling::Sampler::new(5, 5, 5);
    let mut areas = Vec::new();
    for i in 0..40 {
        let mut n = square_to_uniform_sphere(s.next_2d());
        if i % 5 == 0 {
            n[i % 3] = 0.0; // in no list of that axis
        }
        if i % 7 == 0 {
            n = if i % 2 == 0 { Vec3::Z } else { -Vec3::Z };
        }
        areas.push(OrientedArea { n, area: 0.01 + s.next_1d() });
    }
    let mut sides = SideAreas::default();
    sides.fill(&areas);
    assert!((0..6).all(|k| sides.start[k + 1] > sides.start[k]), "every half-axis has areas");
    let (min_cos, a_min) = (0.1, 0.05);
    let mut acc = Accumulator::new();
    let mut direct = [[DVec3::ZERO; 3]; 6];
    for i in 0..2000 {
        let w = square_to_uniform_sphere(s.next_2d());
        let mut ng = square_to_uniform_sphere(s.next_2d());
        if i % 4 == 0 {
            ng[i % 3] = 0.0;
        }
        let c = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
        add_by_surface(&mut acc.zero, w, c, ng, &sides, min_cos, a_min, 1.0);
        for a in 0..3 {
            if ng[a] == 0.0 {
                continue;
            }
            let neg = ng[a] < 0.0;
            let (mut proj, mut total) = (0.0f32, 0.0f32);
            for e in &areas {
                if e.n[a] != 0.0 && (e.n[a] < 0.0) == neg {
                    let g = e.n[a] * e.n[a] * e.area;
                    total += g;
                    proj += g * e.n.dot(w).max(0.0);
                }
            }
            let den = proj.max(min_cos * total).max(ng[a] * ng[a] * min_cos * a_min);
            if !(den > 0.0) {
                continue;
            }
            let wd = DVec3::from(w) * (ng[a] * ng[a] / den) as f64;
            let m = &mut direct[2 * a + neg as usize];
            m[0] += wd * c.x as f64;
            m[1] += wd * c.y as f64;
            m[2] += wd * c.z as f64;
        }
    }
    for (k, (got, want)) in acc.zero.iter().zip(&direct).enumerate() {
        for (j, (g, d)) in got.iter().zip(want).enumerate() {
            assert_eq!(g.to_array().map(f64::to_bits), d.to_array().map(f64::to_bits), "matrix {k}, column {j}");
        }
    }
}

#[test]
fn accumulator_matches_the_direct_sums() {
    let mut s = crate::sampling::Sampler::new(2, 2, 2);
    let mut acc = Accumulator::new();
    let mut direct = [[DVec3::ZERO; 3]; 6];
    for i in 0..1000 {
        let mut w = crate::sampling::square_to_uniform_sphere(s.next_2d());
        if i % 10 == 0 {
            w[i % 3] = 0.0; // zero components: in no matrix of that axis
        }
        let c = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
        let weight = 0.5 + s.next_1d();
        acc.add(w, c, weight);
        for a in 0..3 {
            if w[a] != 0.0 {
                let k = 2 * a + (w[a] < 0.0) as usize;
                for j in 0..3 {
                    direct[k][j] += (w * weight * c[j]).as_dvec3();
                }
            }
        }
    }
    let m = acc.finish();
    for k in 0..6 {
        let expect = Mat3::from_cols(direct[k][0].as_vec3(), direct[k][1].as_vec3(), direct[k][2].as_vec3());
        let d = m[k] - expect;
        let err = d.x_axis.abs().max(d.y_axis.abs()).max(d.z_axis.abs()).max_element();
        assert!(err < 1e-3, "{k}: {err}");
    }
}

/// A leaf's lit sides under moved photons (`incremental.rs` estimates the leaf from its photons
/// when they change): on a floor lit on its front, a photon from behind lights its back, one
/// from the front changes nothing; on a floor lit on its back alone, its last photon gone, the
/// front is lit; the paper's estimator counts nothing.
#[test]
fn moved_photons_change_the_lit_sides_when_a_count_crosses_zero() {
    use super::super::geometry::lit_areas;
    let b = Bounds3 { min: Vec3::ZERO, max: Vec3::ONE };
    let tris = [
        [Vec3::new(-1.0, -1.0, 0.3), Vec3::new(2.0, -1.0, 0.3), Vec3::new(2.0, 2.0, 0.3)],
        [Vec3::new(-1.0, -1.0, 0.3), Vec3::new(2.0, 2.0, 0.3), Vec3::new(-1.0, 2.0, 0.3)],
    ];
    let on = Vec3::new(0.5, 0.5, 0.3);
    let weights = |ng: Vec3| {
        let (mut areas, mut groups) = (Vec::new(), Vec::new());
        lit_areas(&tris, &[0, 1], &[], &b, &[on], &[ng], &mut areas, Some(&mut groups));
        let lit_total = areas.iter().map(|a| a.area).sum();
        let (by_normal, sides) = (true, SideAreas::default());
        LeafWeights {
            estimator: Estimator::GeometryArea,
            by_normal,
            inv_da: 1.0,
            min_cos: 0.1,
            a_min: 0.0,
            lit_total,
            areas,
            groups,
            sides,
        }
    };
    let mut front = weights(Vec3::Z);
    front.count_sides(Vec3::new(0.2, 0.2, 0.3), Vec3::Z, 1);
    assert!(!front.sides_changed(), "another photon on the lit side");
    front.count_sides(Vec3::new(0.2, 0.2, 0.8), -Vec3::Z, 1);
    assert!(!front.sides_changed(), "a photon off the plane");
    front.count_sides(Vec3::new(0.7, 0.2, 0.3), -Vec3::Z, 1);
    assert!(front.sides_changed(), "a photon from behind lights the back");
    front.count_sides(Vec3::new(0.7, 0.2, 0.3), -Vec3::Z, -1);
    assert!(!front.sides_changed(), "gone again: the sides of the estimate");
    let mut back = weights(-Vec3::Z);
    back.count_sides(on, -Vec3::Z, -1);
    assert!(back.sides_changed(), "the last photon from behind gone: the front is lit");
    let mut paper = LeafWeights { estimator: Estimator::Paper, groups: Vec::new(), ..weights(-Vec3::Z) };
    paper.count_sides(on, -Vec3::Z, -1);
    assert!(!paper.sides_changed(), "the paper's estimator reads no lit sides");
}
