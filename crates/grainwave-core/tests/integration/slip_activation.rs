//! The slip-activation law (the E2 paper's Eq. 13, `Tangential::SlipActivation`):
//! Ḋ_t = v_t − Θ(|D_t| − D_tᶜ)(D_t − D_tᶜ)/τ with D_tᶜ = μF_n/K_t, against its closed forms on a
//! single contact (2D and 3D), the τ → 0 limit, and through the engine (every force path gives
//! the bits of the general kernel, checkpoint/resume continues to the bit).

use crate::common;
use common::*;
use glam::{DVec2, DVec3};
use grainwave_core::contact::{pair_kinematics, ContactState, HistoryValue, Partner, Specialized};
use grainwave_core::prelude::*;

/// Undamped Hooke law with friction μ and slip-activation time τ (None: the key left out).
fn law(mu: f64, tau: Option<f64>) -> ContactLaw {
    let mut p = hooke(1.0e4, None, mu);
    p.slip_activation_time = tau;
    p.build(Partner::Grain, "contact").unwrap()
}

/// One contact at fixed overlap (constant F_n), j sliding past i at constant speed `v` along the
/// unit tangent `t` (2D: `t` = ŷ; 3D: an oblique tangent), for `steps` steps of `dt`; returns
/// the tangential force along t at each step and whether the contact was in the sliding regime.
fn drive_3d(law: &ContactLaw, t: DVec3, v: f64, dt: f64, steps: usize, state: &mut ContactState<D3>) -> Vec<(f64, bool)> {
    let (r, xi) = (0.5, 1e-3);
    let kin = pair_kinematics::<D3>(DVec3::new(2.0 * r - xi, 0.0, 0.0), r, r, 1.0, 1.0, DVec3::ZERO, t * v, DVec3::ZERO, DVec3::ZERO).unwrap();
    (0..steps)
        .map(|_| {
            let o = law.evaluate(&kin, state, dt);
            // the force stays along the slip direction (to round-off)
            assert!((o.tangential_force - t * o.tangential_force.dot(t)).length() <= 1e-12 * o.tangential_force.length().max(1e-300));
            (o.tangential_force.dot(t), o.sliding)
        })
        .collect()
}

fn drive_2d(law: &ContactLaw, v: f64, dt: f64, steps: usize, state: &mut ContactState<D2>) -> Vec<(f64, bool)> {
    let (r, xi) = (0.5, 1e-3);
    let kin = pair_kinematics::<D2>(DVec2::new(2.0 * r - xi, 0.0), r, r, 1.0, 1.0, DVec2::ZERO, DVec2::new(0.0, v), 0.0, 0.0).unwrap();
    (0..steps).map(|_| law.evaluate(&kin, state, dt)).map(|o| (o.tangential_force.y, o.sliding)).collect()
}

/// Constant slip velocity: the spring sticks up to D_tᶜ (F_t = K_t s), then its excess over D_tᶜ
/// relaxes towards v_t τ as vτ(1 − e^{−(t−t₀)/τ}) and stays there (F_t = K_t(D_tᶜ + v_t τ),
/// above μF_n); with the drive stopped the excess decays as e^{−t/τ} back to μF_n.
/// In 2D and in 3D along an oblique tangent.
#[test]
fn constant_slip_relaxes_to_the_coulomb_length_plus_v_tau() {
    let (mu, v, dt) = (0.4, 1e-2, 1e-4);
    let (k_n, k_t, xi) = (1.0e4, 2.0 / 7.0 * 1.0e4, 1e-3);
    let cap = mu * k_n * xi;
    let d_c = cap / k_t;
    let t0 = d_c / v; // time the stick phase takes (1400 steps)
    for tau in [1e-2, 3e-3] {
        let h = dt / tau;
        let l = law(mu, Some(tau));
        assert!(matches!(l.tangential, Tangential::SlipActivation(_)));
        assert!(matches!(l.specialize(), Specialized::HookeSlipActivation(_)));
        let steps = (t0 / dt) as usize + (60.0 * tau / dt) as usize;
        let t = DVec3::new(0.0, 0.6, -0.8);
        let mut s3 = ContactState::<D3>::default();
        let mut s2 = ContactState::<D2>::default();
        let runs = [drive_3d(&l, t, v, dt, steps, &mut s3), drive_2d(&l, v, dt, steps, &mut s2)];
        for (dim, run) in [3, 2].into_iter().zip(runs) {
            let mut worst = 0.0f64;
            for (n, &(f, sliding)) in run.iter().enumerate() {
                let time = (n + 1) as f64 * dt;
                if time < t0 * (1.0 - 1e-9) {
                    // stick: F = K_t v t (one product and a sum per step: round-off only)
                    assert!(!sliding && (f - k_t * v * time).abs() <= 1e-9 * cap, "{dim}D τ {tau}: stick at step {n}: {f}");
                } else if time > t0 + 2.0 * dt {
                    assert!(sliding, "{dim}D τ {tau}: step {n} should slide");
                    let excess = f / k_t - d_c;
                    let exact = v * tau * (1.0 - (-(time - t0) / tau).exp());
                    worst = worst.max((excess - exact).abs() / (v * tau));
                }
            }
            // backward Euler's error on a relaxation of rate 1/τ is at most ≈ h/2 of the
            // asymptote (plus the crossing step, one Δt of slip: h of vτ): 2h bounds both
            assert!(worst < 2.0 * h, "{dim}D τ {tau}: transient off by {worst} of vτ (h = {h})");
            // steady slide: F = K_t(D_c + vτ) exactly (the scheme's fixed point), above μF_n
            let f_end = run.last().unwrap().0;
            assert!(rel(f_end, k_t * (d_c + v * tau)) < 1e-9, "{dim}D τ {tau}: steady F {f_end} vs {}", k_t * (d_c + v * tau));
            assert!(f_end > cap * (1.0 + 0.5 * v * tau / d_c));
        }
        // the drive stops: the excess decays as e^{-t/τ} (backward Euler: (1 + h)^{-n}), the
        // spring ends at the Coulomb length
        let rest = drive_3d(&l, t, 0.0, dt, (20.0 * tau / dt) as usize, &mut s3);
        let x0 = v * tau;
        for (n, &(f, _)) in rest.iter().enumerate() {
            let x = f / k_t - d_c;
            let exact = x0 * (-((n + 1) as f64) * h).exp();
            assert!((x - exact).abs() <= h * x0, "τ {tau}: rest step {n}: excess {x} vs {exact}");
        }
        let HistoryValue::Displacement(s) = l.tangential.read(s3.spring) else { panic!("the spring is a length") };
        assert!((s.length() - d_c).abs() < 1e-8 * d_c, "spring {} vs D_c {d_c}", s.length());
    }
}

/// τ = 0 is the Coulomb cap itself (the key set to 0 builds today's law, equal field by field);
/// a τ far below the step gives the cap to that ratio; negative, NaN or infinite τ are refused
/// naming the key; the Hertz–Mindlin preset refuses the key.
#[test]
fn tau_zero_is_the_coulomb_cap_and_bad_values_are_refused() {
    assert_eq!(law(0.4, Some(0.0)), law(0.4, None));
    assert!(matches!(law(0.4, None).tangential, Tangential::Linear(_)));
    let (dt, v) = (1e-4, 1e-2);
    let cap = 0.4 * 1.0e4 * 1e-3;
    let tiny = law(0.4, Some(1e-12 * dt));
    let mut a = ContactState::<D2>::default();
    let mut b = ContactState::<D2>::default();
    let ra = drive_2d(&tiny, v, dt, 3000, &mut a);
    let rb = drive_2d(&law(0.4, None), v, dt, 3000, &mut b);
    for (x, y) in ra.iter().zip(&rb) {
        assert!((x.0 - y.0).abs() <= 1e-9 * cap && x.1 == y.1);
    }
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let mut p = hooke(1.0e4, None, 0.4);
        p.slip_activation_time = Some(bad);
        let e = p.build(Partner::Grain, "contact").unwrap_err().to_string();
        assert!(e.contains("contact.slip_activation_time") && e.contains("τ ≥ 0"), "{e}");
    }
    let mut p = hertz(1.0e4, 0.3, 0.4, None);
    p.slip_activation_time = Some(1.0);
    let e = p.build(Partner::Grain, "contact").unwrap_err().to_string();
    assert!(e.contains("slip_activation_time") && e.contains("hooke_cundall_strack"), "{e}");
}

/// A sheared frictional packing with the slip-activation law: the general kernel, every vector
/// path and thread count give the same bits (2D with rolling resistance, 3D), the law changes the
/// run (a τ of a few steps against the Coulomb cap), and a checkpoint taken half-way resumes to
/// the bits of the uninterrupted run.
#[test]
fn the_law_runs_on_every_force_path_and_resumes_to_the_bit() {
    let levels = simd_levels("the_law_runs_on_every_force_path_and_resumes_to_the_bit", &[0, 1, 2, 3]);
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let mut p2 = hooke(1.0e3, Some(0.8), 0.3);
    p2.rolling_stiffness = Some(0.5);
    p2.rolling_friction = Some(0.01);
    let p3 = hooke(1.0e3, Some(0.8), 0.3);
    for (dim, p) in [(2, p2), (3, p3)] {
        let hash = |tau: Option<f64>, general: bool, simd: u8, threads: usize, split: bool| -> u64 {
            let mut q = p.clone();
            q.slip_activation_time = tau;
            let l = q.build(Partner::Grain, "contact").unwrap();
            pool(threads).install(|| {
                if dim == 2 {
                    let mut sim = dense_2d(30, 40, l, 0.5, 21).expected_overlap(0.05).build().unwrap();
                    sim.domain.set_shear_rate(0.02).unwrap();
                    sim.set_general_kernel(general);
                    sim.set_simd_level(simd);
                    sim.set_force_block_len(Some(300));
                    step_maybe_split(sim, split, "simulation-2d")
                } else {
                    let mut sim = dense_3d(4, l, 0.3, 22).expected_overlap(0.05).build().unwrap();
                    sim.domain.set_shear_rate(0.02).unwrap();
                    sim.set_general_kernel(general);
                    sim.set_simd_level(simd);
                    sim.set_force_block_len(Some(50));
                    step_maybe_split(sim, split, "simulation-3d")
                }
            })
        };
        // τ of about ten steps (dt ≈ 5e-3 here)
        let tau = Some(0.05);
        let reference = hash(tau, true, 0, 1, false);
        assert_ne!(reference, hash(None, true, 0, 1, false), "{dim}D: the slip-activation time changes nothing");
        for threads in [1, 2] {
            for &simd in &levels {
                assert_eq!(hash(tau, false, simd, threads, false), reference, "{dim}D, {threads} threads, simd {simd}");
            }
        }
        assert_eq!(hash(tau, false, 0, 1, true), reference, "{dim}D: resumed from a checkpoint");
    }
}

/// 400 steps; with `split`, 150 steps, an encoded checkpoint decoded into a new simulation, and
/// the remaining 250.
fn step_maybe_split<D: Dim>(mut sim: Simulation<D>, split: bool, tag: &str) -> u64 {
    if split {
        sim.steps(150).unwrap();
        let bytes = grainwave_core::checkpoint::encode(tag, &sim).unwrap();
        let mut resumed: Simulation<D> = grainwave_core::checkpoint::decode(&bytes, tag, "memory").unwrap();
        resumed.set_force_block_len(Some(if D::D == 2 { 300 } else { 50 }));
        resumed.steps(250).unwrap();
        assert!(resumed.counters.contacts > 0);
        return resumed.state_hash();
    }
    sim.steps(400).unwrap();
    assert!(sim.counters.contacts > 0 && sim.nlist.builds > 1);
    sim.state_hash()
}
