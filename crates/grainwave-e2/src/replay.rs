//! Replays of checkpoints (SPEC §6.3–6.5).
//!
//! **Paired replays** (wall pulse, radius change): two copies of the checkpointed state are
//! advanced in lockstep, one with the perturbation of amplitude a and one with amplitude 0 — the
//! same code path, so that the two differ by nothing but a. Every `sample_every` steps the
//! perturbed velocity of each grain, δv_i = v_i(with) − v_i(without), is stored (float32, by grain
//! id), together with the sliding-contact counts of both copies. Since the engine is deterministic
//! for any number of threads, a = 0 gives δv = 0 exactly.
//!
//! **Single replays** (velocities × γ, friction changed, wall stop ramp): one copy with the
//! modification, run for the replay's duration; its stresses, M_s and kinetic energy are recorded.

use super::arrival::{self, StripFit};
use super::config::{ArrivalDefinition, Modification, PulseShape, ReplayConfig};
use super::model::{self, Drive, Pulse, Units, TOP};
use glam::DVec2;
use grainwave_core::prelude::*;
use serde::{Deserialize, Serialize};

/// A perturbation of a paired replay; its size is the amplitude given to [`paired_replay`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Perturbation {
    /// A pressure pulse on the right wall (the amplitude is p_a).
    WallPulse {
        /// δ or wavelet.
        shape: PulseShape,
        /// The engine time of one t* (SPEC §6.4): a δ pulse of amplitude p_a (a time in t*)
        /// delivers the impulse p_a · p* · L_wall · `time_unit` [engine time]. Unused by the
        /// wavelet, whose p_a is a dimensionless pressure fraction.
        time_unit: f64,
        /// t₀ after the start of the replay [engine time].
        delay: f64,
        /// Wavelet width T [engine time].
        width: f64,
    },
    /// The radius of grain `grain` (id) × (1 + amplitude); its mass is unchanged.
    Radius {
        /// Grain id.
        grain: u32,
    },
}

impl Perturbation {
    /// Applies the perturbation with `amplitude` to `sim` and `drive` at the start of a replay.
    /// A δ pulse's p_a is converted from t* to engine time here, so that [`Pulse`] delivers the
    /// impulse p_a · p* · L_wall · t* (SPEC §6.4).
    pub fn apply(&self, sim: &mut Simulation<D2>, drive: &mut Drive, amplitude: f64) -> Result<()> {
        match *self {
            Perturbation::WallPulse { shape, time_unit, delay, width } => {
                let amplitude = match shape {
                    PulseShape::Delta => amplitude * time_unit,
                    PulseShape::Wavelet => amplitude,
                };
                drive.pulse = Some(Pulse { shape, amplitude, start: sim.time, delay, width });
                Ok(())
            }
            Perturbation::Radius { grain } => {
                let k = sim.grains.index_of(grain).ok_or_else(|| CoreError::invalid("grain", grain, "the id of a grain of the packing"))?;
                sim.grains.radius[k] *= 1.0 + amplitude;
                sim.refresh()
            }
        }
    }
}

/// The outcome of a paired replay.
#[derive(Clone, Debug, Default)]
pub struct PairResult {
    /// Sample times from the start of the replay [engine time].
    pub times: Vec<f64>,
    /// Number of grains.
    pub grains: usize,
    /// δv as [samples][grain id][x, y], float32.
    pub field: Vec<f32>,
    /// Largest |δv| component, computed in float64 before rounding.
    pub max_difference: f64,
    /// Sliding contacts of the perturbed copy at each sample.
    pub sliding: Vec<u64>,
    /// Sliding contacts of the unperturbed copy at each sample.
    pub sliding_reference: Vec<u64>,
    /// Positions at the start (by id).
    pub positions: Vec<DVec2>,
    /// State fingerprints of the two copies at the end.
    pub hashes: (u64, u64),
    /// M_s at rest by mobilisation ([`model::mobilised_contacts`]): at the start (both copies),
    /// and at the end of the perturbed and of the unperturbed copy.
    pub mobilised: [u64; 3],
    /// Wall pulses: of the contacts counted in `mobilised[0]`, those that the pulse's mean strain
    /// increment pushes further into sliding ([`model::sliding_drive`] > 0 for a compression
    /// (p_a > 0) or a rarefaction (p_a < 0) along the pulsing wall's normal). 0 for other
    /// perturbations.
    pub pushed_on: u64,
}

/// Runs the paired replay of `base` driven by `drive` for `steps` steps (see the module docs).
pub fn paired_replay(base: &Simulation<D2>, drive: &Drive, perturbation: &Perturbation, amplitude: f64, steps: u64, sample_every: u64) -> Result<PairResult> {
    let sample_every = sample_every.max(1);
    let mut with = base.clone();
    let mut without = base.clone();
    let mut drive_with = drive.clone();
    let mut drive_without = drive.clone();
    perturbation.apply(&mut with, &mut drive_with, amplitude)?;
    perturbation.apply(&mut without, &mut drive_without, 0.0)?;
    let n = base.len();
    let mut out = PairResult { grains: n, positions: super::strain::positions_by_id(&base.grains), ..Default::default() };
    let t0 = base.time;
    let sample = |a: &Simulation<D2>, b: &Simulation<D2>, out: &mut PairResult| {
        out.times.push(a.time - t0);
        let mut row = vec![0.0f32; 2 * n];
        for k in 0..n {
            let id = a.grains.id[k] as usize;
            let kb = if b.grains.id[k] as usize == id { k } else { b.grains.index_of(id as u32).expect("same grains") };
            let d = a.grains.vel[k] - b.grains.vel[kb];
            out.max_difference = out.max_difference.max(d.x.abs()).max(d.y.abs());
            row[2 * id] = d.x as f32;
            row[2 * id + 1] = d.y as f32;
        }
        out.field.extend_from_slice(&row);
        out.sliding.push(a.counters.sliding);
        out.sliding_reference.push(b.counters.sliding);
    };
    // a wall pulse leaves the grains as they are (it arms the drive), so one pass over the
    // contacts gives both counts
    if matches!(perturbation, Perturbation::WallPulse { .. }) && amplitude != 0.0 {
        (out.mobilised[0], out.pushed_on) = model::mobilised_pushed_on(&with, pulse_strain(drive.pulse_wall, amplitude));
    } else {
        out.mobilised[0] = model::mobilised_contacts(&with);
    }
    sample(&with, &without, &mut out);
    grainwave_core::util::in_pool(|| -> Result<()> {
        for s in 1..=steps {
            drive_with.step(&mut with)?;
            drive_without.step(&mut without)?;
            if s % sample_every == 0 {
                sample(&with, &without, &mut out);
            }
        }
        Ok(())
    })?;
    out.hashes = (with.state_hash(), without.state_hash());
    out.mobilised[1] = model::mobilised_contacts(&with);
    out.mobilised[2] = model::mobilised_contacts(&without);
    Ok(out)
}

/// The direction of the mean strain increment of a pulse from wall `wall` ([`model::RIGHT`]:
/// along x; otherwise along y) of amplitude `amplitude`: a displacement gradient, extension
/// positive, so a compressive pulse (p_a > 0) is −e e.
pub fn pulse_strain(wall: usize, amplitude: f64) -> [[f64; 2]; 2] {
    let e = -amplitude.signum();
    if wall == model::RIGHT {
        [[e, 0.0], [0.0, 0.0]]
    } else {
        [[0.0, 0.0], [0.0, e]]
    }
}

/// Id of the grain nearest the centre of the box.
pub fn central_grain(sim: &Simulation<D2>) -> u32 {
    let w = &sim.domain.walls;
    let c = DVec2::new(0.5 * (w[model::LEFT].position.x + w[model::RIGHT].position.x), 0.5 * (w[model::BOTTOM].position.y + w[TOP].position.y));
    let mut best = (f64::INFINITY, 0u32);
    for k in 0..sim.len() {
        let d = (sim.grains.pos[k] - c).length_squared();
        if d < best.0 || (d == best.0 && sim.grains.id[k] < best.1) {
            best = (d, sim.grains.id[k]);
        }
    }
    best.1
}

/// Arrival times and the strip fit of a paired replay.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Arrivals {
    /// Per grain id: distance from the source [engine length].
    pub distance: Vec<f64>,
    /// Per grain id: arrival time by the replay's definition (None: no arrival) [engine time].
    pub time: Vec<Option<f64>>,
    /// The strip fit of `time` (None: too few strips).
    pub fit: Option<StripFit>,
    /// Wall pulses: the strip fit of the SPEC arrival (maximum of |δv_x|).
    pub fit_maximum: Option<StripFit>,
    /// Wall pulses: the strip fit of the first-lobe arrival.
    pub fit_first_lobe: Option<StripFit>,
    /// Wall pulses: the incident amplitude A_inc [engine velocity].
    pub incident: f64,
    /// Wall pulses: the round-off floor of δv [engine velocity] (see [`resolution_floor`]).
    pub floor: f64,
}

/// The smallest velocity difference the float64 state resolves: one unit in the last place of
/// the largest coordinate, ε |x|_max, oscillating at the contact frequency √(K_n/m̄) = v_a/d̄,
/// gives δv ≈ ε |x|_max v_a/d̄. Below it, δv is round-off carried along by the dynamics (it is
/// not proportional to the amplitude, and it runs ahead of the pulse: it is seeded wherever the
/// two replays differ at all). Measured on a 64 × 64 packing (|x|_max ≈ 64 d̄): the early part
/// of δv_x at p_a = 1e−10 is ≈ 7e−13 (engine units), and so is this formula.
pub fn resolution_floor(positions: &[DVec2], u: &Units) -> f64 {
    let x_max = positions.iter().map(|p| p.x.abs().max(p.y.abs())).fold(0.0, f64::max);
    f64::EPSILON * x_max * u.acoustic_velocity / u.mean_diameter
}

/// Arrivals of a paired replay of amplitude `amplitude` under the settings of replay `rc` (arrival
/// definition, lobe threshold, strips, fit range), with v_a from `u`. For a wall pulse the distance is from
/// the pulse wall's position at the start; both arrival definitions are computed (maximum of the
/// δv component along the wall normal, and its first lobe in the direction of the incident
/// motion, sign(p_a) × inward normal) and `rc.arrival` picks the one in `time` and `fit`. For a
/// radius change the distance is from the changed grain and the arrival is the first time |δv|
/// reaches 10 % of its maximum.
pub fn arrivals(result: &PairResult, base: &Simulation<D2>, drive: &Drive, perturbation: &Perturbation, amplitude: f64, rc: &ReplayConfig, u: &Units) -> Arrivals {
    let (strips, fit_range) = (rc.strips, rc.fit_range);
    match perturbation {
        Perturbation::WallPulse { shape, delay, width, .. } => {
            let wall = &base.domain.walls[drive.pulse_wall];
            let component = if wall.normal.x.abs() >= wall.normal.y.abs() { 0 } else { 1 };
            let inward = if component == 0 { wall.normal.x } else { wall.normal.y };
            let distance: Vec<f64> = result.positions.iter().map(|p| wall.distance(*p)).collect();
            let maximum = arrival::arrival_of_maximum(&result.field, result.grains, &result.times, component);
            // the pulse has entered the first strip once it has been emitted (a wavelet lasts
            // about ±6 T around t₀) and a front at v_a/4 has crossed the strip
            let s_max = distance.iter().cloned().fold(0.0, f64::max);
            let near = s_max / strips.max(1) as f64;
            let emitted = delay + if *shape == PulseShape::Wavelet { 6.0 * width } else { 0.0 };
            let until = emitted + 4.0 * near / u.acoustic_velocity;
            let incident = arrival::incident_amplitude(&result.field, result.grains, &result.times, component, &distance, near, until);
            let sign = amplitude.signum() * inward.signum();
            // a lobe must also stand ten times above the round-off floor, or the floor's own
            // fluctuations, which run ahead of the pulse, are taken for it (p_a = 1e−10)
            let floor = resolution_floor(&result.positions, u);
            let threshold = (rc.lobe_threshold * incident).max(10.0 * floor);
            let first_lobe = if incident > 0.0 {
                arrival::arrival_of_first_lobe(&result.field, result.grains, &result.times, component, sign, threshold)
            } else {
                vec![None; result.grains]
            };
            let fit_maximum = arrival::strip_speed(&distance, &maximum, strips, fit_range);
            let fit_first_lobe = arrival::strip_speed(&distance, &first_lobe, strips, fit_range);
            let (time, fit) = match rc.arrival {
                ArrivalDefinition::Maximum => (maximum, fit_maximum.clone()),
                ArrivalDefinition::FirstLobe => (first_lobe, fit_first_lobe.clone()),
            };
            Arrivals { distance, time, fit, fit_maximum, fit_first_lobe, incident, floor }
        }
        Perturbation::Radius { grain } => {
            let c = result.positions[*grain as usize];
            let distance: Vec<f64> = result.positions.iter().map(|p| (*p - c).length()).collect();
            let time = arrival::arrival_of_threshold(&result.field, result.grains, &result.times, 0.1);
            let fit = arrival::strip_speed(&distance, &time, strips, fit_range);
            Arrivals { distance, time, fit, ..Default::default() }
        }
    }
}

/// Resolves the perturbation of replay `rc` for `sim` in units `u`.
pub fn perturbation_of(rc: &ReplayConfig, sim: &Simulation<D2>, u: &Units) -> Option<Perturbation> {
    match rc.modification {
        Modification::WallPulse => {
            let width = rc.width * u.acoustic_time;
            let delay = rc.delay.map(|d| d * u.acoustic_time).unwrap_or(match rc.shape {
                PulseShape::Delta => sim.dt,
                PulseShape::Wavelet => 6.0 * width,
            });
            Some(Perturbation::WallPulse { shape: rc.shape, time_unit: u.time, delay, width })
        }
        Modification::Radius => Some(Perturbation::Radius { grain: central_grain(sim) }),
        _ => None,
    }
}

/// Applies a single modification (velocity scale, friction, wall stop) to `sim` at the start of
/// a replay.
pub fn apply_single(rc: &ReplayConfig, sim: &mut Simulation<D2>, drive: &mut Drive, u: &Units, cfg: &super::config::E2Config) -> Result<()> {
    let material = &cfg.material;
    match rc.modification {
        Modification::VelocityScale => {
            let g = rc.factor;
            sim.grains.vel.iter_mut().for_each(|v| *v *= g);
            sim.grains.omega.iter_mut().for_each(|w| *w *= g);
            for w in sim.domain.walls.iter_mut() {
                w.speed *= g;
                if let WallMotion::Velocity { speed: TimeFunction::Constant { value } } = &mut w.motion {
                    *value *= g;
                }
            }
            sim.refresh_forces()
        }
        Modification::Friction => {
            sim.law = model::grain_law(material, rc.friction, u.acoustic_time);
            sim.refresh_forces()
        }
        Modification::WallStop => {
            let v0 = sim.domain.walls[TOP].speed;
            sim.domain.walls[TOP].motion =
                WallMotion::Velocity { speed: TimeFunction::CosineStop { value: v0, start: sim.time, duration: rc.stop_time * u.acoustic_time } };
            Ok(())
        }
        Modification::TopPiston => {
            // The piston starts at rest. A prescribed-speed wall keeps its last speed in
            // `speed`, and a piston integrates from it: checkpoint 0 (the undeformed state) is
            // taken as the loading starts, with the top wall already at the loading speed
            // ε̇ H, so the piston would carry that speed (and a dashpot load computed with it)
            // into the packing and launch a compression wave of particle velocity ≈ ε̇ H
            // through it before the pulses (KE ≈ ½ M* (ε̇ H)², docs/e2.md, "The state before
            // the top-wall pulses"). A stopped wall (the static states) is at rest already and
            // is left to the bit as it was.
            if sim.domain.walls[TOP].speed != 0.0 {
                let w = &mut sim.domain.walls[TOP];
                w.speed = 0.0;
                // the load of the wall at rest: the absorbing wall's dashpot no longer sees the
                // loading speed
                sim.refresh_forces()?;
            }
            let load = sim.domain.walls[TOP].normal_load();
            sim.domain.walls[TOP].motion = WallMotion::Piston { mass: cfg.preparation.wall_mass * u.total_mass, force: TimeFunction::constant(load) };
            drive.pistons.retain(|(k, _)| *k != TOP);
            drive.pistons.push((TOP, model::PistonLoad::Force(load)));
            sim.refresh_forces()
        }
        Modification::WallPulse | Modification::Radius | Modification::Incremental => Ok(()),
    }
}
