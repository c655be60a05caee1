//! The `e2` protocol (SPEC §6): acoustics of a 2D packing under biaxial loading, with frictional
//! sliding. See docs/e2.md.
//!
//! Config → [`E2Spec`] (the validated config and its plan) → [`E2State`] → run → [`E2Summary`].
//! The plan ([`work::plan`]) has two kinds of units of work, run by the scheduler
//! ([`grainwave_study::work::Scheduler`]): the `loading` — preparation by two pistons
//! ([`biaxial::prepare`]) and biaxial test with checkpoints every Δε ([`biaxial::load`]) — and one
//! unit per `[[replays]]` entry ([`work::run_replay`]), which reads the loading's checkpoints or
//! the final state of the replay named in `from`: paired replays with a pressure pulse or a
//! central radius change, whose difference gives the perturbed velocity field, the arrival times
//! and the pulse speed ([`replay`], [`arrival`]); or single replays with the velocities scaled, the
//! friction changed or the top wall stopped. The loading's progress is saved in `checkpoint.gwck`,
//! each replay's report in `replays/<name>/report.gwck`, so `grainwave resume` continues an
//! interrupted run bit for bit; the tables are aggregated from the reports in the order of the
//! config ([`outputs`]).
#![warn(missing_docs)]

mod limits;

pub mod arrival;
pub mod biaxial;
pub mod config;
pub mod incremental;
pub mod model;
pub mod outputs;
pub mod replay;
pub mod strain;
pub mod work;

pub use config::E2Config;
pub use outputs::E2Summary;

use grainwave_study::config::{non_negative, positive, ConfigError, ConfigSource};
use grainwave_study::{ExperimentError, Result};
use grainwave_study::protocol::RunContext;
use grainwave_study::study::Protocol;
use grainwave_study::work::{Finished, Scheduler, Unit};
use biaxial::{Loading, PreparationInfo};
use grainwave_core::prelude::*;
use model::Units;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Content tag of this protocol's checkpoints (the state carries its plan).
pub const TAG: &str = "experiment-e2/plan";
/// Content tag of the earlier layout, whose state carried no plan (read by [`E2Protocol`]'s
/// `upgrade`).
pub const EARLIER_TAG: &str = "experiment-e2";

/// Where a run is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Stage {
    /// Relaxing the gas under the pistons.
    Preparing,
    /// The biaxial test.
    Loading,
    /// Replaying checkpoints.
    Replays,
    /// Everything is written.
    Finished,
}

/// The state of an `e2` run (what `checkpoint.gwck` holds): the config and its plan (the units
/// of [`work::plan`]), the stage, the engine state and the finished replays. A state read from a
/// checkpoint is checked (the plan fits the config) before it is used.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(try_from = "CarriedE2State")]
pub struct E2State {
    /// The units of the run, in the order of aggregation ([`work::plan`] of the config).
    pub plan: Vec<Unit>,
    /// The config (stored as its TOML text).
    #[serde(with = "grainwave_study::config::toml_text")]
    pub config: E2Config,
    /// Current stage.
    pub stage: Stage,
    /// Engine state during preparation and loading.
    pub sim: Option<Simulation<D2>>,
    /// How the preparation went.
    pub preparation: PreparationInfo,
    /// Units (known after the preparation, or from the source run).
    pub units: Option<Units>,
    /// The loading.
    pub loading: Option<Loading>,
    /// Reports of the finished replays, in the order of the config (gathered from their unit
    /// results, `replays/<name>/report.gwck`, when the run is interrupted and at its end).
    pub replays: Vec<outputs::ReplayReport>,
}

/// [`E2State`] as decoded, before it is checked: its plan, then the fields of the earlier layout.
/// Checkpoints are bincode, which writes a struct's fields in order with no markers, so the
/// nested struct reads the same bytes as [`E2State`]'s flat fields.
#[derive(Deserialize)]
struct CarriedE2State {
    plan: Vec<Unit>,
    rest: EarlierE2State,
}

impl TryFrom<CarriedE2State> for E2State {
    type Error = String;
    fn try_from(s: CarriedE2State) -> std::result::Result<Self, String> {
        // the scheduler and the replay lookup index by the plan: it must have one unit per
        // replay (and the loading, unless the checkpoints come from `source.dir`), each reading
        // only units before it
        let expected = s.rest.config.replays.len() + usize::from(s.rest.config.source.dir.is_none());
        if s.plan.len() != expected || s.plan.iter().enumerate().any(|(k, u)| u.inputs.iter().any(|&i| i >= k)) {
            return Err(format!("the e2 plan it carries ({} units) does not fit its config ({expected} units, each reading earlier ones only)", s.plan.len()));
        }
        Ok(E2State::from_parts(s.plan, s.rest))
    }
}

/// The earlier layout of the state ([`EARLIER_TAG`]): no plan.
#[derive(Deserialize)]
struct EarlierE2State {
    /// The config (stored as its TOML text).
    #[serde(with = "grainwave_study::config::toml_text")]
    config: E2Config,
    /// Current stage.
    stage: Stage,
    /// Engine state during preparation and loading.
    sim: Option<Simulation<D2>>,
    /// How the preparation went.
    preparation: PreparationInfo,
    /// Units (known after the preparation, or from the source run).
    units: Option<Units>,
    /// The loading.
    loading: Option<Loading>,
    /// Reports of the finished replays, in the order of the config (gathered from their unit
    /// results, `replays/<name>/report.gwck`, when the run is interrupted and at its end).
    replays: Vec<outputs::ReplayReport>,
}


/// A validated `e2` config and its plan.
#[derive(Clone, Debug)]
pub struct E2Spec {
    /// The config, every key checked ([`prepare`]).
    pub config: E2Config,
    /// The units of work ([`work::plan`]): the loading (unless `source.dir` is given) and one
    /// unit per replay, each with the unit it starts from as its input.
    pub units: Vec<Unit>,
}

impl E2Spec {
    /// Validates a config file into a spec.
    pub fn validate(src: &ConfigSource) -> Result<E2Spec, ConfigError> {
        let config = prepare(src)?;
        Ok(E2Spec { units: work::plan(&config), config })
    }
}

use grainwave_study::outputs::{Format, OutputFile};

const PLOTS: &str = "output.plots = true";

/// Every file an `e2` run writes into its output directory (docs/outputs.md). Times of the
/// replays' files are in t_a, positions and distances in L*, speeds in v_a (`summary.json`'s
/// `unit_system`).
pub const OUTPUTS: &[OutputFile] = &[
    grainwave_study::outputs::RESOLVED_CONFIG,
    grainwave_study::outputs::SUMMARY,
    grainwave_study::outputs::CHECKPOINT,
    grainwave_study::outputs::LOG,
    grainwave_study::outputs::LOCK,
    grainwave_study::outputs::FAILED,
    // the loading
    OutputFile::when(
        "loading.csv",
        Format::Csv,
        "the loading series: time [t*], strain_yy, strain_xx (compression positive), stress_yy, stress_xx [p*], sliding, contacts, kinetic_energy [p* L*²], step; sliding, contacts and step as integers",
        "unless source.dir is set",
    ),
    OutputFile::when("loading.npz", Format::Npz, "the same loading series as NumPy arrays", "unless source.dir is set"),
    OutputFile::when(
        "checkpoints/index.csv",
        Format::Csv,
        "the strain checkpoints: index, step, time [t*], strain_yy, strain_xx, stress_yy, stress_xx [p*], sliding, file, kind (full or reference)",
        "unless source.dir is set",
    ),
    OutputFile::when("checkpoints/ck-<index>.gwck", Format::Checkpoint, "strain checkpoint <index> (6 digits) of the loading, replayed by `[[replays]]`", "unless source.dir is set"),
    OutputFile::when("stress_strain.png", Format::Png, "σ_yy and σ_xx against ε_yy", PLOTS),
    OutputFile::when("stress_strain.svg", Format::Svg, "the same plot as SVG", PLOTS),
    OutputFile::when("sliding_strain.png", Format::Png, "sliding contacts M_s against ε_yy", PLOTS),
    OutputFile::when("sliding_strain.svg", Format::Svg, "the same plot as SVG", PLOTS),
    OutputFile::when("kinetic_energy_strain.png", Format::Png, "kinetic energy against ε_yy (log scale)", PLOTS),
    OutputFile::when("kinetic_energy_strain.svg", Format::Svg, "the same plot as SVG", PLOTS),
    // every replay
    OutputFile::when("replays/<name>/report.gwck", Format::Checkpoint, "the finished replay's report (its unit of work's result)", "per replay"),
    // paired replays, per amplitude <k> (index into `amplitudes`)
    OutputFile::when("replays/<name>/a<k>_field.npy", Format::Npy, "δv field, shape (samples, grains, 2) [engine velocity]", "per amplitude of a paired replay, output.fields = true"),
    OutputFile::when("replays/<name>/a<k>_times.npy", Format::Npy, "sample times of the field [t_a]", "per amplitude of a paired replay"),
    OutputFile::when(
        "replays/<name>/a<k>_arrivals.csv",
        Format::Csv,
        "per grain: id, x, y [L*], distance from the source [L*], arrival [t_a] (empty: no arrival)",
        "per amplitude of a paired replay",
    ),
    OutputFile::when(
        "replays/<name>/a<k>_sliding.csv",
        Format::Csv,
        "per sample: time [t_a], sliding (M_s with the perturbation), sliding_reference (without)",
        "per amplitude of a paired replay",
    ),
    OutputFile::when("replays/<name>/a<k>_strips.csv", Format::Csv, "the strip fit's points: distance [L*], arrival [t_a]", "per amplitude with a strip fit"),
    OutputFile::when(
        "replays/<name>/a<k>_branches.csv",
        Format::Csv,
        "per contact at the Coulomb limit: i, j (j < 0: wall −1 − j), slip_steps, switches, first_slip, last_switch [t_a] (empty: never), slipping_at_end (0/1)",
        "per amplitude of an incremental replay",
    ),
    OutputFile::when("replays/<name>/incremental.json", Format::Json, "per amplitude: branch rule, contact counts, slips, steps, dt, impulse, seconds", "per incremental replay"),
    OutputFile::when("replays/<name>/a<k>_arrival_map.png", Format::Png, "map of the arrival times over the packing", "per amplitude of a paired replay, output.plots = true"),
    OutputFile::when("replays/<name>/a<k>_arrival_map.svg", Format::Svg, "the same map as SVG", "per amplitude of a paired replay, output.plots = true"),
    OutputFile::when("replays/<name>/a<k>_arrival_fit.png", Format::Png, "arrival against distance, with the strip fit", "per amplitude with arrivals, output.plots = true"),
    OutputFile::when("replays/<name>/a<k>_arrival_fit.svg", Format::Svg, "the same plot as SVG", "per amplitude with arrivals, output.plots = true"),
    OutputFile::when("replays/<name>/sliding_difference.png", Format::Png, "M_s(with) − M_s(without) against t/t_a, per amplitude", "per paired replay, output.plots = true"),
    OutputFile::when("replays/<name>/sliding_difference.svg", Format::Svg, "the same plot as SVG", "per paired replay, output.plots = true"),
    OutputFile::when("replays/<name>/speed_vs_amplitude.png", Format::Png, "pulse speed [v_a] against the amplitude", "per paired replay with two or more speeds, output.plots = true"),
    OutputFile::when("replays/<name>/speed_vs_amplitude.svg", Format::Svg, "the same plot as SVG", "per paired replay with two or more speeds, output.plots = true"),
    // single replays
    OutputFile::when(
        "replays/<name>/series.csv",
        Format::Csv,
        "the replay's series: time [t_a], stress_yy, stress_xx [p*], sliding (an integer), kinetic_energy [p* L*²]",
        "per single replay",
    ),
    OutputFile::when("replays/<name>/series.npz", Format::Npz, "the same series as NumPy arrays", "per single replay"),
    OutputFile::when("replays/<name>/final.gwck", Format::Checkpoint, "the state at the end of the replay (start of replays `from` it)", "per single replay"),
    OutputFile::when("replays/<name>/partial.gwck", Format::Checkpoint, "the progress of an unfinished single replay (removed when it finishes)", "while a single replay is unfinished"),
    OutputFile::when("replays/<name>/kinetic_energy.png", Format::Png, "kinetic energy against t/t_a (log scale)", "per single replay, output.plots = true"),
    OutputFile::when("replays/<name>/kinetic_energy.svg", Format::Svg, "the same plot as SVG", "per single replay, output.plots = true"),
    OutputFile::when("replays/<name>/sliding.png", Format::Png, "M_s against t/t_a", "per single replay, output.plots = true"),
    OutputFile::when("replays/<name>/sliding.svg", Format::Svg, "the same plot as SVG", "per single replay, output.plots = true"),
    // the tables over replays
    OutputFile::when(
        "pulses.csv",
        Format::Csv,
        "every amplitude of every paired replay: replay, checkpoint, strain_yy, amplitude, speed [v_a] (empty: none), mobilised and flagged M_s (start, end with, end without), max_sliding_difference, pushed_on",
        "with paired replays",
    ),
    OutputFile::when("pulses_released.png", Format::Png, "fraction of the mobilised contacts a pulse released, against |p_a|", "with four or more wall-pulse amplitudes of a sign, output.plots = true"),
    OutputFile::when("pulses_released.svg", Format::Svg, "the same plot as SVG", "with four or more wall-pulse amplitudes of a sign, output.plots = true"),
    OutputFile::when(
        "static_limit.csv",
        Format::Csv,
        "the Δc/c₀ decomposition per amplitude: speeds c₀, c_ns, c_s, c_d [v_a] and the losses [fractions of c₀] (empty: missing), by the replays' arrival and by the maximum",
        "with [static_limit]",
    ),
    OutputFile::when("static_limit_speeds.png", Format::Png, "pulse speed against |p_a| for the four states and the variants", "with [static_limit], output.plots = true"),
    OutputFile::when("static_limit_speeds.svg", Format::Svg, "the same plot as SVG", "with [static_limit], output.plots = true"),
    OutputFile::when(
        "anisotropy.csv",
        Format::Csv,
        "per state and amplitude: state, amplitude, along_y, along_x [v_a], anisotropy 2(c₁ − c₂)/(c₁ + c₂) (empty: missing)",
        "with [anisotropy]",
    ),
];

/// The `e2` protocol.
pub struct E2Protocol;

impl Protocol for E2Protocol {
    const NAME: &'static str = "e2";
    const TAG: &'static str = TAG;
    const REFERENCE: &'static str = "Acoustics of a 2D packing under biaxial loading, with frictional sliding (SPEC §6; see docs/e2.md). Units:\n\
         pressure p* (force/length), total grain mass M*, L* = √(M*/ρ*), t* = √(M*/p*), v_a = d̄√(K_n/m̄), t_a = L*/v_a;\n\
         grain sizes in mean diameters d̄.";
    type Config = E2Config;
    type Spec = E2Spec;
    type State = E2State;
    type Report = E2Summary;
    const OUTPUTS: &'static [OutputFile] = OUTPUTS;

    fn validate(src: &ConfigSource) -> Result<E2Spec, ConfigError> {
        E2Spec::validate(src)
    }
    fn describe(spec: &E2Spec) -> Vec<String> {
        describe(&spec.config)
    }
    fn check_inputs(src: &ConfigSource, spec: &E2Spec) -> Result<(), ConfigError> {
        check_source(src, &spec.config)
    }
    fn plan(spec: &E2Spec) -> Vec<Unit> {
        spec.units.clone()
    }
    fn start(spec: E2Spec) -> E2State {
        E2State::new(spec.config)
    }
    fn config(state: &E2State) -> &E2Config {
        &state.config
    }
    fn run(state: &mut E2State, ctx: &mut RunContext<'_>) -> Result<E2Summary> {
        state.run(ctx)
    }
    fn serve(state: &mut E2State, out: &Path, link: &dyn grainwave_study::work::WorkerLink, interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>) -> Result<()> {
        // the replays (the loading runs on rank 0: it writes the protocol checkpoint)
        let cfg = state.config.clone();
        let work = work::E2Work::new(&cfg, out, state);
        grainwave_study::work::serve(&work, link, out, interrupt)
    }
    fn summary_lines(report: &E2Summary, out: &Path) -> Vec<String> {
        summary_lines(report, out)
    }

    const EARLIER_TAGS: &'static [&'static str] = &[EARLIER_TAG];
    /// A checkpoint of the earlier layout carried no plan: plan its config once ([`work::plan`],
    /// as `run` did then).
    fn upgrade(tag: &str, file: &Path) -> Result<E2State> {
        let e: EarlierE2State = grainwave_core::checkpoint::load(file, tag)?;
        Ok(E2State::from_parts(work::plan(&e.config), e))
    }
    fn replot(dir: &Path, state: &E2State) -> Result<Vec<String>> {
        replot(dir, state)
    }
}

/// Parses and validates an `e2` config.
pub fn prepare(src: &ConfigSource) -> Result<E2Config, ConfigError> {
    let cfg: E2Config = src.parse()?;
    limits::check_sizes(src, &cfg)?;
    if cfg.experiment != "e2" {
        return Err(src.error_at_key("experiment", format!("this protocol is `e2`, not `{}`", cfg.experiment)));
    }
    let p = &cfg.packing;
    if p.columns < 2 || p.rows < 2 {
        return Err(src.error_at_key("packing.columns", format!("{} × {} (allowed: at least 2 columns and 2 rows)", p.columns, p.rows)));
    }
    if !(0.0..1.0).contains(&p.polydispersity) {
        return Err(src.error_at_key("packing.polydispersity", format!("{} (allowed: a in [0, 1))", p.polydispersity)));
    }
    // below 1e-3 the gas box is a thousand times the packing's area (and at 5e-324 infinite)
    if !(p.gas_fraction >= 1e-3 && p.gas_fraction <= 0.5) {
        return Err(src.error_at_key("packing.gas_fraction", format!("{} (allowed: a solid fraction in [0.001, 0.5])", p.gas_fraction)));
    }
    let m = &cfg.material;
    positive(src, "material.normal_stiffness", m.normal_stiffness)?;
    if grainwave_core::contact::critical_fraction_for_restitution(m.restitution).is_none() {
        return Err(src.error_at_key("material.restitution", format!("{} (allowed: a restitution in [e⁻² ≈ 0.1353, 1])", m.restitution)));
    }
    positive(src, "material.tangential_stiffness_ratio", m.tangential_stiffness_ratio)?;
    non_negative(src, "material.tangential_damping_ratio", m.tangential_damping_ratio)?;
    non_negative(src, "material.friction", m.friction)?;
    non_negative(src, "material.rolling_stiffness", m.rolling_stiffness)?;
    non_negative(src, "material.rolling_friction", m.rolling_friction)?;
    if !(m.slip_activation_time >= 0.0 && m.slip_activation_time <= 1e12) {
        return Err(src.error_at_key(
            "material.slip_activation_time",
            format!("{} (allowed: a time τ in [0, 1e12] t_a; 0 is the Coulomb cap)", m.slip_activation_time),
        ));
    }
    positive(src, "material.absorbing_damping", m.absorbing_damping)?;
    let pc = &cfg.preparation;
    positive(src, "preparation.wall_mass", pc.wall_mass)?;
    non_negative(src, "preparation.gravity", pc.gravity)?;
    if cfg.source.dir.is_none() {
        engine_values(src, &cfg)?;
    }
    positive(src, "preparation.max_force", pc.max_force)?;
    // the forces of the prepared packing are of order p* d̄ and are sums of contact forces of that
    // order: their round-off alone is about 1e-15 p* d̄, so a tolerance below MIN_MAX_FORCE is never
    // met and the preparation ran to `max_time` before failing (5e-324)
    if pc.max_force < MIN_MAX_FORCE {
        return Err(src.error_at_key(
            "preparation.max_force",
            format!(
                "{:e} (allowed: a tolerance of at least {MIN_MAX_FORCE:e} p* d̄; the residual forces of a packing at rest are sums of contact forces of order p* d̄, and their round-off alone is about 1e-15 p* d̄)",
                pc.max_force
            ),
        ));
    }
    positive(src, "preparation.max_time", pc.max_time)?;
    if pc.check_every == 0 {
        return Err(src.error_at_key("preparation.check_every", "0 (allowed: at least 1 step)"));
    }
    if !(pc.dt_fraction > 0.0 && pc.dt_fraction <= 0.2) {
        return Err(src.error_at_key("preparation.dt_fraction", format!("{} (allowed: a fraction in (0, 0.2] of the contact period)", pc.dt_fraction)));
    }
    let l = &cfg.loading;
    positive(src, "loading.strain_rate", l.strain_rate)?;
    positive(src, "loading.final_strain", l.final_strain)?;
    if l.final_strain >= 0.5 {
        return Err(src.error_at_key("loading.final_strain", format!("{} (allowed: a strain in (0, 0.5))", l.final_strain)));
    }
    non_negative(src, "loading.checkpoint_strain", l.checkpoint_strain)?;
    if l.checkpoint_strain > 0.0 {
        // one checkpoint per `checkpoint_strain` of the loading (5e-324: 4e319 of them, and the
        // loading's bookkeeping of full and reference checkpoints failed after it ran)
        let count = l.final_strain / l.checkpoint_strain;
        if !count.is_finite() {
            return Err(src.error_at_key(
                "loading.checkpoint_strain",
                format!("{}: final_strain / checkpoint_strain = {count} checkpoints (allowed: a strain that gives a finite number of checkpoints, at most 1e7)", l.checkpoint_strain),
            ));
        }
        grainwave_study::limits::check(
            src,
            "loading.checkpoint_strain",
            "strain checkpoints (final_strain / checkpoint_strain)",
            count,
            grainwave_study::limits::MAX_POINTS,
            f64::INFINITY,
            0.0,
        )?;
    }
    positive(src, "loading.reference_strain", l.reference_strain)?;
    if l.full_checkpoint_every == 0 {
        return Err(src.error_at_key("loading.full_checkpoint_every", "0 (allowed: at least 1; 1 keeps every checkpoint's state)"));
    }
    if l.sample_every == 0 {
        return Err(src.error_at_key("loading.sample_every", "0 (allowed: at least 1 step)"));
    }
    if cfg.source.dir.as_deref().is_some_and(str::is_empty) {
        return Err(src.error_at_key("source.dir", "\"\" (allowed: the output directory of an earlier e2 run)"));
    }
    if !cfg.replays.is_empty() && cfg.source.dir.is_none() && l.checkpoint_strain == 0.0 {
        return Err(src.error_at_key("loading.checkpoint_strain", "0 writes no checkpoint, but `[[replays]]` need them (allowed: a strain > 0)"));
    }
    // names of the replays so far → their index: one lookup per `from`, so that checking n chained
    // replays takes n log n, not n² (30 000 chained replays took 80 s)
    let mut names: std::collections::BTreeMap<String, usize> = std::collections::BTreeMap::new();
    // whether the top wall of each replay's end state is a piston: only a `top_piston` replay
    // makes it one, and the replays `from` it keep it (the loading's top wall moves at a speed)
    let mut top_piston: Vec<bool> = Vec::with_capacity(cfg.replays.len());
    for (k, r) in cfg.replays.iter().enumerate() {
        let key = |s: &str| format!("replays[{k}].{s}");
        let name = r.name.clone().unwrap_or(format!("r{k}"));
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
            return Err(src.error_at_key(&key("name"), format!("`{}` (allowed: letters, digits, `-`, `_`)", grainwave_study::config::clip(&name, grainwave_study::config::MAX_ECHO_CHARS))));
        }
        // the name is a directory, replays/<name>/, whose files have names of their own
        if name.len() > MAX_REPLAY_NAME {
            return Err(src.error_at_key(
                &key("name"),
                format!(
                    "`{}`, {} characters (allowed: at most {MAX_REPLAY_NAME} letters, digits, `-`, `_`: the name becomes the directory replays/<name>/)",
                    grainwave_study::config::clip(&name, 60),
                    name.len()
                ),
            ));
        }
        let from_top_piston = match &r.from {
            Some(from) => names.get(from).map_or(true, |&j| top_piston[j]),
            None => false,
        };
        top_piston.push(r.modification == config::Modification::TopPiston || from_top_piston);
        if r.modification == config::Modification::WallPulse && r.pulse_wall == config::PulseWall::Top && !from_top_piston {
            return Err(src.error_at_key(
                &key("pulse_wall"),
                format!(
                    "\"top\", but the top wall of the replay's start state ({}) is not a piston (allowed: with `from` a `top_piston` replay, or a replay started from one)",
                    match &r.from {
                        Some(f) => format!("the end of replay `{f}`"),
                        None => "a checkpoint of the loading".to_string(),
                    }
                ),
            ));
        }
        if names.contains_key(&name) {
            return Err(src.error_at_key(&key("name"), format!("`{name}` is used twice (each replay writes replays/<name>/)")));
        }
        if let Some(from) = &r.from {
            match names.get(from).map(|&j| (j, &cfg.replays[j])) {
                // with `source.dir`, a single replay of that run (its final.gwck is read at run time)
                None if cfg.source.dir.is_some() => {}
                None => {
                    return Err(src.error_at_key(
                        &key("from"),
                        format!("`{from}` (allowed: the name of an earlier replay of this file, or with `source.dir` a single replay of that run)"),
                    ))
                }
                Some((_, q)) if q.modification.paired() => {
                    return Err(src.error_at_key(
                        &key("from"),
                        format!("`{from}` is a paired replay (allowed: an earlier single replay: velocity_scale, friction or wall_stop)"),
                    ))
                }
                _ => {}
            }
        }
        names.insert(name, k);
        if r.checkpoint < -1 {
            return Err(src.error_at_key(&key("checkpoint"), format!("{} (allowed: a checkpoint index ≥ 0, or −1 for the last)", r.checkpoint)));
        }
        // the loading ends at `final_strain`: an index beyond it is never written, and its replay
        // failed after the loading ("no checkpoint k")
        if r.from.is_none() && cfg.source.dir.is_none() && r.checkpoint >= 0 && l.checkpoint_strain > 0.0 {
            let last = (l.final_strain / l.checkpoint_strain).floor();
            if r.checkpoint as f64 > last {
                return Err(src.error_at_key(
                    &key("checkpoint"),
                    format!(
                        "{}: the strain {:e} of that checkpoint is beyond the loading's final_strain = {:e} (allowed: an index of at most final_strain / checkpoint_strain = {last}, or −1 for the last)",
                        r.checkpoint,
                        r.checkpoint as f64 * l.checkpoint_strain,
                        l.final_strain
                    ),
                ));
            }
        }
        positive(src, &key("duration"), r.duration)?;
        positive(src, &key("sample_interval"), r.sample_interval)?;
        if r.strips < 2 {
            return Err(src.error_at_key(&key("strips"), format!("{} (allowed: at least 2)", r.strips)));
        }
        // sizes a replay allocates from: one bin per strip, one row of the records per sample
        use grainwave_study::limits::{check, MAX_POINTS};
        check(src, &key("strips"), "strips", r.strips as f64, MAX_POINTS, f64::INFINITY, 48.0)?;
        check(src, &key("sample_interval"), "samples (duration / sample_interval)", r.duration / r.sample_interval, MAX_POINTS, f64::INFINITY, 64.0)?;
        if !(0.0 <= r.fit_range[0] && r.fit_range[0] < r.fit_range[1] && r.fit_range[1] <= 1.0) {
            return Err(src.error_at_key(&key("fit_range"), format!("{:?} (allowed: fractions 0 ≤ from < to ≤ 1)", r.fit_range)));
        }
        positive(src, &key("bands"), r.bands)?;
        if !(r.lobe_threshold > 0.0 && r.lobe_threshold <= 1.0) {
            return Err(src.error_at_key(&key("lobe_threshold"), format!("{} (allowed: a fraction 0 < f ≤ 1)", r.lobe_threshold)));
        }
        if r.modification != config::Modification::VelocityScale && (r.rate.is_some() || r.extra_strain.is_some()) {
            let k2 = if r.rate.is_some() { "rate" } else { "extra_strain" };
            return Err(src.error_at_key(&key(k2), format!("given for a `{}` replay (allowed: only with modification = \"velocity_scale\")", r.modification.name())));
        }
        match r.modification {
            config::Modification::WallPulse | config::Modification::Radius => {
                if r.amplitudes.is_empty() {
                    return Err(src.error_at_key(&key("amplitudes"), "empty (allowed: one or more finite amplitudes, e.g. [1e-6, -1e-6])"));
                }
                for a in &r.amplitudes {
                    if !a.is_finite() || a.abs() >= 1.0 {
                        return Err(src.error_at_key(&key("amplitudes"), format!("{a} (allowed: finite amplitudes with |a| < 1)")));
                    }
                }
                positive(src, &key("width"), r.width)?;
                if let Some(d) = r.delay {
                    non_negative(src, &key("delay"), d)?;
                }
            }
            config::Modification::VelocityScale => {
                non_negative(src, &key("factor"), r.factor)?;
                if let Some(v) = r.rate {
                    positive(src, &key("rate"), v)?;
                }
                if let Some(v) = r.extra_strain {
                    positive(src, &key("extra_strain"), v)?;
                }
            }
            config::Modification::Friction => non_negative(src, &key("friction"), r.friction)?,
            config::Modification::WallStop => positive(src, &key("stop_time"), r.stop_time)?,
            config::Modification::TopPiston => {}
            config::Modification::Incremental => {
                if r.amplitudes.is_empty() {
                    return Err(src.error_at_key(&key("amplitudes"), "empty (allowed: one or more finite, non-zero amplitudes, e.g. [1, -1])"));
                }
                for a in &r.amplitudes {
                    if !a.is_finite() || *a == 0.0 {
                        return Err(src.error_at_key(&key("amplitudes"), format!("{a} (allowed: finite, non-zero amplitudes: the response is homogeneous in p_a)")));
                    }
                }
                if r.shape != config::PulseShape::Delta {
                    return Err(src.error_at_key(&key("shape"), "\"wavelet\" (allowed: \"delta\" for an incremental replay)"));
                }
                if !(r.steps_per_period.is_finite() && r.steps_per_period > std::f64::consts::PI) {
                    return Err(src.error_at_key(&key("steps_per_period"), format!("{} (allowed: a number > π)", r.steps_per_period)));
                }
                if let Some(d) = r.delay {
                    non_negative(src, &key("delay"), d)?;
                }
            }
        }
    }
    let sl = &cfg.static_limit;
    let roles = [
        ("static_limit.undeformed", &sl.undeformed),
        ("static_limit.non_sliding", &sl.non_sliding),
        ("static_limit.static_state", &sl.static_state),
        ("static_limit.deforming", &sl.deforming),
    ];
    let given = roles.iter().filter(|(_, v)| v.is_some()).count();
    if given != 0 && given != 4 {
        return Err(src.error_at_key(
            "static_limit",
            format!("{given} of the 4 replays named (allowed: all of undeformed, non_sliding, static_state, deforming, or none)"),
        ));
    }
    let mut amplitudes: Option<&Vec<f64>> = None;
    for (key, name) in roles {
        if let Some(name) = name {
            let Some((_, q)) = cfg.replays.iter().enumerate().find(|(j, q)| q.name.clone().unwrap_or(format!("r{j}")) == *name) else {
                return Err(src.error_at_key(key, format!("`{name}` (allowed: the name of a wall_pulse replay of this file)")));
            };
            if q.modification != config::Modification::WallPulse {
                return Err(src.error_at_key(key, format!("`{name}` is a `{}` replay (allowed: a wall_pulse replay)", q.modification.name())));
            }
            if amplitudes.is_some_and(|a| *a != q.amplitudes) {
                return Err(src.error_at_key(
                    key,
                    format!("`{name}` has amplitudes {:?}, the others {:?} (allowed: the same amplitudes in all four)", q.amplitudes, amplitudes.unwrap()),
                ));
            }
            amplitudes = Some(&q.amplitudes);
        }
    }
    for (k, name) in sl.variants.iter().enumerate() {
        let key = format!("static_limit.variants[{k}]");
        let Some((_, q)) = cfg.replays.iter().enumerate().find(|(j, q)| q.name.clone().unwrap_or(format!("r{j}")) == *name) else {
            return Err(src.error_at_key(&key, format!("`{name}` (allowed: the name of a wall_pulse replay of this file)")));
        };
        if q.modification != config::Modification::WallPulse {
            return Err(src.error_at_key(&key, format!("`{name}` is a `{}` replay (allowed: a wall_pulse replay)", q.modification.name())));
        }
    }
    let an = &cfg.anisotropy;
    if an.along_y.is_some() != an.along_x.is_some() {
        return Err(src.error_at_key("anisotropy", "one of the two replays named (allowed: both of along_y, along_x, or none)"));
    }
    let mut pairs: Vec<[(String, Option<String>, config::PulseWall); 2]> = vec![[
        ("anisotropy.along_y".into(), an.along_y.clone(), config::PulseWall::Top),
        ("anisotropy.along_x".into(), an.along_x.clone(), config::PulseWall::Right),
    ]];
    let mut labels = std::collections::BTreeSet::new();
    if an.along_y.is_some() {
        labels.insert(an.state.clone());
    }
    for (k, p) in an.states.iter().enumerate() {
        if p.state.is_empty() || !labels.insert(p.state.clone()) {
            return Err(src.error_at_key(&format!("anisotropy.states[{k}].state"), format!("\"{}\" (allowed: a label not empty and not used by another state)", p.state)));
        }
        pairs.push([
            (format!("anisotropy.states[{k}].along_y"), Some(p.along_y.clone()), config::PulseWall::Top),
            (format!("anisotropy.states[{k}].along_x"), Some(p.along_x.clone()), config::PulseWall::Right),
        ]);
    }
    for pair in &pairs {
    let mut amplitudes: Option<&Vec<f64>> = None;
    for (key, name, wall) in pair.iter().map(|(k, n, w)| (k.as_str(), n, *w)) {
        if let Some(name) = name {
            let Some((_, q)) = cfg.replays.iter().enumerate().find(|(j, q)| q.name.clone().unwrap_or(format!("r{j}")) == *name) else {
                return Err(src.error_at_key(key, format!("`{name}` (allowed: the name of a wall_pulse replay of this file)")));
            };
            if q.modification != config::Modification::WallPulse || q.pulse_wall != wall {
                return Err(src.error_at_key(key, format!("`{name}` is not a wall_pulse replay from the {:?} wall (allowed: such a replay)", wall)));
            }
            if amplitudes.is_some_and(|a| *a != q.amplitudes) {
                return Err(src.error_at_key(
                    key,
                    format!("`{name}` has amplitudes {:?}, the other {:?} (allowed: the same amplitudes)", q.amplitudes, amplitudes.unwrap()),
                ));
            }
            amplitudes = Some(&q.amplitudes);
        }
    }
    }
    positive(src, "output.save_every", cfg.output.save_every)?;
    Ok(cfg)
}

/// The run a config with `source.dir` replays: a directory with strain checkpoints, holding
/// the checkpoint of each replay that starts from one and the `final.gwck` of each replay of that
/// run that one `from` names. Checked by `grainwave check` and before the run (a missing
/// directory made every replay fail at its start); not by [`prepare`], so that a config stays
/// valid before its source run is made.
pub fn check_source(src: &ConfigSource, cfg: &E2Config) -> Result<(), ConfigError> {
    let Some(dir) = &cfg.source.dir else { return Ok(()) };
    let path = Path::new(dir);
    let shown = grainwave_study::config::clip(dir, 100);
    if !path.is_dir() {
        return Err(src.error_at_key(
            "source.dir",
            format!("`{shown}` is not a directory (allowed: the output directory of an earlier e2 run, relative to the directory grainwave runs in)"),
        ));
    }
    let present = biaxial::checkpoint_indices(path);
    if present.is_empty() {
        return Err(src.error_at_key(
            "source.dir",
            format!("`{shown}` holds no strain checkpoint (`checkpoints/ck-<index>.gwck`) (allowed: the output directory of an e2 run whose loading wrote checkpoints)"),
        ));
    }
    let names: std::collections::BTreeSet<String> = cfg.replays.iter().enumerate().map(|(k, r)| r.name.clone().unwrap_or(format!("r{k}"))).collect();
    for (k, r) in cfg.replays.iter().enumerate() {
        match &r.from {
            None if r.checkpoint >= 0 && !present.contains(&(r.checkpoint as u64)) => {
                return Err(src.error_at_key(
                    &format!("replays[{k}].checkpoint"),
                    format!(
                        "{} is not a checkpoint of `{shown}` (allowed: one of its {} checkpoints {}…{}, or −1 for the last)",
                        r.checkpoint,
                        present.len(),
                        present[0],
                        present[present.len() - 1]
                    ),
                ));
            }
            Some(from) if !names.contains(from) && !path.join("replays").join(from).join("final.gwck").is_file() => {
                return Err(src.error_at_key(
                    &format!("replays[{k}].from"),
                    format!("`{from}` is neither a replay of this file nor a finished replay of `{shown}` (no replays/{from}/final.gwck there)"),
                ));
            }
            _ => {}
        }
    }
    Ok(())
}

/// Longest replay name [characters]: the name is the directory `replays/<name>/` (file systems
/// take 255 bytes; a 300-character name failed after the loading had run).
const MAX_REPLAY_NAME: usize = 200;

/// The smallest `preparation.max_force` [p* d̄]: a thousand times the round-off of the residual
/// forces of a packing at rest (sums of contact forces of order p* d̄). A smaller tolerance is
/// never met, and the preparation runs to `preparation.max_time` before failing.
const MIN_MAX_FORCE: f64 = 1e-12;

/// The values the run gives the engine, derived from the config's: the contact laws (grain–grain
/// with the friction, grain–wall, absorbing walls), the pistons' mass and the gravity of the
/// preparation (`model::build_gas`). A value that makes one of them unrepresentable (a normal
/// stiffness of 5e-324 makes the rolling stiffness 0, a wall mass of 1e308 an infinite piston
/// mass) is refused at the key the file has, not at the engine's name of the derived value when
/// the run starts.
fn engine_values(src: &ConfigSource, cfg: &E2Config) -> Result<(), ConfigError> {
    let m = &cfg.material;
    // the engine's range of a modulus, from which every other stiffness and the time step follow
    if !(m.normal_stiffness.is_finite() && (1e-100..=1e100).contains(&m.normal_stiffness)) {
        return Err(src.error_at_key(
            "material.normal_stiffness",
            format!("{} (allowed: a finite number in [1e-100, 1e100] p* (stiffnesses derived from it must stay representable))", m.normal_stiffness),
        ));
    }
    let p = &cfg.packing;
    let n = (p.columns * p.rows) as f64;
    // grain masses π R² with R in [(1 − a)/2, (1 + a)/2]: the total and mean mass lie between
    let (light, heavy) = (std::f64::consts::FRAC_PI_4 * (1.0 - p.polydispersity).powi(2), std::f64::consts::FRAC_PI_4 * (1.0 + p.polydispersity).powi(2));
    let laws = [
        model::grain_law(m, m.friction, 1.0),
        model::wall_law(m),
        model::absorbing_wall_law(m, p.columns * p.rows, light),
        model::absorbing_wall_law(m, p.columns * p.rows, heavy),
    ];
    for law in laws {
        if let Err(grainwave_core::CoreError::InvalidParameter { field, value, allowed }) = law.validate("material") {
            let (key, derived) = match field.trim_start_matches("material.") {
                "normal_stiffness" => ("material.normal_stiffness", "the normal stiffness"),
                "tangential_stiffness" => ("material.tangential_stiffness_ratio", "the tangential stiffness ratio × normal_stiffness"),
                "slip_activation_time" => ("material.slip_activation_time", "the slip-activation time"),
                "tangential_damping_ratio" => ("material.tangential_damping_ratio", "the tangential damping ratio"),
                "rolling_stiffness" => ("material.rolling_stiffness", "the rolling stiffness rolling_stiffness × normal_stiffness"),
                "rolling_friction" => ("material.rolling_friction", "the rolling friction"),
                "normal_damping" => ("material.absorbing_damping", "the absorbing walls' dashpot absorbing_damping × √(m̄ normal_stiffness)"),
                "damping_fraction" => ("material.restitution", "the damping fraction of the restitution"),
                "friction" => ("material.friction", "the friction"),
                _ => ("material", "a contact parameter"),
            };
            return Err(src.error_at_key(key, format!("makes {derived} {value} (allowed: values for which it is {allowed})")));
        }
    }
    // the pistons' mass `wall_mass` M* and the preparation's gravity `gravity` p* L*/M*
    for total in [n * light, n * heavy] {
        let mass = cfg.preparation.wall_mass * total;
        if !(mass.is_finite() && mass > 0.0) {
            return Err(src.error_at_key(
                "preparation.wall_mass",
                format!("{} makes the pistons' mass wall_mass × M* = {mass} (M* ≈ {total:.4e}) (allowed: a ratio for which it is a finite number > 0)", cfg.preparation.wall_mass),
            ));
        }
        let g = cfg.preparation.gravity * (total / 0.84).sqrt() / total;
        if !g.is_finite() {
            return Err(src.error_at_key(
                "preparation.gravity",
                format!("{} makes the gravity {g} in engine units (allowed: a value for which it is finite)", cfg.preparation.gravity),
            ));
        }
    }
    Ok(())
}

/// Lines of `grainwave check` for a valid `e2` config.
pub fn describe(cfg: &E2Config) -> Vec<String> {
    let mut v = vec![format!("experiment   e2, seed {}", cfg.seed)];
    match &cfg.source.dir {
        Some(d) => v.push(format!("source       checkpoints of {d}")),
        None => {
            let p = &cfg.packing;
            v.push(format!("packing      {} × {} = {} disks, diameters d̄(1 ± {})", p.columns, p.rows, p.columns * p.rows, p.polydispersity));
            let m = &cfg.material;
            v.push(format!(
                "contacts     K_n = {} p*, e = {}, K_t/K_n = {}, γ_t/γ_n = {}, μ = {}, walls frictionless",
                m.normal_stiffness, m.restitution, m.tangential_stiffness_ratio, m.tangential_damping_ratio, m.friction
            ));
            let l = &cfg.loading;
            v.push(format!(
                "loading      {} at |ε̇| = {} /t* to |ε_yy| = {}, checkpoints every {}{}",
                l.direction.name(),
                l.strain_rate,
                l.final_strain,
                l.checkpoint_strain,
                if l.strain_rate != 2e-5 { " (published: 2e-5 /t*; slow down to the published final rate with `velocity_scale` `rate`)" } else { "" }
            ));
            if !m.absorbing_walls {
                v.push("walls        stiff, reflecting (the canonical protocol has absorbing top, left and bottom walls, SPEC §6.7)".into());
            }
        }
    }
    for (k, r) in cfg.replays.iter().enumerate() {
        v.push(format!(
            "replay       {}: checkpoint {}, {}{}, {} t_a",
            r.name.clone().unwrap_or(format!("r{k}")),
            r.checkpoint,
            r.modification.name(),
            if r.modification.paired() { format!(" amplitudes {:?}", r.amplitudes) } else { String::new() },
            r.duration
        ));
    }
    v
}

impl E2State {
    /// The state of `plan` and the fields of the earlier layout.
    fn from_parts(plan: Vec<Unit>, e: EarlierE2State) -> Self {
        E2State { plan, config: e.config, stage: e.stage, sim: e.sim, preparation: e.preparation, units: e.units, loading: e.loading, replays: e.replays }
    }

    /// A fresh state.
    pub fn new(config: E2Config) -> Self {
        let stage = if config.source.dir.is_some() { Stage::Replays } else { Stage::Preparing };
        E2State { plan: work::plan(&config), config, stage, sim: None, preparation: PreparationInfo::default(), units: None, loading: None, replays: Vec::new() }
    }

    /// Runs (or continues) the protocol: the units of [`work::plan`] on the scheduler, then the
    /// summary from the replays' reports, in the order of the config.
    pub fn run(&mut self, ctx: &mut RunContext<'_>) -> Result<E2Summary> {
        let cfg = self.config.clone();
        let started = std::time::Instant::now();
        if self.stage != Stage::Finished {
            grainwave_study::outputs::write_resolved_config(ctx.out_dir(), "e2", &cfg, "")?;
            let out = ctx.out_dir().to_path_buf();
            work::adopt_reports(&out, &self.replays)?;
            let (finished, loading_error) = {
                let work = work::E2Work::new(&cfg, &out, self);
                let mut scheduler = Scheduler::new(&work);
                let finished = scheduler.run(ctx);
                (finished, work.take_loading_error())
            };
            if let Some(e) = loading_error {
                return Err(e);
            }
            self.replays = work::finished_reports(&out, &cfg)?;
            if self.units.is_none() {
                // a run on the checkpoints of another: the units of that run
                self.units = self.replays.first().map(|r| r.units);
            }
            if finished? == Finished::Interrupted {
                return Err(ctx.interrupted_error(TAG, self));
            }
            self.stage = Stage::Finished;
        }
        let summary = outputs::write_summary(ctx.out_dir(), self, started.elapsed().as_secs_f64())?;
        ctx.save_checkpoint(TAG, self)?;
        Ok(summary)
    }
}


/// Re-makes the plots and the summary of the finished run in `dir` (`grainwave plot DIR`).
pub fn replot(dir: &std::path::Path, state: &E2State) -> Result<Vec<String>> {
    if state.stage != Stage::Finished {
        return Err(ExperimentError::Resume { path: dir.to_path_buf(), reason: "the run has not finished: resume it first".into() });
    }
    if let Some(l) = &state.loading {
        outputs::write_loading(dir, &state.config, l)?;
    }
    Ok(outputs::write_summary(dir, state, 0.0)?.files)
}

/// Parses, validates and runs an `e2` config into `ctx`'s directory.
pub fn run_config(src: &ConfigSource, ctx: &mut RunContext<'_>) -> Result<E2Summary> {
    let cfg = prepare(src)?;
    E2State::new(cfg).run(ctx)
}

/// Lines the command line prints after a run.
pub fn summary_lines(r: &E2Summary, out: &std::path::Path) -> Vec<String> {
    let mut v = vec![format!("e2: {} grains, seed {}", r.grains, r.seed)];
    if let Some(u) = &r.units {
        v.push(format!(
            "units        L* = {:.4} d̄, t* = {:.4}, v_a = {:.4}, t_a = {:.4} (engine units)",
            u.length, u.time, u.acoustic_velocity, u.acoustic_time
        ));
    }
    if let Some(l) = &r.loading {
        v.push(format!(
            "loading      ε_yy = {:.4e}, σ_yy = {:.4} p*, σ_xx = {:.4} p*, M_s = {}, {} checkpoints, {:.1} s",
            l.final_strain_yy, l.final_stress_yy, l.final_stress_xx, l.final_sliding, l.checkpoints, l.seconds
        ));
    }
    for rep in &r.replays {
        for p in &rep.pairs {
            v.push(format!(
                "replay       {} ({}, a = {:e}): speed {} v_a, max |δv| {:.3e}",
                rep.name,
                rep.modification,
                p.amplitude,
                p.speed.map(|s| format!("{s:.4}")).unwrap_or("—".into()),
                p.max_difference
            ));
        }
    }
    v.push(format!("outputs      {}/", out.display()));
    v
}
