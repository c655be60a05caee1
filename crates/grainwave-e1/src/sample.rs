//! The analysis of one sample: static characterization, elastic moduli, the pulse signal (modal sum
//! or direct propagation), its metrics, spectrum and mode contributions, displacement fields, and
//! the damped MD runs.

use super::config::*;
use super::plan::{Group, Plan, StudyKind};
use super::prepare::{set_damping, PreparationInfo};
use grainwave_analysis::packing::{characterize, CharacterizationOptions, PackingStatistics};
use grainwave_analysis::signal::{pulse_metrics, PulseMetrics, PulseOptions};
use grainwave_core::prelude::*;
use grainwave_linear::moduli::{elastic_moduli, local_modulus, LocalLoading, ModuliOptions};
use grainwave_linear::prelude::{
    detector_vector, propagate_signal, source_vector, AssemblyOptions, Constraints, DynamicalMatrix, EigenOptions, InitialCondition, ModalSignal, Modes,
    PreStress, PropagationOptions, Propagator, Rattlers, ZeroRows,
};
use grainwave_linear::contact::Partner;
use grainwave_linear::reference::ChainSpec;
use serde::{Deserialize, Serialize};

/// Elastic moduli of a sample. In 2D, C₁₁ = C_xxxx, C₁₂ = C_xxyy, C₂₂ = C_yyyy, C₃₃ = C_xyxy (y the
/// piston axis); in 3D the same names stand for C_xxxx, C_xxzz, C_zzzz and C_xzxz (z the piston axis).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModuliResult {
    /// C₁₁ [force/area].
    pub c11: f64,
    /// C₁₂ [force/area].
    pub c12: f64,
    /// C₂₂ [force/area].
    pub c22: f64,
    /// C₃₃ [force/area].
    pub c33: f64,
    /// The relaxed Voigt matrix (3 × 3 or 6 × 6) [force/area].
    pub voigt: Vec<Vec<f64>>,
    /// The affine Voigt matrix [force/area].
    pub affine: Vec<Vec<f64>>,
    /// Density ρ* = Φ₃* (non-rattlers) [mass/volume].
    pub density: f64,
    /// c_ℓ = √(C₂₂/ρ*) [length/time].
    pub longitudinal_speed: f64,
    /// c_t = √(C₃₃/ρ*) [length/time].
    pub transverse_speed: f64,
    /// Relative asymmetry of C before symmetrization.
    pub asymmetry: f64,
    /// Local moduli: (name, value), e.g. (`C33 body force n=1`, …) [force/area].
    pub local: Vec<(String, f64)>,
}

/// A displacement field at one time: the translation of every grain (storage order, d components).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DisplacementField {
    /// Time [time].
    pub time: f64,
    /// The time as a fraction of the first-peak time.
    pub fraction: f64,
    /// u of grain g, component a at `g * d + a` [length per unit h].
    pub displacement: Vec<f64>,
}

/// The pulse of a sample.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PulseResult {
    /// F_sig on the group's time grid.
    pub signal: Vec<f64>,
    /// Metrics of the first coherent peak (absent when no peak could be found).
    pub metrics: Option<PulseMetrics>,
    /// Why there are no metrics.
    pub metrics_error: Option<String>,
    /// ω_n² (modal sum only) [1/time²].
    pub omega_squared: Vec<f64>,
    /// Mode contributions a_n b_n (modal sum only).
    pub contributions: Vec<f64>,
    /// Participation ratios of the modes (modal sum only).
    pub participation: Vec<f64>,
    /// Free dofs of the linear system.
    pub dofs: usize,
    /// Zero modes (|ω²| ≤ 1e-12 max ω², [`grainwave_linear::pulse::ZERO_MODE_TOLERANCE`]; modal sum
    /// only).
    pub zero_modes: usize,
    /// The rattlers' part of the zero space: the eigenvalues ≥ [`RATTLER_ZERO_MODE_WEIGHT`] of
    /// P = Zᵀ M_R Z (Z the M-normalized zero modes, M_R the mass on the rattlers' dofs), i.e. the
    /// dimension of the zero-energy motions with at least 99 % of their kinetic energy on rattlers
    /// (see [`grainwave_linear::Modes::zero_space_split`]). Rattlers as in the characterization.
    pub rattler_zero_modes: usize,
    /// Smallest eigenvalue of P counted in `rattler_zero_modes` (1 when all are exact; NaN when none).
    pub rattler_weight_min: f64,
    /// Largest eigenvalue of P not counted (0 for a clean split; NaN when every zero mode is counted).
    pub other_weight_max: f64,
    /// |ω²| of the first mode above the zero modes over max ω² (the gap that makes the count).
    pub zero_mode_gap: f64,
    /// Rattlers without any linearized contact (k_n > 0): 3 zero modes each in 2D (6 in 3D).
    pub contactless_rattlers: usize,
    /// Rattlers with exactly one linearized contact: with friction, at least one zero mode each
    /// (rolling about the contact point). 3 × contactless + one-contact (2D, frictional) is a lower
    /// bound of `rattler_zero_modes`.
    pub one_contact_rattlers: usize,
    /// Chains: the closed-form mode sum on the same grid.
    pub closed_form: Option<Vec<f64>>,
    /// Chains: max |generic − closed form| / max |closed form|.
    pub closed_form_difference: Option<f64>,
    /// Displacement fields (first sample of each group).
    pub fields: Vec<DisplacementField>,
    /// Wall-clock seconds of the pulse computation [s].
    pub seconds: f64,
}

/// One damped MD run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DampedRun {
    /// ζ.
    pub zeta: f64,
    /// Kick strength h [length × time].
    pub strength: f64,
    /// MD time step [time].
    pub dt: f64,
    /// (Top-wall load kicked − unkicked)/h on the group's grid.
    pub signal: Vec<f64>,
    /// Metrics of the first peak.
    pub metrics: Option<PulseMetrics>,
    /// Relative L2 difference to the linear signal over its first transit (0 to its first zero
    /// crossing after the first peak).
    pub difference_to_linear: Option<f64>,
}

/// Everything measured on one sample (persisted as `result.gwck`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleResult {
    /// Fingerprint of the config parts that determine this result.
    pub fingerprint: u64,
    /// Group index.
    pub group: usize,
    /// Sample index k.
    pub sample: usize,
    /// Seed.
    pub seed: u64,
    /// Why the sample failed, if it did (then the other fields may be empty).
    pub failure: Option<String>,
    /// Grains.
    pub grains: usize,
    /// Source–detector distance: the gap between the bottom and top walls [length].
    pub height: f64,
    /// The preparation (packings, polydisperse lattices).
    pub preparation: Option<PreparationInfo>,
    /// Static characterization.
    pub statistics: Option<PackingStatistics>,
    /// Elastic moduli.
    pub moduli: Option<ModuliResult>,
    /// The pulse.
    pub pulse: Option<PulseResult>,
    /// Damped MD runs.
    pub damped: Vec<DampedRun>,
    /// Wall-clock seconds of the analysis [s].
    pub seconds: f64,
}

impl SampleResult {
    /// An empty result for `task`.
    pub fn new(fingerprint: u64, group: usize, sample: usize, seed: u64) -> Self {
        SampleResult {
            fingerprint,
            group,
            sample,
            seed,
            failure: None,
            grains: 0,
            height: f64::NAN,
            preparation: None,
            statistics: None,
            moduli: None,
            pulse: None,
            damped: Vec::new(),
            seconds: 0.0,
        }
    }
}

/// A direction of the zero space counts as the rattlers' when at least this share of its kinetic
/// energy is on rattler dofs. The constructed packings of the linear crate's tests give shares of
/// exactly 0 or 1 (to 1e-9), so any threshold inside (0, 1) counts the same there; in prepared
/// packings `rattler_weight_min` and `other_weight_max` record how clean the split is.
pub const RATTLER_ZERO_MODE_WEIGHT: f64 = 0.99;

fn pulse_options(c: &PulseConfig) -> PulseOptions {
    PulseOptions { edge_fraction: c.edge_fraction, peak_threshold: c.peak_threshold.unwrap_or(grainwave_analysis::signal::DEFAULT_PEAK_THRESHOLD) }
}

fn metrics_of(times: &[f64], values: &[f64], c: &PulseConfig) -> (Option<PulseMetrics>, Option<String>) {
    match pulse_metrics(times, values, &pulse_options(c)) {
        Ok(m) => (Some(m), None),
        Err(e) => (None, Some(e.to_string())),
    }
}

fn linear_error(e: grainwave_linear::LinearError) -> crate::ExperimentError {
    CoreError::Inconsistent(format!("linear analysis: {e}")).into()
}

/// Relative L2 difference of `a` to `reference` over the first `n` samples.
pub fn relative_l2(a: &[f64], reference: &[f64], n: usize) -> f64 {
    let n = n.min(a.len()).min(reference.len());
    let num: f64 = (0..n).map(|k| (a[k] - reference[k]).powi(2)).sum();
    let den: f64 = (0..n).map(|k| reference[k].powi(2)).sum();
    (num / den).sqrt()
}

/// Characterization, moduli, pulse and damped runs of a static Hertz–Mindlin packing or lattice.
pub fn analyze_packing<D: Dim>(sim: &Simulation<D>, plan: &Plan, group: &Group, sample: usize, result: &mut SampleResult) -> crate::Result<()> {
    let cfg = &plan.config;
    let snap = sim.snapshot();
    let z = D::D - 1;
    result.grains = snap.len();
    let gap = grainwave_analysis::packing::wall_gap(&snap.domain, z);
    result.height = gap.map_or(f64::NAN, |(a, b)| b - a);
    let ch = &cfg.characterization;
    let stats = characterize(
        &snap,
        &CharacterizationOptions { boundary_layer: ch.boundary_layer, axis: Some(z), rattler_min_contacts: ch.rattler_min_contacts, pressure: group.pressure },
    );
    result.statistics = Some(stats);

    if cfg.moduli.enabled {
        let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).map_err(linear_error)?;
        let m = elastic_moduli(&dm, &ModuliOptions::default()).map_err(linear_error)?;
        let (i11, i12, i22, i33) = if D::D == 2 { ((0, 0), (0, 1), (1, 1), (2, 2)) } else { ((0, 0), (0, 2), (2, 2), (4, 4)) };
        let mut local = Vec::new();
        if cfg.moduli.local {
            let opts = ModuliOptions::default();
            for (axis, name) in [(0, "C33"), (z, "C22")] {
                for n in [1, 2] {
                    let l = local_modulus(&dm, axis, &LocalLoading::BodyForce { n }, &opts).map_err(linear_error)?;
                    local.push((format!("{name} body force n={n}"), l.modulus));
                }
                for n in [1, 3] {
                    let l = local_modulus(&dm, axis, &LocalLoading::ImposedLines { n, fix_transverse: true }, &opts).map_err(linear_error)?;
                    local.push((format!("{name} imposed lines n={n}"), l.modulus));
                }
            }
        }
        result.moduli = Some(ModuliResult {
            c11: m.voigt[i11.0][i11.1],
            c12: m.voigt[i12.0][i12.1],
            c22: m.voigt[i22.0][i22.1],
            c33: m.voigt[i33.0][i33.1],
            density: m.density,
            longitudinal_speed: m.longitudinal_speed,
            transverse_speed: m.transverse_speed,
            asymmetry: m.asymmetry,
            voigt: m.voigt,
            affine: m.affine,
            local,
        });
    }

    if cfg.pulse.enabled {
        let pc = &cfg.pulse;
        let options = AssemblyOptions {
            prestress: match pc.prestress {
                PreStressName::None => PreStress::None,
                PreStressName::Normal => PreStress::Normal,
                PreStressName::Full => PreStress::Full,
            },
            rattlers: match pc.rattlers {
                RattlerHandling::Keep => Rattlers::Keep,
                RattlerHandling::Remove => Rattlers::Remove,
            },
            ..Default::default()
        };
        let ic = match pc.initial_condition {
            InitialConditionName::Impulse => InitialCondition::Impulse { strength: 1.0 },
            InitialConditionName::Displacement => InitialCondition::Displacement { amplitude: 1.0 },
        };
        let fields = if sample == 0 { pc.field_times.clone() } else { Vec::new() };
        let flags = result.statistics.as_ref().map(|s| s.rattler_flags.as_slice());
        let pulse = linear_pulse(&snap, &options, &Constraints::new(), &ic, group, pc, &fields, flags)?;
        if let Some(d) = &cfg.damped {
            if sample < d.samples {
                result.damped = damped_runs(sim, plan, group, d, &pulse)?;
            }
        }
        result.pulse = Some(pulse);
    }
    Ok(())
}

/// The linear pulse of `snap` (walls 0 → 1).
fn linear_pulse<D: Dim>(
    snap: &Snapshot<D>,
    options: &AssemblyOptions,
    constraints: &Constraints,
    ic: &InitialCondition,
    group: &Group,
    pc: &PulseConfig,
    field_fractions: &[f64],
    rattlers: Option<&[bool]>,
) -> crate::Result<PulseResult> {
    let started = std::time::Instant::now();
    let dm = DynamicalMatrix::assemble(snap, options).map_err(linear_error)?;
    let system = dm.free_system(constraints, ZeroRows::Keep).map_err(linear_error)?;
    let source = source_vector(&dm, &system, 0).map_err(linear_error)?;
    let detector = detector_vector(&dm, &system, 1).map_err(linear_error)?;
    let state = ic.state(&system, &source).map_err(linear_error)?;
    let times = &group.times;
    let d = D::D;
    let layout = *dm.layout();
    let translations = |full: &[f64]| -> Vec<f64> {
        let mut u = vec![0.0; layout.grains * d];
        for g in 0..layout.grains {
            for a in 0..d {
                u[g * d + a] = full[layout.translation(g, a)];
            }
        }
        u
    };
    let mut out = PulseResult {
        signal: Vec::new(),
        metrics: None,
        metrics_error: None,
        omega_squared: Vec::new(),
        contributions: Vec::new(),
        participation: Vec::new(),
        dofs: system.dofs(),
        zero_modes: 0,
        rattler_zero_modes: 0,
        rattler_weight_min: f64::NAN,
        other_weight_max: f64::NAN,
        zero_mode_gap: f64::NAN,
        contactless_rattlers: 0,
        one_contact_rattlers: 0,
        closed_form: None,
        closed_form_difference: None,
        fields: Vec::new(),
        seconds: 0.0,
    };
    match pc.method {
        PulseMethod::Modal => {
            let modes = Modes::compute(&system, &EigenOptions { threads: Some(1), ..Default::default() }).map_err(linear_error)?;
            let modal = ModalSignal::new(&modes, &state, &detector.vector).map_err(linear_error)?;
            out.signal = modal.eval_many(times);
            out.omega_squared = modes.omega_squared().to_vec();
            out.contributions = modal.contributions(ic).to_vec();
            out.participation = modes.participation().to_vec();
            let tolerance = grainwave_linear::pulse::ZERO_MODE_TOLERANCE;
            out.zero_modes = modes.zero_modes(tolerance);
            out.zero_mode_gap = modes.zero_mode_gap(tolerance);
            // (with rattlers removed from the system there is nothing of theirs to count)
            if let (Some(flags), false) = (rattlers, dm.removed().iter().any(|&r| r)) {
                let selected: Vec<bool> = modes.free_dofs().iter().map(|&f| flags[layout.grain_of(f)]).collect();
                let split = modes.zero_space_split(tolerance, &selected, RATTLER_ZERO_MODE_WEIGHT).map_err(linear_error)?;
                out.rattler_zero_modes = split.localized;
                out.rattler_weight_min = split.weights[..split.localized].last().copied().unwrap_or(f64::NAN);
                out.other_weight_max = split.weights.get(split.localized).copied().unwrap_or(f64::NAN);
                let mut held = vec![0usize; layout.grains];
                for c in dm.contacts().iter().filter(|c| c.normal_stiffness > 0.0) {
                    held[c.i] += 1;
                    if let Partner::Grain(j) = c.j {
                        held[j] += 1;
                    }
                }
                out.contactless_rattlers = (0..layout.grains).filter(|&g| flags[g] && held[g] == 0).count();
                out.one_contact_rattlers = (0..layout.grains).filter(|&g| flags[g] && held[g] == 1).count();
            }
            let (m, e) = metrics_of(times, &out.signal, pc);
            if let (Some(m), false) = (&m, field_fractions.is_empty()) {
                let alpha = modes.project(&state.displacement).map_err(linear_error)?;
                let beta = modes.project(&state.velocity).map_err(linear_error)?;
                let v = modes.vectors();
                let n = modes.len();
                for &f in field_fractions {
                    let t = f * m.peak_time;
                    let coef: Vec<f64> = (0..n)
                        .map(|k| {
                            if modal.zero_mode[k] {
                                alpha[k] + beta[k] * t
                            } else {
                                let w = modal.omega[k];
                                alpha[k] * (w * t).cos() + beta[k] * (w * t).sin() / w
                            }
                        })
                        .collect();
                    let mut u = vec![0.0; n];
                    for (k, c) in coef.iter().enumerate() {
                        if *c != 0.0 {
                            let col = v.col(k);
                            for (r, ur) in u.iter_mut().enumerate() {
                                *ur += c * col[r];
                            }
                        }
                    }
                    let full = system.expand(&u).map_err(linear_error)?;
                    out.fields.push(DisplacementField { time: t, fraction: f, displacement: translations(&full) });
                }
            }
            out.metrics = m;
            out.metrics_error = e;
        }
        PulseMethod::Direct => {
            let popts = PropagationOptions::default();
            let sig = propagate_signal(&system, system.mass(), &state, &detector.vector, times, &popts).map_err(linear_error)?;
            out.signal = sig.values;
            let (m, e) = metrics_of(times, &out.signal, pc);
            if let (Some(m), false) = (&m, field_fractions.is_empty()) {
                let mut order: Vec<f64> = field_fractions.to_vec();
                order.sort_by(f64::total_cmp);
                let mut prop = Propagator::new(&system, system.mass(), &state, None, &popts).map_err(linear_error)?;
                for f in order {
                    let t = f * m.peak_time;
                    prop.advance_to(t).map_err(linear_error)?;
                    let full = system.expand(prop.displacement()).map_err(linear_error)?;
                    out.fields.push(DisplacementField { time: t, fraction: f, displacement: translations(&full) });
                }
            }
            out.metrics = m;
            out.metrics_error = e;
        }
    }
    out.seconds = started.elapsed().as_secs_f64();
    Ok(out)
}

/// The pulse of a 1D chain: generic machinery and, when monodisperse, the closed-form mode sum.
pub fn analyze_chain(spec: &ChainSpec, plan: &Plan, group: &Group, result: &mut SampleResult) -> crate::Result<()> {
    let pc = &plan.config.pulse;
    let sim = spec.build().map_err(linear_error)?;
    let snap = sim.snapshot();
    result.grains = snap.len();
    result.height = grainwave_analysis::packing::wall_gap(&snap.domain, 0).map_or(f64::NAN, |(a, b)| b - a);
    if !pc.enabled {
        return Ok(());
    }
    let ic = match pc.initial_condition {
        InitialConditionName::Impulse => spec.impulse(),
        InitialConditionName::Displacement => spec.displacement(),
    };
    let mut pulse = linear_pulse(&snap, &AssemblyOptions::default(), &spec.constraints(), &ic, group, pc, &[], None)?;
    if spec.polydispersity == 0.0 {
        let closed: Vec<f64> = group.times.iter().map(|&t| spec.closed_form_signal(t, &ic)).collect();
        let scale = closed.iter().fold(0.0_f64, |a, &b| a.max(b.abs()));
        let diff = pulse.signal.iter().zip(&closed).fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
        pulse.closed_form_difference = Some(diff / scale);
        pulse.closed_form = Some(closed);
    }
    result.pulse = Some(pulse);
    Ok(())
}

/// The damped MD runs of SPEC §5.7 (see [`DampedConfig`]).
fn damped_runs<D: Dim>(sim0: &Simulation<D>, plan: &Plan, group: &Group, d: &DampedConfig, linear: &PulseResult) -> crate::Result<Vec<DampedRun>> {
    let times = &group.times;
    let dt_grid = times[1] - times[0];
    let n_transit = linear
        .metrics
        .as_ref()
        .and_then(|m| m.zero_crossing_time)
        .map_or(times.len(), |tz| ((tz / dt_grid).ceil() as usize + 1).min(times.len()));
    let mut runs = Vec::new();
    for &zeta in &d.damping_fractions {
        let mut base = sim0.clone();
        for w in base.domain.walls.iter_mut() {
            w.motion = WallMotion::Fixed;
            w.speed = 0.0;
        }
        for v in base.grains.vel.iter_mut() {
            *v = D::Vector::ZERO;
        }
        for w in base.grains.omega.iter_mut() {
            *w = D::AngVector::ZERO;
        }
        set_damping(&mut base, plan.friction, plan.poisson, zeta)?;
        let snap = base.snapshot();
        let bottom: Vec<&ContactRecord<D>> = snap.contacts.iter().filter(|c| c.j == Counterpart::Wall(0)).collect();
        if bottom.is_empty() {
            return Err(CoreError::Inconsistent("no grain touches the bottom wall: no pulse can be emitted".into()).into());
        }
        let xi = bottom.iter().map(|c| c.overlap).sum::<f64>() / bottom.len() as f64;
        let k = bottom.iter().map(|c| c.normal_stiffness).sum::<f64>() / bottom.len() as f64;
        let m_mean = base.grains.total_mass() / base.len() as f64;
        let h = d.amplitude * xi / (k / m_mean).sqrt();
        let substeps = (dt_grid / base.dt).ceil().max(1.0) as u64;
        base.dt = dt_grid / substeps as f64;
        let mut kicked = base.clone();
        let index: std::collections::HashMap<u32, usize> = kicked.grains.id.iter().enumerate().map(|(k, &id)| (id, k)).collect();
        for c in &bottom {
            let g = index[&c.i];
            let m = kicked.grains.mass[g];
            let dv = c.normal * (-h * c.normal_stiffness / m);
            kicked.grains.vel[g] += dv;
        }
        let mut signal = Vec::with_capacity(times.len());
        signal.push((kicked.domain.walls[1].normal_load() - base.domain.walls[1].normal_load()) / h);
        for _ in 1..times.len() {
            base.steps(substeps)?;
            kicked.steps(substeps)?;
            signal.push((kicked.domain.walls[1].normal_load() - base.domain.walls[1].normal_load()) / h);
        }
        let (metrics, _) = metrics_of(times, &signal, &plan.config.pulse);
        let difference_to_linear = if linear.signal.len() == signal.len() { Some(relative_l2(&signal, &linear.signal, n_transit)) } else { None };
        runs.push(DampedRun { zeta, strength: h, dt: base.dt, signal, metrics, difference_to_linear });
    }
    Ok(runs)
}

/// The chain spec of a chain group.
pub fn chain_spec(plan: &Plan, group: &Group, seed: u64) -> ChainSpec {
    let c = plan.config.chain.as_ref().expect("a chain study");
    ChainSpec { grains: group.grains, spacing: c.spacing, stiffness: c.stiffness, mass: c.mass, polydispersity: c.polydispersity, seed }
}

/// True when `plan` studies Hertz–Mindlin packings or lattices.
pub fn is_hertz(plan: &Plan) -> bool {
    plan.kind != StudyKind::Chain
}
