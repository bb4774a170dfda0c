//! The volume query's free-space reading of an atmospheric leaf (`atmosphere.rs`,
//! `free_space_irradiance`) against exact irradiance.

use super::atmosphere::free_space_irradiance;
use glam::{Mat3, Vec3};

/// A radiance field over directions.
type Field = dyn Fn(Vec3) -> f64;

/// `n` points of a Fibonacci sphere, each with solid angle `4π/n`.
fn sphere(n: usize) -> impl Iterator<Item = Vec3> {
    (0..n).map(move |i| {
        let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
        Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
    })
}

/// The six half-space moments `∫_{H_k} L w dω` of a grey field, as the leaf matrices hold
/// them (every column the same), and the irradiance `∫_{w·n>0} L w·n dω`, by quadrature.
fn moments(l: &dyn Fn(Vec3) -> f64, n: usize) -> [Mat3; 6] {
    let mut v = [[0f64; 3]; 6];
    for w in sphere(n) {
        let lw = l(w) * 4.0 * std::f64::consts::PI / n as f64;
        for a in 0..3 {
            let k = 2 * a + (w[a] < 0.0) as usize;
            for b in 0..3 {
                v[k][b] += lw * w[b] as f64;
            }
        }
    }
    v.map(|c| {
        let col = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32);
        Mat3::from_cols(col, col, col)
    })
}

fn irradiance(l: &dyn Fn(Vec3) -> f64, nrm: Vec3, n: usize) -> f64 {
    sphere(n).map(|w| l(w) * (w.dot(nrm) as f64).max(0.0)).sum::<f64>() * 4.0 * std::f64::consts::PI / n as f64
}

/// The volume query's reading of an atmospheric leaf (`free_space_irradiance`) is exact
/// for radiance fields of spherical-harmonic order 2, whatever the normal; a field with a
/// narrow lobe is not (so the test can fail).
#[test]
fn free_space_query_is_exact_for_order_2_fields() {
    let fields: [(&str, Box<Field>); 4] = [
        ("isotropic", Box::new(|_| 1.0)),
        ("linear", Box::new(|w: Vec3| 1.0 + 0.8 * w.x as f64 - 0.3 * w.z as f64)),
        (
            "quadratic",
            Box::new(|w: Vec3| {
                1.0 + 0.5 * w.y as f64 + 0.7 * (w.x * w.z) as f64 + 0.4 * (3.0 * w.y * w.y - 1.0) as f64 + 0.6 * (w.x * w.y) as f64
            }),
        ),
        ("sky", Box::new(|w: Vec3| 2.0 + 1.5 * w.y as f64 + 0.5 * (w.y * w.y) as f64)),
    ];
    let normals = [
        Vec3::X,
        Vec3::NEG_Y,
        Vec3::new(1.0, 1.0, 1.0).normalize(),
        Vec3::new(-0.3, 0.8, -0.52).normalize(),
        Vec3::new(0.1, -0.2, 0.97).normalize(),
    ];
    for (name, l) in &fields {
        let six = moments(l.as_ref(), 400_000);
        for n in normals {
            let (got, want) = (free_space_irradiance(&six, n).x as f64, irradiance(l.as_ref(), n, 400_000));
            assert!((got / want - 1.0).abs() < 2e-3, "{name}, normal {n}: {got} against {want}");
        }
    }
    // a lobe of exponent 50 around (1, 1, 0)/√2: order 2 does not hold it
    let d = Vec3::new(1.0, 1.0, 0.0).normalize();
    let lobe = move |w: Vec3| (w.dot(d).max(0.0) as f64).powi(50);
    let six = moments(&lobe, 400_000);
    // a normal 90° from the lobe: half the lobe lights it; order 2 smears the lobe
    let n = Vec3::new(1.0, -1.0, 0.0).normalize();
    let (got, want) = (free_space_irradiance(&six, n).x as f64, irradiance(&lobe, n, 400_000));
    eprintln!("lobe: {got} against {want}");
    assert!(want > 0.0 && (got / want - 1.0).abs() > 0.05, "the lobe's {got} against {want}");
}
