//! Relaxation to static equilibrium (SPEC §3, §7.2.2): damped molecular dynamics until the
//! kinetic energy per grain and the largest grain acceleration are below their limits, then, for
//! frictionless packings, Newton iterations on the static force balance.
//!
//! **Newton iterations.** With every contact frictionless the static state is the minimum of the
//! elastic + gravitational energy and does not depend on the path; once the dynamics has brought
//! the packing near it, grainwave-linear's active-set Newton iterations
//! ([`frictionless_equilibrium`]) find it to round-off: the closed contacts are updated until none
//! is in tension and the largest displacement increment is below `static_tolerance` (SPEC: 1e-14
//! R̄). They replace the hundreds of τ that damped dynamics needs for the softest modes of a
//! frictionless slab.

use super::config::RelaxationConfig;
use glam::DVec2;
use grainwave_core::prelude::*;
use grainwave_linear::frictionless_equilibrium::{frictionless_equilibrium, EquilibriumOptions};
use serde::{Deserialize, Serialize};

/// How a relaxation ended.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RelaxOutcome {
    /// All criteria held before the time limit.
    pub converged: bool,
    /// Steps of molecular dynamics done by this relaxation.
    pub steps: u64,
    /// Simulated time of this relaxation [τ].
    pub duration: f64,
    /// Kinetic energy per grain when the dynamics stopped (0 after Newton iterations) [m̄gR̄].
    pub kinetic_energy_per_grain: f64,
    /// Largest grain acceleration of the state at rest (velocities zeroed) [g].
    pub max_acceleration: f64,
    /// Newton iterations done (0 when not applicable).
    pub newton_iterations: usize,
    /// Largest displacement increment of the last Newton iteration [R̄].
    pub newton_last_increment: f64,
    /// Why Newton stopped early, if it did.
    pub newton_note: Option<String>,
}

/// Stop criteria of a relaxation that started at step `start_step`, with acceleration limit
/// `max_acceleration`, not converging before `not_before`.
pub fn criteria(relax: &RelaxationConfig, ke: f64, max_acceleration: f64, start_step: u64, dt: f64, extra_time: f64, not_before: Option<f64>) -> StopCriteria {
    let steps = ((relax.max_time + extra_time) / dt).ceil() as u64;
    StopCriteria {
        step_limit: Some(start_step + steps),
        kinetic_energy_per_grain: Some(ke),
        max_acceleration: Some(max_acceleration),
        check_every: relax.check_every,
        not_before_time: not_before,
        ..Default::default()
    }
}

/// Zeroes velocities and angular velocities and recomputes the forces.
pub fn at_rest(sim: &mut Simulation<D2>) -> grainwave_core::Result<()> {
    for v in &mut sim.grains.vel {
        *v = glam::DVec2::ZERO;
    }
    for w in &mut sim.grains.omega {
        *w = 0.0;
    }
    sim.refresh_forces()
}

/// Largest grain acceleration of the current forces.
pub fn max_acceleration(sim: &Simulation<D2>) -> f64 {
    sim.progress(&StopCriteria::default()).max_acceleration
}

/// Newton iterations on the static force balance of a frictionless packing (see the module docs).
/// Returns (outer iterations, last increment, note when the tolerance was not reached).
pub fn newton(sim: &mut Simulation<D2>, tolerance: f64, max_iterations: usize) -> grainwave_core::Result<(usize, f64, Option<String>)> {
    at_rest(sim)?;
    let snapshot = sim.snapshot();
    let mut external: Vec<DVec2> = sim.grains.mass.iter().map(|&m| sim.gravity * m).collect();
    for load in &sim.loads {
        if let Some(k) = sim.grains.index_of(load.grain) {
            external[k] += load.force * load.profile.eval(sim.time);
        }
    }
    let options = EquilibriumOptions { tolerance, max_iterations, ..Default::default() };
    match frictionless_equilibrium(&snapshot, &external, &options) {
        Ok(sol) => {
            for (p, d) in sim.grains.pos.iter_mut().zip(&sol.displacement) {
                *p += *d;
            }
            sim.refresh()?;
            at_rest(sim)?;
            let note = (!sol.converged).then(|| format!("stopped after {} iterations at an increment of {:.3e}", sol.iterations, sol.last_increment));
            Ok((sol.iterations, sol.last_increment, note))
        }
        Err(e) => Ok((0, f64::NAN, Some(format!("not applied: {e}")))),
    }
}
