//! The `e3` protocol (SPEC §7): the response of a gravity-loaded 2D granular slab to a localized
//! force — floor response with the reference state subtracted, coarse-grained stress, contact
//! network changes, ensembles and sweeps with a single/double-peak classifier, superposition, a
//! pile variant and lattice elasticity. See docs/e3.md.
//!
//! A run is a [`plan::Plan`] of units of work: one reference state per case (parameter set ×
//! seed), one relaxation per response run (a force, or a pair of forces, applied to a reference)
//! and optionally one first-opening bisection per case ([`work`]). The scheduler
//! ([`grainwave_study::work::Scheduler`]) runs them in parallel and persists each as it completes; the
//! protocol state in `checkpoint.gwck` records which are done, so `grainwave resume` redoes
//! nothing that finished and continues interrupted units from their own checkpoints. Once every
//! unit is done, the aggregates, tables, plots and the summary are written ([`outputs`]).
#![warn(missing_docs)]

mod limits;

pub mod config;
pub mod measure;
pub mod outputs;
pub mod plan;
pub mod relax;
pub mod slab;
pub mod work;

pub use config::E3Config;
pub use outputs::E3Summary;

use grainwave_study::config::{non_negative, positive, ConfigError, ConfigSource};
use grainwave_study::Result;
use grainwave_study::protocol::RunContext;
use config::Mode;
use plan::Plan;
use serde::{Deserialize, Serialize};

/// Content tag of this protocol's checkpoints.
pub const TAG: &str = "experiment-e3/plan";
/// Content tag of the earlier layout, whose state carried no plan (read by [`E3Protocol`]'s
/// `upgrade`).
pub const EARLIER_TAG: &str = "experiment-e3";

/// The state of an `e3` run (what `checkpoint.gwck` holds): the config and its plan, and which
/// units are done. A state read from a checkpoint is checked ([`Plan::check_carried`], flags one
/// per unit) before it is used.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(try_from = "CarriedE3State")]
pub struct E3State {
    /// Its parameter sets, cases and response runs.
    pub plan: Plan,
    /// The config (stored as its TOML text).
    #[serde(with = "grainwave_study::config::toml_text")]
    pub config: E3Config,
    /// Per case: its reference state is done.
    pub references_done: Vec<bool>,
    /// Per run: its response is done.
    pub runs_done: Vec<bool>,
    /// All outputs are written.
    pub finished: bool,
}

/// [`E3State`] as decoded, before it is checked: its plan, then the fields of the earlier layout.
/// Checkpoints are bincode, which writes a struct's fields in order with no markers, so the
/// nested struct reads the same bytes as [`E3State`]'s flat fields.
#[derive(Deserialize)]
struct CarriedE3State {
    plan: Plan,
    rest: EarlierE3State,
}

impl TryFrom<CarriedE3State> for E3State {
    type Error = String;
    fn try_from(s: CarriedE3State) -> std::result::Result<Self, String> {
        let bad = |e: String| format!("the e3 plan it carries is inconsistent: {e}");
        s.plan.check_carried().map_err(bad)?;
        let e = s.rest;
        if e.references_done.len() != s.plan.cases.len() || e.runs_done.len() != s.plan.runs.len() {
            return Err(bad(format!("{} / {} done flags for {} cases / {} runs", e.references_done.len(), e.runs_done.len(), s.plan.cases.len(), s.plan.runs.len())));
        }
        Ok(E3State { plan: s.plan, config: e.config, references_done: e.references_done, runs_done: e.runs_done, finished: e.finished })
    }
}

/// The earlier layout of the state ([`EARLIER_TAG`]): no plan.
#[derive(Deserialize)]
struct EarlierE3State {
    #[serde(with = "grainwave_study::config::toml_text")]
    config: E3Config,
    references_done: Vec<bool>,
    runs_done: Vec<bool>,
    finished: bool,
}

/// A validated `e3` config and the plan of its units.
pub struct E3Spec {
    /// The config.
    pub config: E3Config,
    /// Its parameter sets, cases and response runs.
    pub plan: Plan,
}

use grainwave_study::outputs::{Format, OutputFile};

const RUN_FILES: &str = "per response run, when run directories are written (output.runs; default: every mode but sweep)";
const RUN_PLOTS: &str = "per response run, when run directories are written, output.plots = true";
const PLOTS: &str = "output.plots = true";

/// Every file an `e3` run writes into its output directory (docs/outputs.md); `<case>` is a
/// case's label (parameter set and seed), `<run>` a response run's label, `<group>` a
/// parameter set's label. Lengths in R̄, forces in m̄g, stresses in m̄g/R̄.
pub const OUTPUTS: &[OutputFile] = &[
    grainwave_study::outputs::RESOLVED_CONFIG,
    grainwave_study::outputs::SUMMARY,
    grainwave_study::outputs::CHECKPOINT,
    grainwave_study::outputs::LOG,
    grainwave_study::outputs::LOCK,
    grainwave_study::outputs::FAILED,
    OutputFile::always("timing.json", Format::Json, "wall-clock seconds of the units of work [s]"),
    OutputFile::when("runs.csv", Format::Csv, "one row per response run: case, force, its measurements", "with response runs"),
    OutputFile::when("results.csv", Format::Csv, "one row per parameter set and force: the ensemble's measurements", "with response runs"),
    OutputFile::when("profiles.csv", Format::Csv, "the ensemble-mean floor response Δσ_zz(x) per parameter set, force and width", "with response runs"),
    OutputFile::when("profiles.npz", Format::Npz, "the same profiles as NumPy arrays", "with response runs"),
    OutputFile::when("superposition.csv", Format::Csv, "left, right and both loads: the superposition error per case and force", "mode = \"superposition\""),
    OutputFile::when("pile_floor_<group>.csv", Format::Csv, "mean floor stress σ_zz(x) under the pile, per width", "mode = \"pile\""),
    OutputFile::when("pile_floor_<group>.npz", Format::Npz, "the same profile as NumPy arrays", "mode = \"pile\""),
    OutputFile::when("pile_floor_<group>_contacts.csv", Format::Csv, "the floor contacts of every pile: seed, x, fz, fx", "mode = \"pile\""),
    OutputFile::when("pile_floor_<group>_verdict.csv", Format::Csv, "the profile the verdict is judged on, with the window (in_window 0/1)", "mode = \"pile\""),
    OutputFile::when("pile_floor_<group>_verdict.npz", Format::Npz, "the same as NumPy arrays", "mode = \"pile\""),
    OutputFile::when("lattice_scan.csv", Format::Csv, "the lattice elasticity scan", "mode = \"lattice_elasticity\" with a scan"),
    OutputFile::when("<plot>.png", Format::Png, "plots: profiles_<group>, linearity, opened_region, crossover_…, superposition_…, pile_floor_<group>, lattice_scan", PLOTS),
    OutputFile::when("<plot>.svg", Format::Svg, "the same plots as SVG", PLOTS),
    OutputFile::when("units/<case>/<unit>.gwck", Format::Checkpoint, "units of work: reference.gwck (the relaxed reference), <run>.gwck (a response), opening_<k>.gwck (a bisection step), ….partial.gwck (an interrupted unit)", "per unit of work"),
    OutputFile::when("runs/<case>/<run>/floor_contacts.csv", Format::Csv, "the floor contacts: grain, x, fz_reference, fz, dfz, fx_reference, fx", RUN_FILES),
    OutputFile::when("runs/<case>/<run>/floor_profile.csv", Format::Csv, "the floor response Δσ_zz(x) per width", RUN_FILES),
    OutputFile::when("runs/<case>/<run>/floor_profile.npz", Format::Npz, "the same profile as NumPy arrays", RUN_FILES),
    OutputFile::when("runs/<case>/<run>/contact_changes.csv", Format::Csv, "every contact whose force changed, or that opened or closed", RUN_FILES),
    OutputFile::when("runs/<case>/<run>/stress_field.npz", Format::Npz, "the coarse-grained stress field, with the reference's", "per response run with a stress field"),
    OutputFile::when("runs/<case>/<run>/contact_force_difference.vtp", Format::Vtp, "the contact force change (ParaView)", "per response run, output.vtk = true"),
    OutputFile::when("runs/<case>/<run>/grains.vtp", Format::Vtp, "the grains after the load (ParaView)", "per response run, output.vtk = true"),
    OutputFile::when("runs/<case>/<run>/<plot>.png", Format::Png, "plots: network, stress_zz, floor_profile", RUN_PLOTS),
    OutputFile::when("runs/<case>/<run>/<plot>.svg", Format::Svg, "the same plots as SVG", RUN_PLOTS),
    OutputFile::when("runs/<case>/<plot>.png", Format::Png, "pile plots: force_network, stress_zz", "mode = \"pile\", output.plots = true"),
    OutputFile::when("runs/<case>/<plot>.svg", Format::Svg, "the same plots as SVG", "mode = \"pile\", output.plots = true"),
    OutputFile::when("runs/<case>/stress_field.npz", Format::Npz, "the pile's stress field under gravity", "mode = \"pile\", output.plots = true"),
    OutputFile::when("runs/<case>/grains.vtp", Format::Vtp, "the pile's grains (ParaView)", "mode = \"pile\", output.plots and output.vtk = true"),
    OutputFile::when("runs/<case>/contacts.vtp", Format::Vtp, "the pile's contact network (ParaView)", "mode = \"pile\", output.plots and output.vtk = true"),
];

/// The `e3` protocol: its spec is the config with its [`Plan`]; its units are the reference
/// states, response runs and bisections ([`work::E3Work`]).
pub struct E3Protocol;

impl grainwave_study::study::Protocol for E3Protocol {
    const NAME: &'static str = "e3";
    const TAG: &'static str = TAG;
    const REFERENCE: &'static str = "The response of a gravity-loaded granular slab to a localized force (SPEC §7; see docs/e3.md). Units: length R̄\n\
         (the largest radius), mass m̄ (a disk of radius R̄), time τ = √(R̄/g), force m̄g.";
    type Config = E3Config;
    type Spec = E3Spec;
    type State = E3State;
    type Report = E3Summary;
    const OUTPUTS: &'static [OutputFile] = OUTPUTS;

    fn validate(src: &ConfigSource) -> Result<E3Spec, ConfigError> {
        let config = prepare(src)?;
        let plan = Plan::new(&config);
        check_names(src, &config, &plan)?;
        Ok(E3Spec { config, plan })
    }
    fn describe(spec: &E3Spec) -> Vec<String> {
        describe_plan(&spec.config, &spec.plan)
    }
    fn plan(spec: &E3Spec) -> Vec<grainwave_study::work::Unit> {
        work::plan_units(&spec.config, &spec.plan)
    }
    fn start(spec: E3Spec) -> E3State {
        E3State::new(spec.config, spec.plan)
    }
    fn config(state: &E3State) -> &E3Config {
        &state.config
    }
    fn run(state: &mut E3State, ctx: &mut RunContext<'_>) -> Result<E3Summary> {
        state.run(ctx)
    }
    fn serve(state: &mut E3State, out: &std::path::Path, link: &dyn grainwave_study::work::WorkerLink, interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>) -> Result<()> {
        state.serve(out, link, interrupt)
    }
    fn summary_lines(report: &E3Summary, out: &std::path::Path) -> Vec<String> {
        summary_lines(report, out)
    }
    fn replot(dir: &std::path::Path, state: &E3State) -> Result<Vec<String>> {
        replot(dir, state)
    }

    const EARLIER_TAGS: &'static [&'static str] = &[EARLIER_TAG];
    /// A checkpoint of the earlier layout carried no plan: plan its config once, as `run` did
    /// then (the resolved config is not validated again: it holds every mode's defaults, which a
    /// config file may not); the done flags must fit the plan.
    fn upgrade(tag: &str, file: &std::path::Path) -> Result<E3State> {
        let earlier: EarlierE3State = grainwave_core::checkpoint::load(file, tag)?;
        E3State::try_from(CarriedE3State { plan: Plan::new(&earlier.config), rest: earlier }).map_err(|reason| grainwave_study::ExperimentError::Resume { path: file.to_path_buf(), reason })
    }
}

/// Parses and validates an `e3` config.
pub fn prepare(src: &ConfigSource) -> Result<E3Config, ConfigError> {
    let cfg: E3Config = src.parse()?;
    limits::check_sizes(src, &cfg)?;
    if cfg.experiment != "e3" {
        return Err(src.error_at_key("experiment", format!("this protocol is `e3`, not `{}`", cfg.experiment)));
    }
    let table: toml::Table = src.parse()?;
    for (key, mode) in [("sweep", Mode::Sweep), ("superposition", Mode::Superposition), ("pile", Mode::Pile), ("lattice", Mode::LatticeElasticity)] {
        if table.contains_key(key) && cfg.mode != mode {
            return Err(src.error_at_key(key, format!("`[{key}]` applies to mode `{}` only (this file's mode is `{}`)", mode.name(), cfg.mode.name())));
        }
    }
    for (key, modes) in [("slab", &[Mode::Slab, Mode::Sweep, Mode::Superposition][..]), ("load", &[Mode::Slab, Mode::Sweep, Mode::Superposition][..])] {
        if table.contains_key(key) && !modes.contains(&cfg.mode) {
            return Err(src.error_at_key(key, format!("`[{key}]` does not apply to mode `{}`", cfg.mode.name())));
        }
    }
    if cfg.samples == 0 {
        return Err(src.error_at_key("samples", "0 (allowed: at least 1)"));
    }
    // slab
    let s = &cfg.slab;
    let sizes: Vec<[usize; 2]> =
        if cfg.mode == Mode::Sweep && !cfg.sweep.sizes.is_empty() { cfg.sweep.sizes.clone() } else { vec![[s.layers, s.grains_per_layer]] };
    let size_key = if cfg.mode == Mode::Sweep && !cfg.sweep.sizes.is_empty() { "sweep.sizes" } else { "slab.layers" };
    for [l, m] in &sizes {
        if *l < 2 || *m < 3 {
            return Err(src.error_at_key(size_key, format!("{l} layers × {m} grains (allowed: at least 2 layers of at least 3 grains)")));
        }
    }
    let deltas: Vec<f64> = if cfg.mode == Mode::Sweep && !cfg.sweep.deltas.is_empty() { cfg.sweep.deltas.clone() } else { vec![s.delta] };
    for d in &deltas {
        if !(0.0..1.0).contains(d) {
            return Err(src.error_at_key(
                if cfg.mode == Mode::Sweep && !cfg.sweep.deltas.is_empty() { "sweep.deltas" } else { "slab.delta" },
                format!("{d} (allowed: δ in [0, 1))"),
            ));
        }
    }
    // material
    let m = &cfg.material;
    positive(src, "material.normal_stiffness", m.normal_stiffness)?;
    positive(src, "material.tangential_stiffness_ratio", m.tangential_stiffness_ratio)?;
    positive(src, "material.wall_stiffness_ratio", m.wall_stiffness_ratio)?;
    non_negative(src, "material.friction", m.friction)?;
    for (k, v) in [
        ("material.wall_friction", m.wall_friction),
        ("material.side_wall_friction", m.side_wall_friction),
        ("material.normal_damping", m.normal_damping),
        ("material.tangential_damping", m.tangential_damping),
        ("material.wall_normal_damping", m.wall_normal_damping),
        ("material.wall_tangential_damping", m.wall_tangential_damping),
    ] {
        if let Some(v) = v {
            non_negative(src, k, v)?;
        }
    }
    for v in &cfg.sweep.frictions {
        non_negative(src, "sweep.frictions", *v)?;
    }
    for v in &cfg.sweep.stiffness_ratios {
        positive(src, "sweep.stiffness_ratios", *v)?;
    }
    positive(src, "integration.dt", cfg.integration.dt)?;
    // relaxation
    let r = &cfg.relaxation;
    if let Some(v) = r.kinetic_energy_per_grain {
        positive(src, "relaxation.kinetic_energy_per_grain", v)?;
    }
    positive(src, "relaxation.max_acceleration", r.max_acceleration)?;
    positive(src, "relaxation.response_max_acceleration", r.response_max_acceleration)?;
    positive(src, "relaxation.max_time", r.max_time)?;
    positive(src, "relaxation.static_tolerance", r.static_tolerance)?;
    if r.static_iterations == 0 {
        return Err(src.error_at_key("relaxation.static_iterations", "0 (allowed: at least 1)"));
    }
    // load
    let l = &cfg.load;
    let fo = &cfg.first_opening;
    if matches!(cfg.mode, Mode::Slab | Mode::Sweep | Mode::Superposition) {
        if l.forces.is_empty() {
            return Err(src.error_at_key("load.forces", "empty (allowed: one or more forces > 0)"));
        }
        for f in &l.forces {
            positive(src, "load.forces", *f)?;
        }
        let mut sorted = l.forces.clone();
        sorted.sort_by(f64::total_cmp);
        if sorted.windows(2).any(|w| w[0] == w[1]) {
            return Err(src.error_at_key("load.forces", format!("{:?} repeats a force (each force is one run)", l.forces)));
        }
        // a response run stops at the tolerances `response_max_acceleration` × F and (kinetic
        // energy) × min(F, 1)²: both must be representable numbers > 0, or every run fails at
        // its start after the reference states are computed
        let mut forces: Vec<(&str, f64)> = l.forces.iter().map(|&f| ("load.forces", f)).collect();
        if fo.bisection && matches!(cfg.mode, Mode::Slab | Mode::Sweep) {
            forces.extend(fo.bracket.iter().map(|&f| ("first_opening.bracket", f)));
        }
        let ra = r.response_max_acceleration;
        let ke = r.kinetic_energy_per_grain.unwrap_or(1e-13);
        for (key, f) in forces {
            let tolerance = ra * f;
            if tolerance.is_infinite() {
                return Err(src.error_at_key(
                    "relaxation.response_max_acceleration",
                    format!("{ra} (allowed: a tolerance whose product with every force is finite; × {f} m̄g gives {tolerance})"),
                ));
            }
            if !(tolerance >= f64::MIN_POSITIVE && ke * f.min(1.0).powi(2) >= f64::MIN_POSITIVE) {
                return Err(src.error_at_key(
                    key,
                    format!(
                        "{f} (allowed: forces whose stopping tolerances stay representable: `relaxation.response_max_acceleration` × F = {tolerance} and the kinetic energy limit × min(F, 1)² = {} must be ≥ {:e})",
                        ke * f.min(1.0).powi(2),
                        f64::MIN_POSITIVE
                    ),
                ));
            }
        }
    }
    if !l.angle.is_finite() || l.angle.abs() >= 90.0 {
        return Err(src.error_at_key("load.angle", format!("{} (allowed: degrees from the downward vertical in (−90, 90))", l.angle)));
    }
    if !l.torque.is_finite() {
        return Err(src.error_at_key("load.torque", format!("{} (allowed: a finite torque)", l.torque)));
    }
    positive(src, "load.ramp_time", l.ramp_time)?;
    if table.contains_key("first_opening") && !matches!(cfg.mode, Mode::Slab | Mode::Sweep) {
        return Err(src.error_at_key("first_opening", format!("`[first_opening]` applies to modes `slab` and `sweep` only (this file's mode is `{}`)", cfg.mode.name())));
    }
    let [lo, hi] = fo.bracket;
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Err(src.error_at_key("first_opening.bracket", format!("{:?} (allowed: [F_low, F_high] with 0 < F_low < F_high, in m̄g)", fo.bracket)));
    }
    if !(fo.relative_tolerance > 0.0 && fo.relative_tolerance < 1.0) {
        return Err(src.error_at_key("first_opening.relative_tolerance", format!("{} (allowed: a fraction in (0, 1))", fo.relative_tolerance)));
    }
    if let Some(g) = l.grain {
        for [layers, m] in &sizes {
            let n = slab::Sites::of(slab::Shape::Slab { layers: *layers, grains_per_layer: *m, rows: s.rows }).positions.len();
            if g as usize >= n {
                return Err(src.error_at_key("load.grain", format!("{g} (allowed: a grain id < {n}, the grain count of a {layers} × {m} slab)")));
            }
        }
    }
    // response
    let rc = &cfg.response;
    if rc.widths.is_empty() {
        return Err(src.error_at_key("response.widths", "empty (allowed: one or more widths > 0)"));
    }
    for w in &rc.widths {
        positive(src, "response.widths", *w)?;
    }
    // each width is a column of the response tables (`dsigma_w<width>`): one width twice would
    // fail writing them, after every run is computed
    for (k, w) in rc.widths.iter().enumerate() {
        if rc.widths[..k].contains(w) {
            return Err(src.error_at_key(&format!("response.widths[{k}]"), format!("{w} appears twice in {:?} (allowed: distinct widths: each is a column of the response tables)", rc.widths)));
        }
    }
    positive(src, "response.profile_step", rc.profile_step)?;
    positive(src, "response.stress_width", rc.stress_width)?;
    positive(src, "response.stress_step", rc.stress_step)?;
    if let Some(w) = rc.classifier_width {
        positive(src, "response.classifier_width", w)?;
    }
    if !(rc.prominence > 0.0 && rc.prominence < 1.0) {
        return Err(src.error_at_key("response.prominence", format!("{} (allowed: a fraction in (0, 1))", rc.prominence)));
    }
    non_negative(src, "response.boundary_layer", rc.boundary_layer)?;
    positive(src, "response.asymmetry_threshold", rc.asymmetry_threshold)?;
    if !(rc.asymmetry_factor.is_finite() && rc.asymmetry_factor >= 1.0) {
        return Err(src.error_at_key("response.asymmetry_factor", format!("{} (allowed: a factor ≥ 1)", rc.asymmetry_factor)));
    }
    // modes
    if cfg.mode == Mode::Superposition {
        positive(src, "superposition.separation", cfg.superposition.separation)?;
        let sites = slab::Sites::of(slab::Shape::Slab { layers: s.layers, grains_per_layer: s.grains_per_layer, rows: s.rows });
        let axis = 0.5 * sites.width;
        let d = 0.5 * cfg.superposition.separation;
        if sites.top_grain_near(axis - d) == sites.top_grain_near(axis + d) {
            return Err(src.error_at_key(
                "superposition.separation",
                format!(
                    "{} puts both forces on the same grain (allowed: at least the top-row spacing, 2 R̄)",
                    cfg.superposition.separation
                ),
            ));
        }
        if axis + d > sites.width {
            return Err(src.error_at_key("superposition.separation", format!("{} is wider than the slab ({} R̄)", cfg.superposition.separation, sites.width)));
        }
    }
    if cfg.mode == Mode::Pile {
        if cfg.pile.layers < 2 || cfg.pile.top_grains < 1 {
            return Err(src.error_at_key(
                "pile.layers",
                format!("{} layers, {} top grains (allowed: at least 2 layers and 1 top grain)", cfg.pile.layers, cfg.pile.top_grains),
            ));
        }
        positive(src, "pile.verdict_width", cfg.pile.verdict_width)?;
        if !(0.0..1.0).contains(&cfg.pile.delta) {
            return Err(src.error_at_key("pile.delta", format!("{} (allowed: δ in [0, 1))", cfg.pile.delta)));
        }
    }
    if cfg.mode == Mode::LatticeElasticity {
        let lt = &cfg.lattice;
        positive(src, "lattice.spacing", lt.spacing)?;
        for (k, v) in [("lattice.horizontal", lt.horizontal), ("lattice.oblique", lt.oblique)] {
            if v.iter().any(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(src.error_at_key(k, format!("{v:?} (allowed: stiffnesses ≥ 0)")));
            }
        }
        if lt.oblique[0] <= 0.0 {
            return Err(src.error_at_key("lattice.oblique", "the oblique normal stiffness must be > 0 (the lattice would have no vertical stiffness)"));
        }
        for x in &lt.tangential_ratios {
            non_negative(src, "lattice.tangential_ratios", *x)?;
        }
        // the scan's criterion r at each ratio (outputs.rs, `lattice_outputs`): tangential
        // stiffnesses x k_n, and r itself, must be finite, or the run failed plotting it
        let r = |h: [f64; 2], o: [f64; 2]| grainwave_linear::lattice::SpringNetwork::triangular(lt.spacing, (h[0], h[1]), (o[0], o[1])).moduli().r();
        for (k, &x) in lt.tangential_ratios.iter().enumerate() {
            let with = r([lt.horizontal[0], x * lt.horizontal[0]], [lt.oblique[0], x * lt.oblique[0]]);
            let without = r([0.0, 0.0], [lt.oblique[0], x * lt.oblique[0]]);
            if !((x * lt.horizontal[0]).is_finite() && (x * lt.oblique[0]).is_finite() && with.is_finite() && without.is_finite()) {
                return Err(src.error_at_key(
                    &format!("lattice.tangential_ratios[{k}]"),
                    format!("{x} gives the criterion r = {with} (horizontal bonds as given), {without} (open) (allowed: ratios for which x × k_n and r are finite)"),
                ));
            }
        }
    }
    if cfg.mode != Mode::LatticeElasticity {
        engine_laws(src, &cfg)?;
    }
    // units
    let u = &cfg.units;
    for (k, v) in [("units.radius", u.radius), ("units.thickness", u.thickness), ("units.density", u.density), ("units.gravity", u.gravity)] {
        positive(src, k, v)?;
    }
    Ok(cfg)
}

/// Longest file name a unit writes (bytes): the limit of common file systems (`NAME_MAX`).
const MAX_NAME_BYTES: usize = 255;

/// The values of a set or a run are written out in full in its directory and file names
/// (`units/L4xM8_d0_mu0.5_kt0.8_s1/F5.partial.gwck`): a value such as 5e-324 or 1e308 (hundreds
/// of digits) makes a name the file system refuses, and every unit fails at its start. Refused
/// here at the key of the value, the names of every config that ran before are unchanged.
fn check_names(src: &ConfigSource, cfg: &E3Config, plan: &Plan) -> Result<(), ConfigError> {
    let sweep = cfg.mode == Mode::Sweep;
    let refuse = |key: &str, value: f64, name: &str| {
        src.error_at_key(
            key,
            format!(
                "{value:e} is written out as {} characters in the name `{}` of its unit's files, {} bytes (allowed: a value that keeps every name within {MAX_NAME_BYTES} bytes, e.g. with fewer digits)",
                format!("{value}").len(),
                grainwave_study::config::clip(name, 32),
                name.len()
            ),
        )
    };
    for g in &plan.groups {
        for &c in &g.cases {
            let name = &plan.cases[c].label;
            if name.len() > MAX_NAME_BYTES {
                let parts = [
                    (if cfg.mode == Mode::Pile { "pile.delta" } else if sweep && !cfg.sweep.deltas.is_empty() { "sweep.deltas" } else { "slab.delta" }, g.delta),
                    (if sweep && !cfg.sweep.frictions.is_empty() { "sweep.frictions" } else { "material.friction" }, g.friction),
                    (if sweep && !cfg.sweep.stiffness_ratios.is_empty() { "sweep.stiffness_ratios" } else { "material.tangential_stiffness_ratio" }, g.ratio),
                ];
                let (key, value) = parts.into_iter().max_by_key(|(_, v)| format!("{v}").len()).expect("three parts");
                return Err(refuse(key, value, name));
            }
        }
    }
    // a run's longest file: `<run>.partial.gwck`
    for r in plan.runs.iter().take(cfg.load.forces.len() * 3) {
        let name = format!("{}.partial.gwck", r.label);
        if name.len() > MAX_NAME_BYTES {
            return Err(refuse("load.forces", r.force, &name));
        }
    }
    Ok(())
}

/// Checks the contact laws the run gives the engine — the grain–grain law and the walls' laws of
/// every friction and stiffness ratio of the config (its own and the sweep's) — and names the key
/// a bad derived value comes from. The walls' stiffness is `wall_stiffness_ratio` ×
/// `normal_stiffness` and the default dashpots are square roots of stiffnesses: each keyed value
/// can be valid while a product is not (`normal_stiffness = 1e308` with the default ratio 2 gave
/// the floor an infinite stiffness, refused by the engine when the first reference state was
/// built).
fn engine_laws(src: &ConfigSource, cfg: &E3Config) -> Result<(), ConfigError> {
    let m = &cfg.material;
    let frictions: Vec<f64> = std::iter::once(m.friction).chain(cfg.sweep.frictions.iter().copied()).collect();
    let ratios: Vec<(&str, f64)> =
        std::iter::once(("material.tangential_stiffness_ratio", m.tangential_stiffness_ratio)).chain(cfg.sweep.stiffness_ratios.iter().map(|&r| ("sweep.stiffness_ratios", r))).collect();
    for &friction in &frictions {
        for &(ratio_key, ratio) in &ratios {
            let mat = slab::Material::resolve(m, friction, ratio);
            let laws = [
                ("grain", mat.grain_law(), mat.normal_stiffness),
                ("wall", mat.wall_law(mat.wall_friction), mat.wall_stiffness_ratio * mat.normal_stiffness),
                ("wall", mat.wall_law(mat.side_wall_friction), mat.wall_stiffness_ratio * mat.normal_stiffness),
            ];
            for (whose, law, k) in laws {
                let fault = match law.validate("material") {
                    Err(grainwave_core::CoreError::InvalidParameter { field, value, .. }) => Some((field.trim_start_matches("material.").to_string(), value)),
                    Err(e) => Some(("contact".to_string(), e.to_string())),
                    // a subnormal stiffness gives a time step and dashpots that are not representable
                    Ok(()) if k < f64::MIN_POSITIVE => Some(("normal_stiffness".to_string(), k.to_string())),
                    Ok(()) => None,
                };
                let Some((field, value)) = fault else { continue };
                let (key, derived) = match (whose, field.as_str()) {
                    ("grain", "normal_stiffness") => ("material.normal_stiffness", "the grains' normal stiffness"),
                    ("grain", "tangential_stiffness") => (ratio_key, "the grains' tangential stiffness ratio × normal_stiffness"),
                    ("grain", "normal_damping") => ("material.normal_damping", "the grains' normal dashpot (default √normal_stiffness)"),
                    ("grain", "tangential_damping") => ("material.tangential_damping", "the grains' tangential dashpot (default √(ratio × normal_stiffness))"),
                    ("wall", "normal_stiffness") => ("material.wall_stiffness_ratio", "the walls' stiffness wall_stiffness_ratio × normal_stiffness"),
                    ("wall", "tangential_stiffness") => ("material.wall_stiffness_ratio", "the walls' tangential stiffness ratio × wall_stiffness_ratio × normal_stiffness"),
                    ("wall", "normal_damping") => ("material.wall_normal_damping", "the walls' normal dashpot (default √(wall_stiffness_ratio × normal_stiffness))"),
                    ("wall", "tangential_damping") => ("material.wall_tangential_damping", "the walls' tangential dashpot"),
                    (_, "friction") => ("material.friction", "the friction"),
                    _ => ("material", "a contact parameter"),
                };
                return Err(src.error_at_key(
                    key,
                    format!("makes {derived} {value} (allowed: values for which it is a finite, normal number > 0; normal_stiffness = {}, wall_stiffness_ratio = {})", m.normal_stiffness, m.wall_stiffness_ratio),
                ));
            }
        }
    }
    Ok(())
}

/// Lines of `grainwave check` for a valid `e3` config.
pub fn describe(cfg: &E3Config) -> Vec<String> {
    describe_plan(cfg, &Plan::new(cfg))
}

/// Lines of `grainwave check` for a valid `e3` config and its plan.
fn describe_plan(cfg: &E3Config, plan: &Plan) -> Vec<String> {
    let mut v = vec![format!("experiment   e3, mode {}, seed {}, {} sample(s) per disordered set", cfg.mode.name(), cfg.seed, cfg.samples)];
    if cfg.mode == Mode::LatticeElasticity {
        v.push(format!("lattice      spacing {}, horizontal {:?}, oblique {:?}", cfg.lattice.spacing, cfg.lattice.horizontal, cfg.lattice.oblique));
        return v;
    }
    for g in &plan.groups {
        let n = slab::Sites::of(g.shape).positions.len();
        let mat = slab::Material::resolve(&cfg.material, g.friction, g.ratio);
        v.push(format!(
            "set          {}: {n} grains, δ = {}, μ = {} (floor {}, side walls {}), k_T/k_N = {}, {} case(s)",
            g.label,
            g.delta,
            g.friction,
            mat.wall_friction,
            mat.side_wall_friction,
            g.ratio,
            g.cases.len()
        ));
    }
    v.push(format!(
        "work         {} reference state(s), {} response run(s); forces {:?} m̄g, ramp {} τ",
        plan.cases.len(),
        plan.runs.len(),
        if cfg.mode == Mode::Pile { Vec::new() } else { cfg.load.forces.clone() },
        cfg.load.ramp_time
    ));
    v.push(format!("integration  dt = {} τ, {:?}", cfg.integration.dt, cfg.integration.integrator));
    v
}

/// What `config.resolved.toml` says about the keys computed during the run.
const RESOLVED_NOTE: &str = "Keys left out are computed per parameter set (dashpots from the stiffnesses, wall friction\n\
                             from μ, the kinetic-energy limit from δ; see docs/e3.md).";

impl E3State {
    /// A fresh state for `config` and its plan ([`Plan::new`]).
    pub fn new(config: E3Config, plan: Plan) -> Self {
        E3State { references_done: vec![false; plan.cases.len()], runs_done: vec![false; plan.runs.len()], finished: false, config, plan }
    }

    /// Runs, in a worker process, the units of this state's run in `out` that the coordinator
    /// sends ([`grainwave_study::work::serve`]): the same units as [`E3State::run`]'s (the coordinator
    /// records them and saves the state).
    pub fn serve(&self, out: &std::path::Path, link: &dyn grainwave_study::work::WorkerLink, interrupt: std::sync::Arc<std::sync::atomic::AtomicBool>) -> Result<()> {
        let plan = &self.plan;
        let write_run = run_writer(&self.config, plan);
        let save = |_: &mut RunContext<'_>, _: &[bool], _: &[bool]| -> Result<()> { Ok(()) };
        let work = work::E3Work::new(&self.config, plan, out, &self.references_done, &self.runs_done, &write_run, &save);
        grainwave_study::work::serve(&work, link, out, interrupt)
    }

    /// Runs (or continues) the protocol, writing every output into the context's directory.
    pub fn run(&mut self, ctx: &mut RunContext<'_>) -> Result<E3Summary> {
        let cfg = self.config.clone();
        let plan = self.plan.clone();
        if !self.finished {
            grainwave_study::outputs::write_resolved_config(ctx.out_dir(), "e3", &cfg, RESOLVED_NOTE)?;
            ctx.log(&format!("e3 {}: {} reference state(s), {} response run(s)", cfg.mode.name(), plan.cases.len(), plan.runs.len()));
            let save = |ctx: &mut RunContext<'_>, refs: &[bool], runs: &[bool]| -> Result<()> {
                let state = E3State { config: cfg.clone(), plan: plan.clone(), references_done: refs.to_vec(), runs_done: runs.to_vec(), finished: false };
                ctx.save_checkpoint(TAG, &state)?;
                Ok(())
            };
            let write_run = run_writer(&cfg, &plan);
            let out = ctx.out_dir().to_path_buf();
            let work = work::E3Work::new(&cfg, &plan, &out, &self.references_done, &self.runs_done, &write_run, &save);
            let mut scheduler = grainwave_study::work::Scheduler::new(&work);
            let finished = scheduler.run(ctx);
            (self.references_done, self.runs_done) = work.flags(scheduler.done());
            if finished? == grainwave_study::work::Finished::Interrupted {
                return Err(ctx.interrupted_error(TAG, self));
            }
        }
        let summary = outputs::write_final(ctx.out_dir(), &cfg, &plan)?;
        self.finished = true;
        ctx.save_checkpoint(TAG, self)?;
        Ok(summary)
    }
}


/// Writes the files of a finished response run (a unit's own outputs, written where it runs).
fn run_writer<'a>(cfg: &'a E3Config, plan: &'a Plan) -> impl Fn(
    &std::path::Path,
    &plan::RunSpec,
    &measure::RunResult,
    &grainwave_core::snapshot::Snapshot<grainwave_core::dim::D2>,
    &grainwave_core::snapshot::Snapshot<grainwave_core::dim::D2>,
    &grainwave_analysis::network::NetworkChanges<grainwave_core::dim::D2>,
    Option<&measure::FieldData>,
) -> Result<()>
       + Sync
       + 'a {
    move |out, run, result, reference, after, changes, reference_field| outputs::write_run_files(out, cfg, plan, run, result, reference, after, changes, reference_field)
}

/// Re-makes the aggregate outputs (tables, plots, summary) of the finished run in `dir` from its
/// saved units (`grainwave plot DIR`); returns the files written. Per-run pictures are made when a
/// run completes and are not re-made.
pub fn replot(dir: &std::path::Path, state: &E3State) -> Result<Vec<String>> {
    if !state.finished {
        return Err(grainwave_study::ExperimentError::Resume { path: dir.to_path_buf(), reason: "the run has not finished: resume it first".into() });
    }
    Ok(outputs::write_final(dir, &state.config, &state.plan)?.files)
}

/// Parses, validates and runs an `e3` config into `ctx`'s directory.
pub fn run_config(src: &ConfigSource, ctx: &mut RunContext<'_>) -> Result<E3Summary> {
    let cfg = prepare(src)?;
    let plan = Plan::new(&cfg);
    E3State::new(cfg, plan).run(ctx)
}

/// The lines `grainwave run` prints at the end.
pub fn summary_lines(r: &E3Summary, out: &std::path::Path) -> Vec<String> {
    let mut lines = vec![format!("e3 {}: {} parameter set(s)", r.mode, r.groups.len())];
    for g in &r.groups {
        for c in g.cases.iter().take(3) {
            lines.push(format!(
                "reference    {} seed {}: floor carries {:.9} × the weight, max acceleration {:.2e}",
                g.label, c.seed, c.floor_over_weight, c.max_acceleration
            ));
        }
        for a in &g.responses {
            lines.push(format!(
                "response     F = {} ({}): p(0)/F = {:.4e}, {} opened ({} in the cone below the load), {} sliding, {} ({} verdict, dip {:.4}; smoothed {}), A_s = {:.3e}",
                a.force,
                a.variant.name(),
                a.response_at_zero.first().copied().unwrap_or(f64::NAN),
                a.opened,
                a.opened_cone,
                a.sliding,
                a.verdict,
                a.verdict_basis,
                a.dip,
                a.classification.shape.name(),
                a.asymmetry
            ));
        }
        for b in &g.first_opening_bisection {
            let v = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{x:.4}"));
            lines.push(format!(
                "first opening  {}: below the load (cone) {} m̄g [{}, {}], connected to the load {} [{}, {}], anywhere [{}, {}] (linear estimate {})",
                b.case,
                v(b.first_opening_below_load),
                v(b.lower),
                v(b.upper),
                v(b.first_opening_connected),
                v(b.connected_lower),
                v(b.connected_upper),
                v(b.anywhere_lower),
                v(b.anywhere_upper),
                v(b.anywhere_linear_estimate)
            ));
        }
        if let Some(f) = &g.first_opening {
            if let Some(e) = f.linear_estimate {
                lines.push(format!("first opening  ≈ {e:.4} m̄g (linear estimate from F = {})", f.estimated_from.unwrap_or(f64::NAN)));
            }
        }
    }
    for s in &r.superposition {
        lines.push(format!("superposition F = {}: per-contact deviation {:.2e}, profile {:.2e}", s.force, s.contact_max_deviation, s.profile_max_deviation.first().copied().unwrap_or(f64::NAN)));
    }
    for p in &r.piles {
        lines.push(format!(
            "pile         {}: floor/weight {:.9}, {} floor profile ({}, dip {:.4}); raw without the wall-supported contacts: {} (dip {:.4})",
            p.group,
            p.floor_over_weight,
            p.shape.name(),
            p.verdict_basis,
            p.dip,
            p.shape_raw.map_or("none", |s| s.name()),
            p.dip_raw
        ));
    }
    if let Some(l) = &r.lattice {
        lines.push(format!("lattice      a = {:.4}, b = {:.4}, c = {:.4}, d = {:.4}, r = {:.4} ({})", l.moduli.a, l.moduli.b, l.moduli.c, l.moduli.d, l.moduli.r, l.verdict));
    }
    if !r.not_converged.is_empty() {
        lines.push(format!("warning      {} relaxation(s) did not converge: {}", r.not_converged.len(), r.not_converged.join(", ")));
    }
    lines.push(format!("outputs      {}/", out.display()));
    lines
}
