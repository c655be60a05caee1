//! The integration tests of grainwave-core, in one test binary (one link of the whole stack instead of
//! one per file): each module is a file of tests of one subject.

mod common;
mod bad_input;
mod collisions;
mod crafted_checkpoints;
mod damping_variants;
mod determinism;
mod energy;
mod engine;
mod equilibrium;
mod force_blocks;
mod periodic;
mod shear;
mod slip_activation;
mod sort;
mod tangential;
