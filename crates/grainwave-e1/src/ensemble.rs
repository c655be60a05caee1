//! The samples of an `e1` run as units of work ([`grainwave_study::work`]): run several at once by the
//! scheduler, each prepared (or loaded from its `packing.gwck`), analysed and persisted as
//! `result.gwck` in its own directory `samples/<group>/s<seed>/`. A sample whose result is there with the right fingerprint is not
//! redone; an interrupted preparation continues from its `preparing.gwck`. Results do not depend
//! on the number of threads or of samples run at once: each sample is a deterministic function of
//! its seed and the config.

use super::plan::{Plan, StudyKind, Task};
use super::prepare::{build_gas, relax, set_damping, PackingFile, PackingSpec, PreparationInfo, RelaxStatus};
use super::sample::{analyze_chain, analyze_packing, chain_spec, SampleResult};
use grainwave_study::Result;
use grainwave_study::protocol::RunContext;
use grainwave_core::checkpoint::AnySimulation;
use grainwave_study::work::{store, Finished, Scheduler, Unit, UnitEnv, UnitResult, UnitStop, Work};
use grainwave_core::prelude::*;
use grainwave_linear::reference::TriangularLatticeSpec;
use std::path::{Path, PathBuf};

/// Checkpoint tag of prepared packings.
pub const PACKING_TAG: &str = "e1-packing";
/// Checkpoint tag of preparations in progress.
pub const PREPARING_TAG: &str = "e1-preparing";
/// Checkpoint tag of sample results.
pub const RESULT_TAG: &str = "e1-sample-result";

/// Directory of a sample, relative to the output directory.
pub fn sample_dir(plan: &Plan, task: &Task) -> PathBuf {
    PathBuf::from("samples").join(&plan.groups[task.group].name).join(format!("s{:04}", task.seed))
}

/// Loads the result of `task` if it is there and its fingerprint matches.
pub fn load_result(out: &Path, plan: &Plan, task: &Task) -> Option<SampleResult> {
    let path = out.join(sample_dir(plan, task)).join("result.gwck");
    if !path.exists() {
        return None;
    }
    let r: SampleResult = grainwave_core::checkpoint::load(&path, RESULT_TAG).ok()?;
    (r.fingerprint == plan.result_fingerprint(task)).then_some(r)
}

/// Loads the prepared packing of `task` if it is there and its fingerprint matches.
pub fn load_packing(out: &Path, plan: &Plan, task: &Task) -> Option<PackingFile> {
    let path = out.join(sample_dir(plan, task)).join("packing.gwck");
    let f: PackingFile = grainwave_core::checkpoint::load(&path, PACKING_TAG).ok()?;
    (f.fingerprint == plan.packing_fingerprint(task) && f.info.converged).then_some(f)
}

/// The units of `plan`: one sample per task (id: its directory), without inputs.
pub fn units(plan: &Plan) -> Vec<Unit> {
    plan.tasks.iter().map(|t| Unit { id: sample_dir(plan, t).display().to_string(), kind: "samples".into(), inputs: vec![] }).collect()
}

/// The samples of a plan as units of work: one per task, without inputs.
pub struct Samples<'p> {
    plan: &'p Plan,
    out: PathBuf,
    units: Vec<Unit>,
}

impl<'p> Samples<'p> {
    /// The units of `plan`, whose results go under `out`.
    pub fn new(plan: &'p Plan, out: &Path) -> Self {
        Samples { plan, out: out.to_path_buf(), units: units(plan) }
    }
}

impl Work for Samples<'_> {
    type Output = SampleResult;

    fn units(&self) -> &[Unit] {
        &self.units
    }

    fn is_done(&self, k: usize) -> bool {
        load_result(&self.out, self.plan, &self.plan.tasks[k]).is_some()
    }

    fn run(&self, k: usize, env: &UnitEnv<'_, '_, '_>) -> UnitResult<SampleResult> {
        run_sample(self.plan, &self.plan.tasks[k], &self.out, env)
    }

    fn record(&self, k: usize, result: &SampleResult) -> Result<()> {
        store(&self.out.join(sample_dir(self.plan, &self.plan.tasks[k])).join("result.gwck"), RESULT_TAG, result, None)
    }

    fn recorded(&self, k: usize, result: &SampleResult, ctx: &mut RunContext<'_>, _done: &[bool]) -> Result<()> {
        let mut line = format!("{} done in {:.1} s", self.units[k].id, result.seconds);
        if let Some(p) = &result.preparation {
            line.push_str(&format!(" (preparation {} steps, {:.1} s)", p.steps, p.seconds));
        }
        if let Some(s) = &result.statistics {
            line.push_str(&format!(", L = {:.2}, z* = {:.3}", result.height, s.coordination_star));
        }
        if let Some(m) = result.pulse.as_ref().and_then(|p| p.metrics.as_ref()) {
            line.push_str(&format!(", leading edge at t = {:.4}", m.leading_edge_time));
        }
        if let Some(p) = result.pulse.as_ref().filter(|p| !p.omega_squared.is_empty()) {
            line.push_str(&format!(", {} zero modes ({} of rattlers)", p.zero_modes, p.rattler_zero_modes));
        }
        ctx.log(&line);
        Ok(())
    }
}

/// Runs every task of `plan` that has no result yet (at most `parallel_samples` at once).
pub fn run_ensemble(plan: &Plan, ctx: &mut RunContext<'_>) -> Result<Finished> {
    let samples = Samples::new(plan, ctx.out_dir());
    let mut scheduler = Scheduler::new(&samples);
    scheduler.max_parallel = plan.config.parallel_samples;
    scheduler.run(ctx)
}

/// Runs, in a worker process, the samples of `plan` that the coordinator sends
/// ([`grainwave_study::work::serve`]).
pub fn serve(plan: &Plan, out: &Path, link: &dyn grainwave_study::work::WorkerLink, interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>) -> Result<()> {
    grainwave_study::work::serve(&Samples::new(plan, out), link, out, interrupt)
}

fn save_file(path: &Path, tag: &str, file: &PackingFile) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| CoreError::Io { action: "cannot create".into(), path: dir.display().to_string(), error: e })?;
    }
    grainwave_core::checkpoint::save(path, tag, file)?;
    Ok(())
}

/// Prepares (or continues preparing) a packing; `None` when interrupted.
fn prepare<D: Dim>(
    mut sim: Simulation<D>,
    mut info: PreparationInfo,
    fingerprint: u64,
    wrap: fn(Simulation<D>) -> AnySimulation,
    plan: &Plan,
    pressure: f64,
    dir: &Path,
    env: &UnitEnv<'_, '_, '_>,
) -> Result<Option<(AnySimulation, PreparationInfo)>> {
    let preparing = dir.join("preparing.gwck");
    let mut save = |s: &Simulation<D>, i: &PreparationInfo| save_file(&preparing, PREPARING_TAG, &PackingFile { fingerprint, sim: wrap(s.clone()), info: i.clone() });
    let status = relax(&mut sim, &mut info, &plan.config.preparation, pressure, env.interrupt_flag(), plan.config.output.save_every_seconds, &mut save)?;
    match status {
        RelaxStatus::Interrupted => {
            save(&sim, &info)?;
            Ok(None)
        }
        RelaxStatus::Converged => {
            let file = PackingFile { fingerprint, sim: wrap(sim), info: info.clone() };
            save_file(&dir.join("packing.gwck"), PACKING_TAG, &file)?;
            let _ = std::fs::remove_file(&preparing);
            Ok(Some((file.sim, info)))
        }
    }
}

/// The static system of a Hertz task: loaded, continued or prepared; `None` when interrupted.
fn obtain_system(plan: &Plan, task: &Task, out: &Path, dir: &Path, env: &UnitEnv<'_, '_, '_>) -> Result<Option<(AnySimulation, Option<PreparationInfo>)>> {
    let group = &plan.groups[task.group];
    let fingerprint = plan.packing_fingerprint(task);
    if let Some(f) = load_packing(out, plan, task) {
        return Ok(Some((f.sim, Some(f.info))));
    }
    let pressure = group.pressure.expect("Hertz groups have a pressure");
    if plan.kind == StudyKind::Lattice && plan.spread == 0.0 {
        let lc = plan.config.lattice.as_ref().expect("a lattice study");
        let spec = TriangularLatticeSpec {
            rows: group.rows,
            columns: lc.columns,
            pressure,
            young: 1.0 - lc.poisson * lc.poisson,
            poisson: lc.poisson,
            friction: lc.friction,
            polydispersity: 0.0,
            piston: false,
            seed: task.seed,
            ..Default::default()
        };
        let sim = spec.build().map_err(|e| CoreError::Inconsistent(e.to_string()))?;
        return Ok(Some((AnySimulation::D2(sim), None)));
    }
    // continue an interrupted preparation
    let preparing = dir.join("preparing.gwck");
    let resumed: Option<PackingFile> =
        grainwave_core::checkpoint::load::<PackingFile>(&preparing, PREPARING_TAG).ok().filter(|f| f.fingerprint == fingerprint);
    let (sim, info) = match resumed {
        Some(f) => {
            env.log_quiet(&format!("{}: continuing its preparation at step {}", dir.display(), f.info.steps));
            (f.sim, f.info)
        }
        None => {
            let sim = if plan.kind == StudyKind::Lattice {
                let lc = plan.config.lattice.as_ref().expect("a lattice study");
                let spec = TriangularLatticeSpec {
                    rows: group.rows,
                    columns: lc.columns,
                    pressure,
                    young: 1.0 - lc.poisson * lc.poisson,
                    poisson: lc.poisson,
                    friction: lc.friction,
                    polydispersity: lc.polydispersity,
                    piston: true,
                    seed: task.seed,
                    ..Default::default()
                };
                let mut sim = spec.build().map_err(|e| CoreError::Inconsistent(e.to_string()))?;
                set_damping(&mut sim, plan.friction, plan.poisson, plan.config.preparation.damping)?;
                let r_max = sim.grains.radius_range().1;
                let overlap = plan.config.preparation.expected_overlap.unwrap_or_else(|| super::prepare::default_expected_overlap(pressure, r_max));
                sim.dt = grainwave_core::timestep::suggest_timestep(&sim.grains, &sim.law, &sim.domain.walls, plan.config.preparation.dt_fraction, overlap);
                sim.suggested_dt = sim.dt;
                sim.dt_fraction = plan.config.preparation.dt_fraction;
                sim.expected_overlap = overlap;
                AnySimulation::D2(sim)
            } else {
                let spec = PackingSpec {
                    grains: group.grains,
                    width: plan.width,
                    spread: plan.spread,
                    friction: plan.friction,
                    poisson: plan.poisson,
                    pressure,
                    seed: task.seed,
                    preparation: plan.config.preparation.clone(),
                };
                if plan.dimension == 2 {
                    AnySimulation::D2(build_gas::<D2>(&spec)?)
                } else {
                    AnySimulation::D3(build_gas::<D3>(&spec)?)
                }
            };
            (sim, PreparationInfo::default())
        }
    };
    let r = match sim {
        AnySimulation::D2(s) => prepare(s, info, fingerprint, AnySimulation::D2, plan, pressure, dir, env)?,
        AnySimulation::D3(s) => prepare(s, info, fingerprint, AnySimulation::D3, plan, pressure, dir, env)?,
    };
    Ok(r.map(|(s, i)| (s, Some(i))))
}

/// Runs one sample (preparation or its saved packing, then the analysis). A failure of the
/// sample's physics (a preparation that does not converge, a singular matrix…) is part of its
/// result (`failure`, reported per sample); an output error or an interruption stops the unit.
fn run_sample(plan: &Plan, task: &Task, out: &Path, env: &UnitEnv<'_, '_, '_>) -> UnitResult<SampleResult> {
    let group = &plan.groups[task.group];
    let rel = sample_dir(plan, task);
    let dir = out.join(&rel);
    std::fs::create_dir_all(&dir).map_err(|e| CoreError::Io { action: "cannot create".into(), path: dir.display().to_string(), error: e })?;
    let fingerprint = plan.result_fingerprint(task);
    let mut result = SampleResult::new(fingerprint, task.group, task.sample, task.seed);
    let started = std::time::Instant::now();
    let outcome: std::result::Result<(), UnitStop> = (|| {
        if plan.kind == StudyKind::Chain {
            let spec = chain_spec(plan, group, task.seed);
            return Ok(analyze_chain(&spec, plan, group, &mut result)?);
        }
        let Some((sim, info)) = obtain_system(plan, task, out, &dir, env)? else {
            return Err(UnitStop::Interrupted);
        };
        result.preparation = info;
        match &sim {
            AnySimulation::D2(s) => analyze_packing(s, plan, group, task.sample, &mut result)?,
            AnySimulation::D3(s) => analyze_packing(s, plan, group, task.sample, &mut result)?,
        }
        Ok(())
    })();
    match outcome {
        Ok(()) => {}
        Err(UnitStop::Interrupted) => return Err(UnitStop::Interrupted),
        Err(UnitStop::Failed(e @ crate::ExperimentError::Output(_))) => return Err(UnitStop::Failed(e)),
        Err(UnitStop::Failed(e)) => {
            let text = e.to_string();
            env.log(&format!("{}: failed: {text}", rel.display()));
            result.failure = Some(text);
        }
    }
    result.seconds = started.elapsed().as_secs_f64();
    Ok(result)
}
