//! Dispatch by the `experiment` key: check, run and resume any protocol, and the config reference.

use crate::config::{did_you_mean, reference, ConfigError, ConfigSource};
use crate::error::{ExperimentError, Result};
use crate::protocol::{checkpoint_tag, load_state, RunContext};
use crate::{e1, e2, e3, simulation};
use schemars::schema_for;
use std::path::Path;

/// Names of the protocols a config can select with `experiment = "…"`.
pub const EXPERIMENTS: &[&str] = &["simulation", "e1", "e2", "e3"];

/// The protocol a config selects, from its top-level `experiment` key.
pub fn experiment_name(src: &ConfigSource) -> Result<String, ConfigError> {
    let table: toml::Table = src.parse()?;
    match table.get("experiment") {
        None => Err(src.error_at_key("experiment", format!("missing: say which protocol this file configures (allowed: {})", EXPERIMENTS.join(", ")))),
        Some(toml::Value::String(name)) if EXPERIMENTS.contains(&name.as_str()) => Ok(name.clone()),
        Some(toml::Value::String(name)) => {
            let mut msg = format!("unknown experiment `{name}`");
            if let Some(best) = did_you_mean(name, EXPERIMENTS) {
                msg.push_str(&format!(" — did you mean `{best}`?"));
            }
            msg.push_str(&format!(" (allowed: {})", EXPERIMENTS.join(", ")));
            Err(src.error_at_key("experiment", msg))
        }
        Some(other) => Err(src.error_at_key("experiment", format!("{other} is not a name (allowed: {})", EXPERIMENTS.join(", ")))),
    }
}

/// Checks the shapes of the file's values against the schema of protocol `name`
/// ([`crate::config::check_shapes`]).
/// The schema of each protocol is generated once per process (it depends on the types only);
/// generating it took most of the time of a `check` of a small config.
pub fn check_shapes(src: &ConfigSource, name: &str) -> Result<(), ConfigError> {
    use std::sync::OnceLock;
    static SCHEMAS: [OnceLock<serde_json::Value>; 4] = [OnceLock::new(), OnceLock::new(), OnceLock::new(), OnceLock::new()];
    let (slot, make): (usize, fn() -> serde_json::Value) = match name {
        "simulation" => (0, || serde_json::to_value(schema_for!(simulation::SimulationConfig)).expect("schema serializes")),
        "e1" => (1, || serde_json::to_value(schema_for!(e1::E1Config)).expect("schema serializes")),
        "e2" => (2, || serde_json::to_value(schema_for!(e2::E2Config)).expect("schema serializes")),
        "e3" => (3, || serde_json::to_value(schema_for!(e3::E3Config)).expect("schema serializes")),
        _ => return Ok(()),
    };
    crate::config::check_shapes(src, SCHEMAS[slot].get_or_init(make))
}

/// What `grainwave check` prints about a valid config.
pub fn check(src: &ConfigSource) -> Result<Vec<String>, ConfigError> {
    let name = experiment_name(src)?;
    check_shapes(src, &name)?;
    match name.as_str() {
        "simulation" => {
            let p = simulation::prepare(src)?;
            Ok(describe(&p))
        }
        "e1" => Ok(e1::describe(&e1::prepare(src)?)),
        "e2" => Ok(e2::describe(&e2::prepare(src)?)),
        "e3" => Ok(e3::describe(&e3::prepare(src)?)),
        other => unreachable!("experiment `{other}` is listed but not dispatched"),
    }
}

fn describe(p: &simulation::Prepared) -> Vec<String> {
    fn lines<D: grainwave_core::dim::Dim>(s: &grainwave_core::sim::Simulation<D>, c: &simulation::SimulationConfig) -> Vec<String> {
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
        simulation::AnySim::D2(s) => lines(s, &p.config),
        simulation::AnySim::D3(s) => lines(s, &p.config),
    }
}

/// The outcome of a run, for the command line.
#[derive(Clone, Debug)]
pub struct RunSummary {
    /// Lines describing the result.
    pub lines: Vec<String>,
    /// The report as JSON.
    pub report: serde_json::Value,
}

fn summarize(r: &simulation::SimulationReport, out: &Path) -> RunSummary {
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
    RunSummary { lines, report: serde_json::to_value(r).unwrap_or_default() }
}

fn summarize_e1(r: &e1::E1Report, out: &Path) -> RunSummary {
    RunSummary { lines: e1::summary_lines(r, out), report: serde_json::to_value(r).unwrap_or_default() }
}

fn summarize_e2(r: &e2::E2Summary, out: &Path) -> RunSummary {
    RunSummary { lines: e2::summary_lines(r, out), report: serde_json::to_value(r).unwrap_or_default() }
}

fn summarize_e3(r: &e3::E3Summary, out: &Path) -> RunSummary {
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
                "response     F = {} ({}): p(0)/F = {:.4e}, {} opened, {} sliding, {} peak",
                a.force,
                a.variant.name(),
                a.response_at_zero.first().copied().unwrap_or(f64::NAN),
                a.opened,
                a.sliding,
                a.classification.shape.name()
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
        lines.push(format!("pile         {}: floor/weight {:.9}, {} floor profile ({}, dip {:.4})", p.group, p.floor_over_weight, p.shape.name(), p.verdict_basis, p.dip));
    }
    if let Some(l) = &r.lattice {
        lines.push(format!("lattice      a = {:.4}, b = {:.4}, c = {:.4}, d = {:.4}, r = {:.4} ({})", l.moduli.a, l.moduli.b, l.moduli.c, l.moduli.d, l.moduli.r, l.verdict));
    }
    if !r.not_converged.is_empty() {
        lines.push(format!("warning      {} relaxation(s) did not converge: {}", r.not_converged.len(), r.not_converged.join(", ")));
    }
    lines.push(format!("outputs      {}/", out.display()));
    RunSummary { lines, report: serde_json::to_value(r).unwrap_or_default() }
}

/// Parses, validates and runs a config.
pub fn run(src: &ConfigSource, ctx: &mut RunContext<'_>) -> Result<RunSummary> {
    let name = experiment_name(src)?;
    check_shapes(src, &name)?;
    match name.as_str() {
        "simulation" => {
            let out = ctx.out_dir().to_path_buf();
            Ok(summarize(&simulation::run_config(src, ctx)?, &out))
        }
        "e1" => {
            let out = ctx.out_dir().to_path_buf();
            Ok(summarize_e1(&e1::run_config(src, ctx)?, &out))
        }
        "e2" => {
            let out = ctx.out_dir().to_path_buf();
            Ok(summarize_e2(&e2::run_config(src, ctx)?, &out))
        }
        "e3" => {
            let out = ctx.out_dir().to_path_buf();
            Ok(summarize_e3(&e3::run_config(src, ctx)?, &out))
        }
        other => unreachable!("experiment `{other}` is listed but not dispatched"),
    }
}

/// Continues the run whose checkpoint is in `dir`.
pub fn resume(dir: &Path, ctx: &mut RunContext<'_>) -> Result<RunSummary> {
    let (file, tag) = checkpoint_tag(dir)?;
    // a process killed while writing leaves its temporary file; the resumed run rewrites the file
    for stale in grainwave_core::checkpoint::remove_stale_temporaries(dir) {
        ctx.log(&format!("removed the temporary file {} left by an interrupted write", stale.display()));
    }
    match tag.as_str() {
        simulation::TAG => {
            let mut state: simulation::SimulationState = load_state(&file, &tag)?;
            belongs_to(dir, &state.config)?;
            ctx.log(&format!("resuming from {}", file.display()));
            let out = ctx.out_dir().to_path_buf();
            Ok(summarize(&state.run(ctx)?, &out))
        }
        e1::TAG => {
            let mut state: e1::E1State = load_state(&file, &tag)?;
            belongs_to(dir, &state.config)?;
            ctx.log(&format!("resuming from {}", file.display()));
            let out = ctx.out_dir().to_path_buf();
            Ok(summarize_e1(&state.run(ctx)?, &out))
        }
        e2::TAG => {
            let mut state: e2::E2State = load_state(&file, &tag)?;
            belongs_to(dir, &state.config)?;
            ctx.log(&format!("resuming from {}", file.display()));
            let out = ctx.out_dir().to_path_buf();
            Ok(summarize_e2(&state.run(ctx)?, &out))
        }
        e3::TAG => {
            let mut state: e3::E3State = load_state(&file, &tag)?;
            belongs_to(dir, &state.config)?;
            ctx.log(&format!("resuming from {}", file.display()));
            let out = ctx.out_dir().to_path_buf();
            Ok(summarize_e3(&state.run(ctx)?, &out))
        }
        other => Err(ExperimentError::Resume { path: dir.to_path_buf(), reason: format!("its checkpoint holds `{other}`, which is not a protocol state") }),
    }
}

/// Checks that a checkpoint belongs to output directory `dir`: the config it carries (every
/// state holds its resolved config) must be the one in the directory's `config.resolved.toml`
/// (experiment, seed and every other key). A checkpoint copied from another run is refused,
/// naming the first key that differs.
pub fn belongs_to<C: serde::Serialize>(dir: &Path, config: &C) -> Result<()> {
    let path = dir.join("config.resolved.toml");
    let Ok(text) = std::fs::read_to_string(&path) else { return Ok(()) }; // written at the start of a run; absent before
    let refuse = |reason: String| ExperimentError::Resume { path: dir.to_path_buf(), reason };
    let on_disk: toml::Table = toml::from_str(&text).map_err(|e| refuse(format!("its config.resolved.toml cannot be read: {}", crate::config::clip(e.message(), 200))))?;
    let carried = toml::Value::try_from(config).map_err(|e| refuse(format!("the checkpoint's config cannot be compared: {e}")))?;
    if let Some((key, a, b)) = first_difference(&carried, &toml::Value::Table(on_disk), "") {
        return Err(refuse(format!(
            "its checkpoint belongs to another run: key `{key}` is {} in the checkpoint but {} in the directory's config.resolved.toml \
             (copy a run's whole directory, or start a new run)",
            crate::config::clip(&a, 60),
            crate::config::clip(&b, 60)
        )));
    }
    Ok(())
}

/// The first key path where `a` and `b` differ, with both values as text.
fn first_difference(a: &toml::Value, b: &toml::Value, path: &str) -> Option<(String, String, String)> {
    let show = |v: Option<&toml::Value>| v.map_or("absent".to_string(), |v| v.to_string());
    match (a, b) {
        (toml::Value::Table(x), toml::Value::Table(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                let p = if path.is_empty() { k.clone() } else { format!("{path}.{k}") };
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => {
                        if let Some(d) = first_difference(u, v, &p) {
                            return Some(d);
                        }
                    }
                    (u, v) => return Some((p, show(u), show(v))),
                }
            }
            None
        }
        (toml::Value::Array(x), toml::Value::Array(y)) if x.len() == y.len() => {
            x.iter().zip(y).enumerate().find_map(|(i, (u, v))| first_difference(u, v, &format!("{path}[{i}]")))
        }
        (toml::Value::Float(x), toml::Value::Float(y)) if x == y || (x.is_nan() && y.is_nan()) => None,
        _ if a == b => None,
        _ => Some((path.to_string(), a.to_string(), b.to_string())),
    }
}

/// Re-makes the plots of the run in `dir` from its saved data (series and checkpoint). Returns
/// the files written, relative to `dir`.
pub fn plot(dir: &Path) -> Result<Vec<String>> {
    let (file, tag) = checkpoint_tag(dir)?;
    match tag.as_str() {
        simulation::TAG => {
            let state: simulation::SimulationState = load_state(&file, &tag)?;
            let series = grainwave_io::Series::read_npz(&dir.join("series.npz"))?;
            Ok(simulation::make_plots(dir, &series, state.picture().as_ref())?)
        }
        e1::TAG => {
            let state: e1::E1State = load_state(&file, &tag)?;
            e1::replot(dir, &state)
        }
        e2::TAG => {
            let state: e2::E2State = load_state(&file, &tag)?;
            e2::replot(dir, &state)
        }
        e3::TAG => {
            let state: e3::E3State = load_state(&file, &tag)?;
            e3::replot(dir, &state)
        }
        other => Err(ExperimentError::Resume { path: dir.to_path_buf(), reason: format!("its checkpoint holds `{other}`, which has no plots") }),
    }
}

/// The config reference (`docs/config.md`), generated from the key definitions.
pub fn reference_markdown() -> String {
    let mut s = String::from(
        "# Config reference\n\n\
         Generated from the key definitions by `grainwave reference`; do not edit by hand (a test fails when this file\n\
         is stale). Every config file names its protocol with `experiment = \"…\"`. Units are given per key in the units\n\
         of the user's choice (grainwave is unit-agnostic): `length`, `time`, `mass`, `force` and their combinations;\n\
         keys without a unit are dimensionless. Unknown keys are refused.\n\n",
    );
    let schema = schema_for!(simulation::SimulationConfig);
    let value = serde_json::to_value(&schema).expect("schema serializes");
    s.push_str(&reference::markdown(
        "`experiment = \"simulation\"`",
        "A general discrete-element run (see docs/simulation.md). The `[contact]` keys are those of the presets\n\
         (docs/engine.md); `[wall_contact]` and `walls[].contact` take the same keys and replace the grain–grain values.",
        &reference::sections(&value),
    ));
    let schema = schema_for!(e1::E1Config);
    let value = serde_json::to_value(&schema).expect("schema serializes");
    s.push_str(&reference::markdown(
        "`experiment = \"e1\"`",
        "Pulse transmission through confined, pressurized Hertz–Mindlin packings (SPEC §5; see docs/e1.md). Units:\n\
         length d̄ (the mean diameter), grain density ρ = 1, pressure E* = E/(1 − ν²) = 1, time d̄ √(ρ/E*).",
        &reference::sections(&value),
    ));
    let schema = schema_for!(e2::E2Config);
    let value = serde_json::to_value(&schema).expect("schema serializes");
    s.push_str(&reference::markdown(
        "`experiment = \"e2\"`",
        "Acoustics of a 2D packing under biaxial loading, with frictional sliding (SPEC §6; see docs/e2.md). Units:\n\
         pressure p* (force/length), total grain mass M*, L* = √(M*/ρ*), t* = √(M*/p*), v_a = d̄√(K_n/m̄), t_a = L*/v_a;\n\
         grain sizes in mean diameters d̄.",
        &reference::sections(&value),
    ));
    let schema = schema_for!(e3::E3Config);
    let value = serde_json::to_value(&schema).expect("schema serializes");
    s.push_str(&reference::markdown(
        "`experiment = \"e3\"`",
        "The response of a gravity-loaded granular slab to a localized force (SPEC §7; see docs/e3.md). Units: length R̄\n\
         (the largest radius), mass m̄ (a disk of radius R̄), time τ = √(R̄/g), force m̄g.",
        &reference::sections(&value),
    ));
    s
}
