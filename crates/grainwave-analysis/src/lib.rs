//! # grainwave-analysis
//!
//! Analysis of grainwave results. Today: the pulse-signal metrics of SPEC §5.5 ([`signal`]) —
//! leading edge, first peak, first zero crossing, widths, time-of-flight velocity, linear and
//! power-law fits over series and effective exponents. They work on plain time series, whether
//! they come from a modal sum, a direct linear propagation or a molecular-dynamics run.
#![warn(missing_docs)]

pub mod signal;
