//! The sizes an `e1` config asks for, checked when it is validated (by `grainwave check` and
//! before `run` computes anything) with the kernel's bounds ([`grainwave_study::limits`]).

use grainwave_study::config::{ConfigError, ConfigSource};
use grainwave_study::limits::{check, BYTES_PER_GRAIN, HARD_MAX_GRAINS, MAX_GRAINS, MAX_POINTS, MAX_UNITS};

/// The sizes of an `e1` config that the plan would allocate (before planning).
pub fn check_config(src: &ConfigSource, cfg: &crate::E1Config) -> Result<(), ConfigError> {
    let (sizes, pressures) = if let Some(p) = &cfg.packing {
        let sizes = p.heights.as_ref().map(Vec::len).or(p.grains.as_ref().map(Vec::len)).unwrap_or(0);
        if let Some(g) = &p.grains {
            for (k, n) in g.iter().enumerate() {
                check(src, &format!("packing.grains[{k}]"), "grains", *n as f64, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN)?;
            }
        }
        (sizes, p.pressures.len())
    } else if let Some(l) = &cfg.lattice {
        for (k, r) in l.rows.iter().enumerate() {
            check(src, &format!("lattice.rows[{k}]"), "grains", *r as f64 * l.columns as f64, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN)?;
        }
        (l.rows.len(), l.pressures.len())
    } else if let Some(c) = &cfg.chain {
        for (k, n) in c.grains.iter().enumerate() {
            check(src, &format!("chain.grains[{k}]"), "grains", *n as f64, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN)?;
        }
        (c.grains.len(), 1)
    } else {
        (0, 0)
    };
    let groups = (sizes * pressures.max(1)) as f64;
    // every task keeps its signals (two per time sample) until the outputs are written
    let per_task = 64.0 + 16.0 * cfg.pulse.time_samples as f64;
    check(src, "samples", "samples", cfg.samples as f64, MAX_UNITS, f64::INFINITY, 0.0)?;
    check(src, "pulse.time_samples", "time samples", cfg.pulse.time_samples as f64, MAX_POINTS, f64::INFINITY, 16.0 * groups.max(1.0))?;
    check(src, "samples", "tasks (samples × sizes × pressures)", cfg.samples as f64 * groups.max(1.0), MAX_UNITS, f64::INFINITY, per_task)?;
    // one damped MD run (a whole pulse, stepped) per damping fraction, on each of the first
    // `damped.samples` samples of every group: 100 000 fractions ran for minutes inside one
    // sample, out of reach of the interrupt
    if let Some(d) = &cfg.damped {
        let runs = d.damping_fractions.len() as f64 * d.samples.min(cfg.samples) as f64 * groups.max(1.0);
        check(src, "damped.damping_fractions", "damped MD runs (damping fractions × damped samples × sizes × pressures)", runs, MAX_DAMPED_RUNS, f64::INFINITY, per_task)?;
    }
    Ok(())
}

/// The most damped MD runs a config may ask for without `--allow-large`: each is a whole pulse
/// stepped by molecular dynamics inside its sample (the published study has 4 fractions × 1 sample
/// per group).
pub const MAX_DAMPED_RUNS: f64 = 1.0e3;

/// The grain counts an `e1` plan computed (from `heights`).
pub fn check_plan(src: &ConfigSource, plan: &crate::plan::Plan) -> Result<(), ConfigError> {
    for g in &plan.groups {
        let key = match (&plan.config.packing, &plan.kind) {
            (Some(p), crate::plan::StudyKind::Packing) if p.heights.is_some() => format!("packing.heights[{}]", g.size_index),
            (Some(_), crate::plan::StudyKind::Packing) => format!("packing.grains[{}]", g.size_index),
            (_, crate::plan::StudyKind::Lattice) => format!("lattice.rows[{}]", g.size_index),
            _ => format!("chain.grains[{}]", g.size_index),
        };
        check(src, &key, "grains", g.grains as f64, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN)?;
    }
    // samples prepared at once hold the largest group's grains each: named by their own key (a
    // parallel_samples of 2³¹ was blamed on `packing.heights[0]`)
    if let Some(parallel) = plan.config.parallel_samples {
        let largest = plan.groups.iter().map(|g| g.grains).max().unwrap_or(0) as f64;
        check(src, "parallel_samples", "samples at once", parallel as f64, f64::INFINITY, f64::INFINITY, BYTES_PER_GRAIN * largest)?;
    }
    Ok(())
}
