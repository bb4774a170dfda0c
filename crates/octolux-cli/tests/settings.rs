//! Integrator settings from the command line: `--settings FILE.json|FILE.toml`, `--set
//! KEY=VALUE`, their precedence over the flags (file < flags < --set), the warnings for options
//! the chosen integrator does not have, the errors for keys no integrator has, and the
//! render-time counters in `OUT.json`. Each case renders a 4x4 image with 1 spp and a few
//! thousand photons and reads back what `OUT.json` says was used.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A scratch folder of one test, removed at the end.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(format!("octolux-cli-settings-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        Scratch(dir)
    }

    fn file(&self, name: &str, text: &str) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, text).expect("write");
        p
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// What one run of `octolux render` left: success, stderr, and `OUT.json` when written.
struct Run {
    ok: bool,
    stderr: String,
    json: Option<Value>,
}

fn render(dir: &Path, args: &[&str]) -> Run {
    render_at(dir, "4x4", args)
}

fn render_at(dir: &Path, resolution: &str, args: &[&str]) -> Run {
    let out = dir.join("out.exr");
    let _ = std::fs::remove_file(out.with_extension("json"));
    let o = Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(["render", "cornell-box", "--spp", "1", "--resolution", resolution, "-q", "-o"])
        .arg(&out)
        .args(args)
        .output()
        .expect("octolux runs");
    let json = std::fs::read_to_string(out.with_extension("json")).ok().map(|t| serde_json::from_str(&t).expect("out.json is JSON"));
    Run { ok: o.status.success(), stderr: String::from_utf8_lossy(&o.stderr).into_owned(), json }
}

/// The render succeeded; its `OUT.json`.
fn rendered(dir: &Path, args: &[&str]) -> (Value, String) {
    let r = render(dir, args);
    assert!(r.ok, "octolux {args:?} failed: {}", r.stderr);
    (r.json.expect("out.json written"), r.stderr)
}

/// The render failed before writing anything; its error message.
fn failed(dir: &Path, args: &[&str]) -> String {
    let r = render(dir, args);
    assert!(!r.ok, "octolux {args:?} should fail; stderr: {}", r.stderr);
    assert!(r.json.is_none(), "a failed run writes no out.json");
    assert!(r.stderr.starts_with("error: "), "{}", r.stderr);
    r.stderr
}

/// The setting at a dotted key of `OUT.json`'s `integrator_settings`.
fn setting<'a>(json: &'a Value, key: &str) -> &'a Value {
    key.split('.').fold(&json["integrator_settings"], |v, k| &v[k])
}

#[test]
fn a_json_settings_file_chooses_the_integrator_and_its_settings() {
    let d = Scratch::new("json");
    let f = d.file("s.json", r#"{ "type": "octree", "photons": { "photons": 3000 }, "global": { "h_max": 4 }, "mode": "paper" }"#);
    let (json, _) = rendered(&d.0, &["--settings", f.to_str().unwrap()]);
    assert_eq!(json["integrator"], "octree");
    assert_eq!(setting(&json, "type"), "octree");
    assert_eq!(setting(&json, "photons.photons"), 3000);
    assert_eq!(setting(&json, "global.h_max"), 4);
    assert_eq!(setting(&json, "caustic.h_max"), 10, "keys the file does not give keep the integrator's defaults");
    assert_eq!(setting(&json, "mode"), "paper");
    assert_eq!(json["build"]["photons_emitted"], 3000);
}

#[test]
fn a_toml_settings_file_is_read_and_out_json_settings_read_back_the_same() {
    let d = Scratch::new("toml");
    let f = d.file(
        "s.toml",
        "type = \"ward\"\nmax_depth = 5\n[photons]\nphotons = 2500\n[cache]\nbatch = 64\n[density.r_max]\nabsolute = 30.0\n",
    );
    let (json, _) = rendered(&d.0, &["--settings", f.to_str().unwrap()]);
    assert_eq!(json["integrator"], "ward");
    assert_eq!(setting(&json, "photons.photons"), 2500);
    assert_eq!(setting(&json, "cache.batch"), 64);
    assert_eq!(setting(&json, "max_depth"), 5);
    // an enum value switched by naming another variant's key
    assert_eq!(setting(&json, "density.r_max"), &serde_json::json!({ "absolute": 30.0 }));
    // OUT.json's settings are a settings file: the same run again
    let again = d.file("again.json", &json["integrator_settings"].to_string());
    let (json2, _) = rendered(&d.0, &["--settings", again.to_str().unwrap()]);
    assert_eq!(json2["integrator_settings"], json["integrator_settings"]);
}

#[test]
fn set_wins_over_flags_which_win_over_the_settings_file() {
    let d = Scratch::new("precedence");
    let f = d.file("s.json", r#"{ "photons": { "photons": 3000 }, "every": 2 }"#);
    let f = f.to_str().unwrap();
    let base = ["--integrator", "christensen", "--settings", f];
    let (json, _) = rendered(&d.0, &base);
    assert_eq!(setting(&json, "photons.photons"), 3000);
    assert_eq!(setting(&json, "every"), 2);
    let (json, _) = rendered(&d.0, &[&base[..], &["--photons", "4000", "--set", "every=3"]].concat());
    assert_eq!(setting(&json, "photons.photons"), 4000);
    assert_eq!(setting(&json, "every"), 3);
    let (json, _) = rendered(&d.0, &[&base[..], &["--photons", "4000", "--set", "photons.photons=5000", "--set", "every=3"]].concat());
    assert_eq!(setting(&json, "photons.photons"), 5000);
    assert_eq!(setting(&json, "every"), 3);
    assert_eq!(json["build"]["photons"]["photons_emitted"], 5000, "the integrator was built with the value that won");
}

#[test]
fn set_values_are_json_when_they_parse_and_strings_otherwise() {
    let d = Scratch::new("values");
    let (json, _) = rendered(
        &d.0,
        &[
            "--integrator",
            "octree",
            "--set",
            "photons.photons=2000",
            "--set",
            "footprint=2",
            "--set",
            "view=irradiance",
            "--set",
            "global.epsilon=0.5",
        ],
    );
    assert_eq!(setting(&json, "footprint"), 2.0);
    assert_eq!(setting(&json, "view"), "irradiance");
    assert_eq!(setting(&json, "global.epsilon"), 0.5);
    assert_eq!(setting(&json, "caustic.epsilon").as_f64(), Some(0.2f32 as f64), "--set writes one key");
    // the scene's seed and max_depth reach the settings when nothing else gives them
    let (json, _) = rendered(&d.0, &["--integrator", "ward", "--photons", "2000", "--seed", "7"]);
    assert_eq!(setting(&json, "photons.seed"), 7);
    assert_eq!(setting(&json, "max_depth"), -1);
}

#[test]
fn options_the_integrator_does_not_have_warn_and_name_it() {
    let d = Scratch::new("warn");
    // a flag meant for the baselines' photons, given to `path`
    let (json, err) = rendered(&d.0, &["--integrator", "path", "--photons", "2000", "--view", "irradiance"]);
    assert!(
        err.contains("warning: --photons applies to --integrator octree, photonmap, ward, christensen only; ignored by --integrator path"),
        "{err}"
    );
    assert!(err.contains("warning: --view applies to"), "{err}");
    assert!(json["warnings"].as_array().unwrap().iter().any(|w| w.as_str().unwrap().contains("--photons")), "{json}");
    // an octree key set for ward, and a file key of christensen's
    let f = d.file("s.toml", "every = 8\n");
    let (json, err) =
        rendered(&d.0, &["--integrator", "ward", "--photons", "2000", "--set", "footprint=2", "--settings", f.to_str().unwrap()]);
    assert!(err.contains("warning: --set footprint=2: `footprint` is a setting of --integrator octree, not of ward; ignored"), "{err}");
    assert!(err.contains("s.toml: `every` is a setting of --integrator christensen, not of ward; ignored"), "{err}");
    assert!(setting(&json, "footprint").is_null() && setting(&json, "every").is_null());
}

#[test]
fn an_enum_value_has_one_spelling_from_every_source() {
    // `geometry-area` (a command-line spelling) and `geometry_area` (serde's) name one value,
    // from --set, a settings file and the flags alike (issue 30, item 7)
    let d = Scratch::new("spelling");
    let (json, _) = rendered(&d.0, &["--integrator", "octree", "--photons", "2000", "--set", "global.estimator=paper"]);
    assert_eq!(setting(&json, "global.estimator"), "paper");
    let (json, _) = rendered(&d.0, &["--integrator", "octree", "--photons", "2000", "--set", "global.estimator=geometry-area"]);
    assert_eq!(setting(&json, "global.estimator"), "geometry_area");
    let f = d.file("s.toml", "type = \"octree\"\nview = \"irradiance-all\"\n[caustic]\nenlarge = \"under-n-min\"\n");
    let (json, _) = rendered(&d.0, &["--photons", "2000", "--settings", f.to_str().unwrap()]);
    assert_eq!((setting(&json, "view"), setting(&json, "caustic.enlarge")), (&Value::from("irradiance_all"), &Value::from("under_n_min")));
    let (json, _) = rendered(&d.0, &["--integrator", "octree", "--photons", "2000", "--view", "irradiance-all"]);
    assert_eq!(setting(&json, "view"), "irradiance_all");
    let (json, _) = rendered(&d.0, &["--reconstruction", "importance-sampled"]);
    assert_eq!(json["render_settings"]["reconstruction"], "importance_sampled");
    // a wrong value is still refused, naming the key
    let err = failed(&d.0, &["--integrator", "octree", "--set", "global.estimator=geometry-arena"]);
    assert!(err.contains("--set global.estimator=geometry-arena") && err.contains("geometry_arena"), "{err}");
}

#[test]
fn unknown_keys_are_errors_that_name_them_and_list_the_valid_ones() {
    let d = Scratch::new("unknown");
    let err = failed(&d.0, &["--integrator", "octree", "--set", "photons.cuont=5"]);
    assert!(err.contains("--set photons.cuont=5: no integrator has the setting `photons.cuont`"), "{err}");
    assert!(err.contains("photons.photons") && err.contains("global.h_max"), "the valid keys are listed: {err}");
    let f = d.file("bad.json", r#"{ "global": { "hmax": 4 } }"#);
    let err = failed(&d.0, &["--integrator", "octree", "--settings", f.to_str().unwrap()]);
    assert!(err.contains("bad.json") && err.contains("`global.hmax`"), "{err}");
    // a key below an enum variant that the variant does not have
    let err = failed(&d.0, &["--integrator", "ward", "--set", "cache.prime.grid.colums=8"]);
    assert!(err.contains("--set cache.prime.grid.colums=8") && err.contains("colums"), "{err}");
}

#[test]
fn bad_values_and_bad_files_are_errors_that_say_where() {
    let d = Scratch::new("bad");
    let err = failed(&d.0, &["--integrator", "octree", "--set", "photons.photons=many"]);
    assert!(err.contains("--set photons.photons=many") && err.contains("invalid type"), "{err}");
    let err = failed(&d.0, &["--integrator", "ward", "--view", "leaves"]);
    assert!(err.contains("--view") && err.contains("leaves"), "{err}");
    let err = failed(&d.0, &["--set", "max_depth"]);
    assert!(err.contains("expected KEY=VALUE"), "{err}");
    let f = d.file("syntax.json", "{\n  \"photons\": {\n    \"photons\": ,\n  }\n}\n");
    let err = failed(&d.0, &["--integrator", "octree", "--settings", f.to_str().unwrap()]);
    assert!(err.contains("syntax.json is not valid JSON") && err.contains("line 3"), "{err}");
    let f = d.file("syntax.toml", "[photons]\nphotons = 20\nphotons = 30\n");
    let err = failed(&d.0, &["--integrator", "octree", "--settings", f.to_str().unwrap()]);
    assert!(err.contains("syntax.toml is not valid TOML") && err.contains("line 3"), "{err}");
    let f = d.file("other.json", r#"{ "type": "octree" }"#);
    let err = failed(&d.0, &["--integrator", "ward", "--settings", f.to_str().unwrap()]);
    assert!(err.contains("other.json is for --integrator octree, but --integrator ward was given"), "{err}");
    let f = d.file("s.yaml", "photons: 3\n");
    let err = failed(&d.0, &["--settings", f.to_str().unwrap()]);
    assert!(err.contains("s.yaml: expected a .json or .toml file"), "{err}");
    let err = failed(&d.0, &["--settings", d.0.join("absent.json").to_str().unwrap()]);
    assert!(err.contains("cannot read settings file") && err.contains("absent.json"), "{err}");
}

/// The render loop's counters and the integrators' own reports reach OUT.json (16x16: one
/// cache lookup in 16 is timed, so a few hundred make the time non-zero).
#[test]
fn out_json_holds_the_render_time_counters() {
    let d = Scratch::new("counters");
    for integrator in ["path", "octree", "photonmap", "ward", "christensen"] {
        let photons: &[&str] = if integrator == "path" { &[] } else { &["--photons", "3000"] };
        let r = render_at(&d.0, "16x16", &[&["--integrator", integrator, "--max-depth", "4"], photons].concat());
        assert!(r.ok && !r.stderr.contains("warning"), "{integrator}: {}", r.stderr);
        let json = r.json.expect("out.json");
        let c = &json["render"]["counters"];
        let n = |k: &str| c[k].as_u64().unwrap_or_else(|| panic!("{integrator}: render.counters.{k} missing: {json}"));
        assert!(n("rays") >= 256, "{integrator}: at least the 256 camera rays: {c}");
        assert!(n("shadow_rays") > 0, "{integrator}: {c}");
        if integrator == "path" {
            assert_eq!(n("cache_queries"), 0);
            assert!(json["build"].is_null());
            assert_eq!(json["cache_query_share"], 0.0);
        } else {
            assert!(n("cache_queries") > 0, "{integrator}: {c}");
            assert!(n("cache_query_ns") > 0, "{integrator}: {c}");
            assert!(json["cache_query_share"].as_f64().unwrap() > 0.0);
            assert!(json["build"].is_object(), "{integrator}: {json}");
        }
        assert!(json["render_report"].is_object(), "{integrator}: {json}");
        assert!(json["timings"]["build_s"].as_f64().unwrap() >= 0.0);
        // the render phase's CPU time, all threads: some, and at most what the threads had
        let t = &json["timings"];
        let (cpu, wall) = (t["render_cpu_s"].as_f64().expect("timings.render_cpu_s"), t["render_s"].as_f64().unwrap());
        let threads = json["threads"].as_f64().unwrap();
        assert!(cpu > 0.0 && cpu <= wall * threads * 1.05 + 0.01, "{integrator}: render_cpu_s {cpu}, render_s {wall}");
    }
    let (json, _) = rendered(&d.0, &["--integrator", "ward", "--photons", "3000"]);
    assert!(json["render_report"]["temporaries"].is_u64(), "{json}");
    let (json, _) = rendered(&d.0, &["--integrator", "christensen", "--photons", "3000"]);
    assert!(json["render_report"]["misses"].is_u64(), "{json}");
}
