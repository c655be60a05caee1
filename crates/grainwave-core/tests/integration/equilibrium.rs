//! Static equilibrium (SPEC §3): grains settle under gravity in a walled box, and a column is
//! compressed by a piston. Force balance is checked on the walls; both dimensions run through the
//! same generic code.
//!
//! Relaxation runs until KE per grain < 1e-12 (units: mean diameter, density, g = 1) **and** the
//! largest grain acceleration < 1e-7 g. The second criterion is what bounds the force balance:
//! |floor load − weight| = |Σ m_i a_i| ≤ M a_max. Kinetic energy alone does not: with contact
//! frequencies ω ~ 300 a residual collective vibration of KE/grain = 1e-12 still carries
//! accelerations ~ ω v ~ 5e-4 g (measured: floor/weight − 1 = 5e-4 at KE/grain 6e-14).

use crate::common;
use common::*;
use grainwave_core::contact::Partner;
use grainwave_core::placement::random_gas;
use grainwave_core::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// A walled box with `n` polydisperse grains dropped in it, gravity −g along the last axis.
/// Side walls are frictionless (they must not carry weight); the floor is frictional (a grain
/// alone on a frictionless floor would slide and spin for ever). In 3D weak twisting and rolling
/// resistances are on: without them a sphere spinning about the normal of a contact, or rolling
/// without slip alone on the floor, dissipates nothing and the kinetic energy never vanishes
/// (seen: KE/grain 5e-4 with all accelerations < 1e-13 from spin; then 6e-12 from spheres
/// rolling on the floor with KE_rot/KE_trans = I/(mR²) = 0.4 exactly).
fn gravity_box<D: Dim>(kind: GrainKind, n: usize, width: f64, seed: u64) -> Simulation<D> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut params = hooke(1.0e4, Some(0.5), 0.4);
    if D::D == 3 {
        params.twisting_stiffness = Some(1.0);
        params.twisting_damping = Some(0.05);
        params.twisting_friction = Some(0.1);
        params.rolling_stiffness = Some(1.0);
        params.rolling_damping = Some(0.05);
        params.rolling_friction = Some(0.1);
    }
    let law = params.build(Partner::Grain, "contact").unwrap();
    let mut wp = params.clone();
    wp.friction = Some(0.0); // frictionless walls: the floor alone carries the weight
    let wall_law = wp.build(Partner::Wall, "contact.wall").unwrap();
    let up = D::D - 1;
    let height = 3.0 * n as f64 / width.powi(D::D as i32 - 1);
    let mut lo = D::Vector::ZERO;
    let mut hi = D::Vector::ZERO;
    for k in 0..D::D {
        hi.set(k, if k == up { height } else { width });
    }
    let radii = SizeDistribution::UniformDiameter { mean_diameter: 1.0, spread: 0.2 }.sample(n, &mut rng).unwrap();
    let pos = random_gas::<D>(&radii, lo, hi, [false; 3], &mut rng, 10_000).unwrap();
    let mut grains = Grains::<D>::new(kind);
    for (p, r) in pos.iter().zip(&radii) {
        grains.push(*p, *r, 1.0, D::Vector::ZERO);
    }
    lo.set(up, 0.0);
    let mut domain = Domain::new(lo, hi, [false; 3]);
    let floor_law = params.build(Partner::Wall, "contact.wall").unwrap();
    for k in 0..D::D {
        let low_law = if k == up { floor_law } else { wall_law };
        domain = domain.with_wall(Wall::axis_aligned(format!("low{k}"), k, 0.0, true, low_law));
        domain = domain.with_wall(Wall::axis_aligned(format!("high{k}"), k, hi.get(k), false, wall_law));
    }
    let mut g = D::Vector::ZERO;
    g.set(up, -1.0);
    SimulationBuilder::new(grains, domain, law).gravity(g).seed(seed).build().unwrap()
}

fn settle_and_check<D: Dim>(mut sim: Simulation<D>) {
    let stop = StopCriteria {
        kinetic_energy_per_grain: Some(1e-12),
        max_acceleration: Some(1e-7),
        step_limit: Some(3_000_000),
        check_every: 100,
        ..Default::default()
    };
    let out = sim.run(&stop, &mut |_| Control::Continue).unwrap();
    assert_eq!(out.reason, StopReason::Converged, "did not settle: {:?}", out.last);
    let up = D::D - 1;
    let weight: f64 = sim.grains.mass.iter().sum::<f64>() * 1.0;
    // the floor is wall `low{up}` = index 2·up
    let floor = &sim.domain.walls[2 * up];
    let floor_load = floor.normal_load();
    eprintln!(
        "{}: {} steps, KE/grain {:.2e}, max acceleration {:.2e}, floor/weight − 1 = {:.2e}",
        D::NAME,
        out.steps,
        out.last.kinetic_energy_per_grain,
        out.last.max_acceleration,
        floor_load / weight - 1.0
    );
    assert!(rel(floor_load, weight) < 1e-6, "floor load {floor_load} vs weight {weight}");
    // the same from the contact records
    let snap = sim.snapshot();
    assert!(rel(snap.wall_load(2 * up as u32), weight) < 1e-6);
}

both_dims! {
    /// 150 grains in a box 10 wide (2D) or 4 × 4 (3D).
    fn grains_settle_under_gravity<D>() {
        settle_and_check(gravity_box::<D>(D::kind(), 150, D::pick(10.0, 4.0), D::pick(1, 2)));
    }
}

/// A column between a fixed floor and a piston of prescribed force F, periodic sideways: at
/// equilibrium the floor carries F + weight.
fn piston_column<D: Dim>(kind: GrainKind, n: usize, width: f64, force: f64, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let params = hooke(1.0e4, Some(0.5), 0.4);
    let law = params.build(Partner::Grain, "contact").unwrap();
    let wall_law = params.build(Partner::Wall, "contact.wall").unwrap();
    let up = D::D - 1;
    let height = 4.0 * n as f64 / width.powi(D::D as i32 - 1);
    let mut hi = D::Vector::ZERO;
    for k in 0..D::D {
        hi.set(k, if k == up { height } else { width });
    }
    let mut periodic = [false; 3];
    for p in periodic.iter_mut().take(up) {
        *p = true;
    }
    let radii = SizeDistribution::UniformDiameter { mean_diameter: 1.0, spread: 0.2 }.sample(n, &mut rng).unwrap();
    let pos = random_gas::<D>(&radii, D::Vector::ZERO, hi, periodic, &mut rng, 10_000).unwrap();
    let mut grains = Grains::<D>::new(kind);
    for (p, r) in pos.iter().zip(&radii) {
        grains.push(*p, *r, 1.0, D::Vector::ZERO);
    }
    let layer_mass = grains.total_mass() * 1.0 / (height / 1.0);
    let domain = Domain::new(D::Vector::ZERO, hi, periodic)
        .with_wall(Wall::axis_aligned("bottom", up, 0.0, true, wall_law))
        .with_wall(
            Wall::axis_aligned("piston", up, height, false, wall_law)
                .with_motion(WallMotion::Piston { mass: layer_mass, force: TimeFunction::constant(force) }),
        );
    let mut g = D::Vector::ZERO;
    g.set(up, -1.0);
    let mut sim = SimulationBuilder::new(grains, domain, law).gravity(g).seed(seed).build().unwrap();
    let stop = StopCriteria {
        kinetic_energy_per_grain: Some(1e-12),
        max_acceleration: Some(1e-7),
        step_limit: Some(3_000_000),
        check_every: 100,
        ..Default::default()
    };
    let out = sim.run(&stop, &mut |_| Control::Continue).unwrap();
    assert_eq!(out.reason, StopReason::Converged, "did not settle: {:?}", out.last);
    let weight = sim.grains.total_mass();
    let bottom = sim.domain.walls[0].normal_load();
    let piston = &sim.domain.walls[1];
    eprintln!(
        "{} piston: {} steps, bottom/(F+W) − 1 = {:.2e}, piston load/F − 1 = {:.2e}, piston travel {:.3}",
        D::NAME,
        out.steps,
        bottom / (force + weight) - 1.0,
        piston.normal_load() / force - 1.0,
        piston.displacement()
    );
    assert!(rel(bottom, force + weight) < 1e-6, "bottom {bottom} vs F + W = {}", force + weight);
    assert!(rel(piston.normal_load(), force) < 1e-6, "the piston is in equilibrium");
    assert!(piston.displacement() > 0.5 * height, "the piston moved down onto the grains");
}

both_dims! {
    /// 80 grains, 8 wide (2D) or 3.5 × 3.5 (3D), under a piston force of 50.
    fn piston_compresses_a_column<D>() {
        piston_column::<D>(D::kind(), 80, D::pick(8.0, 3.5), 50.0, D::pick(3, 4));
    }
}
