//! The model of E2 (SPEC §6.1): units, contact laws, the initial gas and the box, and the wall
//! drive (pistons under p* × their length, plus an optional pressure pulse).
//!
//! **Engine units.** The engine runs with mean diameter d̄ = 1, disks of unit thickness and unit
//! material density (m_i = π R_i²), and p* = 1. Results are reported in the units of SPEC §6.1:
//! p*, M* (total grain mass), ρ* = M*/A (2D density of the packing, A the area of the box after
//! preparation), L* = √(M*/ρ*) = √A, t* = √(M*/p*), the acoustic velocity v_a = d̄√(K_n/m̄)
//! (d̄, m̄ the mean diameter and mass; = √(4K_n/(ρπ)) for disks of material density ρ) and the
//! acoustic time t_a = L*/v_a.

use super::config::{MaterialConfig, PackingConfig, PreparationConfig, PulseShape};
use grainwave_core::contact::damping::normal;
use grainwave_core::contact::damping::tangential::FractionOfNormal;
use grainwave_core::contact::rolling::SpringDashpot;
use grainwave_core::contact::tangential::{Linear, SlipActivation};
use grainwave_core::contact::{critical_fraction_for_restitution, Hooke};
use grainwave_core::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Index of the fixed bottom wall.
pub const BOTTOM: usize = 0;
/// Index of the fixed left wall.
pub const LEFT: usize = 1;
/// Index of the right wall (a piston under p* × height).
pub const RIGHT: usize = 2;
/// Index of the top wall (a piston in the preparation, moving at constant speed in the test).
pub const TOP: usize = 3;

/// The units of SPEC §6.1, in engine units, and the derived acoustic scales.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Units {
    /// p* [force/length].
    pub pressure: f64,
    /// K_n [force/length].
    pub normal_stiffness: f64,
    /// M*: total mass of the grains.
    pub total_mass: f64,
    /// Area A of the box (after preparation).
    pub area: f64,
    /// ρ* = M*/A.
    pub density: f64,
    /// L* = √(M*/ρ*).
    pub length: f64,
    /// t* = √(M*/p*).
    pub time: f64,
    /// d̄, the mean diameter.
    pub mean_diameter: f64,
    /// m̄, the mean grain mass.
    pub mean_mass: f64,
    /// v_a = d̄ √(K_n/m̄).
    pub acoustic_velocity: f64,
    /// t_a = L*/v_a.
    pub acoustic_time: f64,
}

impl Units {
    /// The units of `sim` (its grains and the box between walls `LEFT`/`RIGHT`, `BOTTOM`/`TOP`),
    /// with pressure `p` and normal stiffness `k_n`.
    pub fn of(sim: &Simulation<D2>, p: f64, k_n: f64) -> Units {
        let g = &sim.grains;
        let n = g.len() as f64;
        let total_mass = g.total_mass();
        let (w, h) = box_size(sim);
        let area = w * h;
        let mean_diameter = 2.0 * g.radius.iter().sum::<f64>() / n;
        let mean_mass = total_mass / n;
        let density = total_mass / area;
        let length = (total_mass / density).sqrt();
        let acoustic_velocity = mean_diameter * (k_n / mean_mass).sqrt();
        Units {
            pressure: p,
            normal_stiffness: k_n,
            total_mass,
            area,
            density,
            length,
            time: (total_mass / p).sqrt(),
            mean_diameter,
            mean_mass,
            acoustic_velocity,
            acoustic_time: length / acoustic_velocity,
        }
    }
}

/// Width (right − left wall) and height (top − bottom wall) of the box.
pub fn box_size(sim: &Simulation<D2>) -> (f64, f64) {
    let w = &sim.domain.walls;
    (w[RIGHT].position.x - w[LEFT].position.x, w[TOP].position.y - w[BOTTOM].position.y)
}

/// The grain–grain law: Hooke K_n, dashpot γ_n = 2ζ√(m* K_n) with ζ from the restitution,
/// Cundall–Strack K_t = ratio × K_n with γ_t = ratio × γ_n, Coulomb μ = `friction` (0: no
/// tangential force), rolling resistance k_r = `rolling_stiffness` K_n d̄² capped at μ_r R* F_n.
/// With `material.slip_activation_time` > 0 the tangential spring has that slip-activation time
/// (× `acoustic_time`, t_a in engine units) instead of the plain Coulomb cap
/// ([`SlipActivation`]).
pub fn grain_law(m: &MaterialConfig, friction: f64, acoustic_time: f64) -> ContactLaw {
    let zeta = critical_fraction_for_restitution(m.restitution).unwrap_or(0.0);
    let stiffness = m.tangential_stiffness_ratio * m.normal_stiffness;
    let activation_time = m.slip_activation_time * acoustic_time;
    ContactLaw {
        normal: NormalElastic::Hooke(Hooke { stiffness: m.normal_stiffness }),
        damping: normal::CriticalFraction { zeta }.into(),
        tangential: if friction <= 0.0 {
            Tangential::None
        } else if activation_time > 0.0 {
            SlipActivation { stiffness, activation_time }.into()
        } else {
            Linear { stiffness }.into()
        },
        tangential_damping: FractionOfNormal { ratio: m.tangential_damping_ratio }.into(),
        friction,
        rolling: if m.rolling_stiffness > 0.0 {
            SpringDashpot { stiffness: m.rolling_stiffness * m.normal_stiffness, damping: 0.0, friction: m.rolling_friction }.into()
        } else {
            Rolling::None
        },
        twisting: Twisting::None,
    }
}

/// The grain–wall law: the same normal spring and dashpot, frictionless.
pub fn wall_law(m: &MaterialConfig) -> ContactLaw {
    let mut law = grain_law(m, 0.0, 0.0);
    law.rolling = Rolling::None;
    law
}

/// The law of an absorbing wall (SPEC §6.7) for `grains` grains of mean mass `mean_mass`: Hooke
/// stiffness K_n/√N, constant dashpot γ_w = `absorbing_damping` √(m̄ K_n), frictionless. The soft
/// spring leaves the dashpot in charge at all but the lowest frequencies, and the dashpot per unit
/// length matches the acoustic impedance of the packing, so incoming waves are mostly absorbed.
pub fn absorbing_wall_law(m: &MaterialConfig, grains: usize, mean_mass: f64) -> ContactLaw {
    ContactLaw {
        normal: NormalElastic::Hooke(Hooke { stiffness: m.normal_stiffness / (grains as f64).sqrt() }),
        damping: normal::Dashpot { coefficient: m.absorbing_damping * (mean_mass * m.normal_stiffness).sqrt() }.into(),
        tangential: Tangential::None,
        tangential_damping: TangentialDamping::None,
        friction: 0.0,
        rolling: Rolling::None,
        twisting: Twisting::None,
    }
}

/// Gives the bottom, left and top walls the absorbing law (SPEC §6.7) when
/// `material.absorbing_walls` and they do not have it yet; returns whether it changed them. Called
/// when the preparation with stiff walls has converged: the packing then relaxes into the soft
/// walls (overlap ≈ p* d̄/(K_n/√N)) before the loading, which and every replay of it run with
/// them. (Not from the start: pistons driving a gas into walls of stiffness K_n/√N overshoot them
/// — at 64 × 64 the top wall's overlap reached 0.3 R; nor at the start of the loading: settling
/// into the soft walls moves the grains by ≈ 0.03 d̄ at 64 × 64, a strain far above Δε = 1e−5.)
pub fn make_walls_absorbing(sim: &mut Simulation<D2>, m: &MaterialConfig) -> bool {
    if !m.absorbing_walls {
        return false;
    }
    let n = sim.grains.len();
    let law = absorbing_wall_law(m, n, sim.grains.total_mass() / n as f64);
    if sim.domain.walls[BOTTOM].law == law {
        return false;
    }
    for k in [BOTTOM, LEFT, TOP] {
        sim.domain.walls[k].law = law;
    }
    true
}

/// The granular gas in its box (SPEC §6.2): N = columns × rows disks with diameters uniform in
/// [1 − a, 1 + a], at random non-overlapping positions in a square of area Σπ R²/gas_fraction, at
/// rest; walls bottom (fixed), left (fixed), right and top (pistons of mass `wall_mass` M* under
/// p* × their length; all stiff: the absorbing walls of SPEC §6.7 are for the biaxial test and the
/// replays, see [`make_walls_absorbing`]), gravity g (−1, −1)/√2 with M* g = `gravity` p* L*.
pub fn build_gas(pk: &PackingConfig, m: &MaterialConfig, pc: &PreparationConfig, seed: u64) -> Result<Simulation<D2>> {
    let n = pk.columns * pk.rows;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a = pk.polydispersity;
    let radii: Vec<f64> = (0..n).map(|_| 0.5 * (1.0 - a + 2.0 * a * rng.random::<f64>())).collect();
    let solid: f64 = radii.iter().map(|r| std::f64::consts::PI * r * r).sum();
    let aspect = pk.columns as f64 / pk.rows as f64;
    let area = solid / pk.gas_fraction;
    let h = (area / aspect).sqrt();
    let w = aspect * h;
    let pos = grainwave_core::placement::random_gas::<D2>(&radii, glam::DVec2::new(0.0, 0.0), glam::DVec2::new(w, h), [false; 3], &mut rng, 100_000)?;
    let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    for (p, &r) in pos.iter().zip(&radii) {
        grains.push_with_mass(*p, r, std::f64::consts::PI * r * r, glam::DVec2::new(0.0, 0.0));
    }
    let total_mass = grains.total_mass();
    let wl = wall_law(m);
    let soft = wl;
    let piston = |f: f64| WallMotion::Piston { mass: pc.wall_mass * total_mass, force: TimeFunction::constant(f) };
    let domain = Domain::new(glam::DVec2::new(0.0, 0.0), glam::DVec2::new(w, h), [false; 3])
        .with_wall(Wall::axis_aligned("bottom", 1, 0.0, true, soft))
        .with_wall(Wall::axis_aligned("left", 0, 0.0, true, soft))
        .with_wall(Wall::axis_aligned("right", 0, w, false, wl).with_motion(piston(h)))
        .with_wall(Wall::axis_aligned("top", 1, h, false, soft).with_motion(piston(w)));
    // L* at the gas stage is only an estimate; the gravity is fixed here, from the solid area
    // at a packing fraction ≈ 0.84 (the scale of the prepared packing).
    let l_star = (solid / 0.84).sqrt();
    let g = pc.gravity * l_star / total_mass;
    let gravity = glam::DVec2::new(-g / std::f64::consts::SQRT_2, -g / std::f64::consts::SQRT_2);
    SimulationBuilder::new(grains, domain, grain_law(m, 0.0, 0.0)).gravity(gravity).dt_fraction(pc.dt_fraction).seed(seed).build()
}

/// An extra pressure on the right wall, p(t) = p*[1 + f(t)] (SPEC §6.4); time measured from
/// `start`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pulse {
    /// δ or wavelet.
    pub shape: PulseShape,
    /// p_a in engine units: for a δ pulse a time [engine time] (the replay converts the
    /// configured p_a, a time in t*, by t*), for a wavelet a dimensionless pressure fraction.
    pub amplitude: f64,
    /// Simulated time the pulse clock starts at.
    pub start: f64,
    /// t₀ after `start`.
    pub delay: f64,
    /// Wavelet width T.
    pub width: f64,
}

impl Pulse {
    /// f at the end time `t1` of a step of length `dt`. The δ pulse is p_a/dt in the one step
    /// whose end time is the first ≥ start + delay (impulse p_a p* L dt/dt).
    pub fn value(&self, t1: f64, dt: f64) -> f64 {
        let t = t1 - self.start;
        match self.shape {
            PulseShape::Delta => {
                if t >= self.delay - 0.5 * dt && t < self.delay + 0.5 * dt {
                    self.amplitude / dt
                } else {
                    0.0
                }
            }
            PulseShape::Wavelet => {
                let tau = (t - self.delay) / self.width;
                let t2 = tau * tau;
                self.amplitude * (3.0 - 6.0 * t2 + t2 * t2) * (-0.5 * t2).exp()
            }
        }
    }
}

/// The external force on a piston.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum PistonLoad {
    /// p* × the height of the box (walls `BOTTOM`–`TOP`): the right wall.
    Height,
    /// p* × the width of the box (walls `LEFT`–`RIGHT`): the top wall.
    Width,
    /// A constant force.
    Force(f64),
}

/// How the walls are driven: each piston's external force is set before every step from its
/// [`PistonLoad`], times 1 + f(t) for the pulse wall when a pulse is on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Drive {
    /// p*.
    pub pressure: f64,
    /// Wall indices of the pistons and their loads.
    pub pistons: Vec<(usize, PistonLoad)>,
    /// The wall the pulse acts on.
    pub pulse_wall: usize,
    /// Extra pressure on the pulse wall.
    pub pulse: Option<Pulse>,
}

impl Drive {
    /// The drive of the biaxial test: the right wall a piston under p* × height, pulses on it.
    pub fn biaxial(pressure: f64) -> Drive {
        Drive { pressure, pistons: vec![(RIGHT, PistonLoad::Height)], pulse_wall: RIGHT, pulse: None }
    }

    /// Sets the piston forces for the step ending at t + dt: F = load × (1 + f(t + dt)), lengths
    /// taken at the start of the step.
    pub fn set_forces(&self, sim: &mut Simulation<D2>) {
        let t1 = sim.time + sim.dt;
        let dt = sim.dt;
        for &(k, load) in &self.pistons {
            let mut f = match load {
                PistonLoad::Height => self.pressure * box_size(sim).1,
                PistonLoad::Width => self.pressure * box_size(sim).0,
                PistonLoad::Force(f) => f,
            };
            if k == self.pulse_wall {
                if let Some(p) = &self.pulse {
                    f *= 1.0 + p.value(t1, dt);
                }
            }
            if let WallMotion::Piston { mass, .. } = sim.domain.walls[k].motion {
                sim.domain.walls[k].motion = WallMotion::Piston { mass, force: TimeFunction::constant(f) };
            }
        }
    }

    /// One step with the forces of [`Drive::set_forces`].
    pub fn step(&self, sim: &mut Simulation<D2>) -> Result<()> {
        self.set_forces(sim);
        sim.step()
    }
}

/// Relative tolerance of [`mobilised_contacts`]: a contact counts as sliding at rest when
/// |F_t| ≥ (1 − `MOBILISATION_TOLERANCE`) μ F_n (SPEC §6.2).
pub const MOBILISATION_TOLERANCE: f64 = 1e-6;

/// M_s at rest (SPEC §6.2): the grain–grain contacts whose friction is fully mobilised,
/// |F_t| ≥ (1 − 1e−6) μ F_n, with μ the current grain–grain friction (0 when μ = 0). In a static
/// state this is the count that matters: the engine's cap flag ([`Simulation::counters`]`.sliding`)
/// is set only in the steps where the trial force exceeds the cap, which at rest depends on the
/// last bit of the trial force (a contact held exactly at the Coulomb limit flips in and out of
/// the flag). During motion the two counts agree to within the contacts that are just leaving or
/// reaching the limit.
pub fn mobilised_contacts(sim: &Simulation<D2>) -> u64 {
    let mu = sim.law.friction;
    if !(mu > 0.0) {
        return 0;
    }
    sim.contact_records().iter().filter(|c| is_mobilised(c, mu)).count() as u64
}

/// The test of [`mobilised_contacts`] for one record: a grain–grain contact with F_n > 0 and
/// |F_t| ≥ (1 − [`MOBILISATION_TOLERANCE`]) μ F_n.
pub fn is_mobilised(c: &grainwave_core::snapshot::ContactRecord<D2>, friction: f64) -> bool {
    matches!(c.j, grainwave_core::snapshot::Counterpart::Grain(_))
        && c.normal_force > 0.0
        && c.tangential_force.length() >= (1.0 - MOBILISATION_TOLERANCE) * friction * c.normal_force
}

/// Whether a small homogeneous strain increment pushes a contact that sits at the Coulomb limit
/// further into sliding: the affine test behind the sign dependence of the sliding loss.
///
/// `e` is the displacement gradient of the increment (extension positive; a compressive pulse
/// along x is `[[-1, 0], [0, 0]]`, any positive scale). The relative displacement of j with
/// respect to i is E b, b = (ℓ_i + ℓ_j) n the branch vector, so the normal force grows by
/// δF_n = −k_n n·E b and the tangential force on i by δF_t = k_t (t·E b) t (t = (−n_y, n_x)).
/// The contact stays at the limit and slides on when F̂_t·δF_t > μ δF_n; the value returned is
/// ŝ k_t (t·E b) + μ k_n (n·E b), ŝ = sign(F_t·t) [force per unit strain]: positive = pushed on,
/// negative = released (it sticks). Meaningful for mobilised contacts only
/// ([`MOBILISATION_TOLERANCE`]); the grains' actual motion under a pulse is not affine, so this
/// says where the mean increment pushes, not what each contact does.
pub fn sliding_drive(c: &grainwave_core::snapshot::ContactRecord<D2>, friction: f64, e: [[f64; 2]; 2]) -> f64 {
    let n = c.normal;
    let t = glam::DVec2::new(-n.y, n.x);
    let b = n * (c.lever_i + c.lever_j);
    let eb = glam::DVec2::new(e[0][0] * b.x + e[0][1] * b.y, e[1][0] * b.x + e[1][1] * b.y);
    let s = c.tangential_force.dot(t).signum();
    s * c.tangential_stiffness * t.dot(eb) + friction * c.normal_stiffness * n.dot(eb)
}

/// Of the grain–grain contacts of `sim` at the Coulomb limit at rest (counted as
/// [`mobilised_contacts`] does), how many a strain increment `e` pushes on
/// ([`sliding_drive`] > 0): `(mobilised, pushed on)`.
pub fn mobilised_pushed_on(sim: &Simulation<D2>, e: [[f64; 2]; 2]) -> (u64, u64) {
    let mu = sim.law.friction;
    if !(mu > 0.0) {
        return (0, 0);
    }
    let records = sim.contact_records();
    let mobilised: Vec<_> = records.iter().filter(|c| is_mobilised(c, mu)).collect();
    let on = mobilised.iter().filter(|c| sliding_drive(c, mu, e) > 0.0).count();
    (mobilised.len() as u64, on as u64)
}

/// Wall stresses [p*]: σ_xx = load on the right wall / height, σ_yy = load on the top wall / width
/// (compression positive).
pub fn wall_stresses(sim: &Simulation<D2>) -> (f64, f64) {
    let (w, h) = box_size(sim);
    (sim.domain.walls[RIGHT].normal_load() / h, sim.domain.walls[TOP].normal_load() / w)
}
