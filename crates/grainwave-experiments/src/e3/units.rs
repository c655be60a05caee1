//! Units of work of an `e3` run — one reference state per case, one relaxation per response run —
//! executed in parallel (rayon), each persisted when done so that a resumed run never redoes it.
//!
//! Files, in the output directory:
//!
//! * `units/<case>/reference.gwck`: the relaxed reference state and what was measured on it;
//! * `units/<case>/<run>.gwck`: the measured response of a run;
//! * `units/<case>/….partial.gwck`: the engine state of a unit interrupted during its dynamics
//!   (removed when the unit completes); a resumed unit continues from it bit for bit.
//!
//! A unit is a pure function of the config and its inputs; results do not depend on the number
//! of threads nor on the order in which units complete.

use super::config::{E3Config, Mode};
use super::measure::{self, FieldData, ModuliReport, RunInputs, RunResult};
use super::plan::{Case, Plan, RunSpec, Variant};
use super::relax::{self, RelaxOutcome};
use super::slab::{self, Material, Sites};
use crate::error::{ExperimentError, Result};
use crate::protocol::RunContext;
use grainwave_core::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

/// Content tag of a finished reference unit.
pub const REFERENCE_TAG: &str = "e3-reference";
/// Content tag of a finished response unit.
pub const RUN_TAG: &str = "e3-run";
/// Content tag of an interrupted unit.
pub const PARTIAL_TAG: &str = "e3-partial";

/// A relaxed reference state.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReferenceResult {
    /// The engine state at rest.
    pub sim: Simulation<D2>,
    /// How the relaxation ended.
    pub outcome: RelaxOutcome,
    /// Wall-clock seconds of the unit.
    pub wall_clock: f64,
    /// Box width [R̄].
    pub width: f64,
    /// Height of the highest grain top [R̄].
    pub top: f64,
    /// Total weight [m̄g].
    pub weight: f64,
    /// Normal loads of floor, left and right walls [m̄g].
    pub wall_loads: [f64; 3],
    /// Coarse-grained stress (when fields are computed).
    pub field: Option<FieldData>,
    /// Affine moduli of the bulk window.
    pub moduli_bulk: ModuliReport,
}

/// An interrupted unit: the engine state and where its relaxation stands.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Partial {
    sim: Simulation<D2>,
    /// Step and time at which the current relaxation stage started.
    start_step: u64,
    start_time: f64,
    /// 0: dynamics (before Newton when frictionless); 1: dynamics after Newton.
    stage: u8,
    /// Steps of the stages before.
    steps_before: u64,
    /// Newton report of stage 0 → 1.
    newton: Option<(usize, f64, Option<String>)>,
    /// Start of the unit (for the relaxation duration).
    unit_start_step: u64,
    unit_start_time: f64,
    /// Rounds of dynamics resumed because the state at rest (velocities zeroed, dashpots silent)
    /// still exceeded the acceleration limit.
    rounds: u8,
}

/// At most this many extra rounds of dynamics after zeroing the velocities.
const MAX_ROUNDS: u8 = 4;

/// Why a unit did not complete.
enum UnitStop {
    Interrupted,
    Failed(ExperimentError),
}

impl From<ExperimentError> for UnitStop {
    fn from(e: ExperimentError) -> Self {
        UnitStop::Failed(e)
    }
}

impl From<CoreError> for UnitStop {
    fn from(e: CoreError) -> Self {
        UnitStop::Failed(e.into())
    }
}

/// What the units of a run share: the context (logging, progress, checkpoints) under a lock.
pub(crate) struct Shared<'x, 'a> {
    pub ctx: &'x mut RunContext<'a>,
    pub done: usize,
    pub total: usize,
}

/// The environment of one unit.
struct Env<'s, 'x, 'a> {
    shared: &'s Mutex<Shared<'x, 'a>>,
    flag: Arc<AtomicBool>,
    forward_progress: bool,
    report_every: u64,
}

impl Env<'_, '_, '_> {
    fn run(&self, sim: &mut Simulation<D2>, stop: &StopCriteria) -> grainwave_core::Result<RunOutcome> {
        let shared = self.shared;
        let forward = self.forward_progress;
        let mut observer = |p: &Progress| {
            if forward {
                if let Ok(mut s) = shared.lock() {
                    s.ctx.reporter.progress(p);
                }
            }
            Control::Continue
        };
        let mut hooks = RunHooks { observer: &mut observer, report_every: self.report_every, interrupt: Some(&self.flag) };
        sim.run_with(stop, &mut hooks)
    }
}

/// Directory of a case's unit files.
pub fn case_dir(out: &Path, case: &Case) -> PathBuf {
    out.join("units").join(&case.label)
}

/// File of a finished reference.
pub fn reference_file(out: &Path, case: &Case) -> PathBuf {
    case_dir(out, case).join("reference.gwck")
}

/// File of a finished run.
pub fn run_file(out: &Path, plan: &Plan, run: &RunSpec) -> PathBuf {
    case_dir(out, &plan.cases[run.case]).join(format!("{}.gwck", run.label))
}

fn partial_file(done: &Path) -> PathBuf {
    done.with_extension("partial.gwck")
}

/// Whether stress fields are computed.
pub fn fields_enabled(cfg: &E3Config) -> bool {
    cfg.response.stress_field.unwrap_or(cfg.mode != Mode::Sweep)
}

/// Kinetic-energy limit of a relaxation (SPEC §7.2.2).
pub fn kinetic_energy_limit(cfg: &E3Config, delta: f64) -> f64 {
    cfg.relaxation.kinetic_energy_per_grain.unwrap_or(if delta == 0.0 { 1e-13 } else { 1e-9 })
}

/// Acceleration below which frictionless packings switch from dynamics to Newton iterations [g].
const NEWTON_AFTER: f64 = 1e-3;

/// Relaxes `p` to rest: dynamics with `ke`/`acc` (after `not_before`), and for frictionless
/// packings dynamics to `NEWTON_AFTER`, Newton, and more dynamics if Newton left a residual.
#[allow(clippy::too_many_arguments)]
fn relax_to_rest(
    mut p: Partial,
    cfg: &E3Config,
    ke: f64,
    acc: f64,
    not_before: Option<f64>,
    extra_time: f64,
    newton: bool,
    env: &Env<'_, '_, '_>,
    partial_path: &Path,
) -> std::result::Result<(Simulation<D2>, RelaxOutcome), UnitStop> {
    let rc = &cfg.relaxation;
    let dt = p.sim.dt;
    loop {
        let before_newton = newton && p.stage == 0;
        let stage_acc = if before_newton { acc.max(NEWTON_AFTER) } else { acc };
        let mut stop = relax::criteria(rc, ke, stage_acc, p.start_step, dt, extra_time, not_before);
        if before_newton {
            // only close enough for Newton: the kinetic energy is zeroed there
            stop.kinetic_energy_per_grain = None;
        }
        let outcome = env.run(&mut p.sim, &stop)?;
        match outcome.reason {
            StopReason::Interrupted => {
                grainwave_core::checkpoint::save(partial_path, PARTIAL_TAG, &p)?;
                return Err(UnitStop::Interrupted);
            }
            reason => {
                let converged = reason == StopReason::Converged;
                if newton && p.stage == 0 && converged {
                    let report = relax::newton(&mut p.sim, rc.static_tolerance, rc.static_iterations)?;
                    let a = relax::max_acceleration(&p.sim);
                    p.newton = Some(report);
                    if a < acc {
                        return Ok((p.sim.clone(), finish(&p, true, 0.0)));
                    }
                    // Newton left a residual: continue with dynamics and the full criteria
                    p.steps_before += p.sim.step - p.start_step;
                    p.stage = 1;
                    p.start_step = p.sim.step;
                    p.start_time = p.sim.time;
                    continue;
                }
                let ke_at_rest = outcome.last.kinetic_energy_per_grain;
                relax::at_rest(&mut p.sim)?;
                // zeroing the velocities silences the dashpots: the static residual may exceed
                // the limit that held with them; relax again from rest
                if converged && relax::max_acceleration(&p.sim) >= acc && p.rounds < MAX_ROUNDS {
                    p.rounds += 1;
                    continue;
                }
                return Ok((p.sim.clone(), finish(&p, converged, ke_at_rest)));
            }
        }
    }
}

/// The outcome: `ke` is the kinetic energy per grain when the dynamics stopped (velocities are
/// zeroed afterwards; 0 after Newton iterations), the acceleration that of the state at rest.
fn finish(p: &Partial, converged: bool, ke: f64) -> RelaxOutcome {
    let progress = p.sim.progress(&StopCriteria::default());
    let (newton_iterations, newton_last_increment, newton_note) = match &p.newton {
        Some((i, l, n)) => (*i, *l, n.clone()),
        None => (0, 0.0, None),
    };
    RelaxOutcome {
        converged,
        steps: p.sim.step - p.unit_start_step,
        duration: p.sim.time - p.unit_start_time,
        kinetic_energy_per_grain: ke,
        max_acceleration: progress.max_acceleration,
        newton_iterations,
        newton_last_increment,
        newton_note,
    }
}

/// Builds and relaxes the reference state of `case`.
fn reference_unit(cfg: &E3Config, plan: &Plan, case: &Case, out: &Path, env: &Env<'_, '_, '_>) -> std::result::Result<ReferenceResult, UnitStop> {
    let started = std::time::Instant::now();
    let group = &plan.groups[case.group];
    let sites = Sites::of(group.shape);
    let material = Material::resolve(&cfg.material, group.friction, group.ratio);
    let done = reference_file(out, case);
    let partial_path = partial_file(&done);
    let partial = if partial_path.exists() {
        grainwave_core::checkpoint::load::<Partial>(&partial_path, PARTIAL_TAG)?
    } else {
        let radii = slab::radii(sites.positions.len(), group.delta, case.seed)?;
        let sim = slab::build(&sites, &radii, &material, cfg, case.seed)?;
        Partial { sim, start_step: 0, start_time: 0.0, stage: 0, steps_before: 0, newton: None, unit_start_step: 0, unit_start_time: 0.0, rounds: 0 }
    };
    let ke = kinetic_energy_limit(cfg, group.delta);
    let acc = cfg.relaxation.max_acceleration;
    let newton = material.frictionless() && cfg.relaxation.static_solve;
    let (sim, outcome) = relax_to_rest(partial, cfg, ke, acc, None, 0.0, newton, env, &partial_path)?;
    let snapshot = sim.snapshot();
    let width = sites.width;
    let top = measure::top_of(&snapshot);
    let field = fields_enabled(cfg).then(|| measure::stress_field(&snapshot, cfg, &measure::field_grid(width, top + 1.0, cfg.response.stress_step)));
    let moduli_bulk = measure::moduli(&snapshot, measure::bulk_window(width, top, cfg.response.boundary_layer));
    let result = ReferenceResult {
        weight: sim.grains.total_mass(),
        wall_loads: [snapshot.wall_load(slab::FLOOR), snapshot.wall_load(slab::LEFT), snapshot.wall_load(slab::RIGHT)],
        sim,
        outcome,
        wall_clock: started.elapsed().as_secs_f64(),
        width,
        top,
        field,
        moduli_bulk,
    };
    Ok(result)
}

/// The loaded grains of a run: (id, force vector, torque).
pub fn run_loads(cfg: &E3Config, plan: &Plan, run: &RunSpec) -> Vec<(u32, glam::DVec2, f64)> {
    let group = &plan.groups[plan.cases[run.case].group];
    let sites = Sites::of(group.shape);
    let theta = cfg.load.angle.to_radians();
    let f = glam::DVec2::new(theta.sin(), -theta.cos()) * run.force;
    let axis = 0.5 * sites.width;
    let centre = cfg.load.grain.unwrap_or_else(|| sites.top_grain_near(axis));
    let d = 0.5 * cfg.superposition.separation;
    let left = sites.top_grain_near(axis - d);
    let right = sites.top_grain_near(axis + d);
    match run.variant {
        Variant::Single => vec![(centre, f, cfg.load.torque)],
        Variant::Left => vec![(left, f, cfg.load.torque)],
        Variant::Right => vec![(right, f, cfg.load.torque)],
        Variant::Both => vec![(left, f, cfg.load.torque), (right, f, cfg.load.torque)],
    }
}

/// Applies the load(s) of `run` to the reference and relaxes; returns the measured response and
/// the final state.
fn run_unit(
    cfg: &E3Config,
    plan: &Plan,
    run: &RunSpec,
    reference: &ReferenceResult,
    out: &Path,
    env: &Env<'_, '_, '_>,
) -> std::result::Result<(RunResult, Simulation<D2>, grainwave_analysis::network::NetworkChanges<D2>), UnitStop> {
    let started = std::time::Instant::now();
    let group = &plan.groups[plan.cases[run.case].group];
    let material = Material::resolve(&cfg.material, group.friction, group.ratio);
    let loads = run_loads(cfg, plan, run);
    let done = run_file(out, plan, run);
    let partial_path = partial_file(&done);
    let ramp = cfg.load.ramp_time;
    let partial = if partial_path.exists() {
        grainwave_core::checkpoint::load::<Partial>(&partial_path, PARTIAL_TAG)?
    } else {
        let mut sim = reference.sim.clone();
        let t0 = sim.time;
        sim.loads = loads
            .iter()
            .map(|&(grain, force, torque)| ExternalLoad { grain, force, torque, profile: TimeFunction::Ramp { from: 0.0, to: 1.0, start: t0, end: t0 + ramp } })
            .collect();
        relax::at_rest(&mut sim)?;
        let step = sim.step;
        Partial { sim, start_step: step, start_time: t0, stage: 0, steps_before: 0, newton: None, unit_start_step: step, unit_start_time: t0, rounds: 0 }
    };
    let t0 = partial.unit_start_time;
    let ke = kinetic_energy_limit(cfg, group.delta) * run.force.min(1.0).powi(2);
    let acc = cfg.relaxation.response_max_acceleration * run.force;
    let newton = material.frictionless() && cfg.relaxation.static_solve;
    let (sim, mut outcome) = relax_to_rest(partial, cfg, ke, acc, Some(t0 + ramp), ramp, newton, env, &partial_path)?;
    outcome.duration = sim.time - t0;
    let ref_snapshot = reference.sim.snapshot();
    let snapshot = sim.snapshot();
    let points: Vec<(u32, f64, f64)> = loads
        .iter()
        .map(|&(id, _, _)| {
            let k = reference.sim.grains.index_of(id).expect("loaded grain exists");
            (id, reference.sim.grains.pos[k].x, reference.sim.grains.pos[k].y)
        })
        .collect();
    let vertical = loads.iter().map(|l| -l.1.y).sum();
    let x_of = |id: u32| reference.sim.grains.pos[reference.sim.grains.index_of(id).expect("loaded grain exists")].x;
    let origin = match run.variant {
        Variant::Single => x_of(loads[0].0),
        _ => {
            let both = run_loads(cfg, plan, &RunSpec { variant: Variant::Both, ..run.clone() });
            0.5 * (x_of(both[0].0) + x_of(both[1].0))
        }
    };
    let inputs = RunInputs {
        cfg,
        run: run.index,
        force: run.force,
        loads: points,
        origin,
        vertical_load: vertical,
        width: reference.width,
        reference_field: reference.field.as_ref(),
        keep_contacts: cfg.mode == Mode::Superposition,
        outcome,
        friction: [material.friction, material.wall_friction, material.side_wall_friction],
    };
    let (result, changes) = measure::measure_run(inputs, &ref_snapshot, &snapshot);
    let _ = started;
    Ok((result, sim, changes))
}

/// What a completed run unit stores.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StoredRun {
    /// The measurements.
    pub result: RunResult,
    /// Wall-clock seconds of the unit.
    pub wall_clock: f64,
}

/// Runs every pending unit in parallel; `on_reference` and `on_run` are called (under the lock)
/// when one completes, to write its files and record it in the protocol state.
#[allow(clippy::type_complexity)]
pub(crate) fn execute(
    ctx: &mut RunContext<'_>,
    cfg: &E3Config,
    plan: &Plan,
    references_done: &mut [bool],
    runs_done: &mut [bool],
    save_state: &(dyn Fn(&mut RunContext<'_>, &[bool], &[bool]) -> Result<()> + Sync),
    write_run: &(dyn Fn(&Path, &RunSpec, &RunResult, &Snapshot<D2>, &Snapshot<D2>, &grainwave_analysis::network::NetworkChanges<D2>, Option<&FieldData>) -> Result<()>
          + Sync),
) -> Result<()> {
    use rayon::prelude::*;
    let out = ctx.out_dir().to_path_buf();
    let flag = ctx.interrupt_flag();
    let report_every = ctx.report_every;
    let pending_refs: Vec<usize> = (0..plan.cases.len()).filter(|&c| !references_done[c] || !reference_file(&out, &plan.cases[c]).exists()).collect();
    let total = pending_refs.len() + (0..plan.runs.len()).filter(|&r| !runs_done[r] || !run_file(&out, plan, &plan.runs[r]).exists()).count();
    let done_flags = Mutex::new((references_done.to_vec(), runs_done.to_vec()));
    let shared = Mutex::new(Shared { ctx, done: 0, total });
    // 1. references
    if !pending_refs.is_empty() {
        if let Ok(mut s) = shared.lock() {
            s.ctx.reporter.stage(&format!("reference states ({} to relax)", pending_refs.len()), None);
        }
    }
    let single = pending_refs.len() == 1;
    let outcomes: Vec<std::result::Result<(), UnitStop>> = pending_refs
        .par_iter()
        .with_max_len(1)
        .map(|&c| {
            let case = &plan.cases[c];
            let env = Env { shared: &shared, flag: flag.clone(), forward_progress: single, report_every };
            std::fs::create_dir_all(case_dir(&out, case)).map_err(|e| UnitStop::Failed(io_error(&case_dir(&out, case), e)))?;
            let r = reference_unit(cfg, plan, case, &out, &env)?;
            let path = reference_file(&out, case);
            grainwave_core::checkpoint::save(&path, REFERENCE_TAG, &r)?;
            let _ = std::fs::remove_file(partial_file(&path));
            let mut guard = shared.lock().map_err(|_| UnitStop::Failed(poisoned()))?;
            let (refs, runs) = {
                let mut d = done_flags.lock().map_err(|_| UnitStop::Failed(poisoned()))?;
                d.0[c] = true;
                (d.0.clone(), d.1.clone())
            };
            guard.done += 1;
            let (done, total) = (guard.done, guard.total);
            guard.ctx.reporter.samples(done, total);
            guard.ctx.log(&format!(
                "reference {} relaxed: {} steps, KE/grain {:.2e}, max acceleration {:.2e}{}, {:.1} s",
                case.label,
                r.outcome.steps,
                r.outcome.kinetic_energy_per_grain,
                r.outcome.max_acceleration,
                if r.outcome.converged { "" } else { " (NOT converged)" },
                r.wall_clock
            ));
            save_state(guard.ctx, &refs, &runs)?;
            Ok(())
        })
        .collect();
    let labels: Vec<String> = pending_refs.iter().map(|&c| format!("reference {}", plan.cases[c].label)).collect();
    settle("reference states", &labels, outcomes, &shared, &done_flags, save_state)?;
    // 2. runs
    let pending_runs: Vec<usize> = (0..plan.runs.len())
        .filter(|&r| {
            let flags = done_flags.lock().map(|d| d.1[r]).unwrap_or(false);
            !flags || !run_file(&out, plan, &plan.runs[r]).exists()
        })
        .collect();
    if !pending_runs.is_empty() {
        if let Ok(mut s) = shared.lock() {
            s.ctx.reporter.stage(&format!("responses ({} runs)", pending_runs.len()), None);
        }
    }
    let single = pending_runs.len() == 1;
    let cache: Mutex<std::collections::HashMap<usize, Arc<ReferenceResult>>> = Mutex::new(std::collections::HashMap::new());
    let load_reference = |c: usize| -> Result<Arc<ReferenceResult>> {
        if let Some(r) = cache.lock().map_err(|_| poisoned())?.get(&c) {
            return Ok(r.clone());
        }
        let r: ReferenceResult = grainwave_core::checkpoint::load(&reference_file(&out, &plan.cases[c]), REFERENCE_TAG)?;
        let r = Arc::new(r);
        cache.lock().map_err(|_| poisoned())?.insert(c, r.clone());
        Ok(r)
    };
    let outcomes: Vec<std::result::Result<(), UnitStop>> = pending_runs
        .par_iter()
        .with_max_len(1)
        .map(|&ri| {
            let run = &plan.runs[ri];
            let started = std::time::Instant::now();
            let reference = load_reference(run.case)?;
            let env = Env { shared: &shared, flag: flag.clone(), forward_progress: single, report_every };
            let (result, sim, changes) = run_unit(cfg, plan, run, &reference, &out, &env)?;
            write_run(&out, run, &result, &reference.sim.snapshot(), &sim.snapshot(), &changes, reference.field.as_ref())?;
            let stored = StoredRun { result, wall_clock: started.elapsed().as_secs_f64() };
            let path = run_file(&out, plan, run);
            grainwave_core::checkpoint::save(&path, RUN_TAG, &stored)?;
            let _ = std::fs::remove_file(partial_file(&path));
            let mut guard = shared.lock().map_err(|_| UnitStop::Failed(poisoned()))?;
            let (refs, runs) = {
                let mut d = done_flags.lock().map_err(|_| UnitStop::Failed(poisoned()))?;
                d.1[ri] = true;
                (d.0.clone(), d.1.clone())
            };
            guard.done += 1;
            let (done, total) = (guard.done, guard.total);
            guard.ctx.reporter.samples(done, total);
            let r = &stored.result;
            guard.ctx.log(&format!(
                "run {}/{}: F = {}, p(0)/F = {:.4e}, {} opened, {} sliding, raw verdict {}, {} steps{}, {:.1} s",
                plan.cases[run.case].label,
                run.label,
                run.force,
                r.response_at_zero.first().copied().unwrap_or(f64::NAN),
                r.counts.opened,
                r.counts.sliding,
                r.raw.map_or(r.classification.shape, |v| v.shape).name(),
                r.outcome.steps,
                if r.outcome.converged { "" } else { " (NOT converged)" },
                stored.wall_clock
            ));
            save_state(guard.ctx, &refs, &runs)?;
            Ok(())
        })
        .collect();
    let labels: Vec<String> = pending_runs.iter().map(|&r| format!("run {}/{}", plan.cases[plan.runs[r].case].label, plan.runs[r].label)).collect();
    settle("response runs", &labels, outcomes, &shared, &done_flags, save_state)?;
    let d = done_flags.into_inner().map_err(|_| poisoned())?;
    references_done.copy_from_slice(&d.0);
    runs_done.copy_from_slice(&d.1);
    Ok(())
}

/// One run of a first-opening bisection (SPEC §7.2.5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OpeningProbe {
    /// F_ext [m̄g].
    pub force: f64,
    /// Opened contacts connected to the load (the region below the load).
    pub opened_below_load: usize,
    /// Depth of that region below the load [R̄].
    pub region_depth: f64,
    /// Contacts opened anywhere.
    pub opened_anywhere: usize,
    /// No contact opened, formed or started sliding.
    pub linear: bool,
    /// Linear estimate of the force opening the first contact anywhere (linear runs) [m̄g].
    pub linear_estimate_anywhere: Option<f64>,
    /// The relaxation converged.
    pub converged: bool,
    /// Steps of the run.
    pub steps: u64,
    /// Wall-clock seconds.
    pub wall_clock: f64,
}

/// The bisection of one reference state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OpeningBisection {
    /// Case label.
    pub case: String,
    /// Largest force run without an opening below the load [m̄g].
    pub lower: Option<f64>,
    /// Smallest force run with an opening below the load [m̄g].
    pub upper: Option<f64>,
    /// The first-opening force below the load: √(lower · upper) when both are known [m̄g].
    pub first_opening_below_load: Option<f64>,
    /// Largest force run without any opened contact, anywhere [m̄g].
    pub anywhere_lower: Option<f64>,
    /// Smallest force run with an opened contact somewhere [m̄g].
    pub anywhere_upper: Option<f64>,
    /// Linear estimate of the first opening anywhere, from the smallest linear run [m̄g].
    pub anywhere_linear_estimate: Option<f64>,
    /// Every run in the order done.
    pub probes: Vec<OpeningProbe>,
    /// Why the bisection could not bracket the force, if so.
    pub note: Option<String>,
}

/// File of bisection run `k` of `case`.
pub fn opening_file(out: &Path, case: &Case, k: usize) -> PathBuf {
    case_dir(out, case).join(format!("opening_{k}.gwck"))
}

/// The bisection runs of `case` (probe k at force `f`) as run specs.
fn opening_spec(plan: &Plan, case: &Case, k: usize, force: f64) -> RunSpec {
    RunSpec { index: plan.runs.len() + k, case: case.index, force_index: 0, force, variant: Variant::Single, label: format!("opening_{k}") }
}

/// Forces of the bisection given the probes so far: None when done.
fn next_force(cfg: &E3Config, probes: &[OpeningProbe]) -> Option<f64> {
    let [lo, hi] = cfg.first_opening.bracket;
    match probes.len() {
        0 => return Some(lo),
        1 => return (probes[0].opened_below_load == 0).then_some(hi),
        _ => {}
    }
    if probes[1].opened_below_load == 0 {
        return None;
    }
    let lower = probes.iter().filter(|p| p.opened_below_load == 0).map(|p| p.force).fold(f64::NEG_INFINITY, f64::max);
    let upper = probes.iter().filter(|p| p.opened_below_load > 0).map(|p| p.force).fold(f64::INFINITY, f64::min);
    (upper / lower - 1.0 > cfg.first_opening.relative_tolerance).then(|| (lower * upper).sqrt())
}

/// Summarizes the probes of one case.
pub fn summarize_bisection(cfg: &E3Config, case: &Case, probes: Vec<OpeningProbe>) -> OpeningBisection {
    let [lo, hi] = cfg.first_opening.bracket;
    let max_of = |it: &mut dyn Iterator<Item = f64>| it.fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.max(f))));
    let min_of = |it: &mut dyn Iterator<Item = f64>| it.fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.min(f))));
    let lower = max_of(&mut probes.iter().filter(|p| p.opened_below_load == 0).map(|p| p.force));
    let upper = min_of(&mut probes.iter().filter(|p| p.opened_below_load > 0).map(|p| p.force));
    let note = if probes.first().is_some_and(|p| p.opened_below_load > 0) {
        Some(format!("a contact below the load opens already at the lower end of the bracket, {lo} m̄g"))
    } else if probes.len() >= 2 && probes[1].opened_below_load == 0 {
        Some(format!("no contact below the load opens up to the upper end of the bracket, {hi} m̄g"))
    } else {
        None
    };
    let anywhere_linear_estimate = probes.iter().filter(|p| p.linear).min_by(|a, b| a.force.total_cmp(&b.force)).and_then(|p| p.linear_estimate_anywhere);
    OpeningBisection {
        case: case.label.clone(),
        lower,
        upper,
        first_opening_below_load: match (lower, upper) {
            (Some(l), Some(u)) if note.is_none() => Some((l * u).sqrt()),
            _ => None,
        },
        anywhere_lower: max_of(&mut probes.iter().filter(|p| p.opened_anywhere == 0).map(|p| p.force)),
        anywhere_upper: min_of(&mut probes.iter().filter(|p| p.opened_anywhere > 0).map(|p| p.force)),
        anywhere_linear_estimate,
        probes,
        note,
    }
}

fn probe_of(stored: &StoredRun) -> OpeningProbe {
    let r = &stored.result;
    OpeningProbe {
        force: r.force,
        opened_below_load: r.region.count,
        region_depth: r.region.depth,
        opened_anywhere: r.counts.opened,
        linear: r.linear,
        linear_estimate_anywhere: r.first_opening_estimate,
        converged: r.outcome.converged,
        steps: r.outcome.steps,
        wall_clock: stored.wall_clock,
    }
}

/// Reads the bisection runs of `case` done so far (in order, stopping at the first missing one).
pub fn read_bisection(out: &Path, case: &Case) -> Result<Vec<OpeningProbe>> {
    let mut probes = Vec::new();
    loop {
        let path = opening_file(out, case, probes.len());
        if !path.exists() {
            return Ok(probes);
        }
        let stored: StoredRun = grainwave_core::checkpoint::load(&path, RUN_TAG)?;
        probes.push(probe_of(&stored));
    }
}

/// The first-opening bisection (SPEC §7.2.5) of every case, cases in parallel, each bisection
/// sequential: F_low and F_high of the bracket are run first (no opening below the load at F_low,
/// one at F_high), then the geometric midpoint of the current bracket until F_high/F_low − 1 ≤ the
/// tolerance. Each run is a response unit of its own (`units/<case>/opening_<k>.gwck`; resumable
/// like the others): the k-th force depends only on the runs before it, so a resumed bisection
/// reads them back and continues.
pub(crate) fn bisect_first_opening(ctx: &mut RunContext<'_>, cfg: &E3Config, plan: &Plan) -> Result<()> {
    use rayon::prelude::*;
    let out = ctx.out_dir().to_path_buf();
    let flag = ctx.interrupt_flag();
    let report_every = ctx.report_every;
    ctx.reporter.stage(&format!("first-opening bisection ({} reference state(s))", plan.cases.len()), None);
    let shared = Mutex::new(Shared { ctx, done: 0, total: plan.cases.len() });
    let single = plan.cases.len() == 1;
    let outcomes: Vec<std::result::Result<(), UnitStop>> = plan
        .cases
        .par_iter()
        .with_max_len(1)
        .map(|case| {
            let env = Env { shared: &shared, flag: flag.clone(), forward_progress: single, report_every };
            let reference: ReferenceResult = grainwave_core::checkpoint::load(&reference_file(&out, case), REFERENCE_TAG)?;
            let mut probes = read_bisection(&out, case)?;
            while let Some(force) = next_force(cfg, &probes) {
                let k = probes.len();
                let spec = opening_spec(plan, case, k, force);
                let started = std::time::Instant::now();
                let (result, _, _) = run_unit(cfg, plan, &spec, &reference, &out, &env)?;
                let stored = StoredRun { result, wall_clock: started.elapsed().as_secs_f64() };
                let path = opening_file(&out, case, k);
                grainwave_core::checkpoint::save(&path, RUN_TAG, &stored)?;
                let _ = std::fs::remove_file(partial_file(&path));
                let p = probe_of(&stored);
                if let Ok(mut guard) = shared.lock() {
                    guard.ctx.log(&format!(
                        "first opening {}: F = {:.6} m̄g, {} opened below the load (depth {:.2} R̄), {} anywhere{}, {:.1} s",
                        case.label,
                        p.force,
                        p.opened_below_load,
                        p.region_depth,
                        p.opened_anywhere,
                        if p.converged { "" } else { " (NOT converged)" },
                        p.wall_clock
                    ));
                }
                probes.push(p);
            }
            if let Ok(mut guard) = shared.lock() {
                guard.done += 1;
                let (d, t) = (guard.done, guard.total);
                guard.ctx.reporter.samples(d, t);
            }
            Ok(())
        })
        .collect();
    let mut interrupted = false;
    let mut failures = Vec::new();
    for (case, o) in plan.cases.iter().zip(outcomes) {
        match o {
            Ok(()) => {}
            Err(UnitStop::Interrupted) => interrupted = true,
            Err(UnitStop::Failed(e)) => failures.push(format!("bisection {}: {}", case.label, crate::protocol::failure_line(&e))),
        }
    }
    if !failures.is_empty() {
        return Err(crate::protocol::failed_units("first-opening bisections", plan.cases.len(), failures));
    }
    if interrupted {
        let mut guard = shared.lock().map_err(|_| poisoned())?;
        let checkpoint = guard.ctx.path(crate::protocol::CHECKPOINT_FILE);
        let dir = guard.ctx.out_dir().to_path_buf();
        guard.ctx.log(&format!("interrupted during the first-opening bisection: state saved in {}", checkpoint.display()));
        return Err(ExperimentError::Interrupted { checkpoint, dir });
    }
    Ok(())
}

fn poisoned() -> ExperimentError {
    ExperimentError::Core(CoreError::Inconsistent("a worker thread panicked".into()))
}

fn io_error(path: &Path, e: std::io::Error) -> ExperimentError {
    ExperimentError::Core(CoreError::Io { action: "cannot create".into(), path: path.display().to_string(), error: e })
}

/// Failures take precedence: when units failed, every failure is listed with its unit (the
/// units that completed are saved and not redone by `resume --retry`); otherwise an interruption
/// saves the state. `labels[k]` names the unit of `outcomes[k]`; `what` is the stage's units in
/// the plural.
fn settle(
    what: &str,
    labels: &[String],
    outcomes: Vec<std::result::Result<(), UnitStop>>,
    shared: &Mutex<Shared<'_, '_>>,
    done_flags: &Mutex<(Vec<bool>, Vec<bool>)>,
    save_state: &(dyn Fn(&mut RunContext<'_>, &[bool], &[bool]) -> Result<()> + Sync),
) -> Result<()> {
    let mut interrupted = false;
    let mut failures = Vec::new();
    for (label, o) in labels.iter().zip(outcomes) {
        match o {
            Ok(()) => {}
            Err(UnitStop::Interrupted) => interrupted = true,
            Err(UnitStop::Failed(e)) => failures.push(format!("{label}: {}", crate::protocol::failure_line(&e))),
        }
    }
    if !failures.is_empty() {
        return Err(crate::protocol::failed_units(what, labels.len(), failures));
    }
    if interrupted {
        let (refs, runs) = done_flags.lock().map(|d| (d.0.clone(), d.1.clone())).map_err(|_| poisoned())?;
        let mut guard = shared.lock().map_err(|_| poisoned())?;
        save_state(guard.ctx, &refs, &runs)?;
        let checkpoint = guard.ctx.path(crate::protocol::CHECKPOINT_FILE);
        let dir = guard.ctx.out_dir().to_path_buf();
        guard.ctx.log(&format!("interrupted: state saved in {}", checkpoint.display()));
        return Err(ExperimentError::Interrupted { checkpoint, dir });
    }
    Ok(())
}

