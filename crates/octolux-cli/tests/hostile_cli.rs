//! The command line under hostile input and failing disks (issue 12, CLI side): each case with
//! the exact message it must give (docs/guide/errors.md lists them). Cases that need a tmpfs mount
//! (disk full, read-only folder) print one line and pass where mounting is not allowed.

use octolux::budget;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A fresh folder for one test, removed on drop (unmounted first if a tmpfs was put there).
struct TempDir {
    path: PathBuf,
    mounted: bool,
}

impl TempDir {
    fn new(name: &str) -> Self {
        let path = std::env::temp_dir().join(format!("octolux-hostile-cli-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).expect("temp dir");
        TempDir { path, mounted: false }
    }

    /// Mount a tmpfs with `options` on this folder; false (after printing why) where not allowed.
    fn mount_tmpfs(&mut self, options: &str, test: &str) -> bool {
        let ok = Command::new("mount")
            .args(["-t", "tmpfs", "-o", options, "tmpfs"])
            .arg(&self.path)
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            println!("skipped {test}: cannot mount a tmpfs here (needs root)");
        }
        self.mounted = ok;
        ok
    }

    fn files(&self) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(&self.path)
            .expect("read dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if self.mounted {
            let _ = Command::new("umount").arg(&self.path).status();
        }
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

fn octolux() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_octolux"));
    c.env_remove(budget::MEMORY_LIMIT_ENV);
    c
}

fn run(args: &[&str]) -> Output {
    octolux().args(args).output().expect("octolux runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A small Mitsuba scene: `integrator` type, `spp` (the sampler's sample_count, through the
/// `$spp` default), and a `width`x8 film.
fn scene_xml(integrator: &str, spp: &str, width: u64) -> String {
    format!(
        r#"<scene version="3.0.0">
    <default name="spp" value="{spp}"/>
    <integrator type="{integrator}"/>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="8"/></film>
    </sensor>
    <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1,1,1"/></emitter></shape>
</scene>
"#
    )
}

fn write_scene(dir: &TempDir, integrator: &str, spp: &str, width: u64) -> String {
    let p = dir.path.join("scene.xml");
    std::fs::write(&p, scene_xml(integrator, spp, width)).expect("write scene");
    p.to_string_lossy().into_owned()
}

fn path_str(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

#[test]
fn sizes_beyond_the_memory_budget_are_refused_before_any_work() {
    let dir = TempDir::new("budget");
    let out = path_str(&dir.path.join("x.exr"));
    // The largest --resolution accepted by the parser, against a 1 GiB limit.
    let o = run(&["render", "cornell-box", "--resolution", "32768x32768", "--memory-limit", "1G", "-q", "-o", &out]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        stderr(&o),
        "error: --resolution: a 32768x32768 film would need 64.0 GiB of memory, more than the limit of 1.0 GiB \
         (set OCTOLUX_MEMORY_LIMIT to change the limit)\n"
    );
    // The same limit from the environment.
    let o = octolux()
        .env(budget::MEMORY_LIMIT_ENV, "1G")
        .args(["render", "cornell-box", "--resolution", "32768x32768", "-q", "-o", &out])
        .output()
        .expect("runs");
    assert!(stderr(&o).starts_with("error: --resolution: a 32768x32768 film would need 64.0 GiB"), "{}", stderr(&o));
    // A malformed limit is an error, not ignored.
    let o = octolux().env(budget::MEMORY_LIMIT_ENV, "lots").args(["render", "-q", "-o", &out]).output().expect("runs");
    assert_eq!(
        stderr(&o),
        "error: OCTOLUX_MEMORY_LIMIT=\"lots\" is not a memory size (expected bytes with an optional K, M, G or T suffix)\n"
    );
    // 10^12 photons.
    let o =
        run(&["render", "cornell-box", "--integrator", "octree", "--photons", "1000000000000", "--memory-limit", "4G", "-q", "-o", &out]);
    let need = budget::format_bytes(1_000_000_000_000 * budget::PHOTON_BYTES);
    assert_eq!(
        stderr(&o),
        format!(
            "error: the photon count (--photons or photons.photons): 1000000000000 photons would need {need} of memory, \
             more than the limit of 4.0 GiB (set OCTOLUX_MEMORY_LIMIT to change the limit)\n"
        )
    );
    // A film of the scene file (checked by the loader, naming file and line).
    let scene = write_scene(&dir, "path", "4", 32768);
    let o = run(&["render", &scene, "--memory-limit", "1M", "-q", "-o", &out]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(e.contains(&format!("{scene}:8")), "names file and line: {e}");
    assert!(e.contains("a 32768x8 film would need 16.0 MiB of memory, more than the limit of 1.0 MiB"), "{e}");
    let o = run(&["render", "--memory-limit", "1Q", "-q", "-o", &out]);
    assert_eq!(stderr(&o), "error: --memory-limit 1Q: expected a memory size (bytes with an optional K, M, G or T suffix)\n");
    assert_eq!(dir.files(), vec!["scene.xml"], "nothing written");
}

#[test]
fn the_output_folder_is_checked_before_the_scene_is_read() {
    let dir = TempDir::new("outdir");
    // A missing folder is created (issue 30), and removed again when the run fails: here on the
    // scene, which does not exist.
    let missing = dir.path.join("missing").join("deeper").join("x.exr");
    let o = run(&["render", "no-such-scene.xml", "-q", "-o", &path_str(&missing)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no-such-scene.xml"), "{}", stderr(&o));
    assert!(!dir.path.join("missing").exists(), "the folders created for a failed run stay");

    std::fs::create_dir(dir.path.join("x.exr")).expect("mkdir");
    let out = path_str(&dir.path.join("x.exr"));
    let o = run(&["render", "no-such-scene.xml", "-q", "-o", &out]);
    assert_eq!(stderr(&o), format!("error: output path '{out}' is a folder\n"));
    std::fs::create_dir(dir.path.join("y.json")).expect("mkdir");
    let o = run(&["render", "no-such-scene.xml", "-q", "-o", &path_str(&dir.path.join("y.exr"))]);
    assert_eq!(stderr(&o), format!("error: output path '{}' is a folder\n", dir.path.join("y.json").display()));

    let file = dir.path.join("plain");
    std::fs::write(&file, "").expect("write");
    let o = run(&["render", "no-such-scene.xml", "-q", "-o", &path_str(&file.join("x.exr"))]);
    assert_eq!(stderr(&o), format!("error: output folder '{}' is not a folder\n", file.display()));
    let o = run(&["render", "-q", "-o", &path_str(&dir.path.join("x.png"))]);
    assert_eq!(
        stderr(&o),
        format!("error: output '{}' must end in .exr (a .png and a .json are written beside it)\n", dir.path.join("x.png").display())
    );
    assert_eq!(dir.files(), vec!["plain", "x.exr", "y.json"]);
}

#[test]
fn a_missing_output_folder_is_created() {
    let dir = TempDir::new("newdir");
    // one image into two new folders: the log says so, the set is written there
    let out = dir.path.join("a").join("b").join("x.exr");
    let o = run(&["render", "--resolution", "4x4", "--spp", "1", "-o", &path_str(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains(&format!("created the output folder '{}'", out.parent().unwrap().display())), "{}", stderr(&o));
    for ext in ["exr", "png", "json"] {
        assert!(out.with_extension(ext).is_file(), "{ext}");
    }
    // the frames of a camera path into a new folder (the Dask farm made it; the CLI refused)
    let path = dir.path.join("path.json");
    std::fs::write(
        &path,
        r#"{"fps": 1, "keyframes": [{"time": 0, "position": [278, 273, -800], "target": [278, 273, 0], "fov": 40},
           {"time": 1, "position": [300, 273, -800], "target": [278, 273, 0], "fov": 40}]}"#,
    )
    .expect("write path");
    let frames = dir.path.join("frames").join("f.exr");
    let o = run(&["render", "--resolution", "4x4", "--spp", "1", "--camera-path", &path_str(&path), "-q", "-o", &path_str(&frames)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.path.join("frames").join("f_0001.exr").is_file() && dir.path.join("frames").join("f_0002.exr").is_file());
    // a bake and a report too
    let oxc = dir.path.join("c").join("l.oxc");
    let o = run(&["bake", "--photons", "1000", "-q", "-o", &path_str(&oxc)]);
    assert!(o.status.success() && oxc.is_file(), "{}", stderr(&o));
    let page = dir.path.join("d").join("r.html");
    let o = run(&["report", &path_str(&out), "-o", &path_str(&page)]);
    assert!(o.status.success() && page.is_file(), "{}", stderr(&o));
    // what cannot be a folder is still refused, naming it
    let file = dir.path.join("plain");
    std::fs::write(&file, "").expect("write");
    let o = run(&["render", "-q", "-o", &path_str(&file.join("sub").join("x.exr"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(&format!("'{}'", file.join("sub").display())), "{}", stderr(&o));
}

#[test]
fn a_read_only_output_folder_is_refused_before_any_work() {
    let mut dir = TempDir::new("readonly");
    if !dir.mount_tmpfs("ro,size=64k", "a_read_only_output_folder_is_refused_before_any_work") {
        return;
    }
    let o = run(&["render", "no-such-scene.xml", "-q", "-o", &path_str(&dir.path.join("x.exr"))]);
    assert_eq!(stderr(&o), format!("error: output folder '{}' is not writable: Read-only file system (os error 30)\n", dir.path.display()));
}

#[test]
fn a_full_disk_leaves_the_previous_outputs_and_no_new_file() {
    let mut dir = TempDir::new("full");
    // tmpfs counts whole pages: the 4x4 set takes 3 of the 8, a 96x96 EXR alone needs more.
    if !dir.mount_tmpfs("size=32k", "a_full_disk_leaves_the_previous_outputs_and_no_new_file") {
        return;
    }
    let out = path_str(&dir.path.join("x.exr"));
    let small = run(&["render", "cornell-box", "--resolution", "4x4", "--spp", "1", "-q", "-o", &out]);
    assert!(small.status.success(), "{}", stderr(&small));
    let before: Vec<Vec<u8>> = ["x.exr", "x.json", "x.png"].iter().map(|f| std::fs::read(dir.path.join(f)).expect("read")).collect();
    let big = run(&["render", "cornell-box", "--resolution", "96x96", "--spp", "1", "--seed", "7", "-q", "-o", &out]);
    assert_eq!(big.status.code(), Some(1));
    let e = stderr(&big);
    assert!(e.starts_with(&format!("error: cannot write {out}: ")) && e.contains("No space left on device"), "{e}");
    assert_eq!(dir.files(), vec!["x.exr", "x.json", "x.png"], "no staged file left behind");
    let after: Vec<Vec<u8>> = ["x.exr", "x.json", "x.png"].iter().map(|f| std::fs::read(dir.path.join(f)).expect("read")).collect();
    assert!(before == after, "the previous outputs are untouched");
}

#[test]
fn two_renders_to_the_same_path_leave_one_whole_set() {
    let dir = TempDir::new("race");
    let args = |seed: &str, out: &str| -> Vec<String> {
        ["render", "cornell-box", "--resolution", "16x16", "--spp", "2", "-q", "--seed", seed, "-o", out]
            .iter()
            .map(|s| s.to_string())
            .collect()
    };
    // Each seed's set, rendered alone.
    let mut alone = Vec::new();
    for seed in ["1", "2"] {
        let out = path_str(&dir.path.join(format!("alone{seed}.exr")));
        assert!(octolux().args(args(seed, &out)).status().expect("runs").success());
        alone.push((std::fs::read(&out).expect("exr"), std::fs::read(dir.path.join(format!("alone{seed}.png"))).expect("png")));
    }
    let out = path_str(&dir.path.join("x.exr"));
    for round in 0..6 {
        let a = octolux().args(args("1", &out)).stderr(Stdio::piped()).spawn().expect("spawn");
        let b = octolux().args(args("2", &out)).stderr(Stdio::piped()).spawn().expect("spawn");
        let (a, b) = (a.wait_with_output().expect("a"), b.wait_with_output().expect("b"));
        assert!(a.status.success() && b.status.success(), "round {round}: {} {}", stderr(&a), stderr(&b));
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path.join("x.json")).expect("json")).expect("valid JSON");
        let seed = json["seed"].as_u64().expect("seed") as usize;
        let (exr, png) = (std::fs::read(&out).expect("exr"), std::fs::read(dir.path.join("x.png")).expect("png"));
        assert!(exr == alone[seed - 1].0 && png == alone[seed - 1].1, "round {round}: the set mixes two runs");
        let stray: Vec<String> = dir.files().into_iter().filter(|f| f.starts_with('.')).collect();
        assert!(stray.is_empty(), "round {round}: left behind {stray:?}");
    }
}

/// Start a render, wait for its stderr line starting with `marker` and then `wait`, send
/// `signals` (`kill -s` names) a moment apart, and return its output and how long it took to
/// exit after them.
fn interrupt(args: &[&str], marker: &str, wait: Duration, signals: &[&str]) -> (Output, Duration) {
    let mut child = octolux().args(args).stderr(Stdio::piped()).stdout(Stdio::null()).spawn().expect("spawn");
    let mut err = BufReader::new(child.stderr.take().expect("stderr"));
    let mut seen = String::new();
    loop {
        let mut line = String::new();
        if err.read_line(&mut line).expect("read") == 0 {
            panic!("octolux ended before '{marker}': {seen}");
        }
        seen.push_str(&line);
        if line.starts_with(marker) {
            break;
        }
    }
    std::thread::sleep(wait);
    let pid = child.id().to_string();
    for s in signals {
        assert!(Command::new("kill").args(["-s", s, &pid]).status().expect("kill").success());
        std::thread::sleep(Duration::from_millis(50));
    }
    let t = Instant::now();
    let reader = std::thread::spawn(move || {
        let mut rest = String::new();
        let _ = std::io::Read::read_to_string(&mut err, &mut rest);
        rest
    });
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        assert!(t.elapsed() < Duration::from_secs(60), "octolux did not stop on {signals:?}");
        std::thread::sleep(Duration::from_millis(20));
    };
    let took = t.elapsed();
    seen.push_str(&reader.join().expect("reader"));
    (Output { status, stdout: Vec::new(), stderr: seen.into_bytes() }, took)
}

#[test]
fn an_interrupted_progressive_render_writes_its_passes_marked_partial() {
    for signal in ["INT", "TERM"] {
        let dir = TempDir::new(&format!("sig{signal}"));
        let out = path_str(&dir.path.join("x.exr"));
        let args = ["render", "cornell-box", "--resolution", "32x32", "--spp", "1", "--time-budget", "600", "-o", &out];
        let (o, took) = interrupt(&args, "octolux: cornell-box", Duration::from_millis(1500), &[signal]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(130), "{e}");
        assert!(took < Duration::from_secs(10), "took {took:?} to stop");
        assert!(e.contains("octolux: interrupted; writing the passes done so far (interrupt again to exit at once)"), "{e}");
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path.join("x.json")).expect("json")).expect("JSON");
        let p = &json["partial"];
        assert_eq!(p["reason"], "interrupted", "{json}");
        let passes = p["passes"].as_u64().expect("passes");
        assert!(passes >= 1, "{p}");
        assert_eq!(p["spp"].as_u64(), Some(passes), "{p}");
        assert_eq!(p["samples"].as_u64(), Some(passes * 32 * 32), "{p}");
        assert_eq!(json["render"]["interrupted"], true);
        assert!(e.contains(&format!("octolux: interrupted after {passes} passes ({passes} spp); wrote the partial image to {out}")), "{e}");
        let img = octolux_io::image_io::read_exr(Path::new(&out)).expect("a readable EXR");
        assert!(img.data.iter().any(|c| c.x > 0.0), "the passes done are in the image");
        assert_eq!(dir.files(), vec!["x.exr", "x.json", "x.png"]);
    }
}

#[test]
fn a_signal_before_the_render_loop_exits_at_once_and_writes_nothing() {
    // The photon pass of 20M photons takes far longer than the wait; nothing is saved yet.
    let dir = TempDir::new("sigbuild");
    let out = path_str(&dir.path.join("x.exr"));
    let args = ["render", "cornell-box", "--integrator", "photonmap", "--photons", "20000000", "--resolution", "8x8", "-o", &out];
    let (o, took) = interrupt(&args, "photonmap: tracing", Duration::from_millis(200), &["INT"]);
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(took < Duration::from_secs(2), "took {took:?} to exit");
    assert!(stderr(&o).ends_with("octolux: interrupted; exiting without writing\n"), "{}", stderr(&o));
    assert!(dir.files().is_empty(), "{:?}", dir.files());
}

#[test]
fn an_interrupted_bake_exits_at_once_and_keeps_the_previous_cache() {
    // 20M photons take far longer than the wait: the signal comes during the photon pass.
    let dir = TempDir::new("sigbake");
    let out = dir.path.join("x.oxc");
    std::fs::write(&out, b"the previous cache").expect("write");
    let args = ["bake", "cornell-box", "--photons", "20000000", "-o", &path_str(&out)];
    let (o, took) = interrupt(&args, "octree: tracing", Duration::from_millis(200), &["INT"]);
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(took < Duration::from_secs(2), "took {took:?} to exit");
    assert!(stderr(&o).ends_with("octolux: interrupted; exiting without writing\n"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&out).expect("read"), b"the previous cache");
    assert_eq!(dir.files(), vec!["x.oxc"]);
}

#[test]
fn compare_refuses_non_finite_values_and_counts_them() {
    let dir = TempDir::new("compare");
    let px = |v: f32| octolux::math::Color::new(v, v, v);
    let good = octolux::image::Image { width: 2, height: 2, data: vec![px(0.5); 4] };
    let mut bad = good.clone();
    bad.data[1] = octolux::math::Color::new(f32::NAN, 0.5, f32::INFINITY);
    bad.data[3] = px(f32::NEG_INFINITY);
    let (g, b) = (dir.path.join("good.exr"), dir.path.join("bad.exr"));
    octolux_io::image_io::write_exr(&g, &good).expect("write");
    octolux_io::image_io::write_exr(&b, &bad).expect("write");
    let o = run(&["compare", &path_str(&b), &path_str(&g)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(o.stdout.is_empty());
    assert_eq!(stderr(&o), format!("error: cannot compare: {} holds 5 non-finite values (NaN or infinity) in 2 pixels\n", b.display()));
    let o = run(&["compare", &path_str(&g), &path_str(&b)]);
    assert_eq!(stderr(&o), format!("error: cannot compare: {} holds 5 non-finite values (NaN or infinity) in 2 pixels\n", b.display()));
    let o = run(&["compare", &path_str(&g), &path_str(&g)]);
    assert!(o.status.success(), "{}", stderr(&o));
    // PNGs are read (decoded from sRGB), not refused as unreadable OpenEXR (issue 30)
    let p = dir.path.join("good.png");
    octolux_io::image_io::write_png(&p, &good).expect("write");
    let o = run(&["compare", &path_str(&p), &path_str(&g)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    // 0.5 through 8-bit sRGB and back: within half a step
    assert!(json["rel_mse"].as_f64().is_some_and(|e| e < 1e-4), "{json}");
    let o = run(&["compare", &path_str(&dir.path.join("good.json")), &path_str(&g)]);
    assert_eq!(
        stderr(&o),
        format!(
            "error: cannot read the image: {}: unsupported image format '.json' (expected png, jpg, exr or hdr)\n",
            dir.path.join("good.json").display()
        )
    );
}

#[test]
fn scene_inputs_that_used_to_be_dropped_silently_warn() {
    let dir = TempDir::new("silent");
    let out = path_str(&dir.path.join("x.exr"));
    let scene = write_scene(&dir, "path", "1", 8);
    // An unused -D warns; one that overrides a <default> does not.
    let o = run(&["render", &scene, "-D", "nosuch=3", "-D", "spp=2", "-q", "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), format!("warning: -D nosuch=3 is unused: {scene} has no <default name=\"nosuch\"> and no $nosuch\n"));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path.join("x.json")).expect("json")).expect("JSON");
    assert_eq!(json["render_settings"]["spp"], 2, "the used define applies");
    assert!(json["warnings"][0].as_str().is_some_and(|w| w.starts_with("-D nosuch=3 is unused")), "{json}");

    let o = run(&["render", "cornell-box", "-D", "spp=2", "--resolution", "4x4", "--spp", "1", "-q", "-o", &out]);
    assert_eq!(stderr(&o), "warning: -D is ignored: 'cornell-box' is not a Mitsuba XML scene (it has no parameters)\n");

    // sample_count 2^32 is too large, not "not positive".
    let scene = write_scene(&dir, "path", "4294967296", 8);
    let o = run(&["render", &scene, "-q", "-o", &out]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("sample_count 4294967296 is too large (at most 4294967295)"), "{}", stderr(&o));

    // An integrator octolux does not know renders path with a warning; another method that
    // converges to the same image (bdpt) with a note; a path tracer's says nothing.
    let scene = write_scene(&dir, "whitted", "1", 8);
    let o = run(&["render", &scene, "-q", "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        format!(
            "warning: scene '{scene}': <integrator type=\"whitted\"> is not an octolux integrator; rendering with path \
             (choose one with --integrator: path, octree, photonmap, ward, christensen)\n"
        )
    );
    let scene = write_scene(&dir, "bdpt", "1", 8);
    let o = run(&["render", &scene, "-q", "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        format!(
            "note: scene '{scene}': <integrator type=\"bdpt\"> converges to the image a path tracer converges to; \
             rendering with path (choose another with --integrator: path, octree, photonmap, ward, christensen)\n"
        )
    );
    let o = run(&["render", &scene, "--integrator", "path", "-q", "-o", &out]);
    assert_eq!(stderr(&o), "", "chosen on the command line: nothing to say");
    let scene = write_scene(&dir, "volpath", "1", 8);
    let o = run(&["render", &scene, "-q", "-o", &out]);
    assert_eq!(stderr(&o), "");
}

/// Lights that emit nothing: a zero-area emitter (the loader's two warnings, then the CLI's
/// "no light"), zero radiance (a light that is there but dark), and a photon integrator on a
/// scene without light (a clear error, each cause said once).
#[test]
fn lights_that_emit_nothing_warn() {
    let dir = TempDir::new("dark");
    let out = path_str(&dir.path.join("x.exr"));
    let scene_file = dir.path.join("scene.xml");
    let scene = path_str(&scene_file);
    let write = |emitter: &str| {
        let xml = scene_xml("path", "1", 8).replace(
            "<shape type=\"rectangle\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"1,1,1\"/></emitter></shape>",
            &format!("{emitter}\n<shape type=\"cube\"><transform name=\"to_world\"><translate z=\"-3\"/></transform></shape>"),
        );
        std::fs::write(&scene_file, xml).expect("write scene");
    };
    write("<shape type=\"rectangle\"><transform name=\"to_world\"><scale value=\"0\"/></transform>\n<emitter type=\"area\"/></shape>");
    let o = run(&["render", &scene, "-q", "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        format!(
            "warning: {scene}:10: <shape type=\"rectangle\">: to_world is singular (determinant 0): the shape has zero area and is skipped\n\
             warning: {scene}:11: <emitter type=\"area\">: its shape has zero area: the emitter emits nothing\n\
             warning: the scene has no light; the image will be black\n"
        )
    );
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path.join("x.json")).expect("json")).expect("JSON");
    assert_eq!(json["warnings"][2], "the scene has no light; the image will be black", "{json}");
    let o = run(&["render", &scene, "--integrator", "octree", "--photons", "1000", "-q", "-o", &out]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).ends_with("error: cannot build the integrator: octree: the scene has no light to emit photons from\n"),
        "{}",
        stderr(&o)
    );
    let o = run(&["render", &scene, "--integrator", "photonmap", "--photons", "1000", "-q", "-o", &out]);
    assert!(
        stderr(&o).ends_with("error: cannot build the integrator: photonmap: the scene has no light to emit photons from\n"),
        "{}",
        stderr(&o)
    );

    write("<shape type=\"rectangle\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"0\"/></emitter></shape>");
    let o = run(&["render", &scene, "-q", "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "warning: the scene's lights emit nothing (zero radiance, intensity or area); the image will be black\n");
}

/// A camera path file `path.json` in `dir`: `fps` and keys of (time, position, target), fov 40.
fn write_camera_path(dir: &TempDir, fps: f64, keys: &[(f64, [f32; 3], [f32; 3])]) -> PathBuf {
    let keys: Vec<serde_json::Value> =
        keys.iter().map(|(t, p, target)| serde_json::json!({"time": t, "position": p, "target": target, "fov": 40})).collect();
    let path = dir.path.join("path.json");
    std::fs::write(&path, serde_json::json!({"fps": fps, "keyframes": keys}).to_string()).expect("write");
    path
}

/// Make a FIFO at `p` (`mkfifo`).
fn mkfifo(p: &Path) {
    assert!(Command::new("mkfifo").arg(p).status().expect("mkfifo runs").success(), "mkfifo {}", p.display());
}

/// Is `p` (not following links) a FIFO, a character device? The file type as `stat` names it.
fn file_type(p: &Path) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let Ok(m) = std::fs::symlink_metadata(p) else { return "missing" };
    let t = m.file_type();
    if t.is_fifo() {
        "fifo"
    } else if t.is_char_device() {
        "char"
    } else if t.is_socket() {
        "socket"
    } else if t.is_symlink() {
        "link"
    } else if t.is_dir() {
        "dir"
    } else {
        "file"
    }
}

/// Issue 27, item 1: an output that exists and is not a regular file is refused, by every
/// writer, before any work; the node is left as it was. `/dev/null` itself is only given to
/// `bake`, whose check refuses it before the scene is read (a character device made here with
/// `mknod`, where allowed, stands in for it everywhere else).
#[test]
fn outputs_that_are_not_regular_files_are_refused() {
    let dir = TempDir::new("nodes");
    let fifo = dir.path.join("fifo.exr");
    mkfifo(&fifo);
    let fifo_s = path_str(&fifo);
    let refused = |p: &Path, kind: &str| {
        format!("error: output '{}' is {kind}, not a regular file: octolux replaces only regular files\n", p.display())
    };
    // The scene does not exist: the output is reported, so it was checked first.
    let o = run(&["render", "no-such-scene.xml", "-q", "-o", &fifo_s]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(stderr(&o), refused(&fifo, "a FIFO (named pipe)"));
    // a FIFO where the PNG of the set would go
    let png = dir.path.join("x.png");
    mkfifo(&png);
    let o = run(&["render", "cornell-box", "--resolution", "4x4", "--spp", "1", "-q", "-o", &path_str(&dir.path.join("x.exr"))]);
    assert_eq!(stderr(&o), refused(&png, "a FIFO (named pipe)"));
    // a link to a FIFO
    let link = dir.path.join("link.exr");
    std::os::unix::fs::symlink(&fifo, &link).expect("symlink");
    let o = run(&["render", "no-such-scene.xml", "-q", "-o", &path_str(&link)]);
    assert_eq!(
        stderr(&o),
        format!(
            "error: output '{}' is a link to a FIFO (named pipe) ('{fifo_s}'), not to a regular file: octolux replaces only regular files\n",
            link.display()
        )
    );
    // bake, report and export, each to a FIFO
    let oxc = dir.path.join("fifo.oxc");
    mkfifo(&oxc);
    let o = run(&["bake", "cornell-box", "--photons", "1000", "-q", "-o", &path_str(&oxc)]);
    assert_eq!(stderr(&o), refused(&oxc, "a FIFO (named pipe)"));
    let img = dir.path.join("a.exr");
    let px = octolux::math::Color::new(0.5, 0.5, 0.5);
    octolux_io::image_io::write_exr(&img, &octolux::image::Image { width: 2, height: 2, data: vec![px; 4] }).expect("write");
    let sock = dir.path.join("sock.html");
    let _listener = std::os::unix::net::UnixListener::bind(&sock).expect("bind a socket");
    let o = run(&["report", &path_str(&img), "-o", &path_str(&sock)]);
    assert_eq!(stderr(&o), refused(&sock, "a socket"));
    let xml = dir.path.join("fifo.xml");
    mkfifo(&xml);
    let o = run(&["export", "cornell-box", "-o", &path_str(&xml)]);
    assert_eq!(stderr(&o), refused(&xml, "a FIFO (named pipe)"));
    // /dev/null itself: refused by the check that runs before the scene is read
    let o = run(&["bake", "no-such-scene.xml", "-o", "/dev/null"]);
    assert_eq!(stderr(&o), refused(Path::new("/dev/null"), "a character device"));
    assert_eq!(file_type(Path::new("/dev/null")), "char");
    // a character device node of our own (major 1, minor 3: what /dev/null is), where allowed
    let null = dir.path.join("null.oxc");
    if Command::new("mknod").arg(&null).args(["c", "1", "3"]).stderr(Stdio::null()).status().is_ok_and(|s| s.success()) {
        let o = run(&["bake", "cornell-box", "--photons", "1000", "-q", "-o", &path_str(&null)]);
        assert_eq!(stderr(&o), refused(&null, "a character device"));
        let o = run(&["render", "cornell-box", "--resolution", "4x4", "--spp", "1", "-q", "-o", &path_str(&dir.path.join("null.exr"))]);
        assert!(o.status.success(), "a regular set beside it is fine: {}", stderr(&o));
        assert_eq!(file_type(&null), "char");
    } else {
        println!("skipped the device-node case of outputs_that_are_not_regular_files_are_refused: mknod needs root");
    }
    for p in [&fifo, &png, &oxc, &xml] {
        assert_eq!(file_type(p), "fifo", "{} left as it was", p.display());
    }
    assert_eq!(file_type(&sock), "socket");
    assert_eq!(file_type(&link), "link");
    let stray: Vec<String> = dir.files().into_iter().filter(|f| f.starts_with('.')).collect();
    assert!(stray.is_empty(), "left behind {stray:?}");
}

/// Issue 27, item 1: an output that is one of the run's inputs (by name, through a symbolic
/// link or a hard link: the same device and inode) is refused before any work.
#[test]
fn an_output_that_is_an_input_is_refused() {
    let dir = TempDir::new("same");
    let img = dir.path.join("a.exr");
    let px = octolux::math::Color::new(0.5, 0.5, 0.5);
    octolux_io::image_io::write_exr(&img, &octolux::image::Image { width: 2, height: 2, data: vec![px; 4] }).expect("write");
    let before = std::fs::read(&img).expect("read");
    let (a, hard, soft) = (path_str(&img), dir.path.join("hard.html"), dir.path.join("soft.html"));
    std::fs::hard_link(&img, &hard).expect("hard link");
    std::os::unix::fs::symlink(&img, &soft).expect("symlink");
    let o = run(&["report", &a, "-o", &a]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(stderr(&o), format!("error: output '{a}' is an input of this run: writing it would destroy the input\n"));
    for link in [&hard, &soft] {
        let o = run(&["report", &a, "-o", &path_str(link)]);
        assert_eq!(
            stderr(&o),
            format!(
                "error: output '{}' is an input of this run (the same file as '{a}'): writing it would destroy the input\n",
                link.display()
            )
        );
    }
    let o = run(&["report", &a, "--reference", &path_str(&soft), "-o", &path_str(&hard)]);
    assert!(stderr(&o).contains("is an input of this run (the same file as"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&img).expect("read"), before, "the input is untouched");

    // export s.xml -o s.xml
    let scene = write_scene(&dir, "path", "1", 8);
    let text = std::fs::read(&scene).expect("read");
    let o = run(&["export", &scene, "-o", &scene]);
    assert_eq!(stderr(&o), format!("error: output '{scene}' is an input of this run: writing it would destroy the input\n"));
    assert_eq!(std::fs::read(&scene).expect("read"), text);
    // a settings file where the render's JSON would go, and a bake over its own settings
    let settings = dir.path.join("x.json");
    std::fs::write(&settings, "{}").expect("write");
    let o = run(&["render", "cornell-box", "--settings", &path_str(&settings), "-q", "-o", &path_str(&dir.path.join("x.exr"))]);
    assert_eq!(stderr(&o), format!("error: output '{}' is an input of this run: writing it would destroy the input\n", settings.display()));
    let o = run(&["bake", "cornell-box", "--settings", &path_str(&settings), "-q", "-o", &path_str(&settings)]);
    assert!(stderr(&o).ends_with("is an input of this run: writing it would destroy the input\n"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&settings).expect("read"), b"{}");
    assert!(!dir.path.join("x.exr").exists());
}

/// Issue 27, items 1 and 10: the whole output path is checked before any work, the staging
/// name included (a 234-byte name used to fail once staged), and `-o sub.exr/` fails at once.
#[test]
fn output_names_are_checked_whole_before_any_work() {
    let dir = TempDir::new("names");
    let long = format!("{}.exr", "a".repeat(230));
    let o = run(&["render", "cornell-box", "--resolution", "4x4", "--spp", "1", "-q", "-o", &path_str(&dir.path.join(&long))]);
    assert!(o.status.success(), "a 234-byte name: {}", stderr(&o));
    let stem = "a".repeat(230);
    assert_eq!(dir.files(), vec![long.clone(), format!("{stem}.json"), format!("{stem}.png")]);
    let too_long = format!("{}.exr", "b".repeat(252));
    let o = run(&["render", "no-such-scene.xml", "-q", "-o", &path_str(&dir.path.join(&too_long))]);
    assert_eq!(stderr(&o), format!("error: output name '{too_long}' is 256 bytes long; a file name may have at most 255\n"));
    let slash = format!("{}/", dir.path.join("sub.exr").display());
    let o = run(&["render", "no-such-scene.xml", "-q", "-o", &slash]);
    assert_eq!(stderr(&o), format!("error: output '{slash}' ends in '/': that names a folder, not a file\n"));
    let o = run(&["bake", "no-such-scene.xml", "-q", "-o", &format!("{}/", dir.path.join("x.oxc").display())]);
    assert!(stderr(&o).ends_with("ends in '/': that names a folder, not a file\n"), "{}", stderr(&o));
    // the frames' names are checked as the single output's: a camera path of 2 frames
    let path = write_camera_path(&dir, 1.0, &[(0.0, [0.0, 1.0, 4.0], [0.0, 1.0, 0.0]), (1.0, [1.0, 1.0, 4.0], [0.0, 1.0, 0.0])]);
    let frame_long = format!("{}.exr", "c".repeat(248));
    let o = run(&["render", "cornell-box", "--camera-path", &path_str(&path), "-q", "-o", &path_str(&dir.path.join(&frame_long))]);
    assert_eq!(
        stderr(&o),
        format!("error: output name '{}_0001.exr' is 257 bytes long; a file name may have at most 255\n", "c".repeat(248))
    );
    assert_eq!(dir.files().len(), 4, "nothing else written: {:?}", dir.files());
}

/// Issue 27, item 1: `export` stages its XML and its `meshes/` folder and renames them into
/// place only when all is written; a `meshes` that is not a folder is refused before any work.
#[test]
fn export_stages_its_meshes_and_checks_them_first() {
    let dir = TempDir::new("export");
    let xml = dir.path.join("s.xml");
    let o = run(&["export", "cornell-box", "-o", &path_str(&xml)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(dir.files(), vec!["meshes", "s.xml"]);
    let meshes: Vec<String> = std::fs::read_dir(dir.path.join("meshes"))
        .expect("meshes")
        .map(|e| e.expect("e").file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!meshes.is_empty() && meshes.iter().all(|m| m.ends_with(".ply")), "{meshes:?}");
    // again into the same folder: the files are replaced, nothing staged is left
    let o = run(&["export", "cornell-box", "-o", &path_str(&xml)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(dir.files(), vec!["meshes", "s.xml"]);
    // the exported scene loads back
    let o = run(&["render", &path_str(&xml), "--resolution", "4x4", "--spp", "1", "-q", "-o", &path_str(&dir.path.join("r.exr"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    // a mesh file that is a FIFO is refused, and nothing is renamed (the XML stays the old one)
    let first = dir.path.join("meshes").join(&meshes[0]);
    std::fs::remove_file(&first).expect("rm");
    mkfifo(&first);
    let old = std::fs::read(&xml).expect("xml");
    std::fs::write(&xml, b"previous").expect("write");
    let o = run(&["export", "cornell-box", "-o", &path_str(&xml)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(&format!("output '{}' is a FIFO (named pipe), not a regular file", first.display())), "{}", stderr(&o));
    assert_eq!(std::fs::read(&xml).expect("xml"), b"previous");
    assert_eq!(file_type(&first), "fifo");
    assert!(!old.is_empty());
    let other = TempDir::new("export-file");
    std::fs::write(other.path.join("meshes"), b"a file").expect("write");
    let o = run(&["export", "cornell-box", "-o", &path_str(&other.path.join("s.xml"))]);
    assert_eq!(
        stderr(&o),
        format!(
            "error: cannot export to {}: '{}' is a regular file: the exported meshes go into a folder of that name\n",
            other.path.join("s.xml").display(),
            other.path.join("meshes").display()
        )
    );
    assert_eq!(other.files(), vec!["meshes"]);
    let stray: Vec<String> = dir.files().into_iter().filter(|f| f.starts_with('.')).collect();
    assert!(stray.is_empty(), "left behind {stray:?}");
}

/// Issue 27, item 10: a full disk during `export` leaves neither a partial `meshes/` folder
/// nor an XML (a tmpfs too small for the scene; skipped where mounting is not allowed).
#[test]
fn an_export_on_a_full_disk_leaves_nothing() {
    let mut dir = TempDir::new("export-full");
    if !dir.mount_tmpfs("size=16k", "an_export_on_a_full_disk_leaves_nothing") {
        return;
    }
    let o = run(&["export", "cornell-box", "-o", &path_str(&dir.path.join("s.xml"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("No space left on device"), "{}", stderr(&o));
    assert!(dir.files().is_empty(), "{:?}", dir.files());
}

/// Issue 27, item 5: inputs that are not regular files are refused before a byte is read
/// (`--settings /dev/zero`, `--cache /dev/zero` and `compare /dev/zero x` read until memory ran
/// out); a folder says it is one.
#[test]
fn inputs_that_are_not_regular_files_are_refused() {
    let dir = TempDir::new("inputs");
    let out = path_str(&dir.path.join("x.exr"));
    let dev = "/dev/zero: this is a character device, not a regular file: octolux reads only regular files";
    let o = run(&["render", "cornell-box", "--settings", "/dev/zero", "-q", "-o", &out]);
    assert_eq!(stderr(&o), format!("error: cannot read settings file {dev}\n"));
    let o = run(&["render", "cornell-box", "--cache", "/dev/zero", "-q", "-o", &out]);
    assert_eq!(stderr(&o), format!("error: {dev}\n"));
    let o = run(&["compare", "/dev/zero", &out]);
    assert_eq!(stderr(&o), format!("error: cannot read the image: {dev}\n"));
    let o = run(&["render", "cornell-box", "--camera-path", &path_str(&dir.path), "-q", "-o", &out]);
    assert_eq!(stderr(&o), format!("error: camera path {}: this is a folder, not a file\n", dir.path.display()));
    assert!(dir.files().is_empty());
}

/// Issue 27, item 6: one SIGINT stops a render inside a long tile (`--spp 100000000` on one
/// pixel kept running 40 s after it), and `--threads` is capped at 8 per core with a warning
/// (`--threads 100000` hung); `--insert-ao` is bounded.
#[test]
fn one_interrupt_stops_a_long_tile_and_threads_are_capped() {
    let dir = TempDir::new("longtile");
    let out = path_str(&dir.path.join("x.exr"));
    let args = ["render", "cornell-box", "--resolution", "1x1", "--spp", "100000000", "-o", &out];
    let (o, took) = interrupt(&args, "octolux: cornell-box", Duration::from_millis(500), &["INT"]);
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(took < Duration::from_secs(1), "took {took:?} to stop");
    assert!(stderr(&o).ends_with("octolux: interrupted before the first pass was complete; nothing written\n"), "{}", stderr(&o));
    assert!(dir.files().is_empty());

    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    for n in ["100000", "18446744073709551615"] {
        let o = run(&["render", "cornell-box", "--resolution", "4x4", "--spp", "1", "--threads", n, "-q", "-o", &out]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            stderr(&o),
            format!("warning: --threads {n} is more than 8 per core on this machine's {cores} cores; using {}\n", 8 * cores)
        );
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path.join("x.json")).expect("json")).expect("JSON");
        assert_eq!(json["threads"], 8 * cores as u64);
    }
    let obj = dir.path.join("o.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").expect("write");
    let o = run(&["render", "cornell-box", "--insert", &path_str(&obj), "--insert-ao", "4294967295", "-q", "-o", &out]);
    assert_eq!(stderr(&o), "error: --insert-ao 4294967295: at most 4096 rays per shading point\n");
}

/// Issue 27, item 10: an interrupt after some frames says which were written (it said
/// "nothing written" after 21 frames).
#[test]
fn an_interrupt_after_some_frames_names_the_frames_written() {
    let dir = TempDir::new("sigframes");
    let path = write_camera_path(&dir, 1.0, &[(0.0, [0.0, 1.0, 4.0], [0.0, 1.0, 0.0]), (9.0, [1.0, 1.0, 4.0], [0.0, 1.0, 0.0])]);
    let out = dir.path.join("f.exr");
    let args =
        ["render", "cornell-box", "--camera-path", &path_str(&path), "--resolution", "16x16", "--spp", "3000", "-o", &path_str(&out)];
    let (o, _) = interrupt(&args, "rendered", Duration::from_millis(100), &["INT"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(130), "{e}");
    let last = e.lines().last().unwrap_or("");
    assert!(last.starts_with("octolux: interrupted during frame "), "{e}");
    let written: Vec<String> = dir.files().into_iter().filter(|f| f.ends_with(".exr")).collect();
    assert!(!written.is_empty() && written.len() < 10, "{written:?}");
    assert_eq!(
        last,
        format!(
            "octolux: interrupted during frame {} before its first pass was complete: nothing written for it; the {} frames before it are \
             complete ({} to {})",
            written.len() + 1,
            written.len(),
            dir.path.join("f_0001.exr").display(),
            dir.path.join(&written[written.len() - 1]).display()
        )
    );
}

/// Issue 27, items 7 and 8: every frame of a camera path is checked, not only its keys; a bake
/// made with `--view leaves` does not make later renders write the leaves.
#[test]
fn camera_path_frames_and_baked_views_are_checked() {
    let dir = TempDir::new("frames");
    // valid keys; half-way the position meets the target
    let path = write_camera_path(&dir, 2.0, &[(0.0, [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]), (1.0, [2.0, 1.0, 0.0], [1.0, 1.0, 0.0])]);
    let o = run(&["render", "cornell-box", "--camera-path", &path_str(&path), "-q", "-o", &path_str(&dir.path.join("x.exr"))]);
    assert_eq!(
        stderr(&o),
        format!("error: camera path {}: frame 2 (time 0.5 s, between keyframes): target is the position\n", path.display())
    );
    let oxc = path_str(&dir.path.join("l.oxc"));
    let o = run(&["bake", "cornell-box", "--photons", "2000", "--view", "leaves", "-q", "-o", &oxc]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning: view leaves does not apply to bake"), "{}", stderr(&o));
    let out = dir.path.join("r.exr");
    let o = run(&["render", "cornell-box", "--cache", &oxc, "--resolution", "4x4", "--spp", "1", "-q", "-o", &path_str(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path.join("r.json")).expect("json")).expect("JSON");
    assert_eq!(json["integrator_settings"]["view"], "render");
}

/// Issue 27, item 8: one validator per value, whatever the source: `max_depth` below -1 from
/// the flag, `--set`, a settings file and `export`; `export --spp 0`; a non-object for a table
/// of settings; `{}` for one changes nothing; NaN named as such; `global.epsilon=1e30`; an empty
/// settings file; a repeated `-D` warns and the last wins.
#[test]
fn every_source_of_a_value_is_checked_alike() {
    let dir = TempDir::new("values");
    let out = path_str(&dir.path.join("x.exr"));
    let quick = ["render", "cornell-box", "--resolution", "4x4", "--spp", "1", "-q", "-o", &out];
    let with = |extra: &[&str]| run(&[&quick[..], extra].concat());
    assert_eq!(stderr(&with(&["--max-depth", "-5"])), "error: --max-depth -5 must be -1 (unbounded) or at least 0\n");
    assert_eq!(stderr(&with(&["--set", "max_depth=-5"])), "error: --set max_depth=-5: max_depth -5 must be -1 (unbounded) or at least 0\n");
    // the path tracer's split factor, refused before the render as the others are
    assert_eq!(
        stderr(&with(&["--integrator", "path", "--set", "split=0"])),
        "error: --set split=0: invalid setting `split`: 0 must be 1 (no splitting) to 256\n"
    );
    let file = dir.path.join("s.json");
    std::fs::write(&file, r#"{"type": "octree", "max_depth": -5}"#).expect("write");
    assert_eq!(
        stderr(&with(&["--settings", &path_str(&file)])),
        format!("error: settings file {}: max_depth -5 must be -1 (unbounded) or at least 0\n", file.display())
    );
    let xml = path_str(&dir.path.join("e.xml"));
    assert_eq!(
        stderr(&run(&["export", "cornell-box", "--max-depth", "-5", "-o", &xml])),
        "error: --max-depth -5 must be -1 (unbounded) or at least 0\n"
    );
    assert_eq!(stderr(&run(&["export", "cornell-box", "--spp", "0", "-o", &xml])), "error: --spp must be at least 1\n");
    let o = with(&["--integrator", "octree", "--set", "global=[1,2]"]);
    assert!(stderr(&o).starts_with("error: --set global=[1,2]: `global` is a table of settings ("), "{}", stderr(&o));
    assert!(stderr(&o).ends_with("not a value: set its keys (`global.alpha=...`) or give an object\n"), "{}", stderr(&o));
    // `{}` changes nothing: the same settings as without it
    let settings_of = |extra: &[&str]| {
        let o = with(&[&["--integrator", "octree", "--photons", "1000"][..], extra].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path.join("x.json")).expect("json")).expect("JSON");
        json["integrator_settings"].clone()
    };
    let plain = settings_of(&[]);
    assert_eq!(settings_of(&["--set", "global={}"]), plain);
    assert_eq!(settings_of(&["--set", "global={\"n_max\": 400}"])["global"]["n_max"], 400);
    assert_eq!(settings_of(&["--set", "global={\"n_max\": 400}"])["global"]["h_max"], plain["global"]["h_max"]);
    // NaN and infinity: said so (it was "invalid type: null")
    let o = with(&["--integrator", "octree", "--set", "global.epsilon=NaN"]);
    assert_eq!(stderr(&o), "error: --set global.epsilon=NaN: NaN is not a finite number\n");
    // a number out of range, and an object that is not JSON: said so (they said "invalid type:
    // string \"1e999\", expected f32" and "is a table of settings ..., not a value")
    let o = with(&["--integrator", "octree", "--set", "global.epsilon=1e999"]);
    assert_eq!(stderr(&o), "error: --set global.epsilon=1e999: 1e999 is not a finite number (number out of range at line 1 column 5)\n");
    let o = with(&["--integrator", "octree", "--set", "global={\"epsilon\": 1e999}"]);
    assert_eq!(
        stderr(&o),
        "error: --set global={\"epsilon\": 1e999}: {\"epsilon\": 1e999} is not a finite number (number out of range at line 1 column \
         17)\n"
    );
    let o = with(&["--integrator", "octree", "--set", "global={n_max: 400}"]);
    assert_eq!(stderr(&o), "error: --set global={n_max: 400}: {n_max: 400} is not valid JSON: key must be a string at line 1 column 2\n");
    // a negative length reaches the check of the value (clap took it for an option)
    let obj = dir.path.join("o.obj");
    std::fs::write(&obj, "v 0 0 0\nv 0.3 0 0\nv 0 0.3 0\nf 1 2 3\n").expect("write");
    let o = with(&["--insert", &path_str(&obj), "--insert-ao-distance", "-1"]);
    assert_eq!(stderr(&o), "error: --insert-ao-distance must be a positive length, got -1\n");
    let toml = dir.path.join("s.toml");
    std::fs::write(&toml, "type = \"octree\"\n[global]\nepsilon = inf\n").expect("write");
    assert_eq!(
        stderr(&with(&["--settings", &path_str(&toml)])),
        format!("error: settings file {}: `global.epsilon` = inf is not a finite number\n", toml.display())
    );
    let o = with(&["--integrator", "octree", "--set", "global.epsilon=1e30"]);
    assert_eq!(
        stderr(&o),
        "error: --set global.epsilon=1e30: global: invalid octree settings: epsilon = 1000000000000000000000000000000 must be in \
         [0, 10]\n"
    );
    // empty settings files are valid (they said "no integrator has the setting ``")
    for (name, text) in [("e.json", "{}"), ("e.toml", "")] {
        let f = dir.path.join(name);
        std::fs::write(&f, text).expect("write");
        let o = with(&["--settings", &path_str(&f)]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
    // a repeated -D: the last wins, with a warning
    let scene = write_scene(&dir, "path", "1", 8);
    let o = run(&["render", &scene, "-D", "spp=1", "-D", "spp=2", "-q", "-o", &out]);
    assert_eq!(stderr(&o), "warning: -D spp=2 repeats -D spp=1: the last value wins\n");
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path.join("x.json")).expect("json")).expect("JSON");
    assert_eq!(json["render_settings"]["spp"], 2);
}

/// Issue 27, items 4 and 8: `report` checks its memory before FLIP (two 8192x8192 images
/// segfaulted in FLIP at an 8 GB limit); a `near_clip` beyond the whole scene warns.
#[test]
fn report_memory_is_checked_before_flip_and_a_far_near_clip_warns() {
    let dir = TempDir::new("flip");
    let px = octolux::math::Color::new(0.5, 0.5, 0.5);
    let img = octolux::image::Image { width: 512, height: 512, data: vec![px; 512 * 512] };
    let (a, b) = (dir.path.join("a.exr"), dir.path.join("b.exr"));
    octolux_io::image_io::write_exr(&a, &img).expect("write");
    octolux_io::image_io::write_exr(&b, &img).expect("write");
    let o = octolux()
        .env(budget::MEMORY_LIMIT_ENV, "16M")
        .args(["report", &path_str(&a), "--reference", &path_str(&b), "-o", &path_str(&dir.path.join("r.html"))])
        .output()
        .expect("runs");
    let need = budget::format_bytes(2 * 512 * 512 * 56 + 512 * 512 * 96);
    assert_eq!(
        stderr(&o),
        format!(
            "error: the report of 2 images of 512x512 (FLIP and the page) would need {need} of memory, more than the limit of 16.0 MiB \
             (set OCTOLUX_MEMORY_LIMIT to change the limit)\n"
        )
    );
    assert_eq!(dir.files(), vec!["a.exr", "b.exr"]);

    let scene = dir.path.join("far.xml");
    std::fs::write(
        &scene,
        scene_xml("path", "1", 8)
            .replace("<float name=\"fov\" value=\"40\"/>", "<float name=\"fov\" value=\"40\"/><float name=\"near_clip\" value=\"1e30\"/>"),
    )
    .expect("write");
    let o = run(&["render", &path_str(&scene), "-q", "-o", &path_str(&dir.path.join("x.exr"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).starts_with("warning: near_clip 1000000000000000000000000000000 is beyond the whole scene (its farthest point is "),
        "{}",
        stderr(&o)
    );
}

/// Issue 27, item 5: glTF buffer URIs stay inside the file's folder unless
/// `--allow-outside-uris`; a closed stdout ends `compare` quietly (it panicked).
#[test]
fn gltf_uris_outside_the_folder_need_the_flag() {
    let dir = TempDir::new("uris");
    let mut buf = Vec::new();
    for v in [0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        buf.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(dir.path.join("tri.bin"), &buf).expect("write");
    std::fs::create_dir(dir.path.join("sub")).expect("mkdir");
    let gltf = dir.path.join("sub").join("s.gltf");
    std::fs::write(
        &gltf,
        r#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}], "buffers": [{"byteLength": 36, "uri": "../tri.bin"}]}"#,
    )
    .expect("write");
    let out = path_str(&dir.path.join("x.exr"));
    let o = run(&["render", &path_str(&gltf), "--resolution", "4x4", "--spp", "1", "-q", "-o", &out]);
    assert_eq!(
        stderr(&o),
        format!(
            "error: cannot load scene '{}': {}: buffer 0: URI \"../tri.bin\" names a file outside the glTF file's folder \
             (allow it with --allow-outside-uris)\n",
            gltf.display(),
            gltf.display()
        )
    );
    let o = run(&["render", &path_str(&gltf), "--allow-outside-uris", "--resolution", "4x4", "--spp", "1", "-q", "-o", &out]);
    assert!(o.status.success(), "{}", stderr(&o));

    let mut child = octolux().args(["compare", &out, &out]).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn");
    drop(child.stdout.take());
    let o = child.wait_with_output().expect("wait");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stderr(&o), "");
}

#[test]
fn a_closed_stderr_does_not_stop_a_render() {
    // `octolux render ... 2>&1 | head -1`: the log's reader is gone; the render goes on and
    // writes its set (each log line panicked, exit status 101, issue 30)
    let dir = TempDir::new("stderr");
    let out = dir.path.join("x.exr");
    let mut child = octolux()
        .args(["render", "--resolution", "8x8", "--spp", "1", "--photons", "100", "-o", &path_str(&out)])
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn");
    drop(child.stderr.take());
    let status = child.wait().expect("wait");
    assert!(status.success(), "{status:?}");
    assert!(out.is_file() && out.with_extension("json").is_file());
}

/// A binary PLY grid of `nx` x `ny` quads (two triangles each), written row by row: `(nx +
/// 1)(ny + 1)` vertices, `2 nx ny` triangles.
fn write_ply_grid(path: &Path, nx: u32, ny: u32) {
    use std::io::Write;
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).expect("create"));
    let (v, t) = ((nx + 1) * (ny + 1), 2 * nx * ny);
    write!(
        f,
        "ply\nformat binary_little_endian 1.0\nelement vertex {v}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {t}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    .expect("write");
    for j in 0..=ny {
        for i in 0..=nx {
            for c in [i as f32 / nx as f32, j as f32 / ny as f32, 0.0] {
                f.write_all(&c.to_le_bytes()).expect("write");
            }
        }
    }
    for j in 0..ny {
        for i in 0..nx {
            let a = j * (nx + 1) + i;
            let (b, c, d) = (a + 1, a + nx + 1, a + nx + 2);
            for tri in [[a, b, d], [a, d, c]] {
                f.write_all(&[3]).expect("write");
                for k in tri {
                    f.write_all(&(k as i32).to_le_bytes()).expect("write");
                }
            }
        }
    }
    f.flush().expect("flush");
}

/// The peak resident size (KiB) of one `octolux` run, read from `/proc/PID/status` (`VmHWM`,
/// which only grows) while it runs; `None` where there is no such file (not Linux).
fn peak_rss_kib(args: &[&str]) -> Option<u64> {
    let mut child = octolux().args(args).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().expect("spawn");
    let status = format!("/proc/{}/status", child.id());
    let mut peak: Option<u64> = None;
    loop {
        let hwm = std::fs::read_to_string(&status).ok().and_then(|text| {
            text.lines().find_map(|l| l.strip_prefix("VmHWM:")).and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        });
        if let Some(kib) = hwm {
            peak = Some(peak.map_or(kib, |p| p.max(kib)));
        }
        if child.try_wait().expect("wait").is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let o = child.wait_with_output().expect("output");
    assert!(o.status.success(), "octolux {args:?}: {}", stderr(&o));
    peak
}

/// Issue 27, item 3: the memory a mesh is allowed is what the whole render takes. With 64
/// bytes per triangle a 1 KB glTF of 262 million instanced triangles got through an 18 GiB
/// limit, and the process was killed (out of memory) at 21 GiB. Here the peak resident size
/// of a render of a 2-million-triangle grid (less that of a 2-triangle one) must stay within
/// the budget's estimate for its vertices and triangles, with each backend.
#[test]
fn the_mesh_budget_bounds_the_measured_peak() {
    let dir = TempDir::new("meshpeak");
    let (small, big) = (dir.path.join("small.ply"), dir.path.join("big.ply"));
    write_ply_grid(&small, 1, 1);
    let (nx, ny) = (1000, 1000);
    write_ply_grid(&big, nx, ny);
    let (v, t) = (((nx + 1) * (ny + 1)) as u64, (2 * nx * ny) as u64);
    let estimate = v * budget::VERTEX_BYTES + t * budget::TRIANGLE_BYTES;
    let out = path_str(&dir.path.join("x.exr"));
    let render = |mesh: &Path, backend: &str| {
        peak_rss_kib(&["render", &path_str(mesh), "--backend", backend, "--resolution", "4x4", "--spp", "1", "-q", "-o", &out])
    };
    let mut backends = vec!["bvh"];
    let embree = octolux().args(["render", &path_str(&small), "--backend", "embree", "-q", "-o", &out]).output().expect("runs");
    if embree.status.success() {
        backends.push("embree");
    } else {
        let why = format!(
            "Embree cannot be loaded ({}); the Embree case of the_mesh_budget_bounds_the_measured_peak is not run",
            stderr(&embree).trim()
        );
        octolux_probe::skip("embree", &why);
    }
    for backend in backends {
        let (Some(base), Some(peak)) = (render(&small, backend), render(&big, backend)) else {
            println!("skip: no /proc/PID/status here; the_mesh_budget_bounds_the_measured_peak is not run");
            return;
        };
        let used = peak.saturating_sub(base) * 1024;
        let per_triangle = (used as f64 - (v * budget::VERTEX_BYTES) as f64) / t as f64;
        println!(
            "{backend}: {t} triangles, {v} vertices: peak {} more than a 2-triangle render ({per_triangle:.0} bytes per triangle \
             beyond {} per vertex); the budget's estimate {}",
            budget::format_bytes(used),
            budget::VERTEX_BYTES,
            budget::format_bytes(estimate)
        );
        assert!(used <= estimate, "{backend}: the render took {used} bytes more than a 2-triangle one, the budget estimates {estimate}");
    }
}

/// Issue 27, item 8: `max_depth` from a scene file and from a lighting cache is checked by
/// the same validator as the flag's (the scene file said "or >= 0"; a crafted cache got in).
#[test]
fn a_scene_files_and_a_caches_values_are_checked_as_the_flags() {
    let dir = TempDir::new("values2");
    let scene = write_scene(&dir, "path", "1", 8);
    let text = std::fs::read_to_string(&scene).expect("read");
    std::fs::write(
        &scene,
        text.replace("<integrator type=\"path\"/>", "<integrator type=\"path\"><integer name=\"max_depth\" value=\"-5\"/></integrator>"),
    )
    .expect("write");
    let o = run(&["render", &scene, "-q", "-o", &path_str(&dir.path.join("x.exr"))]);
    assert_eq!(
        stderr(&o),
        format!("error: cannot load scene '{scene}': {scene}:3: <integrator type=\"path\">: max_depth -5 must be -1 (unbounded) or at least 0\n")
    );
    // a cache whose settings hold max_depth -5 (its checksum made right)
    let good = dir.path.join("c.oxc");
    let o = run(&["bake", "cornell-box", "--photons", "2000", "-q", "-o", &path_str(&good)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut c = octolux_io::cache::decode(&std::fs::read(&good).expect("read"), true).expect("decodes");
    assert_eq!(c.parts.settings.max_depth, -1);
    c.parts.settings.max_depth = -5;
    let bad = dir.path.join("bad.oxc");
    std::fs::write(&bad, octolux_io::cache::encode(&c)).expect("write");
    let o = run(&[
        "render",
        "cornell-box",
        "--cache",
        &path_str(&bad),
        "--resolution",
        "4x4",
        "--spp",
        "1",
        "-q",
        "-o",
        &path_str(&dir.path.join("y.exr")),
    ]);
    assert_eq!(
        stderr(&o),
        format!(
            "error: {}: cannot use this lighting cache: its settings: max_depth -5 must be -1 (unbounded) or at least 0\n",
            bad.display()
        )
    );
    assert!(!dir.path.join("x.exr").exists() && !dir.path.join("y.exr").exists());
}

/// Issue 27, item 7: a camera path whose `up` turns from +x to -x between two valid keys
/// passes through zero half-way (a black frame, exit 0, before); an object path key of scale
/// 1e30 (the inserted object put every point of the scene inside it).
#[test]
fn camera_up_between_keys_and_object_scales_are_checked() {
    let dir = TempDir::new("frames2");
    let key = |t: f64, up: [f32; 3]| serde_json::json!({"time": t, "position": [0, 1, 4], "target": [0, 1, 0], "up": up, "fov": 40});
    let path = dir.path.join("up.json");
    std::fs::write(&path, serde_json::json!({"fps": 2, "keyframes": [key(0.0, [1.0, 0.0, 0.0]), key(1.0, [-1.0, 0.0, 0.0])]}).to_string())
        .expect("write");
    let out = path_str(&dir.path.join("x.exr"));
    let o = run(&["render", "cornell-box", "--camera-path", &path_str(&path), "-q", "-o", &out]);
    assert_eq!(
        stderr(&o),
        format!("error: camera path {}: frame 2 (time 0.5 s, between keyframes): up is zero or along the view direction\n", path.display())
    );
    let obj = dir.path.join("o.obj");
    std::fs::write(&obj, "v 0 0 0\nv 0.3 0 0\nv 0 0.3 0\nf 1 2 3\n").expect("write");
    let op = dir.path.join("op.json");
    std::fs::write(
        &op,
        r#"{"fps": 1, "keyframes": [{"time": 0, "position": [0, 0, 0]}, {"time": 1, "position": [0, 0, 0], "scale": 1e30}]}"#,
    )
    .expect("write");
    let o = run(&["render", "cornell-box", "--insert", &path_str(&obj), "--insert-path", &path_str(&op), "-q", "-o", &out]);
    assert_eq!(stderr(&o), format!("error: object path {}: keyframe 2: scale 1e30 is out of range [1e-6, 1e6]\n", op.display()));
    assert_eq!(dir.files(), vec!["o.obj", "op.json", "up.json"]);
}

/// Issue 27, item 10: `export` never replaces a mesh file the exported scene reads (a scene
/// whose shape `floor` reads `meshes/0000_floor.ply`, exported beside it, would write its own
/// `meshes/0000_floor.ply`); the file and the XML are left as they were.
#[test]
fn export_never_replaces_a_mesh_it_reads() {
    let dir = TempDir::new("export-input");
    let first = dir.path.join("first.xml");
    let o = run(&["export", "cornell-box", "-o", &path_str(&first)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let floor = dir.path.join("meshes").join("0000_floor.ply");
    let before = std::fs::read(&floor).expect("the export wrote the floor");
    let scene = dir.path.join("a.xml");
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\"><shape type=\"ply\" id=\"floor\"><string name=\"filename\" value=\"meshes/0000_floor.ply\"/>\
         <transform name=\"to_world\"><translate y=\"0.5\"/></transform></shape></scene>",
    )
    .expect("write");
    let o = run(&["export", &path_str(&scene), "-o", &path_str(&dir.path.join("b.xml"))]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).ends_with(&format!(
            "error: cannot export to {}: output '{}' is an input of this run: writing it would destroy the input\n",
            dir.path.join("b.xml").display(),
            floor.display()
        )),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(&floor).expect("read"), before);
    assert!(!dir.path.join("b.xml").exists());
    let stray: Vec<String> = dir.files().into_iter().filter(|f| f.starts_with('.')).collect();
    assert!(stray.is_empty(), "left behind {stray:?}");
}

/// Issue 27, item 1: every writer refuses `/dev/null` (and a device node of its own) before
/// any work, and an output that a scene reads (a texture where the render's PNG goes, a mesh
/// named as a bake's cache) is refused once the scene is read, before the render or the bake
/// (whose first lines, printed when they start, must not appear), not at the rename after it:
/// a render of 10^8 samples per pixel over such a texture ran until it was stopped. A frame's
/// output that is a FIFO is refused before the first frame.
#[test]
fn every_writer_refuses_devices_and_the_scenes_own_files_before_the_work() {
    let dir = TempDir::new("writers");
    let refused = |p: &Path, kind: &str| {
        format!("error: output '{}' is {kind}, not a regular file: octolux replaces only regular files\n", p.display())
    };
    let null = Path::new("/dev/null");
    // a scene that does not exist, an image that does not exist: the output is checked first
    // (a regression would fail on the missing input, never touch /dev/null)
    for args in [
        vec!["render", "no-such-scene.xml", "-q", "-o", "/dev/null"],
        vec!["report", "no-such-image.exr", "-o", "/dev/null"],
        vec!["export", "no-such-scene.xml", "-o", "/dev/null"],
    ] {
        let o = run(&args);
        assert_eq!(o.status.code(), Some(1), "{args:?}");
        assert_eq!(stderr(&o), refused(null, "a character device"), "{args:?}");
    }
    assert_eq!(file_type(null), "char");
    // `/dev/stdout` is a link to `/proc/self/fd/1`: with stdout a regular file, the rename
    // would have replaced the link; one of our own stands in for it
    let fd = dir.path.join("fd.exr");
    std::os::unix::fs::symlink("/proc/self/fd/1", &fd).expect("symlink");
    let log = std::fs::File::create(dir.path.join("stdout.txt")).expect("create");
    let o = octolux()
        .args(["render", "cornell-box", "--resolution", "4x4", "--spp", "1", "-q", "-o", &path_str(&fd)])
        .stdout(log)
        .output()
        .expect("runs");
    assert_eq!(
        stderr(&o),
        format!(
            "error: output '{}' is a link to '/proc/self/fd/1', an open file of a process: octolux writes only files it can replace\n",
            fd.display()
        )
    );
    assert_eq!(file_type(&fd), "link");
    std::fs::remove_file(&fd).expect("rm");
    std::fs::remove_file(dir.path.join("stdout.txt")).expect("rm");
    // a device node of our own where the render's PNG, the report and the export would go
    let (png, html, xml) = (dir.path.join("d.png"), dir.path.join("d.html"), dir.path.join("d.xml"));
    let mknod = |p: &Path| Command::new("mknod").arg(p).args(["c", "1", "3"]).stderr(Stdio::null()).status().is_ok_and(|s| s.success());
    if mknod(&png) && mknod(&html) && mknod(&xml) {
        let o = run(&["render", "cornell-box", "--resolution", "4x4", "--spp", "1", "-q", "-o", &path_str(&dir.path.join("d.exr"))]);
        assert_eq!(stderr(&o), refused(&png, "a character device"));
        let img = dir.path.join("a.exr");
        let px = octolux::math::Color::new(0.5, 0.5, 0.5);
        octolux_io::image_io::write_exr(&img, &octolux::image::Image { width: 2, height: 2, data: vec![px; 4] }).expect("write");
        let o = run(&["report", &path_str(&img), "-o", &path_str(&html)]);
        assert_eq!(stderr(&o), refused(&html, "a character device"));
        let o = run(&["export", "cornell-box", "-o", &path_str(&xml)]);
        assert_eq!(stderr(&o), refused(&xml, "a character device"));
        for p in [&png, &html, &xml] {
            assert_eq!(file_type(p), "char", "{} left as it was", p.display());
            std::fs::remove_file(p).expect("rm");
        }
        std::fs::remove_file(&img).expect("rm");
    } else {
        println!("skipped the device-node cases of every_writer_refuses_devices_...: mknod needs root");
        let _ = [&png, &html, &xml].map(std::fs::remove_file);
    }
    // a texture where the render's PNG would go: refused once the scene is read
    let tex = dir.path.join("t.png");
    let o = run(&["render", "cornell-box", "--resolution", "2x2", "--spp", "1", "-q", "-o", &path_str(&dir.path.join("t.exr"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    let before = std::fs::read(&tex).expect("the PNG");
    let scene = dir.path.join("t.xml");
    std::fs::write(
        &scene,
        scene_xml("path", "4", 8).replace(
            "</scene>",
            "<shape type=\"sphere\"><bsdf type=\"diffuse\">\
         <texture type=\"bitmap\" name=\"reflectance\"><string name=\"filename\" value=\"t.png\"/></texture></bsdf></shape></scene>",
        ),
    )
    .expect("write");
    let o = run(&["render", &path_str(&scene), "-o", &path_str(&dir.path.join("t.exr"))]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(stderr(&o), format!("error: output '{}' is an input of this run: writing it would destroy the input\n", tex.display()));
    assert_eq!(std::fs::read(&tex).expect("read"), before);
    // a mesh named as a bake's cache: refused before the photons are traced
    let o = run(&["export", "cornell-box", "-o", &path_str(&dir.path.join("c.xml"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mesh = dir.path.join("meshes").join("0000_floor.ply");
    let before = std::fs::read(&mesh).expect("the floor");
    let o = run(&["bake", &path_str(&dir.path.join("c.xml")), "--photons", "20000", "-o", &path_str(&mesh)]);
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(stderr(&o), format!("error: output '{}' is an input of this run: writing it would destroy the input\n", mesh.display()));
    assert_eq!(std::fs::read(&mesh).expect("read"), before);
    // a FIFO where the second frame's PNG would go: refused before the first frame
    let path = write_camera_path(&dir, 1.0, &[(0.0, [0.0, 1.0, 4.0], [0.0, 1.0, 0.0]), (1.0, [1.0, 1.0, 4.0], [0.0, 1.0, 0.0])]);
    let fifo = dir.path.join("f_0002.png");
    mkfifo(&fifo);
    let o = run(&[
        "render",
        "cornell-box",
        "--camera-path",
        &path_str(&path),
        "--resolution",
        "4x4",
        "-q",
        "-o",
        &path_str(&dir.path.join("f.exr")),
    ]);
    assert_eq!(stderr(&o), refused(&fifo, "a FIFO (named pipe)"));
    assert!(!dir.path.join("f_0001.exr").exists());
    let stray: Vec<String> = dir.files().into_iter().filter(|f| f.starts_with('.')).collect();
    assert!(stray.is_empty(), "left behind {stray:?}");
}

/// Issue 27, item 3: a scene's images are counted together against the memory budget. Each
/// file was checked alone: a small Mitsuba scene naming one large image through hard links,
/// or a glTF whose images all name one file (or one buffer view), decoded it once per name.
/// One file under several names (`sub/../t.png`) is read once. Here at a 20 MiB limit, with a
/// 512x512 PNG (8 MiB as texels): two fit, the third is refused.
#[test]
fn a_scenes_images_are_counted_together() {
    let dir = TempDir::new("texels");
    let px = octolux::math::Color::new(0.5, 0.25, 0.125);
    let img = octolux::image::Image { width: 512, height: 512, data: vec![px; 512 * 512] };
    octolux_io::image_io::write_png(&dir.path.join("t.png"), &img).expect("write");
    for n in ["h1.png", "h2.png"] {
        std::fs::hard_link(dir.path.join("t.png"), dir.path.join(n)).expect("hard link");
    }
    std::fs::create_dir(dir.path.join("sub")).expect("mkdir");
    let limited = |args: &[&str]| octolux().env(budget::MEMORY_LIMIT_ENV, "20M").args(args).output().expect("runs");
    let out = path_str(&dir.path.join("x.exr"));
    let textured = |names: [&str; 3]| {
        let spheres: Vec<String> = names
            .iter()
            .map(|n| {
                format!(
                    "<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">\
                     <string name=\"filename\" value=\"{n}\"/></texture></bsdf></shape>\n"
                )
            })
            .collect();
        let p = dir.path.join("s.xml");
        std::fs::write(&p, scene_xml("path", "1", 8).replace("</scene>", &format!("{}</scene>", spheres.concat()))).expect("write");
        p
    };
    let scene = textured(["t.png", "h1.png", "h2.png"]);
    let line = scene_xml("path", "1", 8).lines().count() + 2;
    let o = limited(&["render", &path_str(&scene), "-q", "-o", &out]);
    assert_eq!(
        stderr(&o),
        format!(
            "error: cannot load scene '{s}': {s}:{line}: <texture type=\"bitmap\" name=\"reflectance\">: the scene's images together, with this one: \
             786432 texels would need 24.0 MiB of memory, more than the limit of 20.0 MiB (set OCTOLUX_MEMORY_LIMIT to change the \
             limit)\n",
            s = scene.display()
        )
    );
    let scene = textured(["t.png", "sub/../t.png", "./t.png"]);
    let o = limited(&["render", &path_str(&scene), "-q", "-o", &out]);
    assert!(o.status.success(), "one file under three names is read once: {}", stderr(&o));
    // a glTF of three images naming one file
    let mut buf = Vec::new();
    for v in [0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0] {
        buf.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(dir.path.join("tri.bin"), &buf).expect("write");
    let prim = |i: u32| format!(r#"{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "material": {i}}}"#);
    let gltf = dir.path.join("s.gltf");
    std::fs::write(
        &gltf,
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{}, {}, {}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}}}},
    {{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 1}}}}}}, {{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 2}}}}}}],
  "textures": [{{"source": 0}}, {{"source": 1}}, {{"source": 2}}],
  "images": [{{"uri": "t.png"}}, {{"uri": "t.png"}}, {{"uri": "t.png"}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": 24}}],
  "buffers": [{{"byteLength": 60, "uri": "tri.bin"}}]}}"#,
            prim(0),
            prim(1),
            prim(2)
        ),
    )
    .expect("write");
    let o = limited(&["render", &path_str(&gltf), "--resolution", "4x4", "--spp", "1", "-q", "-o", &out]);
    assert_eq!(
        stderr(&o),
        format!(
            "error: cannot load scene '{g}': {g}: image 2: the scene's images together, with this one: 786432 texels would need 24.0 \
             MiB of memory, more than the limit of 20.0 MiB (set OCTOLUX_MEMORY_LIMIT to change the limit)\n",
            g = gltf.display()
        )
    );
}
