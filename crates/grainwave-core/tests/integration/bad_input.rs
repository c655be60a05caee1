//! Bad input gives an error that names the field and the value (never a panic), and numerical
//! blow-ups stop the run with a diagnosis naming the step and the grain.

use crate::common;
use common::*;
use glam::DVec2;
use grainwave_core::contact::Partner;
use grainwave_core::prelude::*;

fn two_disks(r0: f64, x1: f64) -> (Grains<D2>, Domain<D2>) {
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    g.push(DVec2::new(0.0, 0.0), r0, 1.0, DVec2::ZERO);
    g.push(DVec2::new(x1, 0.0), 0.5, 1.0, DVec2::ZERO);
    (g, Domain::new(DVec2::splat(-5.0), DVec2::splat(5.0), [false; 3]))
}

fn law() -> ContactLaw {
    hooke(1.0e4, Some(0.9), 0.5).build(Partner::Grain, "contact").unwrap()
}

fn err_of<T: std::fmt::Debug>(r: Result<T>) -> String {
    r.expect_err("must be refused").to_string()
}

#[test]
fn negative_radius_is_refused_with_field_and_value() {
    let (g, d) = two_disks(-0.5, 3.0);
    let e = err_of(SimulationBuilder::new(g, d, law()).build());
    assert!(e.contains("grains.radius") && e.contains("-0.5") && e.contains("grain id 0"), "{e}");
    let e = err_of(SizeDistribution::Monodisperse { radius: -1.0 }.validate());
    assert!(e.contains("radius") && e.contains("-1"), "{e}");
}

#[test]
fn negative_friction_is_refused() {
    let e = err_of(hooke(1.0e4, None, -0.2).build(Partner::Grain, "contact"));
    assert!(e.contains("contact.friction") && e.contains("-0.2") && e.contains("≥ 0"), "{e}");
    let e = err_of(hertz(1.0, 0.0, -1.0, None).build(Partner::Wall, "contact.wall"));
    assert!(e.contains("contact.wall.friction") && e.contains("-1"), "{e}");
}

#[test]
fn restitution_outside_unit_interval_is_refused() {
    for bad in [0.0, -0.3, 1.5, f64::NAN] {
        let e = err_of(hooke(1.0e4, Some(bad), 0.5).build(Partner::Grain, "contact"));
        assert!(e.contains("contact.restitution") && e.contains(&format!("{bad}")) && e.contains("(0, 1]"), "{e}");
    }
    // in (0, e^-2): physically unreachable with a clamped dashpot, and said so
    let e = err_of(hooke(1.0e4, Some(0.1), 0.5).build(Partner::Grain, "contact"));
    assert!(e.contains("contact.restitution") && e.contains("0.1") && e.contains("e^-2"), "{e}");
}

#[test]
fn non_positive_time_step_is_refused() {
    for bad in [0.0, -1e-4, f64::INFINITY] {
        let (g, d) = two_disks(0.5, 3.0);
        let e = err_of(SimulationBuilder::new(g, d, law()).dt(bad).build());
        assert!(e.contains("`dt`") && e.contains(&format!("{bad}")) && e.contains("> 0"), "{e}");
    }
}

#[test]
fn overlapping_grains_at_start_are_refused() {
    let (g, d) = two_disks(0.5, 0.8); // overlap 0.2 = 40 % of the radius
    let e = err_of(SimulationBuilder::new(g, d, law()).build());
    assert!(e.contains("grains 0 and 1 overlap") && e.contains("max_initial_overlap") && e.contains("0.4"), "{e}");
    // within the tolerance it is accepted
    let (g, d) = two_disks(0.5, 0.995);
    assert!(SimulationBuilder::new(g, d, law()).build().is_ok());
}

#[test]
fn unknown_preset_is_refused_with_the_alternatives() {
    let e = err_of(ContactParams::preset("hertz_mindlim").build(Partner::Grain, "contact"));
    assert!(e.contains("`hertz_mindlim`") && e.contains("contact.preset") && e.contains("hertz_mindlin, hooke_cundall_strack"), "{e}");
}

#[test]
fn inconsistent_and_missing_parameters_are_named() {
    let mut p = ContactParams::preset("hertz_mindlin");
    let e = err_of(p.build(Partner::Grain, "contact"));
    assert!(e.contains("contact.young") && e.contains("missing"), "{e}");
    p.young = Some(1.0);
    p.restitution = Some(0.5);
    let e = err_of(p.build(Partner::Grain, "contact"));
    assert!(e.contains("contact.restitution") && e.contains("damping_fraction"), "{e}");
    let mut p = hooke(1.0, Some(0.5), 0.5);
    p.normal_damping = Some(1.0);
    let e = err_of(p.build(Partner::Grain, "contact"));
    assert!(e.contains("at most one of") && e.contains("restitution, normal_damping"), "{e}");
    let mut p = hooke(1.0, None, 0.5);
    p.rolling_damping = Some(1.0);
    let e = err_of(p.build(Partner::Grain, "contact"));
    assert!(e.contains("contact.rolling_damping") && e.contains("contact.rolling_stiffness"), "{e}");
    assert!(err_of(GrainKind::from_name("cube")).contains("`cube`"));
    assert!(err_of(Integrator::from_name("euler")).contains("velocity_verlet, beeman"));
}

#[test]
fn grain_kind_must_fit_the_dimension_and_periodic_cells_must_fit_the_grains() {
    let mut g = Grains::<D2>::new(GrainKind::Sphere);
    g.push(DVec2::ZERO, 0.5, 1.0, DVec2::ZERO);
    let d = Domain::new(DVec2::splat(-5.0), DVec2::splat(5.0), [false; 3]);
    assert!(err_of(SimulationBuilder::new(g, d, law()).build()).contains("`sphere` lives in 3D"));
    let (g, _) = two_disks(0.5, 3.0);
    let small = Domain::new(DVec2::ZERO, DVec2::new(1.5, 8.0), [true, false, false]);
    let e = err_of(SimulationBuilder::new(g, small, law()).build());
    assert!(e.contains("domain.size[0]") && e.contains("1.5"), "{e}");
}

#[test]
fn stop_criteria_need_a_limit() {
    let (g, d) = two_disks(0.5, 3.0);
    let mut sim = SimulationBuilder::new(g, d, law()).build().unwrap();
    let e = err_of(sim.run(&StopCriteria { kinetic_energy_per_grain: Some(1e-9), ..Default::default() }, &mut |_| Control::Continue));
    assert!(e.contains("stop.step_limit"), "{e}");
}

#[test]
fn blow_up_names_step_grain_and_state() {
    // A disk squeezed between two walls, time step with ω dt ≈ 4 (stability needs ω dt < 2):
    // its oscillation grows until it interpenetrates a wall.
    let wall = hooke(1.0e4, None, 0.0).build(Partner::Wall, "contact.wall").unwrap();
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    g.push(DVec2::ZERO, 0.5, 1.0, DVec2::new(0.1, 0.0));
    let d = Domain::new(DVec2::splat(-5.0), DVec2::splat(5.0), [false; 3])
        .with_wall(Wall::axis_aligned("left", 0, -0.495, true, wall))
        .with_wall(Wall::axis_aligned("right", 0, 0.495, false, wall));
    let mut sim = SimulationBuilder::new(g, d, law()).dt(0.02).build().unwrap();
    assert!(!sim.warnings.is_empty(), "a time step above the suggestion is warned about");
    let e = sim.steps(1000).unwrap_err();
    match &e {
        CoreError::BlowUp { step, grain, reason, .. } => {
            assert!(*step > 0 && *grain == 0);
            assert!(reason.contains("overlap") && reason.contains("max_overlap_fraction"), "{reason}");
        }
        other => panic!("expected a blow-up, got {other}"),
    }
    let msg = e.to_string();
    assert!(msg.contains("numerical blow-up at step") && msg.contains("grain id") && msg.contains("velocity"), "{msg}");
}

#[test]
fn non_finite_state_is_a_blow_up() {
    let (g, d) = two_disks(0.5, 3.0);
    let mut sim = SimulationBuilder::new(g, d, law()).build().unwrap();
    sim.grains.vel[1] = DVec2::new(f64::NAN, 0.0);
    let e = sim.steps(10).unwrap_err().to_string();
    assert!(e.contains("non-finite") && e.contains("grain id 1"), "{e}");
}

#[test]
fn grain_escaping_through_a_wall_is_a_blow_up() {
    let wall = hooke(1.0e4, None, 0.0).build(Partner::Wall, "contact.wall").unwrap();
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    g.push(DVec2::new(0.0, 1.0), 0.5, 1.0, DVec2::new(0.0, -1.0e4)); // tunnels through in one step
    let d = Domain::new(DVec2::splat(-5.0), DVec2::splat(5.0), [false; 3]).with_wall(Wall::axis_aligned("floor", 1, 0.0, true, wall));
    let mut sim = SimulationBuilder::new(g, d, law()).dt(1e-3).build().unwrap();
    let e = sim.steps(10).unwrap_err().to_string();
    assert!(e.contains("left the domain through wall `floor`") || e.contains("overlap with wall `floor`"), "{e}");
}

/// A piston pulled away under a force its mass cannot represent for long (acceleration 1e306)
/// reaches a non-finite position within a few hundred steps: the run stops with a blow-up naming
/// the wall at the step it happens, instead of carrying on with non-finite positions (which an
/// earlier version reported only when plotting, after the run, or as "converged").
#[test]
fn a_wall_at_a_non_finite_position_is_a_blow_up() {
    let wall = hooke(1.0e4, None, 0.0).build(Partner::Wall, "contact.wall").unwrap();
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    g.push(DVec2::new(0.0, 0.5), 0.5, 1.0, DVec2::ZERO);
    let d = Domain::new(DVec2::splat(-5.0), DVec2::splat(5.0), [false; 3])
        .with_wall(Wall::axis_aligned("floor", 1, -5.0, true, wall))
        .with_wall(Wall::axis_aligned("top", 1, 5.0, false, wall).with_motion(WallMotion::Piston { mass: 1e-296, force: TimeFunction::constant(-1e10) }));
    let mut sim = SimulationBuilder::new(g, d, law()).dt(1e-2).build().unwrap();
    let e = sim.steps(100_000).unwrap_err();
    assert!(matches!(e, CoreError::BlowUp { .. }), "{e}");
    let e = e.to_string();
    assert!(e.contains("wall `top` reached a non-finite position"), "{e}");
    assert!(sim.step < 100_000, "stopped at step {}", sim.step);
}

/// The overlap guard of a grain–wall contact scales with the wall's softness (an absorbing wall of
/// SPEC §6.7 has K_n/√N): a disk resting under gravity at 0.4 R in a floor 64 × softer than the
/// grains carries the force of a 0.4/64 R grain contact and must run on, while the same 0.4 R
/// in a floor as stiff as the grains exceeds the guard (0.3 R) and stops the run.
#[test]
fn soft_wall_overlap_guard_scales_with_the_wall_stiffness() {
    let k = 1.0e4;
    let settle = |k_wall: f64| {
        let wall = hooke(k_wall, Some(0.3), 0.0).build(Partner::Wall, "contact.wall").unwrap();
        let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        g.push(DVec2::new(0.0, 0.5), 0.5, 1.0, DVec2::ZERO);
        let m = g.mass[0];
        let d = Domain::new(DVec2::splat(-5.0), DVec2::splat(5.0), [false; 3]).with_wall(Wall::axis_aligned("floor", 1, 0.0, true, wall));
        // static overlap m g / k_w = 0.2 = 0.4 R
        let gravity = DVec2::new(0.0, -0.2 * k_wall / m);
        let mut sim = SimulationBuilder::new(g, d, law()).gravity(gravity).build().unwrap();
        let r = sim.steps(20_000);
        (r, 0.5 - sim.grains.pos[0].y)
    };
    let (soft, overlap) = settle(k / 64.0);
    soft.expect("a 64 × softer wall allows 0.4 R");
    assert!((overlap / 0.2 - 1.0).abs() < 0.02, "settled overlap {overlap}");
    let e = err_of(settle(k).0);
    assert!(e.contains("overlap with wall `floor`") && e.contains("limit 0.300"), "{e}");
}
