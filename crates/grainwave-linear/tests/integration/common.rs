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
    /// Area fraction of the initial gas.
    pub gas_fraction: f64,
}

impl PackingSpec {
    pub fn e1(grains: usize, width: f64, seed: u64) -> Self {
        PackingSpec { grains, width, pressure: 1e-4, friction: 0.5, damping_fraction: 0.2, seed, max_acceleration: 1e-10, gas_fraction: 0.3 }
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

/// Prepares the packing: a loose gas (area fraction `gas_fraction`, default 0.3) compressed by the piston with damping,
/// then relaxed with velocity quenching (all velocities, piston included, are zeroed whenever the
/// power F·v of the grains becomes negative) until the largest grain acceleration (and the
/// piston's) is below `max_acceleration`.
pub fn prepare_packing(spec: &PackingSpec) -> Simulation<D2> {
    prepare_packing_with(spec, &mut |_, _| {})
}

/// [`prepare_packing`] with a progress callback (see [`relax`]).
pub fn prepare_packing_with(spec: &PackingSpec, report: &mut dyn FnMut(&Simulation<D2>, f64)) -> Simulation<D2> {
    let mut sim = gas(spec);
    if let Err(e) = relax(&mut sim, spec.max_acceleration, 20_000_000, report) {
        panic!("{e}");
    }
    sim
}

/// The initial gas of [`prepare_packing`] between the bottom wall and the piston.
pub fn gas(spec: &PackingSpec) -> Simulation<D2> {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let radii = SizeDistribution::UniformDiameter { mean_diameter: 1.0, spread: 0.2 }.sample(spec.grains, &mut rng).unwrap();
    let area: f64 = radii.iter().map(|r| std::f64::consts::PI * r * r).sum();
    let height = area / (spec.width * spec.gas_fraction);
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
    SimulationBuilder::new(grains, domain, law).dt_fraction(0.05).expected_overlap(0.02).seed(spec.seed).build().unwrap()
}

/// Relaxes with quenching until max acceleration < `tol` (grains and pistons); `report` sees the
/// simulation and its largest acceleration every 10 steps. Err after `max_steps` steps.
pub fn relax(sim: &mut Simulation<D2>, tol: f64, max_steps: u64, report: &mut dyn FnMut(&Simulation<D2>, f64)) -> Result<(), String> {
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
        report(sim, p.max_acceleration.max(piston_acc));
        if p.max_acceleration < tol && piston_acc < tol {
            return Ok(());
        }
        if sim.step - start >= max_steps {
            return Err(format!("packing did not relax in {max_steps} steps: {p:?}, piston acceleration {piston_acc:e}"));
        }
    }
}

/// Hooke law (k_n, k_t = ratio · k_n, friction μ), undamped.
pub fn hooke_params(k_n: f64, ratio: f64, friction: f64) -> ContactParams {
    let mut p = ContactParams::preset("hooke_cundall_strack");
    p.normal_stiffness = Some(k_n);
    p.tangential_stiffness_ratio = Some(ratio);
    p.friction = Some(friction);
    p
}

/// A compressed triangular lattice of `rows` × `cols` grains (spacing 1, one lattice direction
/// along x), radii 0.515 (1 + 0.02 u), u uniform in [−1, 1]: every nearest-neighbour pair overlaps
/// by at least 0.009 and at most 0.051, next-nearest neighbours are far apart. `walls`: periodic in
/// x with a bottom and a top wall 0.5 from the outer rows' centres (wall overlaps 0.005 … 0.025);
/// otherwise periodic in x and y (`rows` even). `mass`: Some(m) gives every grain mass m. Grains
/// listed in `rattlers` get radius 0.3: they touch nothing.
#[allow(clippy::too_many_arguments)]
pub fn lattice_2d(rows: usize, cols: usize, kind: GrainKind, params: &ContactParams, walls: bool, mass: Option<f64>, seed: u64, rattlers: &[usize]) -> SimulationBuilder<D2> {
    use rand::RngExt;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dy = 3f64.sqrt() / 2.0;
    let y0 = 1.0;
    let mut grains = Grains::<D2>::new(kind);
    for (k, p) in grainwave_core::placement::triangular_lattice(rows, cols, 1.0, [0.3, y0]).into_iter().enumerate() {
        let mut r = 0.515 * (1.0 + 0.02 * (2.0 * rng.random::<f64>() - 1.0));
        if rattlers.contains(&k) {
            r = 0.3;
        }
        match mass {
            Some(m) => grains.push_with_mass(DVec2::new(p[0], p[1]), r, m, DVec2::ZERO),
            None => grains.push(DVec2::new(p[0], p[1]), r, 1.0, DVec2::ZERO),
        };
    }
    let law = params.build(Partner::Grain, "contact").unwrap();
    let lx = cols as f64;
    let domain = if walls {
        let wall_law = params.build(Partner::Wall, "contact.wall").unwrap();
        let top = y0 + (rows - 1) as f64 * dy + 0.5;
        Domain::new(DVec2::new(0.0, y0 - 0.5), DVec2::new(lx, top), [true, false, false])
            .with_wall(Wall::axis_aligned("bottom", 1, y0 - 0.5, true, wall_law))
            .with_wall(Wall::axis_aligned("top", 1, top, false, wall_law))
    } else {
        assert!(rows % 2 == 0);
        Domain::new(DVec2::new(0.0, y0 - 0.5 * dy), DVec2::new(lx, y0 - 0.5 * dy + rows as f64 * dy), [true, true, false])
    };
    SimulationBuilder::new(grains, domain, law).max_initial_overlap(0.2).seed(seed)
}

/// A compressed FCC block of n × n × layers cubic cells (nearest-neighbour distance 1), radii as in
/// [`lattice_2d`]; periodic in x and y, and in z unless `walls` (then walls 0.5 below/above the
/// outer layers). Grains listed in `rattlers` get radius 0.3.
pub fn lattice_3d(n: usize, layers: usize, params: &ContactParams, walls: bool, mass: Option<f64>, seed: u64, rattlers: &[usize]) -> SimulationBuilder<D3> {
    use glam::DVec3;
    use rand::RngExt;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a = 2f64.sqrt();
    let basis = [[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]];
    let mut grains = Grains::<D3>::new(GrainKind::Sphere);
    let z0 = 1.0;
    let mut zmax: f64 = 0.0;
    for i in 0..n {
        for j in 0..n {
            for k in 0..layers {
                for b in basis {
                    let p = DVec3::new((i as f64 + b[0]) * a + 0.1, (j as f64 + b[1]) * a + 0.1, (k as f64 + b[2]) * a + z0);
                    zmax = zmax.max(p.z);
                    let mut r = 0.515 * (1.0 + 0.02 * (2.0 * rng.random::<f64>() - 1.0));
                    if rattlers.contains(&grains.len()) {
                        r = 0.3;
                    }
                    match mass {
                        Some(m) => grains.push_with_mass(p, r, m, DVec3::ZERO),
                        None => grains.push(p, r, 1.0, DVec3::ZERO),
                    };
                }
            }
        }
    }
    let law = params.build(Partner::Grain, "contact").unwrap();
    let l = n as f64 * a;
    let domain = if walls {
        let wall_law = params.build(Partner::Wall, "contact.wall").unwrap();
        Domain::new(DVec3::new(0.0, 0.0, z0 - 0.5), DVec3::new(l, l, zmax + 0.5), [true, true, false])
            .with_wall(Wall::axis_aligned("bottom", 2, z0 - 0.5, true, wall_law))
            .with_wall(Wall::axis_aligned("top", 2, zmax + 0.5, false, wall_law))
    } else {
        Domain::new(DVec3::new(0.0, 0.0, z0 - 0.25 * a), DVec3::new(l, l, z0 - 0.25 * a + layers as f64 * a), [true, true, true])
    };
    SimulationBuilder::new(grains, domain, law).max_initial_overlap(0.2).seed(seed)
}
