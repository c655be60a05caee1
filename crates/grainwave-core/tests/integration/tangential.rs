//! Tangential contact mechanics (SPEC §2.3–2.5), driven by prescribed kinematics through the
//! pure contact-law functions, and through the engine for a sliding block.

use crate::common;
use common::*;
use glam::{DVec2, DVec3};
use grainwave_core::contact::{pair_kinematics, ContactState, HistoryValue, Partner};
use grainwave_core::prelude::*;

/// Cundall–Strack: load tangentially at fixed overlap (constant F_n): slope k_t, cap at μF_n,
/// sliding with the spring held at the Coulomb length, elastic unloading from the cap.
#[test]
fn cundall_strack_loads_caps_slides_and_unloads() {
    let (k_n, mu) = (1.0e4, 0.4);
    let law = hooke(k_n, None, mu).build(Partner::Grain, "contact").unwrap();
    let k_t = 2.0 / 7.0 * k_n;
    let (r, xi) = (0.5, 1e-3);
    let f_n = k_n * xi;
    let cap = mu * f_n;
    let dt = 1e-4;
    let v = 1e-2; // tangential speed of j relative to i (along +y); the cap is reached after 1400 steps
    let mut state = ContactState::<D2>::default();
    let mut s = 0.0;
    let mut history = Vec::new();
    // load: j moves along +y (no rotation), at constant overlap
    for step in 0..6000 {
        let vt = if step < 2000 { v } else { -v };
        let r_ij = DVec2::new(2.0 * r - xi, 0.0);
        let kin = pair_kinematics::<D2>(r_ij, r, r, 1.0, 1.0, DVec2::ZERO, DVec2::new(0.0, vt), 0.0, 0.0).unwrap();
        let out = law.evaluate(&kin, &mut state, dt);
        s += vt * dt;
        // the linear law stores the spring elongation (a length)
        let HistoryValue::Displacement(spring) = law.tangential.read(state.spring) else { panic!("the linear law stores a displacement") };
        history.push((s, out.tangential_force.y, out.sliding, spring.y));
        assert!((out.normal_force - f_n).abs() < 1e-12 * f_n);
        assert!(out.tangential_force.x.abs() < 1e-15, "force stays tangential");
    }
    let s_cap = cap / k_t;
    for &(s, f, sliding, spring) in &history[..2000] {
        if s < s_cap * (1.0 - 1e-9) {
            // elastic: F = k_t s (damping is zero: the law has no dashpot), not sliding
            assert!((f - k_t * s).abs() < 1e-9 * cap, "elastic branch: s {s}, F {f}");
            assert!(!sliding);
        } else if s > s_cap * (1.0 + 1e-9) {
            assert!((f - cap).abs() < 1e-12 * cap, "capped: F {f} vs μF_n {cap}");
            assert!(sliding);
            // the spring does not keep growing: held at the Coulomb length
            assert!((spring - s_cap).abs() < 1e-12 * s_cap);
        }
    }
    // unloading from the cap is elastic with slope k_t, starting at the cap immediately
    let (s_turn, f_turn, _, _) = history[1999];
    assert!((f_turn - cap).abs() < 1e-12 * cap);
    for &(s, f, sliding, _) in &history[2000..2000 + (2.0 * s_cap / (v * dt)) as usize - 2] {
        let expected = cap - k_t * (s_turn - s);
        assert!((f - expected).abs() < 1e-9 * cap, "unloading: s {s}, F {f} vs {expected}");
        assert!(!sliding);
    }
    // and it slides again in the opposite direction at −μF_n
    let (_, f_end, sliding_end, _) = *history.last().unwrap();
    assert!((f_end + cap).abs() < 1e-12 * cap && sliding_end);
}

/// Incremental Mindlin: initial tangential stiffness 8 G*_ij √(R* ξ).
#[test]
fn mindlin_initial_stiffness_matches_closed_form() {
    for &(young, nu) in &[(1.0, 0.0), (7.0e4, 0.3), (2.0e2, 0.45)] {
        let params = hertz(young, nu, 0.5, None);
        let law = params.build(Partner::Grain, "contact").unwrap();
        let (ri, rj, xi): (f64, f64, f64) = (0.4, 0.6, 2e-3);
        let r_eff = ri * rj / (ri + rj);
        let g_star = young / (2.0 * (1.0 + nu) * (2.0 - nu));
        let expected = 8.0 * (g_star / 2.0) * (r_eff * xi).sqrt();
        let mut state = ContactState::<D3>::default();
        let r_ij = DVec3::new(0.0, 0.0, ri + rj - xi);
        let (v, dt) = (1e-6, 1e-3);
        let kin = pair_kinematics::<D3>(r_ij, ri, rj, 1.0, 1.0, DVec3::ZERO, DVec3::new(v, 0.0, 0.0), DVec3::ZERO, DVec3::ZERO).unwrap();
        let out = law.evaluate(&kin, &mut state, dt);
        let k_measured = out.tangential_force.x / (v * dt);
        assert!(rel(k_measured, expected) < 1e-9, "E={young} ν={nu}: k_t {k_measured} vs {expected}");
        assert!(rel(out.tangential_stiffness, expected) < 1e-12);
        // k_t/k_n = 1 − ν/(2−ν)
        assert!(rel(out.tangential_stiffness / out.normal_stiffness, 1.0 - nu / (2.0 - nu)) < 1e-12);
    }
}

/// Two grains in contact rotating rigidly together (orbiting their centre of mass and spinning
/// at the same rate): the stored tangential force must turn with the normal and keep its length.
#[test]
fn history_rotates_with_the_normal_in_rigid_rotation_2d_and_3d() {
    let (r, xi, big_omega, dt) = (0.5, 1e-3, 0.7, 1e-3);
    for law in [
        hooke(1.0e4, None, 10.0).build(Partner::Grain, "contact").unwrap(),
        hertz(1.0e4, 0.2, 10.0, None).build(Partner::Grain, "contact").unwrap(),
    ] {
        // 2D: preload with a tangential slip, then rotate rigidly.
        let mut st = ContactState::<D2>::default();
        let d = 2.0 * r - xi;
        let kin0 = pair_kinematics::<D2>(DVec2::new(d, 0.0), r, r, 1.0, 1.0, DVec2::ZERO, DVec2::new(0.0, 0.05), 0.0, 0.0).unwrap();
        let f0 = law.evaluate(&kin0, &mut st, dt).tangential_force.length();
        assert!(f0 > 0.0);
        for step in 1..=5000 {
            let phi = big_omega * dt * step as f64;
            let n = DVec2::new(phi.cos(), phi.sin());
            let (xi_, xj) = (-n * (0.5 * d), n * (0.5 * d));
            let (vi, vj) = (DVec2::new(-big_omega * xi_.y, big_omega * xi_.x), DVec2::new(-big_omega * xj.y, big_omega * xj.x));
            let kin = pair_kinematics::<D2>(xj - xi_, r, r, 1.0, 1.0, vi, vj, big_omega, big_omega).unwrap();
            assert!(kin.v_t.length() < 1e-15, "rigid motion has no slip: {:?}", kin.v_t);
            let out = law.evaluate(&kin, &mut st, dt);
            // rounding of the per-step projection accumulates over 5000 steps: ~1e-12
            assert!(rel(out.tangential_force.length(), f0) < 1e-10, "step {step}: |F_t| {} vs {f0}", out.tangential_force.length());
            assert!(out.tangential_force.dot(n).abs() < 1e-12 * f0, "F_t stays in the tangent plane");
        }
        // 3D: rotation about z of a pair lying in the x–y plane, with a preload along z and y.
        let mut st = ContactState::<D3>::default();
        let kin0 = pair_kinematics::<D3>(DVec3::new(d, 0.0, 0.0), r, r, 1.0, 1.0, DVec3::ZERO, DVec3::new(0.0, 0.03, 0.04), DVec3::ZERO, DVec3::ZERO).unwrap();
        let f0 = law.evaluate(&kin0, &mut st, dt).tangential_force.length();
        let w = DVec3::new(0.0, 0.0, big_omega);
        for step in 1..=5000 {
            let phi = big_omega * dt * step as f64;
            let n = DVec3::new(phi.cos(), phi.sin(), 0.0);
            let (xi_, xj) = (-n * (0.5 * d), n * (0.5 * d));
            let kin = pair_kinematics::<D3>(xj - xi_, r, r, 1.0, 1.0, w.cross(xi_), w.cross(xj), w, w).unwrap();
            assert!(kin.v_t.length() < 1e-15);
            let out = law.evaluate(&kin, &mut st, dt);
            assert!(rel(out.tangential_force.length(), f0) < 1e-10, "3D step {step}");
            assert!(out.tangential_force.dot(n).abs() < 1e-12 * f0);
        }
    }
}

/// Rolling resistance: rigid co-rotation gives no rolling torque; counter-rotation is resisted,
/// capped at μ_r R* F_n.
#[test]
fn rolling_resistance_spring_and_cap() {
    let mut p = hooke(1.0e4, None, 0.5);
    p.rolling_stiffness = Some(2.0);
    p.rolling_friction = Some(0.1);
    let law = p.build(Partner::Grain, "contact").unwrap();
    let (r, xi, dt) = (0.5, 1e-3, 1e-3);
    let r_ij = DVec2::new(2.0 * r - xi, 0.0);
    let mut st = ContactState::<D2>::default();
    let kin = pair_kinematics::<D2>(r_ij, r, r, 1.0, 1.0, DVec2::ZERO, DVec2::ZERO, 0.3, 0.3).unwrap();
    assert_eq!(law.evaluate(&kin, &mut st, dt).rolling_torque, 0.0);
    let mut st = ContactState::<D2>::default();
    let kin = pair_kinematics::<D2>(r_ij, r, r, 1.0, 1.0, DVec2::ZERO, DVec2::ZERO, 0.0, 0.01).unwrap();
    let m1 = law.evaluate(&kin, &mut st, dt).rolling_torque;
    assert!(rel(m1, 2.0 * 0.01 * dt) < 1e-12, "spring torque {m1}");
    let cap = 0.1 * (r / 2.0) * 1.0e4 * xi;
    let mut last = 0.0;
    for _ in 0..100_000 {
        last = law.evaluate(&kin, &mut st, dt).rolling_torque;
    }
    assert!(rel(last, cap) < 1e-12, "capped rolling torque {last} vs {cap}");
}

/// A disk on a frictional floor under gravity, pushed sideways by a slowly ramped force F at its
/// centre together with the torque F·h (h = distance from centre to floor) that cancels the
/// friction torque — so it behaves as a block instead of rolling (a disk pushed at its centre
/// alone rolls, with friction F/3). It sticks while F < μ m g and slides beyond.
#[test]
fn disk_on_floor_sticks_then_slides() {
    let (k_n, mu, r, rho) = (1.0e4, 0.3, 0.5, 1.0);
    let mut params = hooke(k_n, Some(0.3), mu);
    let law = params.build(Partner::Grain, "contact").unwrap();
    params.friction = Some(mu);
    let wall = params.build(Partner::Wall, "contact.wall").unwrap();
    let m = rho * std::f64::consts::PI * r * r;
    let g = 1.0;
    let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    let h = r - m * g / k_n;
    grains.push(DVec2::new(0.0, h), r, rho, DVec2::ZERO);
    let domain = Domain::new(DVec2::new(-50.0, 0.0), DVec2::new(50.0, 5.0), [false; 3])
        .with_wall(Wall::axis_aligned("floor", 1, 0.0, true, wall));
    let t_ramp = 400.0;
    let f_max = 2.0 * mu * m * g;
    let mut sim = SimulationBuilder::new(grains, domain, law)
        .gravity(DVec2::new(0.0, -g))
        .load(ExternalLoad {
            grain: 0,
            force: DVec2::new(f_max, 0.0),
            torque: f_max * h,
            profile: TimeFunction::Ramp { from: 0.0, to: 1.0, start: 0.0, end: t_ramp },
        })
        .build()
        .unwrap();
    let mut slid_at = None;
    while sim.time < t_ramp {
        sim.step().unwrap();
        let f = f_max * sim.time / t_ramp;
        let rec = sim.contact_records();
        let c = rec.iter().find(|c| c.j == Counterpart::Wall(0)).expect("on the floor");
        if c.sliding && slid_at.is_none() {
            slid_at = Some(f);
        }
        if slid_at.is_none() && f < 0.9 * mu * m * g && sim.time > 1.0 {
            // static: the floor's tangential force balances the push (after the start-up transient)
            assert!((c.tangential_force.x + f).abs() < 1e-3 * mu * m * g, "static friction {} vs push {f}", c.tangential_force.x);
            // slip of the contact point = x + h θ (rolling without slip is a neutral mode here)
            let slip = sim.grains.pos[0].x + h * sim.grains.orientation[0];
            let k_t = 2.0 / 7.0 * k_n;
            assert!((slip - f / k_t).abs() < 1e-3 * mu * m * g / k_t, "sticking: slip {slip} vs F/k_t = {}", f / k_t);
        }
    }
    let f_slide = slid_at.expect("the disk must slide");
    assert!(rel(f_slide, mu * m * g) < 0.01, "sliding starts at F = {f_slide}, μmg = {}", mu * m * g);
}

/// A sphere resting on a frictional floor and spinning about the vertical: the tangential force
/// cannot stop it (the contact point is on the spin axis); twisting resistance does.
#[test]
fn twisting_resistance_stops_spin_about_the_normal() {
    for twisting in [false, true] {
        let mut params = hertz(1.0e4, 0.3, 0.5, Some(0.1));
        if twisting {
            params.twisting_stiffness = Some(1.0);
            params.twisting_damping = Some(0.05);
            params.twisting_friction = Some(0.1);
        }
        let law = params.build(Partner::Grain, "contact").unwrap();
        let wall = params.build(Partner::Wall, "contact.wall").unwrap();
        let mut grains = Grains::<D3>::new(GrainKind::Sphere);
        grains.push(DVec3::new(0.0, 0.0, 0.5), 0.5, 1.0, DVec3::ZERO);
        grains.omega[0] = DVec3::new(0.0, 0.0, 2.0);
        let domain = Domain::new(DVec3::splat(-5.0), DVec3::splat(5.0), [false; 3]).with_wall(Wall::axis_aligned("floor", 2, 0.0, true, wall));
        let mut sim = SimulationBuilder::new(grains, domain, law).gravity(DVec3::new(0.0, 0.0, -1.0)).build().unwrap();
        sim.steps(200_000).unwrap();
        let spin = sim.grains.omega[0].z;
        if twisting {
            assert!(spin.abs() < 1e-6, "twisting resistance stops the spin: ω_z = {spin}");
        } else {
            assert!((spin - 2.0).abs() < 1e-9, "nothing resists spin about the normal: ω_z = {spin}");
        }
    }
}
