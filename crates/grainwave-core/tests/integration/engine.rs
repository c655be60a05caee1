//! Engine mechanics: stop criteria, neighbor-list rebuilds, snapshots, moving walls, time step.

use crate::common;
use common::*;
use glam::{DVec2, DVec3};
use grainwave_core::contact::Partner;
use grainwave_core::prelude::*;
use grainwave_core::timestep::suggest_timestep;

/// A small pile of disks on a floor between walls. Weak rolling resistance is on: without it a
/// disk that rolls without slip on the floor keeps its kinetic energy (seen: KE/grain 1e-10 with
/// max acceleration 2e-15 after 2·10⁶ steps).
fn settled_pile() -> Simulation<D2> {
    let mut params = hooke(1.0e4, Some(0.5), 0.4);
    params.rolling_stiffness = Some(1.0);
    params.rolling_damping = Some(0.05);
    params.rolling_friction = Some(0.1);
    let law = params.build(Partner::Grain, "contact").unwrap();
    let wall = params.build(Partner::Wall, "contact.wall").unwrap();
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    for (k, p) in grainwave_core::placement::triangular_lattice(6, 8, 1.1, [0.6, 0.6]).iter().enumerate() {
        g.push(DVec2::new(p[0], p[1] + 0.02 * (k % 3) as f64), 0.5 - 0.01 * (k % 4) as f64, 1.0, DVec2::ZERO);
    }
    let d = Domain::new(DVec2::ZERO, DVec2::new(9.9, 10.0), [false; 3])
        .with_wall(Wall::axis_aligned("left", 0, 0.0, true, wall))
        .with_wall(Wall::axis_aligned("right", 0, 9.9, false, wall))
        .with_wall(Wall::axis_aligned("floor", 1, 0.0, true, wall));
    SimulationBuilder::new(g, d, law).gravity(DVec2::new(0.0, -1.0)).build().unwrap()
}

#[test]
fn network_unchanged_and_time_limit_criteria() {
    let mut sim = settled_pile();
    let stop = StopCriteria { network_unchanged_steps: Some(5000), step_limit: Some(1_000_000), check_every: 10, ..Default::default() };
    let out = sim.run(&stop, &mut |_| Control::Continue).unwrap();
    assert_eq!(out.reason, StopReason::Converged);
    assert!(out.last.steps_network_unchanged >= 5000 && out.last.steps_network_unchanged < 5010);
    // time limit: exactly k steps for t = k dt
    let t0 = sim.time;
    let dt = sim.dt;
    let stop = StopCriteria { time_limit: Some(t0 + 123.0 * dt), ..Default::default() };
    let out = sim.run(&stop, &mut |_| Control::Continue).unwrap();
    assert_eq!((out.reason, out.steps), (StopReason::TimeLimit, 123));
    // not before: convergence is not declared before the given time
    let stop = StopCriteria {
        kinetic_energy_per_grain: Some(1.0),
        not_before_time: Some(sim.time + 50.0 * dt),
        step_limit: Some(sim.step + 1000),
        ..Default::default()
    };
    let out = sim.run(&stop, &mut |_| Control::Continue).unwrap();
    assert_eq!((out.reason, out.steps), (StopReason::Converged, 50));
}

both_dims! {
    /// Forcing a rebuild at every step must not change anything: histories are carried by id
    /// pair (frictional Hooke law with rolling resistance; 120 disks, 108 spheres).
    fn history_survives_neighbor_rebuilds_bit_for_bit<D>() {
        let mut p = hooke(1.0e3, Some(0.8), 0.3);
        p.rolling_stiffness = Some(0.5);
        let law = p.build(Partner::Grain, "contact").unwrap();
        let b = D::dense((10, 12), 3, law, 0.5, 4);
        let mut a = if D::D == 3 { b.expected_overlap(0.05) } else { b }.build().unwrap();
        let mut b = a.clone();
        for _ in 0..400 {
            a.step().unwrap();
            b.nlist.stale = true;
            b.step().unwrap();
        }
        assert!(b.nlist.builds > a.nlist.builds + 300);
        assert!(a.counters.sliding > 0 || a.nlist.pairs().any(|p| !p.state.spring.is_zero()));
        assert_eq!(a.state_hash(), b.state_hash());
    }
}

#[test]
fn contact_records_add_up_to_the_grain_forces() {
    let mut sim = settled_pile();
    let stop = StopCriteria {
        kinetic_energy_per_grain: Some(1e-14),
        max_acceleration: Some(1e-8),
        step_limit: Some(2_000_000),
        check_every: 100,
        ..Default::default()
    };
    let out = sim.run(&stop, &mut |_| Control::Continue).unwrap();
    assert_eq!(out.reason, StopReason::Converged, "{:?}", out.last);
    let snap = sim.snapshot();
    let mut force = vec![DVec2::ZERO; snap.len()];
    let mut torque = vec![0.0; snap.len()];
    for c in &snap.contacts {
        let f = c.force_on_i();
        let i = c.i as usize;
        force[i] += f;
        torque[i] += D2::cross(c.normal * c.lever_i, c.tangential_force) + c.rolling_torque;
        if let Counterpart::Grain(j) = c.j {
            force[j as usize] -= f;
            torque[j as usize] += D2::cross(c.normal * c.lever_j, c.tangential_force) - c.rolling_torque;
        }
        assert!(c.overlap > 0.0 && c.normal_stiffness > 0.0 && (c.normal.length() - 1.0).abs() < 1e-14);
        assert!(c.tangential_force.dot(c.normal).abs() < 1e-12);
        assert!(c.tangential_force.length() <= 0.4 * c.normal_force * (1.0 + 1e-12), "Coulomb");
    }
    assert!(snap.contacts.iter().any(|c| matches!(c.j, Counterpart::Wall(_))));
    let scale = snap.mass.iter().cloned().fold(0.0, f64::max);
    for k in 0..snap.len() {
        let total = force[k] + snap.gravity * snap.mass[k];
        // the engine's force used half-step velocities; the records the end-of-step ones: at rest
        // the difference is the damping of velocities ~1e-7
        assert!((total - snap.force[k]).length() < 1e-6 * scale, "grain {k}: {total:?} vs {:?}", snap.force[k]);
        assert!((torque[k] - snap.torque[k]).abs() < 1e-6 * scale);
    }
}

#[test]
fn prescribed_wall_motion_and_smooth_stop() {
    let wall = hooke(1.0e4, Some(0.5), 0.0).build(Partner::Wall, "contact.wall").unwrap();
    let law = hooke(1.0e4, Some(0.5), 0.3).build(Partner::Grain, "contact").unwrap();
    let mut g = Grains::<D3>::new(GrainKind::Sphere);
    g.push(DVec3::new(0.0, 0.0, 1.2), 0.5, 1.0, DVec3::ZERO);
    let (v0, ts) = (0.5, 2.0);
    let d = Domain::new(DVec3::splat(-5.0), DVec3::splat(5.0), [false; 3]).with_wall(
        Wall::axis_aligned("pusher", 2, 0.0, true, wall)
            .with_motion(WallMotion::Velocity { speed: TimeFunction::CosineStop { value: v0, start: 1.0, duration: ts } }),
    );
    let mut sim = SimulationBuilder::new(g, d, law).build().unwrap();
    let stop = StopCriteria { time_limit: Some(6.0), ..Default::default() };
    sim.run(&stop, &mut |_| Control::Continue).unwrap();
    // travel = v0 · 1 + v0 · t_s / 2 (the cosine stop covers half of v0 t_s); midpoint rule error O(dt²)
    let travel = sim.domain.walls[0].displacement();
    assert!(rel(travel, v0 * 1.0 + v0 * ts / 2.0) < 1e-6, "travel {travel}");
    assert_eq!(sim.domain.walls[0].speed, 0.0);
    // the wall reached the sphere (bottom at z = 0.7) and pushed it away along +z
    assert!(sim.grains.vel[0].z > 0.1 && sim.grains.pos[0].z > 1.5 + 0.5, "sphere at {:?}", sim.grains.pos[0]);
}

#[test]
fn suggested_time_step_is_a_fraction_of_the_contact_period() {
    let k = 2.0e3;
    let law = hooke(k, None, 0.0).build(Partner::Grain, "contact").unwrap();
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    g.push(DVec2::ZERO, 0.5, 2.0, DVec2::ZERO);
    g.push(DVec2::new(2.0, 0.0), 0.4, 2.0, DVec2::ZERO);
    let m_min = 2.0 * std::f64::consts::PI * 0.16;
    let dt = suggest_timestep(&g, &law, &[], 0.02, 0.01);
    let expected = 0.02 * 2.0 * std::f64::consts::PI * (0.5 * m_min / k).sqrt();
    assert!(rel(dt, expected) < 1e-12, "{dt} vs {expected}");
    // with friction the translation–rotation mode k_t (1 + mR²/I)/m* = (2/7)·3 k/m* is slower
    // than k/m*, so the suggestion is unchanged; a stiffer wall shortens it
    let wall = hooke(4.0 * k, None, 0.0).build(Partner::Wall, "contact.wall").unwrap();
    let w: Wall<D2> = Wall::axis_aligned("w", 1, -1.0, true, wall);
    let dt_w = suggest_timestep(&g, &law, &[w], 0.02, 0.01);
    assert!(rel(dt_w, 0.02 * 2.0 * std::f64::consts::PI * (m_min / (4.0 * k)).sqrt()) < 1e-12);
}
