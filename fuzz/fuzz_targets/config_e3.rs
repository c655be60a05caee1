//! TOML text → validated `e3` spec: the shape check and the protocol's own validation (what
//! `grainwave check` runs; `grainwave_experiments::fuzzing::config`). Property: no input panics,
//! aborts or exhausts memory; a refused config has a message of bounded length.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = grainwave_experiments::fuzzing::config("e3", data) {
        panic!("{e}");
    }
});
