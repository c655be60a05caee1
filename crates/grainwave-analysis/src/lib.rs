//! # grainwave-analysis
//!
//! Analysis of grainwave results:
//!
//! * [`signal`]: the pulse-signal metrics of SPEC §5.5 — leading edge, first peak, first zero
//!   crossing, widths, time-of-flight velocity, linear and power-law fits over series and effective
//!   exponents. They work on plain time series, whether they come from a modal sum, a direct linear
//!   propagation or a molecular-dynamics run;
//! * [`stress`]: the contact (virial) stress of a snapshot (SPEC §4), principal values;
//! * [`coarse_grain`]: Gaussian smoothing along a line, and the Goldhirsch coarse-grained density
//!   and stress fields of a snapshot on a grid (SPEC §4);
//! * [`network`]: contacts opened, created and sliding between two snapshots, the contact-force
//!   difference field and the size of the region of opened contacts (SPEC §7.2.5);
//! * [`peaks`]: peaks with prominences and the single/double-peak classifier (SPEC §7.2.8);
//! * [`special`]: the error function.
//!
//! Analysis reads snapshots and contact records of `grainwave-core`; it never reaches into the
//! engine's internals.
#![warn(missing_docs)]

pub mod coarse_grain;
pub mod network;
pub mod peaks;
pub mod signal;
pub mod special;
pub mod stress;
