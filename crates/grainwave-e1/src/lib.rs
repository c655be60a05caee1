//! The `e1` protocol (SPEC §5): pulse transmission through confined, pressurized Hertz–Mindlin
//! packings, from one config file.
//!
//! A run is a set of **groups** — one per size (target height, grain count, lattice rows or chain
//! length) and pressure — each with N **samples** (seeds s₀ … s₀ + N − 1). Every sample is
//!
//! 1. prepared ([`prepare`]): a granular gas compressed by a piston under constant force until the
//!    largest acceleration is below the tolerance (packings), built in exact equilibrium
//!    (monodisperse lattices), or built as a chain; prepared packings are kept as
//!    `samples/<group>/s<seed>/packing.gwck` and reused by later runs whose preparation keys match;
//! 2. analysed ([`sample`]): static characterization, elastic moduli, the pulse signal F_sig(t) by
//!    modal sum or direct propagation with its metrics, spectrum and mode contributions,
//!    displacement fields (first sample), damped MD runs; the result is kept as `result.gwck`.
//!
//! Samples run several at a time ([`ensemble`]); a sample with a result is never redone, an
//! interrupted preparation continues where it stopped, and results do not depend on the number of
//! threads. Once all samples are done, [`aggregate`] makes the ensemble tables and series over
//! heights and pressures and [`outputs`] writes `summary.json`, tables, signals and plots
//! (docs/e1.md explains each).
#![warn(missing_docs)]

mod limits;

pub mod aggregate;
pub mod config;
pub mod ensemble;
pub mod outputs;
pub mod plan;
pub mod prepare;
pub mod sample;

pub use config::E1Config;
pub use outputs::E1Report;
pub use plan::Plan;

use grainwave_study::config::{ConfigError, ConfigSource};
use grainwave_study::{ExperimentError, Result};
use grainwave_study::protocol::RunContext;
use grainwave_study::work::Finished;
use serde::{Deserialize, Serialize};

/// Content tag of this protocol's checkpoints (the state carries its plan).
pub const TAG: &str = "experiment-e1/plan";
/// Content tag of the earlier layout, whose state carried the config only (read by
/// [`E1Protocol`]'s `upgrade`).
pub const EARLIER_TAG: &str = "experiment-e1";

/// The state of an `e1` run (what `checkpoint.gwck` holds): the validated plan, config included;
/// the samples' progress is in their own files. A plan read from a checkpoint is checked
/// ([`Plan::check_carried`]) before it is used.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(try_from = "CarriedE1State")]
pub struct E1State {
    /// The plan of the run (the config with computed defaults filled in, groups, tasks).
    pub plan: Plan,
    /// All samples are done and the outputs written.
    pub finished: bool,
}

/// [`E1State`] as decoded, before its plan is checked.
#[derive(Deserialize)]
struct CarriedE1State {
    plan: Plan,
    finished: bool,
}

impl TryFrom<CarriedE1State> for E1State {
    type Error = String;
    fn try_from(s: CarriedE1State) -> std::result::Result<Self, String> {
        s.plan.check_carried().map_err(|e| format!("the e1 plan it carries is inconsistent: {e}"))?;
        Ok(E1State { plan: s.plan, finished: s.finished })
    }
}

/// The earlier layout of the state ([`EARLIER_TAG`]): the config only.
#[derive(Deserialize)]
struct EarlierE1State {
    #[serde(with = "grainwave_study::config::toml_text")]
    config: E1Config,
    finished: bool,
}

/// Parses and validates an `e1` config.
pub fn prepare(src: &ConfigSource) -> Result<Plan, ConfigError> {
    let config: E1Config = src.parse()?;
    limits::check_config(src, &config)?;
    let plan = plan::plan(src, &config)?;
    limits::check_plan(src, &plan)?;
    Ok(plan)
}

/// What `grainwave check` says about a valid plan.
pub fn describe(p: &Plan) -> Vec<String> {
    let c = &p.config;
    let mut v = vec![format!("experiment   e1 ({}), seeds {} … {}", p.kind.name(), c.seed, c.seed + c.samples as u64 - 1)];
    match p.kind {
        plan::StudyKind::Chain => v.push(format!("chains       N = {:?}", p.groups.iter().map(|g| g.grains).collect::<Vec<_>>())),
        _ => {
            v.push(format!("pressures    {:?}", p.pressures()));
            let mut sizes: Vec<String> = Vec::new();
            for g in &p.groups {
                let s = format!("{} ({} grains)", g.size_label, g.grains);
                if !sizes.contains(&s) {
                    sizes.push(s);
                }
            }
            v.push(format!("sizes        {}", sizes.join(", ")));
            if p.kind == plan::StudyKind::Packing {
                v.push(format!("packing      {}D, width {}, diameter spread {}, μ = {}, ν = {}", p.dimension, p.width, p.spread, p.friction, p.poisson));
            }
        }
    }
    v.push(format!("samples      {} groups × {} samples = {} tasks", p.groups.len(), c.samples, p.tasks.len()));
    if c.pulse.enabled {
        v.push(format!(
            "pulse        {:?}, {:?}, {} times up to {:.4} … {:.4}",
            c.pulse.initial_condition,
            c.pulse.method,
            c.pulse.time_samples,
            p.groups.iter().map(|g| *g.times.last().unwrap_or(&0.0)).fold(f64::INFINITY, f64::min),
            p.groups.iter().map(|g| *g.times.last().unwrap_or(&0.0)).fold(0.0, f64::max)
        ));
    }
    if let Some(d) = &c.damped {
        v.push(format!("damped MD    ζ = {:?} on the first {} sample(s)", d.damping_fractions, d.samples));
    }
    v
}

impl E1State {
    /// A fresh state from a validated plan.
    pub fn new(plan: &Plan) -> Self {
        E1State { plan: plan.clone(), finished: false }
    }

    /// The config of the run, with computed defaults filled in.
    pub fn config(&self) -> &E1Config {
        &self.plan.config
    }

    /// Runs (or continues) every sample, then writes the outputs.
    pub fn run(&mut self, ctx: &mut RunContext<'_>) -> Result<E1Report> {
        let plan = self.plan.clone();
        grainwave_study::outputs::write_resolved_config(ctx.out_dir(), "e1", &plan.config, "")?;
        ctx.save_checkpoint(TAG, self)?;
        let started = std::time::Instant::now();
        match ensemble::run_ensemble(&plan, ctx)? {
            Finished::Interrupted => return Err(ctx.interrupted_error(TAG, self)),
            Finished::Complete => {}
        }
        let results = outputs::collect(ctx.out_dir(), &plan);
        grainwave_study::protocol::refuse_all_failed(
            ctx,
            "samples",
            results.iter().zip(&plan.tasks).map(|(r, t)| r.as_ref().and_then(|r| r.failure.clone()).map(|f| format!("{} seed {}: {f}", plan.groups[t.group].name, t.seed))),
        )?;
        ctx.log("writing the outputs");
        let report = outputs::write_outputs(ctx.out_dir(), &plan, started.elapsed().as_secs_f64())?;
        self.finished = true;
        ctx.save_checkpoint(TAG, self)?;
        ctx.log(&format!("done: {} samples, {} failed", report.done, report.failures.len()));
        Ok(report)
    }
}

use grainwave_study::outputs::{Format, OutputFile};

const PLOTS: &str = "output.plots = true";

/// Every file an `e1` run writes into its output directory (docs/outputs.md); `<group>` is a
/// parameter set's name, `<seed>` a sample's seed (4 digits).
pub const OUTPUTS: &[OutputFile] = &[
    grainwave_study::outputs::RESOLVED_CONFIG,
    grainwave_study::outputs::SUMMARY,
    grainwave_study::outputs::CHECKPOINT,
    grainwave_study::outputs::LOG,
    grainwave_study::outputs::LOCK,
    grainwave_study::outputs::FAILED,
    OutputFile::always("samples.csv", Format::Csv, "one row per finished sample: group, seed, grains, its measurements, failure (empty: none)"),
    OutputFile::always("groups.csv", Format::Csv, "one row per parameter set: the ensemble means and spreads of the measurements"),
    OutputFile::always("heights.csv", Format::Csv, "the packing heights of the samples, per group"),
    OutputFile::when("pressures.csv", Format::Csv, "the measurements against the confining pressure", "with pressures"),
    OutputFile::when("signals/<group>.csv", Format::Csv, "the transmitted signal against time: the mean, each sample (s<seed>), the closed form and damped variants where computed", "per group with signals"),
    OutputFile::when("signals/<group>.npz", Format::Npz, "the same signals as NumPy arrays", "per group with signals"),
    OutputFile::when("spectra/<group>.csv", Format::Csv, "the spectrum of the first sample of the group", "per group with a finished sample"),
    OutputFile::when("spectra/<group>.npz", Format::Npz, "the same spectrum as NumPy arrays", "per group with a finished sample"),
    OutputFile::when("histograms/<group>.csv", Format::Csv, "histograms of the contact angles and forces, pooled over the group's samples", "per group with statistics"),
    OutputFile::when("histograms/<group>.npz", Format::Npz, "the same histograms as NumPy arrays", "per group with statistics"),
    OutputFile::when("vtk/<group>_grains.vtp", Format::Vtp, "the first sample's grains, with displacement fields and rattler flags", "output.vtk = true, packings (not chains)"),
    OutputFile::when("vtk/<group>_contacts.vtp", Format::Vtp, "the first sample's contact network", "output.vtk = true, packings (not chains)"),
    OutputFile::when("plots/<plot>.png", Format::Png, "plots: signals, damped signals, spectra, contributions, angle and force histograms, networks, displacements, arrival times, amplitudes, widths, speeds, moduli", PLOTS),
    OutputFile::when("plots/<plot>.svg", Format::Svg, "the same plots as SVG", PLOTS),
    OutputFile::when("samples/<group>/s<seed>/result.gwck", Format::Checkpoint, "the result of one sample (its unit of work), reused on resume", "per finished sample"),
    OutputFile::when("samples/<group>/s<seed>/packing.gwck", Format::Checkpoint, "the prepared packing of one sample, reused by runs with the same preparation keys", "per prepared packing"),
    OutputFile::when("samples/<group>/s<seed>/preparing.gwck", Format::Checkpoint, "a preparation in progress (removed when it is done)", "while a preparation is unfinished"),
];

/// The `e1` protocol: its spec is the [`Plan`] (groups × seeds = samples, the units of work).
pub struct E1Protocol;

impl grainwave_study::study::Protocol for E1Protocol {
    const NAME: &'static str = "e1";
    const TAG: &'static str = TAG;
    const REFERENCE: &'static str = "Pulse transmission through confined, pressurized Hertz–Mindlin packings (SPEC §5; see docs/e1.md). Units:\n\
         length d̄ (the mean diameter), grain density ρ = 1, pressure E* = E/(1 − ν²) = 1, time d̄ √(ρ/E*).";
    type Config = E1Config;
    type Spec = Plan;
    type State = E1State;
    type Report = E1Report;
    const OUTPUTS: &'static [OutputFile] = OUTPUTS;

    fn validate(src: &ConfigSource) -> Result<Plan, ConfigError> {
        prepare(src)
    }
    fn describe(spec: &Plan) -> Vec<String> {
        describe(spec)
    }
    fn plan(spec: &Plan) -> Vec<grainwave_study::work::Unit> {
        ensemble::units(spec)
    }
    fn start(spec: Plan) -> E1State {
        E1State::new(&spec)
    }
    fn config(state: &E1State) -> &E1Config {
        state.config()
    }
    fn run(state: &mut E1State, ctx: &mut RunContext<'_>) -> Result<E1Report> {
        state.run(ctx)
    }
    fn serve(state: &mut E1State, out: &std::path::Path, link: &dyn grainwave_study::work::WorkerLink, interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>) -> Result<()> {
        ensemble::serve(&state.plan, out, link, interrupt)
    }
    fn summary_lines(report: &E1Report, out: &std::path::Path) -> Vec<String> {
        summary_lines(report, out)
    }
    fn replot(dir: &std::path::Path, state: &E1State) -> Result<Vec<String>> {
        replot(dir, state)
    }

    const EARLIER_TAGS: &'static [&'static str] = &[EARLIER_TAG];
    /// A checkpoint of the earlier layout carried the config only: plan it once, as `run` did
    /// then (through its TOML text, for the planner's error locations), and check the plan's
    /// sizes; the result is checked like a carried plan.
    fn upgrade(tag: &str, file: &std::path::Path) -> Result<E1State> {
        let earlier: EarlierE1State = grainwave_core::checkpoint::load(file, tag)?;
        let text = toml::to_string(&earlier.config).expect("a config serializes to TOML");
        let src = ConfigSource::from_text(&format!("the config in {}", file.display()), text);
        let plan = plan::plan(&src, &earlier.config)?;
        limits::check_plan(&src, &plan)?;
        let carried = CarriedE1State { plan, finished: earlier.finished };
        E1State::try_from(carried).map_err(|reason| ExperimentError::Resume { path: file.to_path_buf(), reason })
    }
}

/// Parses, validates and runs an `e1` config into `ctx`'s directory.
pub fn run_config(src: &ConfigSource, ctx: &mut RunContext<'_>) -> Result<E1Report> {
    let plan = prepare(src)?;
    E1State::new(&plan).run(ctx)
}

/// Re-writes the outputs (tables, plots) of the run in `dir` from its saved samples; also works on
/// an unfinished run (the tables then hold the samples done so far). Returns the files written;
/// an error when no sample has succeeded yet (none finished, or every finished one failed).
pub fn replot(dir: &std::path::Path, state: &E1State) -> Result<Vec<String>> {
    let plan = &state.plan;
    // without one successful sample there is nothing to tabulate or plot: say why, rather than
    // fail in the plot stage on empty data
    let results = outputs::collect(dir, &plan);
    if !results.iter().flatten().any(|r| r.failure.is_none()) {
        let failures: Vec<String> = results
            .iter()
            .zip(&plan.tasks)
            .filter_map(|(r, t)| r.as_ref().and_then(|r| r.failure.clone()).map(|f| format!("{} seed {}: {f}", plan.groups[t.group].name, t.seed)))
            .collect();
        if failures.is_empty() {
            let reason = "no sample has finished yet (`grainwave resume DIR` continues the run)".to_string();
            return Err(ExperimentError::Plot { path: dir.to_path_buf(), reason });
        }
        return Err(grainwave_study::protocol::failed_units("finished samples", failures.len(), failures));
    }
    Ok(outputs::write_outputs(dir, &plan, 0.0)?.files)
}

/// The lines `grainwave run` prints at the end.
pub fn summary_lines(r: &E1Report, out: &std::path::Path) -> Vec<String> {
    let mut lines = vec![format!("e1 ({}): {} of {} samples done, {} failed, {:.1} s of sample work", r.study, r.done, r.tasks, r.failures.len(), r.sample_seconds)];
    for g in &r.aggregate.groups {
        let mut l = format!("{:16} {:3} samples", g.name, g.samples);
        if g.height.count > 0 && r.study != "chain" {
            l.push_str(&format!("  L = {:.2}", g.height.mean));
        }
        if let Some(z) = g.characterization.get("z_star") {
            l.push_str(&format!("  z* = {:.3}", z.mean));
        }
        if let Some(c) = g.moduli.get("c_l") {
            l.push_str(&format!("  c_l = {:.4}", c.mean));
        }
        if let Some(m) = &g.mean_signal {
            l.push_str(&format!("  edge {:.3}, A = {:.4e}", m.leading_edge_time, m.peak_amplitude));
        }
        lines.push(l);
    }
    for h in &r.aggregate.heights {
        if let Some(s) = &h.series {
            let mut l = format!("{}:", h.pressure.map_or("chain".to_string(), |p| format!("p = {p:e}")));
            if let Some(t) = &s.time_of_flight {
                l.push_str(&format!(" c_tof = {:.4} (L {:.1} → {:.1})", t.velocity, t.height_1, t.height_2));
            }
            if let Some(e) = &s.amplitude_exponent {
                l.push_str(&format!(", γ = {:.3}", e.gamma));
            }
            if let Some(e) = &s.width_exponent {
                l.push_str(&format!(", α = {:.3}", e.exponent));
            }
            if s.heights.len() >= 2 {
                lines.push(l);
            }
            if let Some(e) = &h.exponent_intervals {
                for v in e.verdicts.iter().filter(|v| !v.starts_with("effective")) {
                    lines.push(format!("  {v}"));
                }
            }
        }
    }
    for (dir, why) in &r.failures {
        lines.push(format!("failed       {dir}: {why}"));
    }
    lines.push(format!("outputs      {}/", out.display()));
    lines
}
