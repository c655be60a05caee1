//! The sizes an `e2` config asks for, checked when it is validated (by `grainwave check` and
//! before `run` computes anything) with the kernel's bounds ([`grainwave_study::limits`]).

use grainwave_study::config::{ConfigError, ConfigSource};
use grainwave_study::limits::{check, BYTES_PER_GRAIN, HARD_MAX_GRAINS, MAX_GRAINS};

/// The sizes of an `e2` config.
pub fn check_sizes(src: &ConfigSource, cfg: &crate::E2Config) -> Result<(), ConfigError> {
    let p = &cfg.packing;
    check(src, "packing.columns", "grains (columns × rows)", p.columns as f64 * p.rows as f64, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN)
}
