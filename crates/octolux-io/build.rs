//! Probes the shared scenes this crate's tests read: an absent one sets
//! `cfg(missing = "scenes/...")`, which marks its tests ignored (see `crates/octolux-probe`).

fn main() {
    octolux_probe::build_script(&[
        "scenes/bitterli-collection/box",
        "scenes/bitterli-collection/classroom",
        "scenes/bitterli-collection/dining-room",
        "scenes/bitterli-collection/sponza",
        "scenes/bitterli-collection/torus",
        "scenes/bitterli-collection/veach-lamp",
        "scenes/bitterli-cornell-box",
        "scenes/mitsuba-tutorials-cbox",
        "scenes/stanford-bunny",
    ]);
}
