//! # grainwave-experiments
//!
//! Experiment protocols. Each protocol is a typed, serde-readable config with documented
//! defaults, a `run_*` function that reports progress through a callback and writes its outputs
//! into one directory, and a typed report (also written there as `summary.json`).
//!
//! So far there is one protocol, the [`demo`]: a loose gas of polydisperse disks settles under
//! gravity in a box with frictionless walls until static equilibrium, and the force on the floor
//! is compared with the total weight.
#![warn(missing_docs)]

pub mod demo;
mod error;

pub use error::{ExperimentError, Result};
/// The engine types a caller of the protocols needs: progress reports, the answer to them, and
/// why a run stopped.
pub use grainwave_core::sim::{Control, Progress, StopReason};
/// Version of the engine (recorded in every report).
pub use grainwave_core::VERSION;
