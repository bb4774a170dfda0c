//! `octolux flicker` (issue 13 item 3, docs/guide/baking.md) on synthetic frames with a known flicker:
//! a grey sequence whose frames are alternately too bright and too dark, against a constant
//! reference; with a scene and a camera path, static points are followed through the frames.
//! Bad folders are refused with their messages. No rendering: the whole file runs in a second.

use octolux::image::Image;
use octolux::Color;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A box with a sphere, seen from the front (the camera path moves around this view).
const SCENE: &str = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="70"/>
        <transform name="to_world"><lookat origin="0, 1, 2.9" target="0, 0.9, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
    </sensor>
    <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.7"/></bsdf>
    <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform><ref id="white"/></shape>
    <shape type="rectangle"><transform name="to_world"><translate y="1" z="-1"/></transform><ref id="white"/></shape>
    <shape type="sphere"><point name="center" x="0.3" y="0.3" z="0"/><float name="radius" value="0.3"/><ref id="white"/></shape>
</scene>
"#;

const PATH: &str = r#"{"fps": 4, "keyframes": [
    {"time": 0.0, "position": [-0.2, 1, 2.9], "target": [0, 0.9, 0], "fov": 70},
    {"time": 0.75, "position": [0.2, 1.1, 2.7], "target": [0, 0.9, 0], "fov": 70}]}"#;

struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let path = std::env::temp_dir().join(format!("octolux-flicker-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(path.join("frames")).expect("temp dir");
        std::fs::create_dir_all(path.join("ref")).expect("temp dir");
        std::fs::write(path.join("scene.xml"), SCENE).expect("scene");
        std::fs::write(path.join("path.json"), PATH).expect("path");
        TempDir(path)
    }
    fn s(&self, name: &str) -> String {
        self.0.join(name).to_string_lossy().into_owned()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn grey(dir: &Path, name: &str, v: f32) {
    let img = Image { width: 16, height: 16, data: vec![Color::splat(v); 256] };
    octolux_io::image_io::write_exr(&dir.join(name), &img).expect("write exr");
}

/// Reference 0.5 everywhere; frames 0.5 ± d alternately.
fn sequence(t: &TempDir, frames: u32, d: f32) {
    for i in 1..=frames {
        grey(&t.0.join("ref"), &format!("ref_{i:04}.exr"), 0.5);
        grey(&t.0.join("frames"), &format!("f_{i:04}.exr"), if i % 2 == 1 { 0.5 + d } else { 0.5 - d });
    }
}

fn octolux(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octolux")).args(args).output().expect("run octolux")
}

fn report(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

#[test]
fn alternating_frames_give_the_analytic_flicker() {
    let t = TempDir::new("alt");
    sequence(&t, 4, 0.1);
    let j = report(&octolux(&["flicker", &t.s("frames"), "--reference", &t.s("ref")]));
    let f = &j["flicker"];
    let denom = 0.25 + 0.01; // r² + ε
    let close = |key: &str, v: f64| {
        let got = f[key].as_f64().unwrap();
        assert!((got - v).abs() < 1e-5 * v.max(1.0), "{key}: {got} against {v}: {j}");
    };
    close("frame_rel_mse", 0.01 / denom);
    close("temporal_rel_mse", 0.04 / denom);
    close("temporal_ratio", 2.0);
    assert_eq!(f["points"], 0);
    assert_eq!((j["first"].as_u64(), j["last"].as_u64()), (Some(1), Some(4)));

    // Static points of the scene, reprojected along the camera path: each keeps an error of
    // ±0.1 over the four frames, a relative spread of 0.1 / sqrt(0.26).
    let j = report(&octolux(&[
        "flicker",
        &t.s("frames"),
        "--reference",
        &t.s("ref"),
        "--scene",
        &t.s("scene.xml"),
        "--camera-path",
        &t.s("path.json"),
        "--points",
        "64",
        "--border",
        "1",
    ]));
    let f = &j["flicker"];
    let points = f["points"].as_u64().unwrap();
    assert!(points >= 10 && points <= j["tracks"].as_u64().unwrap(), "{j}");
    let s = f["static_rel_std"].as_f64().unwrap();
    assert!((s - 0.1 / denom.sqrt()).abs() < 1e-5, "{j}");
    assert_eq!(f["static_rel_std_reference"].as_f64(), Some(0.0));

    // A still sequence (the same error in every frame) does not flicker at all.
    sequence(&t, 4, 0.0);
    for i in 1..=4 {
        grey(&t.0.join("frames"), &format!("f_{i:04}.exr"), 0.6);
    }
    let j = report(&octolux(&["flicker", &t.s("frames"), "--reference", &t.s("ref")]));
    assert_eq!(j["flicker"]["temporal_rel_mse"].as_f64(), Some(0.0), "{j}");
    assert!(j["flicker"]["frame_rel_mse"].as_f64().unwrap() > 0.03, "{j}");
}

#[test]
fn bad_folders_are_refused() {
    let t = TempDir::new("bad");
    sequence(&t, 3, 0.1);
    let err = |args: &[&str]| {
        let out = octolux(args);
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    std::fs::remove_file(t.0.join("ref").join("ref_0002.exr")).unwrap();
    let e = err(&["flicker", &t.s("frames"), "--reference", &t.s("ref")]);
    assert!(e.contains("frame 2") && e.contains("has no reference"), "{e}");
    grey(&t.0.join("ref"), "ref_0002.exr", 0.5);
    grey(&t.0.join("frames"), "g_0001.exr", 0.5);
    let e = err(&["flicker", &t.s("frames"), "--reference", &t.s("ref")]);
    assert!(e.contains("both claim frame 1"), "{e}");
    std::fs::remove_file(t.0.join("frames").join("g_0001.exr")).unwrap();
    let e = err(&["flicker", &t.s("frames"), "--reference", &t.s("ref"), "--camera-path", &t.s("path.json")]);
    assert!(e.contains("--camera-path needs --scene"), "{e}");
    let e = err(&["flicker", &t.s("nowhere"), "--reference", &t.s("ref")]);
    assert!(e.contains("cannot read frame folder") && e.contains("nowhere"), "{e}");
    std::fs::remove_file(t.0.join("frames").join("f_0003.exr")).unwrap();
    std::fs::remove_file(t.0.join("frames").join("f_0002.exr")).unwrap();
    let e = err(&["flicker", &t.s("frames"), "--reference", &t.s("ref")]);
    assert!(e.contains("holds 1 numbered frames") && e.contains("at least 2"), "{e}");
}
