//! Running the samples: several at once (worker threads pull tasks in order), each prepared (or
//! loaded from its `packing.gwck`), analysed and persisted as `result.gwck` in its own directory
//! `samples/<group>/s<seed>/`. A sample whose result is there with the right fingerprint is not
//! redone; an interrupted preparation continues from its `preparing.gwck`. Results do not depend
//! on the number of threads or of samples run at once: each sample is a deterministic function of
//! its seed and the config.

use super::plan::{Plan, StudyKind, Task};
use super::prepare::{build_gas, relax, set_damping, PackingFile, PackingSpec, PreparationInfo, RelaxStatus};
use super::sample::{analyze_chain, analyze_packing, chain_spec, SampleResult};
use crate::error::Result;
use crate::protocol::RunContext;
use crate::simulation::AnySim;
use grainwave_core::prelude::*;
use grainwave_linear::reference::TriangularLatticeSpec;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

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

/// What the workers share.
struct Shared<'c, 'r> {
    ctx: Mutex<&'c mut RunContext<'r>>,
    interrupt: std::sync::Arc<AtomicBool>,
    out: PathBuf,
    done: AtomicUsize,
    total: usize,
    error: Mutex<Option<crate::ExperimentError>>,
    interrupted: AtomicBool,
}

impl Shared<'_, '_> {
    fn log(&self, text: &str) {
        if let Ok(mut c) = self.ctx.lock() {
            c.log(text);
        }
    }
    fn log_quiet(&self, text: &str) {
        if let Ok(mut c) = self.ctx.lock() {
            c.log_quiet(text);
        }
    }
    fn bump(&self) {
        let done = self.done.fetch_add(1, Ordering::SeqCst) + 1;
        if let Ok(mut c) = self.ctx.lock() {
            c.reporter.samples(done, self.total);
        }
    }
}

/// How the ensemble ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnsembleStatus {
    /// Every task has a result.
    Complete,
    /// Interrupted; finished samples are saved.
    Interrupted,
}

/// Runs every task of `plan` that has no result yet.
pub fn run_ensemble(plan: &Plan, ctx: &mut RunContext<'_>) -> Result<EnsembleStatus> {
    let out = ctx.out_dir().to_path_buf();
    let todo: Vec<Task> = plan.tasks.iter().copied().filter(|t| load_result(&out, plan, t).is_none()).collect();
    let total = plan.tasks.len();
    let already = total - todo.len();
    ctx.reporter.stage("e1 samples", None);
    ctx.reporter.samples(already, total);
    if already > 0 {
        ctx.log(&format!("{already} of {total} samples already done (their results are reused)"));
    }
    if todo.is_empty() {
        return Ok(EnsembleStatus::Complete);
    }
    let workers = plan.config.parallel_samples.unwrap_or_else(rayon::current_num_threads).max(1).min(todo.len());
    ctx.log(&format!("{} samples to run, {workers} at a time", todo.len()));
    let interrupt = ctx.interrupt_flag();
    let shared = Shared {
        ctx: Mutex::new(ctx),
        interrupt,
        out,
        done: AtomicUsize::new(already),
        total,
        error: Mutex::new(None),
        interrupted: AtomicBool::new(false),
    };
    let next = AtomicUsize::new(0);
    rayon::scope(|s| {
        for _ in 0..workers {
            s.spawn(|_| loop {
                if shared.interrupt.load(Ordering::Relaxed) || shared.error.lock().map(|e| e.is_some()).unwrap_or(true) {
                    if shared.interrupt.load(Ordering::Relaxed) {
                        shared.interrupted.store(true, Ordering::SeqCst);
                    }
                    return;
                }
                let k = next.fetch_add(1, Ordering::SeqCst);
                if k >= todo.len() {
                    return;
                }
                match run_task(plan, &todo[k], &shared) {
                    Ok(true) => shared.bump(),
                    Ok(false) => {
                        shared.interrupted.store(true, Ordering::SeqCst);
                        return;
                    }
                    Err(e) => {
                        if let Ok(mut slot) = shared.error.lock() {
                            slot.get_or_insert(e);
                        }
                        return;
                    }
                }
            });
        }
    });
    if let Some(e) = shared.error.into_inner().ok().flatten() {
        return Err(e);
    }
    if shared.interrupted.load(Ordering::SeqCst) {
        return Ok(EnsembleStatus::Interrupted);
    }
    Ok(EnsembleStatus::Complete)
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
    wrap: fn(Simulation<D>) -> AnySim,
    plan: &Plan,
    dir: &Path,
    shared: &Shared<'_, '_>,
) -> Result<Option<(AnySim, PreparationInfo)>> {
    let preparing = dir.join("preparing.gwck");
    let mut save = |s: &Simulation<D>, i: &PreparationInfo| save_file(&preparing, PREPARING_TAG, &PackingFile { fingerprint, sim: wrap(s.clone()), info: i.clone() });
    let status = relax(&mut sim, &mut info, &plan.config.preparation, &shared.interrupt, plan.config.output.save_every_seconds, &mut save)?;
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
fn obtain_system(plan: &Plan, task: &Task, dir: &Path, shared: &Shared<'_, '_>) -> Result<Option<(AnySim, Option<PreparationInfo>)>> {
    let group = &plan.groups[task.group];
    let fingerprint = plan.packing_fingerprint(task);
    if let Some(f) = load_packing(&shared.out, plan, task) {
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
        return Ok(Some((AnySim::D2(sim), None)));
    }
    // continue an interrupted preparation
    let preparing = dir.join("preparing.gwck");
    let resumed: Option<PackingFile> =
        grainwave_core::checkpoint::load::<PackingFile>(&preparing, PREPARING_TAG).ok().filter(|f| f.fingerprint == fingerprint);
    let (sim, info) = match resumed {
        Some(f) => {
            shared.log_quiet(&format!("{}: continuing its preparation at step {}", dir.display(), f.info.steps));
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
                AnySim::D2(sim)
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
                    AnySim::D2(build_gas::<D2>(&spec)?)
                } else {
                    AnySim::D3(build_gas::<D3>(&spec)?)
                }
            };
            (sim, PreparationInfo::default())
        }
    };
    let r = match sim {
        AnySim::D2(s) => prepare(s, info, fingerprint, AnySim::D2, plan, dir, shared)?,
        AnySim::D3(s) => prepare(s, info, fingerprint, AnySim::D3, plan, dir, shared)?,
    };
    Ok(r.map(|(s, i)| (s, Some(i))))
}

/// Runs one task: `Ok(true)` when its result is saved, `Ok(false)` when interrupted.
fn run_task(plan: &Plan, task: &Task, shared: &Shared<'_, '_>) -> Result<bool> {
    let group = &plan.groups[task.group];
    let rel = sample_dir(plan, task);
    let dir = shared.out.join(&rel);
    std::fs::create_dir_all(&dir).map_err(|e| CoreError::Io { action: "cannot create".into(), path: dir.display().to_string(), error: e })?;
    let fingerprint = plan.result_fingerprint(task);
    let mut result = SampleResult::new(fingerprint, task.group, task.sample, task.seed);
    let started = std::time::Instant::now();
    let outcome: Result<()> = (|| {
        if plan.kind == StudyKind::Chain {
            let spec = chain_spec(plan, group, task.seed);
            return analyze_chain(&spec, plan, group, &mut result);
        }
        let Some((sim, info)) = obtain_system(plan, task, &dir, shared)? else {
            return Err(crate::ExperimentError::Resume { path: dir.clone(), reason: "interrupted".into() });
        };
        result.preparation = info;
        match &sim {
            AnySim::D2(s) => analyze_packing(s, plan, group, task.sample, &mut result),
            AnySim::D3(s) => analyze_packing(s, plan, group, task.sample, &mut result),
        }
    })();
    match outcome {
        Ok(()) => {}
        Err(crate::ExperimentError::Resume { reason, .. }) if reason == "interrupted" => return Ok(false),
        Err(e @ crate::ExperimentError::Output(_)) => return Err(e),
        Err(e) => {
            let text = e.to_string();
            shared.log(&format!("{}: failed: {text}", rel.display()));
            result.failure = Some(text);
        }
    }
    result.seconds = started.elapsed().as_secs_f64();
    grainwave_core::checkpoint::save(&dir.join("result.gwck"), RESULT_TAG, &result)?;
    let mut line = format!("{} done in {:.1} s", rel.display(), result.seconds);
    if let Some(p) = &result.preparation {
        line.push_str(&format!(" (preparation {} steps, {:.1} s)", p.steps, p.seconds));
    }
    if let Some(s) = &result.statistics {
        line.push_str(&format!(", L = {:.2}, z* = {:.3}", result.height, s.coordination_star));
    }
    if let Some(m) = result.pulse.as_ref().and_then(|p| p.metrics.as_ref()) {
        line.push_str(&format!(", leading edge at t = {:.4}", m.leading_edge_time));
    }
    shared.log(&line);
    Ok(true)
}
