//! The `simulation` protocol end to end: config errors with positions, the generated reference,
//! a small settling run, interrupt + resume bit for bit, and the resolved config.

use grainwave_study::protocol::InterruptAfter as Interrupter;

use grainwave_study::config::ConfigSource;
use grainwave_study::protocol::{RunContext, SilentReporter};
use grainwave_study::ExperimentError;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// 60 disks settling under gravity (a small version of the demo).
const SMALL: &str = r#"
experiment = "simulation"
seed = 7
gravity = [0.0, -1.0]

[grains]
kind = "disk"
count = 60
size = { distribution = "uniform_diameter", mean_diameter = 1.0, spread = 0.2 }

[domain]
size = [8.0, 20.0]

[placement]
region_min = [0.0, 4.0]

[contact]
preset = "hooke_cundall_strack"
normal_stiffness = 1.0e4
restitution = 0.5
friction = 0.3

[wall_contact]
friction = 0.0

[[walls]]
name = "floor"
axis = "y"
side = "low"
contact = { friction = 0.3, rolling_stiffness = 700.0, rolling_damping = 5.0, rolling_friction = 0.1 }

[[walls]]
name = "left"
axis = "x"
side = "low"

[[walls]]
name = "right"
axis = "x"
side = "high"

[stop]
kinetic_energy_per_grain = 1e-12
max_acceleration = 1e-7
check_every = 100
step_limit = 1_000_000

[output]
series_every = 500
checkpoint_every = 5000
snapshot_every = 4000
"#;

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("grainwave-sim-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn run_text(text: &str, out: &Path) -> grainwave_study::Result<grainwave_study::registry::RunSummary> {
    let src = ConfigSource::from_text("small.toml", text);
    let mut rep = SilentReporter;
    let mut ctx = RunContext::new(out, &mut rep, Arc::new(AtomicBool::new(false)))?;
    crate::REGISTRY.run(&src, &mut ctx)
}

fn check_err(text: &str) -> grainwave_study::config::ConfigError {
    crate::REGISTRY.check(&ConfigSource::from_text("bad.toml", text)).expect_err("must be refused")
}

/// Records the stages a run announces, with their bar totals.
#[derive(Default)]
struct Stages(Vec<(String, Option<u64>)>);

impl grainwave_study::protocol::Reporter for Stages {
    fn stage(&mut self, name: &str, total_steps: Option<u64>) {
        self.0.push((name.to_string(), total_steps));
    }
    fn progress(&mut self, _: &grainwave_study::Progress) {}
    fn samples(&mut self, _: usize, _: usize) {}
    fn message(&mut self, _: &str) {}
}

#[test]
fn the_bar_has_a_total_only_where_the_step_limit_ends_the_run() {
    let announced = |text: &str, name: &str| {
        let out = out_dir(name);
        let mut rep = Stages::default();
        let mut ctx = RunContext::new(&out, &mut rep, Arc::new(AtomicBool::new(false))).unwrap();
        crate::REGISTRY.run(&ConfigSource::from_text("small.toml", text), &mut ctx).unwrap();
        drop(ctx);
        let _ = std::fs::remove_dir_all(&out);
        rep.0
    };
    // settling: the equilibrium criteria end it long before its step limit of 10⁶
    assert_eq!(announced(SMALL, "bar-settle"), [("simulation".to_string(), None)]);
    // a fixed number of steps: the bar runs to it
    let fixed = SMALL.replace("kinetic_energy_per_grain = 1e-12\nmax_acceleration = 1e-7\n", "").replace("step_limit = 1_000_000", "step_limit = 300");
    assert_ne!(fixed, SMALL);
    assert_eq!(announced(&fixed, "bar-fixed"), [("simulation".to_string(), Some(300))]);
}

#[test]
fn small_pile_settles_and_the_walls_carry_the_weight() {
    let out = out_dir("pile");
    let s = run_text(SMALL, &out).unwrap();
    let r = &s.report;
    assert_eq!(r["stop_reason"], "converged");
    let support = r["support_over_weight"].as_f64().unwrap();
    assert!((support - 1.0).abs() < 1e-6, "walls carry {support} × the weight");
    for f in ["summary.json", "config.resolved.toml", "series.csv", "series.npz", "grains.csv", "grains.pvd", "contacts.pvd", "checkpoint.gwck", "run.log"] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    let series = std::fs::read_to_string(out.join("series.csv")).unwrap();
    assert!(series.starts_with("step,time,kinetic_energy_per_grain"), "{}", &series[..80]);
    assert!(series.lines().count() > 5);
    // the files of the run are the declared ones (docs/outputs.md), and the declarations that
    // hold for every run have their files
    let c = grainwave_study::outputs::check_directory(&out, grainwave_simulation::OUTPUTS).unwrap();
    assert!(c.undeclared.is_empty(), "files simulation does not declare: {:?}", c.undeclared);
    assert!(c.missing.is_empty(), "declared files the run did not write: {:?}", c.missing);
    let files = grainwave_study::outputs::files_under(&out).unwrap();
    let snapshot = files.iter().find(|f| f.starts_with("snapshots/grains_")).expect("a snapshot (snapshot_every = 4000)");
    assert_eq!(grainwave_study::outputs::declaration_of(grainwave_simulation::OUTPUTS, snapshot).map(|o| o.pattern), Some("snapshots/grains_<step>.vtp"));
    assert!(files.iter().any(|f| f == "plots/energy.png"), "{files:?}");
    // a file the study does not write is reported
    std::fs::write(out.join("plots/notes.txt"), b"mine").unwrap();
    let c = grainwave_study::outputs::check_directory(&out, grainwave_simulation::OUTPUTS).unwrap();
    assert_eq!(c.undeclared, ["plots/notes.txt"]);
}

#[test]
fn config_errors_name_file_line_column_key_value_and_what_is_allowed() {
    // unknown key, with a suggestion
    let e = check_err(&SMALL.replace("friction = 0.3\n\n[wall_contact]", "frction = 0.3\n\n[wall_contact]"));
    assert_eq!((e.file.as_str(), e.line, e.column), ("bad.toml", 21, 1));
    assert_eq!(e.key.as_deref(), Some("contact.frction"));
    assert!(e.message.contains("unknown key `frction`") && e.message.contains("did you mean `friction`?"), "{e}");
    assert!(e.to_string().starts_with("bad.toml:21:1: key `contact.frction`: unknown key"), "{e}");
    // wrong type
    let e = check_err(&SMALL.replace("count = 60", "count = \"sixty\""));
    assert_eq!((e.line, e.column, e.key.as_deref()), (8, 9, Some("grains.count")));
    assert!(e.message.contains("text \"sixty\", but `grains.count` takes a whole number"), "{e}");
    // out of range
    let e = check_err(&SMALL.replace("restitution = 0.5", "restitution = 1.5"));
    assert_eq!((e.line, e.column, e.key.as_deref()), (20, 15, Some("contact.restitution")));
    assert!(e.message.contains("1.5") && e.message.contains("(0, 1]"), "{e}");
    let e = check_err(&SMALL.replace("size = [8.0, 20.0]", "size = [8.0, -20.0]"));
    assert_eq!(e.key.as_deref(), Some("domain.size"));
    assert!(e.message.contains("-20") && e.message.contains("lengths > 0"), "{e}");
    // inconsistent combination
    let e = check_err(&SMALL.replace("restitution = 0.5", "restitution = 0.5\ndamping_fraction = 0.2"));
    assert_eq!((e.line, e.key.as_deref()), (20, Some("contact.restitution")));
    assert!(e.message.contains("at most one of"), "{e}");
    let e = check_err(&SMALL.replace("side = \"high\"", "side = \"high\"\nmass = 3.0"));
    assert_eq!(e.key.as_deref(), Some("walls[2].mass"));
    assert!(e.message.contains("does not apply to a `fixed` wall"), "{e}");
    // a vector of the wrong dimension
    let e = check_err(&SMALL.replace("gravity = [0.0, -1.0]", "gravity = [0.0, 0.0, -1.0]"));
    assert_eq!((e.line, e.key.as_deref()), (4, Some("gravity")));
    assert!(e.message.contains("3 components") && e.message.contains("needs 2"), "{e}");
    // unknown value of an enumerated key, with a suggestion
    let e = check_err(&SMALL.replace("kind = \"disk\"", "kind = \"disc\""));
    assert!(e.message.contains("unknown value `disc`") && e.message.contains("did you mean `disk`?"), "{e}");
    // unknown experiment
    let e = check_err(&SMALL.replace("experiment = \"simulation\"", "experiment = \"simulations\""));
    assert_eq!((e.line, e.key.as_deref()), (2, Some("experiment")));
    assert!(e.message.contains("did you mean `simulation`?"), "{e}");
    // wall names become file names: refused by check, not after the run
    for bad in ["a/../b", "a\\\\b", "tab\\there"] {
        let text = SMALL.replacen("name = \"floor\"", &format!("name = \"{bad}\""), 1);
        assert_ne!(text, SMALL, "the config must have a wall called floor");
        let e = check_err(&text);
        assert_eq!(e.key.as_deref(), Some("walls[0].name"), "{bad}: {e}");
        assert!(e.message.contains("file names"), "{e}");
    }
    // placement impossible: too many grains for the region
    let e = check_err(&SMALL.replace("count = 60", "count = 6000"));
    assert_eq!(e.key.as_deref(), Some("placement"));
    assert!(e.message.contains("too dense"), "{e}");
}

fn results(out: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<String> = ["summary.json", "series.csv", "series.npz", "grains.csv", "config.resolved.toml", "grains.pvd", "contacts.pvd"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let mut snaps: Vec<String> =
        std::fs::read_dir(out.join("snapshots")).unwrap().map(|e| format!("snapshots/{}", e.unwrap().file_name().to_string_lossy())).collect();
    snaps.sort();
    files.extend(snaps);
    files.into_iter().map(|f| (f.clone(), std::fs::read(out.join(&f)).unwrap())).collect()
}

#[test]
fn interrupted_run_resumes_to_the_same_bits() {
    let straight = out_dir("straight");
    run_text(SMALL, &straight).unwrap();

    let split = out_dir("split");
    let src = ConfigSource::from_text("small.toml", SMALL);
    let flag = Arc::new(AtomicBool::new(false));
    let mut rep = Interrupter::new(flag.clone(), 7);
    {
        let mut ctx = RunContext::new(&split, &mut rep, flag.clone()).unwrap();
        ctx.report_every = 37; // reports (and so the interruption) at an odd step
        match crate::REGISTRY.run(&src, &mut ctx) {
            Err(ExperimentError::Interrupted { checkpoint, .. }) => assert!(checkpoint.exists()),
            other => panic!("expected an interruption, got {other:?}"),
        }
    }
    assert!(!split.join("summary.json").exists(), "no summary before the end");
    // resume (with a fresh, unset flag)
    let mut rep = SilentReporter;
    let mut ctx = RunContext::new(&split, &mut rep, Arc::new(AtomicBool::new(false))).unwrap();
    crate::REGISTRY.resume(&split, &mut ctx).unwrap();
    assert_eq!(results(&straight), results(&split), "resumed outputs differ from the uninterrupted run");
    // resuming a finished run changes nothing
    crate::REGISTRY.resume(&split, &mut ctx).unwrap();
    assert_eq!(results(&straight), results(&split));
}

#[test]
fn the_resolved_config_reproduces_the_run() {
    let first = out_dir("first");
    run_text(SMALL, &first).unwrap();
    let resolved = std::fs::read_to_string(first.join("config.resolved.toml")).unwrap();
    assert!(resolved.contains("dt = ") && resolved.contains("skin = "), "computed defaults are filled in");
    let second = out_dir("second");
    run_text(&resolved, &second).unwrap();
    let strip = |v: Vec<(String, Vec<u8>)>| v.into_iter().filter(|(f, _)| f != "config.resolved.toml").collect::<Vec<_>>();
    assert_eq!(strip(results(&first)), strip(results(&second)));
}

/// `SMALL`'s grain–grain law written by family (docs/engine.md, "The contact law by family").
fn small_by_family() -> String {
    let text = SMALL.replace(
        "[contact]\npreset = \"hooke_cundall_strack\"\nnormal_stiffness = 1.0e4\nrestitution = 0.5\nfriction = 0.3\n",
        "[contact]\nfriction = 0.3\n\n[contact.normal]\nlaw = \"hooke\"\nstiffness = 1.0e4\n\n[contact.damping]\nlaw = \"restitution\"\nrestitution = 0.5\n\n[contact.tangential]\nlaw = \"linear\"\n",
    );
    assert_ne!(text, SMALL);
    text
}

#[test]
fn the_law_written_by_family_runs_the_bits_of_the_flat_keys() {
    let (flat, by_family) = (out_dir("flat"), out_dir("family"));
    run_text(SMALL, &flat).unwrap();
    run_text(&small_by_family(), &by_family).unwrap();
    // the resolved configs differ (each keeps its form); every other output is the same bits
    let strip = |v: Vec<(String, Vec<u8>)>| v.into_iter().filter(|(f, _)| f != "config.resolved.toml").collect::<Vec<_>>();
    assert_eq!(strip(results(&flat)), strip(results(&by_family)));
    let resolved = std::fs::read_to_string(by_family.join("config.resolved.toml")).unwrap();
    assert!(resolved.contains("[contact.normal]") && resolved.contains("law = \"hooke\""), "{resolved}");
    // the resolved config of the family form reproduces the run too
    let again = out_dir("family-again");
    run_text(&resolved, &again).unwrap();
    assert_eq!(strip(results(&by_family)), strip(results(&again)));
}

#[test]
fn family_tables_are_checked_at_their_keys() {
    let text = small_by_family();
    // a value out of range: at the value, under the family's key
    let e = check_err(&text.replace("stiffness = 1.0e4", "stiffness = -1.0e4"));
    assert_eq!((e.line, e.column, e.key.as_deref()), (22, 13, Some("contact.normal.stiffness")), "{e}");
    let e = check_err(&text.replace("restitution = 0.5", "restitution = 1.5"));
    assert_eq!((e.line, e.key.as_deref()), (26, Some("contact.damping.restitution")), "{e}");
    // a key the family's law does not have
    let e = check_err(&text.replace("law = \"linear\"", "law = \"linear\"\nstifness_ratio = 0.3"));
    assert_eq!((e.line, e.column), (30, 1), "{e}");
    assert!(e.message.contains("unknown key `stifness_ratio`") && e.message.contains("did you mean `stiffness_ratio`?"), "{e}");
    // an unknown law, with the laws of the family
    let e = check_err(&text.replace("law = \"hooke\"", "law = \"hook\""));
    assert_eq!(e.line, 21, "{e}");
    assert!(e.message.contains("hook") && e.message.contains("hertz"), "{e}");
    // one form per family
    let e = check_err(&text.replace("friction = 0.3\n\n[contact.normal]", "friction = 0.3\nnormal_stiffness = 1.0e4\n\n[contact.normal]"));
    assert_eq!(e.key.as_deref(), Some("contact.normal_stiffness"), "{e}");
    assert!(e.message.contains("one form"), "{e}");
    // the wall overrides of flat keys still apply to a law written by family (`friction = 0`,
    // the floor's rolling resistance): the run of `the_law_written_by_family…` covers them
}

use grainwave_study::registry::{entry, Entry, Registry};

static ONE: [Entry; 1] = [entry::<grainwave_simulation::SimulationProtocol>()];
/// The study alone in a registry: the tests check, run, resume and re-plot configs through the
/// same dispatch as the command line (the table of every study is `grainwave-experiments`').
pub static REGISTRY: Registry = Registry::new(&ONE);
