//! Fuzz target `paths`: [`octolux_io::fuzzing::paths`] on arbitrary bytes (a camera or object path file (first byte selects which)), under
//! the fuzzing memory limit. Any panic, abort or out-of-memory is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    octolux::budget::set_memory_limit(octolux_io::fuzzing::FUZZ_MEMORY_LIMIT);
    let _ = octolux_io::fuzzing::paths(data);
});
