//! Errors of the experiment protocols.

use crate::config::ConfigError;
use grainwave_core::CoreError;
use grainwave_io::OutputError;
use std::path::PathBuf;
use thiserror::Error;

/// Everything that can make an experiment fail or stop early.
#[derive(Debug, Error)]
pub enum ExperimentError {
    /// The config is invalid: the message names the file, line, column, key, value and what is
    /// allowed.
    #[error("{0}")]
    Config(Box<ConfigError>),
    /// Invalid parameters, an impossible set-up, or a failure of the engine (e.g. a numerical
    /// blow-up); the message names the key or the grain concerned.
    #[error(transparent)]
    Core(#[from] CoreError),
    /// An output file could not be written.
    #[error("cannot write the outputs")]
    Output(#[from] OutputError),
    /// The run was interrupted (Ctrl-C, SIGTERM); its state is in `checkpoint`.
    #[error("interrupted; the state is saved in `{}` — continue with `grainwave resume {}`", .checkpoint.display(), .dir.display())]
    Interrupted {
        /// The checkpoint written.
        checkpoint: PathBuf,
        /// The output directory.
        dir: PathBuf,
    },
    /// Every unit of work (sample, run) failed: there is nothing to aggregate. The failures are
    /// listed (and written to `run.log`).
    #[error("every one of the {} {what} failed; nothing to aggregate:{}", .failures.len(), .failures.iter().map(|f| format!("\n    {f}")).collect::<String>())]
    AllFailed {
        /// What failed, in the plural ("samples").
        what: String,
        /// One line per failure: name and reason.
        failures: Vec<String>,
    },
    /// Some units of work (reference states, response runs, replays) failed while the others
    /// completed: the run stops before its outputs, which need every unit. Each failure is listed
    /// with its unit (and written to `run.log`); the completed units are kept, so `grainwave
    /// resume --retry` redoes only the failed ones once their cause is fixed.
    #[error("{} of the {total} {what} failed; the outputs need all of them:{}", .failures.len(), .failures.iter().map(|f| format!("\n    {f}")).collect::<String>())]
    UnitsFailed {
        /// What failed, in the plural ("response runs").
        what: String,
        /// How many units there were in the stage.
        total: usize,
        /// One line per failure: unit and reason.
        failures: Vec<String>,
    },
    /// A stage of the run did not reach its goal within the limits the config gives it (the
    /// preparation found no equilibrium within its time limit): found only by running, a failure
    /// of the run (exit code 1), not of its input. The message names the limit's key.
    #[error("{0}")]
    NotReached(String),
    /// Another process is running in the output directory (it holds the directory's lock).
    #[error("`{}` is in use by another grainwave process ({holder}); wait for it to end or give another output directory", .dir.display())]
    Busy {
        /// The directory.
        dir: PathBuf,
        /// What the lock file says about its holder (`pid N`).
        holder: String,
    },
    /// A new run cannot use the output directory.
    #[error("cannot run into `{}`: {reason}", .dir.display())]
    UsedDirectory {
        /// The directory.
        dir: PathBuf,
        /// Why, and what to do.
        reason: String,
    },
    /// The outputs of a directory cannot be (re)written by `grainwave plot`.
    #[error("cannot plot `{}`: {reason}", .path.display())]
    Plot {
        /// What was given.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A unit of work run by another process (an MPI rank) failed there, or that process could
    /// not be reached.
    #[error("{message} (on rank {rank})")]
    Rank {
        /// The rank (≥ 1) of the process.
        rank: usize,
        /// What happened there.
        message: String,
    },
    /// A directory or checkpoint cannot be resumed.
    #[error("cannot resume `{}`: {reason}", .path.display())]
    Resume {
        /// What was given.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// The message of `e` followed by those of its causes, joined by `separator` (`": "` on one line,
/// `"\n  caused by: "` on several); a cause whose text the message so far already ends with is
/// left out (an error that shows its source in its own message). The one formatting of an error
/// chain: failure lines, the failure marker, the command line's and the Python module's errors.
pub fn error_chain(e: &dyn std::error::Error, separator: &str) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let t = c.to_string();
        if !text.ends_with(&t) {
            text.push_str(separator);
            text.push_str(&t);
        }
        cause = c.source();
    }
    text
}

impl From<ConfigError> for ExperimentError {
    fn from(e: ConfigError) -> Self {
        ExperimentError::Config(Box::new(e))
    }
}

impl ExperimentError {
    /// True when the error comes from the input (a parameter out of range, an unknown name, an
    /// inconsistent set-up) rather than from running or writing.
    pub fn is_input_error(&self) -> bool {
        matches!(
            self,
            ExperimentError::Config(_)
                | ExperimentError::Resume { .. }
                | ExperimentError::Plot { .. }
                | ExperimentError::Busy { .. }
                | ExperimentError::UsedDirectory { .. }
                | ExperimentError::Core(
                    CoreError::InvalidParameter { .. }
                        | CoreError::UnknownName { .. }
                        | CoreError::Inconsistent(_)
                        | CoreError::InitialOverlap { .. }
                        // a checkpoint that cannot be read (damaged, foreign, other version) is
                        // bad input, like a checkpoint of another run
                        | CoreError::Checkpoint { .. }
                )
        )
    }
}

/// Result alias of the experiments.
pub type Result<T, E = ExperimentError> = std::result::Result<T, E>;
