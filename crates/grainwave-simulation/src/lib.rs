//! The `simulation` protocol: a general discrete-element run from one config file.
//!
//! Grains of one kind are placed in a domain (random gas or lattice), with walls (fixed, moving,
//! pistons), a contact law, gravity and loads, and integrated until the stop criteria hold or a
//! limit is reached. Along the way it records a time series, writes snapshots and checkpoints at
//! fixed step numbers; at the end it writes the summary, the final grains and plots.
//!
//! Outputs (see docs/simulation.md): `config.resolved.toml`, `summary.json`, `series.csv` and
//! `series.npz`, `grains.csv`, VTK snapshots with a `.pvd` collection, plots, `checkpoint.gwck`,
//! `run.log`.
#![warn(missing_docs)]

mod limits;

pub mod build;
pub mod config;
mod outputs;

pub use grainwave_core::checkpoint::AnySimulation;
pub use config::SimulationConfig;
pub use outputs::{make_plots, snapshot_files, write_snapshot_in, SimulationReport, WallReport};

use grainwave_study::config::{ConfigError, ConfigSource};
use grainwave_study::Result;
use grainwave_study::protocol::RunContext;
use grainwave_core::prelude::*;
use serde::{Deserialize, Serialize};

/// Content tag of this protocol's checkpoints.
pub const TAG: &str = "experiment-simulation";

/// Named columns of equal length (a time series), kept in the protocol state.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SeriesData {
    /// Column names.
    pub names: Vec<String>,
    /// Columns.
    pub columns: Vec<Vec<f64>>,
}

impl SeriesData {
    /// Appends a row (one value per column; the first row fixes the names).
    pub fn push(&mut self, row: &[(String, f64)]) {
        if self.names.is_empty() {
            self.names = row.iter().map(|(n, _)| n.clone()).collect();
            self.columns = vec![Vec::new(); row.len()];
        }
        for (c, (_, v)) in self.columns.iter_mut().zip(row) {
            c.push(*v);
        }
    }
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }
    /// True when there is no row.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names.iter().position(|n| n == name).map(|k| self.columns[k].as_slice())
    }
}

/// The complete state of a `simulation` run (what a checkpoint holds).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SimulationState {
    /// The config, with computed defaults filled in (stored as its TOML text).
    #[serde(with = "grainwave_study::config::toml_text")]
    pub config: SimulationConfig,
    /// The engine state.
    pub sim: AnySimulation,
    /// Time series recorded so far.
    pub series: SeriesData,
    /// Snapshots written so far: (time, step).
    pub snapshots: Vec<(f64, u64)>,
    /// Step of the last series row.
    pub last_series_step: Option<u64>,
    /// Step of the last snapshot.
    pub last_snapshot_step: Option<u64>,
    /// Step of the last periodic checkpoint.
    pub last_checkpoint_step: Option<u64>,
    /// Why the run stopped, once it has.
    pub outcome: Option<StopReason>,
}

/// A validated `simulation` config: the parsed keys and the built engine state.
pub struct Prepared {
    /// The config with computed defaults (time step, skin) filled in.
    pub config: SimulationConfig,
    /// The simulation, ready to step.
    pub sim: AnySimulation,
}

/// Parses and validates a config; builds the simulation without stepping it.
pub fn prepare(src: &ConfigSource) -> Result<Prepared, ConfigError> {
    let mut config: SimulationConfig = src.parse()?;
    limits::check_sizes(src, &config)?;
    let sim = build::build(src, &config)?;
    // resolved values: the time step and skin actually used
    let (dt, skin) = match &sim {
        AnySimulation::D2(s) => (s.dt, s.nlist.skin),
        AnySimulation::D3(s) => (s.dt, s.nlist.skin),
    };
    config.integration.dt = Some(dt);
    config.integration.skin = Some(skin);
    Ok(Prepared { config, sim })
}

impl SimulationState {
    /// The current 2D snapshot (for packing pictures), if the run is 2D.
    pub fn picture(&self) -> Option<Snapshot<D2>> {
        match &self.sim {
            AnySimulation::D2(s) => Some(s.snapshot()),
            AnySimulation::D3(_) => None,
        }
    }

    /// A fresh state from a prepared config.
    pub fn new(p: Prepared) -> Self {
        SimulationState {
            config: p.config,
            sim: p.sim,
            series: SeriesData::default(),
            snapshots: Vec::new(),
            last_series_step: None,
            last_snapshot_step: None,
            last_checkpoint_step: None,
            outcome: None,
        }
    }

    /// Runs (or continues) the protocol until it is done, writing every output into the context's
    /// directory. Returns the report.
    pub fn run(&mut self, ctx: &mut RunContext<'_>) -> Result<SimulationReport> {
        if self.outcome.is_none() {
            grainwave_study::outputs::write_resolved_config(ctx.out_dir(), "simulation", &self.config, "")?;
            match self.sim.clone() {
                AnySimulation::D2(s) => self.advance::<D2>(ctx, s, AnySimulation::D2)?,
                AnySimulation::D3(s) => self.advance::<D3>(ctx, s, AnySimulation::D3)?,
            }
        }
        let report = match &self.sim {
            AnySimulation::D2(s) => outputs::write_final(ctx, self, s)?,
            AnySimulation::D3(s) => outputs::write_final(ctx, self, s)?,
        };
        ctx.save_checkpoint(TAG, self)?;
        Ok(report)
    }

    fn advance<D: Dim>(&mut self, ctx: &mut RunContext<'_>, mut sim: Simulation<D>, wrap: fn(Simulation<D>) -> AnySimulation) -> Result<()> {
        let out = self.config.output.clone();
        let stop = self.config.stop.clone();
        let limit = stop.step_limit.unwrap_or(u64::MAX);
        // a bar drawn to the step limit only where nothing ends the run before it
        ctx.reporter.stage("simulation", stop.certain_end());
        ctx.log(&format!(
            "{} {} grains ({}D), dt = {:.4e}, {} contacts at the start",
            sim.len(),
            sim.grains.kind.name(),
            D::D,
            sim.dt,
            sim.counters.contacts
        ));
        let due = |every: u64, step: u64| every > 0 && step % every == 0;
        loop {
            // events at the current step (each at most once, also across a resume)
            if (self.last_series_step.is_none() || due(out.series_every, sim.step)) && self.last_series_step != Some(sim.step) {
                outputs::record_series(&mut self.series, &sim, &stop);
                self.last_series_step = Some(sim.step);
            }
            if out.vtk && due(out.snapshot_every, sim.step) && self.last_snapshot_step != Some(sim.step) {
                outputs::write_snapshot(ctx, &sim)?;
                self.snapshots.push((sim.time, sim.step));
                self.last_snapshot_step = Some(sim.step);
            }
            if due(out.checkpoint_every, sim.step) && self.last_checkpoint_step != Some(sim.step) && sim.step > 0 {
                self.last_checkpoint_step = Some(sim.step);
                self.sim = wrap(sim.clone());
                ctx.save_checkpoint(TAG, self)?;
                ctx.log_quiet(&format!("checkpoint at step {}", sim.step));
            }
            // next event
            let next = |every: u64| if every > 0 { (sim.step / every + 1) * every } else { u64::MAX };
            let target = next(out.series_every).min(next(out.snapshot_every)).min(next(out.checkpoint_every)).min(limit);
            let mut segment = stop.clone();
            segment.step_limit = Some(target);
            let result = ctx.with_hooks(|hooks| sim.run_with(&segment, hooks));
            let outcome = match result {
                Ok(o) => o,
                Err(e) => {
                    ctx.log(&format!("error: {e}"));
                    return Err(e.into());
                }
            };
            match outcome.reason {
                StopReason::StepLimit if sim.step < limit => continue,
                StopReason::Interrupted => {
                    self.sim = wrap(sim);
                    return Err(ctx.interrupted_error(TAG, self));
                }
                reason => {
                    if self.last_series_step != Some(sim.step) {
                        outputs::record_series(&mut self.series, &sim, &stop);
                        self.last_series_step = Some(sim.step);
                    }
                    ctx.log(&format!(
                        "stopped ({reason:?}) at step {}, t = {:.6e}, KE/grain {:.3e}, max acceleration {:.3e}",
                        sim.step, sim.time, outcome.last.kinetic_energy_per_grain, outcome.last.max_acceleration
                    ));
                    self.outcome = Some(reason);
                    self.sim = wrap(sim);
                    return Ok(());
                }
            }
        }
    }
}

use grainwave_study::outputs::{Format, OutputFile};

/// Every file a `simulation` run writes into its output directory (docs/outputs.md).
pub const OUTPUTS: &[OutputFile] = &[
    grainwave_study::outputs::RESOLVED_CONFIG,
    grainwave_study::outputs::SUMMARY,
    grainwave_study::outputs::CHECKPOINT,
    grainwave_study::outputs::LOG,
    grainwave_study::outputs::LOCK,
    grainwave_study::outputs::FAILED,
    OutputFile::always(
        "series.csv",
        Format::Csv,
        "time series, one row per record (`output.series_every` steps): step, time, kinetic energy per grain, max acceleration, contacts, sliding, load_<wall> per wall [config units]; step, contacts and sliding as integers",
    ),
    OutputFile::always("series.npz", Format::Npz, "the same time series as NumPy arrays, one per column"),
    OutputFile::always("grains.csv", Format::Csv, "the final grains, one row per grain: id, position, velocity, angular velocity, radius, mass, force [config units]"),
    OutputFile::when("snapshots/grains_<step>.vtp", Format::Vtp, "VTK snapshot of the grains at step <step> (10 digits), the final state included", "output.vtk = true"),
    OutputFile::when("snapshots/contacts_<step>.vtp", Format::Vtp, "VTK snapshot of the contact network at step <step>", "output.vtk = true"),
    OutputFile::when("grains.pvd", Format::Pvd, "ParaView collection of the grain snapshots over time", "output.vtk = true"),
    OutputFile::when("contacts.pvd", Format::Pvd, "ParaView collection of the contact snapshots over time", "output.vtk = true"),
    OutputFile::when("plots/energy.png", Format::Png, "kinetic energy per grain and max acceleration against time (log scale)", "output.plots = true"),
    OutputFile::when("plots/energy.svg", Format::Svg, "the same plot as SVG", "output.plots = true"),
    OutputFile::when("plots/wall_loads.png", Format::Png, "normal load of each wall against time", "output.plots = true, with walls"),
    OutputFile::when("plots/wall_loads.svg", Format::Svg, "the same plot as SVG", "output.plots = true, with walls"),
    OutputFile::when("plots/force_network.png", Format::Png, "picture of the final packing with its force network", "output.plots = true, 2D runs"),
    OutputFile::when("plots/force_network.svg", Format::Svg, "the same picture as SVG", "output.plots = true, 2D runs"),
];

/// The `simulation` protocol: one unit of work (the run itself, checkpointed as a whole at fixed
/// step numbers), so its plan is the prepared engine state.
pub struct SimulationProtocol;

impl grainwave_study::study::Protocol for SimulationProtocol {
    const NAME: &'static str = "simulation";
    const TAG: &'static str = TAG;
    const REFERENCE: &'static str = "A general discrete-element run (see docs/simulation.md). The `[contact]` keys are those of the presets\n\
         or the family tables `[contact.normal]`, `[contact.damping]`, `[contact.tangential]`, `[contact.rolling]`,\n\
         `[contact.twisting]` (docs/engine.md); `[wall_contact]` and `walls[].contact` take the same keys and replace the grain–grain values.";
    type Config = SimulationConfig;
    type Spec = Prepared;
    type State = SimulationState;
    type Report = SimulationReport;
    const OUTPUTS: &'static [OutputFile] = OUTPUTS;

    fn validate(src: &ConfigSource) -> Result<Prepared, ConfigError> {
        prepare(src)
    }
    fn describe(spec: &Prepared) -> Vec<String> {
        describe(spec)
    }
    fn plan(_: &Prepared) -> Vec<grainwave_study::work::Unit> {
        // one unit, checkpointed as a whole at fixed step numbers
        vec![grainwave_study::work::Unit { id: "simulation".into(), kind: "simulations".into(), inputs: Vec::new() }]
    }
    fn start(spec: Prepared) -> SimulationState {
        SimulationState::new(spec)
    }
    fn config(state: &SimulationState) -> &SimulationConfig {
        &state.config
    }
    fn run(state: &mut SimulationState, ctx: &mut RunContext<'_>) -> Result<SimulationReport> {
        state.run(ctx)
    }
    fn serve(_: &mut SimulationState, out: &std::path::Path, link: &dyn grainwave_study::work::WorkerLink, interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>) -> Result<()> {
        // one simulation runs in one process (on its threads): nothing to hand out
        grainwave_study::work::serve(&grainwave_study::work::NoUnits, link, out, interrupt)
    }
    fn summary_lines(report: &SimulationReport, out: &std::path::Path) -> Vec<String> {
        summary_lines(report, out)
    }
    fn replot(dir: &std::path::Path, state: &SimulationState) -> Result<Vec<String>> {
        let series = grainwave_io::Series::read_npz(&dir.join("series.npz"))?;
        make_plots(dir, &series, state.picture().as_ref())
    }
}

/// What `grainwave check` prints about a valid config.
pub fn describe(p: &Prepared) -> Vec<String> {
    fn lines<D: Dim>(s: &Simulation<D>, c: &SimulationConfig) -> Vec<String> {
        let (rmin, rmax) = s.grains.radius_range();
        let mut v = vec![
            format!("experiment   simulation, seed {}", c.seed),
            format!("grains       {} {} ({}D), radii {:.4}–{:.4}", s.len(), s.grains.kind.name(), D::D, rmin, rmax),
            format!("contacts     {} at the start; law {:?} / {:?} / {:?}, μ = {}", s.counters.contacts, s.law.normal, s.law.damping, s.law.tangential, s.law.friction),
            format!("walls        {}", if s.domain.walls.is_empty() { "none".into() } else { s.domain.walls.iter().map(|w| w.name.clone()).collect::<Vec<_>>().join(", ") }),
            format!("time step    {:.4e} (suggested {:.4e})", s.dt, s.suggested_dt),
            format!(
                "stop         step limit {:?}, time limit {:?}, equilibrium criteria: {}",
                c.stop.step_limit,
                c.stop.time_limit,
                if c.stop.has_equilibrium_criterion() { "yes" } else { "none" }
            ),
        ];
        for w in &s.warnings {
            v.push(format!("warning      {w}"));
        }
        v
    }
    match &p.sim {
        AnySimulation::D2(s) => lines(s, &p.config),
        AnySimulation::D3(s) => lines(s, &p.config),
    }
}

/// The lines `grainwave run` prints at the end.
pub fn summary_lines(r: &SimulationReport, out: &std::path::Path) -> Vec<String> {
    let mut lines = vec![
        format!("stopped      {:?} after {} steps (simulated time {:.6})", r.stop_reason, r.steps, r.time),
        format!("grains       {} {} ({}D), seed {}", r.grains, r.grain_kind, r.dimension, r.seed),
        format!("final state  KE/grain {:.3e}, max acceleration {:.3e}, {} contacts, {} sliding", r.kinetic_energy_per_grain, r.max_acceleration, r.contacts, r.sliding),
    ];
    if let Some(s) = r.support_over_weight {
        lines.push(format!("walls carry  {:.9} × the weight {:.6}", s, r.weight));
    }
    for w in &r.warnings {
        lines.push(format!("warning      {w}"));
    }
    lines.push(format!("outputs      {}/", out.display()));
    lines
}

/// Parses, validates and runs a `simulation` config into `ctx`'s directory.
pub fn run_config(src: &ConfigSource, ctx: &mut RunContext<'_>) -> Result<SimulationReport> {
    let prepared = prepare(src)?;
    SimulationState::new(prepared).run(ctx)
}
