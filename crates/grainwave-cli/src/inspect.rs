//! `grainwave inspect FILE|DIR`: what a checkpoint, config or output directory holds, in plain
//! words.

use anyhow::{Context, Result};
use grainwave_experiments::engine::{decode, verify, Dim, Simulation, D2, D3};
use grainwave_experiments::engine::AnySimulation;
use grainwave_experiments::simulation::{SimulationState, TAG as SIMULATION_TAG};
use std::path::Path;

/// Describes `path`.
pub fn describe(path: &Path) -> Result<Vec<String>> {
    if path.is_dir() {
        return describe_dir(path);
    }
    // a checkpoint is a regular file: its size bounds the read (`inspect /dev/zero` is refused)
    let bytes = grainwave_experiments::engine::read_bytes(path).map_err(grainwave_experiments::ExperimentError::from)?;
    if bytes.starts_with(grainwave_experiments::engine::MAGIC) {
        return describe_checkpoint(path, &bytes);
    }
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_default();
    Ok(match ext.as_str() {
        "toml" => {
            let src = grainwave_experiments::config::ConfigSource::from_file(path)?;
            let mut v = vec![format!("{name}: a grainwave config")];
            match grainwave_experiments::registry::check(&src) {
                Ok(lines) => v.extend(lines.into_iter().map(|l| format!("  {l}"))),
                Err(e) => v.push(format!("  invalid: {e}")),
            }
            v
        }
        "json" => {
            let value: serde_json::Value = serde_json::from_slice(&bytes).with_context(|| format!("`{}` is not JSON", path.display()))?;
            let mut v = vec![format!("{name}: JSON with {} top-level entries", value.as_object().map_or(0, |o| o.len()))];
            if let Some(o) = value.as_object() {
                for (k, x) in o {
                    if !x.is_array() && !x.is_object() {
                        v.push(format!("  {k:28} {x}"));
                    }
                }
            }
            v
        }
        "csv" => {
            let text = String::from_utf8_lossy(&bytes);
            let mut lines = text.lines();
            let header = lines.next().unwrap_or("");
            vec![format!("{name}: CSV table, {} rows, columns: {}", lines.count(), header.replace(',', ", "))]
        }
        _ => vec![format!("{name}: {} bytes, not a format grainwave describes", bytes.len())],
    })
}

fn describe_sim<D: Dim>(s: &Simulation<D>, v: &mut Vec<String>) {
    let (rmin, rmax) = s.grains.radius_range();
    v.push(format!("  grains        {} {} ({}D), radii {:.4}–{:.4}, seed {}", s.len(), s.grains.kind.name(), D::D, rmin, rmax, s.seed));
    v.push(format!("  time          step {}, t = {:.6e}, dt = {:.4e}", s.step, s.time, s.dt));
    v.push(format!("  contacts      {} ({} sliding); neighbor list rebuilt {} times", s.counters.contacts, s.counters.sliding, s.nlist.builds));
    v.push(format!("  energy        kinetic {:.4e}, elastic {:.4e}", s.kinetic_energy(), s.elastic_energy()));
    for w in &s.domain.walls {
        v.push(format!("  wall {:9} load {:.6e}, moved {:.6e}", w.name, w.normal_load(), w.displacement()));
    }
    v.push(format!("  state hash    {:016x}", s.state_hash()));
}

fn describe_checkpoint(path: &Path, bytes: &[u8]) -> Result<Vec<String>> {
    let p = path.display().to_string();
    let (tag, body) = verify(bytes, &p)?;
    let mut v = vec![format!(
        "{}: grainwave checkpoint (format {}, {} bytes, checksum ok), holds `{tag}`",
        path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        // the file's own version (verified: 16 bytes or more), not the newest this program writes
        u32::from_le_bytes(bytes[8..12].try_into().unwrap()),
        body.len()
    )];
    match tag.as_str() {
        SIMULATION_TAG => {
            let state: SimulationState = decode(bytes, &tag, &p)?;
            v.push(format!(
                "  protocol      simulation, {}",
                match state.outcome {
                    Some(r) => format!("finished ({r:?})"),
                    None => "in progress — continue with `grainwave resume DIR`".into(),
                }
            ));
            v.push(format!("  recorded      {} series rows, {} snapshots", state.series.len(), state.snapshots.len()));
            match &state.sim {
                AnySimulation::D2(s) => describe_sim(s, &mut v),
                AnySimulation::D3(s) => describe_sim(s, &mut v),
            }
        }
        grainwave_experiments::e3::TAG => {
            let state: grainwave_experiments::e3::E3State = decode(bytes, &tag, &p)?;
            let count = |f: &[bool]| f.iter().filter(|&&d| d).count();
            v.push(format!(
                "  protocol      e3, mode {}, {}",
                state.config.mode.name(),
                if state.finished { "finished".to_string() } else { "in progress — continue with `grainwave resume DIR`".to_string() }
            ));
            v.push(format!(
                "  units         {}/{} reference states, {}/{} response runs done",
                count(&state.references_done),
                state.references_done.len(),
                count(&state.runs_done),
                state.runs_done.len()
            ));
        }
        grainwave_experiments::e3::work::REFERENCE_TAG => {
            let r: grainwave_experiments::e3::work::ReferenceResult = decode(bytes, &tag, &p)?;
            v.push(format!(
                "  e3 reference  {}converged after {} steps; floor load/weight {:.9}; bulk r = {:.4}",
                if r.outcome.converged { "" } else { "NOT " },
                r.outcome.steps,
                r.wall_loads[0] / r.weight,
                r.moduli_bulk.r
            ));
            describe_sim(&r.sim, &mut v);
        }
        grainwave_experiments::e3::work::RUN_TAG => {
            let r: grainwave_experiments::e3::work::StoredRun = decode(bytes, &tag, &p)?;
            let x = &r.result;
            v.push(format!(
                "  e3 response   F = {} m̄g: p(0)/F = {:?}, {} opened, {} created, {} sliding, {} profile",
                x.force,
                x.response_at_zero,
                x.counts.opened,
                x.counts.created,
                x.counts.sliding,
                x.classification.shape.name()
            ));
        }
        grainwave_experiments::e1::TAG => {
            let state: grainwave_experiments::e1::E1State = decode(bytes, &tag, &p)?;
            let plan = &state.plan;
            let dir = path.parent().unwrap_or(Path::new("."));
            let done = plan.tasks.iter().filter(|t| grainwave_experiments::e1::ensemble::load_result(dir, plan, t).is_some()).count();
            v.push(format!(
                "  protocol      e1 ({}), {}",
                plan.kind.name(),
                if state.finished { "finished".to_string() } else { "in progress — continue with `grainwave resume DIR`".to_string() }
            ));
            v.push(format!("  samples       {done} of {} done ({} groups × {} samples)", plan.tasks.len(), plan.groups.len(), plan.config.samples));
        }
        grainwave_experiments::e1::ensemble::PACKING_TAG | grainwave_experiments::e1::ensemble::PREPARING_TAG => {
            let f: grainwave_experiments::e1::prepare::PackingFile = decode(bytes, &tag, &p)?;
            v.push(format!(
                "  e1 packing    {}, {} steps, {} quenches, max acceleration {:.3e}, piston {:.3e}",
                if f.info.converged { "prepared (static equilibrium)" } else { "preparation in progress" },
                f.info.steps,
                f.info.quenches,
                f.info.max_acceleration,
                f.info.piston_acceleration
            ));
            match &f.sim {
                AnySimulation::D2(s) => describe_sim(s, &mut v),
                AnySimulation::D3(s) => describe_sim(s, &mut v),
            }
        }
        grainwave_experiments::e1::ensemble::RESULT_TAG => {
            let r: grainwave_experiments::e1::sample::SampleResult = decode(bytes, &tag, &p)?;
            v.push(format!("  e1 sample     seed {}, {} grains, L = {:.4}, {:.1} s", r.seed, r.grains, r.height, r.seconds));
            if let Some(f) = &r.failure {
                v.push(format!("  failed        {f}"));
            }
            if let Some(s) = &r.statistics {
                v.push(format!("  packing       Φ₂ = {:?}, z* = {:.4}, f₀ = {:.4}, σ₁/σ₂ = {:.4}", s.phi2, s.coordination_star, s.rattler_fraction, s.stress.ratio));
            }
            if let Some(m) = &r.moduli {
                v.push(format!("  moduli        C₁₁ = {:.4e}, C₂₂ = {:.4e}, C₃₃ = {:.4e}, c_ℓ = {:.4}, c_t = {:.4}", m.c11, m.c22, m.c33, m.longitudinal_speed, m.transverse_speed));
            }
            if let Some(m) = r.pulse.as_ref().and_then(|p| p.metrics.as_ref()) {
                v.push(format!("  pulse         leading edge {:.4}, peak {:.4} (A = {:.4e})", m.leading_edge_time, m.peak_time, m.peak_amplitude));
            }
        }
        "simulation-2d" => describe_sim::<D2>(&decode(bytes, &tag, &p)?, &mut v),
        "simulation-3d" => describe_sim::<D3>(&decode(bytes, &tag, &p)?, &mut v),
        grainwave_experiments::e1::EARLIER_TAG | grainwave_experiments::e2::EARLIER_TAG | grainwave_experiments::e3::EARLIER_TAG => {
            v.push("  layout        an earlier one (the state without its plan): `grainwave resume DIR` and `grainwave plot DIR` read it, and the resumed run saves the current layout".into());
        }
        _ => {}
    }
    Ok(v)
}

/// What each file of an output directory is.
fn file_role(name: &str) -> &'static str {
    match name {
        "summary.json" => "every scalar result, with units and version",
        "config.resolved.toml" => "the config with every default filled in (re-runnable)",
        "checkpoint.gwck" => "complete state (resume or inspect it)",
        "run.log" => "log of the run",
        "series.csv" | "series.npz" => "time series (one row per record)",
        "grains.csv" => "final grains, one row per grain",
        n if n.ends_with(".pvd") => "ParaView collection of snapshots",
        n if n.ends_with(".vtp") || n.ends_with(".vtu") => "VTK snapshot (ParaView)",
        n if n.ends_with(".png") || n.ends_with(".svg") => "plot",
        n if n.ends_with(".npy") || n.ends_with(".npz") => "NumPy arrays",
        n if n.ends_with(".csv") => "table",
        _ => "",
    }
}

/// The largest `summary.json` that `inspect` reads [bytes]. A run's summary is a few kB to a few
/// MB; anything larger is not one (a FIFO or a device would otherwise be read without end).
const MAX_SUMMARY_BYTES: u64 = 64 << 20;

/// The bytes of a run's `summary.json`: `None` when there is none; an error (as text) when it is
/// not a regular file or is longer than [`MAX_SUMMARY_BYTES`].
fn read_summary(path: &Path) -> std::result::Result<Option<Vec<u8>>, String> {
    let Ok(meta) = std::fs::metadata(path) else { return Ok(None) };
    if !meta.is_file() {
        return Err("not a regular file".into());
    }
    let mut bytes = Vec::new();
    let read = std::fs::File::open(path).and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, MAX_SUMMARY_BYTES + 1), &mut bytes));
    match read {
        Err(e) => Err(e.to_string()),
        Ok(_) if bytes.len() as u64 > MAX_SUMMARY_BYTES => Err(format!("longer than {} MiB (allowed: at most {MAX_SUMMARY_BYTES} bytes)", MAX_SUMMARY_BYTES >> 20)),
        Ok(_) => Ok(Some(bytes)),
    }
}

fn describe_dir(dir: &Path) -> Result<Vec<String>> {
    let mut v = vec![format!("{}: output directory", dir.display())];
    let summary = dir.join("summary.json");
    let bytes = match read_summary(&summary) {
        Ok(b) => b,
        Err(why) => {
            v.push(format!("  summary.json not read: {why}"));
            None
        }
    };
    if let Some(bytes) = bytes {
        if let Ok(s) = serde_json::from_slice::<serde_json::Value>(&bytes) {
            let get = |k: &str| s.get(k).map(|x| x.to_string()).unwrap_or_else(|| "?".into());
            if s.get("experiment").and_then(|e| e.as_str()) == Some("e3") {
                v.push(format!(
                    "  e3 run, mode {}, {} parameter set(s), {} relaxation(s) not converged",
                    get("mode").trim_matches('"'),
                    s.get("groups").and_then(|g| g.as_array()).map_or(0, |g| g.len()),
                    s.get("not_converged").and_then(|g| g.as_array()).map_or(0, |g| g.len())
                ));
            } else if s.get("experiment").and_then(|e| e.as_str()) == Some("e1") {
                v.push(format!("  e1 run ({}), {} of {} samples done, complete: {}", get("study").trim_matches('"'), get("done"), get("tasks"), get("complete")));
            } else {
                v.push(format!(
                    "  {} run, stopped: {}, {} steps, t = {}, {} grains",
                    get("experiment").trim_matches('"'),
                    get("stop_reason").trim_matches('"'),
                    get("steps"),
                    get("time"),
                    get("grains")
                ));
            }
        }
    }
    if let Some(why) = grainwave_experiments::protocol::failure_of(dir) {
        v.push(format!("  FAILED: {}", why.lines().next().unwrap_or("")));
        for l in why.lines().skip(1).take(20) {
            v.push(format!("    {l}"));
        }
        v.push(format!("  (`grainwave resume --retry {}` tries again after a change; `run --overwrite` starts afresh)", dir.display()));
    } else if !dir.join("summary.json").exists() && dir.join("checkpoint.gwck").exists() {
        v.push("  no summary.json yet: the run is in progress or was interrupted (`grainwave resume` continues it)".into());
    }
    let mut entries: Vec<_> = std::fs::read_dir(dir)?.filter_map(|e| e.ok()).collect();
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let name = e.file_name().to_string_lossy().into_owned();
        let meta = e.metadata()?;
        if meta.is_dir() {
            let n = std::fs::read_dir(e.path()).map(|r| r.count()).unwrap_or(0);
            v.push(format!("  {name:24} directory, {n} files"));
        } else {
            v.push(format!("  {name:24} {:>10} bytes  {}", meta.len(), file_role(&name)));
        }
    }
    v.extend(describe_declared(dir));
    if dir.join("checkpoint.gwck").exists() {
        v.push(String::new());
        let lines = describe_checkpoint(&dir.join("checkpoint.gwck"), &grainwave_experiments::engine::read_bytes(&dir.join("checkpoint.gwck")).map_err(grainwave_experiments::ExperimentError::from)?)?;
        // the checkpoint of a failed run is the state saved before the failure, not a run in progress
        let failed = grainwave_experiments::protocol::failure_of(dir).is_some();
        let in_progress = "in progress — continue with `grainwave resume DIR`";
        v.extend(lines.into_iter().map(|l| if failed { l.replace(in_progress, "saved before the failure (`grainwave resume --retry DIR` continues from it)") } else { l }));
    }
    Ok(v)
}

/// The most files of one declaration that [`describe_declared`] names one by one; more are
/// counted under their pattern.
const NAMED_PER_DECLARATION: usize = 8;

/// The files under `dir` by the output declarations of its protocol (found from its
/// `config.resolved.toml` or its checkpoint: `Registry::of_directory`): per declaration the files
/// that match it (named, or counted when there are many) with its description, then the files
/// that match no declaration.
fn describe_declared(dir: &Path) -> Vec<String> {
    let mut v = vec![String::new()];
    let Some(entry) = grainwave_experiments::registry::REGISTRY.of_directory(dir) else {
        v.push("  files: the protocol of this directory is unknown (no readable config.resolved.toml or checkpoint.gwck)".into());
        return v;
    };
    let files = match grainwave_experiments::outputs::files_under(dir) {
        Ok(f) => f,
        Err(e) => {
            v.push(format!("  files: cannot list the directory: {e}"));
            return v;
        }
    };
    v.push(format!("  files, by the outputs `{}` declares (docs/outputs.md):", entry.name));
    let mut undeclared = Vec::new();
    let mut by_declaration: Vec<Vec<&str>> = vec![Vec::new(); entry.outputs.len()];
    for f in &files {
        match entry.outputs.iter().position(|o| o.matches(f)) {
            Some(k) => by_declaration[k].push(f.as_str()),
            None => undeclared.push(f.as_str()),
        }
    }
    for (o, found) in entry.outputs.iter().zip(&by_declaration) {
        match found.len() {
            0 => {}
            n if n <= NAMED_PER_DECLARATION => {
                for f in found {
                    v.push(format!("    {f:40} {}: {}", o.format.name(), o.description));
                }
            }
            n => v.push(format!("    {:40} {n} files, {}: {}", o.pattern, o.format.name(), o.description)),
        }
    }
    if undeclared.is_empty() {
        v.push(format!("  every file ({}) matches a declaration", files.len()));
    } else {
        v.push(format!("  {} file(s) match no declaration of `{}`:", undeclared.len(), entry.name));
        for f in undeclared {
            v.push(format!("    {f}"));
        }
    }
    v
}
