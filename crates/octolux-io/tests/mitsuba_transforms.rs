//! Mitsuba `<transform>` operations, each checked against a matrix computed by hand, read
//! through a sensor's `to_world`.

use glam::{Mat4, Vec3, Vec4};
use octolux_io::mitsuba::load_str;
use std::path::Path;

/// `to_world` of a sensor whose transform body is `ops`.
fn to_world(ops: &str) -> Mat4 {
    let xml = format!(
        r#"<scene version="3.0.0">
            <sensor type="perspective">
                <float name="fov" value="45"/>
                <transform name="to_world">{ops}</transform>
            </sensor>
        </scene>"#
    );
    let scene = load_str(&xml, Path::new("/virtual/transform.xml"), &[]).unwrap_or_else(|e| panic!("{ops}: {e}"));
    scene.desc.camera.to_world
}

/// Build a matrix from its rows.
fn rows(r: [[f32; 4]; 4]) -> Mat4 {
    Mat4::from_cols(Vec4::from(r[0]), Vec4::from(r[1]), Vec4::from(r[2]), Vec4::from(r[3])).transpose()
}

fn assert_mat(got: Mat4, want: Mat4, what: &str) {
    assert!(got.abs_diff_eq(want, 1e-6), "{what}:\n got  {got:?}\n want {want:?}");
}

#[test]
fn translate_forms() {
    let want = rows([[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 2.0], [0.0, 0.0, 1.0, 3.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<translate x="1" y="2" z="3"/>"#), want, "x/y/z");
    assert_mat(to_world(r#"<translate value="1, 2, 3"/>"#), want, "value with commas");
    assert_mat(to_world(r#"<translate value="1 2 3"/>"#), want, "value with spaces");
    // A missing coordinate is 0; a single value applies to all three axes (Mitsuba's rule).
    let y_only = rows([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, -2.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<translate y="-2"/>"#), y_only, "y only");
    let all = rows([[1.0, 0.0, 0.0, 2.0], [0.0, 1.0, 0.0, 2.0], [0.0, 0.0, 1.0, 2.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<translate value="2"/>"#), all, "single value");
}

#[test]
fn scale_forms() {
    let uniform = rows([[2.0, 0.0, 0.0, 0.0], [0.0, 2.0, 0.0, 0.0], [0.0, 0.0, 2.0, 0.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<scale value="2"/>"#), uniform, "uniform");
    // Missing coordinates default to 1 for scale; a negative x mirrors the image.
    let x_only = rows([[-3.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<scale x="-3"/>"#), x_only, "x only");
    let xyz = rows([[1.0, 0.0, 0.0, 0.0], [0.0, 2.0, 0.0, 0.0], [0.0, 0.0, 4.0, 0.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<scale value="1, 2, 4"/>"#), xyz, "three values");
}

#[test]
fn rotate_forms() {
    // 90 degrees about +z maps x to y and y to -x (right-handed).
    let rz = rows([[0.0, -1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<rotate z="1" angle="90"/>"#), rz, "z attribute");
    assert_mat(to_world(r#"<rotate value="0, 0, 5" angle="90"/>"#), rz, "unnormalised value axis");
    // 90 degrees about +x maps y to z.
    let rx = rows([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<rotate x="1" angle="90"/>"#), rx, "x axis");
    // 120 degrees about (1,1,1) permutes the axes: x -> y -> z -> x.
    let perm = rows([[0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<rotate value="1 1 1" angle="120"/>"#), perm, "diagonal axis");
}

#[test]
fn matrix_is_row_major() {
    let want = rows([[0.0, 1.0, 0.0, 5.0], [0.0, 0.0, 2.0, 6.0], [1.0, 0.0, 0.0, 7.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<matrix value="0 1 0 5  0 0 2 6  1 0 0 7  0 0 0 1"/>"#), want, "16 values");
    let m3 = rows([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 2.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<matrix value="0 1 0 0 0 2 1 0 0"/>"#), m3, "9 values");
}

#[test]
fn lookat_matches_mitsuba() {
    // Camera at (0,0,4) looking at the origin, +y up: camera x (left) is world -x, z is -z.
    let want = rows([[-1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 4.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/>"#), want, "lookat");
    // Looking down -y from (0,5,0) with up +z: left = z x (-y) = +x, up = (-y) x x = +z.
    let down = rows([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 5.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]);
    assert_mat(to_world(r#"<lookat origin="0 5 0" target="0 0 0" up="0 0 1"/>"#), down, "looking down");
}

#[test]
fn operations_compose_in_document_order() {
    // scale then translate: p' = T (S p).
    let m = to_world(r#"<scale value="2"/><translate x="1"/>"#);
    assert!(m.transform_point3(Vec3::X).abs_diff_eq(Vec3::new(3.0, 0.0, 0.0), 1e-6));
    // translate then scale: p' = S (T p).
    let m = to_world(r#"<translate x="1"/><scale value="2"/>"#);
    assert!(m.transform_point3(Vec3::X).abs_diff_eq(Vec3::new(4.0, 0.0, 0.0), 1e-6));
    // rotate then translate: the rotation happens about the origin first.
    let m = to_world(r#"<rotate z="1" angle="90"/><translate x="10"/>"#);
    assert!(m.transform_point3(Vec3::X).abs_diff_eq(Vec3::new(10.0, 1.0, 0.0), 1e-5));
}

#[test]
fn invalid_operations_are_errors_with_location() {
    let bad = [
        r#"<translate value="1 2"/>"#,
        r#"<translate value="1" x="2"/>"#,
        r#"<rotate z="1"/>"#,
        r#"<rotate angle="30"/>"#,
        r#"<matrix value="1 2 3"/>"#,
        r#"<lookat origin="0 0 0" target="0 0 0"/>"#,
        r#"<lookat origin="0 0 0" target="0 1 0" up="0 1 0"/>"#,
        r#"<scale x="abc"/>"#,
        r#"<float name="x" value="1"/>"#,
    ];
    for ops in bad {
        let xml = format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<transform name=\"to_world\">\n{ops}\n</transform>\n</sensor>\n</scene>"
        );
        let err = load_str(&xml, Path::new("/virtual/bad_transform.xml"), &[]).err().unwrap_or_else(|| panic!("{ops} was accepted"));
        let msg = err.to_string();
        assert!(msg.starts_with("/virtual/bad_transform.xml:4:"), "{ops}: {msg}");
    }
}
