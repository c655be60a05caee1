//! Errors of the linear analysis. Every variant carries the data needed to understand and fix the
//! problem (sizes, indices, residuals), in the style of faer's error enums.

use thiserror::Error;

/// Everything that can go wrong in `grainwave-linear`.
#[derive(Debug, Error)]
pub enum LinearError {
    /// A parameter is outside its allowed range.
    #[error("invalid value for `{field}`: {value} (allowed: {allowed})")]
    InvalidParameter {
        /// Name of the parameter.
        field: String,
        /// The offending value, as written.
        value: String,
        /// What would have been accepted.
        allowed: String,
    },
    /// A vector has the wrong length.
    #[error("`{what}` has length {found}, expected {expected}")]
    LengthMismatch {
        /// Which vector.
        what: String,
        /// Expected length.
        expected: usize,
        /// Actual length.
        found: usize,
    },
    /// The snapshot and the requested analysis do not fit together.
    #[error("inconsistent input: {0}")]
    Inconsistent(String),
    /// A wall index does not exist in the snapshot's domain.
    #[error("wall index {index} does not exist (the domain has {walls} walls)")]
    UnknownWall {
        /// Index asked for.
        index: u32,
        /// Number of walls.
        walls: usize,
    },
    /// No free grain touches a wall that a pulse source or detector needs.
    #[error("no free grain is in contact with wall `{wall}` (index {index}): it can neither emit nor receive a pulse")]
    NoWallContacts {
        /// Wall name.
        wall: String,
        /// Wall index.
        index: u32,
    },
    /// The problem has no free degree of freedom.
    #[error("the linear system has no free degree of freedom (every dof is constrained or removed)")]
    NoFreeDofs,
    /// The dense eigensolver refused the problem or failed.
    #[error("dense eigen-decomposition of {dofs} dofs failed: {reason}")]
    Eigen {
        /// Number of free dofs.
        dofs: usize,
        /// Why.
        reason: String,
    },
    /// The dense eigensolver would need more memory than allowed.
    #[error(
        "a dense eigen-decomposition of {dofs} dofs needs about {gib:.1} GiB (limit {limit} dofs, \
         key `max_dense_dofs`): use direct propagation for systems this large"
    )]
    TooLargeForDense {
        /// Number of free dofs.
        dofs: usize,
        /// Allowed maximum.
        limit: usize,
        /// Estimated memory (GiB).
        gib: f64,
    },
    /// The static solver met a direction of zero or negative stiffness (a floppy mode that is not a
    /// rigid-body translation or a zero-stiffness dof, or an instability of the pre-stressed system).
    #[error(
        "the stiffness matrix is not positive definite on the loaded subspace: conjugate gradient met a \
         direction with pᵀDp/pᵀdiag(D)p = {curvature:.3e} at iteration {iteration}; the packing has a floppy \
         mode that the load excites (remove rattlers, constrain the mode, or set a regularization)"
    )]
    NotPositiveDefinite {
        /// Iteration at which it happened.
        iteration: usize,
        /// Rayleigh quotient of the search direction, relative to the diagonal.
        curvature: f64,
    },
    /// The static solver did not reach its tolerance.
    #[error("conjugate gradient did not converge: relative residual {residual:.3e} after {iterations} iterations (tolerance {tolerance:.1e})")]
    NoConvergence {
        /// Iterations done.
        iterations: usize,
        /// Relative residual reached.
        residual: f64,
        /// Requested tolerance.
        tolerance: f64,
    },
    /// A method that needs a symmetric D got the full (non-symmetric) linearization.
    #[error("{what} needs a symmetric dynamical matrix; the full linearization (`prestress = \"full\"`) is not symmetric and serves direct propagation only")]
    NotSymmetric {
        /// The method.
        what: String,
    },
    /// Time propagation produced non-finite values.
    #[error("direct propagation blew up at t = {time:.6e} (step {step}, dt = {dt:.4e}): the time step exceeds the stability limit of the largest frequency")]
    Unstable {
        /// Time reached.
        time: f64,
        /// Step index.
        step: u64,
        /// Time step used.
        dt: f64,
    },
}

/// Result alias of the linear analysis.
pub type Result<T, E = LinearError> = std::result::Result<T, E>;

impl LinearError {
    /// Shorthand for [`LinearError::InvalidParameter`].
    pub fn invalid(field: impl Into<String>, value: impl std::fmt::Display, allowed: impl Into<String>) -> Self {
        LinearError::InvalidParameter { field: field.into(), value: value.to_string(), allowed: allowed.into() }
    }

    /// Checks a length.
    pub(crate) fn check_len(what: &str, expected: usize, found: usize) -> Result<()> {
        if expected == found {
            Ok(())
        } else {
            Err(LinearError::LengthMismatch { what: what.into(), expected, found })
        }
    }
}
