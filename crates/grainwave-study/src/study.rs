//! The shape every study has: a [`Protocol`].
//!
//! ```text
//! TOML text ──parse──► Config ──validate──► Spec ──start──► State ──run──► Report
//!  (ConfigSource)      (serde, schema)      (always valid:    (checkpoint.gwck)  (summary.json,
//!                                            ranges, plan)                        tables, plots)
//! ```
//!
//! * `Config` is the raw serde struct of the file; its JSON schema drives the shape check and the
//!   config reference (docs/config.md).
//! * `Spec` is what validation returns: a value whose fields are valid (keys checked against
//!   their ranges and each other, every error naming the key, the value and what is allowed),
//!   with the *plan* of the run where the study has one: its units of work (samples, reference
//!   states, response runs…) with stable ids and declared inputs ([`crate::work`]).
//! * `State` is the whole resumable state of a run, written to `checkpoint.gwck`; it carries
//!   the spec (the resolved config and the plan made from it), so that `run`, `resume`, `plot`
//!   and the worker processes never validate or plan again, and `grainwave resume` can check
//!   that a checkpoint belongs to its directory. A study that changes its state's layout gives
//!   it a new content tag and reads the earlier one with [`Protocol::upgrade`].
//! * `run` executes the plan (the units on the [`crate::work::Scheduler`], which persists each
//!   result and skips the finished ones on resume), aggregates the results in the order of the
//!   unit ids (so the bits do not depend on the thread count or the completion order), writes
//!   the outputs and returns the typed `Report`.
//!
//! The registry ([`crate::registry::PROTOCOLS`]) holds one entry per protocol, built from its
//! `Protocol` implementation; `grainwave check`, `run`, `resume`, `plot`, `reference`, the
//! fuzz targets and the checkpoint decoders all go through it.

use crate::config::{ConfigError, ConfigSource};
use crate::error::Result;
use crate::protocol::RunContext;
use crate::work::{Unit, WorkerLink};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use serde::{de::DeserializeOwned, Serialize};
use std::path::Path;

/// A study: config → validated spec → state → run → report.
pub trait Protocol: 'static {
    /// The name a config selects it with (`experiment = "…"`).
    const NAME: &'static str;
    /// Content tag of its state in `checkpoint.gwck`.
    const TAG: &'static str;
    /// The introduction of its section in the config reference (what it does, its units).
    const REFERENCE: &'static str;
    /// The raw config (serde; its schema checks shapes and generates the reference).
    type Config: Serialize + DeserializeOwned + schemars::JsonSchema;
    /// The validated config (and plan).
    type Spec;
    /// The resumable state of a run.
    type State: Serialize + DeserializeOwned;
    /// The typed result of a run (written as `summary.json`).
    type Report: Serialize;

    /// Parses and validates a config file into its spec.
    fn validate(src: &ConfigSource) -> Result<Self::Spec, ConfigError>;
    /// What `grainwave check` prints about a valid spec.
    fn describe(spec: &Self::Spec) -> Vec<String>;
    /// Checks what a valid spec names outside the file (the directory of an earlier run it
    /// starts from…): called by `grainwave check` and before a run computes anything, so that a
    /// missing input is refused as a config error (exit 2) instead of failing the run; not by
    /// [`Protocol::validate`] (a config stays valid, and its plan listable, before the run it
    /// names has been made). The default has nothing to check.
    fn check_inputs(_src: &ConfigSource, _spec: &Self::Spec) -> Result<(), ConfigError> {
        Ok(())
    }
    /// The units of work of a run of `spec` ([`crate::work::Unit`]: stable ids, declared inputs),
    /// in the order of aggregation; the same list the run gives its scheduler, so that a generic
    /// driver (another process, MPI ranks, Python) can list and place them.
    fn plan(spec: &Self::Spec) -> Vec<Unit>;
    /// A fresh state for a run of `spec`.
    fn start(spec: Self::Spec) -> Self::State;
    /// The resolved config a state carries.
    fn config(state: &Self::State) -> &Self::Config;
    /// Runs (or continues) the state until the run is done, writing every output into the
    /// context's directory.
    fn run(state: &mut Self::State, ctx: &mut RunContext<'_>) -> Result<Self::Report>;
    /// Runs, in a worker process (an MPI rank ≠ 0), the units of `state`'s run in `out` that the
    /// coordinator sends, until it says to quit ([`crate::work::serve`]).
    fn serve(state: &mut Self::State, out: &Path, link: &dyn WorkerLink, interrupt: Arc<AtomicBool>) -> Result<()>;
    /// The lines `grainwave run` prints at the end.
    fn summary_lines(report: &Self::Report, out: &Path) -> Vec<String>;
    /// Re-makes the plots (and tables) of the run in `dir` from its saved data; returns the files
    /// written, relative to `dir`.
    fn replot(dir: &Path, state: &Self::State) -> Result<Vec<String>>;

    /// Content tags of earlier layouts of `State` that [`Protocol::upgrade`] still reads
    /// (checkpoints written by earlier versions); empty when there is none.
    const EARLIER_TAGS: &'static [&'static str] = &[];
    /// Reads checkpoint `file`, whose content tag `tag` is one of [`Protocol::EARLIER_TAGS`], into
    /// the current `State`. This is the one place where a state is made again from the config an
    /// earlier layout carried (a run and its resumption otherwise use the spec the state holds);
    /// the resumed run then saves the current layout. The default refuses.
    fn upgrade(tag: &str, file: &Path) -> Result<Self::State> {
        Err(crate::error::ExperimentError::Resume {
            path: file.to_path_buf(),
            reason: format!("its checkpoint holds `{tag}`, an earlier layout of the {} state that this version does not read", Self::NAME),
        })
    }

    /// Every file a run writes into its output directory, declared once
    /// ([`crate::outputs::OutputFile`]; the common ones are [`crate::outputs::COMMON`]).
    const OUTPUTS: &'static [crate::outputs::OutputFile];
}
