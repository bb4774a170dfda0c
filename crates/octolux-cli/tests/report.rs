//! `octolux report` (issue 15, item 4): the page holds the metrics octolux computes, bad inputs
//! are refused before anything is written, and in headless Chromium the page runs to its end
//! with no console message and its screenshot shows the images.
//!
//! Chromium is `$OCTOLUX_CHROMIUM`, else `chromium` or `chromium-browser` on the PATH (Debian's
//! `chromium`, which `.ci/run` installs; `octolux_probe::chromium`); without it the browser test
//! is ignored (probed when this crate is built), unless `OCTOLUX_REQUIRE_CHROMIUM=1` (set by
//! `.ci/run`), where it runs and fails.

use glam::Vec3;
use octolux::image::Image;
use octolux_io::image_io::{read_image, write_exr};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn octolux(args: &[&std::ffi::OsStr]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_octolux")).args(args).output().expect("run octolux")
}

fn solid(w: u32, h: u32, c: Vec3) -> Image {
    Image { width: w, height: h, data: vec![c; (w * h) as usize] }
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("octolux-report-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn headless(browser: &Path, page: &Path, extra: &[&str]) -> Output {
    Command::new(browser)
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--enable-logging=stderr", "--v=0"])
        .args(["--window-size=1000,1400", "--virtual-time-budget=5000"])
        .args(extra)
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("run chromium")
}

/// The size of the solid images of [`report_page`].
const W: u32 = 64;
const H: u32 = 48;

/// Writes a report of three solid images (red, green; a blue reference) and two benchmark
/// files into `d`, checks the numbers the page holds, and returns the page.
fn report_page(d: &Path) -> PathBuf {
    let (w, h) = (W, H);
    let (red, green, blue) = (Vec3::new(0.8, 0.0, 0.0), Vec3::new(0.0, 0.8, 0.0), Vec3::new(0.0, 0.0, 0.8));
    write_exr(&d.join("red.exr"), &solid(w, h, red)).unwrap();
    write_exr(&d.join("green.exr"), &solid(w, h, green)).unwrap();
    // the reference: blue with a brighter square, so the error maps have structure
    let mut r = solid(w, h, blue);
    for y in 10..20 {
        for x in 10..20 {
            r.data[(y * w + x) as usize] = Vec3::new(0.0, 0.0, 2.0);
        }
    }
    write_exr(&d.join("ref.exr"), &r).unwrap();
    std::fs::write(d.join("bench.json"), r#"{"title": "t", "series": [{"name": "path", "time_s": [1, 2], "rel_mse": [0.1, 0.05]}]}"#)
        .unwrap();
    // a series whose greatest relMSE lies in (0.1, 1] (and times in (0.1, 1] s): the page once
    // drew it off the plot (`Math.ceil(-0.3)` is `-0`, taken for "no bound")
    std::fs::write(
        d.join("bench2.json"),
        r#"{"title": "u", "series": [{"name": "low", "time_s": [0.2, 0.5], "rel_mse": [0.5, 0.05]}, {"name": "one", "time_s": [0.3], "rel_mse": [1.0]}]}"#,
    )
    .unwrap();
    let page = d.join("report.html");
    let out = octolux(&[
        "report".as_ref(),
        d.join("red.exr").as_os_str(),
        d.join("green.exr").as_os_str(),
        "--reference".as_ref(),
        d.join("ref.exr").as_os_str(),
        "--bench".as_ref(),
        d.join("bench.json").as_os_str(),
        "--bench".as_ref(),
        d.join("bench2.json").as_os_str(),
        "-o".as_ref(),
        page.as_os_str(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let html = std::fs::read_to_string(&page).unwrap();
    // the table's numbers are octolux's metrics
    let m = octolux::metrics::compare(&solid(w, h, red), &r).unwrap();
    assert!(html.contains(&format!("\"rel_mse\":{}", m.rel_mse)), "relMSE {} not in the page", m.rel_mse);
    assert!(html.contains("\"flip_mean\":"), "no FLIP mean");
    assert!(!html.contains("__OCTOLUX_DATA__"), "the template was not filled");
    // the axes' decades hold every point
    assert!(html.contains(r#""x_decades":[0,1]"#) && html.contains(r#""y_decades":[-2,-1]"#), "bench axes");
    assert!(html.contains(r#""x_decades":[-1,0]"#) && html.contains(r#""y_decades":[-2,0]"#), "bench2 axes");
    page
}

#[test]
fn report_holds_the_metrics() {
    report_page(&tmp("ok"));
}

#[test]
#[cfg_attr(missing = "chromium", ignore = "needs chromium (Debian's chromium, or $OCTOLUX_CHROMIUM)")]
fn report_shows_the_images_in_chromium() {
    let d = tmp("browser");
    let (w, h) = (W, H);
    let page = report_page(&d);
    let Some(browser) = octolux_probe::chromium() else {
        octolux_probe::skip("chromium", "report in headless Chromium: no chromium (set OCTOLUX_CHROMIUM or install Debian's chromium)");
        return;
    };
    let dom = headless(&browser, &page, &["--dump-dom"]);
    let dom_text = String::from_utf8_lossy(&dom.stdout);
    assert!(dom_text.contains("data-status=\"ok\""), "the page's script did not run to its end: {}", &dom_text[..dom_text.len().min(300)]);
    // every point of every series inside its plot (the SVG's frame: x in [60, 330], y in [24, 260])
    let mut points = 0;
    // (the page's script, which the dump holds too, writes `points="${p}"`)
    for poly in dom_text.split("<polyline points=\"").skip(1).filter(|p| !p.starts_with('$')) {
        for xy in poly.split('"').next().unwrap_or("").split_whitespace() {
            let (x, y) = xy.split_once(',').expect("x,y");
            let (x, y): (f64, f64) = (x.parse().expect("x"), y.parse().expect("y"));
            assert!((59.9..=330.1).contains(&x) && (23.9..=260.1).contains(&y), "point {x},{y} outside the plot");
            points += 1;
        }
    }
    assert_eq!(points, 5, "the plotted points");
    let console: Vec<String> = String::from_utf8_lossy(&dom.stderr).lines().filter(|l| l.contains("CONSOLE")).map(String::from).collect();
    assert!(console.is_empty(), "console messages: {console:?}");
    let shot = d.join("shot.png");
    let s = headless(&browser, &page, &[&format!("--screenshot={}", shot.display())]);
    assert!(shot.is_file(), "no screenshot: {}", String::from_utf8_lossy(&s.stderr));
    let img = read_image(&shot).unwrap();
    // pixels of each solid image (linear values after sRGB decoding; 0.8 shows as 0.8)
    let count = |c: usize| img.data.iter().filter(|p| (0..3).all(|k| if k == c { p[k] > 0.6 && p[k] < 0.95 } else { p[k] < 0.03 })).count();
    let n = (w * h) as usize;
    for (c, name) in [(0, "red"), (1, "green"), (2, "blue")] {
        assert!(count(c) >= n * 3 / 4, "{name}: {} pixels of the {n} of its image in the screenshot", count(c));
    }
}

/// What this crate's build probed as absent (its tests compiled as ignored) is still absent and
/// not required (`crates/octolux-probe`).
#[test]
fn the_build_probe_still_holds() {
    octolux_probe::check_build_probe(env!("OCTOLUX_PROBE_MISSING"), env!("CARGO_MANIFEST_DIR"));
}

#[test]
fn bad_inputs_are_refused_before_writing() {
    let d = tmp("bad");
    write_exr(&d.join("a.exr"), &solid(16, 12, Vec3::splat(0.5))).unwrap();
    write_exr(&d.join("small.exr"), &solid(8, 8, Vec3::splat(0.5))).unwrap();
    let mut nan = solid(16, 12, Vec3::splat(0.5));
    nan.data[3] = Vec3::new(f32::NAN, 0.0, 0.0);
    write_exr(&d.join("nan.exr"), &nan).unwrap();
    std::fs::write(d.join("bad.json"), r#"{"series": [{"name": "x", "time_s": [1], "rel_mse": []}]}"#).unwrap();
    let page = d.join("r.html");
    let cases: [(&[&str], &str); 3] = [
        (&["small.exr", "--reference", "a.exr"], "small.exr is 8x8 but the reference"),
        (&["nan.exr"], "nan.exr holds non-finite values"),
        (&["a.exr", "--bench", "bad.json"], "needs as many positive time_s as rel_mse"),
    ];
    for (args, msg) in cases {
        let mut full: Vec<std::ffi::OsString> = vec!["report".into()];
        full.extend(args.iter().map(|a| if a.ends_with(".exr") || a.ends_with(".json") { d.join(a).into_os_string() } else { a.into() }));
        full.extend(["-o".into(), page.clone().into_os_string()]);
        let out = octolux(&full.iter().map(|s| s.as_os_str()).collect::<Vec<_>>());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(msg), "{args:?}: {err}");
        assert!(!page.exists(), "{args:?}: a page was written");
    }
}
