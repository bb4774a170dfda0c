//! Probes what this crate's tests need from the machine (Chromium, the shared scenes): an
//! absent one sets `cfg(missing = "NAME")`, which marks its tests ignored (see
//! `crates/octolux-probe`).

fn main() {
    octolux_probe::build_script(&[
        "chromium",
        "scenes/bitterli-collection/box",
        "scenes/bitterli-collection/classroom",
        "scenes/bitterli-collection/dining-room",
        "scenes/bitterli-collection/sponza",
        "scenes/bitterli-collection/torus",
        "scenes/bitterli-collection/veach-lamp",
        "scenes/bitterli-cornell-box",
        "scenes/mitsuba-tutorials-cbox",
    ]);
}
