//! Ensemble tables: per group (size × pressure) means and standard deviations over the samples,
//! the ensemble-averaged signal with its r.m.s. deviation and metrics, series over heights (arrival
//! times, c_tof, exponents) and over pressures (speeds and their log–log slopes).

use super::plan::{Plan, StudyKind};
use super::sample::{PulseResult, SampleResult};
use grainwave_analysis::ensemble::{mean_and_rms, mean_std, MeanStd};
use grainwave_analysis::pulse_series::{analyze_heights, bootstrap_exponents, BootstrapOptions, ExponentIntervals, HeightSeries, SeriesGroup, SeriesOptions};
use grainwave_analysis::signal::{linear_fit, power_law_fit, pulse_metrics, LinearFit, PowerLawFit, PulseMetrics, PulseOptions};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Statistics of one damped MD setting over the samples that have it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DampedSummary {
    /// ζ.
    pub zeta: f64,
    /// Samples averaged.
    pub samples: usize,
    /// Metrics of the averaged MD signal.
    pub metrics: Option<PulseMetrics>,
    /// Relative L2 difference to the linear signal over its first transit (per sample).
    pub difference_to_linear: MeanStd,
}

/// One group: a size at a pressure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroupSummary {
    /// Group name.
    pub name: String,
    /// Pressure p [force/area].
    pub pressure: Option<f64>,
    /// The size as configured (`L25`, `N600`, `r20`, `N50`).
    pub size: String,
    /// Grains per sample.
    pub grains: usize,
    /// Samples with a result (failures excluded).
    pub samples: usize,
    /// Samples that failed.
    pub failed: usize,
    /// Source–detector distance L (wall gap) [length].
    pub height: MeanStd,
    /// Preparation: steps, quenches, seconds, final accelerations.
    pub preparation: BTreeMap<String, MeanStd>,
    /// Static characterization (bulk values).
    pub characterization: BTreeMap<String, MeanStd>,
    /// Elastic moduli and continuum speeds.
    pub moduli: BTreeMap<String, MeanStd>,
    /// Per-sample pulse metrics.
    pub pulse: BTreeMap<String, MeanStd>,
    /// Metrics of the ensemble-averaged signal.
    pub mean_signal: Option<PulseMetrics>,
    /// Why the averaged signal has no metrics.
    pub mean_signal_error: Option<String>,
    /// Chains: largest relative difference generic vs closed form.
    pub closed_form_difference: Option<f64>,
    /// Damped MD runs.
    pub damped: Vec<DampedSummary>,
}

/// Series over heights at one pressure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeightSeriesSummary {
    /// Pressure (none for chains) [force/area].
    pub pressure: Option<f64>,
    /// Fits on the ensemble-averaged signals (heights: group means of L).
    pub series: Option<HeightSeries>,
    /// Leading-edge time vs L over every sample (all heights together).
    pub edge_fit_samples: Option<LinearFit>,
    /// c_tof between the reference heights, per seed (samples of equal seed at the two heights).
    pub time_of_flight_samples: MeanStd,
    /// γ, α, α′ and the effective exponents with bootstrap intervals over the samples, and for
    /// each whether it can be called (`pulse.bootstrap` > 0).
    pub exponent_intervals: Option<ExponentIntervals>,
    /// Why there are no intervals (fewer than two heights with two samples, no peak, …).
    pub exponent_intervals_error: Option<String>,
}

/// A speed vs pressure, with its log–log slope.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeedSeries {
    /// What it is (`c_tof`, `c_l`, …) and at which size.
    pub name: String,
    /// Pressures [force/area].
    pub pressures: Vec<f64>,
    /// Values [length/time] (NaN when missing).
    pub values: Vec<f64>,
    /// c ∝ p^slope.
    pub fit: Option<PowerLawFit>,
}

/// Everything aggregated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aggregate {
    /// Per group.
    pub groups: Vec<GroupSummary>,
    /// Per pressure (or one for chains).
    pub heights: Vec<HeightSeriesSummary>,
    /// Speeds and moduli vs pressure.
    pub pressures: Vec<SpeedSeries>,
}

/// Ensemble-averaged signals of a group.
#[derive(Clone, Debug, Default)]
pub struct GroupSignals {
    /// Seeds of the samples.
    pub seeds: Vec<u64>,
    /// Signals per sample.
    pub signals: Vec<Vec<f64>>,
    /// Ensemble mean.
    pub mean: Vec<f64>,
    /// R.m.s. deviation.
    pub rms: Vec<f64>,
    /// Chains: the closed form (first sample).
    pub closed_form: Option<Vec<f64>>,
    /// Damped MD mean signals: (ζ, mean signal).
    pub damped: Vec<(f64, Vec<f64>)>,
}

fn stats(values: impl Iterator<Item = f64>) -> MeanStd {
    mean_std(&values.collect::<Vec<f64>>())
}

/// Aggregates `results` (indexed like `plan.tasks`, `None` when missing).
pub fn aggregate(plan: &Plan, results: &[Option<SampleResult>]) -> (Aggregate, Vec<GroupSignals>) {
    let pc = &plan.config.pulse;
    let popts = PulseOptions { edge_fraction: pc.edge_fraction, peak_threshold: pc.peak_threshold.unwrap_or(grainwave_analysis::signal::DEFAULT_PEAK_THRESHOLD) };
    let mut groups = Vec::new();
    let mut signals = Vec::new();
    for g in &plan.groups {
        let all: Vec<&SampleResult> = plan.tasks.iter().zip(results).filter(|(t, _)| t.group == g.index).filter_map(|(_, r)| r.as_ref()).collect();
        let ok: Vec<&SampleResult> = all.iter().copied().filter(|r| r.failure.is_none()).collect();
        let mut prep = BTreeMap::new();
        let preps: Vec<_> = ok.iter().filter_map(|r| r.preparation.as_ref()).collect();
        if !preps.is_empty() {
            prep.insert("steps".into(), stats(preps.iter().map(|p| p.steps as f64)));
            prep.insert("quenches".into(), stats(preps.iter().map(|p| p.quenches as f64)));
            prep.insert("seconds".into(), stats(preps.iter().map(|p| p.seconds)));
            prep.insert("max_acceleration".into(), stats(preps.iter().map(|p| p.max_acceleration)));
            prep.insert("piston_acceleration".into(), stats(preps.iter().map(|p| p.piston_acceleration)));
        }
        let mut ch = BTreeMap::new();
        let st: Vec<_> = ok.iter().filter_map(|r| r.statistics.as_ref()).collect();
        if !st.is_empty() {
            let mut put = |k: &str, f: &dyn Fn(&grainwave_analysis::packing::PackingStatistics) -> Option<f64>| {
                let v: Vec<f64> = st.iter().filter_map(|s| f(s)).collect();
                if !v.is_empty() {
                    ch.insert(k.to_string(), mean_std(&v));
                }
            };
            put("phi2", &|s| s.phi2);
            put("phi3", &|s| s.phi3);
            put("phi3_star", &|s| s.phi3_star);
            put("z_star", &|s| Some(s.coordination_star));
            put("z", &|s| Some(s.coordination));
            put("f0", &|s| Some(s.rattler_fraction));
            put("mean_force_over_p", &|s| Some(s.mean_force_over_p));
            put("Z2", &|s| Some(s.z2));
            put("Z3", &|s| Some(s.z3));
            put("F2", &|s| Some(s.f2));
            put("F2_strong", &|s| Some(s.f2_strong));
            put("sigma_1", &|s| Some(s.stress.sigma_1));
            put("sigma_2", &|s| Some(s.stress.sigma_2));
            put("sigma_ratio", &|s| Some(s.stress.ratio));
            put("bulk_sigma_1", &|s| Some(s.bulk_stress.sigma_1));
            put("bulk_sigma_2", &|s| Some(s.bulk_stress.sigma_2));
            put("bulk_sigma_ratio", &|s| Some(s.bulk_stress.ratio));
            put("sliding_fraction", &|s| Some(s.sliding_fraction));
            put("bulk_contacts", &|s| Some(s.bulk_contacts as f64));
            put("rattlers", &|s| Some(s.rattlers as f64));
        }
        let mut mo = BTreeMap::new();
        let ms: Vec<_> = ok.iter().filter_map(|r| r.moduli.as_ref()).collect();
        if !ms.is_empty() {
            mo.insert("C11".into(), stats(ms.iter().map(|m| m.c11)));
            mo.insert("C12".into(), stats(ms.iter().map(|m| m.c12)));
            mo.insert("C22".into(), stats(ms.iter().map(|m| m.c22)));
            mo.insert("C33".into(), stats(ms.iter().map(|m| m.c33)));
            mo.insert("density".into(), stats(ms.iter().map(|m| m.density)));
            mo.insert("c_l".into(), stats(ms.iter().map(|m| m.longitudinal_speed)));
            mo.insert("c_t".into(), stats(ms.iter().map(|m| m.transverse_speed)));
            mo.insert("asymmetry".into(), stats(ms.iter().map(|m| m.asymmetry)));
            for (k, (name, _)) in ms[0].local.iter().enumerate() {
                mo.insert(format!("local {name}"), stats(ms.iter().filter_map(|m| m.local.get(k).map(|x| x.1))));
            }
        }
        let mut pu = BTreeMap::new();
        let pulses: Vec<_> = ok.iter().filter_map(|r| r.pulse.as_ref().map(|p| (r.seed, p))).collect();
        let metrics: Vec<&PulseMetrics> = pulses.iter().filter_map(|(_, p)| p.metrics.as_ref()).collect();
        if !pulses.is_empty() {
            pu.insert("leading_edge_time".into(), stats(metrics.iter().map(|m| m.leading_edge_time)));
            pu.insert("peak_time".into(), stats(metrics.iter().map(|m| m.peak_time)));
            pu.insert("peak_amplitude".into(), stats(metrics.iter().map(|m| m.peak_amplitude)));
            pu.insert("zero_crossing_time".into(), stats(metrics.iter().map(|m| m.zero_crossing_time.unwrap_or(f64::NAN))));
            pu.insert("width".into(), stats(metrics.iter().map(|m| m.width.unwrap_or(f64::NAN))));
            pu.insert("fwhm".into(), stats(metrics.iter().map(|m| m.fwhm.unwrap_or(f64::NAN))));
            if pulses.iter().any(|(_, p)| !p.omega_squared.is_empty()) {
                let modal: Vec<&PulseResult> = pulses.iter().map(|(_, p)| *p).filter(|p| !p.omega_squared.is_empty()).collect();
                pu.insert("zero_modes".into(), stats(modal.iter().map(|p| p.zero_modes as f64)));
                pu.insert("rattler_zero_modes".into(), stats(modal.iter().map(|p| p.rattler_zero_modes as f64)));
                pu.insert("backbone_zero_modes".into(), stats(modal.iter().map(|p| (p.zero_modes - p.rattler_zero_modes) as f64)));
                pu.insert("contactless_rattlers".into(), stats(modal.iter().map(|p| p.contactless_rattlers as f64)));
                pu.insert("one_contact_rattlers".into(), stats(modal.iter().map(|p| p.one_contact_rattlers as f64)));
                pu.insert("zero_mode_gap".into(), stats(modal.iter().map(|p| p.zero_mode_gap)));
            }
            pu.insert("samples_without_peak".into(), MeanStd { mean: (pulses.len() - metrics.len()) as f64, std: 0.0, count: 1 });
        }
        let sig: Vec<Vec<f64>> = pulses.iter().map(|(_, p)| p.signal.clone()).collect();
        let (mean, rms) = mean_and_rms(&sig);
        let (mean_signal, mean_signal_error) = if mean.is_empty() {
            (None, None)
        } else {
            match pulse_metrics(&g.times, &mean, &popts) {
                Ok(m) => (Some(m), None),
                Err(e) => (None, Some(e.to_string())),
            }
        };
        let closed_form_difference = pulses.iter().filter_map(|(_, p)| p.closed_form_difference).reduce(f64::max);
        let closed_form = pulses.first().and_then(|(_, p)| p.closed_form.clone());
        let mut damped = Vec::new();
        let mut damped_signals = Vec::new();
        if let Some(dc) = &plan.config.damped {
            for &zeta in &dc.damping_fractions {
                let runs: Vec<_> = ok.iter().flat_map(|r| r.damped.iter().filter(|d| d.zeta == zeta)).collect();
                if runs.is_empty() {
                    continue;
                }
                let (m, _) = mean_and_rms(&runs.iter().map(|r| r.signal.clone()).collect::<Vec<_>>());
                damped.push(DampedSummary {
                    zeta,
                    samples: runs.len(),
                    metrics: pulse_metrics(&g.times, &m, &popts).ok(),
                    difference_to_linear: stats(runs.iter().map(|r| r.difference_to_linear.unwrap_or(f64::NAN))),
                });
                damped_signals.push((zeta, m));
            }
        }
        groups.push(GroupSummary {
            name: g.name.clone(),
            pressure: g.pressure,
            size: g.size_label.clone(),
            grains: g.grains,
            samples: ok.len(),
            failed: all.len() - ok.len(),
            height: stats(ok.iter().map(|r| r.height)),
            preparation: prep,
            characterization: ch,
            moduli: mo,
            pulse: pu,
            mean_signal,
            mean_signal_error,
            closed_form_difference,
            damped,
        });
        signals.push(GroupSignals { seeds: pulses.iter().map(|(s, _)| *s).collect(), signals: sig, mean, rms, closed_form, damped: damped_signals });
    }

    // series over heights, one per pressure
    let sopts = SeriesOptions { tof_heights: pc.tof_heights };
    let pressures: Vec<Option<f64>> = if plan.kind == StudyKind::Chain { vec![None] } else { plan.pressures().into_iter().map(Some).collect() };
    let mut heights = Vec::new();
    for (pi, &p) in pressures.iter().enumerate() {
        let idx: Vec<usize> = plan.groups.iter().filter(|g| plan.kind == StudyKind::Chain || g.pressure_index == pi).map(|g| g.index).collect();
        let points: Vec<(f64, PulseMetrics)> = idx
            .iter()
            .filter_map(|&k| {
                let h = if plan.kind == StudyKind::Chain { plan.groups[k].estimated_height } else { groups[k].height.mean };
                groups[k].mean_signal.clone().filter(|_| h.is_finite()).map(|m| (h, m))
            })
            .collect();
        let series = if points.is_empty() { None } else { analyze_heights(&points, &sopts).ok() };
        // every sample: (L, t_edge)
        let mut xs = Vec::new();
        let mut ts = Vec::new();
        for (t, r) in plan.tasks.iter().zip(results) {
            if !idx.contains(&t.group) {
                continue;
            }
            if let Some(r) = r.as_ref().filter(|r| r.failure.is_none()) {
                if let Some(m) = r.pulse.as_ref().and_then(|p| p.metrics.as_ref()) {
                    let h = if plan.kind == StudyKind::Chain { plan.groups[t.group].estimated_height } else { r.height };
                    xs.push(h);
                    ts.push(m.leading_edge_time);
                }
            }
        }
        let edge_fit_samples = if xs.len() >= 2 { linear_fit(&xs, &ts).ok() } else { None };
        // per-seed c_tof between the two reference groups
        let mut tof = Vec::new();
        if let Some(s) = series.as_ref().and_then(|s| s.time_of_flight.as_ref()) {
            let group_at = |h: f64| idx.iter().copied().find(|&k| {
                let gh = if plan.kind == StudyKind::Chain { plan.groups[k].estimated_height } else { groups[k].height.mean };
                gh == h
            });
            if let (Some(g1), Some(g2)) = (group_at(s.height_1), group_at(s.height_2)) {
                for seed in (0..plan.config.samples).map(|k| plan.config.seed + k as u64) {
                    let find = |g: usize| {
                        plan.tasks.iter().zip(results).find(|(t, _)| t.group == g && t.seed == seed).and_then(|(_, r)| r.as_ref()).filter(|r| r.failure.is_none())
                    };
                    if let (Some(a), Some(b)) = (find(g1), find(g2)) {
                        let ha = if plan.kind == StudyKind::Chain { plan.groups[g1].estimated_height } else { a.height };
                        let hb = if plan.kind == StudyKind::Chain { plan.groups[g2].estimated_height } else { b.height };
                        if let (Some(ma), Some(mb)) = (a.pulse.as_ref().and_then(|p| p.metrics.as_ref()), b.pulse.as_ref().and_then(|p| p.metrics.as_ref())) {
                            tof.push((hb - ha) / (mb.leading_edge_time - ma.leading_edge_time));
                        }
                    }
                }
            }
        }
        // exponents with bootstrap intervals over the samples of every height
        let (mut exponent_intervals, mut exponent_intervals_error) = (None, None);
        if pc.bootstrap > 0 && idx.len() >= 2 {
            let mut sg = Vec::new();
            for &k in &idx {
                let g = &plan.groups[k];
                let mut grp = SeriesGroup { times: g.times.clone(), heights: Vec::new(), signals: Vec::new() };
                for (t, r) in plan.tasks.iter().zip(results) {
                    if let Some(r) = r.as_ref().filter(|r| t.group == k && r.failure.is_none()) {
                        if let Some(pulse) = &r.pulse {
                            grp.heights.push(if plan.kind == StudyKind::Chain { g.estimated_height } else { r.height });
                            grp.signals.push(pulse.signal.clone());
                        }
                    }
                }
                if grp.signals.len() >= 2 {
                    sg.push(grp);
                }
            }
            let bo = BootstrapOptions { replicates: pc.bootstrap, resolution: pc.exponent_resolution, ..Default::default() };
            if sg.len() >= 2 {
                match bootstrap_exponents(&sg, &popts, &bo) {
                    Ok(e) => exponent_intervals = Some(e),
                    Err(e) => exponent_intervals_error = Some(e.to_string()),
                }
            } else {
                exponent_intervals_error = Some(format!("{} height(s) with at least two samples (intervals need two)", sg.len()));
            }
        }
        heights.push(HeightSeriesSummary { pressure: p, series, edge_fit_samples, time_of_flight_samples: mean_std(&tof), exponent_intervals, exponent_intervals_error });
    }

    // speeds vs pressure
    let mut speeds = Vec::new();
    if plan.kind != StudyKind::Chain && pressures.len() >= 2 {
        let ps: Vec<f64> = pressures.iter().map(|p| p.unwrap_or(f64::NAN)).collect();
        let fit = |v: &[f64]| -> Option<PowerLawFit> {
            let (x, y): (Vec<f64>, Vec<f64>) = ps.iter().zip(v).filter(|(_, y)| y.is_finite() && **y > 0.0).map(|(a, b)| (*a, *b)).unzip();
            if x.len() >= 2 {
                power_law_fit(&x, &y).ok()
            } else {
                None
            }
        };
        let mut push = |name: String, values: Vec<f64>| {
            let f = fit(&values);
            speeds.push(SpeedSeries { name, pressures: ps.clone(), values, fit: f });
        };
        push("c_tof".into(), heights.iter().map(|h| h.series.as_ref().and_then(|s| s.time_of_flight.as_ref()).map_or(f64::NAN, |t| t.velocity)).collect());
        push("edge_speed".into(), heights.iter().map(|h| h.series.as_ref().and_then(|s| s.edge_speed).unwrap_or(f64::NAN)).collect());
        if plan.kind == StudyKind::Lattice {
            // SPEC §5.6: the small-pressure closed form of the monodisperse lattice's speed
            let closed = |p: f64| {
                grainwave_linear::reference::TriangularLatticeSpec { pressure: p, friction: plan.friction, poisson: plan.poisson, young: 1.0 - plan.poisson * plan.poisson, ..Default::default() }
                    .closed_form_speed()
            };
            push("closed_form".into(), ps.iter().map(|&p| closed(p)).collect());
        }
        for si in 0..plan.sizes() {
            let at = |pi: usize| groups.iter().zip(&plan.groups).find(|(_, g)| g.size_index == si && g.pressure_index == pi).map(|(s, _)| s);
            let label = plan.groups.iter().find(|g| g.size_index == si).map(|g| g.size_label.clone()).unwrap_or_default();
            for key in ["c_l", "c_t", "C22", "C33"] {
                let v: Vec<f64> = (0..ps.len()).map(|pi| at(pi).and_then(|s| s.moduli.get(key)).map_or(f64::NAN, |m| m.mean)).collect();
                if v.iter().any(|x| x.is_finite()) {
                    push(format!("{key} {label}"), v);
                }
            }
        }
    }
    (Aggregate { groups, heights, pressures: speeds }, signals)
}
