//! Outputs of `e2`: the loading series and plots, the replays (fields, arrivals, strip fits,
//! arrival-time maps, M_s(t)), and `summary.json`.

use super::arrival::StripFit;
use super::biaxial::{self, Loading};
use super::config::{E2Config, ReplayConfig};
use super::model::Units;
use super::replay::{Arrivals, PairResult};
use super::{E2State, Stage};
use grainwave_study::Result;
use grainwave_core::prelude::*;
use grainwave_core::snapshot::Snapshot;
use grainwave_io::plot::{LinePlot, PackingPicture};
use grainwave_io::{CsvTable, Series, write_csv_atomic};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Outcome of the loading, for the summary.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LoadingReport {
    /// `compression` or `extension`.
    pub direction: String,
    /// ε_yy at the end (compression positive).
    pub final_strain_yy: f64,
    /// ε_xx at the end (compression positive).
    pub final_strain_xx: f64,
    /// σ_yy at the end [p*].
    pub final_stress_yy: f64,
    /// σ_xx at the end [p*].
    pub final_stress_xx: f64,
    /// Largest σ_yy/σ_xx along the way.
    pub peak_stress_ratio: f64,
    /// Sliding contacts at the end.
    pub final_sliding: u64,
    /// Duration of the loading [t*].
    pub time: f64,
    /// Checkpoints written.
    pub checkpoints: usize,
    /// Rows of the series.
    pub samples: usize,
    /// Wall-clock seconds of the loading [s].
    pub seconds: f64,
}

/// One paired replay (one amplitude).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PairReport {
    /// Amplitude (p_a, or the relative radius change).
    pub amplitude: f64,
    /// Pulse speed from the strip fit [v_a] (None: too few strips with arrivals), by the replay's
    /// arrival definition.
    pub speed: Option<f64>,
    /// Wall pulses: the speed by the SPEC arrival, the maximum of |δv_x| [v_a].
    pub speed_maximum: Option<f64>,
    /// Wall pulses: the speed by the first-lobe arrival [v_a].
    pub speed_first_lobe: Option<f64>,
    /// Wall pulses: incident amplitude A_inc [v_a].
    pub incident_amplitude: f64,
    /// Wall pulses: round-off floor of δv [v_a]; A_inc / floor is the usable dynamic range.
    pub resolution_floor: f64,
    /// Strips in the fit.
    pub strips_used: usize,
    /// Grains with an arrival.
    pub arrived: usize,
    /// Largest |δv| component [v_a].
    pub max_difference: f64,
    /// Largest |M_s(with) − M_s(without)| over the replay.
    pub max_sliding_difference: i64,
    /// M_s(with) − M_s(without) at the end.
    pub final_sliding_difference: i64,
    /// M_s at rest by mobilisation, |F_t| ≥ (1 − 1e−6) μ F_n (SPEC §6.2): at the start, and at
    /// the end with and without the perturbation.
    pub mobilised: [u64; 3],
    /// Wall pulses: of the contacts mobilised at the start, those that the pulse's mean strain
    /// increment (a compression or rarefaction along the wall normal) pushes further into sliding
    /// (the affine test of `model::sliding_drive`).
    #[serde(default)]
    pub pushed_on: u64,
    /// The engine's cap flag count M_s at the start, and at the end with and without the
    /// perturbation (differs from `mobilised` at rest; see docs/e2.md).
    pub flagged: [u64; 3],
    /// Samples of the field.
    pub samples: usize,
    /// Files of this amplitude (relative to the output directory).
    pub files: Vec<String>,
}

/// A single replay.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SingleReport {
    /// σ_yy at the end [p*].
    pub final_stress_yy: f64,
    /// σ_xx at the end [p*].
    pub final_stress_xx: f64,
    /// M_s by the engine's cap flag at the start and at the end.
    pub sliding: [u64; 2],
    /// M_s at rest by mobilisation, |F_t| ≥ (1 − 1e−6) μ F_n (SPEC §6.2), at the start and at the
    /// end (the count to use for static states; see docs/e2.md).
    pub mobilised: [u64; 2],
    /// Kinetic energy at the start and at the end [p* L*²].
    pub kinetic_energy: [f64; 2],
    /// Velocity factor γ applied (`velocity_scale`; 1 otherwise).
    pub factor: f64,
    /// Duration of the replay [t_a].
    pub duration: f64,
}

/// One `[[replays]]` entry.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ReplayReport {
    /// Name (directory `replays/<name>/`).
    pub name: String,
    /// Checkpoint index replayed.
    pub checkpoint: u64,
    /// ε_yy of that checkpoint.
    pub strain_yy: f64,
    /// The modification.
    pub modification: String,
    /// Units of the source run.
    pub units: Units,
    /// Paired replays, one per amplitude.
    pub pairs: Vec<PairReport>,
    /// The single replay.
    pub single: Option<SingleReport>,
    /// Wall-clock seconds [s].
    pub seconds: f64,
}

/// The summary of an `e2` run (`summary.json`).
#[derive(Clone, Debug, Serialize)]
pub struct E2Summary {
    /// Protocol name.
    pub experiment: String,
    /// grainwave version.
    pub version: String,
    /// Seed.
    pub seed: u64,
    /// Grains N.
    pub grains: usize,
    /// Unit of every quantity, by name.
    pub unit_system: BTreeMap<String, String>,
    /// The units (engine values; engine: d̄ = 1, grain density 1, p* = 1).
    pub units: Option<Units>,
    /// The preparation.
    pub preparation: biaxial::PreparationInfo,
    /// The loading.
    pub loading: Option<LoadingReport>,
    /// The replays.
    pub replays: Vec<ReplayReport>,
    /// The Δc/c₀ decomposition (SPEC §6.6), one row per amplitude.
    pub static_limit: Vec<StaticLimitRow>,
    /// The anisotropy (SPEC §6.6), one row per state and amplitude.
    pub anisotropy: Vec<AnisotropyRow>,
    /// Every amplitude of every paired replay: speed, M_s before and after the pulse.
    pub pulses: Vec<PulseRow>,
    /// Wall-clock seconds of this process [s].
    pub wall_seconds: f64,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
}

fn rel(dir: &Path, p: &Path) -> String {
    p.strip_prefix(dir).unwrap_or(p).display().to_string()
}

fn push_plot(dir: &Path, files: &mut Vec<String>, r: grainwave_io::Result<grainwave_io::plot::PlotFiles>) -> Result<()> {
    let f = r?;
    files.push(rel(dir, &f.png));
    files.push(rel(dir, &f.svg));
    Ok(())
}

/// Files of the loading stage (relative paths).
pub fn write_loading(dir: &Path, cfg: &E2Config, l: &Loading) -> Result<Vec<String>> {
    let mut files = Vec::new();
    let col = |k: usize| l.series.iter().map(|r| r[k]).collect::<Vec<f64>>();
    let mut series = Series::from_columns(biaxial::SERIES_COLUMNS.iter().enumerate().map(|(k, n)| (n.to_string(), col(k))))?;
    series.mark_counts(&["sliding", "contacts", "step"])?;
    let f = series.write(dir, "loading")?;
    files.push(rel(dir, &f.npz));
    files.push(rel(dir, &f.csv));
    if !l.checkpoints.is_empty() {
        files.push("checkpoints/index.csv".into());
    }
    if cfg.output.plots && l.series.len() >= 2 {
        let eps: Vec<f64> = col(1).iter().map(|e| 100.0 * e).collect();
        push_plot(
            dir,
            &mut files,
            LinePlot::new(&format!("Biaxial {}: stresses", cfg.loading.direction.name()))
                .x_label("ε_yy (%)")
                .y_label("stress / p*")
                .series("σ_yy (top wall)", &eps, &col(3))
                .series("σ_xx (right wall)", &eps, &col(4))
                .save(dir, "stress_strain"),
        )?;
        push_plot(
            dir,
            &mut files,
            LinePlot::new("Sliding contacts").x_label("ε_yy (%)").y_label("M_s").series("M_s", &eps, &col(5)).save(dir, "sliding_strain"),
        )?;
        // a log axis cannot show KE = 0 (e.g. right after a quench): those samples are left out
        let (ke_x, ke): (Vec<f64>, Vec<f64>) = eps.iter().zip(col(7)).filter(|(_, k)| *k > 0.0).map(|(e, k)| (*e, k)).unzip();
        if ke.len() >= 2 {
            push_plot(
                dir,
                &mut files,
                LinePlot::new("Kinetic energy")
                    .x_label("ε_yy (%)")
                    .y_label("KE / (p* L*²)")
                    .log_y()
                    .series("KE", &ke_x, &ke)
                    .save(dir, "kinetic_energy_strain"),
            )?;
        }
    }
    Ok(files)
}

/// Writes `a<ai>_branches.csv` of an incremental replay: one row per contact at the Coulomb
/// limit (or the rolling cap) — grain ids i, j (j < 0: wall −1 − j), steps on the slip branch,
/// branch switches, time of the first slip and of the last switch [t_a] (empty: never), and
/// whether it slips at the end.
pub fn write_branches(dir: &Path, ai: usize, info: &super::incremental::IncrementalInfo, u: &Units) -> Result<()> {
    let in_t_a = |x: Option<f64>| x.map(|x| x / u.acoustic_time);
    let h = &info.history;
    let mut t = CsvTable::new();
    t.push_u32("i", info.pairs.iter().map(|p| p.0))?;
    t.push_i64("j", info.pairs.iter().map(|p| p.1))?;
    t.push_u64("slip_steps", h.iter().map(|h| h.slip_steps))?;
    t.push_u64("switches", h.iter().map(|h| h.switches))?;
    t.push_opt_f64("first_slip", h.iter().map(|h| in_t_a(h.first_slip)))?;
    t.push_opt_f64("last_switch", h.iter().map(|h| in_t_a(h.last_switch)))?;
    t.push_u32("slipping_at_end", h.iter().map(|h| h.slipping as u32))?;
    write_csv_atomic(&dir.join(format!("a{ai}_branches.csv")), &t)?;
    Ok(())
}

/// Writes `incremental.json` of an incremental replay: per amplitude the branch rule, the
/// contact counts of the state (at the limit, at the rolling cap, nearly open), how many contacts
/// slipped and how many slipped and stuck again, the steps, step length [engine time], impulse
/// and the wall-clock seconds.
pub fn write_incremental_summary(dir: &Path, infos: &[(f64, f64, super::incremental::IncrementalInfo)]) -> Result<()> {
    let rows: Vec<serde_json::Value> = infos
        .iter()
        .map(|(a, seconds, i)| {
            serde_json::json!({
                "amplitude": a,
                "branches": i.branches,
                "counts": i.counts,
                "slipped": i.history.iter().filter(|h| h.first_slip.is_some()).count(),
                "slipped_and_stuck_again": i.history.iter().filter(|h| h.switches > 1).count(),
                "steps": i.steps,
                "dt": i.dt,
                "impulse": i.impulse,
                "seconds": seconds,
            })
        })
        .collect();
    let text = serde_json::to_string_pretty(&rows).expect("json of plain values");
    grainwave_core::checkpoint::atomic_write(&dir.join("incremental.json"), text.as_bytes())?;
    Ok(())
}

/// Writes the files of amplitude `ai` (value `a`) of a paired replay into `dir` (=
/// `replays/<name>/`, under the output directory `out`): the field, the sample times, the
/// arrivals, the sliding series, the strip fit and the plots; returns its report and its curve
/// of M_s(with) − M_s(without) against t/t_a.
#[allow(clippy::too_many_arguments)]
pub fn write_pair(
    out: &Path,
    dir: &Path,
    cfg: &E2Config,
    rc: &ReplayConfig,
    u: &Units,
    snapshot: &Snapshot<D2>,
    ai: usize,
    a: f64,
    r: &PairResult,
    arr: &Arrivals,
) -> Result<(PairReport, (Vec<f64>, Vec<f64>))> {
    let stem = format!("a{ai}");
    let mut files = Vec::new();
    let times_ta: Vec<f64> = r.times.iter().map(|t| t / u.acoustic_time).collect();
    if cfg.output.fields {
        let p = dir.join(format!("{stem}_field.npy"));
        grainwave_io::npy::write_npy(&p, &[r.times.len(), r.grains, 2], &r.field)?;
        files.push(rel(out, &p));
    }
    let p = dir.join(format!("{stem}_times.npy"));
    grainwave_io::npy::write_npy(&p, &[times_ta.len()], &times_ta)?;
    files.push(rel(out, &p));
    let p = dir.join(format!("{stem}_arrivals.csv"));
    let mut t = CsvTable::new();
    t.push_u64("id", 0..r.grains as u64)?;
    t.push_f64("x", r.positions[..r.grains].iter().map(|p| p.x / u.length))?;
    t.push_f64("y", r.positions[..r.grains].iter().map(|p| p.y / u.length))?;
    t.push_f64("distance", arr.distance[..r.grains].iter().map(|s| s / u.length))?;
    t.push_opt_f64("arrival", arr.time[..r.grains].iter().map(|t| t.map(|t| t / u.acoustic_time)))?;
    write_csv_atomic(&p, &t)?;
    files.push(rel(out, &p));
    let p = dir.join(format!("{stem}_sliding.csv"));
    let mut t = CsvTable::new();
    t.push_f64("time", times_ta.iter().copied())?;
    t.push_u64("sliding", r.sliding.iter().copied())?;
    t.push_u64("sliding_reference", r.sliding_reference.iter().copied())?;
    write_csv_atomic(&p, &t)?;
    files.push(rel(out, &p));
    let diff: Vec<f64> = r.sliding.iter().zip(&r.sliding_reference).map(|(a, b)| *a as f64 - *b as f64).collect();
    let in_v_a = |fit: &Option<StripFit>| fit.as_ref().map(|f| f.speed / u.acoustic_velocity);
    let (speed, by_max, by_lobe) = (in_v_a(&arr.fit), in_v_a(&arr.fit_maximum), in_v_a(&arr.fit_first_lobe));
    if let Some(f) = &arr.fit {
        let p = dir.join(format!("{stem}_strips.csv"));
        let mut t = CsvTable::new();
        t.push_f64("distance", f.distance.iter().map(|s| s / u.length))?;
        t.push_f64("arrival", f.time.iter().map(|t| t / u.acoustic_time))?;
        write_csv_atomic(&p, &t)?;
        files.push(rel(out, &p));
    }
    if cfg.output.plots {
        // arrival map, grains in storage order of the snapshot
        let t_f = rc.duration * u.acoustic_time;
        let times: Vec<f64> = snapshot.id.iter().map(|&id| arr.time[id as usize].unwrap_or(f64::NAN)).collect();
        push_plot(
            out,
            &mut files,
            PackingPicture::new(snapshot, &format!("Arrival times, {} a = {a:e} (J = {})", rc.modification.name(), rc.bands))
                .x_label("x (d̄)")
                .y_label("y (d̄)")
                .arrival_times(&times, t_f, rc.bands)
                .save(dir, &format!("{stem}_arrival_map")),
        )?;
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for (s, t) in arr.distance.iter().zip(&arr.time) {
            if let Some(t) = t {
                xs.push(t / u.acoustic_time);
                ys.push(s / u.length);
            }
        }
        if !xs.is_empty() {
            let mut plot = LinePlot::new(&format!("Arrival vs distance, a = {a:e}"))
                .x_label("arrival time / t_a")
                .y_label("distance from source / L*")
                .scatter("grains", &xs, &ys);
            if let Some(f) = &arr.fit {
                let ft: Vec<f64> = f.time.iter().map(|t| t / u.acoustic_time).collect();
                let fs: Vec<f64> = f.distance.iter().map(|s| s / u.length).collect();
                plot = plot.scatter("3rd earliest per strip", &ft, &fs);
                let (t0, t1) = (ft.iter().cloned().fold(f64::INFINITY, f64::min), ft.iter().cloned().fold(0.0, f64::max));
                let line = |t: f64| (f.speed * t * u.acoustic_time + f.intercept) / u.length;
                plot = plot.series(&format!("fit: c = {:.4} v_a", f.speed / u.acoustic_velocity), &[t0, t1], &[line(t0), line(t1)]);
            }
            push_plot(out, &mut files, plot.save(dir, &format!("{stem}_arrival_fit")))?;
        }
    }
    let max_sd = diff.iter().map(|d| d.abs()).fold(0.0, f64::max) as i64;
    let report = PairReport {
        amplitude: a,
        speed,
        speed_maximum: by_max,
        speed_first_lobe: by_lobe,
        incident_amplitude: arr.incident / u.acoustic_velocity,
        resolution_floor: arr.floor / u.acoustic_velocity,
        strips_used: arr.fit.as_ref().map(|f| f.strips_used).unwrap_or(0),
        arrived: arr.time.iter().filter(|t| t.is_some()).count(),
        max_difference: r.max_difference / u.acoustic_velocity,
        max_sliding_difference: max_sd,
        final_sliding_difference: diff.last().copied().unwrap_or(0.0) as i64,
        mobilised: r.mobilised,
        pushed_on: r.pushed_on,
        flagged: [r.sliding.first().copied().unwrap_or(0), r.sliding.last().copied().unwrap_or(0), r.sliding_reference.last().copied().unwrap_or(0)],
        samples: r.times.len(),
        files,
    };
    Ok((report, (times_ta, diff)))
}

/// The plots of a whole paired replay `name` (every amplitude): M_s(with) − M_s(without) and the
/// pulse speed against the amplitude; the files are added to the first amplitude's report.
pub fn write_pair_plots(out: &Path, dir: &Path, cfg: &E2Config, name: &str, report: &mut ReplayReport, curves: &[(Vec<f64>, Vec<f64>)]) -> Result<()> {
    if !cfg.output.plots {
        return Ok(());
    }
    let mut files = Vec::new();
    let mut plot = LinePlot::new(&format!("Sliding contacts after the perturbation ({name})")).x_label("t / t_a").y_label("M_s(with) − M_s(without)");
    for (p, (t, d)) in report.pairs.iter().zip(curves) {
        plot = plot.series(&format!("a = {:e}", p.amplitude), t, d);
    }
    push_plot(out, &mut files, plot.save(dir, "sliding_difference"))?;
    // the amplitudes with a strip fit (whose speed is the replay's arrival definition)
    let speeds: Vec<(f64, f64)> = report.pairs.iter().filter_map(|p| p.speed.map(|c| (p.amplitude, c))).collect();
    let pos: Vec<(f64, f64)> = speeds.iter().filter(|(a, _)| *a > 0.0).cloned().collect();
    let neg: Vec<(f64, f64)> = speeds.iter().filter(|(a, _)| *a < 0.0).cloned().collect();
    if pos.len() + neg.len() >= 2 {
        let mut plot = LinePlot::new(&format!("Pulse speed vs amplitude ({name})")).x_label("|a|").y_label("c / v_a").log_x();
        if !pos.is_empty() {
            plot = plot.series("compression (a > 0)", &pos.iter().map(|p| p.0).collect::<Vec<_>>(), &pos.iter().map(|p| p.1).collect::<Vec<_>>());
        }
        if !neg.is_empty() {
            plot = plot.series("rarefaction (a < 0)", &neg.iter().map(|p| -p.0).collect::<Vec<_>>(), &neg.iter().map(|p| p.1).collect::<Vec<_>>());
        }
        push_plot(out, &mut files, plot.save(dir, "speed_vs_amplitude"))?;
    }
    if let Some(p) = report.pairs.first_mut() {
        p.files.extend(files);
    }
    Ok(())
}

/// Writes the series of a single replay `name` (rows: time [t_a], σ_yy, σ_xx [p*], M_s, KE
/// [p* L*²]) and its plots into `dir`.
pub fn write_single(dir: &Path, cfg: &E2Config, rc: &ReplayConfig, name: &str, rows: &[[f64; 5]]) -> Result<()> {
    let col = |k: usize| rows.iter().map(|r| r[k]).collect::<Vec<f64>>();
    let mut series = Series::from_columns(["time", "stress_yy", "stress_xx", "sliding", "kinetic_energy"].iter().enumerate().map(|(k, n)| (n.to_string(), col(k))))?;
    series.mark_counts(&["sliding"])?;
    series.write(dir, "series")?;
    if cfg.output.plots {
        let (ke_t, ke): (Vec<f64>, Vec<f64>) = col(0).iter().zip(col(4)).filter(|(_, k)| *k > 0.0).map(|(t, k)| (*t, k)).unzip();
        if ke.len() >= 2 {
            LinePlot::new(&format!("Replay {name}: {}", rc.modification.name()))
                .x_label("t / t_a")
                .y_label("KE / (p* L*²)")
                .log_y()
                .series("KE", &ke_t, &ke)
                .save(dir, "kinetic_energy")?;
        }
        LinePlot::new(&format!("Replay {name}: sliding contacts")).x_label("t / t_a").y_label("M_s").series("M_s", &col(0), &col(3)).save(dir, "sliding")?;
    }
    Ok(())
}

/// One amplitude of the Δc/c₀ decomposition (speeds in v_a of each replay's own source run).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StaticLimitRow {
    /// `compression` or `extension` (the sign of ε_yy of the deforming state's checkpoint).
    pub direction: String,
    /// p_a [t* for δ pulses] (its sign: compression > 0, rarefaction < 0).
    pub amplitude: f64,
    /// c₀ (undeformed) [v_a].
    pub undeformed: Option<f64>,
    /// c_ns (static, μ = 2) [v_a].
    pub non_sliding: Option<f64>,
    /// c_s (static) [v_a].
    pub static_state: Option<f64>,
    /// c_d (deforming) [v_a].
    pub deforming: Option<f64>,
    /// (c₀ − c_ns)/c₀.
    pub contact_loss: Option<f64>,
    /// (c_ns − c_s)/c₀.
    pub sliding: Option<f64>,
    /// (c_s − c_d)/c₀.
    pub strain_rate: Option<f64>,
    /// (c₀ − c_d)/c₀.
    pub total: Option<f64>,
    /// M_s at rest (mobilised) of the static state before the pulse, and after it (with, without).
    pub static_mobilised: [u64; 3],
    /// Of the static state's mobilised contacts, those that the pulse's mean strain increment
    /// pushes further into sliding (`model::sliding_drive`).
    #[serde(default)]
    pub static_pushed_on: u64,
    /// The same decomposition by SPEC §6.5's arrival (the time of the maximum of |δv_x|), which
    /// the replays may not have used (`arrival = "first_lobe"`): c₀, c_ns, c_s, c_d [v_a], then
    /// contact loss, sliding, strain rate and total [fractions of c₀].
    #[serde(default)]
    pub by_maximum: [Option<f64>; 8],
}

/// One amplitude of one state of the anisotropy table.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct AnisotropyRow {
    /// Label of the state (`anisotropy.state`, `anisotropy.states[].state`).
    pub state: String,
    /// p_a.
    pub amplitude: f64,
    /// c₁ along y [v_a].
    pub along_y: Option<f64>,
    /// c₂ along x [v_a].
    pub along_x: Option<f64>,
    /// A = 2(c₁ − c₂)/(c₁ + c₂).
    pub anisotropy: Option<f64>,
}

/// The anisotropy table of the replays named in `[anisotropy]`, state by state (empty when not
/// configured; a state whose replays have not run yet is left out).
pub fn anisotropy_rows(cfg: &E2Config, replays: &[ReplayReport]) -> Vec<AnisotropyRow> {
    let mut rows = Vec::new();
    for (state, y, x) in cfg.anisotropy.pairs() {
        let (Some(y), Some(x)) = (replays.iter().find(|r| r.name == y), replays.iter().find(|r| r.name == x)) else {
            continue;
        };
        rows.extend((0..y.pairs.len()).map(|k| {
            let c1 = y.pairs[k].speed;
            let c2 = x.pairs.get(k).and_then(|p| p.speed);
            AnisotropyRow {
                state: state.clone(),
                amplitude: y.pairs[k].amplitude,
                along_y: c1,
                along_x: c2,
                anisotropy: match (c1, c2) {
                    (Some(a), Some(b)) => Some(2.0 * (a - b) / (a + b)),
                    _ => None,
                },
            }
        }));
    }
    rows
}

/// One amplitude of one paired replay: speed and M_s at rest before and after the pulse
/// (`pulses.csv`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PulseRow {
    /// Replay name.
    pub replay: String,
    /// Checkpoint of the loading it descends from.
    pub checkpoint: u64,
    /// ε_yy of that checkpoint.
    pub strain_yy: f64,
    /// Amplitude (p_a [t*] for a δ pulse).
    pub amplitude: f64,
    /// Pulse speed [v_a].
    pub speed: Option<f64>,
    /// M_s by mobilisation at the start, at the end with the pulse, at the end without.
    pub mobilised: [u64; 3],
    /// Of the contacts mobilised at the start, those the pulse's mean strain increment pushes on.
    pub pushed_on: u64,
    /// M_s by the cap flag at the start, at the end with the pulse, at the end without.
    pub flagged: [u64; 3],
    /// Largest |M_s(with) − M_s(without)| (cap flag) during the replay.
    pub max_sliding_difference: i64,
}

/// Every amplitude of every paired replay, in the order of the config.
pub fn pulse_rows(replays: &[ReplayReport]) -> Vec<PulseRow> {
    replays
        .iter()
        .flat_map(|r| {
            r.pairs.iter().map(|p| PulseRow {
                replay: r.name.clone(),
                checkpoint: r.checkpoint,
                strain_yy: r.strain_yy,
                amplitude: p.amplitude,
                speed: p.speed,
                mobilised: p.mobilised,
                pushed_on: p.pushed_on,
                flagged: p.flagged,
                max_sliding_difference: p.max_sliding_difference,
            })
        })
        .collect()
}

/// The fraction of the contacts mobilised before a pulse that the pulse released,
/// R = (M_s(end without) − M_s(end with)) / M_s(start), by mobilisation (|F_t| ≥ (1 − 1e−6) μ F_n):
/// negative when the pulse set more contacts at the limit than it released. `None` without
/// mobilised contacts at the start.
pub fn released_fraction(row: &PulseRow) -> Option<f64> {
    let [start, with, without] = row.mobilised;
    (start > 0).then(|| (without as f64 - with as f64) / start as f64)
}

/// `pulses_released.png`: [`released_fraction`] against |p_a| (compression solid, rarefaction
/// dashed), one curve per start state — the wall-pulse replays that start from the same
/// checkpoint or the same earlier replay are one curve (e.g. `deforming` with 1e−10 … 1e−7 and a
/// second replay of the same checkpoint with 1e−6 … 1e−4) — for the start states with at least
/// four amplitudes of a sign: how much of the sliding a pulse of each amplitude disturbs.
fn write_released_plot(dir: &Path, cfg: &E2Config, rows: &[PulseRow]) -> Result<()> {
    let start_of = |name: &str| -> (String, String) {
        cfg.replays
            .iter()
            .enumerate()
            .find(|(k, q)| q.name.clone().unwrap_or(format!("r{k}")) == name && q.modification == super::config::Modification::WallPulse)
            .map(|(_, q)| match &q.from {
                Some(from) => (format!("from {from}"), name.to_string()),
                None => (format!("checkpoint {}", q.checkpoint), name.to_string()),
            })
            .unwrap_or_else(|| (name.to_string(), name.to_string()))
    };
    // start states in the order of the config, each labelled by its first replay's name
    let mut groups: Vec<(String, String, Vec<&PulseRow>)> = Vec::new();
    for r in rows {
        let (key, label) = start_of(&r.replay);
        match groups.iter_mut().find(|g| g.0 == key) {
            Some(g) => g.2.push(r),
            None => groups.push((key, label, vec![r])),
        }
    }
    let mut plot = LinePlot::new("Mobilised contacts released by a pulse").x_label("|p_a| [t*]").y_label("released fraction of M_s").log_x();
    let mut any = false;
    for (_, label, members) in &groups {
        for (sign, kind) in [(1.0, "compression"), (-1.0, "rarefaction")] {
            let mut pts: Vec<(f64, f64)> =
                members.iter().filter(|r| r.amplitude * sign > 0.0).filter_map(|r| released_fraction(r).map(|f| (r.amplitude.abs(), f))).collect();
            if pts.len() < 4 {
                continue;
            }
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            any = true;
            let x: Vec<f64> = pts.iter().map(|p| p.0).collect();
            let y: Vec<f64> = pts.iter().map(|p| p.1).collect();
            let name = format!("{label}, {kind}");
            plot = if sign > 0.0 { plot.series(&name, &x, &y) } else { plot.dashed(&name, &x, &y) };
        }
    }
    if any {
        plot.save(dir, "pulses_released")?;
    }
    Ok(())
}

/// The Δc/c₀ table of the replays named in `[static_limit]` (empty when not configured).
pub fn static_limit_rows(cfg: &E2Config, replays: &[ReplayReport]) -> Vec<StaticLimitRow> {
    let sl = &cfg.static_limit;
    let (Some(u), Some(ns), Some(st), Some(d)) = (&sl.undeformed, &sl.non_sliding, &sl.static_state, &sl.deforming) else {
        return Vec::new();
    };
    let find = |n: &str| replays.iter().find(|r| r.name == n);
    let (Some(u), Some(ns), Some(st), Some(d)) = (find(u), find(ns), find(st), find(d)) else {
        return Vec::new();
    };
    (0..u.pairs.len())
        .map(|k| {
            let c = |r: &ReplayReport| r.pairs.get(k).and_then(|p| p.speed);
            let (c0, cns, cs, cd) = (c(u), c(ns), c(st), c(d));
            let [contact_loss, sliding, strain_rate, total] = losses([c0, cns, cs, cd]);
            let m = |r: &ReplayReport| r.pairs.get(k).and_then(|p| p.speed_maximum);
            let by_max = [m(u), m(ns), m(st), m(d)];
            let [lm0, lm1, lm2, lm3] = losses(by_max);
            StaticLimitRow {
                direction: if d.strain_yy >= 0.0 { "compression" } else { "extension" }.into(),
                amplitude: u.pairs[k].amplitude,
                undeformed: c0,
                non_sliding: cns,
                static_state: cs,
                deforming: cd,
                contact_loss,
                sliding,
                strain_rate,
                total,
                static_mobilised: st.pairs.get(k).map(|p| p.mobilised).unwrap_or_default(),
                static_pushed_on: st.pairs.get(k).map(|p| p.pushed_on).unwrap_or_default(),
                by_maximum: [by_max[0], by_max[1], by_max[2], by_max[3], lm0, lm1, lm2, lm3],
            }
        })
        .collect()
}

/// The decomposition of SPEC §6.6 from the speeds [c₀, c_ns, c_s, c_d]: contact loss
/// (c₀ − c_ns)/c₀, sliding (c_ns − c_s)/c₀, strain rate (c_s − c_d)/c₀ and total (c₀ − c_d)/c₀
/// (None where a speed is missing).
fn losses([c0, cns, cs, cd]: [Option<f64>; 4]) -> [Option<f64>; 4] {
    let rel = |a: Option<f64>, b: Option<f64>| match (c0, a, b) {
        (Some(c0), Some(a), Some(b)) => Some((a - b) / c0),
        _ => None,
    };
    [rel(c0, cns), rel(cns, cs), rel(cs, cd), rel(c0, cd)]
}

fn write_static_limit(dir: &Path, cfg: &E2Config, rows: &[StaticLimitRow], replays: &[ReplayReport]) -> Result<()> {
    if rows.is_empty() {
        return Ok(());
    }
    let mut t = CsvTable::new();
    t.push_text("direction", rows.iter().map(|r| r.direction.as_str()))?;
    t.push_f64("amplitude", rows.iter().map(|r| r.amplitude))?;
    let speeds_and_losses: [(&str, fn(&StaticLimitRow) -> Option<f64>); 8] = [
        ("undeformed", |r| r.undeformed),
        ("non_sliding", |r| r.non_sliding),
        ("static", |r| r.static_state),
        ("deforming", |r| r.deforming),
        ("contact_loss", |r| r.contact_loss),
        ("sliding", |r| r.sliding),
        ("strain_rate", |r| r.strain_rate),
        ("total", |r| r.total),
    ];
    for (name, get) in speeds_and_losses {
        t.push_opt_f64(name, rows.iter().map(get))?;
    }
    // before the pulse and at its end with the pulse (index 2, without it, is not tabulated)
    t.push_u64("static_mobilised_before", rows.iter().map(|r| r.static_mobilised[0]))?;
    t.push_u64("static_mobilised_after", rows.iter().map(|r| r.static_mobilised[1]))?;
    t.push_u64("static_pushed_on", rows.iter().map(|r| r.static_pushed_on))?;
    // `by_maximum` in its order: c₀, c_ns, c_s, c_d, then the four losses
    for (k, (name, _)) in speeds_and_losses.iter().enumerate() {
        t.push_opt_f64(format!("{name}_maximum"), rows.iter().map(|r| r.by_maximum[k]))?;
    }
    write_csv_atomic(&dir.join("static_limit.csv"), &t)?;
    if cfg.output.plots {
        let mut plot = LinePlot::new("Pulse speed vs amplitude").x_label("|p_a|").y_label("c / v_a").log_x();
        let states: [(&str, fn(&StaticLimitRow) -> Option<f64>); 4] =
            [("undeformed", |r| r.undeformed), ("static, μ = 2", |r| r.non_sliding), ("static", |r| r.static_state), ("deforming", |r| r.deforming)];
        let mut any = false;
        for (label, get) in states {
            for (sign, name) in [(1.0, "compression"), (-1.0, "rarefaction")] {
                let pts: Vec<(f64, f64)> = rows.iter().filter(|r| r.amplitude * sign > 0.0).filter_map(|r| get(r).map(|c| (r.amplitude.abs(), c))).collect();
                if !pts.is_empty() {
                    any = true;
                    let x: Vec<f64> = pts.iter().map(|p| p.0).collect();
                    let y: Vec<f64> = pts.iter().map(|p| p.1).collect();
                    plot = if sign > 0.0 { plot.series(&format!("{label}, {name}"), &x, &y) } else { plot.dashed(&format!("{label}, {name}"), &x, &y) };
                }
            }
        }
        // the variants (other t_s, other γ): the same axes
        for name in &cfg.static_limit.variants {
            let Some(r) = replays.iter().find(|r| r.name == *name) else { continue };
            for (sign, kind) in [(1.0, "compression"), (-1.0, "rarefaction")] {
                let pts: Vec<(f64, f64)> = r.pairs.iter().filter(|p| p.amplitude * sign > 0.0).filter_map(|p| p.speed.map(|c| (p.amplitude.abs(), c))).collect();
                if !pts.is_empty() {
                    any = true;
                    let x: Vec<f64> = pts.iter().map(|p| p.0).collect();
                    let y: Vec<f64> = pts.iter().map(|p| p.1).collect();
                    plot = if sign > 0.0 { plot.series(&format!("{name}, {kind}"), &x, &y) } else { plot.dashed(&format!("{name}, {kind}"), &x, &y) };
                }
            }
        }
        if any {
            plot.save(dir, "static_limit_speeds")?;
        }
    }
    Ok(())
}

fn unit_system() -> BTreeMap<String, String> {
    let mut u = BTreeMap::new();
    for (k, v) in [
        ("engine", "d̄ = 1 (mean diameter), disks of unit thickness and material density 1, p* = 1"),
        ("units.*", "engine units; L* = √(M*/ρ*), t* = √(M*/p*), v_a = d̄√(K_n/m̄), t_a = L*/v_a"),
        ("preparation.time", "t*"),
        ("preparation.max_force", "p* d̄"),
        ("loading.*strain*", "dimensionless, compression positive"),
        ("loading.*stress*", "p*"),
        ("loading.time", "t*"),
        ("replays.*.pairs.*.speed", "v_a"),
        (
            "replays.*.pairs.*.amplitude",
            "wall_pulse delta: p_a, a time in t* (impulse p_a p* L_wall t*, SPEC §6.4); wall_pulse wavelet: dimensionless; radius: relative change",
        ),
        ("replays.*.pairs.*.mobilised / flagged", "contacts: M_s by |F_t| ≥ (1 − 1e−6) μ F_n / by the engine's cap flag"),
        ("replays.*.pairs.*.pushed_on, static_limit.*.static_pushed_on", "contacts: of those mobilised at the start, the ones the pulse's mean strain increment pushes further into sliding"),
        ("static_limit.*.by_maximum", "the decomposition by the SPEC arrival (maximum of |δv_x|): c₀, c_ns, c_s, c_d [v_a], contact loss, sliding, strain rate, total [fractions of c₀]"),
        ("static_limit.*", "v_a (speeds), fractions of c₀ (losses)"),
        ("replays.*.pairs.*.max_difference", "v_a"),
        ("replays.*.single.kinetic_energy", "p* L*²"),
        ("files: *_times.npy, *_arrivals.csv times", "t_a"),
        ("files: *_arrivals.csv positions and distances", "L*"),
        ("files: *_field.npy", "engine velocity (divide by units.acoustic_velocity for v_a)"),
        ("files: loading.* time / stress / kinetic_energy", "t* / p* / p* L*²"),
        ("seconds", "s (wall clock)"),
    ] {
        u.insert(k.to_string(), v.to_string());
    }
    u
}

fn walk(dir: &Path, root: &Path, out: &mut Vec<String>) {
    if let Ok(rd) = std::fs::read_dir(dir) {
        let mut entries: Vec<PathBuf> = rd.filter_map(|e| e.ok()).map(|e| e.path()).collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, root, out);
            } else {
                out.push(rel(root, &p));
            }
        }
    }
}

/// Writes `summary.json` and returns the summary (its `files` lists every file in the directory
/// except the checkpoints).
pub fn write_summary(dir: &Path, state: &E2State, wall_seconds: f64) -> Result<E2Summary> {
    let loading = state.loading.as_ref().filter(|l| !l.series.is_empty()).map(|l| {
        let last = l.series.last().expect("rows");
        LoadingReport {
            direction: state.config.loading.direction.name().into(),
            final_strain_yy: last[1],
            final_strain_xx: last[2],
            final_stress_yy: last[3],
            final_stress_xx: last[4],
            peak_stress_ratio: l.series.iter().map(|r| r[3] / r[4]).filter(|x| x.is_finite()).fold(0.0, f64::max),
            final_sliding: last[5] as u64,
            time: last[0],
            checkpoints: l.checkpoints.len(),
            samples: l.series.len(),
            seconds: l.seconds,
        }
    });
    let static_limit = static_limit_rows(&state.config, &state.replays);
    write_static_limit(dir, &state.config, &static_limit, &state.replays)?;
    let anisotropy = anisotropy_rows(&state.config, &state.replays);
    if !anisotropy.is_empty() {
        let mut t = CsvTable::new();
        t.push_text("state", anisotropy.iter().map(|r| r.state.as_str()))?;
        t.push_f64("amplitude", anisotropy.iter().map(|r| r.amplitude))?;
        t.push_opt_f64("along_y", anisotropy.iter().map(|r| r.along_y))?;
        t.push_opt_f64("along_x", anisotropy.iter().map(|r| r.along_x))?;
        t.push_opt_f64("anisotropy", anisotropy.iter().map(|r| r.anisotropy))?;
        write_csv_atomic(&dir.join("anisotropy.csv"), &t)?;
    }
    let pulses = pulse_rows(&state.replays);
    if !pulses.is_empty() {
        let mut t = CsvTable::new();
        t.push_text("replay", pulses.iter().map(|r| r.replay.as_str()))?;
        t.push_u64("checkpoint", pulses.iter().map(|r| r.checkpoint))?;
        t.push_f64("strain_yy", pulses.iter().map(|r| r.strain_yy))?;
        t.push_f64("amplitude", pulses.iter().map(|r| r.amplitude))?;
        t.push_opt_f64("speed", pulses.iter().map(|r| r.speed))?;
        for (k, when) in ["start", "end_with", "end_without"].iter().enumerate() {
            t.push_u64(format!("mobilised_{when}"), pulses.iter().map(|r| r.mobilised[k]))?;
        }
        for (k, when) in ["start", "end_with", "end_without"].iter().enumerate() {
            t.push_u64(format!("flagged_{when}"), pulses.iter().map(|r| r.flagged[k]))?;
        }
        t.push_i64("max_sliding_difference", pulses.iter().map(|r| r.max_sliding_difference))?;
        t.push_u64("pushed_on", pulses.iter().map(|r| r.pushed_on))?;
        write_csv_atomic(&dir.join("pulses.csv"), &t)?;
    }
    if state.config.output.plots {
        write_released_plot(dir, &state.config, &pulses)?;
    }
    let mut files = Vec::new();
    walk(dir, dir, &mut files);
    files.retain(|f| !f.ends_with(".gwck") && f != "summary.json" && f != grainwave_study::protocol::LOG_FILE);
    files.push("summary.json".into());
    let grains = state.config.packing.columns * state.config.packing.rows;
    let s = E2Summary {
        experiment: "e2".into(),
        version: grainwave_core::VERSION.into(),
        seed: state.config.seed,
        grains: if state.config.source.dir.is_some() {
            state.replays.first().map(|r| (r.units.total_mass / r.units.mean_mass).round() as usize).unwrap_or(0)
        } else {
            grains
        },
        unit_system: unit_system(),
        units: state.units,
        preparation: state.preparation.clone(),
        loading,
        replays: state.replays.clone(),
        static_limit,
        anisotropy,
        pulses,
        wall_seconds,
        files,
    };
    grainwave_study::outputs::write_summary(dir, &s)?;
    let _ = Stage::Finished;
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(mobilised: [u64; 3]) -> PulseRow {
        PulseRow {
            replay: "static".into(),
            checkpoint: 0,
            strain_yy: 0.01,
            amplitude: 1e-6,
            speed: None,
            mobilised,
            pushed_on: 0,
            flagged: [0; 3],
            max_sliding_difference: 0,
        }
    }

    #[test]
    fn the_released_fraction_is_measured_against_the_unpulsed_copy() {
        // 100 mobilised before; without the pulse 90 stay, with it 60: the pulse released 30 of 100
        assert_eq!(released_fraction(&row([100, 60, 90])), Some(0.3));
        // a pulse that sets contacts at the limit releases a negative fraction
        assert_eq!(released_fraction(&row([100, 95, 90])), Some(-0.05));
        assert_eq!(released_fraction(&row([0, 0, 0])), None);
    }
}
