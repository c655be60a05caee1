//! The 1D chain of SPEC §5.6 through the generic machinery: a packing of disks between two walls
//! (Hooke contacts, K = k_n), its contact records → D → modes → modal sum, against the closed forms
//! ω_n = 2√(K/m) sin(k_n ℓ/2) and F(t) = K u_N(t) = Σ_n (closed-form mode sum).
//!
//! Tolerances (1e-10, from the issue). The dense eigensolver's eigenvalues carry an absolute error
//! ~ ε ‖A‖ = 2e-16 × 4K/m; relative to the smallest ω₁² ≈ (π/(N+1))² K/m this is ≈ 1e-10 for
//! N = 1000, so ω₁ (half the relative error of ω₁²) is good to ≲ 5e-11 (measured: 1.9e-15, 8.3e-14
//! and 9.6e-12 for N = 10, 100, 1000 — the tridiagonal structure helps). The signal is compared
//! relative to its largest value over two transits; it sums N terms of size ≤ K ℓ, so rounding
//! stays ~N ε (measured ≤ 7e-15, 1.9e-13, 1.5e-12).

use grainwave_linear::prelude::*;
use grainwave_linear::reference::ChainSpec;

fn generic(chain: &ChainSpec) -> (DynamicalMatrix<grainwave_core::dim::D2>, LinearSystem, Modes) {
    let snapshot = chain.build().unwrap().snapshot();
    assert_eq!(snapshot.contacts.len(), chain.grains + 1, "N − 1 springs between grains and 2 to the walls");
    let dm = DynamicalMatrix::assemble(&snapshot, &AssemblyOptions::default()).unwrap();
    let system = dm.free_system(&chain.constraints(), ZeroRows::Keep).unwrap();
    assert_eq!(system.dofs(), chain.grains);
    let modes = Modes::compute(&system, &EigenOptions::default()).unwrap();
    (dm, system, modes)
}

fn check_chain(n: usize) {
    let chain = ChainSpec { grains: n, spacing: 1.0, stiffness: 2.5, mass: 0.7, ..ChainSpec::default() };
    let (dm, system, modes) = generic(&chain);
    let exact = chain.frequencies();
    let omega = modes.frequencies();
    let worst = omega.iter().zip(&exact).map(|(w, e)| ((w - e) / e).abs()).fold(0.0, f64::max);
    eprintln!("N = {n}: max relative error of ω_n = {worst:.2e}");
    assert!(worst < 1e-10, "N = {n}: frequencies off by {worst:e}");

    let source = source_vector(&dm, &system, 0).unwrap();
    let detector = detector_vector(&dm, &system, 1).unwrap();
    assert_eq!((source.grains.as_slice(), detector.grains.as_slice()), (&[0][..], &[n - 1][..]));
    let transit = (n + 1) as f64 * chain.spacing / chain.sound_speed();
    let times: Vec<f64> = (0..=2000).map(|k| 2.0 * transit * k as f64 / 2000.0).collect();
    for ic in [chain.impulse(), chain.displacement()] {
        let state = ic.state(&system, &source).unwrap();
        let modal = ModalSignal::new(&modes, &state, &detector.vector).unwrap();
        let generic: Vec<f64> = modal.eval_many(&times);
        let closed: Vec<f64> = times.iter().map(|&t| chain.closed_form_signal(t, &ic)).collect();
        let scale = closed.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
        let err = generic.iter().zip(&closed).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale;
        eprintln!("N = {n}, {ic:?}: max |F_generic − F_closed| / max|F| = {err:.2e}");
        assert!(err < 1e-10, "N = {n}, {ic:?}: signal off by {err:e}");
        assert!(scale > 0.1 * chain.stiffness * chain.spacing / (n as f64).cbrt(), "the pulse arrived");
    }
}

/// Participation ratios of the chain's modes in closed form: with e_k = (2/(N+1)) sin²(nπk/(N+1)),
/// Σ_k sin⁴(nπk/(N+1)) = 3(N+1)/8, so P_n = 1/(N Σ e_k²) = 2(N+1)/(3N) — except for n = (N+1)/2,
/// where sin⁴ is 1 on odd k and 0 on even k: P = (N+1)/(2N).
#[test]
fn chain_participation_ratios_match_the_closed_form() {
    for n in [9usize, 10] {
        let chain = ChainSpec { grains: n, ..ChainSpec::default() };
        let (_, _, modes) = generic(&chain);
        for (k, &p) in modes.participation().iter().enumerate() {
            let mode = k + 1;
            let expected = if 2 * mode == n + 1 { (n + 1) as f64 / (2 * n) as f64 } else { 2.0 * (n + 1) as f64 / (3 * n) as f64 };
            assert!((p - expected).abs() < 1e-12, "N = {n}, mode {mode}: P = {p} vs {expected}");
        }
    }
}

#[test]
fn chain_of_10_matches_the_closed_form() {
    check_chain(10);
}

#[test]
fn chain_of_100_matches_the_closed_form() {
    check_chain(100);
}

#[test]
fn chain_of_1000_matches_the_closed_form() {
    check_chain(1000);
}

/// A polydisperse chain (masses ∝ R³, equal springs): the generic D equals the tridiagonal matrix
/// written by hand, and the modal sum equals direct propagation.
#[test]
fn polydisperse_chain_generic_vs_hand_built_and_direct() {
    let chain = ChainSpec { grains: 40, polydispersity: 0.3, seed: 9, ..ChainSpec::default() };
    let (dm, system, modes) = generic(&chain);
    let n = chain.grains;
    let k = chain.stiffness;
    let d = system.to_dense();
    for r in 0..n {
        for c in 0..n {
            let expected = if r == c { 2.0 * k } else if r.abs_diff(c) == 1 { -k } else { 0.0 };
            assert!((d[(r, c)] - expected).abs() < 1e-14, "D[{r},{c}] = {} vs {expected}", d[(r, c)]);
        }
    }
    let radii = chain.radii();
    for (r, &m) in system.mass().iter().enumerate() {
        assert!((m - chain.mass * (radii[r] / (0.505 * chain.spacing)).powi(3)).abs() < 1e-14);
    }
    // modal sum vs direct propagation (4th-order symplectic, 40 steps per shortest period: phase
    // error ~1e-8 over these 3 transits)
    let source = source_vector(&dm, &system, 0).unwrap();
    let detector = detector_vector(&dm, &system, 1).unwrap();
    let state = chain.impulse().state(&system, &source).unwrap();
    let modal = ModalSignal::new(&modes, &state, &detector.vector).unwrap();
    let times: Vec<f64> = (0..=600).map(|j| j as f64 * 0.25).collect();
    let opts = PropagationOptions { steps_per_period: 40.0, ..Default::default() };
    let direct = propagate_signal(&system, system.mass(), &state, &detector.vector, &times, &opts).unwrap();
    let m = modal.eval_many(&times);
    let scale = m.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
    let err = m.iter().zip(&direct.values).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale;
    eprintln!("polydisperse chain: max |modal − direct| / max|F| = {err:.2e} ({} steps)", direct.steps);
    assert!(err < 1e-6, "{err:e}");
    // the Lanczos estimate of ω_max is within its bound of the true largest frequency
    let w_max = *modes.omega_squared().last().unwrap();
    assert!(direct.bound.ritz <= w_max * (1.0 + 1e-12) && direct.bound.estimate >= w_max * (1.0 - 1e-12), "{:?} vs {w_max}", direct.bound);
}

/// The one-call entry points on the unconstrained chain: the transverse translations and rotations
/// of the frictionless chain have zero rows in D (2N zero modes that neither the source nor the
/// detector couples to), so the signal is still the closed form.
#[test]
fn one_call_modal_and_direct_pulses_on_the_unconstrained_chain() {
    let chain = ChainSpec { grains: 30, ..ChainSpec::default() };
    let snapshot = chain.build().unwrap().snapshot();
    let setup = PulseSetup { source_wall: 0, detector_wall: 1, initial_condition: chain.impulse() };
    let times: Vec<f64> = (0..=400).map(|k| k as f64 * 0.2).collect();
    let modal = modal_pulse(&snapshot, &AssemblyOptions::default(), &EigenOptions::default(), &setup, &times).unwrap();
    assert_eq!(modal.dofs, 3 * chain.grains);
    assert_eq!(modal.omega_squared.iter().filter(|&&w| w.abs() < 1e-12).count(), 2 * chain.grains);
    let closed: Vec<f64> = times.iter().map(|&t| chain.closed_form_signal(t, &chain.impulse())).collect();
    let scale = closed.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
    let err = modal.signal.iter().zip(&closed).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale;
    assert!(err < 1e-10, "modal: {err:e}");
    let direct = direct_pulse(&snapshot, &AssemblyOptions::default(), &PropagationOptions::default(), &setup, &times).unwrap();
    let err = direct.values.iter().zip(&closed).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale;
    assert!(err < 1e-6, "direct: {err:e}");
    // a_n b_n sum to the initial slope: Σ a_n b_n ω_n = dF/dt(0) = K · 0 (grain N does not move at t = 0)
    let slope: f64 = modal.contributions.iter().zip(&modal.omega_squared).map(|(c, w2)| c * w2.max(0.0).sqrt()).sum();
    assert!(slope.abs() < 1e-10 * scale, "{slope:e}");
}
