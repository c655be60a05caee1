//! The integration tests of grainwave-linear, in one test binary (one link of the whole stack instead of
//! one per file): each module is a file of tests of one subject.

mod common;
mod chain;
mod incremental;
mod lattice_elasticity;
mod lattice_moduli;
mod linearization;
mod packing;
mod zero_modes;
