//! LAMMPS data file text → grains, by the 3D and the 2D import
//! (`grainwave_experiments::fuzzing::lammps`). Property: no input panics, aborts or allocates
//! more than its own size allows; an error message echoes at most a bounded part of the input.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = grainwave_experiments::fuzzing::lammps(data) {
        panic!("{e}");
    }
});
