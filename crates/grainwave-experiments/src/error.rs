//! Errors of the experiment protocols.

use grainwave_core::CoreError;
use grainwave_io::OutputError;
use thiserror::Error;

/// Everything that can make an experiment fail.
#[derive(Debug, Error)]
pub enum ExperimentError {
    /// Invalid parameters, an impossible set-up, or a failure of the engine (e.g. a numerical
    /// blow-up); the message names the config key or the grain concerned.
    #[error(transparent)]
    Core(#[from] CoreError),
    /// An output file could not be written.
    #[error("cannot write the outputs")]
    Output(#[from] OutputError),
}

impl ExperimentError {
    /// True when the error comes from the input (a parameter out of range, an unknown name, an
    /// inconsistent set-up) rather than from running or writing.
    pub fn is_input_error(&self) -> bool {
        matches!(
            self,
            ExperimentError::Core(CoreError::InvalidParameter { .. } | CoreError::UnknownName { .. } | CoreError::Inconsistent(_))
        )
    }
}

/// Result alias of the experiments.
pub type Result<T, E = ExperimentError> = std::result::Result<T, E>;
