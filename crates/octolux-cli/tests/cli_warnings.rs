//! The `octolux` binary warns about options that the chosen integrator ignores.

use std::process::Command;

#[test]
fn octree_options_with_another_integrator_are_reported_as_ignored() {
    let dir = std::env::temp_dir().join(format!("octolux-cli-warnings-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let out = dir.join("x.exr");
    let run = |integrator: &str| {
        let o = Command::new(env!("CARGO_BIN_EXE_octolux"))
            .args(["render", "cornell-box", "--integrator", integrator, "--caustic-n-max", "40", "--split", "normal"])
            .args(["--spp", "1", "--resolution", "4x4", "--photons", "2000", "-q", "-o"])
            .arg(&out)
            .output()
            .expect("octolux runs");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let path = run("path");
    assert!(path.contains("warning: --caustic-n-max applies to --integrator octree only"), "{path}");
    assert!(path.contains("warning: --split applies to --integrator octree only"), "{path}");
    let octree = run("octree");
    assert!(!octree.contains("applies to --integrator octree only"), "{octree}");
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
