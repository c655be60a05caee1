//! The table of grainwave's studies — the one place that lists them — and dispatch by the
//! `experiment` key over it: check, run, resume and re-plot any study, generate the config
//! reference. The machinery is the kernel's ([`grainwave_study::registry`]); these functions
//! are its methods on [`REGISTRY`].

use crate::config::{ConfigError, ConfigSource};
use crate::protocol::RunContext;
use crate::work::{Unit, WorkerLink};
use crate::{e1, e2, e3, simulation, Result};
pub use grainwave_study::registry::{belongs_to, entry, Entry, Registry, RunSummary};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// Every protocol, in the order of the config reference.
pub static PROTOCOLS: [Entry; 4] =
    [entry::<simulation::SimulationProtocol>(), entry::<e1::E1Protocol>(), entry::<e2::E2Protocol>(), entry::<e3::E3Protocol>()];

/// The registry of every protocol.
pub static REGISTRY: Registry = Registry::new(&PROTOCOLS);

/// Names of the protocols a config can select with `experiment = "…"`.
pub const EXPERIMENTS: &[&str] = &[PROTOCOLS[0].name, PROTOCOLS[1].name, PROTOCOLS[2].name, PROTOCOLS[3].name];

/// The entry of protocol `name`.
pub fn protocol(name: &str) -> Option<&'static Entry> {
    REGISTRY.protocol(name)
}

/// The protocol a config selects, from its top-level `experiment` key.
pub fn experiment(src: &ConfigSource) -> Result<&'static Entry, ConfigError> {
    REGISTRY.experiment(src)
}

/// The name of the protocol a config selects, from its top-level `experiment` key.
pub fn experiment_name(src: &ConfigSource) -> Result<String, ConfigError> {
    experiment(src).map(|p| p.name.to_string())
}

/// Checks the shapes of the file's values against the schema of protocol `name`
/// ([`crate::config::check_shapes`]); a name that is not a protocol's passes.
pub fn check_shapes(src: &ConfigSource, name: &str) -> Result<(), ConfigError> {
    REGISTRY.check_shapes(src, name)
}

/// What `grainwave check` prints about a valid config.
pub fn check(src: &ConfigSource) -> Result<Vec<String>, ConfigError> {
    REGISTRY.check(src)
}

/// Checks what a valid config names outside itself (an e2 `source.dir`): `grainwave check` and
/// `run` refuse a missing input before anything is computed.
pub fn check_inputs(src: &ConfigSource) -> Result<(), ConfigError> {
    REGISTRY.check_inputs(src)
}

/// The units of work of a run of a config ([`grainwave_study::study::Protocol::plan`]): what a
/// driver of the scheduler lists and places.
pub fn plan(src: &ConfigSource) -> Result<Vec<Unit>, ConfigError> {
    REGISTRY.plan(src)
}

/// Parses, validates and runs a config.
pub fn run(src: &ConfigSource, ctx: &mut RunContext<'_>) -> Result<RunSummary> {
    REGISTRY.run(src, ctx)
}

/// Continues the run whose checkpoint is in `dir`.
pub fn resume(dir: &Path, ctx: &mut RunContext<'_>) -> Result<RunSummary> {
    REGISTRY.resume(dir, ctx)
}

/// A worker process's whole part in a distributed run (an MPI rank ≠ 0): [`Registry::serve`].
pub fn serve(link: &dyn WorkerLink, interrupt: Arc<AtomicBool>) -> Result<()> {
    REGISTRY.serve(link, interrupt)
}

/// Re-makes the plots of the run in `dir` from its saved data (series and checkpoint). Returns
/// the files written, relative to `dir`.
pub fn plot(dir: &Path) -> Result<Vec<String>> {
    REGISTRY.plot(dir)
}

/// The config reference (`docs/config.md`), generated from the key definitions.
pub fn reference_markdown() -> String {
    REGISTRY.reference_markdown()
}

/// The output reference (`docs/outputs.md`), generated from each study's declaration of its
/// files.
pub fn outputs_markdown() -> String {
    REGISTRY.outputs_markdown()
}
