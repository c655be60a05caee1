//! # grainwave-experiments
//!
//! grainwave's studies together, for the front ends (the command line, the Python module, the
//! fuzz targets): the [`registry`] — the one table that lists the studies — and what sits above
//! all of them: the [`demo`], the [`fuzzing`] entry points and the [`bench`] cases.
//!
//! The studies are crates of their own over the study kernel (`grainwave-study`, re-exported
//! here module by module): [`simulation`] (a general run: place grains, load, relax or drive,
//! record), [`e1`] (pulse transmission through pressurized Hertz–Mindlin packings, SPEC §5),
//! [`e2`] (acoustics of a packing under biaxial loading, SPEC §6) and [`e3`] (response of a
//! slab to a localized force, SPEC §7). Each is a typed config read from a TOML file (every key
//! documented, with unit and default, see [`config`]), a run function that reports progress
//! through a [`protocol::Reporter`], can be interrupted and resumed bit for bit, and writes its
//! outputs into one directory, and a typed report (also written there as `summary.json`).
//! The crate graph and how to add a study: `docs/architecture.md`.
#![warn(missing_docs)]

pub mod bench;
pub mod demo;
pub mod fuzzing;
pub mod registry;

pub use grainwave_e1 as e1;
pub use grainwave_e2 as e2;
pub use grainwave_e3 as e3;
pub use grainwave_simulation as simulation;
pub use grainwave_study::{config, limits, outputs, protocol, study, work};
pub use grainwave_study::{error_chain, ExperimentError, Result};
/// The engine types a caller of the protocols needs.
pub use grainwave_core::sim::{Control, Progress, StopReason};
/// Version of the engine (recorded in every report).
pub use grainwave_core::VERSION;

/// The engine types a front end needs to read a stored state (the command line's `inspect`):
/// the checkpoint container, the dimensions and the simulation; and the engine and linear-analysis
/// crates whole, for the Python module. Front ends depend on this crate only; it passes these
/// through from `grainwave-core` and `grainwave-linear`.
pub mod engine {
    pub use grainwave_core::checkpoint::{decode, read_bytes, verify, AnySimulation, FORMAT_VERSION, MAGIC};
    pub use grainwave_core::dim::{Dim, D2, D3};
    pub use grainwave_core::sim::Simulation;
    /// The engine crate, for a front end that steps and reads a simulation itself (the Python
    /// module: grains as arrays, contact records, checkpoints).
    pub use grainwave_core as core;
    /// Linear analysis of snapshots (dynamical matrix, modes, moduli), for the same front ends.
    pub use grainwave_linear as linear;
}
