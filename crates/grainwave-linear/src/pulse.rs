//! Pulse propagation set-up (SPEC §5.4): source and detector walls, initial conditions A and B,
//! and the modal sum of the signal.
//!
//! # Source, detector, signal
//!
//! For a wall w let its grain contacts c (grain i, normal stiffness k_c, normal n̂_c from the grain
//! towards the wall) define two free-dof vectors:
//!
//! * the **source** vector s: s_i = Σ_c k_c (−n̂_c) on the translations of i — the force per unit
//!   displacement that a wall raised along its inward normal exerts on the grains touching it;
//! * the **detector** vector c: c_i = Σ_c k_c n̂_c — so that the change of the wall's normal load is
//!   F_sig = cᵀ u = Σ_c k_c (u_i · n̂_c) (the grain displacement toward the wall compresses its wall
//!   spring; rotations and tangential motion do not change the normal load of a flat wall).
//!
//! Both walls stay fixed during propagation. Dofs that are not free (constrained, removed) are
//! skipped.
//!
//! # Initial conditions
//!
//! * **A** ([`InitialCondition::Impulse`], default): u(0) = 0, every grain touching the source wall
//!   receives the impulse p_i = h s_i, i.e. v(0) = h M⁻¹ s, along the wall's inward normal and
//!   proportional to its wall stiffness. h (length × time) is the product of a wall displacement and
//!   the short time it is held: raising the wall by δ for a time τ ≪ 1/ω_max gives exactly this
//!   impulse with h = δτ.
//! * **B** ([`InitialCondition::Displacement`]): the same grains displaced instead of kicked,
//!   u_i(0) = δ s_i / k̄ with k̄ the mean stiffness of the source contacts (a grain with the mean wall
//!   stiffness moves by δ), v(0) = 0.
//!
//! For the 1D chain of SPEC §5.6 (one grain on the source wall, spring K, mass m) A with
//! h = c m/K gives u̇₁(0) = c and B with δ = ℓ gives u₁(0) = ℓ.
//!
//! # Modal sum
//!
//! With mass-normalized modes v_n (D v_n = ω_n² M v_n), the solution of M ü = −D u is
//! u(t) = Σ_n v_n [α_n cos ω_n t + β_n sin(ω_n t)/ω_n], α_n = v_nᵀ M u(0), β_n = v_nᵀ M v(0), so
//!
//! ```text
//! F_sig(t) = Σ_n b_n [α_n cos ω_n t + β_n sin(ω_n t)/ω_n],      b_n = cᵀ v_n
//! ```
//!
//! i.e. F_sig = Σ a_n b_n sin ω_n t for A (a_n = β_n/ω_n = h v_nᵀ s/ω_n) and Σ a_n b_n cos ω_n t for
//! B (a_n = α_n). Zero modes (ω_n² ≤ 1e-12 max ω², e.g. rattlers) use the limit sin(ωt)/ω → t.

use crate::contact::Partner;
use crate::dynamical::{DynamicalMatrix, LinearSystem};
use crate::error::{LinearError, Result};
use crate::linalg::eigen::Modes;
use grainwave_core::dim::{Dim, VectorOps};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Initial condition of a pulse (SPEC §5.4).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum InitialCondition {
    /// A: impulse p_i = h s_i on the grains touching the source wall (h: length × time).
    Impulse {
        /// Strength h = wall displacement × duration.
        strength: f64,
    },
    /// B: displacement u_i = δ s_i / k̄ of the grains touching the source wall.
    Displacement {
        /// Displacement δ of a grain with the mean wall stiffness.
        amplitude: f64,
    },
}

impl Default for InitialCondition {
    fn default() -> Self {
        InitialCondition::Impulse { strength: 1.0 }
    }
}

/// Which walls emit and receive a pulse.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PulseSetup {
    /// Index of the source wall in the snapshot's domain (E1: the bottom wall).
    pub source_wall: u32,
    /// Index of the detector wall (E1: the top wall).
    pub detector_wall: u32,
    /// Initial condition (default A with h = 1).
    #[serde(default)]
    pub initial_condition: InitialCondition,
}

/// A vector on the free dofs attached to one wall.
#[derive(Clone, Debug)]
pub struct WallVector {
    /// The vector over the free dofs.
    pub vector: Vec<f64>,
    /// Storage indices of the grains touching the wall (free ones only).
    pub grains: Vec<usize>,
    /// Sum of the normal stiffnesses of those contacts.
    pub stiffness_sum: f64,
}

/// Positions and velocities over the free dofs.
#[derive(Clone, Debug, PartialEq)]
pub struct InitialState {
    /// u(0).
    pub displacement: Vec<f64>,
    /// u̇(0).
    pub velocity: Vec<f64>,
}

/// Builds the source (`sign` = −1: along the inward normal) or detector (`sign` = +1: towards the
/// wall) vector of wall `wall`.
fn wall_vector<D: Dim>(dm: &DynamicalMatrix<D>, system: &LinearSystem, wall: u32, sign: f64) -> Result<WallVector> {
    let walls = &dm.domain().walls;
    let w = walls.get(wall as usize).ok_or(LinearError::UnknownWall { index: wall, walls: walls.len() })?;
    let layout = dm.layout();
    let mut vector = vec![0.0; system.dofs()];
    let mut grains = Vec::new();
    let mut stiffness_sum = 0.0;
    for c in dm.contacts() {
        if c.j != Partner::Wall(wall) {
            continue;
        }
        let mut any = false;
        for axis in 0..D::D {
            if let Some(k) = system.free_index(layout.translation(c.i, axis)) {
                vector[k] += sign * c.normal_stiffness * c.normal.get(axis);
                any = true;
            }
        }
        if any {
            grains.push(c.i);
            stiffness_sum += c.normal_stiffness;
        }
    }
    if grains.is_empty() {
        return Err(LinearError::NoWallContacts { wall: w.name.clone(), index: wall });
    }
    Ok(WallVector { vector, grains, stiffness_sum })
}

/// Source vector s of wall `wall` (see the module docs).
pub fn source_vector<D: Dim>(dm: &DynamicalMatrix<D>, system: &LinearSystem, wall: u32) -> Result<WallVector> {
    wall_vector(dm, system, wall, -1.0)
}

/// Detector vector c of wall `wall`: F_sig = cᵀ u.
pub fn detector_vector<D: Dim>(dm: &DynamicalMatrix<D>, system: &LinearSystem, wall: u32) -> Result<WallVector> {
    wall_vector(dm, system, wall, 1.0)
}

impl InitialCondition {
    /// The initial state of this condition for source vector `source` on `system`.
    pub fn state(&self, system: &LinearSystem, source: &WallVector) -> Result<InitialState> {
        let n = system.dofs();
        LinearError::check_len("source vector", n, source.vector.len())?;
        let mass = system.mass();
        match *self {
            InitialCondition::Impulse { strength } => {
                if !strength.is_finite() {
                    return Err(LinearError::invalid("initial_condition.strength", strength, "a finite number"));
                }
                Ok(InitialState { displacement: vec![0.0; n], velocity: source.vector.iter().zip(mass).map(|(s, m)| strength * s / m).collect() })
            }
            InitialCondition::Displacement { amplitude } => {
                if !amplitude.is_finite() {
                    return Err(LinearError::invalid("initial_condition.amplitude", amplitude, "a finite number"));
                }
                let mean = source.stiffness_sum / source.grains.len() as f64;
                Ok(InitialState { displacement: source.vector.iter().map(|s| amplitude * s / mean).collect(), velocity: vec![0.0; n] })
            }
        }
    }
}

/// The signal of a pulse as a sum over modes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModalSignal {
    /// ω_n.
    pub omega: Vec<f64>,
    /// Detector couplings b_n = cᵀ v_n.
    pub coupling: Vec<f64>,
    /// b_n α_n: amplitudes of cos ω_n t.
    pub cos_amplitude: Vec<f64>,
    /// b_n β_n/ω_n: amplitudes of sin ω_n t (zero modes: the coefficient of t).
    pub sin_amplitude: Vec<f64>,
    /// Mode n is a zero mode (ω_n² ≤ 1e-12 max ω²).
    pub zero_mode: Vec<bool>,
}

/// Relative threshold below which a mode counts as a zero mode in the modal sum.
pub const ZERO_MODE_TOLERANCE: f64 = 1e-12;

impl ModalSignal {
    /// Modal decomposition of the signal cᵀ u(t) for initial state `state`.
    pub fn new(modes: &Modes, state: &InitialState, detector: &[f64]) -> Result<ModalSignal> {
        LinearError::check_len("detector vector", modes.len(), detector.len())?;
        let alpha = modes.project(&state.displacement)?;
        let beta = modes.project(&state.velocity)?;
        let b = modes.transpose_times(detector);
        let w2 = modes.omega_squared();
        let scale = w2.iter().fold(0.0_f64, |a, &x| a.max(x.abs()));
        let zero_mode: Vec<bool> = w2.iter().map(|&x| x <= ZERO_MODE_TOLERANCE * scale).collect();
        let omega = modes.frequencies();
        let cos_amplitude = (0..modes.len()).map(|n| b[n] * alpha[n]).collect();
        let sin_amplitude = (0..modes.len()).map(|n| if zero_mode[n] { b[n] * beta[n] } else { b[n] * beta[n] / omega[n] }).collect();
        Ok(ModalSignal { omega, coupling: b, cos_amplitude, sin_amplitude, zero_mode })
    }

    /// F_sig(t).
    pub fn eval(&self, t: f64) -> f64 {
        let mut s = 0.0;
        for n in 0..self.omega.len() {
            if self.zero_mode[n] {
                s += self.cos_amplitude[n] + self.sin_amplitude[n] * t;
            } else {
                let (sn, cs) = (self.omega[n] * t).sin_cos();
                s += self.cos_amplitude[n] * cs + self.sin_amplitude[n] * sn;
            }
        }
        s
    }

    /// F_sig on a time grid (parallel over times).
    pub fn eval_many(&self, times: &[f64]) -> Vec<f64> {
        times.par_iter().with_min_len(16).map(|&t| self.eval(t)).collect()
    }

    /// Mode contributions a_n b_n of SPEC §5.4: the sine amplitudes for an impulse (A), the cosine
    /// amplitudes for a displacement (B).
    pub fn contributions(&self, condition: &InitialCondition) -> &[f64] {
        match condition {
            InitialCondition::Impulse { .. } => &self.sin_amplitude,
            InitialCondition::Displacement { .. } => &self.cos_amplitude,
        }
    }
}

/// Everything a modal pulse analysis reports (SPEC §5.4): spectrum, mode contributions, signal.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModalPulse {
    /// ω_n² of every mode (increasing).
    pub omega_squared: Vec<f64>,
    /// Participation ratios P_n.
    pub participation: Vec<f64>,
    /// Mode contributions a_n b_n (sine amplitudes for A, cosine amplitudes for B).
    pub contributions: Vec<f64>,
    /// Detector couplings b_n.
    pub coupling: Vec<f64>,
    /// The times of the signal.
    pub times: Vec<f64>,
    /// F_sig at those times.
    pub signal: Vec<f64>,
    /// Number of free dofs.
    pub dofs: usize,
}

/// Modal pulse analysis of a snapshot in one call: D and M with `assembly`, all grains free and the
/// walls fixed, all modes, initial condition and walls of `setup`, F_sig on `times`.
pub fn modal_pulse<D: Dim>(
    snapshot: &grainwave_core::snapshot::Snapshot<D>,
    assembly: &crate::dynamical::AssemblyOptions,
    eigen: &crate::linalg::eigen::EigenOptions,
    setup: &PulseSetup,
    times: &[f64],
) -> Result<ModalPulse> {
    let dm = DynamicalMatrix::assemble(snapshot, assembly)?;
    let system = dm.free_system(&crate::dofs::Constraints::new(), crate::dynamical::ZeroRows::Keep)?;
    let modes = Modes::compute(&system, eigen)?;
    let source = source_vector(&dm, &system, setup.source_wall)?;
    let detector = detector_vector(&dm, &system, setup.detector_wall)?;
    let state = setup.initial_condition.state(&system, &source)?;
    let modal = ModalSignal::new(&modes, &state, &detector.vector)?;
    Ok(ModalPulse {
        omega_squared: modes.omega_squared().to_vec(),
        participation: modes.participation().to_vec(),
        contributions: modal.contributions(&setup.initial_condition).to_vec(),
        coupling: modal.coupling.clone(),
        times: times.to_vec(),
        signal: modal.eval_many(times),
        dofs: system.dofs(),
    })
}

/// Direct-propagation pulse analysis of a snapshot in one call (sparse D, all grains free, walls
/// fixed): F_sig on `times`.
pub fn direct_pulse<D: Dim>(
    snapshot: &grainwave_core::snapshot::Snapshot<D>,
    assembly: &crate::dynamical::AssemblyOptions,
    propagation: &crate::propagation::PropagationOptions,
    setup: &PulseSetup,
    times: &[f64],
) -> Result<crate::propagation::PropagatedSignal> {
    let dm = DynamicalMatrix::assemble(snapshot, assembly)?;
    let system = dm.free_system(&crate::dofs::Constraints::new(), crate::dynamical::ZeroRows::Keep)?;
    let source = source_vector(&dm, &system, setup.source_wall)?;
    let detector = detector_vector(&dm, &system, setup.detector_wall)?;
    let state = setup.initial_condition.state(&system, &source)?;
    crate::propagation::propagate_signal(&system, system.mass(), &state, &detector.vector, times, propagation)
}
