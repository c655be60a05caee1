//! Incremental replays: the exact small-amplitude limit of a δ wall pulse on a static state,
//! computed with the piecewise-linear contact network of `grainwave_linear::incremental` instead
//! of the engine (see `docs/linear.md`, "Incremental propagation", and `docs/e2.md`).
//!
//! The state is linearized once; the pulsing wall (a piston of mass M_w under a constant load
//! F_w, so F_w = p* × its length for the right wall) becomes a rigid body of mass M_w moving along
//! its normal, and the δ pulse p_a gives it the velocity J/M_w, J = p_a · t* · F_w — the impulse
//! the engine's drive delivers in one step (SPEC §6.4). The absorbing walls keep their constant
//! dashpots; contact dashpots are left out (the engine's replays have them: the comparison
//! measures what they do to the arrival, see `docs/e2.md`). The grains' velocities are sampled
//! at the replay's sample times into the same δv field as a paired replay, so the arrival
//! definitions, strip fits and outputs are those of the DEM replays. Since the response is
//! positively homogeneous of degree one, amplitudes +1 and −1 are the p_a → 0⁺ and 0⁻ limits
//! (δv per unit p_a); any other amplitude of the same sign only scales δv.

use super::config::{IncrementalBranches, PulseShape, ReplayConfig};
use super::model::{self, Drive, PistonLoad, Units};
use super::replay::PairResult;
use grainwave_study::{ExperimentError, Result};
use grainwave_core::prelude::*;
use grainwave_linear::incremental::{BranchHistory, BranchRule, IncrementalOptions, IncrementalPropagator, Piston, StateCounts};
use serde::{Deserialize, Serialize};

impl IncrementalBranches {
    /// The linear crate's rule.
    pub fn rule(self) -> BranchRule {
        match self {
            IncrementalBranches::Incremental => BranchRule::Incremental,
            IncrementalBranches::Stick => BranchRule::Stick,
            IncrementalBranches::Free => BranchRule::Free,
            IncrementalBranches::Slip => BranchRule::Slip,
        }
    }
}

/// What an incremental replay of one amplitude found besides the δv field.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct IncrementalInfo {
    /// The branch rule.
    pub branches: String,
    /// Contact counts of the static state (at the limit, at the rolling cap, nearly open).
    pub counts: StateCounts,
    /// Branch histories of the contacts at the limit (contact index into the state's records).
    pub history: Vec<BranchHistory>,
    /// Ids (i, j) of each history's contact (j = −1 − wall index for walls).
    pub pairs: Vec<(u32, i64)>,
    /// Steps and the step length [engine time].
    pub steps: u64,
    /// Step length [engine time].
    pub dt: f64,
    /// Impulse J given to the piston [engine force × time].
    pub impulse: f64,
}

fn linear_error(e: grainwave_linear::LinearError) -> ExperimentError {
    CoreError::Inconsistent(format!("incremental replay: {e}")).into()
}

fn inconsistent(m: String) -> ExperimentError {
    CoreError::Inconsistent(format!("incremental replay: {m}")).into()
}

/// The piston load F_w of wall `wall` in `drive` (the force the δ pulse multiplies).
fn piston_load(sim: &Simulation<D2>, drive: &Drive, wall: usize) -> Option<f64> {
    // the box size only for the loads that need it (a test box may have fewer than four walls)
    drive.pistons.iter().find(|(k, _)| *k == wall).map(|(_, l)| match *l {
        PistonLoad::Height => drive.pressure * model::box_size(sim).1,
        PistonLoad::Width => drive.pressure * model::box_size(sim).0,
        PistonLoad::Force(f) => f,
    })
}

/// Runs the incremental replay of `sim` (a static state) for amplitude `amplitude` (p_a in t*)
/// under the settings of `rc` (branch rule, steps per period): `samples` samples of the δv field
/// every `sample_dt` [engine time] from the start of the replay, the pulse at `delay` [engine
/// time] — the DEM replay's sample times and pulse time.
#[allow(clippy::too_many_arguments)]
pub fn incremental_replay(sim: &Simulation<D2>, drive: &Drive, rc: &ReplayConfig, u: &Units, amplitude: f64, samples: usize, sample_dt: f64, delay: f64) -> Result<(PairResult, IncrementalInfo)> {
    if rc.shape != PulseShape::Delta {
        return Err(inconsistent("an incremental replay needs shape = \"delta\"".into()));
    }
    let wall = drive.pulse_wall;
    let mass = match sim.domain.walls[wall].motion {
        WallMotion::Piston { mass, .. } => mass,
        _ => {
            return Err(inconsistent(format!("the pulse wall `{}` of the start state is not a piston", sim.domain.walls[wall].name)))
        }
    };
    let load = piston_load(sim, drive, wall).ok_or_else(|| inconsistent("the pulse wall has no piston load in the drive".into()))?;
    let snapshot = sim.snapshot();
    let options = IncrementalOptions { branches: rc.branches.rule(), steps_per_period: rc.steps_per_period, ..Default::default() };
    let mut p = IncrementalPropagator::<D2>::new(&snapshot, Some(Piston { wall: wall as u32, mass }), &options).map_err(linear_error)?;
    let impulse = amplitude * u.time * load;
    p.set_piston_velocity(impulse / mass).map_err(linear_error)?;
    let n = snapshot.len();
    let mut out = PairResult { grains: n, positions: super::strain::positions_by_id(&sim.grains), ..Default::default() };
    for k in 0..samples {
        let t = k as f64 * sample_dt;
        let mut row = vec![0.0f32; 2 * n];
        if t > delay {
            p.advance_to(t - delay).map_err(linear_error)?;
            let v = p.velocity();
            for g in 0..n {
                let id = snapshot.id[g] as usize;
                let (vx, vy) = (v[3 * g], v[3 * g + 1]);
                out.max_difference = out.max_difference.max(vx.abs()).max(vy.abs());
                row[2 * id] = vx as f32;
                row[2 * id + 1] = vy as f32;
            }
        }
        out.times.push(t);
        out.field.extend_from_slice(&row);
        out.sliding.push(p.slipping() as u64);
        out.sliding_reference.push(0);
    }
    let counts = p.counts();
    let slipped = p.history().iter().filter(|h| h.first_slip.is_some()).count() as u64;
    out.mobilised = [counts.at_limit as u64; 3];
    out.pushed_on = slipped;
    let pairs = p
        .history()
        .iter()
        .map(|h| {
            let c = &snapshot.contacts[h.contact];
            (c.i, c.j.signed_id())
        })
        .collect();
    let info = IncrementalInfo { branches: rc.branches.rule().name().into(), counts, history: p.history().to_vec(), pairs, steps: p.steps(), dt: p.max_step(), impulse };
    Ok((out, info))
}
