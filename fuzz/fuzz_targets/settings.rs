//! Fuzz target `settings`: [`octolux_io::fuzzing::settings`] on arbitrary bytes (a settings file (first byte: JSON or TOML)), under
//! the fuzzing memory limit. Any panic, abort or out-of-memory is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    octolux::budget::set_memory_limit(octolux_io::fuzzing::FUZZ_MEMORY_LIMIT);
    let _ = octolux_io::fuzzing::settings(data);
});
