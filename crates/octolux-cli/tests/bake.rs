//! `octolux bake` and `render --cache` (issue 13, docs/guide/baking.md): a render from a cache
//! reproduces the uncached render bit for bit from two cameras; stale, truncated, corrupt,
//! future-version and foreign files are refused with their messages; camera paths and the
//! scene's sensors render numbered frames, and `--frames` renders exactly a part of them.
//! Tiny renders (24², 2 spp, 20 000 photons): the whole file runs in seconds.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A box with a red wall, a sphere and an area light; `$cx` moves the first camera, `$mat`,
/// `$radius` and `$light` change materials, geometry and emitters. Two sensors.
const SCENE: &str = r#"<scene version="3.0.0">
    <default name="cx" value="0"/>
    <default name="mat" value="0.7"/>
    <default name="radius" value="0.3"/>
    <default name="light" value="15"/>
    <sensor type="perspective">
        <float name="fov" value="70"/>
        <transform name="to_world"><lookat origin="$cx, 1, 2.9" target="0, 0.9, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/></film>
    </sensor>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="0.7, 1.6, 2.5" target="-0.3, 0.5, -0.5" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/></film>
    </sensor>
    <bsdf type="diffuse" id="white"><rgb name="reflectance" value="$mat"/></bsdf>
    <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.7, 0.1, 0.1"/></bsdf>
    <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform><ref id="white"/></shape>
    <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><translate y="2"/></transform><ref id="white"/></shape>
    <shape type="rectangle"><transform name="to_world"><translate y="1" z="-1"/></transform><ref id="white"/></shape>
    <shape type="rectangle"><transform name="to_world"><rotate y="1" angle="90"/><translate x="-1" y="1"/></transform><ref id="red"/></shape>
    <shape type="rectangle"><transform name="to_world"><rotate y="1" angle="-90"/><translate x="1" y="1"/></transform><ref id="white"/></shape>
    <shape type="sphere"><point name="center" x="0.3" y="0.3" z="0"/><float name="radius" value="$radius"/><ref id="white"/></shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.3"/><rotate x="1" angle="90"/><translate y="1.99"/></transform>
        <emitter type="area"><rgb name="radiance" value="$light"/></emitter>
    </shape>
</scene>
"#;

/// The photon and render settings every command of these tests shares.
const PHOTONS: &[&str] = &["--photons", "20000", "--seed", "3"];
const RENDER: &[&str] = &["--spp", "2", "-q"];

struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let path = std::env::temp_dir().join(format!("octolux-bake-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).expect("temp dir");
        std::fs::write(path.join("scene.xml"), SCENE).expect("scene");
        TempDir(path)
    }
    fn p(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
    fn s(&self, name: &str) -> String {
        self.p(name).to_string_lossy().into_owned()
    }
    fn files(&self) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(&self.0).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn octolux(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octolux")).args(args).output().expect("octolux runs")
}

fn ok(args: &[&str]) -> Output {
    let o = octolux(args);
    assert!(o.status.success(), "octolux {args:?} failed: {}", String::from_utf8_lossy(&o.stderr));
    o
}

/// The one-line error of a refused command.
fn refused(args: &[&str]) -> String {
    let o = octolux(args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "octolux {args:?} should fail: {err}");
    // warnings (the scene's second sensor) come first; the error is the last line
    let last = err.lines().last().unwrap_or("").to_string();
    assert!(last.starts_with("error: ") && !err.contains("panicked"), "{err}");
    last
}

fn bake(t: &TempDir, out: &str, extra: &[&str]) {
    let scene = t.s("scene.xml");
    let out = t.s(out);
    let mut a = vec!["bake", scene.as_str(), "-o", out.as_str(), "-q"];
    a.extend_from_slice(PHOTONS);
    a.extend_from_slice(extra);
    ok(&a);
}

fn render(t: &TempDir, out: &str, extra: &[&str]) -> Output {
    let scene = t.s("scene.xml");
    let out = t.s(out);
    let mut a = vec!["render", scene.as_str(), "-o", out.as_str()];
    a.extend_from_slice(RENDER);
    a.extend_from_slice(extra);
    ok(&a)
}

fn bytes(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn a_render_from_the_cache_is_the_uncached_render_bit_for_bit_from_two_cameras() {
    let t = TempDir::new("identical");
    bake(&t, "light.oxc", &[]);
    let cache = t.s("light.oxc");
    for (name, camera) in [("a", "cx=0"), ("b", "cx=0.8")] {
        let mut uncached = vec!["--integrator", "octree", "-D", camera];
        uncached.extend_from_slice(PHOTONS);
        render(&t, &format!("{name}-built.exr"), &uncached);
        // the render's own seed is the bake's photon seed: --seed 3 on both sides
        render(&t, &format!("{name}-cached.exr"), &["--cache", &cache, "-D", camera, "--seed", "3"]);
        let (built, cached) = (bytes(&t.p(&format!("{name}-built.exr"))), bytes(&t.p(&format!("{name}-cached.exr"))));
        assert!(built == cached, "camera {camera}: the cached render differs from the uncached one");
        let json: serde_json::Value = serde_json::from_slice(&bytes(&t.p(&format!("{name}-cached.json")))).unwrap();
        assert!(json["cache"]["load_s"].as_f64().is_some() && json["cache"]["stale"].is_null(), "{}", json["cache"]);
        assert_eq!(json["build"]["photons_emitted"], 20000);
    }
    assert!(bytes(&t.p("a-cached.exr")) != bytes(&t.p("b-cached.exr")), "two cameras, one image");
    // view and gather may change with a cache; the irradiance view still reads the octrees
    render(&t, "irr.exr", &["--cache", &cache, "--view", "irradiance"]);
}

#[test]
fn a_cache_is_refused_when_the_lighting_changed_and_used_when_only_the_camera_did() {
    let t = TempDir::new("stale");
    bake(&t, "light.oxc", &[]);
    let (scene, cache, out) = (t.s("scene.xml"), t.s("light.oxc"), t.s("out.exr"));
    let base = ["render", scene.as_str(), "-o", out.as_str(), "--spp", "1", "-q", "--cache", cache.as_str()];
    for (define, what) in
        [("radius=0.35", "the geometry changed"), ("mat=0.5", "the materials changed"), ("light=10", "the emitters changed")]
    {
        let mut a = base.to_vec();
        a.extend(["-D", define]);
        let e = refused(&a);
        assert!(e.contains(what) && e.contains(&cache) && e.contains("--allow-stale-cache"), "{define}: {e}");
        a.push("--allow-stale-cache");
        let o = ok(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("warning: ") && err.contains(what), "{define}: {err}");
    }
    let mut a = base.to_vec();
    a.extend(["-D", "mat=0.5", "-D", "light=9"]);
    assert!(refused(&a).contains("the materials, emitters changed since it was baked"));
    // settings that shaped the octrees cannot change; another integrator cannot use the cache
    for (flags, word, values) in [
        (&["--set", "global.h_max=4"][..], "global.h_max", "global.h_max = 4 here, \"auto\" in the bake"),
        (&["--photons", "100"][..], "photons.photons", "photons.photons = 100 here, 20000 in the bake"),
        (&["--max-depth", "3"][..], "max_depth", "max_depth = 3 here, -1 in the bake"),
    ] {
        let mut a = base.to_vec();
        a.extend_from_slice(flags);
        let e = refused(&a);
        assert!(e.contains(&format!("the settings {word} differ from the bake's ({values})")), "{flags:?}: {e}");
        // the keys that may change are named, the baked ones are not among them
        let free = e.split("with --cache only ").nth(1).unwrap_or("");
        assert!(free.contains("mode, ") && free.ends_with("view may change)"), "{flags:?}: {e}");
        assert!(!free.contains(" photons") && !free.contains("global") && !free.contains("max_depth"), "{flags:?}: {e}");
    }
    let mut a = base.to_vec();
    a.extend(["--integrator", "path"]);
    assert!(refused(&a).contains("--integrator path cannot render from it"));
    // the film may change
    let mut a = base.to_vec();
    a.extend(["--resolution", "16x8"]);
    ok(&a);
}

#[test]
fn broken_cache_files_are_refused_with_their_name_before_the_scene_is_read() {
    let t = TempDir::new("broken");
    bake(&t, "light.oxc", &[]);
    let good = bytes(&t.p("light.oxc"));
    let fix_crc = |mut b: Vec<u8>| {
        let n = b.len() - 4;
        let crc = octolux_io::cache::crc32(&b[..n]);
        b[n..].copy_from_slice(&crc.to_le_bytes());
        b
    };
    let mut future = good.clone();
    future[8..12].copy_from_slice(&(octolux_io::cache::FORMAT_VERSION + 1).to_le_bytes());
    let mut flipped = good.clone();
    flipped[good.len() / 2] ^= 0x10;
    let mut magic = good.clone();
    magic[0] = b'P';
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty", vec![], "too short"),
        ("truncated", good[..good.len() - 100].to_vec(), "truncated"),
        ("longer", [good.as_slice(), b"junk"].concat(), "after the end"),
        ("flipped", flipped, "corrupt: checksum"),
        ("future", fix_crc(future), "written by a newer octolux"),
        ("magic", magic, "not an octolux cache file"),
    ];
    // the scene does not even exist: the cache is checked first
    for (name, data, word) in cases {
        let path = t.s(&format!("{name}.oxc"));
        std::fs::write(&path, &data).unwrap();
        let out = t.s("out.exr");
        let e = refused(&["render", "no-such-scene.xml", "--cache", &path, "-o", &out]);
        assert!(e.contains(&path) && e.contains(word), "{name}: {e}");
    }
    let missing = t.s("missing.oxc");
    assert!(refused(&["render", "--cache", &missing]).contains(&missing));
    assert!(!t.files().iter().any(|f| f.starts_with("out")), "{:?}", t.files());
}

#[test]
fn camera_paths_and_sensors_render_numbered_frames_and_a_part_equals_the_whole() {
    let t = TempDir::new("frames");
    std::fs::write(
        t.p("path.json"),
        r#"{"fps": 2, "keyframes": [
            {"time": 0, "position": [-0.6, 1, 2.9], "target": [0, 0.9, 0], "fov": 70},
            {"time": 1, "position": [0, 1.2, 2.5], "target": [0, 0.8, 0], "fov": 60},
            {"time": 1.5, "position": [0.6, 1, 2.9], "target": [0, 0.9, 0], "up": [0, 1, 0], "fov": 70}]}"#,
    )
    .unwrap();
    bake(&t, "light.oxc", &[]);
    let (cache, path) = (t.s("light.oxc"), t.s("path.json"));
    render(&t, "full-f.exr", &["--cache", &cache, "--camera-path", &path]);
    render(&t, "part.exr", &["--cache", &cache, "--camera-path", &path, "--frames", "2..3"]);
    let files = t.files();
    let frames = |prefix: &str| files.iter().filter(|f| f.starts_with(prefix)).cloned().collect::<Vec<_>>();
    let full = frames("full-f_");
    assert_eq!(full.len(), 4 * 3, "4 frames x exr, png, json: {files:?}");
    assert_eq!(frames("part"), ["part_0002.exr", "part_0002.json", "part_0002.png", "part_0003.exr", "part_0003.json", "part_0003.png"]);
    for i in [2, 3] {
        assert!(bytes(&t.p(&format!("part_{i:04}.exr"))) == bytes(&t.p(&format!("full-f_{i:04}.exr"))), "frame {i}");
    }
    assert!(bytes(&t.p("full-f_0001.exr")) != bytes(&t.p("full-f_0002.exr")), "the camera moves");
    let json: serde_json::Value = serde_json::from_slice(&bytes(&t.p("part_0003.json"))).unwrap();
    assert_eq!(
        (json["frame"]["index"].as_u64(), json["frame"]["count"].as_u64(), json["frame"]["time_s"].as_f64()),
        (Some(3), Some(4), Some(1.0))
    );
    // the sensors: frame 1 is the first sensor, which a single image uses
    render(&t, "sensor.exr", &["--cache", &cache, "--sensors", "--seed", "3"]);
    render(&t, "single.exr", &["--cache", &cache, "--seed", "3"]);
    assert!(bytes(&t.p("sensor_0001.exr")) == bytes(&t.p("single.exr")));
    assert!(t.p("sensor_0002.exr").exists() && !t.p("sensor_0003.exr").exists());
    // without a cache the photons are traced once for all frames
    let o = render(&t, "built.exr", &["--integrator", "octree", "--photons", "20000", "--seed", "3", "--sensors", "--frames", "2"]);
    assert!(bytes(&t.p("built_0002.exr")) == bytes(&t.p("sensor_0002.exr")), "{}", String::from_utf8_lossy(&o.stderr));
    // ranges outside the path, and --frames alone, are refused before any work
    let scene = t.s("scene.xml");
    assert!(refused(&["render", &scene, "--camera-path", &path, "--frames", "3..5"]).contains("makes 4 frames"));
    assert!(refused(&["render", &scene, "--frames", "1..2"]).contains("--frames needs --camera-path, --sensors or --insert-path"));
    assert!(refused(&["render", "cornell-box", "--sensors"]).contains("has no <sensor>"));
    std::fs::write(t.p("bad.json"), r#"{"keyframes": [{"time": 0, "position": [0,1,2], "target": [0,1,2], "fov": 40}]}"#).unwrap();
    let bad = t.s("bad.json");
    let e = refused(&["render", &scene, "--camera-path", &bad]);
    assert!(e.contains(&bad) && e.contains("keyframe 1: target is the position"), "{e}");
}
