//! Binary collisions against closed-form contact mechanics (SPEC §2.1–2.2).
//!
//! Contact duration is measured from the instants where the overlap crosses zero, located by
//! linear interpolation between steps (the overlap is linear in time there, with slope ±v), so
//! its error is far below the time step.

use crate::common;
use common::*;
use glam::{DVec2, DVec3};
use grainwave_core::contact::{clamped_contact_time, critical_fraction_for_restitution, Partner};
use grainwave_core::prelude::*;

/// Result of a two-body or body–wall collision.
struct Collision {
    duration: f64,
    /// Outgoing / incoming normal relative speed.
    restitution: f64,
}

/// Runs a collision and measures contact duration and restitution. `overlap` gives the current
/// overlap, `speed` the current normal approach speed (positive when approaching).
fn collide<D: Dim>(
    mut sim: Simulation<D>,
    overlap: impl Fn(&Simulation<D>) -> f64,
    speed: impl Fn(&Simulation<D>) -> f64,
) -> Collision {
    let v_in = speed(&sim);
    let mut prev = (sim.time, overlap(&sim));
    let mut t_start = None;
    let mut t_end = None;
    for _ in 0..10_000_000 {
        sim.step().unwrap();
        let now = (sim.time, overlap(&sim));
        if t_start.is_none() && prev.1 <= 0.0 && now.1 > 0.0 {
            t_start = Some(prev.0 + (now.0 - prev.0) * (-prev.1) / (now.1 - prev.1));
        }
        if t_start.is_some() && prev.1 > 0.0 && now.1 <= 0.0 {
            t_end = Some(prev.0 + (now.0 - prev.0) * prev.1 / (prev.1 - now.1));
            break;
        }
        prev = now;
    }
    // a few more steps in free flight so that no force acts any more
    sim.steps(5).unwrap();
    let v_out = -speed(&sim);
    eprintln!("collision: duration {:.10e}, restitution {:.12}", t_end.unwrap() - t_start.unwrap(), v_out / v_in);
    Collision { duration: t_end.expect("contact ended") - t_start.expect("contact started"), restitution: v_out / v_in }
}

/// Two equal spheres approaching head-on along x at relative speed `v0` (3D).
fn sphere_pair(law: ContactLaw, r: f64, rho: f64, v0: f64, dt: f64) -> Simulation<D3> {
    let mut g = Grains::<D3>::new(GrainKind::Sphere);
    g.push(DVec3::new(-r - 0.01 * r, 0.0, 0.0), r, rho, DVec3::new(0.5 * v0, 0.0, 0.0));
    g.push(DVec3::new(r + 0.01 * r, 0.0, 0.0), r, rho, DVec3::new(-0.5 * v0, 0.0, 0.0));
    let d = Domain::new(DVec3::splat(-10.0 * r), DVec3::splat(10.0 * r), [false; 3]);
    SimulationBuilder::new(g, d, law).dt(dt).build().unwrap()
}

fn pair_overlap_3d(s: &Simulation<D3>) -> f64 {
    2.0 * s.grains.radius[0] - (s.grains.pos[1] - s.grains.pos[0]).length()
}
fn pair_speed_3d(s: &Simulation<D3>) -> f64 {
    (s.grains.vel[0] - s.grains.vel[1]).x
}

/// Hertz contact time t_c = 2.868 (m*²/(R* E*² v₀))^{1/5}.
fn hertz_time(m_eff: f64, r_eff: f64, e_eff: f64, v0: f64) -> f64 {
    2.868 * (m_eff * m_eff / (r_eff * e_eff * e_eff * v0)).powf(0.2)
}

#[test]
fn hertz_sphere_sphere_impact_time_and_elastic_rebound() {
    let (young, nu, r, rho, v0): (f64, f64, f64, f64, f64) = (1.0e4, 0.3, 0.5, 1.0, 0.1);
    let law = hertz(young, nu, 0.5, None).build(Partner::Grain, "contact").unwrap();
    let e_star = young / (1.0 - nu * nu);
    let m = rho * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let tc = hertz_time(m / 2.0, r / 2.0, e_star / 2.0, v0);
    let sim = sphere_pair(law, r, rho, v0, tc / 2000.0);
    eprintln!("Hertz t_c = {tc:.10e}");
    let c = collide(sim, pair_overlap_3d, pair_speed_3d);
    // 2.868 is the closed-form constant rounded to 4 digits (2.8683…): 1 % is the bound.
    assert!(rel(c.duration, tc) < 0.01, "contact time {} vs Hertz {tc}", c.duration);
    // Velocity Verlet is symplectic: with dt = t_c/2000 the rebound error is O(1e-8).
    assert!((c.restitution - 1.0).abs() < 1e-6, "rebound speed ratio {}", c.restitution);
}

#[test]
fn hertz_sphere_wall_impact() {
    let (young, nu, r, rho, v0): (f64, f64, f64, f64, f64) = (1.0e4, 0.25, 0.5, 2.0, 0.05);
    let params = hertz(young, nu, 0.5, None);
    let grain_law = params.build(Partner::Grain, "contact").unwrap();
    let wall_law = params.build(Partner::Wall, "contact.wall").unwrap();
    let e_star = young / (1.0 - nu * nu); // rigid wall: E*_iw = E*_i
    let m = rho * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let tc = hertz_time(m, r, e_star, v0);
    let mut g = Grains::<D3>::new(GrainKind::Sphere);
    g.push(DVec3::new(0.0, 0.0, r * 1.01), r, rho, DVec3::new(0.0, 0.0, -v0));
    let d = Domain::new(DVec3::splat(-5.0), DVec3::splat(5.0), [false; 3])
        .with_wall(Wall::axis_aligned("floor", 2, 0.0, true, wall_law));
    let sim = SimulationBuilder::new(g, d, grain_law).dt(tc / 2000.0).build().unwrap();
    let c = collide(sim, |s| s.grains.radius[0] - s.grains.pos[0].z, |s| -s.grains.vel[0].z);
    assert!(rel(c.duration, tc) < 0.01, "contact time {} vs Hertz {tc}", c.duration);
    assert!((c.restitution - 1.0).abs() < 1e-6, "rebound speed ratio {}", c.restitution);
}

#[test]
fn hertz_planar_spheres_in_2d_match_3d() {
    // `sphere2d` grains: 3D spheres with centres in a plane; same contact time as in 3D.
    let (young, r, rho, v0): (f64, f64, f64, f64) = (1.0e4, 0.5, 1.0, 0.1);
    let law = hertz(young, 0.0, 0.0, None).build(Partner::Grain, "contact").unwrap();
    let m = rho * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
    let tc = hertz_time(m / 2.0, r / 2.0, young / 2.0, v0);
    let mut g = Grains::<D2>::new(GrainKind::Sphere2d);
    g.push(DVec2::new(-r * 1.01, 0.0), r, rho, DVec2::new(0.5 * v0, 0.0));
    g.push(DVec2::new(r * 1.01, 0.0), r, rho, DVec2::new(-0.5 * v0, 0.0));
    let d = Domain::new(DVec2::splat(-5.0), DVec2::splat(5.0), [false; 3]);
    let sim = SimulationBuilder::new(g, d, law).dt(tc / 2000.0).build().unwrap();
    let c = collide(
        sim,
        |s| 2.0 * s.grains.radius[0] - (s.grains.pos[1] - s.grains.pos[0]).length(),
        |s| (s.grains.vel[0] - s.grains.vel[1]).x,
    );
    assert!(rel(c.duration, tc) < 0.01, "contact time {} vs Hertz {tc}", c.duration);
    assert!((c.restitution - 1.0).abs() < 1e-6);
}

#[test]
fn hooke_restitution_and_contact_time_disks_spheres_and_walls() {
    let k = 1.0e4;
    for &e in &[0.5, 0.9, 0.92] {
        let zeta = critical_fraction_for_restitution(e).unwrap();
        for integrator in [Integrator::VelocityVerlet, Integrator::Beeman] {
            // --- two disks (2D) ---
            let (r, rho, v0): (f64, f64, f64) = (0.5, 1.0, 0.3);
            let m = rho * std::f64::consts::PI * r * r;
            let w0 = (k / (m / 2.0)).sqrt();
            let params = hooke(k, Some(e), 0.0);
            let law = params.build(Partner::Grain, "contact").unwrap();
            let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
            g.push(DVec2::new(-0.51, 0.0), r, rho, DVec2::new(0.5 * v0, 0.0));
            g.push(DVec2::new(0.51, 0.0), r, rho, DVec2::new(-0.5 * v0, 0.0));
            let d = Domain::new(DVec2::splat(-5.0), DVec2::splat(5.0), [false; 3]);
            let dt = std::f64::consts::PI / w0 / 4000.0;
            let sim = SimulationBuilder::new(g, d, law).dt(dt).integrator(integrator).build().unwrap();
            let c = collide(
                sim,
                |s| 1.0 - (s.grains.pos[1] - s.grains.pos[0]).length(),
                |s| (s.grains.vel[0] - s.grains.vel[1]).x,
            );
            let t_half = std::f64::consts::PI / (w0 * (1.0 - zeta * zeta).sqrt());
            // Issue bounds: e within 0.5 %, duration within 1 % of π/(ω₀√(1−ζ²)).
            assert!(rel(c.restitution, e) < 0.005, "{integrator:?} e = {e}: measured {}", c.restitution);
            assert!(rel(c.duration, t_half) < 0.01, "{integrator:?} e = {e}: duration {} vs {t_half}", c.duration);
            // Tighter, against the exact clamped solution (dt = T/4000: errors ~1e-4).
            assert!(rel(c.restitution, e) < 2e-4, "{integrator:?} e = {e}: measured {}", c.restitution);
            let exact = clamped_contact_time(zeta) / w0;
            assert!(rel(c.duration, exact) < 2e-4, "{integrator:?} e = {e}: duration {} vs exact {exact}", c.duration);

            // --- sphere on a wall (3D): m* = m ---
            let wall_law = params.build(Partner::Wall, "contact.wall").unwrap();
            let m = rho * 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
            let w0 = (k / m).sqrt();
            let mut g = Grains::<D3>::new(GrainKind::Sphere);
            g.push(DVec3::new(0.0, 0.0, 0.51), r, rho, DVec3::new(0.0, 0.0, -v0));
            let d = Domain::new(DVec3::splat(-5.0), DVec3::splat(5.0), [false; 3])
                .with_wall(Wall::axis_aligned("floor", 2, 0.0, true, wall_law));
            let dt = std::f64::consts::PI / w0 / 4000.0;
            let sim = SimulationBuilder::new(g, d, law).dt(dt).integrator(integrator).build().unwrap();
            let c = collide(sim, |s| s.grains.radius[0] - s.grains.pos[0].z, |s| -s.grains.vel[0].z);
            let t_half = std::f64::consts::PI / (w0 * (1.0 - zeta * zeta).sqrt());
            assert!(rel(c.restitution, e) < 0.005, "wall {integrator:?} e = {e}: measured {}", c.restitution);
            assert!(rel(c.duration, t_half) < 0.01, "wall {integrator:?} e = {e}: duration {} vs {t_half}", c.duration);
        }
    }
}
