//! The sizes an `e3` config asks for, checked when it is validated (by `grainwave check` and
//! before `run` computes anything) with the kernel's bounds ([`grainwave_study::limits`]).

use grainwave_study::config::{ConfigError, ConfigSource};
use grainwave_study::limits::{check, BYTES_PER_GRAIN, HARD_MAX_GRAINS, MAX_GRAINS, MAX_POINTS, MAX_UNITS};

/// The sizes of an `e3` config: slab grains, samples and points of the response profiles.
pub fn check_sizes(src: &ConfigSource, cfg: &crate::E3Config) -> Result<(), ConfigError> {
    use crate::config::Mode;
    let s = &cfg.slab;
    let sweep = cfg.mode == Mode::Sweep && !cfg.sweep.sizes.is_empty();
    let sizes: Vec<[usize; 2]> = if sweep { cfg.sweep.sizes.clone() } else { vec![[s.layers, s.grains_per_layer]] };
    let key = if sweep { "sweep.sizes" } else { "slab.layers" };
    check(src, "samples", "samples", cfg.samples as f64, MAX_UNITS, f64::INFINITY, 0.0)?;
    // the plan holds one set per combination of the sweep's lists, `samples` cases per set and
    // one run per case, force and variant (checked before the plan is built)
    if cfg.mode != Mode::LatticeElasticity {
        let len = |n: usize| n.max(1) as f64;
        let sets = if cfg.mode == Mode::Sweep {
            len(cfg.sweep.sizes.len()) * len(cfg.sweep.deltas.len()) * len(cfg.sweep.frictions.len()) * len(cfg.sweep.stiffness_ratios.len())
        } else {
            1.0
        };
        let sets_key = if cfg.mode == Mode::Sweep { "sweep" } else { "samples" };
        check(src, sets_key, "sets (sizes × deltas × frictions × stiffness ratios)", sets, MAX_UNITS, f64::INFINITY, 256.0)?;
        let cases = sets * cfg.samples.max(1) as f64;
        check(src, "samples", "cases (sets × samples)", cases, MAX_UNITS, f64::INFINITY, 256.0)?;
        if cfg.mode != Mode::Pile {
            let variants = if cfg.mode == Mode::Superposition { 3.0 } else { 1.0 };
            check(src, "load.forces", "response runs (cases × forces × variants)", cases * len(cfg.load.forces.len()) * variants, MAX_UNITS, f64::INFINITY, 256.0)?;
        }
    }
    let mut widest = 0.0f64;
    for [l, m] in &sizes {
        check(src, key, "grains (layers × grains per layer)", *l as f64 * *m as f64, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN)?;
        widest = widest.max(2.0 * *m as f64 + 1.0);
    }
    if cfg.mode == Mode::Pile {
        let p = &cfg.pile;
        let n = p.layers as f64 * (p.top_grains as f64 + p.layers as f64);
        check(src, "pile.layers", "grains", n, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN)?;
        widest = widest.max(2.0 * (p.top_grains as f64 + p.layers as f64));
    }
    let rc = &cfg.response;
    // a profile holds one point per step across the slab, for every width and sample
    let per_point = 8.0 * (rc.widths.len().max(1) as f64) * 4.0;
    for (k, step) in [("response.profile_step", rc.profile_step), ("response.stress_step", rc.stress_step)] {
        if step.is_finite() && step > 0.0 {
            check(src, k, "profile points (slab width / step)", widest / step + 1.0, MAX_POINTS, f64::INFINITY, per_point)?;
        }
    }
    Ok(())
}
