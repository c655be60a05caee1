//! Direct propagation (SPEC §5.4): M ü = −D u + f_c integrated in time with a sparse (or
//! matrix-free) D, for systems too large for dense eigensolvers.
//!
//! The time step follows from the largest frequency: dt_max = 2π / (ω_max · `steps_per_period`),
//! with ω_max² estimated by Lanczos iteration and capped by the Gershgorin bound
//! ([`crate::linalg::lanczos`]). Each requested output time t_k is reached exactly with
//! ⌈(t_k − t)/dt_max⌉ equal steps, so outputs need not be multiples of a fixed step. The schemes
//! ([`Scheme`]) are symplectic: the discrete energy is conserved and the only error is a phase error
//! (the default 4th-order scheme at 20 steps per shortest period: 1.5e-7 relative at ω_max,
//! ~6e-10 at ω_max/4; velocity Verlet at 60 steps per period: 4.6e-4 at ω_max).
//!
//! f_c = −D_fc u_c is the constant load of non-zero imposed displacements (zero in pulse problems:
//! walls fixed, no other constraint).
//!
//! ```
//! use grainwave_linear::prelude::*;
//! # use grainwave_linear::reference::ChainSpec;
//! // a chain of 20 grains between walls, kicked at one end (SPEC §5.6)
//! let chain = ChainSpec { grains: 20, ..ChainSpec::default() };
//! let snap = chain.build().unwrap().snapshot();
//! let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
//! let system = dm.free_system(&chain.constraints(), ZeroRows::Keep).unwrap();
//! let source = source_vector(&dm, &system, 0).unwrap();
//! let detector = detector_vector(&dm, &system, 1).unwrap();
//! let state = chain.impulse().state(&system, &source).unwrap();
//! let times: Vec<f64> = (0..50).map(|k| k as f64).collect();
//! let direct = propagate_signal(&system, system.mass(), &state, &detector.vector, &times, &PropagationOptions::default()).unwrap();
//! let exact: Vec<f64> = times.iter().map(|&t| chain.closed_form_signal(t, &chain.impulse())).collect();
//! for (a, b) in direct.values.iter().zip(&exact) {
//!     assert!((a - b).abs() < 1e-6 * chain.stiffness * chain.spacing);
//! }
//! ```

use crate::dynamical::{DynamicalMatrix, LinearSystem};
use crate::error::{LinearError, Result};
use crate::linalg::lanczos::{largest_eigenvalue, SpectralBound};
use crate::linalg::symplectic::Scheme;
use crate::pulse::InitialState;
use grainwave_core::dim::Dim;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// An operator y = D x on the free dofs of a system.
pub trait StiffnessOperator: Sync {
    /// Number of free dofs.
    fn dim(&self) -> usize;
    /// y = D x.
    fn apply(&self, x: &[f64], y: &mut [f64]);
    /// Gershgorin bound of λ_max(M⁻¹D) for masses `mass`, when cheap to compute.
    fn gershgorin(&self) -> Option<f64> {
        None
    }
}

impl StiffnessOperator for LinearSystem {
    fn dim(&self) -> usize {
        self.dofs()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        LinearSystem::apply(self, x, y)
    }
    fn gershgorin(&self) -> Option<f64> {
        Some(self.gershgorin_bound())
    }
}

/// The matrix-free operator of a [`DynamicalMatrix`] restricted to the free dofs of a
/// [`LinearSystem`] built from it (constrained dofs held at zero): D is never stored, every
/// product re-evaluates the contacts.
#[derive(Clone, Copy, Debug)]
pub struct MatrixFree<'a, D: Dim> {
    /// The packing's contacts.
    pub matrix: &'a DynamicalMatrix<D>,
    /// The free dofs.
    pub system: &'a LinearSystem,
}

impl<D: Dim> StiffnessOperator for MatrixFree<'_, D> {
    fn dim(&self) -> usize {
        self.system.dofs()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let total = self.matrix.dofs();
        let mut full = vec![0.0; total];
        let free = self.system.free_dofs();
        for (k, &r) in free.iter().enumerate() {
            full[r] = x[k];
        }
        let mut out = vec![0.0; total];
        self.matrix.apply(&full, &mut out);
        for (k, &r) in free.iter().enumerate() {
            y[k] = out[r];
        }
    }
}

/// Options of direct propagation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PropagationOptions {
    /// Integration scheme (default the 4th-order Blanes–Moan scheme).
    pub scheme: Scheme,
    /// Steps per shortest period 2π/ω_max (default 20; must keep ω_max dt inside the scheme's
    /// stability interval).
    pub steps_per_period: f64,
    /// Lanczos steps for the ω_max estimate (default 60).
    pub lanczos_iterations: usize,
    /// Use this ω_max instead of estimating it.
    pub omega_max: Option<f64>,
    /// Seed of the Lanczos start vector.
    pub seed: u64,
}

impl Default for PropagationOptions {
    fn default() -> Self {
        PropagationOptions { scheme: Scheme::BlanesMoan4, steps_per_period: 20.0, lanczos_iterations: 60, omega_max: None, seed: 1 }
    }
}

/// Time integrator of M ü = −D u + f_c.
pub struct Propagator<'a> {
    op: &'a dyn StiffnessOperator,
    inv_mass: Vec<f64>,
    load: Option<Vec<f64>>,
    u: Vec<f64>,
    v: Vec<f64>,
    acc: Vec<f64>,
    work: Vec<f64>,
    time: f64,
    steps: u64,
    dt_max: f64,
    kicks: Vec<f64>,
    drifts: Vec<f64>,
    bound: SpectralBound,
}

impl<'a> Propagator<'a> {
    /// Starts at t = 0 from `state`; `mass` is the diagonal of M over the free dofs; `load` an
    /// optional constant load f_c (e.g. [`LinearSystem::constraint_load`]).
    pub fn new(op: &'a dyn StiffnessOperator, mass: &[f64], state: &InitialState, load: Option<&[f64]>, options: &PropagationOptions) -> Result<Self> {
        let n = op.dim();
        LinearError::check_len("mass", n, mass.len())?;
        LinearError::check_len("initial displacement", n, state.displacement.len())?;
        LinearError::check_len("initial velocity", n, state.velocity.len())?;
        if let Some(f) = load {
            LinearError::check_len("load", n, f.len())?;
        }
        if n == 0 {
            return Err(LinearError::NoFreeDofs);
        }
        if !(options.steps_per_period.is_finite() && options.steps_per_period > 0.0) {
            return Err(LinearError::invalid("propagation.steps_per_period", options.steps_per_period, "a number > 0"));
        }
        let bound = match options.omega_max {
            Some(w) => {
                if !(w.is_finite() && w > 0.0) {
                    return Err(LinearError::invalid("propagation.omega_max", w, "a frequency > 0"));
                }
                SpectralBound { ritz: w * w, residual: 0.0, gershgorin: None, estimate: w * w, iterations: 0 }
            }
            None => largest_eigenvalue(&|x, y| op.apply(x, y), mass, options.lanczos_iterations, op.gershgorin(), options.seed),
        };
        let omega_max = bound.estimate.max(0.0).sqrt();
        let dt_max = if omega_max > 0.0 { 2.0 * PI / (omega_max * options.steps_per_period) } else { f64::INFINITY };
        let limit = options.scheme.stability_limit();
        if omega_max * dt_max >= limit {
            return Err(LinearError::invalid(
                "propagation.steps_per_period",
                options.steps_per_period,
                format!("more than {:.3} steps per shortest period for the {:?} scheme (stability limit ω dt < {limit:.3})", 2.0 * PI / limit, options.scheme),
            ));
        }
        let (kicks, drifts) = options.scheme.coefficients();
        let mut p = Propagator {
            op,
            inv_mass: mass.iter().map(|m| 1.0 / m).collect(),
            load: load.filter(|f| f.iter().any(|&x| x != 0.0)).map(|f| f.to_vec()),
            u: state.displacement.clone(),
            v: state.velocity.clone(),
            acc: vec![0.0; n],
            work: vec![0.0; n],
            time: 0.0,
            steps: 0,
            dt_max,
            kicks,
            drifts,
            bound,
        };
        p.update_acceleration();
        Ok(p)
    }

    fn update_acceleration(&mut self) {
        self.op.apply(&self.u, &mut self.work);
        let (acc, work, inv) = (&mut self.acc, &self.work, &self.inv_mass);
        match &self.load {
            None => acc.par_iter_mut().zip(work.par_iter()).zip(inv.par_iter()).with_min_len(4096).for_each(|((a, w), im)| *a = -w * im),
            Some(f) => acc
                .par_iter_mut()
                .zip(work.par_iter())
                .zip(inv.par_iter().zip(f.par_iter()))
                .with_min_len(4096)
                .for_each(|((a, w), (im, f))| *a = (f - w) * im),
        }
    }

    fn step(&mut self, h: f64) {
        for k in 0..self.kicks.len() {
            let b = self.kicks[k] * h;
            self.v.par_iter_mut().zip(self.acc.par_iter()).with_min_len(4096).for_each(|(v, a)| *v += b * a);
            if k < self.drifts.len() {
                let a = self.drifts[k] * h;
                self.u.par_iter_mut().zip(self.v.par_iter()).with_min_len(4096).for_each(|(u, v)| *u += a * v);
                self.update_acceleration();
            }
        }
        self.steps += 1;
    }

    /// Advances to time `t` (≥ the current time) in equal steps no longer than the maximal step.
    pub fn advance_to(&mut self, t: f64) -> Result<()> {
        if !(t >= self.time) || !t.is_finite() {
            return Err(LinearError::invalid("time", t, format!("a finite time ≥ the current time {}", self.time)));
        }
        let span = t - self.time;
        if span == 0.0 {
            return Ok(());
        }
        let n = ((span / self.dt_max) * (1.0 - 1e-12)).ceil().max(1.0) as u64;
        let h = span / n as f64;
        for _ in 0..n {
            self.step(h);
        }
        self.time = t;
        let check: f64 = self.u.iter().step_by(97).chain(self.v.iter().step_by(97)).sum();
        if !check.is_finite() {
            return Err(LinearError::Unstable { time: t, step: self.steps, dt: h });
        }
        Ok(())
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Displacements u(t) over the free dofs.
    pub fn displacement(&self) -> &[f64] {
        &self.u
    }

    /// Velocities u̇(t) over the free dofs.
    pub fn velocity(&self) -> &[f64] {
        &self.v
    }

    /// Steps done.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Largest step used, 2π/(ω_max · steps_per_period).
    pub fn max_step(&self) -> f64 {
        self.dt_max
    }

    /// The ω²_max estimate behind the step.
    pub fn spectral_bound(&self) -> &SpectralBound {
        &self.bound
    }

    /// Energy ½ v M v + ½ u D u (− f_c·u): conserved up to the scheme's bounded oscillation.
    pub fn energy(&mut self) -> f64 {
        self.op.apply(&self.u, &mut self.work);
        let mut e = 0.0;
        for k in 0..self.u.len() {
            e += 0.5 * self.v[k] * self.v[k] / self.inv_mass[k] + 0.5 * self.u[k] * self.work[k];
            if let Some(f) = &self.load {
                e -= f[k] * self.u[k];
            }
        }
        e
    }
}

/// Signal of a direct propagation.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PropagatedSignal {
    /// Output times.
    pub times: Vec<f64>,
    /// cᵀ u at each time.
    pub values: Vec<f64>,
    /// Steps done.
    pub steps: u64,
    /// Largest step.
    pub max_step: f64,
    /// The ω²_max estimate.
    pub bound: SpectralBound,
}

/// Propagates `state` and records the signal cᵀ u(t) (`detector` = c) at the increasing `times`.
pub fn propagate_signal(op: &dyn StiffnessOperator, mass: &[f64], state: &InitialState, detector: &[f64], times: &[f64], options: &PropagationOptions) -> Result<PropagatedSignal> {
    LinearError::check_len("detector vector", op.dim(), detector.len())?;
    let mut p = Propagator::new(op, mass, state, None, options)?;
    let mut values = Vec::with_capacity(times.len());
    for &t in times {
        p.advance_to(t)?;
        values.push(p.displacement().iter().zip(detector).map(|(a, b)| a * b).sum());
    }
    Ok(PropagatedSignal { times: times.to_vec(), values, steps: p.steps(), max_step: p.max_step(), bound: *p.spectral_bound() })
}
