//! # grainwave-experiments
//!
//! Experiment protocols. Each protocol is a typed config read from a TOML file (every key
//! documented, with unit and default, see [`config`]), a run function that reports progress
//! through a [`protocol::Reporter`], can be interrupted and resumed bit for bit, and writes its
//! outputs into one directory, and a typed report (also written there as `summary.json`).
//!
//! Protocols: [`simulation`] (a general run: place grains, load, relax or drive, record),
//! [`e1`] (pulse transmission through pressurized Hertz–Mindlin packings, SPEC §5), [`e2`]
//! (acoustics of a packing under biaxial loading, SPEC §6) and [`e3`] (response of a slab to a
//! localized force, SPEC §7). The [`demo`]
//! is an embedded `e1` config: a 200-grain packing, its characterization, moduli and pulse.
#![warn(missing_docs)]

pub mod bench;
pub mod config;
pub mod demo;
pub mod e1;
pub mod e2;
pub mod e3;
mod error;
pub mod fuzzing;
pub mod limits;
pub mod outputs;
pub mod protocol;
pub mod registry;
pub mod simulation;
pub mod study;
pub mod work;

pub use error::{error_chain, ExperimentError, Result};
/// The engine types a caller of the protocols needs.
pub use grainwave_core::sim::{Control, Progress, StopReason};
/// Version of the engine (recorded in every report).
pub use grainwave_core::VERSION;

/// The engine types a front end needs to read a stored state (the command line's `inspect`):
/// the checkpoint container, the dimensions and the simulation; and the engine and linear-analysis
/// crates whole, for the Python module. Front ends depend on this crate only; it passes these
/// through from `grainwave-core` and `grainwave-linear`.
pub mod engine {
    pub use grainwave_core::checkpoint::{decode, read_bytes, verify, FORMAT_VERSION, MAGIC};
    pub use grainwave_core::dim::{Dim, D2, D3};
    pub use grainwave_core::sim::Simulation;
    /// The engine crate, for a front end that steps and reads a simulation itself (the Python
    /// module: grains as arrays, contact records, checkpoints).
    pub use grainwave_core as core;
    /// Linear analysis of snapshots (dynamical matrix, modes, moduli), for the same front ends.
    pub use grainwave_linear as linear;
}
