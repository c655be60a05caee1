//! Checkpoint bytes → the state of every protocol, as they are and with the checksum recomputed
//! (`grainwave_experiments::fuzzing::checkpoint`). Property: no input panics, aborts or makes the
//! decoder allocate beyond the input's size; a refusal has a message of bounded length.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = grainwave_experiments::fuzzing::checkpoint(data) {
        panic!("{e}");
    }
});
