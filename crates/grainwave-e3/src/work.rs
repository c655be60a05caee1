//! The units of work of an `e3` run (SPEC §7.2), as a [`Work`] for the scheduler
//! ([`grainwave_study::work`]): one reference state per case, one relaxation per response run (a force or
//! a pair of forces applied to a reference; input: that reference) and, when asked for, one
//! first-opening bisection per case (a sequence of response runs; input: the reference).
//!
//! Files, in the output directory:
//!
//! * `units/<case>/reference.gwck`: the relaxed reference state and what was measured on it;
//! * `units/<case>/<run>.gwck`: the measured response of a run;
//! * `units/<case>/opening_<k>.gwck`: the k-th run of the case's bisection;
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
use grainwave_study::{ExperimentError, Result};
use grainwave_study::protocol::RunContext;
use grainwave_study::work::{store, Unit, UnitEnv, UnitResult, UnitStop, Work};
use grainwave_core::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
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
    env: &UnitEnv<'_, '_, '_>,
    partial_path: &Path,
) -> UnitResult<(Simulation<D2>, RelaxOutcome)> {
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
fn reference_unit(cfg: &E3Config, plan: &Plan, case: &Case, out: &Path, env: &UnitEnv<'_, '_, '_>) -> UnitResult<ReferenceResult> {
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
        let sim = slab::build(&sites, &radii, &material, &cfg.integration, case.seed)?;
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
fn response_unit(
    cfg: &E3Config,
    plan: &Plan,
    run: &RunSpec,
    reference: &ReferenceResult,
    out: &Path,
    env: &UnitEnv<'_, '_, '_>,
) -> UnitResult<(RunResult, Simulation<D2>, grainwave_analysis::network::NetworkChanges<D2>)> {
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


/// Writes the files of a finished response run (profiles, pictures) into the output directory.
pub(crate) type WriteRun<'a> = dyn Fn(&Path, &RunSpec, &RunResult, &Snapshot<D2>, &Snapshot<D2>, &grainwave_analysis::network::NetworkChanges<D2>, Option<&FieldData>) -> Result<()>
    + Sync
    + 'a;

/// What a unit is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// The reference state of case `c`.
    Reference(usize),
    /// Response run `r` of the plan.
    Run(usize),
    /// The first-opening bisection of case `c`.
    Bisection(usize),
}

/// What a unit produces.
#[derive(serde::Serialize, serde::Deserialize)]
pub(crate) enum Output {
    /// A relaxed reference state.
    Reference(Box<ReferenceResult>),
    /// A response run.
    Run(Box<StoredRun>),
    /// A bisection: its runs are persisted one by one as they complete.
    Bisection,
}

/// The plan of an `e3` run as units of work.
pub(crate) struct E3Work<'a> {
    cfg: &'a E3Config,
    plan: &'a Plan,
    out: PathBuf,
    units: Vec<Unit>,
    kinds: Vec<Kind>,
    /// Which references and runs the protocol state records as done.
    references_done: Vec<bool>,
    runs_done: Vec<bool>,
    /// Reference states read back for their runs.
    cache: Mutex<std::collections::HashMap<usize, Arc<ReferenceResult>>>,
    write_run: &'a WriteRun<'a>,
    /// Saves the protocol state given which references and runs are done.
    save_state: &'a (dyn Fn(&mut RunContext<'_>, &[bool], &[bool]) -> Result<()> + Sync),
}

/// The units of `plan`: references (cases in order), then response runs (input: their
/// reference), then bisections (one per case, when the config asks for them; input: the
/// reference), with what each one is.
fn units(cfg: &E3Config, plan: &Plan) -> (Vec<Unit>, Vec<Kind>) {
    let mut units = Vec::new();
    let mut kinds = Vec::new();
    for c in &plan.cases {
        units.push(Unit { id: format!("reference {}", c.label), kind: "reference states".into(), inputs: vec![] });
        kinds.push(Kind::Reference(c.index));
    }
    for r in &plan.runs {
        units.push(Unit { id: format!("run {}/{}", plan.cases[r.case].label, r.label), kind: "response runs".into(), inputs: vec![r.case] });
        kinds.push(Kind::Run(r.index));
    }
    if cfg.first_opening.bisection {
        for c in &plan.cases {
            units.push(Unit { id: format!("bisection {}", c.label), kind: "first-opening bisections".into(), inputs: vec![c.index] });
            kinds.push(Kind::Bisection(c.index));
        }
    }
    (units, kinds)
}

/// The units of work of an `e3` run of `plan` (see [`E3Work`]).
pub fn plan_units(cfg: &E3Config, plan: &Plan) -> Vec<Unit> {
    units(cfg, plan).0
}

impl<'a> E3Work<'a> {
    /// The units of `plan`: references (cases in order), then response runs, then bisections (one
    /// per case, when the config asks for them). `references_done`/`runs_done` come from the
    /// protocol state.
    pub(crate) fn new(
        cfg: &'a E3Config,
        plan: &'a Plan,
        out: &Path,
        references_done: &[bool],
        runs_done: &[bool],
        write_run: &'a WriteRun<'a>,
        save_state: &'a (dyn Fn(&mut RunContext<'_>, &[bool], &[bool]) -> Result<()> + Sync),
    ) -> Self {
        let (units, kinds) = units(cfg, plan);
        E3Work {
            cfg,
            plan,
            out: out.to_path_buf(),
            units,
            kinds,
            references_done: references_done.to_vec(),
            runs_done: runs_done.to_vec(),
            cache: Mutex::new(std::collections::HashMap::new()),
            write_run,
            save_state,
        }
    }

    /// Which references and which runs are done, from the scheduler's flags.
    pub(crate) fn flags(&self, done: &[bool]) -> (Vec<bool>, Vec<bool>) {
        let mut refs = vec![false; self.plan.cases.len()];
        let mut runs = vec![false; self.plan.runs.len()];
        for (k, kind) in self.kinds.iter().enumerate() {
            match *kind {
                Kind::Reference(c) => refs[c] = done[k],
                Kind::Run(r) => runs[r] = done[k],
                Kind::Bisection(_) => {}
            }
        }
        (refs, runs)
    }

    fn reference(&self, c: usize) -> Result<Arc<ReferenceResult>> {
        let poisoned = || ExperimentError::Core(CoreError::Inconsistent("a worker thread panicked".into()));
        if let Some(r) = self.cache.lock().map_err(|_| poisoned())?.get(&c) {
            return Ok(r.clone());
        }
        let r: ReferenceResult = grainwave_core::checkpoint::load(&reference_file(&self.out, &self.plan.cases[c]), REFERENCE_TAG)?;
        let r = Arc::new(r);
        self.cache.lock().map_err(|_| poisoned())?.insert(c, r.clone());
        Ok(r)
    }

    /// The first-opening bisection (SPEC §7.2.5) of case `c`, sequential: F_low and F_high of the
    /// bracket are run first (no opening in the cone below the load at F_low, one at F_high), then
    /// the geometric midpoint of the current bracket until F_high/F_low − 1 ≤ the tolerance, then
    /// likewise for the opening connected to the loaded grain ([`next_force`]). Each run
    /// is persisted as it completes (`units/<case>/opening_<k>.gwck`; resumable like the other
    /// units): the k-th force depends only on the runs before it, so a resumed bisection reads
    /// them back and continues.
    fn bisection(&self, c: usize, env: &UnitEnv<'_, '_, '_>) -> UnitResult<()> {
        let (cfg, plan, out) = (self.cfg, self.plan, &self.out);
        let case = &plan.cases[c];
        let reference = self.reference(c)?;
        let mut probes = read_bisection(out, case)?;
        while let Some(force) = next_force(cfg, &probes) {
            let k = probes.len();
            let spec = opening_spec(plan, case, k, force);
            let started = std::time::Instant::now();
            let (result, _, _) = response_unit(cfg, plan, &spec, &reference, out, env)?;
            let stored = StoredRun { result, wall_clock: started.elapsed().as_secs_f64() };
            let path = opening_file(out, case, k);
            store(&path, RUN_TAG, &stored, Some(&partial_file(&path)))?;
            let p = probe_of(&stored);
            env.log(&format!(
                "first opening {}: F = {:.6} m̄g, {} opened in the cone below the load (depth {:.2}–{:.2} R̄), {} connected to the load (depth {:.2} R̄), {} anywhere{}, {:.1} s",
                case.label,
                p.force,
                p.opened_in_cone,
                p.cone_shallowest,
                p.cone_depth,
                p.opened_connected,
                p.connected_depth,
                p.opened_anywhere,
                if p.converged { "" } else { " (NOT converged)" },
                p.wall_clock
            ));
            probes.push(p);
        }
        Ok(())
    }
}

impl Work for E3Work<'_> {
    type Output = Output;

    fn units(&self) -> &[Unit] {
        &self.units
    }

    fn is_done(&self, k: usize) -> bool {
        let (out, plan) = (&self.out, self.plan);
        match self.kinds[k] {
            Kind::Reference(c) => self.references_done[c] && reference_file(out, &plan.cases[c]).exists(),
            Kind::Run(r) => self.runs_done[r] && run_file(out, plan, &plan.runs[r]).exists(),
            Kind::Bisection(c) => read_bisection(out, &plan.cases[c]).is_ok_and(|p| next_force(self.cfg, &p).is_none()),
        }
    }

    fn run(&self, k: usize, env: &UnitEnv<'_, '_, '_>) -> UnitResult<Output> {
        let (cfg, plan, out) = (self.cfg, self.plan, &self.out);
        match self.kinds[k] {
            Kind::Reference(c) => {
                let case = &plan.cases[c];
                let dir = case_dir(out, case);
                std::fs::create_dir_all(&dir).map_err(|e| CoreError::Io { action: "cannot create".into(), path: dir.display().to_string(), error: e })?;
                Ok(Output::Reference(Box::new(reference_unit(cfg, plan, case, out, env)?)))
            }
            Kind::Run(r) => {
                let run = &plan.runs[r];
                let started = std::time::Instant::now();
                let reference = self.reference(run.case)?;
                let (result, sim, changes) = response_unit(cfg, plan, run, &reference, out, env)?;
                (self.write_run)(out, run, &result, &reference.sim.snapshot(), &sim.snapshot(), &changes, reference.field.as_ref())?;
                Ok(Output::Run(Box::new(StoredRun { result, wall_clock: started.elapsed().as_secs_f64() })))
            }
            Kind::Bisection(c) => {
                self.bisection(c, env)?;
                Ok(Output::Bisection)
            }
        }
    }

    fn record(&self, k: usize, output: &Output) -> Result<()> {
        let (out, plan) = (&self.out, self.plan);
        match (self.kinds[k], output) {
            (Kind::Reference(c), Output::Reference(r)) => {
                let path = reference_file(out, &plan.cases[c]);
                store(&path, REFERENCE_TAG, r.as_ref(), Some(&partial_file(&path)))
            }
            (Kind::Run(r), Output::Run(s)) => {
                let path = run_file(out, plan, &plan.runs[r]);
                store(&path, RUN_TAG, s.as_ref(), Some(&partial_file(&path)))
            }
            (Kind::Bisection(_), Output::Bisection) => Ok(()),
            _ => Err(ExperimentError::Core(CoreError::Inconsistent(format!("unit {} produced the output of another kind", self.units[k].id)))),
        }
    }

    fn recorded(&self, k: usize, output: &Output, ctx: &mut RunContext<'_>, done: &[bool]) -> Result<()> {
        let plan = self.plan;
        match output {
            Output::Reference(r) => ctx.log(&format!(
                "reference {} relaxed: {} steps, KE/grain {:.2e}, max acceleration {:.2e}{}, {:.1} s",
                self.units[k].id.trim_start_matches("reference "),
                r.outcome.steps,
                r.outcome.kinetic_energy_per_grain,
                r.outcome.max_acceleration,
                if r.outcome.converged { "" } else { " (NOT converged)" },
                r.wall_clock
            )),
            Output::Run(stored) => {
                let Kind::Run(ri) = self.kinds[k] else { unreachable!("a run's output comes from a run") };
                let run = &plan.runs[ri];
                let r = &stored.result;
                ctx.log(&format!(
                    "run {}/{}: F = {}, p(0)/F = {:.4e}, {} opened ({} in the cone below the load, {} connected to it), {} sliding, raw verdict {} (dip {:.4}), A_s = {:.3e}{}, {} steps{}, {:.1} s",
                    plan.cases[run.case].label,
                    run.label,
                    run.force,
                    r.response_at_zero.first().copied().unwrap_or(f64::NAN),
                    r.counts.opened,
                    r.cone.count,
                    r.region.count,
                    r.counts.sliding,
                    r.raw.map_or(r.classification.shape, |v| v.shape).name(),
                    r.raw.map_or(f64::NAN, |v| v.dip),
                    r.symmetry.map_or(f64::NAN, |v| v.antisymmetric_fraction),
                    r.symmetry
                        .map(|v| format!(
                            " (axis contacts {} | {} | {})",
                            v.left.map_or("-".into(), |p| format!("x {:.2}: {:.5}", p[0], p[1])),
                            v.centre.map_or("-".into(), |p| format!("x {:.2}: {:.5}", p[0], p[1])),
                            v.right.map_or("-".into(), |p| format!("x {:.2}: {:.5}", p[0], p[1]))
                        ))
                        .unwrap_or_default(),
                    r.outcome.steps,
                    if r.outcome.converged { "" } else { " (NOT converged)" },
                    stored.wall_clock
                ));
            }
            Output::Bisection => {}
        }
        let (refs, runs) = self.flags(done);
        (self.save_state)(ctx, &refs, &runs)
    }
}

/// One run of a first-opening bisection (SPEC §7.2.5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OpeningProbe {
    /// F_ext [m̄g].
    pub force: f64,
    /// Grain–grain contacts opened in the region below the load of SPEC §7.2.5 (the cone of the
    /// lattice directions through the load with one grain of margin, `measure::in_opening_cone`),
    /// connected to the loaded grain or not.
    pub opened_in_cone: usize,
    /// Depth below the load of the deepest and of the shallowest of them [R̄].
    pub cone_depth: f64,
    /// Depth below the load of the shallowest of them [R̄].
    pub cone_shallowest: f64,
    /// Opened contacts connected to the loaded grain (the region grown from it, docs/e3.md).
    pub opened_connected: usize,
    /// Depth of that region below the load [R̄].
    pub connected_depth: f64,
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

/// The bisection of one reference state: three first-opening forces from the same runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OpeningBisection {
    /// Case label.
    pub case: String,
    /// Largest force run without an opening in the region below the load (SPEC §7.2.5) [m̄g].
    pub lower: Option<f64>,
    /// Smallest force run with an opening in that region [m̄g].
    pub upper: Option<f64>,
    /// **The first-opening force** of SPEC §7.2.5: a grain–grain contact opens in the cone below
    /// the load (connected to the loaded grain or not); √(lower · upper) [m̄g].
    pub first_opening_below_load: Option<f64>,
    /// Largest force run whose opened region connected to the loaded grain is empty [m̄g].
    pub connected_lower: Option<f64>,
    /// Smallest force run with an opened contact connected to the loaded grain [m̄g].
    pub connected_upper: Option<f64>,
    /// The force at which the opened region first links to the loaded grain: √(connected_lower ·
    /// connected_upper) once that bracket is within the tolerance [m̄g].
    pub first_opening_connected: Option<f64>,
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

/// The bracket (largest force without, smallest force with) of `opened` over `probes`.
fn bracket_of(probes: &[OpeningProbe], opened: impl Fn(&OpeningProbe) -> bool) -> (Option<f64>, Option<f64>) {
    let lower = probes.iter().filter(|p| !opened(p)).map(|p| p.force).fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.max(f))));
    let upper = probes.iter().filter(|p| opened(p)).map(|p| p.force).fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.min(f))));
    (lower, upper)
}

/// Forces of the bisection given the probes so far: None when done. First the two ends of the
/// bracket, then the geometric midpoint of the bracket of the opening in the cone below the load
/// (SPEC §7.2.5) until within the tolerance, then that of the opening connected to the loaded
/// grain (often already bracketed by the same runs: no run is added then).
fn next_force(cfg: &E3Config, probes: &[OpeningProbe]) -> Option<f64> {
    let [lo, hi] = cfg.first_opening.bracket;
    match probes.len() {
        0 => return Some(lo),
        1 => return (probes[0].opened_in_cone == 0).then_some(hi),
        _ => {}
    }
    if probes[1].opened_in_cone == 0 {
        return None;
    }
    let tol = cfg.first_opening.relative_tolerance;
    let midpoint = |b: (Option<f64>, Option<f64>)| match b {
        (Some(l), Some(u)) if u / l - 1.0 > tol => Some((l * u).sqrt()),
        _ => None,
    };
    midpoint(bracket_of(probes, |p| p.opened_in_cone > 0)).or_else(|| midpoint(bracket_of(probes, |p| p.opened_connected > 0)))
}

/// Summarizes the probes of one case.
pub fn summarize_bisection(cfg: &E3Config, case: &Case, probes: Vec<OpeningProbe>) -> OpeningBisection {
    let [lo, hi] = cfg.first_opening.bracket;
    let tol = cfg.first_opening.relative_tolerance;
    let (lower, upper) = bracket_of(&probes, |p| p.opened_in_cone > 0);
    let (connected_lower, connected_upper) = bracket_of(&probes, |p| p.opened_connected > 0);
    let note = if probes.first().is_some_and(|p| p.opened_in_cone > 0) {
        Some(format!("a contact in the region below the load opens already at the lower end of the bracket, {lo} m̄g"))
    } else if probes.len() >= 2 && probes[1].opened_in_cone == 0 {
        Some(format!("no contact in the region below the load opens up to the upper end of the bracket, {hi} m̄g"))
    } else {
        None
    };
    let anywhere_linear_estimate = probes.iter().filter(|p| p.linear).min_by(|a, b| a.force.total_cmp(&b.force)).and_then(|p| p.linear_estimate_anywhere);
    let (anywhere_lower, anywhere_upper) = bracket_of(&probes, |p| p.opened_anywhere > 0);
    OpeningBisection {
        case: case.label.clone(),
        lower,
        upper,
        first_opening_below_load: match (lower, upper) {
            (Some(l), Some(u)) if note.is_none() => Some((l * u).sqrt()),
            _ => None,
        },
        connected_lower,
        connected_upper,
        first_opening_connected: match (connected_lower, connected_upper) {
            // bracketed to the tolerance (a loose bracket is given by its ends only)
            (Some(l), Some(u)) if u / l - 1.0 <= tol * (1.0 + 1e-9) => Some((l * u).sqrt()),
            _ => None,
        },
        anywhere_lower,
        anywhere_upper,
        anywhere_linear_estimate,
        probes,
        note,
    }
}

fn probe_of(stored: &StoredRun) -> OpeningProbe {
    let r = &stored.result;
    OpeningProbe {
        force: r.force,
        opened_in_cone: r.cone.count,
        cone_depth: r.cone.depth,
        cone_shallowest: r.cone.shallowest,
        opened_connected: r.region.count,
        connected_depth: r.region.depth,
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

