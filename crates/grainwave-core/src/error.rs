//! Errors of the engine. Every variant carries the data a user needs to fix the problem.

use thiserror::Error;

/// Everything that can go wrong in `grainwave-core`.
#[derive(Debug, Error)]
pub enum CoreError {
    /// A parameter is outside its allowed range or has the wrong form.
    #[error("invalid value for `{field}`: {value} (allowed: {allowed})")]
    InvalidParameter {
        /// Name of the parameter (a config key path where known).
        field: String,
        /// The offending value, as written.
        value: String,
        /// What would have been accepted.
        allowed: String,
    },
    /// A named choice (preset, law, kind…) is not known.
    #[error("unknown {what} `{name}` (available: {available})")]
    UnknownName {
        /// What kind of name it was (e.g. "contact preset").
        what: String,
        /// The name given.
        name: String,
        /// The names that exist, comma-separated.
        available: String,
    },
    /// Two grains overlap more than allowed when a simulation is created.
    #[error(
        "grains {id_a} and {id_b} overlap by {overlap:.6e} = {relative:.4} of the smaller radius at the start \
         (allowed: at most {tolerance} of the smaller radius, key `max_initial_overlap`)"
    )]
    InitialOverlap {
        /// Stable id of the first grain.
        id_a: u32,
        /// Stable id of the second grain.
        id_b: u32,
        /// Overlap ξ (length units).
        overlap: f64,
        /// ξ / min(R_a, R_b).
        relative: f64,
        /// The tolerance in force.
        tolerance: f64,
    },
    /// The set-up is inconsistent (several parameters that cannot hold together).
    #[error("inconsistent set-up: {0}")]
    Inconsistent(String),
    /// The integration blew up; names the step, grain and its state.
    #[error(
        "numerical blow-up at step {step} (t = {time:.6e}): {reason}; grain id {grain} at position {position:?}, \
         velocity {velocity:?}, force {force:?}. Reduce the time step or check the contact parameters."
    )]
    BlowUp {
        /// Step index at which it was detected.
        step: u64,
        /// Simulated time.
        time: f64,
        /// Stable id of the grain concerned.
        grain: u32,
        /// What was detected.
        reason: String,
        /// Position of the grain.
        position: [f64; 3],
        /// Velocity of the grain.
        velocity: [f64; 3],
        /// Total force on the grain.
        force: [f64; 3],
    },
    /// A checkpoint could not be read.
    #[error("checkpoint `{path}` is unusable: {reason}")]
    Checkpoint {
        /// File path.
        path: String,
        /// Why.
        reason: String,
    },
    /// An I/O error, with the path involved (the underlying error is part of the message, not a
    /// separate source, so error chains print it once).
    #[error("{action} `{path}`: {error}")]
    Io {
        /// What was being done.
        action: String,
        /// File path.
        path: String,
        /// Underlying error.
        error: std::io::Error,
    },
}

/// Result alias of the engine.
pub type Result<T, E = CoreError> = std::result::Result<T, E>;

impl CoreError {
    /// Shorthand for [`CoreError::InvalidParameter`].
    pub fn invalid(field: impl Into<String>, value: impl std::fmt::Display, allowed: impl Into<String>) -> Self {
        CoreError::InvalidParameter { field: field.into(), value: value.to_string(), allowed: allowed.into() }
    }
}

/// Checks that `value` is finite and strictly positive.
pub fn require_positive(field: &str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(CoreError::invalid(field, value, "a finite number > 0"))
    }
}

/// Checks that `value` is finite and ≥ 0.
pub fn require_non_negative(field: &str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(CoreError::invalid(field, value, "a finite number ≥ 0"))
    }
}

/// Checks that `value` is finite.
pub fn require_finite(field: &str, value: f64) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(CoreError::invalid(field, value, "a finite number"))
    }
}
