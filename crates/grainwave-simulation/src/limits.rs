//! The sizes a `simulation` config asks for, checked when it is validated (by `grainwave check` and
//! before `run` computes anything) with the kernel's bounds ([`grainwave_study::limits`]).

use grainwave_study::config::{ConfigError, ConfigSource};
use grainwave_study::limits::{check, BYTES_PER_GRAIN, HARD_MAX_GRAINS, MAX_GRAINS};

/// The sizes of an `experiment = "simulation"` config.
pub fn check_sizes(src: &ConfigSource, cfg: &crate::SimulationConfig) -> Result<(), ConfigError> {
    check(src, "grains.count", "grains", cfg.grains.count as f64, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN)
}
