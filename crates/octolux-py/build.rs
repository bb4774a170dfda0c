//! Probes the Python environment of this crate's test (`tests/pytest.rs`): without it,
//! `cfg(missing = "python")` marks the test ignored (see `crates/octolux-probe`).

fn main() {
    octolux_probe::build_script(&["python"]);
}
