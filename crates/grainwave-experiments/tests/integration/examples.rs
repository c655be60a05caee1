//! Every example config runs and produces its plots, non-empty. Examples that are too big for
//! the test suite (full-size studies) carry a line `# test: skip (<reason>)`.

use grainwave_experiments::config::ConfigSource;
use grainwave_experiments::protocol::{RunContext, SilentReporter};
use grainwave_experiments::registry;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

#[test]
fn every_example_runs_and_draws_its_plots() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut examples: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|e| e == "toml")).collect();
    examples.sort();
    assert!(!examples.is_empty());
    let mut ran = 0;
    for path in examples {
        let text = std::fs::read_to_string(&path).unwrap();
        if text.lines().any(|l| l.trim_start().starts_with("# test: skip")) {
            eprintln!("skipping {} (marked `# test: skip`)", path.display());
            continue;
        }
        let out = std::env::temp_dir().join(format!("grainwave-example-{}-{}", std::process::id(), path.file_stem().unwrap().to_string_lossy()));
        let _ = std::fs::remove_dir_all(&out);
        let src = ConfigSource::from_file(&path).unwrap();
        let mut rep = SilentReporter;
        let mut ctx = RunContext::new(&out, &mut rep, Arc::new(AtomicBool::new(false))).unwrap();
        let t = std::time::Instant::now();
        let summary = registry::run(&src, &mut ctx).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        eprintln!("{}: {:.1} s", path.display(), t.elapsed().as_secs_f64());
        let files: Vec<String> = summary.report["files"].as_array().expect("the summary lists its files").iter().map(|f| f.as_str().unwrap().to_string()).collect();
        let plots: Vec<&String> = files.iter().filter(|f| f.ends_with(".png") || f.ends_with(".svg")).collect();
        assert!(!plots.is_empty(), "{} draws no plot", path.display());
        for f in plots {
            let bytes = std::fs::read(out.join(f)).unwrap_or_else(|e| panic!("{}: {f}: {e}", path.display()));
            if f.ends_with(".png") {
                assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.len() > 2000, "{f}: not a non-empty PNG");
            } else {
                let s = String::from_utf8_lossy(&bytes);
                assert!(s.contains("<svg") && s.contains("<text") && (s.contains("<polyline") || s.contains("<circle") || s.contains("<path")), "{f}: empty SVG");
            }
        }
        for f in &files {
            assert!(out.join(f).exists(), "{}: listed file {f} missing", path.display());
        }
        ran += 1;
    }
    assert!(ran >= 1);
}

#[test]
fn every_example_passes_validation_including_the_skipped_ones() {
    // The full-size studies are not run by the suite, but a typo in one of their keys must still
    // fail it.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut checked = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let path = e.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let src = ConfigSource::from_file(&path).unwrap();
            registry::check(&src).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            checked += 1;
        }
    }
    assert!(checked >= 10, "only {checked} examples found");
}

#[test]
fn every_example_plans_units_with_unique_ids_and_inputs_before_them() {
    // the plan a generic driver lists (registry::plan): ids unique, every declared input an
    // earlier unit, so the plan order is a valid order to run it in; an e2 replay reads the
    // replay named in its `from`, else the loading (none when the checkpoints are another run's)
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut e2_checked = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let path = e.unwrap().path();
        if !path.extension().is_some_and(|e| e == "toml") {
            continue;
        }
        let src = ConfigSource::from_file(&path).unwrap();
        let units = registry::plan(&src).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let table: toml::Table = toml::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        // only e3's closed-form mode (the lattice's elastic constants) has no unit of work
        let closed_form = table.get("mode").and_then(|m| m.as_str()) == Some("lattice_elasticity");
        assert_eq!(units.is_empty(), closed_form, "{}: {} units", path.display(), units.len());
        let mut ids = std::collections::BTreeSet::new();
        for (k, u) in units.iter().enumerate() {
            assert!(ids.insert(u.id.clone()), "{}: id {} twice", path.display(), u.id);
            assert!(u.inputs.iter().all(|&i| i < k), "{}: {} reads a later unit", path.display(), u.id);
        }
        if table["experiment"].as_str() != Some("e2") {
            continue;
        }
        let own_loading = table.get("source").is_none();
        assert_eq!(units[0].id == "loading", own_loading, "{}", path.display());
        let replays = table.get("replays").and_then(|r| r.as_array()).cloned().unwrap_or_default();
        assert_eq!(units.len(), replays.len() + own_loading as usize, "{}", path.display());
        for (k, r) in replays.iter().enumerate() {
            let name = r.get("name").and_then(|n| n.as_str()).map(str::to_string).unwrap_or(format!("r{k}"));
            let u = units.iter().find(|u| u.id == format!("replay/{name}")).unwrap_or_else(|| panic!("{}: no unit for {name}", path.display()));
            // `from` names a replay of this config (an input unit) or, with `source.dir`, a
            // replay of the earlier run whose final state is read from disk (no input unit)
            let local = |from: &str| {
                replays.iter().enumerate().any(|(j, q)| q.get("name").and_then(|n| n.as_str()).map(str::to_string).unwrap_or(format!("r{j}")) == from)
            };
            let expected: Vec<String> = match r.get("from").and_then(|f| f.as_str()) {
                Some(from) if own_loading || local(from) => vec![format!("replay/{from}")],
                Some(_) => vec![],
                None if own_loading => vec!["loading".to_string()],
                None => vec![],
            };
            let got: Vec<String> = u.inputs.iter().map(|&i| units[i].id.clone()).collect();
            assert_eq!(got, expected, "{}: inputs of {}", path.display(), u.id);
        }
        e2_checked += 1;
    }
    assert!(e2_checked >= 3, "only {e2_checked} e2 examples");
}
