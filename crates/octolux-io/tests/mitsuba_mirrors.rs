//! Mirrored transforms (negative determinant) on the analytic shapes: an area emitter lights the
//! side Mitsuba 3 lights. Mitsuba 3 takes the normal of `rectangle` and `disk` as
//! `normalize(to_world * Normal3f(0, 0, 1))` (the inverse transpose: a mirror in the plane's own
//! axes does not flip it, a mirror of z does), transforms the outward vertex normals of `cube`
//! the same way (they stay outward), and turns a mirrored sphere inside out (Dr.Jit's
//! `transform_decompose` leaves the determinant's sign in the scale, a negative radius: normals
//! inward; `flip_normals` turns them back out). Its `area` emitter emits on the side of that
//! normal. Measured with Mitsuba 3.9.1 (scalar_rgb, a camera outside each shape): an emitting
//! sphere under `scale x="-1"` (or y, or z, or `radius -1`) renders black, under two mirrors or a
//! mirror plus `flip_normals` it renders lit; cubes render lit under every mirror.
//!
//! Check: the irradiance at a point facing the shape, measured through octolux's prepared scene
//! (rays cast over the receiver's hemisphere, the core's own rule for the emitting side), against
//! the analytic value on the lit side and zero on the other.

use glam::Vec3;
use octolux::accel::BackendKind;
use octolux::math::Ray;
use octolux::scene::Scene;
use octolux_io::mitsuba::load_str;
use std::f32::consts::PI;
use std::path::Path;

/// Radiance of the emitters.
const L: f32 = 2.0;

/// A scene with one emitting shape of type `ty` under the transform `ops` (plus `extra`
/// properties).
fn scene(ty: &str, extra: &str, ops: &str) -> Scene {
    let xml = format!(
        r#"<scene version="3.0.0">
            <shape type="{ty}">
                {extra}
                <transform name="to_world">{ops}</transform>
                <emitter type="area"><rgb name="radiance" value="{L}"/></emitter>
            </shape>
        </scene>"#
    );
    let loaded = load_str(&xml, Path::new("mirrors.xml"), &[]).unwrap_or_else(|e| panic!("{ty} {ops}: {e}"));
    Scene::prepare(loaded.desc, BackendKind::Bvh).unwrap_or_else(|e| panic!("{ty} {ops}: {e}"))
}

/// Irradiance at `p` on a receiver of normal `n`: `pi` times the mean emitted radiance over a
/// stratified cosine-weighted set of directions (256 x 256).
fn irradiance(s: &Scene, p: Vec3, n: Vec3) -> f32 {
    let t = if n.x.abs() < 0.9 { Vec3::X.cross(n).normalize() } else { Vec3::Y.cross(n).normalize() };
    let b = n.cross(t);
    const K: usize = 256;
    let mut sum = 0.0f64;
    for i in 0..K {
        for j in 0..K {
            let u1 = (i as f32 + 0.5) / K as f32;
            let u2 = (j as f32 + 0.5) / K as f32;
            let (r, phi) = (u1.sqrt(), 2.0 * PI * u2);
            let d = t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt();
            if let Some(hit) = s.intersect(&Ray::new(p, d)) {
                if let Some(light) = hit.light {
                    sum += s.lights.area_le(light, hit.ng, -d).y as f64;
                }
            }
        }
    }
    (PI as f64 * sum / (K * K) as f64) as f32
}

/// Irradiance under the centre of a square of half-side `a` at distance `h` (the form factor
/// of a parallel rectangle seen from below one corner, four times).
fn square_irradiance(a: f32, h: f32) -> f32 {
    let x = a / h;
    let s = (1.0 + x * x).sqrt();
    // pi L F, F = 4 * (1 / 2pi) * 2 * (x / s) atan(x / s)
    L * 4.0 * (x / s) * (x / s).atan()
}

/// Irradiance on the axis of a disk of radius `r` at distance `h`.
fn disk_irradiance(r: f32, h: f32) -> f32 {
    PI * L * r * r / (r * r + h * h)
}

fn assert_lit(s: &Scene, p: Vec3, n: Vec3, want: f32, what: &str) {
    let e = irradiance(s, p, n);
    println!("{what}: irradiance {e:.5}, analytic {want:.5}");
    assert!((e - want).abs() <= 0.02 * want, "{what}: irradiance {e}, analytic {want}");
}

fn assert_dark(s: &Scene, p: Vec3, n: Vec3, what: &str) {
    let e = irradiance(s, p, n);
    assert!(e == 0.0, "{what}: irradiance {e} on the side that must stay dark");
}

/// Mirrors of each axis (and none), combined with a lift to z = 1 after the mirror.
const MIRRORS: [(&str, f32); 4] = [
    // (scale, the z sign of Mitsuba's normal M^-T (0, 0, 1) for a plane shape)
    (r#"<scale x="1" y="1" z="1"/>"#, 1.0),
    (r#"<scale x="-1" y="1" z="1"/>"#, 1.0),
    (r#"<scale x="1" y="-1" z="1"/>"#, 1.0),
    (r#"<scale x="1" y="1" z="-1"/>"#, -1.0),
];

#[test]
fn mirrored_rectangles_and_disks_emit_on_mitsubas_side() {
    // The shape lies in z = 1; receivers at z = 0 (below, facing up) and z = 2 (above, facing down).
    let below = (Vec3::ZERO, Vec3::Z);
    let above = (Vec3::new(0.0, 0.0, 2.0), -Vec3::Z);
    for (ty, want) in [("rectangle", square_irradiance(1.0, 1.0)), ("disk", disk_irradiance(1.0, 1.0))] {
        for (scale, nz) in MIRRORS {
            let ops = format!(r#"{scale}<translate z="1"/>"#);
            let s = scene(ty, "", &ops);
            let (lit, dark) = if nz > 0.0 { (above, below) } else { (below, above) };
            // The tessellated disk (128 segments) has 0.04% less area than the disk.
            assert_lit(&s, lit.0, lit.1, want, &format!("{ty} {scale}, lit side"));
            assert_dark(&s, dark.0, dark.1, &format!("{ty} {scale}, dark side"));
        }
        // flip_normals on top of a mirror flips once more.
        let s = scene(ty, r#"<boolean name="flip_normals" value="true"/>"#, r#"<scale z="-1" x="1" y="1"/><translate z="1"/>"#);
        assert_lit(&s, above.0, above.1, want, &format!("{ty} mirrored in z and flipped"));
        assert_dark(&s, below.0, below.1, &format!("{ty} mirrored in z and flipped"));
    }
}

#[test]
fn mirrored_cubes_emit_outwards_and_mirrored_spheres_inwards() {
    // Receiver above the top face (z = 1) of the cube [-1, 1]^3, at z = 2, facing down: only the
    // top face is seen (the side faces are edge-on).
    let p = Vec3::new(0.0, 0.0, 2.0);
    for (scale, _) in MIRRORS {
        let s = scene("cube", "", scale);
        assert_lit(&s, p, -Vec3::Z, square_irradiance(1.0, 1.0), &format!("cube {scale}"));
        // From inside, nothing emits towards the centre.
        assert_dark(&s, Vec3::ZERO, Vec3::Z, &format!("cube {scale}, inside"));
        // A unit sphere seen from distance 2: E = pi L (r / d)^2 when it emits outward; a
        // mirrored one emits inward only (the inside, from the centre: E = pi L).
        let s = scene("sphere", "", scale);
        let mirrored = !scale.starts_with(r#"<scale x="1" y="1" z="1"/>"#);
        if mirrored {
            assert_dark(&s, p, -Vec3::Z, &format!("sphere {scale}, outside"));
            assert_lit(&s, Vec3::ZERO, Vec3::Z, PI * L, &format!("sphere {scale}, inside"));
        } else {
            assert_lit(&s, p, -Vec3::Z, PI * L / 4.0, &format!("sphere {scale}"));
            assert_dark(&s, Vec3::ZERO, Vec3::Z, &format!("sphere {scale}, inside"));
        }
    }
    // Two mirrors make a rotation, and flip_normals undoes one mirror: outward again.
    for (extra, ops) in
        [("", r#"<scale x="-1" y="-1" z="1"/>"#), (r#"<boolean name="flip_normals" value="true"/>"#, r#"<scale x="-1" y="1" z="1"/>"#)]
    {
        let s = scene("sphere", extra, ops);
        assert_lit(&s, p, -Vec3::Z, PI * L / 4.0, &format!("sphere {extra} {ops}"));
    }
    // A negative radius is a mirror too.
    let s = scene("sphere", r#"<float name="radius" value="-1"/>"#, "");
    assert_dark(&s, p, -Vec3::Z, "sphere of radius -1, outside");
}
