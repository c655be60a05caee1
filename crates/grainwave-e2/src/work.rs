//! The units of work of an `e2` run (SPEC §6), as a [`Work`] for the scheduler
//! ([`grainwave_study::work`]):
//!
//! * `loading` (when the run makes its own packing, i.e. without `source.dir`): the preparation
//!   by two pistons and the biaxial test ([`biaxial`]), which writes the strain checkpoints
//!   `checkpoints/ck-*.gwck`. Its partial state is the protocol state in `checkpoint.gwck`
//!   (engine state, series, checkpoints so far); its result is that state once the loading is
//!   done (stage [`Stage::Replays`]: preparation, units, series, checkpoint list).
//! * `replay/<name>`, one per `[[replays]]` entry: a paired replay (wall pulse or radius change,
//!   every amplitude) or a single replay (velocity scale, friction, wall stop, top piston) of a
//!   checkpoint. Declared input: the `loading` (whose checkpoint it starts from), or the single
//!   replay named by `from` (whose `final.gwck` it starts from); with `source.dir` a replay
//!   without `from` has no input (the checkpoints are another run's). Result:
//!   `replays/<name>/report.gwck`; partial state of an interrupted single replay:
//!   `replays/<name>/partial.gwck`.
//!
//! Replays that do not read each other run in parallel; the run's tables (pulses, Δc/c₀,
//! anisotropy) are aggregated from the reports in the order of the config, so the outputs are
//! the same bits for any thread count and across interruptions. The ids are stable: the same
//! config gives the same plan.

use super::biaxial::{self, StrainCheckpoint};
use super::config::{E2Config, GrainOrder, Modification, PulseWall};
use super::model;
use super::outputs::{self, ReplayReport, SingleReport};
use super::replay;
use super::{E2State, Stage, TAG};
use grainwave_study::{ExperimentError, Result};
use grainwave_study::protocol::RunContext;
use grainwave_study::work::{store, Unit, UnitEnv, UnitResult, UnitStop, Work};
use grainwave_core::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Content tag of a finished replay's report (`replays/<name>/report.gwck`).
pub const REPORT_TAG: &str = "e2-replay-report";

/// Id of the loading unit.
pub const LOADING: &str = "loading";

/// Name of replay `k` of `cfg` (`name`, or `r<k>`): its directory `replays/<name>/`.
pub fn replay_name(cfg: &E2Config, k: usize) -> String {
    cfg.replays[k].name.clone().unwrap_or(format!("r{k}"))
}

/// The plan of an `e2` run: the loading (unless the checkpoints come from `source.dir`), then
/// one unit per replay, in the order of the config, each reading the unit it starts from.
pub fn plan(cfg: &E2Config) -> Vec<Unit> {
    let mut units = Vec::new();
    let loading = cfg.source.dir.is_none().then(|| {
        units.push(Unit { id: LOADING.into(), kind: "loading".into(), inputs: Vec::new() });
        0
    });
    let first = units.len();
    // earlier replays by name: one lookup per `from` (a chain of n replays plans in n log n)
    let mut earlier: std::collections::BTreeMap<String, usize> = std::collections::BTreeMap::new();
    for (k, r) in cfg.replays.iter().enumerate() {
        // validation guarantees that `from` names an earlier replay (or, with `source.dir`, a
        // replay of that run: no input here)
        let from = r.from.as_ref().and_then(|f| earlier.get(f).copied()).map(|j| first + j);
        earlier.entry(replay_name(cfg, k)).or_insert(k);
        let inputs = from.or(loading).into_iter().collect();
        units.push(Unit { id: format!("replay/{}", replay_name(cfg, k)), kind: "replays".into(), inputs });
    }
    units
}

/// File of the report of the finished replay `name`.
pub fn report_file(out: &Path, name: &str) -> PathBuf {
    out.join("replays").join(name).join("report.gwck")
}

/// The reports of the finished replays of `cfg` in `out`, in the order of the config.
pub fn finished_reports(out: &Path, cfg: &E2Config) -> Result<Vec<ReplayReport>> {
    let mut v = Vec::new();
    for k in 0..cfg.replays.len() {
        let f = report_file(out, &replay_name(cfg, k));
        if f.exists() {
            v.push(grainwave_core::checkpoint::load(&f, REPORT_TAG)?);
        }
    }
    Ok(v)
}

/// Writes the reports that a state carries (a checkpoint of an earlier version ran the replays
/// one after another and kept their reports in the state only) as unit results, so that the
/// scheduler skips those replays.
pub fn adopt_reports(out: &Path, reports: &[ReplayReport]) -> Result<()> {
    for r in reports {
        let f = report_file(out, &r.name);
        if !f.exists() {
            store(&f, REPORT_TAG, r, None)?;
        }
    }
    Ok(())
}

/// What a unit produces.
#[derive(Serialize, Deserialize)]
pub enum Output {
    /// The loading is done (its result is the protocol state).
    Loading,
    /// A replay's report.
    Replay(Box<ReplayReport>),
}

/// The units of an `e2` run, for the scheduler.
pub struct E2Work<'a> {
    cfg: &'a E2Config,
    units: Vec<Unit>,
    out: PathBuf,
    source: PathBuf,
    state: Mutex<&'a mut E2State>,
    /// The error of a failed loading, returned as it is (the scheduler lists failures by unit).
    loading_error: Mutex<Option<ExperimentError>>,
}

impl<'a> E2Work<'a> {
    /// The units of `state`'s run into `out` (checkpoints from `source.dir`, or from `out`).
    pub fn new(cfg: &'a E2Config, out: &Path, state: &'a mut E2State) -> Self {
        let source = cfg.source.dir.as_ref().map(PathBuf::from).unwrap_or(out.to_path_buf());
        E2Work { cfg, units: state.plan.clone(), out: out.to_path_buf(), source, state: Mutex::new(state), loading_error: Mutex::new(None) }
    }

    /// The error of the loading, if it failed.
    pub fn take_loading_error(&self) -> Option<ExperimentError> {
        self.loading_error.lock().ok().and_then(|mut e| e.take())
    }

    fn replay_index(&self, k: usize) -> usize {
        k - (self.units.len() - self.cfg.replays.len())
    }
}

fn lock<'m, T>(m: &'m Mutex<T>) -> std::sync::MutexGuard<'m, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Work for E2Work<'_> {
    type Output = Output;

    fn units(&self) -> &[Unit] {
        &self.units
    }

    fn is_done(&self, k: usize) -> bool {
        if self.units[k].id == LOADING {
            matches!(lock(&self.state).stage, Stage::Replays | Stage::Finished)
        } else {
            report_file(&self.out, &replay_name(self.cfg, self.replay_index(k))).exists()
        }
    }

    fn run(&self, k: usize, env: &UnitEnv<'_, '_, '_>) -> UnitResult<Output> {
        if self.units[k].id == LOADING {
            let mut state = lock(&self.state);
            return match env.with_context(|ctx| run_loading(&mut state, ctx)) {
                Ok(true) => Ok(Output::Loading),
                Ok(false) => Err(UnitStop::Interrupted),
                Err(e) => {
                    let line = grainwave_study::protocol::failure_line(&e);
                    *lock(&self.loading_error) = Some(e);
                    Err(UnitStop::Failed(ExperimentError::Core(CoreError::Inconsistent(line))))
                }
            };
        }
        run_replay(self.cfg, self.replay_index(k), &self.out, &self.source, env).map(|r| Output::Replay(Box::new(r)))
    }

    fn record(&self, k: usize, output: &Output) -> Result<()> {
        match output {
            Output::Loading => {
                grainwave_core::checkpoint::save(&self.out.join(grainwave_study::protocol::CHECKPOINT_FILE), TAG, &**lock(&self.state))?;
                Ok(())
            }
            Output::Replay(r) => store(&report_file(&self.out, &replay_name(self.cfg, self.replay_index(k))), REPORT_TAG, &**r, None),
        }
    }

    fn anywhere(&self, k: usize) -> bool {
        self.units[k].id != LOADING
    }
}

/// Runs (or continues) the preparation and the loading of `st`; false when interrupted (the
/// engine state stays in `st`, for the checkpoint).
pub fn run_loading(st: &mut E2State, ctx: &mut RunContext<'_>) -> Result<bool> {
    let cfg = st.config.clone();
    if st.stage == Stage::Preparing {
        if st.sim.is_none() {
            ctx.log(&format!("e2: preparing {} disks", cfg.packing.columns * cfg.packing.rows));
            let mut gas = model::build_gas(&cfg.packing, &cfg.material, &cfg.preparation, cfg.seed)?;
            if cfg.packing.grain_order == GrainOrder::Sorted {
                gas.sort_spatially();
            }
            st.sim = Some(gas);
        }
        let mut sim = st.sim.take().expect("engine state");
        let snapshot = |stage: Stage, sim: &Simulation<D2>, info: &biaxial::PreparationInfo| E2State {
            plan: st.plan.clone(),
            config: cfg.clone(),
            stage,
            sim: Some(sim.clone()),
            preparation: info.clone(),
            units: None,
            loading: None,
            replays: Vec::new(),
        };
        let mut save = |ctx: &mut RunContext<'_>, sim: &Simulation<D2>, info: &biaxial::PreparationInfo| -> Result<()> {
            ctx.save_checkpoint(TAG, &snapshot(Stage::Preparing, sim, info))?;
            Ok(())
        };
        let done = biaxial::prepare(&mut sim, &mut st.preparation, &cfg, ctx, &mut save)?;
        st.sim = Some(sim);
        if !done {
            return Ok(false);
        }
        let sim = st.sim.as_mut().expect("engine state");
        if cfg.packing.grain_order == GrainOrder::Sorted {
            // the grains have moved since the gas was sorted: sort the packing the loading runs on
            sim.sort_spatially();
        }
        ctx.log(&format!(
            "preparation converged: {} steps, {:.3} t*, Φ = {:.4}, max |F| = {:.2e} p* d̄, {} quenches",
            st.preparation.steps, st.preparation.time, st.preparation.packing_fraction, st.preparation.max_force, st.preparation.quenches
        ));
        let units = model::Units::of(sim, 1.0, cfg.material.normal_stiffness);
        st.units = Some(units);
        st.loading = Some(biaxial::start_loading(sim, &cfg)?);
        let per_sample = cfg.loading.strain_rate / units.time * sim.dt * cfg.loading.sample_every as f64;
        if cfg.loading.checkpoint_strain > 0.0 && per_sample > 0.5 * cfg.loading.checkpoint_strain {
            ctx.log(&format!(
                "warning: the strain grows by {per_sample:.2e} between samples (`loading.sample_every` = {}), more than half of `loading.checkpoint_strain` = {:.1e}: checkpoints fall up to one sample late, and some are skipped when a sample passes two multiples",
                cfg.loading.sample_every, cfg.loading.checkpoint_strain
            ));
        }
        st.stage = Stage::Loading;
        ctx.save_checkpoint(TAG, st)?;
    }
    if st.stage == Stage::Loading {
        let units = st.units.expect("units after preparation");
        let mut sim = st.sim.take().expect("engine state");
        let mut loading = st.loading.take().expect("loading state");
        let base = E2State { sim: None, loading: None, ..st.clone() };
        let mut save = |ctx: &mut RunContext<'_>, sim: &Simulation<D2>, loading: &biaxial::Loading| -> Result<()> {
            let s = E2State { sim: Some(sim.clone()), loading: Some(loading.clone()), ..base.clone() };
            ctx.save_checkpoint(TAG, &s)?;
            Ok(())
        };
        let done = biaxial::load(&mut sim, &mut loading, &units, &cfg, ctx, &mut save)?;
        st.sim = Some(sim);
        st.loading = Some(loading);
        if !done {
            return Ok(false);
        }
        let l = st.loading.as_ref().expect("loading");
        ctx.log(&format!(
            "loading done: ε_yy = {:.4e} after {:.3} t*, {} checkpoints, {:.1} s",
            l.series.last().map(|r| r[1]).unwrap_or(0.0),
            l.series.last().map(|r| r[0]).unwrap_or(0.0),
            l.checkpoints.len(),
            l.seconds
        ));
        outputs::write_loading(ctx.out_dir(), &cfg, l)?;
        st.sim = None; // the state lives on in the strain checkpoints
        st.stage = Stage::Replays;
    }
    Ok(true)
}

/// Content tag of the progress file of a single replay.
pub const PARTIAL_TAG: &str = "e2-single-replay-progress";

/// The progress of a single replay (`replays/<name>/partial.gwck`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SinglePartial {
    /// The engine state.
    pub sim: Simulation<D2>,
    /// The wall drive.
    pub drive: model::Drive,
    /// The series so far (time [t_a], σ_yy, σ_xx [p*], M_s, KE [p* L*²]).
    pub rows: Vec<[f64; 5]>,
    /// Steps done.
    pub done: u64,
    /// Simulated time at the start [engine time].
    pub t0: f64,
    /// Kinetic energy at the start [p* L*²].
    pub ke0: f64,
    /// M_s (cap flag) at the start.
    pub m0: u64,
    /// M_s (mobilised) at the start.
    pub mob0: u64,
}

/// Runs replay `k` of `cfg` (checkpoints from `source`), writing `replays/<name>/` under
/// `out_root`; an interrupted single replay leaves its progress in `replays/<name>/partial.gwck`
/// and continues from it.
pub fn run_replay(cfg: &E2Config, k: usize, out_root: &Path, source: &Path, env: &UnitEnv<'_, '_, '_>) -> UnitResult<ReplayReport> {
    let started = std::time::Instant::now();
    let rc = &cfg.replays[k];
    let name = rc.name.clone().unwrap_or(format!("r{k}"));
    let dir = out_root.join("replays").join(&name);
    std::fs::create_dir_all(&dir).map_err(|e| CoreError::Io { action: "cannot create".into(), path: dir.display().to_string(), error: e })?;
    let ck = match &rc.from {
        Some(from) => {
            // an earlier replay of this run, or (with `source.dir`) a single replay of that run
            let own = out_root.join("replays").join(from).join("final.gwck");
            let theirs = source.join("replays").join(from).join("final.gwck");
            let in_file = cfg.replays[..k].iter().enumerate().any(|(j, q)| q.name.clone().unwrap_or(format!("r{j}")) == *from);
            biaxial::read_full_checkpoint(if in_file || !theirs.exists() { &own } else { &theirs })?
        }
        None => {
            let mut log = |m: &str| env.log(&format!("replay {name}: {m}"));
            match biaxial::load_checkpoint_with(source, rc.checkpoint, &mut log, &mut || env.interrupted())? {
                Some(ck) => ck,
                None => return Err(UnitStop::Interrupted),
            }
        }
    };
    let u = ck.units;
    env.log(&format!("replay {name}: checkpoint {} (ε_yy = {:.4e}), {}", ck.index, ck.strain.1, rc.modification.name()));
    // velocity_scale by a target rate and for an extra strain (SPEC §6.6)
    let mut rc_eff = rc.clone();
    if rc.modification == Modification::VelocityScale && (rc.rate.is_some() || rc.extra_strain.is_some()) {
        let (_, h) = model::box_size(&ck.sim);
        let rate = ck.sim.domain.walls[model::TOP].speed.abs() / h * u.time;
        if !(rate > 0.0) {
            return Err(UnitStop::Failed(ExperimentError::Resume {
                path: source.to_path_buf(),
                reason: format!("replay `{name}`: `rate`/`extra_strain` need a moving top wall, but it is at rest in the start state"),
            }));
        }
        if let Some(target) = rc.rate {
            rc_eff.factor = target / rate;
        }
        if let Some(de) = rc.extra_strain {
            rc_eff.duration = de / (rate * rc_eff.factor) * u.time / u.acoustic_time;
        }
        env.log(&format!(
            "replay {name}: strain rate {rate:.4e} /t* × γ = {:.4e} → {:.4e} /t*, for {:.2} t_a",
            rc_eff.factor,
            rate * rc_eff.factor,
            rc_eff.duration
        ));
    }
    let rc = &rc_eff;
    let steps = (rc.duration * u.acoustic_time / ck.sim.dt).round().max(1.0) as u64;
    let sample_every = (rc.sample_interval * u.acoustic_time / ck.sim.dt).round().max(1.0) as u64;
    let mut report = ReplayReport {
        name: name.clone(),
        checkpoint: ck.index,
        strain_yy: ck.strain.1,
        modification: rc.modification.name().into(),
        units: u,
        pairs: Vec::new(),
        single: None,
        seconds: 0.0,
    };
    let mut ck = ck;
    if rc.modification == Modification::WallPulse && rc.pulse_wall == PulseWall::Top {
        if !ck.drive.pistons.iter().any(|(k, _)| *k == model::TOP) {
            return Err(UnitStop::Failed(ExperimentError::Resume {
                path: source.to_path_buf(),
                reason: format!("replay `{name}`: the top wall of its start state is not a piston (start it `from` a `top_piston` replay)"),
            }));
        }
        ck.drive.pulse_wall = model::TOP;
    }
    if rc.modification == Modification::Incremental {
        let snapshot = ck.sim.snapshot();
        let mut curves = Vec::new();
        let samples = (steps / sample_every + 1) as usize;
        let sample_dt = sample_every as f64 * ck.sim.dt;
        let delay = rc.delay.map(|d| d * u.acoustic_time).unwrap_or(ck.sim.dt);
        let pert = replay::Perturbation::WallPulse { shape: rc.shape, time_unit: u.time, delay, width: rc.width * u.acoustic_time };
        let mut infos = Vec::new();
        for (ai, &a) in rc.amplitudes.iter().enumerate() {
            let t = std::time::Instant::now();
            let (r, info) = super::incremental::incremental_replay(&ck.sim, &ck.drive, rc, &u, a, samples, sample_dt, delay)?;
            let arr = replay::arrivals(&r, &ck.sim, &ck.drive, &pert, a, rc, &u);
            let (pair, curve) = outputs::write_pair(out_root, &dir, cfg, rc, &u, &snapshot, ai, a, &r, &arr)?;
            outputs::write_branches(&dir, ai, &info, &u)?;
            curves.push(curve);
            let show = |s: Option<f64>| s.map(|s| format!("{s:.4}")).unwrap_or("—".into());
            let slipped = info.history.iter().filter(|h| h.first_slip.is_some()).count();
            let switched = info.history.iter().filter(|h| h.switches > 1).count();
            env.log(&format!(
                "replay {name} ({}) a = {a:e}: speed maximum {} v_a, first lobe {} v_a; {} contacts at the limit ({} at the rolling cap), {} slipped, {} slipped and stuck again; {} steps, {:.1} s",
                info.branches,
                show(pair.speed_maximum),
                show(pair.speed_first_lobe),
                info.counts.at_limit,
                info.counts.at_rolling_cap,
                slipped,
                switched,
                info.steps,
                t.elapsed().as_secs_f64()
            ));
            report.pairs.push(pair);
            infos.push((a, t.elapsed().as_secs_f64(), info));
        }
        outputs::write_incremental_summary(&dir, &infos)?;
        outputs::write_pair_plots(out_root, &dir, cfg, &name, &mut report, &curves)?;
    } else if let Some(pert) = replay::perturbation_of(rc, &ck.sim, &u) {
        let snapshot = ck.sim.snapshot();
        let mut curves = Vec::new();
        for (ai, &a) in rc.amplitudes.iter().enumerate() {
            let r = replay::paired_replay(&ck.sim, &ck.drive, &pert, a, steps, sample_every)?;
            let arr = replay::arrivals(&r, &ck.sim, &ck.drive, &pert, a, rc, &u);
            let (pair, curve) = outputs::write_pair(out_root, &dir, cfg, rc, &u, &snapshot, ai, a, &r, &arr)?;
            curves.push(curve);
            let show = |s: Option<f64>| s.map(|s| format!("{s:.4}")).unwrap_or("—".into());
            let (speed, by_max, by_lobe) = (pair.speed, pair.speed_maximum, pair.speed_first_lobe);
            env.log(&format!(
                "replay {name} a = {a:e}: speed {} v_a (maximum {}, first lobe {}), max |δv| = {:.3e} v_a, M_s (mobilised) {} → {}, {} pushed on by the pulse's mean strain",
                show(speed),
                show(by_max),
                show(by_lobe),
                r.max_difference / u.acoustic_velocity,
                r.mobilised[0],
                r.mobilised[1],
                r.pushed_on
            ));
            if let (Some(m), Some(l)) = (by_max, by_lobe) {
                if (m - l).abs() > 0.05 * l.abs() {
                    env.log(&format!(
                        "replay {name} a = {a:e}: the two arrival definitions differ by more than 5 % — the largest |δv_x| is not the pulse's peak \
                         (the perturbation grows behind the front, as in a deforming packing); see docs/e2.md"
                    ));
                }
            }
            report.pairs.push(pair);
        }
        outputs::write_pair_plots(out_root, &dir, cfg, &name, &mut report, &curves)?;
    } else {
        let energy = u.pressure * u.length * u.length;
        // a long single replay (the 100 t* of the slow-down at 128 × 128 take hours) saves its
        // progress in `partial.gwck` every `output.save_every` seconds and when interrupted, and
        // continues from it bit for bit on resume
        let partial_path = dir.join("partial.gwck");
        let mut p: SinglePartial = if partial_path.exists() {
            let p: SinglePartial = grainwave_core::checkpoint::load(&partial_path, PARTIAL_TAG).map_err(ExperimentError::from)?;
            env.log(&format!("replay {name}: continuing from step {} of {steps} (partial.gwck)", p.done));
            p
        } else {
            let mut sim = ck.sim.clone();
            let mut drive = ck.drive.clone();
            let ke0 = sim.kinetic_energy() / energy;
            let m0 = sim.counters.sliding;
            let mob0 = model::mobilised_contacts(&sim);
            if rc.modification == Modification::TopPiston {
                let (_, h) = model::box_size(&sim);
                let v = sim.domain.walls[model::TOP].speed;
                env.log(&format!(
                    "replay {name}: top wall speed at the switch {:.4e} v_a (strain rate {:.4e} /t*){}",
                    v / u.acoustic_velocity,
                    v / h * u.time,
                    if v != 0.0 { "; the piston starts at rest" } else { "" }
                ));
            }
            replay::apply_single(rc, &mut sim, &mut drive, &u, cfg)?;
            let t0 = sim.time;
            SinglePartial { sim, drive, rows: Vec::new(), done: 0, t0, ke0, m0, mob0 }
        };
        let t0 = p.t0;
        let record = |sim: &Simulation<D2>, rows: &mut Vec<[f64; 5]>| {
            let (sxx, syy) = model::wall_stresses(sim);
            rows.push([(sim.time - t0) / u.acoustic_time, syy / u.pressure, sxx / u.pressure, sim.counters.sliding as f64, sim.kinetic_energy() / energy]);
        };
        if p.done == 0 && p.rows.is_empty() {
            record(&p.sim, &mut p.rows);
        }
        let mut last_save = std::time::Instant::now();
        // the series of a long single replay (the slow-down lasts 100 t* ≈ 4500 t_a) keeps at
        // most ≈ 20 000 rows: sample_interval, or duration/20 000 if longer
        let sample_every = sample_every.max(steps / 20_000);
        // progress, interruption and periodic saves every `report_every` steps (1000 by default),
        // after the step's sample: a saved state has taken its sample, and the resume starts
        // with the next step
        let every = env.report_every().max(1);
        while p.done < steps {
            p.drive.step(&mut p.sim)?;
            p.done += 1;
            if p.done % sample_every == 0 {
                record(&p.sim, &mut p.rows);
            }
            if p.done % every == 0 && p.done < steps {
                let mut progress = p.sim.progress(&StopCriteria::default());
                progress.fraction_of_limit = p.done as f64 / steps as f64;
                env.progress(&format!("replay {name}"), &progress);
                let interrupted = env.interrupted();
                if interrupted || last_save.elapsed().as_secs_f64() >= cfg.output.save_every {
                    grainwave_core::checkpoint::save(&partial_path, PARTIAL_TAG, &p)?;
                    last_save = std::time::Instant::now();
                }
                if interrupted {
                    return Err(UnitStop::Interrupted);
                }
            }
            if p.done % 100_000 == 0 {
                env.log_quiet(&format!("replay {name}: step {} of {steps}, KE {:.3e} p* L*²", p.done, p.sim.kinetic_energy() / energy));
            }
        }
        let SinglePartial { sim, drive, rows, ke0, m0, mob0, .. } = p;
        outputs::write_single(&dir, cfg, rc, &name, &rows)?;
        let last = rows.last().expect("rows");
        let mob1 = model::mobilised_contacts(&sim);
        env.log(&format!(
            "replay {name}: M_s (cap flag) {} → {}, M_s (mobilised, |F_t| ≥ (1 − 1e−6) μ F_n) {} → {}, KE {:.3e} → {:.3e} p* L*², over {:.1} t_a",
            m0,
            sim.counters.sliding,
            mob0,
            mob1,
            ke0,
            last[4],
            last[0]
        ));
        let end = StrainCheckpoint { index: ck.index, sim: sim.clone(), drive, strain: ck.strain, units: u };
        biaxial::save_checkpoint(&dir.join("final.gwck"), &end)?;
        let _ = std::fs::remove_file(&partial_path);
        report.single =
            Some(SingleReport {
            final_stress_yy: last[1],
            final_stress_xx: last[2],
            sliding: [m0, sim.counters.sliding],
            mobilised: [mob0, mob1],
            kinetic_energy: [ke0, last[4]],
            factor: if rc.modification == Modification::VelocityScale { rc.factor } else { 1.0 },
            duration: last[0],
        });
    }
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}
