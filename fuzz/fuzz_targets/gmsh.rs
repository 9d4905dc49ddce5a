#![no_main]
//! Fuzz target `gmsh`: see `harness::gmsh` for how the bytes are used.

#[path = "../harness.rs"]
#[allow(dead_code)] // each target uses one of the harness functions
mod harness;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = harness::gmsh(data);
});
