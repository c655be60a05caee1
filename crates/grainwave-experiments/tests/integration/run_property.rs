//! Property (issue: hardening): any config that `check` accepts either runs or fails with an
//! error that has a message — never a panic. Configs are drawn by `proptest` as one to three
//! edits of a short `simulation` config (400 disks falling in a box): the numbers of a value
//! scaled by a power of ten (1e-12 … 1e12), a value replaced by an extreme number or a wrong
//! shape, a line removed. `proptest` shrinks a failing case to
//! its fewest and simplest edits, which is what a report of the panic needs.
//!
//! Every run is bounded twice: the config's `[stop] step_limit = 200` (the edits never touch
//! `[stop]` or `[output]`), and a wall-clock budget per run (`BUDGET`), after which the run is
//! interrupted the way Ctrl-C interrupts it (it saves a checkpoint and returns
//! `ExperimentError::Interrupted`). Without the budget an accepted config with, say, a tiny
//! time step and 400 grains can run for minutes inside its 200 steps. An interrupted run counts
//! as a clean stop (it ended with a typed error), and the number of them is printed.
//!
//! `GRAINWAVE_PROPTEST_CASES` sets the number of cases (default 64, about 4 s; the seed is fixed, so a
//! failure reproduces).

use grainwave_experiments::config::ConfigSource;
use grainwave_experiments::ExperimentError;
use grainwave_experiments::protocol::{RunContext, SilentReporter};
use grainwave_experiments::registry;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use super::watchdog::Watchdog;
use std::time::Duration;

/// Wall-clock budget of one run: a few times what an unedited run of this config takes
/// (about 0.1 s), short enough that 64 cases stay well under a minute even if every one hits it.
const BUDGET: Duration = Duration::from_millis(600);

/// Values put in place of a value: extremes of every type, empty and wrong shapes.
const REPLACEMENTS: &[&str] = &[
    "0", "-1", "1e308", "-1e308", "5e-324", "nan", "inf", "-inf", "4294967296", "18446744073709551615", "-0.0", "1e-12", "1e30", "\"\"",
    "\"x\"", "[]", "[[]]", "{}", "true", "[1e308, -1e308]", "[0.0, 0.0]", "[nan, 1]", "0.5", "2", "1e6",
];

/// The base config: the adversarial fixture `quick.toml` cut to 200 steps, with the lines an
/// edit may touch (every `key = value` line before `[stop]`).
fn base() -> (Vec<String>, Vec<usize>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../grainwave-cli/tests/adversarial/quick.toml");
    let text = std::fs::read_to_string(path).unwrap().replace("step_limit = 2000", "step_limit = 200");
    let lines: Vec<String> = text.lines().map(str::to_string).collect();
    let stop = lines.iter().position(|l| l.trim() == "[stop]").expect("quick.toml has [stop]");
    let editable = (0..stop).filter(|&k| lines[k].contains('=') && !lines[k].starts_with("experiment")).collect();
    (lines, editable)
}

/// One edit: (which editable line, what to do, a number that picks the replacement or the
/// power of ten).
type Edit = (usize, u8, usize);

/// Values put in place of a number.
const NUMBERS: &[&str] = &["0", "-1", "1e308", "-1e308", "5e-324", "nan", "inf", "1e-12", "1e30", "0.5", "2", "4294967296"];

/// `value` with every number in it multiplied by `factor` (arrays and inline tables included).
fn scale_numbers(value: &str, factor: f64) -> String {
    let mut out = String::new();
    let mut token = String::new();
    let flush = |token: &mut String, out: &mut String| {
        match token.parse::<f64>() {
            Ok(v) if !token.is_empty() => out.push_str(&format!("{:e}", v * factor)),
            _ => out.push_str(token),
        }
        token.clear();
    };
    for c in value.chars() {
        if c.is_ascii_alphanumeric() || c == '.' || c == '-' || c == '+' || c == '_' {
            token.push(c);
        } else {
            flush(&mut token, &mut out);
            out.push(c);
        }
    }
    flush(&mut token, &mut out);
    out
}

fn apply(lines: &[String], editable: &[usize], edits: &[Edit]) -> String {
    let mut lines = lines.to_vec();
    // one edit per line (the first drawn for it), applied from the last line up, so that a
    // removal leaves the others in place
    let mut edits: Vec<Edit> = edits.iter().enumerate().filter(|(i, e)| !edits[..*i].iter().any(|f| f.0 % editable.len() == e.0 % editable.len())).map(|(_, e)| *e).collect();
    edits.sort_by_key(|e| std::cmp::Reverse(editable[e.0 % editable.len()]));
    for (which, what, r) in edits {
        let k = editable[which % editable.len()];
        let eq = lines[k].find('=').expect("an editable line has a value");
        let (key, value) = (lines[k][..eq].to_string(), lines[k][eq + 1..].to_string());
        match what % 20 {
            // every number of the value scaled by a power of ten in 1e-12 … 1e12
            0..=9 => lines[k] = format!("{key}= {}", scale_numbers(&value, 10f64.powi((r % 25) as i32 - 12))),
            // a number replaced by an extreme
            10..=14 => lines[k] = format!("{key}= {}", NUMBERS[r % NUMBERS.len()]),
            // a wrong shape or type
            15..=17 => lines[k] = format!("{key}= {}", REPLACEMENTS[r % REPLACEMENTS.len()]),
            // the line removed (the key takes its default, or is missing)
            _ => {
                lines.remove(k);
            }
        }
    }
    lines.join("\n")
}

/// How a run ended.
#[derive(Debug, PartialEq)]
enum End {
    Rejected,
    Ran,
    Failed,
    OverBudget,
}

/// Checks `text`; runs it when accepted, interrupted after `BUDGET`. A panic fails the case.
fn check_and_run(text: &str, dir: &Path) -> Result<End, TestCaseError> {
    let src = ConfigSource::from_text("edited quick.toml", text);
    if let Err(e) = registry::check(&src) {
        if std::env::var_os("GRAINWAVE_PROPTEST_VERBOSE").is_some() {
            eprintln!("refused: {}", e.message);
        }
        prop_assert!(!e.message.is_empty() && e.message.len() < 2000, "check's message: {:?}", e.message);
        return Ok(End::Rejected);
    }
    let _ = std::fs::remove_dir_all(dir);
    let watchdog = Watchdog::start(BUDGET);
    let mut rep = SilentReporter;
    // a worker pool of its own, as the command-line program has: on the process's global pool
    // the run would queue behind the units of the tests running beside it, and its budget with it
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().expect("a pool of two worker threads");
    let result = pool.install(|| RunContext::new(dir, &mut rep, watchdog.flag()).and_then(|mut ctx| registry::run(&src, &mut ctx)));
    drop(watchdog);
    let _ = std::fs::remove_dir_all(dir);
    Ok(match result {
        Ok(_) => End::Ran,
        Err(ExperimentError::Interrupted { .. }) => End::OverBudget,
        Err(e) => {
            let m = e.to_string();
            prop_assert!(!m.is_empty() && m.len() < 4000, "run's message: {m:?}");
            End::Failed
        }
    })
}

#[test]
fn accepted_simulation_configs_run_or_fail_with_a_message() {
    let cases = std::env::var("GRAINWAVE_PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(64);
    let config = Config { cases, rng_seed: RngSeed::Fixed(21), failure_persistence: None, max_shrink_iters: 200, ..Config::default() };
    let (lines, editable) = base();
    let dir = std::env::temp_dir().join(format!("grainwave-run-property-{}", std::process::id()));
    let counts: [AtomicUsize; 4] = Default::default();
    let mut runner = TestRunner::new(config);
    let strategy = prop::collection::vec((0..editable.len(), any::<u8>(), 0..100usize), 1..=3);
    let outcome = runner.run(&strategy, |edits| {
        let text = apply(&lines, &editable, &edits);
        let end = check_and_run(&text, &dir)?;
        counts[end as usize].fetch_add(1, Ordering::Relaxed);
        Ok(())
    });
    let _ = std::fs::remove_dir_all(&dir);
    let [rejected, ran, failed, over] = counts.map(|c| c.into_inner());
    eprintln!("{cases} cases: {rejected} refused by check, {ran} ran, {failed} failed with a message, {over} stopped by the {BUDGET:?} budget; no panic");
    if let Err(e) = outcome {
        panic!("{e}");
    }
    assert_eq!(rejected + ran + failed + over, cases as usize);
    // the edits exercise both sides of `check`, and some accepted configs run to their step limit
    assert!(rejected > 0 && ran > 0, "{rejected} refused, {ran} ran");
}
