//! Shared fixtures of the grainwave-linear tests (also used by the benchmark example).
#![allow(dead_code)]

use glam::DVec2;
use grainwave_core::placement::random_gas;
use grainwave_core::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Parameters of an E1-style packing (SPEC §5.1): `sphere2d` Hertz–Mindlin grains with diameters
/// uniform in [0.8, 1.2], periodic in x, fixed bottom wall, piston on top under a 3D pressure p
/// (piston force p · L_x · d̄), E = 1, ν = 0.
#[derive(Clone, Debug)]
pub struct PackingSpec {
    pub grains: usize,
    pub width: f64,
    pub pressure: f64,
    pub friction: f64,
    pub damping_fraction: f64,
    pub seed: u64,
    pub max_acceleration: f64,
}

impl PackingSpec {
    pub fn e1(grains: usize, width: f64, seed: u64) -> Self {
        PackingSpec { grains, width, pressure: 1e-4, friction: 0.5, damping_fraction: 0.2, seed, max_acceleration: 1e-10 }
    }
}

pub fn hertz_params(friction: f64, zeta: f64) -> ContactParams {
    let mut p = ContactParams::preset("hertz_mindlin");
    p.young = Some(1.0);
    p.poisson = Some(0.0);
    p.friction = Some(friction);
    p.damping_fraction = if zeta > 0.0 { Some(zeta) } else { None };
    p
}

/// Prepares the packing: a loose gas (area fraction 0.3) compressed by the piston with damping,
/// then relaxed with velocity quenching (all velocities, piston included, are zeroed whenever the
/// power F·v of the grains becomes negative) until the largest grain acceleration (and the
/// piston's) is below `max_acceleration`.
pub fn prepare_packing(spec: &PackingSpec) -> Simulation<D2> {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let radii = SizeDistribution::UniformDiameter { mean_diameter: 1.0, spread: 0.2 }.sample(spec.grains, &mut rng).unwrap();
    let area: f64 = radii.iter().map(|r| std::f64::consts::PI * r * r).sum();
    let height = area / (spec.width * 0.3);
    let hi = DVec2::new(spec.width, height);
    let pos = random_gas::<D2>(&radii, DVec2::ZERO, hi, [true, false, false], &mut rng, 100_000).unwrap();
    let mut grains = Grains::<D2>::new(GrainKind::Sphere2d);
    for (p, r) in pos.iter().zip(&radii) {
        grains.push(*p, *r, 1.0, DVec2::ZERO);
    }
    let params = hertz_params(spec.friction, spec.damping_fraction);
    let law = params.build(Partner::Grain, "contact").unwrap();
    let wall_law = params.build(Partner::Wall, "contact.wall").unwrap();
    let mean_mass = grains.total_mass() / spec.grains as f64;
    let piston_mass = spec.width * mean_mass;
    let force = spec.pressure * spec.width * 1.0;
    let domain = Domain::new(DVec2::ZERO, hi, [true, false, false])
        .with_wall(Wall::axis_aligned("bottom", 1, 0.0, true, wall_law))
        .with_wall(
            Wall::axis_aligned("top", 1, height, false, wall_law)
                .with_motion(WallMotion::Piston { mass: piston_mass, force: TimeFunction::constant(force) }),
        );
    let mut sim = SimulationBuilder::new(grains, domain, law).dt_fraction(0.05).expected_overlap(0.02).seed(spec.seed).build().unwrap();
    relax(&mut sim, spec.max_acceleration, 20_000_000);
    sim
}

/// Relaxes with quenching until max acceleration < `tol` (grains and pistons).
pub fn relax(sim: &mut Simulation<D2>, tol: f64, max_steps: u64) {
    let stop = StopCriteria { step_limit: Some(u64::MAX), ..Default::default() };
    let start = sim.step;
    loop {
        sim.steps(10).unwrap();
        let g = &sim.grains;
        let mut power = 0.0;
        for k in 0..g.len() {
            power += g.force[k].dot(g.vel[k]) + g.torque[k] * g.omega[k];
        }
        let mut piston_acc: f64 = 0.0;
        for w in &sim.domain.walls {
            if let WallMotion::Piston { .. } = w.motion {
                piston_acc = piston_acc.max(w.accel.abs());
            }
        }
        if power < 0.0 {
            for v in sim.grains.vel.iter_mut() {
                *v = DVec2::ZERO;
            }
            for w in sim.grains.omega.iter_mut() {
                *w = 0.0;
            }
            for w in sim.domain.walls.iter_mut() {
                w.speed = 0.0;
            }
        }
        let p = sim.progress(&stop);
        if p.max_acceleration < tol && piston_acc < tol {
            return;
        }
        assert!(sim.step - start < max_steps, "packing did not relax: {p:?}, piston acceleration {piston_acc:e}");
    }
}
