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
//! * [`special`]: the error function;
//! * [`packing`]: static characterization of a packing (SPEC §4, §5.2) — solid fractions, rattlers,
//!   coordination, force moments, fabric, stress, bulk values away from the walls;
//! * [`ensemble`]: means and standard deviations over samples, ensemble average and r.m.s. of
//!   signals;
//! * [`pulse_series`]: arrival-time fits, c_tof and amplitude/width exponents over heights (SPEC §5.5).
//!
//! Analysis reads snapshots and contact records of `grainwave-core`; it never reaches into the
//! engine's internals.
#![warn(missing_docs)]

pub mod coarse_grain;
pub mod ensemble;
pub mod network;
pub mod packing;
pub mod peaks;
pub mod pulse_series;
pub mod signal;
pub mod special;
pub mod stress;
