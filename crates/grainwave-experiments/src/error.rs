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
    /// A directory or checkpoint cannot be resumed.
    #[error("cannot resume `{}`: {reason}", .path.display())]
    Resume {
        /// What was given.
        path: PathBuf,
        /// Why.
        reason: String,
    },
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
                | ExperimentError::Core(CoreError::InvalidParameter { .. } | CoreError::UnknownName { .. } | CoreError::Inconsistent(_))
        )
    }
}

/// Result alias of the experiments.
pub type Result<T, E = ExperimentError> = std::result::Result<T, E>;
