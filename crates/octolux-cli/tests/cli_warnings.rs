//! The `octolux` binary warns about options that the chosen integrator ignores.

use std::process::Command;

#[test]
fn octree_options_with_another_integrator_are_reported_as_ignored() {
    let dir = std::env::temp_dir().join(format!("octolux-cli-warnings-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let out = dir.join("x.exr");
    let run = |integrator: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_octolux"))
            .args(["render", "cornell-box", "--integrator", integrator, "--set", "caustic.n_max=60", "--view", "irradiance"])
            .args(["--spp", "1", "--resolution", "4x4", "--photons", "2000", "-q", "-o"])
            .arg(&out)
            .output()
            .expect("octolux runs");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let path = run("path");
    assert!(path.contains("`caustic.n_max` is a setting of --integrator octree, photonmap, ward, christensen, not of path"), "{path}");
    assert!(path.contains("warning: --view applies to --integrator octree, photonmap, ward, christensen only"), "{path}");
    assert!(path.contains("warning: --photons applies to"), "{path}");
    let octree = run("octree");
    assert!(!octree.contains("warning"), "{octree}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_removed_gather_flag_is_refused_with_what_replaced_it() {
    let o = Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(["render", "cornell-box", "--integrator", "octree", "--gather", "--spp", "1", "--resolution", "4x4", "-q"])
        .args(["-o", "/nonexistent-dir-octolux/x.exr"])
        .output()
        .expect("octolux runs");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--gather was removed") && err.contains("mode=paper"), "{err}");
}

#[test]
fn removed_flags_say_which_key_replaced_them() {
    // the flags of single settings keys went; `--set` (and `octolux settings`) reach every key
    for (flag, value, key) in [("--split", "normal", "global.split"), ("--h-max=7", "", "global.h_max"), ("--every", "3", "every=N")] {
        let mut args = vec!["render", "cornell-box", flag];
        if !value.is_empty() {
            args.push(value);
        }
        let o = Command::new(env!("CARGO_BIN_EXE_octolux")).args(&args).output().expect("octolux runs");
        let err = String::from_utf8_lossy(&o.stderr);
        let name = flag.split('=').next().unwrap_or(flag);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.starts_with(&format!("error: {name} was removed: use `--set {key}")), "{err}");
        assert!(err.contains("octolux settings INTEGRATOR"), "{err}");
    }
}

#[test]
fn settings_lists_every_key_with_its_default_type_and_doc() {
    let run = |args: &[&str]| Command::new(env!("CARGO_BIN_EXE_octolux")).args(args).output().expect("octolux runs");
    let o = run(&["settings", "octree"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    // a key of a nested table, an enum with its values and their docs, a number shown as set
    assert!(text.contains("global.h_max = \"auto\"    (integer from 0 to 21, or \"auto\")"), "{text}");
    assert!(text.contains("global.estimator = \"geometry_area\"    (\"paper\" | \"cosine\" | \"geometry_area\")"), "{text}");
    assert!(text.contains("    - geometry_area: 1/cos and ΔA replaced by the lit geometry"), "{text}");
    assert!(text.contains("global.epsilon = 0.2    (number)"), "{text}");
    assert!(text.contains("leak = \"auto\""), "{text}");
    // every key of the defaults is listed, each once
    let listed: Vec<&str> =
        text.lines().filter(|l| !l.starts_with(' ') && l.contains(" = ")).map(|l| l.split(" = ").next().unwrap()).collect();
    assert_eq!(listed.len(), 37, "{listed:?}");
    let o = run(&["settings"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("path, octree, photonmap, ward, christensen"));
    let o = run(&["settings", "bdpt"]);
    assert_eq!(o.status.code(), Some(2), "clap refuses an unknown integrator");
}

#[test]
fn progress_shows_without_a_terminal_and_quiet_keeps_only_warnings() {
    let dir = std::env::temp_dir().join(format!("octolux-cli-progress-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let out = dir.join("x.exr");
    // stderr is a pipe here, not a terminal: progress lines, one per tile with a 0 s interval
    let run = |quiet: bool| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_octolux"));
        c.args(["render", "cornell-box", "--integrator", "path", "--photons", "2000", "--spp", "1", "--resolution", "64x64", "-o"])
            .arg(&out)
            .env("OCTOLUX_PROGRESS_SECONDS", "0");
        if quiet {
            c.arg("-q");
        }
        let o = c.output().expect("octolux runs");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let err = run(false);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("rendering: ")).collect();
    assert!(!lines.is_empty(), "no progress line: {err}");
    for l in &lines {
        // `rendering: 42% (1720 of 4096 pixels), 0 s`
        let (pct, rest) = l["rendering: ".len()..].split_once("% (").expect(l);
        let pct: u64 = pct.parse().expect(l);
        assert!(pct < 100 && rest.contains(" of 4096 pixels), ") && rest.ends_with(" s"), "{l}");
    }
    assert!(err.contains("octolux: cornell-box (32 triangles)") && err.contains("rendered 1 spp"), "{err}");
    // the log says why `--backend auto` (the default) chose the BVH
    assert!(err.contains("backend bvh8 (octolux) (auto: fewer than 65536 triangles, where the BVH is faster than Embree), "), "{err}");
    // -q: the warning (--photons with path) and nothing else
    let quiet = run(true);
    assert_eq!(quiet.lines().count(), 1, "{quiet}");
    assert!(quiet.starts_with("warning: --photons applies to"), "{quiet}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 30: the log speaks words, the paper's symbols only in brackets after them; `ward` prints
/// no raw JSON; a render from a cache says no photon was traced and not a trace time; a bare
/// mesh inserted has no light to be ignored.
#[test]
fn log_lines_are_words_with_the_papers_symbols_in_brackets() {
    let dir = std::env::temp_dir().join(format!("octolux-cli-log-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let out = dir.join("x.exr");
    let run = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_octolux"))
            .args(args)
            .args(["--spp", "1", "--resolution", "8x8", "-o"])
            .arg(&out)
            .output()
            .expect("octolux runs");
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{args:?}: {err}");
        err
    };
    let symbols = ["m_v", "n_p", "F_m", "t_c", "m_e", "m_a"];
    for integrator in ["octree", "photonmap", "ward", "christensen"] {
        let err = run(&["render", "--integrator", integrator, "--photons", "2000"]);
        assert!(!err.contains('{'), "{integrator}: JSON on the log: {err}");
        for line in err.lines() {
            // every symbol sits in brackets right after the words it stands for
            for s in symbols {
                for (i, _) in line.match_indices(s) {
                    assert!(line[..i].ends_with('[') && line[i + s.len()..].starts_with(']'), "{integrator}: bare {s}: {line}");
                    assert!(line[..i - 1].ends_with(' ') && !line[..i - 1].trim_end().is_empty(), "{integrator}: {s} alone: {line}");
                }
            }
        }
    }
    let octree = run(&["render", "--integrator", "octree", "--photons", "2000"]);
    assert!(octree.contains(" valid leaves [m_v] of ") && octree.contains(" photons per leaf [n_p]"), "{octree}");
    let ward = run(&["render", "--integrator", "ward", "--photons", "2000"]);
    assert!(ward.contains(" cache samples [m_e]") && ward.contains(" bytes [F_m]"), "{ward}");

    // from a cache: no trace time
    let oxc = dir.join("l.oxc");
    let o = Command::new(env!("CARGO_BIN_EXE_octolux"))
        .args(["bake", "--photons", "2000", "-q", "-o"])
        .arg(&oxc)
        .output()
        .expect("octolux runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cached = run(&["render", "--cache", oxc.to_str().unwrap()]);
    assert!(cached.contains("no photon traced") && !cached.contains("traced in"), "{cached}");
    // a bare OBJ inserted: no light of its own to ignore
    let obj = dir.join("tri.obj");
    std::fs::write(&obj, "v 200 0 200\nv 300 0 200\nv 250 100 250\nf 1 2 3\n").expect("write obj");
    let inserted = run(&["render", "--cache", oxc.to_str().unwrap(), "--insert", obj.to_str().unwrap()]);
    assert!(!inserted.contains("ignored") && !inserted.contains("warning"), "{inserted}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The help texts come from doc comments of the library's types; rustdoc's link syntax
/// (`` [`Name`] ``) means nothing on a terminal. Every subcommand's `--help` and every
/// integrator's `settings` list are free of it.
#[test]
fn help_texts_carry_no_rustdoc_links() {
    let run = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_octolux")).args(args).output().expect("octolux runs");
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let top = run(&["--help"]);
    let commands: Vec<String> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect();
    assert!(commands.len() >= 8, "{top}");
    let mut texts = vec![("octolux --help".to_string(), top.clone())];
    for c in &commands {
        texts.push((format!("octolux {c} --help"), run(&[c, "--help"])));
    }
    for i in ["path", "octree", "photonmap", "ward", "christensen"] {
        texts.push((format!("octolux settings {i}"), run(&["settings", i])));
    }
    for (what, text) in texts {
        let bad: Vec<&str> = text.lines().filter(|l| l.contains("[`") || l.contains("`]")).collect();
        assert!(bad.is_empty(), "{what} shows rustdoc links:\n{}", bad.join("\n"));
    }
}
