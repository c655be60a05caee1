//! # grainwave-linear
//!
//! Linear analysis of granular packings (SPEC §5.3–5.6, §7.3): around a static snapshot of
//! grainwave-core, every contact is replaced by its differential stiffnesses — normal
//! k_n = dF_n/dξ, tangential k_t, with the lever arms that couple rotations — and the packing's
//! small motions obey
//!
//! ```text
//! M ü = −D u
//! ```
//!
//! with u all translations and rotations (3 per grain for `disk`/`sphere2d`, 6 for `sphere`), M the
//! masses and moments of inertia, and D the dynamical (stiffness) matrix including grain–wall
//! springs and, optionally, the geometric pre-stress term. Frictional contacts and rotations are
//! handled exactly; D is assembled analytically, not by finite differences.
//!
//! The crate follows faer's layout: owned types with views ([`DynamicalMatrix::stiffness`] is a
//! faer `SparseRowMatRef`), algorithms in [`linalg`], errors as an enum with data
//! ([`LinearError`]). What it offers:
//!
//! | task | entry point |
//! |---|---|
//! | D and M, sparse (CSR) or matrix-free, rattlers kept/removed, pre-stress on/off | [`DynamicalMatrix::assemble`], [`DynamicalMatrix::apply`] |
//! | constrained dofs (fixed or imposed displacements) | [`Constraints`], [`DynamicalMatrix::free_system`] |
//! | all modes D v = ω² M v, participation ratios | [`Modes::compute`] |
//! | pulse: source/detector walls, initial conditions A and B, modal sum Σ a_n b_n sin/cos ω_n t; one-call [`pulse::modal_pulse`] and [`pulse::direct_pulse`] | [`pulse`] |
//! | direct propagation with a symplectic scheme, dt from ω_max | [`propagation`] |
//! | static response D u = f with zero modes handled | [`solve_static`] |
//! | static response by sparse Cholesky (D positive definite) | [`statics_direct`] |
//! | static equilibrium of a frictionless Hooke packing (active-set Newton) | [`frictionless_equilibrium`] |
//! | moduli C₁₁, C₁₂, C₂₂, C₃₃ / 6 × 6 Voigt, local moduli, continuum speeds | [`moduli`] |
//! | affine moduli of spring networks, half-plane criterion r | [`lattice`] |
//! | the spring network of a measured 2D packing in a window | [`measured_network`] |
//! | reference systems: 1D chain, triangular lattice | [`reference`](mod@reference) |
//!
//! Signal metrics of the pulses (leading edge, peak, widths, c_tof, exponents) live in the
//! `grainwave-analysis` crate.
//!
//! ## A pulse through a chain, two ways
//!
//! ```
//! use grainwave_linear::prelude::*;
//! use grainwave_linear::reference::ChainSpec;
//!
//! // 1. a packing: 30 balls between two walls, Hooke springs K = 1, masses 1
//! let chain = ChainSpec { grains: 30, ..ChainSpec::default() };
//! let snapshot = chain.build().unwrap().snapshot();
//!
//! // 2. contacts → D and M; constrain the transverse and rotational dofs
//! let dm = DynamicalMatrix::assemble(&snapshot, &AssemblyOptions::default()).unwrap();
//! let system = dm.free_system(&chain.constraints(), ZeroRows::Keep).unwrap();
//!
//! // 3. all modes
//! let modes = Modes::compute(&system, &EigenOptions::default()).unwrap();
//! let exact = chain.frequencies();
//! for (w, e) in modes.frequencies().iter().zip(&exact) {
//!     assert!((w - e).abs() < 1e-12 * e);
//! }
//!
//! // 4. a kick on the grain touching wall 0, the force on wall 1 as a modal sum
//! let source = source_vector(&dm, &system, 0).unwrap();
//! let detector = detector_vector(&dm, &system, 1).unwrap();
//! let state = chain.impulse().state(&system, &source).unwrap();
//! let signal = ModalSignal::new(&modes, &state, &detector.vector).unwrap();
//! let t = 25.0;
//! assert!((signal.eval(t) - chain.closed_form_signal(t, &chain.impulse())).abs() < 1e-12);
//! ```
#![warn(missing_docs)]

pub mod contact;
pub mod dofs;
pub mod dynamical;
pub mod error;
pub mod frictionless_equilibrium;
pub mod incremental;
pub mod lattice;
pub mod linalg;
pub mod measured_network;
pub mod moduli;
pub mod propagation;
pub mod pulse;
pub mod rattlers;
pub mod reference;
pub mod statics;
pub mod statics_direct;

pub use dofs::{Constraints, DofLayout};
pub use dynamical::{AssemblyOptions, DynamicalMatrix, LinearSystem, PreStress, Rattlers, SlidingContacts, ZeroRows};
pub use error::{LinearError, Result};
pub use linalg::eigen::{EigenOptions, Modes, ZeroSpaceSplit};
pub use statics::{solve_static, StaticOptions, StaticSolution};

/// The names most programs need.
pub mod prelude {
    pub use crate::dofs::{Constraints, DofLayout};
    pub use crate::dynamical::{AssemblyOptions, DynamicalMatrix, LinearSystem, PreStress, Rattlers, SlidingContacts, ZeroRows};
    pub use crate::error::{LinearError, Result};
    pub use crate::linalg::eigen::{EigenOptions, Modes, ZeroSpaceSplit};
    pub use crate::linalg::symplectic::Scheme;
    pub use crate::moduli::{elastic_moduli, local_modulus, ElasticModuli, LocalLoading, ModuliOptions, VolumeConvention};
    pub use crate::propagation::{propagate_signal, MatrixFree, PropagationOptions, Propagator, StiffnessOperator};
    pub use crate::pulse::{detector_vector, direct_pulse, modal_pulse, source_vector, InitialCondition, InitialState, ModalPulse, ModalSignal, PulseSetup};
    pub use crate::statics::{solve_static, StaticOptions, StaticSolution};
}
