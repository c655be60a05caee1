//! Building the systems of E1: packings by piston compression of a granular gas (SPEC §5.1),
//! triangular lattices and chains (SPEC §5.6), and the relaxation to static equilibrium.
//!
//! **Relaxation.** Plain damped molecular dynamics (SPEC §5.1): energy leaves only through the
//! contact dashpots (ζ of critical) and the piston's motion. The simulation advances in chunks of
//! `check_every` steps (at absolute step numbers, so an interrupted and resumed preparation is
//! bit-identical). The preparation is done when the largest grain acceleration
//! max_i max(|F_i|/m_i, |τ_i|R_i/I_i) and the piston's |a_w| are below the tolerance.
//!
//! **Tail time step** (`tail_dt_factor`, default 3): once the kinetic energy per grain is below
//! `tail_kinetic_energy` × p d̄³ (default 1e-5) and at most `tail_sliding_fraction` (1 %) of the
//! contacts slide, the step is multiplied by the factor until convergence and set back
//! afterwards. Measured (618 grains, seed 1): by then the network has settled (contact count and
//! piston height fixed); 50–80 % of the steps are spent afterwards, while rattlers, which carry
//! 10–50 % of the kinetic energy, bounce in their cages and kick the backbone, a physical time.
//! The factor shortens that time's steps without changing the criterion or the kind of dynamics;
//! the packings agree with those of factor 1 within far less than the ensemble spread
//! (docs/validation.md, E1, "Tail time step").
//!
//! *Deviation, off by default* (`quench = true`): after each chunk the power
//! P = Σ_i (F_i·v_i + τ_i·ω_i) + F_w v_w of the forces on the grains and the piston is computed, and
//! when P < 0 every velocity, the piston's included, is set to zero (a FIRE-like accelerator). It
//! relaxes faster but yields a different packing (stiffer in shear), so the published-protocol
//! configs do not use it.

use super::config::PreparationConfig;
use grainwave_core::checkpoint::AnySimulation;
use grainwave_core::contact::{ContactParams, Partner};
use grainwave_core::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, Ordering};

/// Hertz–Mindlin parameters in E1 units: E = 1 − ν² (E* = 1), friction μ, damping ζ.
pub fn hertz_params(friction: f64, poisson: f64, zeta: f64) -> ContactParams {
    let mut p = ContactParams::preset("hertz_mindlin");
    p.young = Some(1.0 - poisson * poisson);
    p.poisson = Some(poisson);
    p.friction = Some(friction);
    p.damping_fraction = if zeta > 0.0 { Some(zeta) } else { None };
    p
}

/// Replaces the damping of every contact law of `sim` (grains and walls) by ζ, keeping μ and ν.
pub fn set_damping<D: Dim>(sim: &mut Simulation<D>, friction: f64, poisson: f64, zeta: f64) -> Result<()> {
    let p = hertz_params(friction, poisson, zeta);
    sim.law = p.build(Partner::Grain, "contact")?;
    let wall = p.build(Partner::Wall, "contact.wall")?;
    for w in &mut sim.domain.walls {
        w.law = wall;
    }
    sim.refresh_forces()
}

/// What the preparation of one packing needs.
#[derive(Clone, Debug)]
pub struct PackingSpec {
    /// Number of grains.
    pub grains: usize,
    /// Periodic width (3D: both lateral lengths).
    pub width: f64,
    /// Diameter spread a.
    pub spread: f64,
    /// Friction μ.
    pub friction: f64,
    /// Poisson ν.
    pub poisson: f64,
    /// Pressure p.
    pub pressure: f64,
    /// Seed.
    pub seed: u64,
    /// Preparation keys.
    pub preparation: PreparationConfig,
}

/// Default expected overlap (fraction of R_max) for the time step: 4 (3p)^{2/3}/R_max.
pub fn default_expected_overlap(pressure: f64, r_max: f64) -> f64 {
    (4.0 * (3.0 * pressure).powf(2.0 / 3.0) / r_max).clamp(1e-6, 0.1)
}

/// The gas, the walls and the piston of a packing (not yet stepped): grains at random
/// non-overlapping positions in [0, L_x) (× [0, L_y)) × [0, H₀], H₀ such that the solid fraction is
/// `gas_fraction`; velocities uniform in [−v₀, v₀]; bottom wall (index 0) at 0, piston (index 1)
/// at H₀ under p L_x d̄ (`sphere2d`) or p L_x L_y (`sphere`).
pub fn build_gas<D: Dim>(spec: &PackingSpec) -> Result<Simulation<D>> {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let radii = SizeDistribution::UniformDiameter { mean_diameter: 1.0, spread: spec.spread }.sample(spec.grains, &mut rng)?;
    let kind = if D::D == 2 { GrainKind::Sphere2d } else { GrainKind::Sphere };
    let measure: f64 = radii.iter().map(|&r| if D::D == 2 { std::f64::consts::PI * r * r } else { kind.measure(r) }).sum();
    let cross = if D::D == 2 { spec.width } else { spec.width * spec.width };
    let pc = &spec.preparation;
    let r_max = radii.iter().cloned().fold(0.0, f64::max);
    let height = (measure / (cross * pc.gas_fraction)).max(4.0 * r_max);
    let z = D::D - 1;
    let mut hi = D::Vector::ZERO;
    for k in 0..D::D {
        hi.set(k, if k == z { height } else { spec.width });
    }
    let mut periodic = [false; 3];
    for p in periodic.iter_mut().take(z) {
        *p = true;
    }
    let pos = grainwave_core::placement::random_gas::<D>(&radii, D::Vector::ZERO, hi, periodic, &mut rng, 100_000)?;
    let v0 = pc.initial_speed.unwrap_or(spec.pressure.sqrt());
    let mut grains = Grains::<D>::new(kind);
    for (p, &r) in pos.iter().zip(&radii) {
        let mut v = D::Vector::ZERO;
        if v0 > 0.0 {
            for k in 0..D::D {
                v.set(k, v0 * (2.0 * rng.random::<f64>() - 1.0));
            }
        }
        grains.push(*p, r, 1.0, v);
    }
    let params = hertz_params(spec.friction, spec.poisson, pc.damping);
    let law = params.build(Partner::Grain, "contact")?;
    let wall_law = params.build(Partner::Wall, "contact.wall")?;
    let mean_diameter = 2.0 * radii.iter().sum::<f64>() / radii.len() as f64;
    let mean_mass = grains.total_mass() / grains.len() as f64;
    let layer = if D::D == 2 { spec.width / mean_diameter } else { cross / (mean_diameter * mean_diameter) };
    let piston_mass = pc.piston_mass.unwrap_or(layer * mean_mass);
    let force = spec.pressure * cross * if D::D == 2 { mean_diameter } else { 1.0 };
    let domain = Domain::new(D::Vector::ZERO, hi, periodic).with_wall(Wall::axis_aligned("bottom", z, 0.0, true, wall_law)).with_wall(
        Wall::axis_aligned("top", z, height, false, wall_law).with_motion(WallMotion::Piston { mass: piston_mass, force: TimeFunction::constant(force) }),
    );
    let overlap = pc.expected_overlap.unwrap_or_else(|| default_expected_overlap(spec.pressure, r_max));
    SimulationBuilder::new(grains, domain, law).dt_fraction(pc.dt_fraction).expected_overlap(overlap).seed(spec.seed).build()
}

/// State of a preparation, kept in `preparing.gwck` while it runs and in `packing.gwck` once done.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PackingFile {
    /// Fingerprint of the study and preparation keys, size, pressure and seed.
    pub fingerprint: u64,
    /// The engine state.
    pub sim: AnySimulation,
    /// How the preparation went (final once `converged`).
    pub info: PreparationInfo,
}

/// How a preparation went.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PreparationInfo {
    /// Reached equilibrium.
    pub converged: bool,
    /// Steps done.
    pub steps: u64,
    /// Simulated time [time].
    pub time: f64,
    /// Time step [time].
    pub dt: f64,
    /// Quenches (velocities zeroed).
    pub quenches: u64,
    /// Largest grain acceleration at the end [length/time²].
    pub max_acceleration: f64,
    /// |acceleration| of the piston at the end [length/time²].
    pub piston_acceleration: f64,
    /// Wall-clock seconds spent, summed over resumes [s].
    pub seconds: f64,
    /// Step at which the tail time step (`preparation.tail_dt_factor`) took over, if it did.
    #[serde(default)]
    pub tail_step: Option<u64>,
    /// Engine warnings.
    pub warnings: Vec<String>,
}

/// Why [`relax`] returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RelaxStatus {
    /// Equilibrium reached.
    Converged,
    /// The interrupt flag was raised (state consistent, at a chunk boundary).
    Interrupted,
}

/// Largest |acceleration| of the pistons.
fn piston_acceleration<D: Dim>(sim: &Simulation<D>) -> f64 {
    sim.domain.walls.iter().filter(|w| matches!(w.motion, WallMotion::Piston { .. })).map(|w| w.accel.abs()).fold(0.0, f64::max)
}

/// Kinetic energy per grain below which the tail time step applies (`preparation.tail_kinetic_energy`
/// × p d̄³, E1 units).
pub fn tail_energy(pc: &PreparationConfig, pressure: f64) -> f64 {
    pc.tail_kinetic_energy * pressure
}

/// Relaxes `sim` to equilibrium (see the module docs) under pressure `pressure` (for the tail
/// criterion of `preparation.tail_dt_factor`). `save` is called with the state at chunk
/// boundaries at least every `save_every` wall-clock seconds (it must not change the state).
pub fn relax<D: Dim>(
    sim: &mut Simulation<D>,
    info: &mut PreparationInfo,
    pc: &PreparationConfig,
    pressure: f64,
    interrupt: &AtomicBool,
    save_every: f64,
    save: &mut dyn FnMut(&Simulation<D>, &PreparationInfo) -> crate::Result<()>,
) -> crate::Result<RelaxStatus> {
    let stop = StopCriteria { step_limit: Some(u64::MAX), ..Default::default() };
    let every = pc.check_every;
    let started = std::time::Instant::now();
    let base_seconds = info.seconds;
    let mut last_save = std::time::Instant::now();
    // a resumed preparation whose tail had begun runs on with the tail step (kept in the state)
    if info.tail_step.is_none() {
        info.dt = sim.dt;
    }
    let tail_below = tail_energy(pc, pressure);
    loop {
        let p = sim.progress(&stop);
        let a_w = piston_acceleration(sim);
        info.steps = sim.step;
        info.time = sim.time;
        info.max_acceleration = p.max_acceleration;
        info.piston_acceleration = a_w;
        info.seconds = base_seconds + started.elapsed().as_secs_f64();
        if sim.step % every == 0 && p.max_acceleration < pc.max_acceleration && a_w < pc.max_acceleration {
            sim.check_timestep_warning();
            if info.tail_step.is_some() {
                // the packing keeps the preparation's time step for what follows (damped MD)
                sim.dt = info.dt;
                sim.dt_fraction = pc.dt_fraction;
            }
            info.converged = true;
            info.warnings = sim.warnings.clone();
            return Ok(RelaxStatus::Converged);
        }
        if interrupt.load(Ordering::Relaxed) {
            return Ok(RelaxStatus::Interrupted);
        }
        if sim.step >= pc.step_limit {
            // a limit the run reached, found only by running (exit code 1), not an inconsistent
            // input: worded and typed as e2's preparation that reaches no equilibrium in time
            return Err(grainwave_study::ExperimentError::NotReached(format!(
                "the preparation reached no equilibrium within {} steps (`preparation.step_limit`): max acceleration {:.3e}, piston acceleration {:.3e} (tolerance `preparation.max_acceleration` = {:.1e})",
                sim.step, p.max_acceleration, a_w, pc.max_acceleration
            )));
        }
        if info.tail_step.is_none() && pc.tail_dt_factor > 1.0 && sim.step % every == 0
            && p.kinetic_energy_per_grain < tail_below
            && p.sliding as f64 <= pc.tail_sliding_fraction * p.contacts as f64 {
            info.tail_step = Some(sim.step);
            sim.dt = info.dt * pc.tail_dt_factor;
            sim.dt_fraction = pc.dt_fraction * pc.tail_dt_factor;
        }
        if last_save.elapsed().as_secs_f64() >= save_every {
            save(sim, info)?;
            last_save = std::time::Instant::now();
        }
        // to the next multiple of `every`, looking at the interrupt flag on the way; a preparation
        // stopped there resumes to the same multiple, as an uninterrupted one
        if !sim.steps_until(every - sim.step % every, || interrupt.load(Ordering::Relaxed))? {
            return Ok(RelaxStatus::Interrupted);
        }
        if pc.quench {
            let g = &sim.grains;
            let mut power = grainwave_core::util::det_sum(g.len(), |k| g.force[k].dot(g.vel[k]) + g.torque[k].dot(g.omega[k]));
            for w in &sim.domain.walls {
                if let WallMotion::Piston { mass, .. } = w.motion {
                    power += mass * w.accel * w.speed;
                }
            }
            if power < 0.0 {
                info.quenches += 1;
                for v in sim.grains.vel.iter_mut() {
                    *v = D::Vector::ZERO;
                }
                for w in sim.grains.omega.iter_mut() {
                    *w = D::AngVector::ZERO;
                }
                for w in sim.domain.walls.iter_mut() {
                    w.speed = 0.0;
                }
            }
        }
    }
}
