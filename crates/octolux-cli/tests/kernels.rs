//! The kernel levels (`octolux::cpu`) from the command line: a bad `OCTOLUX_KERNELS` is refused
//! before any work, `--version` and `out.json` say which level ran, and the levels render the
//! same image, bit for bit.

use std::process::Command;

fn octolux(kernels: Option<&str>) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_octolux"));
    match kernels {
        Some(k) => c.env(octolux::cpu::KERNELS_ENV, k),
        None => c.env_remove(octolux::cpu::KERNELS_ENV),
    };
    c
}

#[test]
fn a_bad_level_is_refused_and_the_levels_render_the_same_image() {
    let dir = std::env::temp_dir().join(format!("octolux-kernels-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let out = |name: &str| dir.join(name).to_string_lossy().into_owned();
    let o = octolux(Some("avx3")).args(["render", "cornell-box", "-q", "-o", &out("bad.exr")]).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(
        String::from_utf8_lossy(&o.stderr),
        "error: OCTOLUX_KERNELS=\"avx3\" is not a kernel level: expected `baseline` or `avx2`\n"
    );
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing written");

    let v = octolux(None).arg("--version").output().unwrap();
    let text = String::from_utf8_lossy(&v.stdout);
    assert!(text.contains(&format!("kernels: {}", octolux::cpu::detected().name())), "{text}");

    let render = |kernels: Option<&str>, name: &str| {
        let o = octolux(kernels)
            .args(["render", "cornell-box", "--integrator", "path", "--spp", "4", "--resolution", "48x48", "-q", "-o", &out(name)])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out(name).replace(".exr", ".json")).unwrap()).unwrap();
        (std::fs::read(out(name)).unwrap(), json["kernels"].as_str().unwrap().to_string())
    };
    let (base, k) = render(Some("baseline"), "base.exr");
    assert_eq!(k, "baseline");
    let (wide, k) = render(None, "wide.exr");
    assert_eq!(k, octolux::cpu::detected().name());
    eprintln!("kernels: baseline against {k}");
    let _ = std::fs::remove_dir_all(&dir);
    assert!(base == wide, "the images differ between the kernel levels");
}
