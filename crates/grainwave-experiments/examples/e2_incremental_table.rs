//! The incremental (p_a → 0±) pulse speeds of E2 static states beside the engine's replays of the
//! same states (docs/e2.md, "The incremental limit").
//!
//! For each earlier E2 run given as `label=RUN_DIR` (a run whose replays `stop500_g3`, the static
//! state, and `nonsliding_state`, the same with μ = 2, hold a `final.gwck`, and whose
//! `summary.json` holds the wall-pulse replays `static` and `nonsliding` of those states), it runs
//! an `e2` config with `source.dir = RUN_DIR` into `OUT/<label>/` (nothing is written into
//! RUN_DIR) with incremental replays of the static state — branch rules `incremental` (amplitudes
//! 1 and −1), `stick` and `free` — and of the non-sliding state (`incremental`, 1 and −1), and
//! writes `OUT/speeds.csv`:
//!
//! `state,replay,rule,amplitude,speed_maximum,speed_first_lobe,at_limit,at_rolling_cap,slipped,stuck_again,seconds`
//!
//! (`slipped`: contacts that slipped at some time, tangentially or at the rolling cap;
//! `stuck_again`: of those, the ones that switched more than once) with the engine's rows (`rule = dem`, |p_a| = 1e−10 … 1e−8 of `static` and `nonsliding`) beside
//! the incremental ones; speeds in v_a, seconds the wall-clock of the replay (per amplitude for the
//! incremental ones). The replays' own `strips`, `fit_range` and `arrival` are read from the run's
//! `config.resolved.toml` (replay `static`), so both use the same strip fit.
//!
//! ```text
//! cargo run --release -p grainwave-experiments --example e2_incremental_table -- OUT s1=RUN1 s2=RUN2 ...
//! ```
use grainwave_experiments::config::ConfigSource;
use grainwave_experiments::protocol::{RunContext, SilentReporter};
use grainwave_experiments::registry;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

fn fail(m: String) -> ! {
    eprintln!("e2_incremental_table: {m}");
    std::process::exit(1)
}

fn read_json(p: &Path) -> serde_json::Value {
    let bytes = std::fs::read(p).unwrap_or_else(|e| fail(format!("cannot read {}: {e}", p.display())));
    serde_json::from_slice(&bytes).unwrap_or_else(|e| fail(format!("{}: {e}", p.display())))
}

/// strips, fit_range and arrival of replay `static` in the run's resolved config.
fn fit_settings(run: &Path) -> String {
    let text = std::fs::read_to_string(run.join("config.resolved.toml")).unwrap_or_else(|e| fail(format!("{}: {e}", run.display())));
    let v: toml::Value = toml::from_str(&text).unwrap_or_else(|e| fail(format!("{}: {e}", run.display())));
    let replays = v.get("replays").and_then(|r| r.as_array()).cloned().unwrap_or_default();
    let r = replays.iter().find(|r| r.get("name").and_then(|n| n.as_str()) == Some("static")).unwrap_or_else(|| fail(format!("{}: no replay `static`", run.display())));
    let strips = r.get("strips").and_then(|x| x.as_integer()).unwrap_or(128);
    let fit = r.get("fit_range").and_then(|x| x.as_array()).map(|a| a.iter().filter_map(|x| x.as_float()).collect::<Vec<_>>()).unwrap_or(vec![0.1, 0.9]);
    let arrival = r.get("arrival").and_then(|x| x.as_str()).unwrap_or("maximum").to_string();
    let duration = r.get("duration").and_then(|x| x.as_float()).unwrap_or(2.0);
    let sample = r.get("sample_interval").and_then(|x| x.as_float()).unwrap_or(0.005);
    format!("strips = {strips}\nfit_range = [{}, {}]\narrival = \"{arrival}\"\nduration = {duration}\nsample_interval = {sample}\n", fit[0], fit[1])
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        fail("usage: e2_incremental_table OUT label=RUN_DIR ...".into());
    }
    let out = PathBuf::from(&args[0]);
    std::fs::create_dir_all(&out).unwrap_or_else(|e| fail(format!("{}: {e}", out.display())));
    let mut csv = String::from("state,replay,rule,amplitude,speed_maximum,speed_first_lobe,at_limit,at_rolling_cap,slipped,stuck_again,seconds\n");
    let f = |x: &serde_json::Value| x.as_f64().map(|v| format!("{v:.6}")).unwrap_or_default();
    for arg in &args[1..] {
        let (label, run) = arg.split_once('=').unwrap_or_else(|| fail(format!("`{arg}` (allowed: label=RUN_DIR)")));
        let run = PathBuf::from(run);
        let settings = fit_settings(&run);
        let replay = |name: &str, from: &str, rule: &str, amplitudes: &str| {
            format!("[[replays]]\nname = \"{name}\"\nfrom = \"{from}\"\nmodification = \"incremental\"\nbranches = \"{rule}\"\namplitudes = {amplitudes}\n{settings}\n")
        };
        let text = format!(
            "experiment = \"e2\"\n[source]\ndir = \"{}\"\n[output]\nplots = false\nfields = false\n\n{}{}{}{}",
            run.display(),
            replay("incremental", "stop500_g3", "incremental", "[1, -1]"),
            replay("stick", "stop500_g3", "stick", "[1]"),
            replay("free", "stop500_g3", "free", "[1]"),
            replay("nonsliding_incremental", "nonsliding_state", "incremental", "[1, -1]"),
        );
        let dir = out.join(label);
        let _ = std::fs::remove_dir_all(&dir);
        let src = ConfigSource::from_text(&format!("{label} incremental"), &text);
        let mut rep = SilentReporter;
        let mut ctx = RunContext::new(&dir, &mut rep, Arc::new(AtomicBool::new(false))).unwrap_or_else(|e| fail(format!("{label}: {e}")));
        let t = std::time::Instant::now();
        registry::run(&src, &mut ctx).unwrap_or_else(|e| fail(format!("{label}: {e}")));
        eprintln!("{label}: incremental replays in {:.1} s", t.elapsed().as_secs_f64());
        let ours = read_json(&dir.join("summary.json"));
        for r in ours["replays"].as_array().into_iter().flatten() {
            let name = r["name"].as_str().unwrap_or("");
            let info = read_json(&dir.join("replays").join(name).join("incremental.json"));
            for (p, i) in r["pairs"].as_array().into_iter().flatten().zip(info.as_array().into_iter().flatten()) {
                let _ = writeln!(
                    csv,
                    "{label},{name},{},{},{},{},{},{},{},{},{:.3}",
                    i["branches"].as_str().unwrap_or(""),
                    p["amplitude"],
                    f(&p["speed_maximum"]),
                    f(&p["speed_first_lobe"]),
                    i["counts"]["at_limit"],
                    i["counts"]["at_rolling_cap"],
                    i["slipped"],
                    i["slipped_and_stuck_again"],
                    i["seconds"].as_f64().unwrap_or(0.0)
                );
            }
        }
        let dem = read_json(&run.join("summary.json"));
        for r in dem["replays"].as_array().into_iter().flatten() {
            let name = r["name"].as_str().unwrap_or("");
            if name != "static" && name != "nonsliding" {
                continue;
            }
            let pairs = r["pairs"].as_array().cloned().unwrap_or_default();
            let seconds = r["seconds"].as_f64().unwrap_or(0.0) / pairs.len().max(1) as f64;
            for p in pairs {
                let a = p["amplitude"].as_f64().unwrap_or(0.0);
                if !(a.abs() <= 1.01e-8) {
                    continue;
                }
                let _ = writeln!(csv, "{label},{name},dem,{a:e},{},{},{},,,,{seconds:.3}", f(&p["speed_maximum"]), f(&p["speed_first_lobe"]), p["mobilised"][0]);
            }
        }
    }
    let path = out.join("speeds.csv");
    std::fs::write(&path, csv).unwrap_or_else(|e| fail(format!("{}: {e}", path.display())));
    println!("{}", path.display());
}
