//! Fuzz target `gltf`: [`octolux_io::fuzzing::gltf`] on arbitrary bytes (a glTF scene (.gltf JSON or .glb bytes)), under
//! the fuzzing memory limit. Any panic, abort or out-of-memory is a bug.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    octolux::budget::set_memory_limit(octolux_io::fuzzing::FUZZ_MEMORY_LIMIT);
    let _ = octolux_io::fuzzing::gltf(data);
});
