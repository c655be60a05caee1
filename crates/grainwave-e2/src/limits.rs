//! The sizes an `e2` config asks for, checked when it is validated (by `grainwave check` and
//! before `run` computes anything) with the kernel's bounds ([`grainwave_study::limits`]).

use grainwave_study::config::{ConfigError, ConfigSource};
use grainwave_study::limits::{check, BYTES_PER_GRAIN, HARD_MAX_GRAINS, MAX_GRAINS, MAX_UNITS};

/// The sizes of an `e2` config: grains, and replays (units of work, bounded like e1's samples
/// and e3's runs).
pub fn check_sizes(src: &ConfigSource, cfg: &crate::E2Config) -> Result<(), ConfigError> {
    check(src, "replays", "replays", cfg.replays.len() as f64, MAX_UNITS, f64::INFINITY, 0.0)?;
    let p = &cfg.packing;
    check(src, "packing.columns", "grains (columns × rows)", p.columns as f64 * p.rows as f64, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN)
}
