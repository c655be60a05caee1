//! Outputs of the `e1` protocol (see docs/e1.md): `summary.json`, tables (`samples.csv`,
//! `groups.csv`, `heights.csv`, `pressures.csv`), signals, spectra and histograms (CSV + npz), VTK
//! files of the first sample of every group (grains, contacts, displacement fields) and plots.

use super::aggregate::{aggregate, Aggregate, GroupSignals};
use super::ensemble::{load_packing, load_result, sample_dir};
use super::plan::{pressure_label, Plan, StudyKind};
use super::sample::SampleResult;
use grainwave_study::Result;
use grainwave_core::checkpoint::AnySimulation;
use grainwave_analysis::packing::density_histogram;
use grainwave_core::prelude::*;
use grainwave_io::plot::{Histogram, LegendPosition, LinePlot, Network, PackingPicture};
use grainwave_io::vtk::{grains_dataset, write_contacts_vtp, VtkValues};
use grainwave_io::{write_csv_atomic, CsvTable, Series};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// The summary of an `e1` run (`summary.json`).
#[derive(Clone, Debug, Serialize)]
pub struct E1Report {
    /// Protocol name.
    pub experiment: String,
    /// grainwave version.
    pub version: String,
    /// `packing`, `lattice` or `chain`.
    pub study: String,
    /// Grain kind (`sphere2d`, `sphere`, or `disk` for chains).
    pub grain_kind: String,
    /// First seed s₀.
    pub seed: u64,
    /// Samples per group N.
    pub samples: usize,
    /// The unit system, in words.
    pub unit_system: String,
    /// Unit of every quantity of this summary, by name.
    pub units: BTreeMap<String, String>,
    /// Sample tasks in the plan.
    pub tasks: usize,
    /// Tasks with a result (failures included).
    pub done: usize,
    /// Every task has a result.
    pub complete: bool,
    /// Failed samples: directory and reason.
    pub failures: Vec<(String, String)>,
    /// Wall-clock seconds of this process (the last run or resume) [s].
    pub wall_seconds: f64,
    /// Wall-clock seconds of the sample tasks, summed over the samples [s]: each as timed by the run
    /// that finished it, its preparation included when that run made the packing (a packing
    /// reused from an earlier run adds only the analysis). Not the preparation again on top.
    pub sample_seconds: f64,
    /// Per group, series over heights and over pressures.
    #[serde(flatten)]
    pub aggregate: Aggregate,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
}

/// Units of the summary's quantities (E1 reduced units).
pub fn units(study: StudyKind) -> BTreeMap<String, String> {
    let mut u = BTreeMap::new();
    let mut put = |k: &str, v: &str| {
        u.insert(k.to_string(), v.to_string());
    };
    if study == StudyKind::Chain {
        put("time", "√(m/K) (chain time unit)");
        put("height", "ℓ (chain spacing; height = N ℓ)");
        put("signal", "K ℓ per unit initial condition (A: u̇₁(0) = c; B: u₁(0) = ℓ)");
        put("speeds", "ℓ √(K/m)");
        return u;
    }
    put("pressure", "E* (3D pressure: force / (L_x d̄) for sphere2d)");
    put("height, width, L", "d̄ (mean diameter)");
    put("time, leading_edge_time, peak_time, zero_crossing_time, width, fwhm", "d̄ √(ρ/E*)");
    put("c_tof, edge_speed, c_l, c_t", "√(E*/ρ)");
    put("C11, C12, C22, C33, sigma_1, sigma_2, bulk_sigma_1, bulk_sigma_2", "E*");
    put("density", "ρ (grain density = 1)");
    put("mean_force_over_p", "dimensionless: ⟨N⟩/(p d̄²)");
    put("phi2, phi3, phi3_star, f0, z, z_star, Z2, Z3, F2, F2_strong, sigma_ratio, sliding_fraction", "dimensionless");
    put("signal, peak_amplitude", "F_sig per unit initial condition: force E* d̄² per unit kick strength h (IC A, h = wall displacement × duration, in d̄ × d̄ √(ρ/E*)) or per unit displacement δ (IC B, in d̄)");
    put("rattlers, zero_modes, rattler_zero_modes, backbone_zero_modes, contactless_rattlers, one_contact_rattlers", "count (whole packing, boundary layers included)");
    put("rattler_weight_min, other_weight_max", "dimensionless: share of a zero-space direction's kinetic energy on rattler dofs");
    put("zero_mode_gap", "dimensionless: |ω²| of the first non-zero mode / max ω²");
    put("preparation.seconds, sample_seconds, wall_seconds", "s (wall clock)");
    put("preparation.max_acceleration, piston_acceleration", "d̄ / (d̄ √(ρ/E*))² = E*/(ρ d̄)");
    u
}

/// Everything needed to write the outputs: loads the results present in `out`.
pub fn collect(out: &Path, plan: &Plan) -> Vec<Option<SampleResult>> {
    plan.tasks.iter().map(|t| load_result(out, plan, t)).collect()
}

fn csv_f64(table: &mut CsvTable, name: &str, values: Vec<f64>) -> Result<()> {
    table.push_f64(name, values)?;
    Ok(())
}

/// Writes every output; returns the report.
pub fn write_outputs(out: &Path, plan: &Plan, wall_seconds: f64) -> Result<E1Report> {
    let results = collect(out, plan);
    let (agg, signals) = aggregate(plan, &results);
    let mut files = vec!["config.resolved.toml".to_string(), "summary.json".into(), grainwave_study::protocol::CHECKPOINT_FILE.into(), grainwave_study::protocol::LOG_FILE.into()];
    let cfg = &plan.config;

    // samples.csv
    let done: Vec<(&super::plan::Task, &SampleResult)> = plan.tasks.iter().zip(&results).filter_map(|(t, r)| r.as_ref().map(|r| (t, r))).collect();
    let mut t = CsvTable::new();
    t.push_text("group", done.iter().map(|(t, _)| plan.groups[t.group].name.clone()))?;
    csv_f64(&mut t, "pressure", done.iter().map(|(t, _)| plan.groups[t.group].pressure.unwrap_or(f64::NAN)).collect())?;
    t.push_u64("seed", done.iter().map(|(t, _)| t.seed))?;
    t.push_u64("grains", done.iter().map(|(_, r)| r.grains as u64))?;
    csv_f64(&mut t, "height", done.iter().map(|(_, r)| r.height).collect())?;
    t.push_text("failure", done.iter().map(|(_, r)| r.failure.clone().unwrap_or_default()))?;
    let prep = |f: &dyn Fn(&super::prepare::PreparationInfo) -> f64| -> Vec<f64> { done.iter().map(|(_, r)| r.preparation.as_ref().map_or(f64::NAN, f)).collect() };
    csv_f64(&mut t, "preparation_steps", prep(&|p| p.steps as f64))?;
    csv_f64(&mut t, "preparation_seconds", prep(&|p| p.seconds))?;
    let st = |f: &dyn Fn(&grainwave_analysis::packing::PackingStatistics) -> f64| -> Vec<f64> { done.iter().map(|(_, r)| r.statistics.as_ref().map_or(f64::NAN, f)).collect() };
    csv_f64(&mut t, "phi2", st(&|s| s.phi2.unwrap_or(f64::NAN)))?;
    csv_f64(&mut t, "phi3", st(&|s| s.phi3.unwrap_or(f64::NAN)))?;
    csv_f64(&mut t, "phi3_star", st(&|s| s.phi3_star.unwrap_or(f64::NAN)))?;
    csv_f64(&mut t, "z_star", st(&|s| s.coordination_star))?;
    csv_f64(&mut t, "f0", st(&|s| s.rattler_fraction))?;
    csv_f64(&mut t, "mean_force_over_p", st(&|s| s.mean_force_over_p))?;
    csv_f64(&mut t, "Z2", st(&|s| s.z2))?;
    csv_f64(&mut t, "Z3", st(&|s| s.z3))?;
    csv_f64(&mut t, "F2", st(&|s| s.f2))?;
    csv_f64(&mut t, "F2_strong", st(&|s| s.f2_strong))?;
    csv_f64(&mut t, "sigma_2", st(&|s| s.stress.sigma_2))?;
    csv_f64(&mut t, "sigma_ratio", st(&|s| s.stress.ratio))?;
    let mo = |f: &dyn Fn(&super::sample::ModuliResult) -> f64| -> Vec<f64> { done.iter().map(|(_, r)| r.moduli.as_ref().map_or(f64::NAN, f)).collect() };
    csv_f64(&mut t, "C11", mo(&|m| m.c11))?;
    csv_f64(&mut t, "C12", mo(&|m| m.c12))?;
    csv_f64(&mut t, "C22", mo(&|m| m.c22))?;
    csv_f64(&mut t, "C33", mo(&|m| m.c33))?;
    csv_f64(&mut t, "c_l", mo(&|m| m.longitudinal_speed))?;
    csv_f64(&mut t, "c_t", mo(&|m| m.transverse_speed))?;
    let pm = |f: &dyn Fn(&grainwave_analysis::signal::PulseMetrics) -> f64| -> Vec<f64> {
        done.iter().map(|(_, r)| r.pulse.as_ref().and_then(|p| p.metrics.as_ref()).map_or(f64::NAN, f)).collect()
    };
    csv_f64(&mut t, "leading_edge_time", pm(&|m| m.leading_edge_time))?;
    csv_f64(&mut t, "peak_time", pm(&|m| m.peak_time))?;
    csv_f64(&mut t, "peak_amplitude", pm(&|m| m.peak_amplitude))?;
    csv_f64(&mut t, "width", pm(&|m| m.width.unwrap_or(f64::NAN)))?;
    csv_f64(&mut t, "fwhm", pm(&|m| m.fwhm.unwrap_or(f64::NAN)))?;
    // zero modes of the modal sum (NaN without one): all, the rattlers' part, the rest (backbone)
    let zm = |f: &dyn Fn(&super::sample::PulseResult) -> f64| -> Vec<f64> {
        done.iter().map(|(_, r)| r.pulse.as_ref().filter(|p| !p.omega_squared.is_empty()).map_or(f64::NAN, f)).collect()
    };
    csv_f64(&mut t, "rattlers", st(&|s| s.rattlers as f64))?;
    csv_f64(&mut t, "zero_modes", zm(&|p| p.zero_modes as f64))?;
    csv_f64(&mut t, "rattler_zero_modes", zm(&|p| p.rattler_zero_modes as f64))?;
    csv_f64(&mut t, "backbone_zero_modes", zm(&|p| (p.zero_modes - p.rattler_zero_modes) as f64))?;
    csv_f64(&mut t, "contactless_rattlers", zm(&|p| p.contactless_rattlers as f64))?;
    csv_f64(&mut t, "one_contact_rattlers", zm(&|p| p.one_contact_rattlers as f64))?;
    csv_f64(&mut t, "rattler_weight_min", zm(&|p| p.rattler_weight_min))?;
    csv_f64(&mut t, "other_weight_max", zm(&|p| p.other_weight_max))?;
    csv_f64(&mut t, "zero_mode_gap", zm(&|p| p.zero_mode_gap))?;
    csv_f64(&mut t, "seconds", done.iter().map(|(_, r)| r.seconds).collect())?;
    write_csv_atomic(&out.join("samples.csv"), &t)?;
    files.push("samples.csv".into());

    // groups.csv
    let mut t = CsvTable::new();
    t.push_text("group", agg.groups.iter().map(|g| g.name.clone()))?;
    csv_f64(&mut t, "pressure", agg.groups.iter().map(|g| g.pressure.unwrap_or(f64::NAN)).collect())?;
    t.push_text("size", agg.groups.iter().map(|g| g.size.clone()))?;
    t.push_u64("samples", agg.groups.iter().map(|g| g.samples as u64))?;
    csv_f64(&mut t, "height_mean", agg.groups.iter().map(|g| g.height.mean).collect())?;
    csv_f64(&mut t, "height_std", agg.groups.iter().map(|g| g.height.std).collect())?;
    let mut keys: Vec<(String, String)> = Vec::new();
    for g in &agg.groups {
        for (section, map) in [("", &g.characterization), ("", &g.moduli), ("pulse_", &g.pulse)] {
            for k in map.keys() {
                let key = (section.to_string(), k.clone());
                if !keys.contains(&key) {
                    keys.push(key);
                }
            }
        }
    }
    for (section, k) in &keys {
        let get = |g: &super::aggregate::GroupSummary| g.characterization.get(k).or(g.moduli.get(k)).filter(|_| section.is_empty()).or(if section.is_empty() { None } else { g.pulse.get(k) }).copied();
        let name = format!("{section}{}", k.replace(' ', "_"));
        csv_f64(&mut t, &format!("{name}_mean"), agg.groups.iter().map(|g| get(g).map_or(f64::NAN, |s| s.mean)).collect())?;
        csv_f64(&mut t, &format!("{name}_std"), agg.groups.iter().map(|g| get(g).map_or(f64::NAN, |s| s.std)).collect())?;
    }
    write_csv_atomic(&out.join("groups.csv"), &t)?;
    files.push("groups.csv".into());

    // heights.csv
    let mut t = CsvTable::new();
    let rows: Vec<(Option<f64>, usize)> = agg.heights.iter().flat_map(|h| (0..h.series.as_ref().map_or(0, |s| s.heights.len())).map(move |k| (h.pressure, k))).collect();
    let series_of = |p: Option<f64>| agg.heights.iter().find(|h| h.pressure == p).and_then(|h| h.series.as_ref());
    csv_f64(&mut t, "pressure", rows.iter().map(|(p, _)| p.unwrap_or(f64::NAN)).collect())?;
    for (name, f) in [
        ("height", (&|s: &grainwave_analysis::pulse_series::HeightSeries, k: usize| s.heights[k]) as &dyn Fn(&grainwave_analysis::pulse_series::HeightSeries, usize) -> f64),
        ("leading_edge_time", &|s, k| s.edge_times[k]),
        ("peak_time", &|s, k| s.peak_times[k]),
        ("peak_amplitude", &|s, k| s.amplitudes[k]),
        ("width", &|s, k| s.widths[k]),
        ("fwhm", &|s, k| s.fwhm[k]),
    ] {
        csv_f64(&mut t, name, rows.iter().map(|(p, k)| series_of(*p).map_or(f64::NAN, |s| f(s, *k))).collect())?;
    }
    write_csv_atomic(&out.join("heights.csv"), &t)?;
    files.push("heights.csv".into());

    // pressures.csv
    if !agg.pressures.is_empty() {
        let mut t = CsvTable::new();
        csv_f64(&mut t, "pressure", agg.pressures[0].pressures.clone())?;
        for s in &agg.pressures {
            csv_f64(&mut t, &s.name.replace(' ', "_"), s.values.clone())?;
        }
        write_csv_atomic(&out.join("pressures.csv"), &t)?;
        files.push("pressures.csv".into());
    }

    // signals per group
    for (g, sig) in plan.groups.iter().zip(&signals) {
        if sig.mean.is_empty() {
            continue;
        }
        let mut cols: Vec<(String, Vec<f64>)> = vec![("time".into(), g.times.clone()), ("mean".into(), sig.mean.clone()), ("rms".into(), sig.rms.clone())];
        for (seed, s) in sig.seeds.iter().zip(&sig.signals) {
            cols.push((format!("s{seed:04}"), s.clone()));
        }
        if let Some(c) = &sig.closed_form {
            cols.push(("closed_form".into(), c.clone()));
        }
        for (z, s) in &sig.damped {
            cols.push((format!("md_zeta_{z}"), s.clone()));
        }
        Series::from_columns(cols)?.write(&out.join("signals"), &g.name)?;
        files.push(format!("signals/{}.npz", g.name));
        files.push(format!("signals/{}.csv", g.name));
    }

    // spectra, histograms and pictures of the first sample of each group
    let mut first: Vec<Option<&SampleResult>> = vec![None; plan.groups.len()];
    for (task, r) in plan.tasks.iter().zip(&results) {
        if let Some(r) = r.as_ref().filter(|r| r.failure.is_none()) {
            if first[task.group].is_none() {
                first[task.group] = Some(r);
            }
        }
    }
    for (g, r) in plan.groups.iter().zip(&first) {
        let Some(p) = r.and_then(|r| r.pulse.as_ref()).filter(|p| !p.omega_squared.is_empty()) else { continue };
        let omega: Vec<f64> = p.omega_squared.iter().map(|w| w.max(0.0).sqrt()).collect();
        Series::from_columns(vec![
            ("omega_squared".to_string(), p.omega_squared.clone()),
            ("omega".to_string(), omega),
            ("contribution".to_string(), p.contributions.clone()),
            ("participation".to_string(), p.participation.clone()),
        ])?
        .write(&out.join("spectra"), &g.name)?;
        files.push(format!("spectra/{}.npz", g.name));
        files.push(format!("spectra/{}.csv", g.name));
    }
    let bins = cfg.characterization.histogram_bins;
    let angle_max = if plan.dimension == 2 { std::f64::consts::PI } else { std::f64::consts::FRAC_PI_2 };
    let mut pooled: Vec<Option<Pooled>> = vec![None; plan.groups.len()];
    for (task, r) in plan.tasks.iter().zip(&results) {
        if let Some(s) = r.as_ref().filter(|r| r.failure.is_none()).and_then(|r| r.statistics.as_ref()) {
            let e = pooled[task.group].get_or_insert_with(Pooled::default);
            e.all.extend(&s.angles_all);
            e.strong.extend(&s.angles_strong);
            e.weak.extend(&s.angles_weak);
            e.sliding.extend(&s.angles_sliding);
            e.force.extend(&s.force_ratios);
            e.stiffness.extend(&s.stiffness_ratios);
        }
    }
    for (g, e) in plan.groups.iter().zip(&pooled) {
        let Some(e) = e else { continue };
        let (centres, all) = density_histogram(&e.all, bins, 0.0, angle_max);
        let (_, strong) = density_histogram(&e.strong, bins, 0.0, angle_max);
        let (_, weak) = density_histogram(&e.weak, bins, 0.0, angle_max);
        let (_, sliding) = density_histogram(&e.sliding, bins, 0.0, angle_max);
        let fmax = 5.0;
        let (fc, force) = density_histogram(&e.force, bins, 0.0, fmax);
        let (_, stiffness) = density_histogram(&e.stiffness, bins, 0.0, fmax);
        Series::from_columns(vec![
            ("angle".to_string(), centres),
            ("angle_all".to_string(), all),
            ("angle_strong".to_string(), strong),
            ("angle_weak".to_string(), weak),
            ("angle_sliding".to_string(), sliding),
            ("ratio".to_string(), fc),
            ("force_ratio".to_string(), force),
            ("stiffness_ratio".to_string(), stiffness),
        ])?
        .write(&out.join("histograms"), &g.name)?;
        files.push(format!("histograms/{}.npz", g.name));
        files.push(format!("histograms/{}.csv", g.name));
    }

    // VTK of the first sample of each group, with its displacement fields
    if cfg.output.vtk && plan.kind != StudyKind::Chain {
        for (g, r) in plan.groups.iter().zip(&first) {
            let Some(r) = r else { continue };
            let Some(task) = plan.tasks.iter().find(|t| t.group == g.index && t.sample == r.sample) else { continue };
            let Some(sim) = system_of(out, plan, task) else { continue };
            match &sim {
                AnySimulation::D2(s) => files.extend(write_vtk(out, &g.name, s, r)?),
                AnySimulation::D3(s) => files.extend(write_vtk(out, &g.name, s, r)?),
            }
        }
    }

    if cfg.output.plots {
        files.extend(make_plots(out, plan, &agg, &signals, &first, &pooled)?);
    }

    let failures: Vec<(String, String)> = plan
        .tasks
        .iter()
        .zip(&results)
        .filter_map(|(t, r)| r.as_ref().and_then(|r| r.failure.clone()).map(|f| (sample_dir(plan, t).display().to_string(), f)))
        .collect();
    let report = E1Report {
        experiment: "e1".into(),
        version: grainwave_core::VERSION.into(),
        study: plan.kind.name().into(),
        grain_kind: match (plan.kind, plan.dimension) {
            (StudyKind::Chain, _) => "disk".into(),
            (_, 2) => "sphere2d".into(),
            _ => "sphere".into(),
        },
        seed: cfg.seed,
        samples: cfg.samples,
        unit_system: if plan.kind == StudyKind::Chain {
            "chain units: spacing ℓ, mass m, spring K as configured".into()
        } else {
            "E1 reduced units: length d̄ (mean diameter), density ρ = 1, pressure E* = E/(1 − ν²) = 1, time d̄ √(ρ/E*)".into()
        },
        units: units(plan.kind),
        tasks: plan.tasks.len(),
        done: done.len(),
        complete: done.len() == plan.tasks.len(),
        failures,
        wall_seconds,
        sample_seconds: done.iter().map(|(_, r)| r.seconds).sum(),
        aggregate: agg,
        files,
    };
    grainwave_study::outputs::write_summary(out, &report)?;
    Ok(report)
}

/// Angles, forces and stiffnesses pooled over the samples of a group.
#[derive(Clone, Debug, Default)]
pub struct Pooled {
    all: Vec<f64>,
    strong: Vec<f64>,
    weak: Vec<f64>,
    sliding: Vec<f64>,
    force: Vec<f64>,
    stiffness: Vec<f64>,
}

/// The static system of `task`: its prepared packing, or the rebuilt monodisperse lattice.
fn system_of(out: &Path, plan: &Plan, task: &super::plan::Task) -> Option<AnySimulation> {
    if let Some(f) = load_packing(out, plan, task) {
        return Some(f.sim);
    }
    if plan.kind == StudyKind::Lattice && plan.spread == 0.0 {
        let lc = plan.config.lattice.as_ref()?;
        let g = &plan.groups[task.group];
        let spec = grainwave_linear::reference::TriangularLatticeSpec {
            rows: g.rows,
            columns: lc.columns,
            pressure: g.pressure?,
            young: 1.0 - lc.poisson * lc.poisson,
            poisson: lc.poisson,
            friction: lc.friction,
            polydispersity: 0.0,
            piston: false,
            seed: task.seed,
            ..Default::default()
        };
        return spec.build().ok().map(AnySimulation::D2);
    }
    None
}

fn write_vtk<D: Dim>(out: &Path, name: &str, sim: &Simulation<D>, r: &SampleResult) -> Result<Vec<String>> {
    let snap = sim.snapshot();
    let mut files = Vec::new();
    let mut ds = grains_dataset(&snap)?;
    if let Some(p) = &r.pulse {
        for (k, f) in p.fields.iter().enumerate() {
            let mut u = Vec::with_capacity(3 * snap.len());
            for g in 0..snap.len() {
                for a in 0..3 {
                    u.push(if a < D::D { f.displacement.get(g * D::D + a).copied().unwrap_or(0.0) } else { 0.0 });
                }
            }
            ds.push_point_data(format!("displacement_{k}_t{:.4}", f.time), 3, VtkValues::Float64(u))?;
        }
    }
    if let Some(s) = &r.statistics {
        ds.push_point_data("rattler", 1, VtkValues::UInt8(s.rattler_flags.iter().map(|&b| b as u8).collect()))?;
    }
    let g = format!("vtk/{name}_grains.vtp");
    ds.write(&out.join(&g))?;
    let c = format!("vtk/{name}_contacts.vtp");
    write_contacts_vtp(&out.join(&c), &snap)?;
    files.push(g);
    files.push(c);
    Ok(files)
}

fn plot_name(p: Option<f64>) -> String {
    p.map_or_else(|| "chain".to_string(), |p| format!("p{}", pressure_label(p)))
}

/// Draws the plots into `out/plots/`; returns the files relative to `out`.
fn make_plots(out: &Path, plan: &Plan, agg: &Aggregate, signals: &[GroupSignals], first: &[Option<&SampleResult>], pooled: &[Option<Pooled>]) -> Result<Vec<String>> {
    let dir = out.join("plots");
    let mut files = Vec::new();
    let mut push = |stem: &str| {
        files.push(format!("plots/{stem}.png"));
        files.push(format!("plots/{stem}.svg"));
    };
    let chain = plan.kind == StudyKind::Chain;
    let time_label = if chain { "t [√(m/K)]" } else { "t [d √(ρ/E*)]" };
    let length_label = if chain { "N" } else { "L [d]" };
    let signal_label = if chain { "F(t) = K u_N [K ℓ]" } else { "F_sig(t) [per unit kick h]" };
    // signals per group: samples and ensemble mean ± rms
    for (g, s) in plan.groups.iter().zip(signals) {
        if s.mean.is_empty() {
            continue;
        }
        let title = match g.pressure {
            Some(p) => format!("Signal at the top wall: p = {p:e}, {} ({} samples)", g.size_label, s.signals.len()),
            None => format!("Signal at the last ball: {} ({})", g.size_label, if plan.spread > 0.0 { "polydisperse" } else { "monodisperse" }),
        };
        let mut plot = LinePlot::new(&title).x_label(time_label).y_label(signal_label);
        if s.signals.len() > 1 {
            for (seed, sig) in s.seeds.iter().zip(&s.signals).take(6) {
                plot = plot.series(&format!("seed {seed}"), &g.times, sig);
            }
            plot = plot.band("ensemble mean ± r.m.s.", &g.times, &s.mean, &s.rms);
        } else {
            plot = plot.series("signal", &g.times, &s.mean);
        }
        if let Some(c) = &s.closed_form {
            plot = plot.dashed("closed-form mode sum", &g.times, c);
        }
        let stem = format!("signal_{}", g.name);
        plot.save(&dir, &stem)?;
        push(&stem);
        if !s.damped.is_empty() {
            let mut plot = LinePlot::new(&format!("Damped MD vs linear: {}", g.name)).x_label(time_label).y_label("F_sig(t) / h");
            plot = plot.dashed("linear (modal)", &g.times, first[g.index].and_then(|r| r.pulse.as_ref()).map_or(&s.mean, |p| &p.signal));
            for (z, sig) in &s.damped {
                plot = plot.series(&format!("MD ζ = {z}"), &g.times, sig);
            }
            let stem = format!("damped_{}", g.name);
            plot.save(&dir, &stem)?;
            push(&stem);
        }
    }
    // mean signals of all sizes at each pressure
    for h in &agg.heights {
        let idx: Vec<usize> = plan.groups.iter().filter(|g| g.pressure == h.pressure || chain).map(|g| g.index).collect();
        if idx.len() < 2 {
            continue;
        }
        let mut plot = LinePlot::new(&format!("Ensemble-averaged signals, {}", h.pressure.map_or("chain".into(), |p| format!("p = {p:e}")))).x_label(time_label).y_label(signal_label);
        let mut any = false;
        for k in idx {
            if signals[k].mean.is_empty() {
                continue;
            }
            let label = if chain { plan.groups[k].size_label.clone() } else { format!("L = {:.1}", agg.groups[k].height.mean) };
            plot = plot.series(&label, &plan.groups[k].times, &signals[k].mean);
            any = true;
        }
        if any {
            let stem = format!("signals_{}", plot_name(h.pressure));
            plot.save(&dir, &stem)?;
            push(&stem);
        }
    }
    // arrival times, amplitudes and widths vs L
    let with_series: Vec<_> = agg.heights.iter().filter_map(|h| h.series.as_ref().filter(|s| s.heights.len() >= 2).map(|s| (h.pressure, s))).collect();
    if !with_series.is_empty() {
        let mut arrival = LinePlot::new("Arrival times of the averaged signals").x_label(length_label).y_label(&format!("t {}", &time_label[2..])).legend(LegendPosition::UpperLeft);
        let mut amplitude = LinePlot::new("First-peak amplitude A(L)").x_label(length_label).y_label("A").log_x().log_y();
        let mut width = LinePlot::new("Pulse width W(L) (leading edge to first zero crossing)").x_label(length_label).y_label(&format!("W {}", &time_label[2..])).log_x().log_y().legend(LegendPosition::UpperLeft);
        for (p, s) in &with_series {
            let tag = plot_name(*p);
            arrival = arrival.scatter(&format!("leading edge, {tag}"), &s.heights, &s.edge_times).scatter(&format!("peak, {tag}"), &s.heights, &s.peak_times);
            if let Some(f) = &s.edge_fit {
                let y: Vec<f64> = s.heights.iter().map(|l| f.slope * l + f.intercept).collect();
                arrival = arrival.dashed(&format!("fit: c = {:.4}", 1.0 / f.slope), &s.heights, &y);
            }
            amplitude = amplitude.scatter(&tag, &s.heights, &s.amplitudes);
            if let Some(e) = &s.amplitude_exponent {
                let y: Vec<f64> = s.heights.iter().map(|l| e.prefactor * l.powf(e.exponent)).collect();
                amplitude = amplitude.dashed(&format!("γ = {:.3}", e.gamma), &s.heights, &y);
            }
            width = width.scatter(&tag, &s.heights, &s.widths);
            if let Some(e) = &s.width_exponent {
                let y: Vec<f64> = s.heights.iter().map(|l| e.prefactor * l.powf(e.exponent)).collect();
                width = width.dashed(&format!("α = {:.3}", e.exponent), &s.heights, &y);
            }
        }
        arrival.save(&dir, "arrival_times")?;
        push("arrival_times");
        amplitude.save(&dir, "amplitude")?;
        push("amplitude");
        width.save(&dir, "width")?;
        push("width");
    }
    // speeds vs pressure
    if !agg.pressures.is_empty() {
        let mut plot = LinePlot::new("Speeds vs pressure").x_label("p [E*]").y_label("c [√(E*/ρ)]").log_x().log_y().legend(LegendPosition::UpperLeft);
        let mut moduli = LinePlot::new("Elastic moduli vs pressure").x_label("p [E*]").y_label("C [E*]").log_x().log_y().legend(LegendPosition::UpperLeft);
        let mut any_m = false;
        for s in &agg.pressures {
            let label = match &s.fit {
                Some(f) => format!("{} (slope {:.3})", s.name, f.exponent),
                None => s.name.clone(),
            };
            if s.name.starts_with('C') {
                moduli = moduli.scatter(&label, &s.pressures, &s.values);
                any_m = true;
            } else if s.values.iter().any(|v| v.is_finite()) {
                plot = plot.scatter(&label, &s.pressures, &s.values);
            }
        }
        plot.save(&dir, "speeds")?;
        push("speeds");
        if any_m {
            moduli.save(&dir, "moduli")?;
            push("moduli");
        }
    }
    // spectra and mode contributions of the first sample
    for (g, r) in plan.groups.iter().zip(first) {
        let Some(p) = r.and_then(|r| r.pulse.as_ref()).filter(|p| !p.omega_squared.is_empty()) else { continue };
        let omega: Vec<f64> = p.omega_squared.iter().map(|w| w.max(0.0).sqrt()).collect();
        let positive: Vec<f64> = omega.iter().copied().filter(|w| *w > 0.0).collect();
        if positive.len() >= 2 {
            let stem = format!("spectrum_{}", g.name);
            Histogram::new(&format!("Density of states (first sample): {}", g.name))
                .x_label(if chain { "ω [√(K/m)]" } else { "ω [√(E*/ρ)/d]" })
                .y_label("D(ω)")
                .density()
                .bins(60)
                .sample("modes", &positive)
                .save(&dir, &stem)?;
            push(&stem);
        }
        let stem = format!("contributions_{}", g.name);
        LinePlot::new(&format!("Mode contributions a_n b_n (first sample): {}", g.name))
            .x_label(if chain { "ω_n [√(K/m)]" } else { "ω_n [√(E*/ρ)/d]" })
            .y_label("a_n b_n")
            .scatter("modes", &omega, &p.contributions)
            .save(&dir, &stem)?;
        push(&stem);
    }
    // histograms
    let angle_label = if plan.dimension == 2 { "contact angle θ from x [rad]" } else { "polar angle from z [rad]" };
    for (g, e) in plan.groups.iter().zip(pooled) {
        let Some(e) = e else { continue };
        if e.all.is_empty() {
            continue;
        }
        let max = if plan.dimension == 2 { std::f64::consts::PI } else { std::f64::consts::FRAC_PI_2 };
        let mut h = Histogram::new(&format!("Contact angles (bulk, all samples): {}", g.name)).x_label(angle_label).y_label("P(θ)").density().range(0.0, max).bins(plan.config.characterization.histogram_bins);
        h = h.sample("all", &e.all).sample("strong (N > ⟨N⟩)", &e.strong).sample("weak", &e.weak);
        if e.sliding.len() >= 5 {
            h = h.sample("sliding", &e.sliding);
        }
        let stem = format!("angles_{}", g.name);
        h.save(&dir, &stem)?;
        push(&stem);
        let stem = format!("forces_{}", g.name);
        Histogram::new(&format!("Normal forces and stiffnesses (bulk, all samples): {}", g.name))
            .x_label("N/⟨N⟩, k_n/⟨k_n⟩")
            .y_label("probability density")
            .density()
            .range(0.0, 5.0)
            .bins(plan.config.characterization.histogram_bins)
            .sample("N/⟨N⟩", &e.force)
            .sample("k_n/⟨k_n⟩", &e.stiffness)
            .save(&dir, &stem)?;
        push(&stem);
    }
    // packing pictures (2D): force and stiffness networks, displacement fields
    if plan.dimension == 2 && !chain {
        for (g, r) in plan.groups.iter().zip(first) {
            let Some(r) = r else { continue };
            let Some(task) = plan.tasks.iter().find(|t| t.group == g.index && t.sample == r.sample) else { continue };
            let Some(AnySimulation::D2(sim)) = system_of(out, plan, task) else { continue };
            let snap = sim.snapshot();
            let stem = format!("force_network_{}", g.name);
            PackingPicture::new(&snap, &format!("Force network {} s{}", g.name, r.seed)).x_label("x [d]").y_label("y [d]").network(Network::Force).save(&dir, &stem)?;
            push(&stem);
            let stem = format!("stiffness_network_{}", g.name);
            PackingPicture::new(&snap, &format!("Stiffness network {} s{}", g.name, r.seed)).x_label("x [d]").y_label("y [d]").network(Network::Stiffness).save(&dir, &stem)?;
            push(&stem);
            if let Some(p) = &r.pulse {
                for (k, f) in p.fields.iter().enumerate() {
                    let u: Vec<glam::DVec2> = (0..snap.len()).map(|i| glam::DVec2::new(f.displacement[2 * i], f.displacement[2 * i + 1])).collect();
                    let stem = format!("displacement_{}_{k}", g.name);
                    PackingPicture::new(&snap, &format!("u(t), t = {:.4} = {} t_peak, {}", f.time, f.fraction, g.name))
                        .x_label("x [d]")
                        .y_label("y [d]")
                        .arrows(&u, None)
                        .save(&dir, &stem)?;
                    push(&stem);
                }
            }
        }
    }
    Ok(files)
}

