//! Rattlers (SPEC §4): grains that carry no force in the static packing.
//!
//! Found by iterated removal: every grain with fewer than `min_contacts` force-carrying contacts
//! (F_n > 0; contacts with walls count, contacts with grains already removed do not) is removed,
//! until no more grain is removed. The default threshold is 2 for frictional packings and d + 1
//! for frictionless ones (the fewest contacts that can hold a grain in equilibrium).
//!
//! The finder is the engine's (`grainwave_core::rattlers`), which `grainwave-analysis` also
//! uses to characterize packings, so that the modes and the static characterization always agree
//! on which grains rattle.

pub use grainwave_core::rattlers::{default_rattler_threshold as default_min_contacts, find_rattlers};
