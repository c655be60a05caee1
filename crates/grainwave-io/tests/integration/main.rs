//! The integration tests of grainwave-io, in one test binary (one link of the whole stack instead of
//! one per file): each module is a file of tests of one subject.

mod common;
mod lammps_adversarial;
mod lammps_forces;
mod numpy_interop;
mod plots;
mod vtk_readers;
