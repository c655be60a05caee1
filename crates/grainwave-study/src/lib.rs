//! # grainwave-study
//!
//! The study kernel: what every grainwave study (protocol) is built from, and nothing that is
//! particular to one study.
//!
//! * [`config`]: a config file read from TOML text, with every error located (file, line,
//!   column, the key, the value and what is allowed), unknown keys refused, the shapes checked
//!   against the config's JSON schema, and the config reference generated from that schema.
//! * [`study::Protocol`]: the shape of a study — config → validated spec (with its plan) → state
//!   → run → report.
//! * [`work`]: units of work with stable ids and declared inputs, and the one scheduler that
//!   runs them on threads or other processes (MPI ranks), persisting each result as it finishes.
//! * [`link`]: the transport to worker processes (implemented by the front end).
//! * [`protocol`]: the run directory (lock, log, checkpoint, failure marker), progress
//!   reporting, interruption and resume.
//! * [`outputs`]: the files every study writes the same way (`config.resolved.toml`,
//!   `summary.json`).
//! * [`limits`]: the machinery of resource bounds (each study checks its own sizes with it).
//! * [`registry`]: dispatch by the config's `experiment` key over a table of studies, built from
//!   their [`study::Protocol`] implementations. The kernel knows no study: the table is made by
//!   the crate above the studies (`grainwave-experiments`), or by a study's own tests.
//!
//! How to add a study: `docs/architecture.md`.
#![warn(missing_docs)]

pub mod config;
mod error;
pub mod limits;
pub mod link;
pub mod outputs;
pub mod protocol;
pub mod registry;
pub mod study;
pub mod work;

pub use error::{error_chain, ExperimentError, Result};
/// The engine types a caller of the protocols needs.
pub use grainwave_core::sim::{Control, Progress, StopReason};
/// Version of the engine (recorded in every report).
pub use grainwave_core::VERSION;
