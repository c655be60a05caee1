//! The `e1` protocol (SPEC §5): preparation reaches the requested pressure and equilibrium; the
//! static characterization on configurations with known answers (a perfect triangular packing,
//! planted rattlers); ensembles resume without recomputing finished samples, bit for bit, and do
//! not depend on the number of threads; the chain through the generic machinery matches its closed
//! form; damped MD without damping matches the linear signal; config errors point at their keys.

use grainwave_analysis::packing::{characterize, CharacterizationOptions};
use grainwave_core::prelude::*;
use grainwave_study::config::ConfigSource;
use grainwave_e1::config::PreparationConfig;
use grainwave_e1::ensemble::{load_packing, load_result, sample_dir};
use grainwave_e1::prepare::{build_gas, relax, PackingSpec, PreparationInfo, RelaxStatus};
use grainwave_e1::sample::SampleResult;
use grainwave_e1 as e1;
use grainwave_e1::E1State;
use grainwave_study::protocol::{Reporter, RunContext, SilentReporter};
use grainwave_study::{ExperimentError, Progress};
use grainwave_linear::reference::TriangularLatticeSpec;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("grainwave-e1-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn run_text(text: &str, out: &Path) -> grainwave_study::Result<grainwave_study::registry::RunSummary> {
    let src = ConfigSource::from_text("e1.toml", text);
    let mut rep = SilentReporter;
    let mut ctx = RunContext::new(out, &mut rep, Arc::new(AtomicBool::new(false)))?;
    crate::REGISTRY.run(&src, &mut ctx)
}

/// Prepares one packing and checks equilibrium and pressure.
fn prepared<D: Dim>(grains: usize, width: f64, pressure: f64, friction: f64, seed: u64) -> (Simulation<D>, PreparationInfo) {
    let spec = PackingSpec { grains, width, spread: if D::D == 2 { 0.2 } else { 0.0 }, friction, poisson: 0.0, pressure, seed, preparation: PreparationConfig::default() };
    let mut sim = build_gas::<D>(&spec).unwrap();
    let mut info = PreparationInfo::default();
    let flag = AtomicBool::new(false);
    let status = relax(&mut sim, &mut info, &spec.preparation, pressure, &flag, 1e9, &mut |_, _| Ok(())).unwrap();
    assert_eq!(status, RelaxStatus::Converged);
    (sim, info)
}

/// SPEC §5.1: the piston compresses the gas until every grain's acceleration and the piston's
/// are below 1e-10; then the stress along the piston axis equals p. At static equilibrium the
/// virial of all contacts (wall contacts with their branch to the contact point) is exactly
/// F_piston × H, so σ_yy = F/(L_x d̄) = p up to the residual forces: |σ_yy − p| ≤ Σm a_max H/V,
/// ~1e-6 p here. The issue asks for 1 %.
#[test]
fn preparation_reaches_the_pressure_and_equilibrium() {
    let tol = PreparationConfig::default().max_acceleration;
    let stop = StopCriteria { step_limit: Some(u64::MAX), ..Default::default() };
    let check = |name: &str, snap_stress: f64, p: f64, acc: f64, piston: f64, info: &PreparationInfo| {
        eprintln!("{name}: σ_axial/p − 1 = {:.2e}, max acceleration {acc:.2e}, piston {piston:.2e}, {} steps, {} quenches, {:.1} s", snap_stress / p - 1.0, info.steps, info.quenches, info.seconds);
        assert!(info.converged && acc < tol && piston < tol, "{name}: not in equilibrium");
        // SPEC §5.1: plain damped MD by default — no velocity was ever zeroed
        assert_eq!(info.quenches, 0, "{name}: the default preparation quenched");
        assert!((snap_stress / p - 1.0).abs() < 0.01, "{name}: σ_axial = {snap_stress:e} for p = {p:e}");
    };
    for (friction, pressure) in [(0.5, 1e-4), (0.0, 1e-5)] {
        let (sim, info) = prepared::<D2>(80, 8.0, pressure, friction, 7);
        let s = characterize(&sim.snapshot(), &CharacterizationOptions { pressure: Some(pressure), ..Default::default() });
        let p = sim.progress(&stop);
        check(&format!("sphere2d μ = {friction}, p = {pressure:e}"), s.stress.tensor[3], pressure, p.max_acceleration, sim.domain.walls[1].accel.abs(), &info);
        if friction == 0.0 {
            // frictionless: rattler threshold d + 1 = 3, no tangential forces
            assert!(sim.snapshot().contacts.iter().all(|c| c.tangential_force.norm() == 0.0));
        }
    }
    let (sim, info) = prepared::<D3>(60, 4.0, 1e-4, 0.5, 3);
    let s = characterize(&sim.snapshot(), &CharacterizationOptions { pressure: Some(1e-4), boundary_layer: 1.0, ..Default::default() });
    let p = sim.progress(&stop);
    check("sphere (3D)", s.stress.tensor[8], 1e-4, p.max_acceleration, sim.domain.walls[1].accel.abs(), &info);
}

/// The tail time step (`preparation.tail_dt_factor`): once the kinetic energy per grain is below
/// 1e-5 p d̄³ and at most 1 % of the contacts slide, the contact network has settled, and the 3× step only shortens the rattlers' slow
/// bouncing. The same seed with the factor 1 and the default must end in the same packing: the
/// same contacts and force-carrying grains, the piston at the same height and the same pressure
/// to 1e-5 relative (measured over 20 + 20 packings of 618 grains: the median per-packing
/// difference of C₃₃ is 5e-5 at p = 1e-4 and 1e-3 at 1e-6, far below the 12–22 % ensemble spread),
/// in fewer steps (2.1–2.5 × fewer over those ensembles; ≥ 1.3 × demanded of this one packing),
/// and the packing keeps the preparation's step for what follows.
#[test]
fn tail_time_step_keeps_the_packing_in_fewer_steps() {
    let run = |factor: f64| {
        let preparation = PreparationConfig { tail_dt_factor: factor, ..PreparationConfig::default() };
        let spec = PackingSpec { grains: 120, width: 10.0, spread: 0.2, friction: 0.5, poisson: 0.0, pressure: 1e-4, seed: 5, preparation };
        let mut sim = build_gas::<D2>(&spec).unwrap();
        let dt0 = sim.dt;
        let mut info = PreparationInfo::default();
        let status = relax(&mut sim, &mut info, &spec.preparation, 1e-4, &AtomicBool::new(false), 1e9, &mut |_, _| Ok(())).unwrap();
        assert_eq!(status, RelaxStatus::Converged);
        assert_eq!(sim.dt, dt0, "the packing must keep the preparation's time step");
        (sim, info)
    };
    let (plain, plain_info) = run(1.0);
    let (tail, tail_info) = run(PreparationConfig::default().tail_dt_factor);
    assert!(plain_info.tail_step.is_none());
    let switched = tail_info.tail_step.expect("the tail step must take over");
    eprintln!("steps {} → {} (tail from step {switched})", plain_info.steps, tail_info.steps);
    assert!(plain_info.steps as f64 >= 1.3 * tail_info.steps as f64, "{} vs {} steps", plain_info.steps, tail_info.steps);
    let opts = CharacterizationOptions { pressure: Some(1e-4), ..Default::default() };
    let (a, b) = (characterize(&plain.snapshot(), &opts), characterize(&tail.snapshot(), &opts));
    assert_eq!(a.rattlers, b.rattlers);
    assert_eq!(a.coordination_star, b.coordination_star);
    let (ha, hb) = (plain.domain.walls[1].position.y, tail.domain.walls[1].position.y);
    assert!((ha / hb - 1.0).abs() < 1e-5, "piston height {ha} vs {hb}");
    assert!((a.stress.tensor[3] / b.stress.tensor[3] - 1.0).abs() < 1e-5, "σ_yy {} vs {}", a.stress.tensor[3], b.stress.tensor[3]);
}

/// A perfect triangular packing (monodisperse Hertz balls in exact equilibrium, one lattice
/// direction along the walls): every bulk grain has 6 contacts, every bulk contact carries the
/// same force N = a p d̄/√3 (a the spacing), F₂ = ⟨n_y²⟩ = (0 + ¾ + ¾)/3 = ½, no rattlers, an
/// isotropic stress σ_xx = σ_yy = p, and Φ₂ = πR²/(a · a√3/2) over a slab spanning whole rows.
#[test]
fn triangular_packing_has_known_characterization() {
    let spec = TriangularLatticeSpec { rows: 14, columns: 10, pressure: 1e-4, friction: 0.5, ..Default::default() };
    let sim = spec.build().unwrap();
    let snap = sim.snapshot();
    let geo = spec.geometry();
    let (a, r) = (geo.spacing, 0.5);
    let dy = a * 3f64.sqrt() / 2.0;
    let height = snap.domain.walls[1].position.y - snap.domain.walls[0].position.y;
    // boundary layer so that the slab is 8 row periods long (the area density is periodic in y)
    let l = (height - 8.0 * dy) / 2.0;
    let s = characterize(&snap, &CharacterizationOptions { boundary_layer: l, pressure: Some(1e-4), ..Default::default() });
    eprintln!("lattice: z* = {}, F2 = {}, Z2 = {}, Φ2 = {:?}, σ = {:?}", s.coordination_star, s.f2, s.z2, s.phi2, s.stress.tensor);
    assert_eq!(s.rattlers, 0);
    assert_eq!(s.rattler_fraction, 0.0);
    assert_eq!(s.bulk_grains, 80);
    assert!((s.coordination_star - 6.0).abs() < 1e-12 && (s.coordination - 6.0).abs() < 1e-12);
    // (F₂^S is not tested: with all forces equal, "N > ⟨N⟩" picks contacts by rounding noise)
    assert!((s.f2 - 0.5).abs() < 1e-12, "F2 = {}", s.f2);
    assert!((s.fabric[0] - 0.5).abs() < 1e-12 && s.fabric[1].abs() < 1e-12);
    // equal forces (to the rounding of the exact-equilibrium construction)
    assert!((s.z2 - 1.0).abs() < 1e-12 && (s.z3 - 1.0).abs() < 1e-12, "Z2 = {}, Z3 = {}", s.z2, s.z3);
    assert!((s.mean_force - geo.contact_force).abs() < 1e-12 * geo.contact_force);
    assert!((s.mean_force_over_p - a / 3f64.sqrt()).abs() < 1e-9);
    let phi2 = std::f64::consts::PI * r * r / (a * dy);
    assert!((s.phi2.unwrap() - phi2).abs() < 1e-12, "Φ₂ = {} vs {phi2}", s.phi2.unwrap());
    let phi3 = std::f64::consts::PI / 6.0 / (a * dy);
    assert!((s.phi3.unwrap() - phi3).abs() < 1e-12 && (s.phi3_star.unwrap() - phi3).abs() < 1e-12);
    // stress: the lattice is in exact equilibrium; the whole cell carries σ_yy = p (its boundary
    // rows and wall gaps make σ_xx smaller), the bulk is isotropic: each grain's six bonds give
    // ½ Σ F a n̂n̂ = 3/2 F a I, i.e. σ = 3F/(2 dy) = p (d̄ = 1)
    let t = &s.stress.tensor;
    assert!((t[3] / 1e-4 - 1.0).abs() < 1e-9 && t[1].abs() < 1e-15 && t[0] < t[3], "{t:?}");
    let b = &s.bulk_stress.tensor;
    assert!((b[3] / 1e-4 - 1.0).abs() < 1e-9 && (b[0] / 1e-4 - 1.0).abs() < 1e-9, "{b:?}");
    assert!((s.bulk_stress.ratio - 1.0).abs() < 1e-9);
    // angles 0, π/3, 2π/3 in equal parts; no sliding contact
    let third = s.angles_all.len() as f64 / 3.0;
    for target in [0.0, std::f64::consts::FRAC_PI_3, 2.0 * std::f64::consts::FRAC_PI_3] {
        let n = s.angles_all.iter().filter(|&&x| (x - target).abs() < 1e-9).count() as f64;
        assert!((n - third).abs() <= 1.0, "{n} contacts at angle {target}");
    }
    assert!(s.angles_sliding.is_empty());
}

/// Rattlers planted in the triangular packing are found, and only they: (1) a shrunk grain that
/// touches nothing; (2) iterated removal in a hand-edited contact network — grain A loses every
/// force, grain C keeps two forces, one of them with A, so C goes in the second round.
#[test]
fn planted_rattlers_are_found() {
    let spec = TriangularLatticeSpec { rows: 12, columns: 10, pressure: 1e-4, friction: 0.5, ..Default::default() };
    let mut sim = spec.build().unwrap();
    let shrunk = 5 * 10 + 4; // a bulk grain
    sim.grains.radius[shrunk] = 0.3;
    sim.refresh().unwrap();
    let snap = sim.snapshot();
    let s = characterize(&snap, &CharacterizationOptions::default());
    assert_eq!(s.rattlers, 1);
    assert!(s.rattler_flags[shrunk]);
    assert!(s.rattler_fraction > 0.0);

    let sim = spec.build().unwrap();
    let mut snap = sim.snapshot();
    let (a, c) = (6 * 10 + 3, 6 * 10 + 4); // neighbours in a row
    let partners = |snap: &Snapshot<D2>, g: u32| -> Vec<usize> {
        (0..snap.contacts.len()).filter(|&k| snap.contacts[k].i == g || snap.contacts[k].j == Counterpart::Grain(g)).collect()
    };
    for k in partners(&snap, a as u32) {
        snap.contacts[k].normal_force = 0.0;
    }
    // C keeps its contact with A and one more
    let mut kept_other = false;
    for k in partners(&snap, c as u32) {
        let rec = &snap.contacts[k];
        let with_a = rec.i == a as u32 || rec.j == Counterpart::Grain(a as u32);
        if with_a {
            snap.contacts[k].normal_force = 1e-4; // A's side was zeroed above: give it back so C counts it
        } else if !kept_other {
            kept_other = true;
        } else {
            snap.contacts[k].normal_force = 0.0;
        }
    }
    let s = characterize(&snap, &CharacterizationOptions::default());
    let found: Vec<usize> = (0..snap.len()).filter(|&g| s.rattler_flags[g]).collect();
    // A now has one force-carrying contact (with C): removed first; then C has one left
    assert_eq!(found, vec![a, c], "rattlers {found:?}");
    // with a threshold of 1, A (one contact) and C (two) both stay
    let s1 = characterize(&snap, &CharacterizationOptions { rattler_min_contacts: Some(1), ..Default::default() });
    assert_eq!(s1.rattlers, 0);
}

/// A small ensemble: 2 sizes × 1 pressure × 2 samples of tiny packings, fields and all.
const SMALL: &str = r#"
experiment = "e1"
seed = 11
samples = 2
parallel_samples = 2

[packing]
kind = "sphere2d"
width = 6.0
grains = [24, 40]
pressures = [1e-4]

[pulse]
field_times = [1.0]
time_samples = 801
"#;

/// Signals and packings of every sample of a finished run in `dir` (timings excluded).
fn fingerprint_of_run(dir: &Path, text: &str) -> Vec<(u64, Vec<u64>)> {
    let plan = e1::prepare(&ConfigSource::from_text("e1.toml", text)).unwrap();
    plan.tasks
        .iter()
        .map(|t| {
            let r = load_result(dir, &plan, t).expect("every sample has a result");
            let p = load_packing(dir, &plan, t).expect("every sample has a packing");
            let hash = match p.sim {
                grainwave_core::checkpoint::AnySimulation::D2(s) => s.state_hash(),
                grainwave_core::checkpoint::AnySimulation::D3(s) => s.state_hash(),
            };
            (hash, r.pulse.unwrap().signal.iter().map(|x| x.to_bits()).collect())
        })
        .collect()
}

/// Stops the run after `after` samples are reported done.
struct StopAfter {
    after: usize,
    flag: Arc<AtomicBool>,
}

impl Reporter for StopAfter {
    fn stage(&mut self, _: &str, _: Option<u64>) {}
    fn progress(&mut self, _: &Progress) {}
    fn samples(&mut self, done: usize, _: usize) {
        if done >= self.after {
            self.flag.store(true, Ordering::SeqCst);
        }
    }
    fn message(&mut self, _: &str) {}
}

fn mtimes(dir: &Path, plan: &e1::Plan) -> Vec<Option<std::time::SystemTime>> {
    plan.tasks.iter().map(|t| std::fs::metadata(dir.join(sample_dir(plan, t)).join("result.gwck")).and_then(|m| m.modified()).ok()).collect()
}

/// Interrupted after the first finished sample, resumed: finished samples are not recomputed
/// (their files are untouched), the run completes, and every packing and signal equals those of an
/// uninterrupted run bit for bit. A second `run` of the same config into the same directory
/// recomputes nothing; deleting one result recomputes that one only, from its saved packing.
#[test]
fn ensemble_resume_does_not_recompute_finished_samples() {
    let reference = out_dir("reference");
    run_text(SMALL, &reference).unwrap();
    let expected = fingerprint_of_run(&reference, SMALL);
    let plan = e1::prepare(&ConfigSource::from_text("e1.toml", SMALL)).unwrap();

    let dir = out_dir("interrupted");
    let flag = Arc::new(AtomicBool::new(false));
    let mut rep = StopAfter { after: 1, flag: flag.clone() };
    let err = {
        let mut ctx = RunContext::new(&dir, &mut rep, flag.clone()).unwrap();
        crate::REGISTRY.run(&ConfigSource::from_text("e1.toml", SMALL), &mut ctx).unwrap_err()
    };
    assert!(matches!(err, ExperimentError::Interrupted { .. }), "{err}");
    let before = mtimes(&dir, &plan);
    let done_before = before.iter().filter(|m| m.is_some()).count();
    assert!(done_before >= 1 && done_before < plan.tasks.len(), "{done_before} samples done at the interrupt");
    std::thread::sleep(std::time::Duration::from_millis(50));
    let mut rep = SilentReporter;
    let mut ctx = RunContext::new(&dir, &mut rep, Arc::new(AtomicBool::new(false))).unwrap();
    crate::REGISTRY.resume(&dir, &mut ctx).unwrap();
    drop(ctx);
    let after = mtimes(&dir, &plan);
    for (b, a) in before.iter().zip(&after) {
        if b.is_some() {
            assert_eq!(b, a, "a finished sample was recomputed");
        }
        assert!(a.is_some());
    }
    let log = std::fs::read_to_string(dir.join("run.log")).unwrap();
    assert!(log.contains(&format!("{done_before} of {} samples already done", plan.tasks.len())), "{log}");
    assert_eq!(fingerprint_of_run(&dir, SMALL), expected, "the resumed run differs from the uninterrupted one");

    // run again: nothing to do
    run_text(SMALL, &dir).unwrap();
    assert_eq!(mtimes(&dir, &plan), after);
    // one result deleted: only it is redone, from its packing (whose file stays untouched)
    let victim = dir.join(sample_dir(&plan, &plan.tasks[1]));
    let packing_time = std::fs::metadata(victim.join("packing.gwck")).unwrap().modified().unwrap();
    std::fs::remove_file(victim.join("result.gwck")).unwrap();
    run_text(SMALL, &dir).unwrap();
    let again = mtimes(&dir, &plan);
    for k in 0..plan.tasks.len() {
        assert_eq!(again[k] == after[k], k != 1, "sample {k}");
    }
    assert_eq!(std::fs::metadata(victim.join("packing.gwck")).unwrap().modified().unwrap(), packing_time);
    assert_eq!(fingerprint_of_run(&dir, SMALL), expected);
    // a changed pulse key keeps the packings but redoes the analyses
    let changed = SMALL.replace("time_samples = 801", "time_samples = 401");
    run_text(&changed, &dir).unwrap();
    assert_eq!(std::fs::metadata(victim.join("packing.gwck")).unwrap().modified().unwrap(), packing_time);
    let log = std::fs::read_to_string(dir.join("run.log")).unwrap();
    assert!(log.lines().last().unwrap().contains("done: 4 samples"), "{log}");
}

/// Samples are deterministic functions of their seed: the same ensemble in pools of 1 and 2
/// threads (and with 1 or 2 samples at a time) gives the same packings and signals, bit for bit.
#[test]
fn results_do_not_depend_on_the_thread_count() {
    let mut runs = Vec::new();
    for threads in [1, 2] {
        let dir = out_dir(&format!("threads{threads}"));
        let text = SMALL.replace("parallel_samples = 2", &format!("parallel_samples = {threads}"));
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| run_text(&text, &dir)).unwrap();
        runs.push(fingerprint_of_run(&dir, &text));
    }
    assert_eq!(runs[0], runs[1]);
}

/// The 1D chain through the generic machinery (packing → contacts → D → modes) and the closed-form
/// mode sum agree (the linear crate's own test: 1e-10 of max |F|); the first peak is the Airy front
/// whose width grows as N^{1/3}.
#[test]
fn chain_generic_matches_closed_form() {
    let dir = out_dir("chain");
    let summary = run_text("experiment = \"e1\"\n[chain]\ngrains = [25, 50, 100, 200]\n[pulse]\ntransits = 1.3\ntime_samples = 4001\n", &dir).unwrap();
    let groups = summary.report["groups"].as_array().unwrap();
    for g in groups {
        let d = g["closed_form_difference"].as_f64().unwrap();
        assert!(d < 1e-10, "{}: generic vs closed form {d:e}", g["name"]);
    }
    let series = &summary.report["heights"][0]["series"];
    let alpha = series["width_exponent"]["exponent"].as_f64().unwrap();
    eprintln!("chain exponents N = 25…200: γ = {}, α = {alpha}", series["amplitude_exponent"]["gamma"]);
    // effective exponents approach 1/3 from below at these sizes (measured 0.27–0.30)
    assert!((alpha - 1.0 / 3.0).abs() < 0.08, "α = {alpha}");
    let c = series["time_of_flight"]["velocity"].as_f64().unwrap();
    assert!((c - 1.0).abs() < 0.05, "c_tof = {c} (the chain's c = 1)");
}

/// SPEC §5.7: with ζ = 0 and a small kick, full MD follows the linear signal over the first
/// transit. The linear signal has no pre-stress term (SPEC default), whose relative size is
/// F_n/(k_n d) ≈ 3e-3 at p = 1e-4 (the linear crate measured 7.6e-3 for this comparison on a
/// 600-grain packing), and the kick (default 1e-6 of the wall overlaps) adds nonlinear terms in
/// proportion to its size (3.3e-3 at 1e-5, 0.11 at 1e-4 on this packing). Tolerance 2e-2. Damping
/// lowers the first peak.
#[test]
fn damped_md_without_damping_matches_the_linear_signal() {
    let dir = out_dir("damped");
    let text = "experiment = \"e1\"\nseed = 3\n[packing]\nwidth = 8.0\ngrains = [60]\npressures = [1e-4]\n[pulse]\ntime_samples = 801\n[damped]\ndamping_fractions = [0.0, 0.3]\n";
    let summary = run_text(text, &dir).unwrap();
    let damped = summary.report["groups"][0]["damped"].as_array().unwrap().clone();
    let diff = damped[0]["difference_to_linear"]["mean"].as_f64().unwrap();
    eprintln!("MD ζ = 0 vs linear: relative L2 {diff:.3e}");
    assert!(diff < 2e-2, "{diff}");
    let a0 = damped[0]["metrics"]["peak_amplitude"].as_f64().unwrap();
    let a1 = damped[1]["metrics"]["peak_amplitude"].as_f64().unwrap();
    assert!(a1 < a0, "damping lowers the first peak: {a1} vs {a0}");
}

/// Every plot listed in the summary exists, and the checkpoint says what it holds.
#[test]
fn outputs_and_checkpoint() {
    let dir = out_dir("outputs");
    let summary = run_text(SMALL, &dir).unwrap();
    let files: Vec<String> = summary.report["files"].as_array().unwrap().iter().map(|f| f.as_str().unwrap().to_string()).collect();
    for stem in ["signal_p1e-4_N24", "signals_p1e-4", "arrival_times", "amplitude", "width", "spectrum_p1e-4_N40", "contributions_p1e-4_N40", "force_network_p1e-4_N40", "stiffness_network_p1e-4_N40", "displacement_p1e-4_N40_0", "angles_p1e-4_N40", "forces_p1e-4_N40"] {
        for ext in ["png", "svg"] {
            let f = format!("plots/{stem}.{ext}");
            assert!(files.contains(&f) && dir.join(&f).exists(), "{f}");
        }
    }
    for f in ["summary.json", "samples.csv", "groups.csv", "heights.csv", "signals/p1e-4_N40.npz", "spectra/p1e-4_N40.csv", "histograms/p1e-4_N40.csv", "vtk/p1e-4_N40_grains.vtp"] {
        assert!(files.iter().any(|x| x == f) && dir.join(f).exists(), "{f}");
    }
    let units = summary.report["units"].as_object().unwrap();
    assert!(units.keys().any(|k| k.contains("c_tof")));
    let state: E1State = grainwave_core::checkpoint::load(&dir.join("checkpoint.gwck"), e1::TAG).unwrap();
    assert!(state.finished);
    // `grainwave plot` re-makes the outputs from the saved samples
    std::fs::remove_dir_all(dir.join("plots")).unwrap();
    let written = crate::REGISTRY.plot(&dir).unwrap();
    assert!(written.iter().any(|f| f == "plots/arrival_times.png") && dir.join("plots/arrival_times.png").exists());
    let r: SampleResult = grainwave_core::checkpoint::load(&dir.join("samples/p1e-4_N24/s0011/result.gwck"), "e1-sample-result").unwrap();
    assert!(r.failure.is_none() && r.statistics.is_some() && r.moduli.is_some());
    // zero modes in samples.csv: the rattlers' part and the backbone's add up, and the rattlers'
    // part holds at least 3 per contactless rattler + 1 per rattler on one frictional contact
    // (rolling about it): independent motions on disjoint grains
    let csv = std::fs::read_to_string(dir.join("samples.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("samples.csv has no column {name}"));
    let (z, zr, zb, c0, c1, rat) = (col("zero_modes"), col("rattler_zero_modes"), col("backbone_zero_modes"), col("contactless_rattlers"), col("one_contact_rattlers"), col("rattlers"));
    for line in lines {
        let v: Vec<f64> = line.split(',').map(|x| x.parse::<f64>().unwrap_or(f64::NAN)).collect();
        eprintln!("zero modes {} = {} rattlers' + {} backbone; rattlers {}, contactless {}, one contact {}", v[z], v[zr], v[zb], v[rat], v[c0], v[c1]);
        assert_eq!(v[z], v[zr] + v[zb]);
        assert!(v[zr] >= 3.0 * v[c0] + v[c1], "{line}");
        assert!(v[c0] + v[c1] <= v[rat]);
    }
    // The summary's sample work is the sum of the samples' own wall-clock (which already includes
    // a preparation made in the same task), not that plus the preparation a second time.
    let mut sum = 0.0;
    let mut prepared = 0;
    for g in std::fs::read_dir(dir.join("samples")).unwrap() {
        for s in std::fs::read_dir(g.unwrap().path()).unwrap() {
            let r: SampleResult = grainwave_core::checkpoint::load(&s.unwrap().path().join("result.gwck"), "e1-sample-result").unwrap();
            prepared += r.preparation.as_ref().is_some_and(|p| p.seconds > 0.0) as usize;
            sum += r.seconds;
        }
    }
    assert!(prepared > 0, "the run prepares packings");
    let reported = summary.report["sample_seconds"].as_f64().unwrap();
    // same numbers summed in possibly another order: rounding only
    assert!((reported - sum).abs() <= 1e-9 * sum.max(1.0), "sample_seconds {reported} vs Σ sample seconds {sum}");

    // The state carries its plan. A checkpoint of the earlier layout (the config only, under the
    // earlier tag) still plots and resumes: the resumed run finds every sample done, writes the
    // same summary and saves the current layout.
    #[derive(serde::Serialize)]
    struct EarlierLayout<'a> {
        #[serde(with = "grainwave_study::config::toml_text")]
        config: &'a e1::E1Config,
        finished: bool,
    }
    let ck = dir.join("checkpoint.gwck");
    grainwave_core::checkpoint::save(&ck, e1::EARLIER_TAG, &EarlierLayout { config: &state.plan.config, finished: false }).unwrap();
    assert!(crate::REGISTRY.plot(&dir).is_ok(), "plot from the earlier layout");
    let before = std::fs::read_to_string(dir.join("groups.csv")).unwrap();
    let mut rep = SilentReporter;
    let mut ctx = RunContext::new(&dir, &mut rep, Arc::new(AtomicBool::new(false))).unwrap();
    let resumed = crate::REGISTRY.resume(&dir, &mut ctx).unwrap();
    assert_eq!(resumed.report["groups"], summary.report["groups"]);
    assert_eq!(std::fs::read_to_string(dir.join("groups.csv")).unwrap(), before);
    let (_, tag) = grainwave_study::protocol::checkpoint_tag(&dir).unwrap();
    assert_eq!(tag, e1::TAG);
    let again: E1State = grainwave_core::checkpoint::load(&ck, e1::TAG).unwrap();
    assert!(again.finished && again.plan.tasks == state.plan.tasks && again.plan.groups == state.plan.groups);
    // a carried plan that does not hold together is refused when the checkpoint is read, before
    // anything indexes by it
    let mut crafted = state.clone();
    crafted.plan.tasks[0].group = crafted.plan.groups.len();
    let bytes = grainwave_core::checkpoint::encode(e1::TAG, &crafted).unwrap();
    let err = grainwave_core::checkpoint::decode::<E1State>(&bytes, e1::TAG, "crafted").unwrap_err().to_string();
    assert!(err.contains("inconsistent") && err.contains("task 0"), "{err}");
    let mut crafted = state.clone();
    crafted.plan.groups[0].times.push(f64::NAN);
    let bytes = grainwave_core::checkpoint::encode(e1::TAG, &crafted).unwrap();
    assert!(grainwave_core::checkpoint::decode::<E1State>(&bytes, e1::TAG, "crafted").is_err());
}

fn check_err(text: &str) -> grainwave_study::config::ConfigError {
    crate::REGISTRY.check(&ConfigSource::from_text("bad.toml", text)).expect_err("must be refused")
}

#[test]
fn config_errors_point_at_their_keys() {
    let e = check_err("experiment = \"e1\"\nsamples = 2\n");
    assert!(e.message.contains("exactly one of `[packing]`, `[lattice]` and `[chain]`"), "{e}");
    let e = check_err("experiment = \"e1\"\n[packing]\npressures = [1e-4]\nheights = [8.0]\ngrains = [100]\n");
    assert!(e.message.contains("either `heights` or `grains`") && e.line == 2, "{e}");
    let e = check_err("experiment = \"e1\"\n[packing]\npressures = [1e-4, -1.0]\nheights = [8.0]\n");
    assert_eq!(e.key.as_deref(), Some("packing.pressures[1]"));
    assert_eq!((e.line, e.column), (3, 20), "{e}");
    let e = check_err("experiment = \"e1\"\n[chain]\ngrains = [10]\n[pulse]\nprestress = \"full\"\n");
    assert!(e.message.contains("direct") && e.line == 5, "{e}");
    let e = check_err("experiment = \"e1\"\n[chain]\ngrains = [10]\n[damped]\n");
    assert_eq!(e.key.as_deref(), Some("damped"));
    let e = check_err("experiment = \"e1\"\n[lattice]\nrows = [10]\npressures = [1e-4]\ncolums = 3\n");
    assert!(e.message.contains("did you mean `columns`"), "{e}");
    // the tail step may not exceed 0.15 of the contact period (dt_fraction 0.05 → factor ≤ 3)
    let e = check_err("experiment = \"e1\"\n[chain]\ngrains = [10]\n[preparation]\ntail_dt_factor = 4.0\n");
    assert_eq!(e.key.as_deref(), Some("preparation.tail_dt_factor"), "{e}");
    assert!(e.message.contains("4") && e.message.contains("at most 3"), "{e}");
    let e = check_err("experiment = \"e1\"\n[chain]\ngrains = [10]\n[preparation]\ntail_kinetic_energy = -1.0\n");
    assert_eq!(e.key.as_deref(), Some("preparation.tail_kinetic_energy"), "{e}");
    // each damping fraction is a damped MD run of a whole pulse inside its sample: 100 000 of them
    // were accepted and ran for minutes without looking at the interrupt
    let many = vec!["0.5"; 100_000].join(", ");
    let e = check_err(&format!("experiment = \"e1\"\n[packing]\nwidth = 8.0\ngrains = [60]\npressures = [1e-4]\n[damped]\ndamping_fractions = [{many}]\n"));
    assert_eq!(e.key.as_deref(), Some("damped.damping_fractions"), "{e}");
    assert!(e.message.contains("damped MD runs") && e.message.contains("limit of 1e3"), "{e}");
    let lines = crate::REGISTRY.check(&ConfigSource::from_text("ok.toml", SMALL)).unwrap();
    assert!(lines.iter().any(|l| l.contains("2 groups × 2 samples = 4 tasks")), "{lines:?}");
}

/// SPEC §5.5–5.6 on the frictional triangular lattice (μ = 0.5) at L ≈ 8 and 25: the first peak is
/// the first Airy lobe of the front, smaller than half of the record's maximum at L ≈ 25 (measured
/// 0.43), so a detector demanding half the maximum — the former default — or the largest peak
/// takes a later oscillation and fails here. c_tof of its 10 % edge is compared with the closed
/// form c_fric = 3^(19/12)/(2^(3/2)π^(1/2)) p^(1/6) √(4/3): the Airy front widens as L^(1/3), so
/// the edge runs ahead of it (measured +5.7 % at p = 1e-4 with 10 columns); the test accepts 0 … 10 %.
#[test]
fn lattice_first_peak_is_the_first_airy_lobe() {
    let dir = out_dir("lattice-first-lobe");
    let summary = run_text("experiment = \"e1\"\n[lattice]\nrows = [9, 29]\ncolumns = 10\npressures = [1e-4]\nfriction = 0.5\n[output]\nvtk = false\nplots = false\n", &dir).unwrap();
    let groups = summary.report["groups"].as_array().unwrap();
    let g = groups.iter().find(|g| g["name"] == "p1e-4_r29").unwrap();
    let peak = g["mean_signal"]["peak_amplitude"].as_f64().unwrap();
    let peak_time = g["mean_signal"]["peak_time"].as_f64().unwrap();
    let text = std::fs::read_to_string(dir.join("signals/p1e-4_r29.csv")).unwrap();
    let rows: Vec<(f64, f64)> = text.lines().skip(1).map(|l| {
        let mut it = l.split(',').map(|x| x.parse::<f64>().unwrap());
        (it.next().unwrap(), it.next().unwrap())
    }).collect();
    let (t_max, max) = rows.iter().cloned().fold((0.0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
    eprintln!("r29: first lobe {peak:.4e} at {peak_time:.2}, record maximum {max:.4e} at {t_max:.2}");
    assert!(peak < 0.5 * max, "the first lobe ({peak}) is not below half the maximum ({max}): the test would not catch the old detector");
    assert!(peak_time < t_max, "the first lobe comes before the record's maximum");
    // the first lobe is the first local maximum above 10 % of the maximum (a lobe: it falls after)
    let first = (1..rows.len() - 1).find(|&k| rows[k].1 >= 0.1 * max && rows[k].1 >= rows[k - 1].1 && rows[k].1 > rows[k + 1].1).unwrap();
    assert!((rows[first].0 - peak_time).abs() < 2.0 * (rows[1].0 - rows[0].0), "first maximum above 10 % at {}, detected peak at {peak_time}", rows[first].0);
    let tof = summary.report["heights"][0]["series"]["time_of_flight"]["velocity"].as_f64().unwrap();
    let closed = grainwave_linear::reference::TriangularLatticeSpec { pressure: 1e-4, friction: 0.5, ..Default::default() }.closed_form_speed();
    eprintln!("c_tof = {tof:.4}, closed form {closed:.4} ({:+.1} %)", 100.0 * (tof / closed - 1.0));
    assert!(tof > closed && tof < 1.1 * closed, "c_tof {tof} vs closed form {closed}");
}

/// `preparation.max_acceleration` against the acceleration a₀ of the piston before any contact
/// (e1::plan: a tolerance above the bound 6p/(π(1 − a)) is met by the uncompressed gas at step 0,
/// so every sample would fail). The bound is checked on built gases: the grains feel no force and
/// the piston's a₀ lies below the bound (equal to it, to rounding, for equal grains), and within a factor 2 of it (the bound is not loose: 1.6 at a = 0.3 in 3D, from ⟨d³⟩ = 1 + a² against (1 − a)).
#[test]
fn a_tolerance_met_by_the_uncompressed_gas_is_refused_by_check() {
    fn gas<D: Dim>(spread: f64, pressure: f64, piston_mass: Option<f64>) -> (f64, f64) {
        let preparation = PreparationConfig { piston_mass, ..PreparationConfig::default() };
        let spec = PackingSpec { grains: 60, width: 10.0, spread, friction: 0.5, poisson: 0.0, pressure, seed: 3, preparation };
        let sim = build_gas::<D>(&spec).unwrap();
        let grains = sim.progress(&StopCriteria::default()).max_acceleration;
        let piston = sim.domain.walls[1].accel.abs();
        (grains, piston)
    }
    let p = 1e-5;
    for (dim, spread, (grains, a0)) in [(2, 0.2, gas::<D2>(0.2, p, None)), (3, 0.0, gas::<D3>(0.0, p, None)), (3, 0.3, gas::<D3>(0.3, p, None))] {
        let bound = 6.0 * p / (std::f64::consts::PI * (1.0 - spread));
        assert_eq!(grains, 0.0, "{dim}D: the gas grains do not touch");
        assert!(a0 <= bound * (1.0 + 1e-12) && a0 > bound / 2.0, "{dim}D, a = {spread}: a₀ = {a0:e}, bound {bound:e}");
    }
    let (_, a0) = gas::<D2>(0.2, p, Some(2.0));
    let bound = p * 10.0 * 1.2 / 2.0;
    assert!(a0 <= bound * (1.0 + 1e-12) && a0 > bound / 2.0, "given piston mass: a₀ = {a0:e}, bound {bound:e}");
    // check: just above the bound refused (naming key, value and range), just below accepted
    let text = |tol: f64, extra: &str| {
        format!("experiment = \"e1\"\nsamples = 1\n[packing]\nwidth = 10.0\nheights = [6.0]\npressures = [1e-5, 1e-4]\n[preparation]\nmax_acceleration = {tol:e}\n{extra}")
    };
    let b2 = 6.0 * p / (std::f64::consts::PI * 0.8);
    let e = check_err(&text(b2 * 1.01, ""));
    assert_eq!(e.key.as_deref(), Some("preparation.max_acceleration"), "{e}");
    assert!(e.message.contains(&format!("allowed: below {b2:.4e}")) && e.message.contains("step 0"), "{e}");
    crate::REGISTRY.check(&ConfigSource::from_text("ok.toml", text(b2 * 0.99, ""))).unwrap();
    let e = check_err(&text(1.3e-4, "piston_mass = 1.0\n"));
    assert!(e.message.contains("allowed: below 1.2000e-4"), "{e}");
    crate::REGISTRY.check(&ConfigSource::from_text("ok.toml", text(1.1e-4, "piston_mass = 1.0\n"))).unwrap();
}

/// Zero modes of a sample (docs/e1.md, Pulse): the frictional lattice between its frictional walls
/// has none; shrinking one bulk grain so that it touches nothing (a rattler) adds exactly its 3
/// free motions (sphere2d: 2 translations, 1 rotation), and all 3 are counted as the rattlers'
/// (P = Zᵀ M_R Z has eigenvalues 1); with `rattlers = "remove"` they are gone.
#[test]
fn a_contactless_rattler_adds_three_zero_modes_all_of_them_the_rattlers() {
    let text = |rattlers: &str| format!("experiment = \"e1\"\n[lattice]\nrows = [9]\ncolumns = 10\npressures = [1e-4]\nfriction = 0.5\n[pulse]\nrattlers = \"{rattlers}\"\n");
    let zero_modes = |rattlers: &str, shrink: Option<usize>| {
        let plan = e1::prepare(&ConfigSource::from_text("e1.toml", text(rattlers))).unwrap();
        let group = &plan.groups[0];
        let spec = TriangularLatticeSpec { rows: 9, columns: 10, pressure: 1e-4, friction: 0.5, ..Default::default() };
        let mut sim = spec.build().unwrap();
        if let Some(g) = shrink {
            sim.grains.radius[g] = 0.3;
            sim.refresh().unwrap();
        }
        let mut result = SampleResult::new(0, 0, 0, 1);
        e1::sample::analyze_packing(&sim, &plan, group, 0, &mut result).unwrap();
        let stats = result.statistics.unwrap();
        let p = result.pulse.unwrap();
        eprintln!(
            "rattlers = {rattlers}, shrunk {shrink:?}: {} rattlers, {} zero modes, {} of rattlers (weights ≥ {:.3e}, others ≤ {:.3e}), contactless {}, gap {:.2e}",
            stats.rattlers, p.zero_modes, p.rattler_zero_modes, p.rattler_weight_min, p.other_weight_max, p.contactless_rattlers, p.zero_mode_gap
        );
        (stats.rattlers, p.zero_modes, p.rattler_zero_modes, p.contactless_rattlers, p.rattler_weight_min, p.zero_mode_gap)
    };
    let (r, z, zr, c, _, gap) = zero_modes("keep", None);
    assert_eq!((r, z, zr, c), (0, 0, 0, 0));
    assert!(gap > 1e-6, "the lattice's softest mode {gap:e} of max ω² is not zero");
    let shrunk = 4 * 10 + 4; // a bulk grain
    let (r, z, zr, c, w, _) = zero_modes("keep", Some(shrunk));
    assert_eq!((r, z, zr, c), (1, 3, 3, 1));
    // the three modes are the rattler's alone, to rounding
    assert!((w - 1.0).abs() < 1e-9, "{w}");
    let (r, z, zr, _, _, _) = zero_modes("remove", Some(shrunk));
    assert_eq!((r, z, zr), (1, 0, 0));
}
