//! Property: **a config that `check` accepts does not fail `run` at its start for a reason of
//! its configuration.** Configs are generated from the config schema: small committed examples
//! of every protocol, each changed at one key at a time — every key the protocol's JSON schema
//! defines (the keys of `docs/config.md`, present in the example or not) and every value the
//! example writes (inside inline tables and arrays of tables too) — to a value drawn for the
//! key's type: boundary numbers (0, −1, subnormal, tiny, huge, 2³², NaN, which the parser
//! refuses), wrong types, empty and very long strings and lists, unknown choices, the key
//! removed. Each config is checked as `grainwave check` checks it (`registry::check` and
//! `check_inputs`); an accepted one is run into a fresh directory for a short wall-clock budget
//! (`BUDGET`), then interrupted the way Ctrl-C interrupts it.
//!
//! A run that ends with an error of the input class (exit code 2: `is_input_error`), or with
//! failed units whose reasons are of that class (an invalid value, an inconsistent set-up, an
//! initial overlap), is a mismatch: `check` should have refused the config. So is a panic in
//! either, and so is a run that does not stop within `STOP_WITHIN` of the interrupt. Run-time
//! failures (a blow-up, no equilibrium) are not mismatches: only running finds them.
//!
//! The cases are drawn with a fixed seed; `GRAINWAVE_CHECK_RUN_CASES` sets their number
//! (default `CASES`, under a minute in a release build).

use grainwave_experiments::config::ConfigSource;
use grainwave_experiments::protocol::{RunContext, SilentReporter};
use grainwave_experiments::registry;
use grainwave_experiments::ExperimentError;
use grainwave_experiments::config::reference;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use super::watchdog::Watchdog;
use std::time::{Duration, Instant};
use toml::Value;

/// Cases drawn by default.
const CASES: usize = 400;

/// Wall-clock budget of one run before it is interrupted: a failure of the set-up shows within
/// it (the runs below build their state in well under this).
const BUDGET: Duration = Duration::from_millis(250);

/// How soon a run must stop once interrupted (Ctrl-C is honoured within a second; this leaves
/// room for a loaded machine).
const STOP_WITHIN: Duration = Duration::from_secs(20);

/// The base configs: the smallest committed example of each protocol (a few hundred grains or
/// fewer), and the adversarial fixture with a wall of each kind.
const BASES: &[&str] = &[
    "examples/settle-pile.toml",
    "crates/grainwave-cli/tests/adversarial/quick.toml",
    "examples/e1-chain.toml",
    "examples/e1-lattice.toml",
    "examples/e1-pulse-2d.toml",
    "examples/e2-biaxial.toml",
    "examples/e3-lattice.toml",
    "examples/e3-slab.toml",
];

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A key to change: a path of table keys and array indices, and the schema's type in words
/// (`number`, `list of number`, `one of …`, …) or the type of the value the example writes.
#[derive(Clone, Debug)]
struct Key {
    path: Vec<Step>,
    kind: String,
}

#[derive(Clone, Debug, PartialEq)]
enum Step {
    Key(String),
    Index(usize),
}

fn show(path: &[Step]) -> String {
    let mut s = String::new();
    for p in path {
        match p {
            Step::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            Step::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// The keys of the schema (`docs/config.md`'s tables); a `[]` (array of tables) is its first
/// element.
fn schema_keys(protocol: &str) -> Vec<Key> {
    let entry = registry::protocol(protocol).expect("a protocol of the registry");
    let mut keys = Vec::new();
    for section in reference::sections(&(entry.schema)()) {
        for k in section.keys {
            let mut path = Vec::new();
            for part in k.path.split('.') {
                match part.strip_suffix("[]") {
                    Some(name) => {
                        path.push(Step::Key(name.to_string()));
                        path.push(Step::Index(0));
                    }
                    None => path.push(Step::Key(part.to_string())),
                }
            }
            keys.push(Key { path, kind: k.kind });
        }
    }
    keys
}

/// Every value the example writes, by its TOML type (inline tables and arrays of tables walked).
fn value_keys(v: &Value, path: &mut Vec<Step>, out: &mut Vec<Key>) {
    match v {
        Value::Table(t) => {
            for (k, x) in t {
                path.push(Step::Key(k.clone()));
                value_keys(x, path, out);
                path.pop();
            }
        }
        Value::Array(a) if a.iter().all(Value::is_table) && !a.is_empty() => {
            for (i, x) in a.iter().enumerate().take(2) {
                path.push(Step::Index(i));
                value_keys(x, path, out);
                path.pop();
            }
        }
        _ => {
            let kind = match v {
                Value::Integer(_) => "integer".to_string(),
                Value::Float(_) => "number".to_string(),
                Value::Boolean(_) => "boolean".to_string(),
                Value::String(_) => "string".to_string(),
                Value::Array(a) => match a.first() {
                    Some(Value::Integer(_)) | Some(Value::Float(_)) => "list of number".to_string(),
                    Some(Value::String(_)) => "list of string".to_string(),
                    _ => "list".to_string(),
                },
                _ => "value".to_string(),
            };
            out.push(Key { path: path.clone(), kind });
        }
    }
}

/// The values tried for a key of type `kind` (`current`: the value the example gives, if any).
fn values_for(kind: &str, current: Option<&Value>) -> Vec<Option<Value>> {
    let f = Value::Float;
    let long_list = |x: Value, n: usize| Value::Array(vec![x; n]);
    let mut v: Vec<Option<Value>> = vec![None]; // the key removed
    let kind = kind.trim_end_matches(" (optional)");
    if kind.starts_with("list") {
        v.push(Some(Value::Array(vec![])));
        v.push(Some(f(0.0)));
        v.push(Some(Value::String("x".into())));
        let item = match current.and_then(Value::as_array).and_then(|a| a.first()) {
            Some(x) => x.clone(),
            None if kind.contains("string") => Value::String("a".into()),
            None => f(1.0),
        };
        v.push(Some(long_list(item.clone(), 3)));
        v.push(Some(long_list(item.clone(), 100_000)));
        if let Some(a) = current.and_then(Value::as_array) {
            // one element changed to an extreme, the others kept
            for x in [f(0.0), f(-1.0), f(5e-324), f(1e308), f(-1e308), f(f64::NAN), Value::Integer(4294967296)] {
                let mut b = a.clone();
                if let Some(first) = b.last_mut() {
                    *first = x;
                    v.push(Some(Value::Array(b)));
                }
            }
            if a.len() > 1 {
                // the same value twice
                let mut b = a.clone();
                b[1] = b[0].clone();
                v.push(Some(Value::Array(b)));
            }
        } else {
            v.push(Some(Value::Array(vec![f(1e308), f(-1e308)])));
            v.push(Some(Value::Array(vec![f(0.0), f(0.0)])));
        }
        return v;
    }
    match kind {
        "number" => {
            for x in [0.0, -0.0, -1.0, 5e-324, 1e-300, 1e-12, 0.5, 2.0, 1e12, 1e300, -1e300, 1e308, 4294967296.0, f64::NAN, f64::INFINITY] {
                v.push(Some(f(x)));
            }
            v.push(Some(Value::String("1".into())));
        }
        "integer" => {
            for x in [0, -1, 1, 2, 4294967295, 4294967296, i64::MAX] {
                v.push(Some(Value::Integer(x)));
            }
            v.push(Some(f(2.5)));
        }
        "boolean" => {
            v.push(Some(Value::Boolean(true)));
            v.push(Some(Value::Boolean(false)));
            v.push(Some(Value::Integer(1)));
        }
        "string" => {
            for s in ["", "a/../b", "\u{7}", "é", "x".repeat(10_000).as_str(), "none"] {
                v.push(Some(Value::String(s.to_string())));
            }
        }
        _ if kind.starts_with("one of") => {
            // every choice the schema lists, and one it does not
            for c in kind.trim_start_matches("one of ").split(", ") {
                v.push(Some(Value::String(c.trim_matches('`').to_string())));
            }
            v.push(Some(Value::String("unknown".into())));
            v.push(Some(f(0.0)));
        }
        _ => {
            // a tagged choice, a vector or a value of several types
            v.push(Some(f(0.0)));
            v.push(Some(f(1e308)));
            v.push(Some(Value::String("x".into())));
            v.push(Some(Value::Table(Default::default())));
            v.push(Some(Value::Array(vec![f(1.0), f(0.0)])));
        }
    }
    v
}

fn get<'a>(v: &'a Value, path: &[Step]) -> Option<&'a Value> {
    let mut cur = v;
    for p in path {
        cur = match p {
            Step::Key(k) => cur.as_table()?.get(k)?,
            Step::Index(i) => cur.as_array()?.get(*i)?,
        };
    }
    Some(cur)
}

/// `doc` with the value at `path` set to `value` (or removed); `None` when a table or array on
/// the way is missing and cannot be made (an absent array of tables).
fn set(doc: &Value, path: &[Step], value: Option<Value>) -> Option<Value> {
    let mut doc = doc.clone();
    let mut cur = &mut doc;
    for (i, p) in path.iter().enumerate() {
        let last = i + 1 == path.len();
        match p {
            Step::Key(k) => {
                let t = cur.as_table_mut()?;
                if last {
                    match value {
                        Some(v) => {
                            t.insert(k.clone(), v);
                        }
                        None => {
                            t.remove(k)?;
                        }
                    }
                    return Some(doc);
                }
                if !t.contains_key(k) {
                    if matches!(path[i + 1], Step::Index(_)) {
                        return None;
                    }
                    t.insert(k.clone(), Value::Table(Default::default()));
                }
                cur = t.get_mut(k)?;
            }
            Step::Index(n) => {
                let a = cur.as_array_mut()?;
                if last {
                    return None;
                }
                cur = a.get_mut(*n)?;
            }
        }
    }
    None
}

/// One generated config.
struct Case {
    base: &'static str,
    key: String,
    value: String,
    text: String,
}

/// How a case ended.
#[derive(Debug, Default)]
struct Counts {
    refused: usize,
    ran: usize,
    interrupted: usize,
    failed_at_run_time: usize,
    mismatches: Vec<String>,
    /// A run did not stop after the interrupt: it still runs, so the cases end there.
    stuck: bool,
}

/// True when a unit's failure line is of the input class (what `check` should have refused).
fn input_reason(line: &str) -> bool {
    // a blow-up's diagnosis names the limit that stopped it (`key `max_overlap_fraction``): not an input fault
    !line.contains("numerical blow-up") && ["invalid value for `", "inconsistent set-up", "overlap by", "unknown ", "key `"].iter().any(|m| line.contains(m))
}

fn is_mismatch(e: &ExperimentError) -> bool {
    match e {
        ExperimentError::AllFailed { failures, .. } | ExperimentError::UnitsFailed { failures, .. } => {
            failures.iter().any(|f| input_reason(f))
        }
        ExperimentError::Interrupted { .. } => false,
        e => e.is_input_error(),
    }
}

fn run_case(case: &Case, dir: &Path, counts: &mut Counts) {
    let label = format!("{} with `{}` = {}", case.base, case.key, case.value);
    let src = ConfigSource::from_text(case.base, &case.text);
    let checked = std::panic::catch_unwind(|| registry::check(&src).and_then(|_| registry::check_inputs(&src)));
    match checked {
        Err(_) => {
            counts.mismatches.push(format!("{label}: check panicked"));
            return;
        }
        Ok(Err(_)) => {
            counts.refused += 1;
            return;
        }
        Ok(Ok(())) => {}
    }
    let _ = std::fs::remove_dir_all(dir);
    let watchdog = Watchdog::start(BUDGET);
    let flag = watchdog.flag();
    // the run in a thread of its own, so that one that does not stop after the interrupt is
    // reported (and the cases stop) instead of holding the test for ever; and in a worker pool
    // of its own, as the command-line program runs it: on the process's global pool it would
    // queue behind the units of the tests running beside it (a unit holds a worker until it
    // ends, tens of seconds for the examples' runs), and that wait is not the run's
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().expect("a pool of two worker threads");
    let (finished, outcome) = mpsc::channel();
    {
        let (dir, base, text) = (dir.to_path_buf(), case.base, case.text.clone());
        std::thread::spawn(move || {
            let src = ConfigSource::from_text(base, &text);
            let result = pool.install(|| {
                std::panic::catch_unwind(|| {
                    let mut rep = SilentReporter;
                    RunContext::new(&dir, &mut rep, flag).and_then(|mut ctx| registry::run(&src, &mut ctx))
                })
            });
            let _ = finished.send(result);
        });
    }
    let Ok(result) = outcome.recv_timeout(BUDGET + STOP_WITHIN) else {
        counts.mismatches.push(format!("{label}: the run did not stop within {STOP_WITHIN:?} of the interrupt"));
        counts.stuck = true;
        return;
    };
    drop(watchdog);
    let _ = std::fs::remove_dir_all(dir);
    match result {
        Err(_) => counts.mismatches.push(format!("{label}: run panicked")),
        Ok(Ok(_)) => counts.ran += 1,
        Ok(Err(ExperimentError::Interrupted { .. })) => counts.interrupted += 1,
        Ok(Err(e)) if is_mismatch(&e) => {
            let m = grainwave_experiments::error_chain(&e, ": ");
            counts.mismatches.push(format!("{label}: check accepted it, run failed: {}", m.chars().take(400).collect::<String>()))
        }
        Ok(Err(e)) => {
            if std::env::var_os("GRAINWAVE_CHECK_RUN_VERBOSE").is_some() {
                let m = grainwave_experiments::error_chain(&e, ": ");
                eprintln!("run-time failure: {label}: {}", m.chars().take(300).collect::<String>());
            }
            counts.failed_at_run_time += 1
        }
    }
}

fn short(v: &Option<Value>) -> String {
    match v {
        None => "(removed)".into(),
        Some(v) => {
            let s = v.to_string();
            if s.len() > 40 {
                format!("{}… ({} bytes)", &s[..30], s.len())
            } else {
                s
            }
        }
    }
}

/// Every (base, key, value) case, in a fixed order.
fn all_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    for base in BASES {
        let text = std::fs::read_to_string(repo().join(base)).unwrap();
        let doc: Value = toml::from_str(&text).unwrap();
        let protocol = doc.get("experiment").and_then(Value::as_str).unwrap_or("simulation").to_string();
        let mut keys = schema_keys(&protocol);
        let mut mine = Vec::new();
        value_keys(&doc, &mut Vec::new(), &mut mine);
        for k in mine {
            if !keys.iter().any(|s| s.path == k.path) {
                keys.push(k);
            }
        }
        for key in keys {
            if key.path == [Step::Key("experiment".into())] {
                continue;
            }
            let current = get(&doc, &key.path);
            for value in values_for(&key.kind, current) {
                let shown = short(&value);
                if let Some(new) = set(&doc, &key.path, value) {
                    cases.push(Case { base, key: show(&key.path), value: shown, text: toml::to_string(&new).unwrap() });
                }
            }
        }
    }
    cases
}

/// Fisher–Yates with SplitMix64 from `seed`: the same order on every machine.
fn shuffle<T>(v: &mut [T], seed: u64) {
    let mut state = seed;
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    for i in (1..v.len()).rev() {
        let j = (next() % (i as u64 + 1)) as usize;
        v.swap(i, j);
    }
}

#[test]
fn a_config_check_accepts_does_not_fail_at_the_start_of_its_run_for_a_config_reason() {
    let n = std::env::var("GRAINWAVE_CHECK_RUN_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(CASES);
    let start = Instant::now();
    // the bases themselves are valid
    for base in BASES {
        let src = ConfigSource::from_file(&repo().join(base)).unwrap();
        registry::check(&src).unwrap_or_else(|e| panic!("{base}: {}", e.message));
    }
    let mut cases = all_cases();
    let total = cases.len();
    shuffle(&mut cases, 41);
    cases.truncate(n);
    let dir = std::env::temp_dir().join(format!("grainwave-check-run-{}", std::process::id()));
    let mut counts = Counts::default();
    let mut done = 0;
    for case in &cases {
        run_case(case, &dir, &mut counts);
        done += 1;
        if counts.stuck {
            break;
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!(
        "{} of {total} generated configs in {:.1} s: {} refused by check, {} ran to their end, {} interrupted after {BUDGET:?}, \
         {} failed at run time (not for a config reason), {} mismatches",
        done,
        start.elapsed().as_secs_f64(),
        counts.refused,
        counts.ran,
        counts.interrupted,
        counts.failed_at_run_time,
        counts.mismatches.len()
    );
    for m in &counts.mismatches {
        eprintln!("  {m}");
    }
    assert_eq!(cases.len(), n.min(total));
    assert_eq!(counts.refused + counts.ran + counts.interrupted + counts.failed_at_run_time + counts.mismatches.len(), done);
    assert!(counts.refused > 0 && counts.ran + counts.interrupted > 0, "both sides of check are exercised");
    assert!(counts.mismatches.is_empty(), "{} configs pass check and fail run for a config reason", counts.mismatches.len());
}
