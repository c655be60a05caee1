//! Incremental (piecewise-linear) propagation: the exact small-amplitude limit of a pulse through
//! a packing whose contacts sit at the Coulomb limit.
//!
//! # The branch rule
//!
//! Around a static state every contact is linearized as in [`crate::contact`] (normal k_n,
//! tangential k_t, rolling k_r, lever arms, normal n̂ fixed), except that a contact whose friction
//! is fully mobilised,
//!
//! ```text
//! |F_t| ≥ (1 − tol) μ F_n,  F_n > 0,  |F_t| > 0          (tol = 1e−6, the E2 "mobilised" test)
//! ```
//!
//! keeps the one-sided Coulomb cone. Write s = F_t/|F_t| for the direction of its tangential force
//! on i, ΔF_n = −k_n Δ·n̂ for the normal force increment (Δ the relative contact-point
//! displacement of j with respect to i) and ΔF_t for the tangential force increment on i. To first
//! order the cone |F_t + ΔF_t| ≤ μ (F_n + ΔF_n) is the half-space
//!
//! ```text
//! d = μ ΔF_n − s·ΔF_t ≥ 0                    (the incremental distance to the cone)
//! ```
//!
//! and the engine's law (trial force F_t + k_t δΔ_t, capped at μ F_n, spring reset to the capped
//! force) becomes, per time step with relative tangential displacement increment δΔ_t:
//!
//! ```text
//! trial   ΔF_t* = ΔF_t + k_t δΔ_t,     d* = μ ΔF_n − s·ΔF_t*
//! stick   d* ≥ 0:  ΔF_t ← ΔF_t*                         (k_t; the contact unloads or stays inside)
//! slip    d* < 0:  ΔF_t ← ΔF_t* + d* s                  (s·ΔF_t = μ ΔF_n: no stiffness along s)
//! ```
//!
//! The component of ΔF_t across s (3D) keeps k_t on both branches (the cone's surface is flat
//! to first order across s). The state (ΔF_t and the displacement Δ it was built from) scales
//! with the pulse, so the whole response is **positively homogeneous of degree one** in the
//! amplitude: amplitude λ > 0 gives λ × the response of amplitude 1, while −1 gives a different
//! response wherever a contact at the limit is pushed on by one sign and released by the other.
//! Amplitudes +1 and −1 are thus the exact p_a → 0⁺ and 0⁻ limits of the engine's law. A power of
//! two scales every floating-point operation exactly, so the responses to 1 and 2 differ by the
//! factor 2 bit for bit.
//!
//! Rolling resistance at its own cap |M_r| ≥ (1 − tol) μ_r R* F_n gets the same rule with the
//! rolling torque (d_r = μ_r R* ΔF_n − s_r·ΔM_r, slip: no rolling stiffness along s_r), unless
//! [`IncrementalOptions::rolling_cap`] is off (then k_r on both branches).
//!
//! # What is exact and what is not
//!
//! Exact (to first order in the amplitude): the stiffnesses, the branch switching, the lever arms
//! coupling rotations. Left out, as in the other linear propagations of this crate: the geometric
//! (pre-stress) terms, and contacts opening or closing — a contact with F_n > 0 cannot open under
//! an infinitesimal pulse, so every contact of the state is kept bilateral (the counts of nearly
//! unloaded contacts, for which a finite pulse opens them, are in [`StateCounts`]). Damping:
//! contact dashpots are left out (the conservative network); the constant dashpots of walls
//! (absorbing walls) act on the normal velocity of the grains touching them when
//! [`IncrementalOptions::wall_damping`] is on.
//!
//! # Integration
//!
//! Velocity Verlet, matrix-free, one contact at a time: half kick, drift, contact forces with the
//! branch update (evaluated once per step, after the drift), half kick. The step is
//! 2π/(ω_max · `steps_per_period`) with ω_max² bounded by Gershgorin on the all-stick
//! network (the slip branch only lowers the stiffness). A wall can be a piston
//! ([`Piston`]): a rigid body of mass M_w moving along its inward normal, driven by the contact
//! forces (its constant external load cancels in the increment). Contact forces are computed in
//! parallel and summed per grain in a fixed order: the result does not depend on the number of
//! threads.

use crate::contact::{LinearContact, Partner};
use crate::dynamical::{AssemblyOptions, DynamicalMatrix, PreStress, Rattlers, SlidingContacts};
use crate::error::{LinearError, Result};
use grainwave_core::contact::{NormalDamping, Rolling};
use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::snapshot::Snapshot;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Default relative tolerance of the mobilisation test |F_t| ≥ (1 − tol) μ F_n.
pub const DEFAULT_MOBILISATION_TOLERANCE: f64 = 1e-6;

/// Which branch the contacts at the Coulomb limit follow.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BranchRule {
    /// The incremental rule (default): slip while pushed on, stick once unloaded.
    #[default]
    Incremental,
    /// Every contact sticks (k_t): the bilateral network of [`SlidingContacts::Stick`].
    Stick,
    /// Contacts at the limit have no tangential (rolling) stiffness at all: the bilateral
    /// network of [`SlidingContacts::Free`] on the mobilised contacts.
    Free,
    /// Contacts at the limit always follow the slip branch, s·ΔF_t = μ ΔF_n, in both directions
    /// (a bilateral, non-symmetric network: the slip branch without its unloading).
    Slip,
}

impl BranchRule {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            BranchRule::Incremental => "incremental",
            BranchRule::Stick => "stick",
            BranchRule::Free => "free",
            BranchRule::Slip => "slip",
        }
    }
}

/// Options of [`IncrementalPropagator`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IncrementalOptions {
    /// Branch rule of the contacts at the limit (default incremental).
    pub branches: BranchRule,
    /// A contact is at the Coulomb limit when |F_t| ≥ (1 − tol) μ F_n (dimensionless, in [0, 1);
    /// default 1e−6).
    pub mobilisation_tolerance: f64,
    /// Apply the two-branch rule to rolling torques at their cap μ_r R* F_n (default true).
    pub rolling_cap: bool,
    /// Constant wall dashpots act on the grains touching such walls (default true).
    pub wall_damping: bool,
    /// Velocity Verlet steps per shortest period 2π/ω_max (default 50; > π for stability).
    pub steps_per_period: f64,
}

impl Default for IncrementalOptions {
    fn default() -> Self {
        IncrementalOptions { branches: BranchRule::Incremental, mobilisation_tolerance: DEFAULT_MOBILISATION_TOLERANCE, rolling_cap: true, wall_damping: true, steps_per_period: 50.0 }
    }
}

impl IncrementalOptions {
    /// Checks the ranges; the error names the key, the value and what is allowed.
    pub fn validate(&self) -> Result<()> {
        let t = self.mobilisation_tolerance;
        if !(t.is_finite() && (0.0..1.0).contains(&t)) {
            return Err(LinearError::invalid("incremental.mobilisation_tolerance", t, "a number in [0, 1)"));
        }
        if !(self.steps_per_period.is_finite() && self.steps_per_period > PI) {
            return Err(LinearError::invalid("incremental.steps_per_period", self.steps_per_period, "a number > π (velocity Verlet is stable for ω dt < 2)"));
        }
        Ok(())
    }
}

/// A wall that moves as a rigid piston of mass `mass` along its inward normal.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Piston {
    /// Wall index in the snapshot's domain.
    pub wall: u32,
    /// Mass M_w of the piston.
    pub mass: f64,
}

/// Contacts of the state by kind (grain–grain and grain–wall together unless said).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StateCounts {
    /// All linearized contacts.
    pub contacts: usize,
    /// Contacts at the Coulomb limit (two-branch tangential rule).
    pub at_limit: usize,
    /// Contacts at the rolling cap (two-branch rolling rule; 0 when the rule is off).
    pub at_rolling_cap: usize,
    /// Contacts with F_n < 1e−6 ⟨F_n⟩.
    pub nearly_open_1e6: usize,
    /// Contacts with F_n < 1e−3 ⟨F_n⟩.
    pub nearly_open_1e3: usize,
    /// Mean normal force ⟨F_n⟩ over all contacts [force].
    pub mean_normal_force: f64,
    /// Contacts with F_n = 0 and F_t = 0 that pass the mobilisation test trivially: kept sticking.
    pub unloaded: usize,
}

/// Branch history of one contact at the limit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BranchHistory {
    /// Index of the contact in [`IncrementalPropagator::contacts`].
    pub contact: usize,
    /// Steps spent on the slip branch.
    pub slip_steps: u64,
    /// Number of branch switches (stick → slip or slip → stick).
    pub switches: u64,
    /// Time of the first step on the slip branch (None: never slipped).
    pub first_slip: Option<f64>,
    /// Time of the last switch (None: never switched).
    pub last_switch: Option<f64>,
    /// On the slip branch at the last step.
    pub slipping: bool,
}

/// The constants of the two-branch rule of one contact.
#[derive(Clone, Copy, Debug)]
pub struct CoulombLimit<D: Dim> {
    /// Direction s of F_t on i (ignored when `mu` = 0).
    pub s: D::Vector,
    /// μ; 0 when the contact is not at the limit (it always sticks).
    pub mu: f64,
    /// Direction s_r of the rolling torque on i (ignored when `mu_r` = 0).
    pub s_r: D::AngVector,
    /// μ_r R* [length]; 0 when not at the rolling cap.
    pub mu_r: f64,
    /// Constant wall dashpot γ_w acting on the normal velocity of i [force/velocity] (0: none).
    pub gamma: f64,
}

impl<D: Dim> CoulombLimit<D> {
    /// A contact that always sticks, without dashpot.
    pub const STICK: CoulombLimit<D> = CoulombLimit { s: D::Vector::ZERO, mu: 0.0, s_r: D::AngVector::ZERO, mu_r: 0.0, gamma: 0.0 };
}

/// The incremental state of one contact (zero at the static state).
#[derive(Clone, Copy, Debug)]
pub struct IncrementState<D: Dim> {
    /// Tangential force increment ΔF_t on i (spring part) [force].
    pub df_t: D::Vector,
    /// Tangential part of Δ at the last evaluation [length].
    pub delta_t: D::Vector,
    /// Rolling torque increment ΔM_r on i [force·length].
    pub dm_r: D::AngVector,
    /// Relative rolling rotation at the last evaluation.
    pub theta_r: D::AngVector,
    /// Tangential branch: slipping at the last evaluation.
    pub slipping: bool,
    /// Rolling branch: slipping at the last evaluation.
    pub rolling_slipping: bool,
}

impl<D: Dim> IncrementState<D> {
    /// The static state: no increment, sticking.
    pub const ZERO: IncrementState<D> =
        IncrementState { df_t: D::Vector::ZERO, delta_t: D::Vector::ZERO, dm_r: D::AngVector::ZERO, theta_r: D::AngVector::ZERO, slipping: false, rolling_slipping: false };
}

/// Load increments of one contact: force and torque on i, torque on j (the force on j, or on the
/// wall, is −`force_i`).
#[derive(Clone, Copy, Debug)]
pub struct ContactLoads<D: Dim> {
    /// Force increment on i.
    pub force_i: D::Vector,
    /// Torque increment on i.
    pub torque_i: D::AngVector,
    /// Torque increment on j.
    pub torque_j: D::AngVector,
}

/// Velocity Verlet integrator of the incremental network (see the module docs).
pub struct IncrementalPropagator<D: Dim> {
    contacts: Vec<LinearContact<D>>,
    limits: Vec<CoulombLimit<D>>,
    states: Vec<IncrementState<D>>,
    history: Vec<BranchHistory>,
    adjacency_start: Vec<u32>,
    adjacency: Vec<u32>,
    p: usize,
    inv_mass: Vec<f64>,
    piston: Option<(Piston, D::Vector)>,
    u: Vec<f64>,
    v: Vec<f64>,
    acc: Vec<f64>,
    q: f64,
    qdot: f64,
    qacc: f64,
    time: f64,
    steps: u64,
    dt_max: f64,
    counts: StateCounts,
    rule: BranchRule,
}

impl<D: Dim> IncrementalPropagator<D> {
    /// The network of the static state `snapshot` (every grain kept; walls fixed except
    /// `piston`), at rest.
    pub fn new(snapshot: &Snapshot<D>, piston: Option<Piston>, options: &IncrementalOptions) -> Result<Self> {
        options.validate()?;
        let assembly = AssemblyOptions {
            prestress: PreStress::None,
            rattlers: Rattlers::Keep,
            rattler_min_contacts: None,
            sliding: SlidingContacts::Stick,
            rolling: true,
        };
        let dm = DynamicalMatrix::assemble(snapshot, &assembly)?;
        let piston = match piston {
            None => None,
            Some(pc) => {
                let wall = snapshot.domain.walls.get(pc.wall as usize).ok_or(LinearError::UnknownWall { index: pc.wall, walls: snapshot.domain.walls.len() })?;
                if !(pc.mass.is_finite() && pc.mass > 0.0) {
                    return Err(LinearError::invalid("piston.mass", pc.mass, "a finite mass > 0"));
                }
                Some((pc, wall.normal / wall.normal.norm()))
            }
        };
        let tol = options.mobilisation_tolerance;
        let mean_fn = dm.contacts().iter().map(|c| c.normal_force).sum::<f64>() / dm.contacts().len().max(1) as f64;
        let mut counts = StateCounts { contacts: dm.contacts().len(), mean_normal_force: mean_fn, ..Default::default() };
        let radii = dm.radii();
        let mut limits = Vec::with_capacity(dm.contacts().len());
        for (k, c) in dm.contacts().iter().enumerate() {
            // rattlers are kept: the k-th linearized contact is the k-th record
            let rec = &snapshot.contacts[k];
            let law = match c.j {
                Partner::Grain(_) => &snapshot.law,
                Partner::Wall(w) => &snapshot.domain.walls[w as usize].law,
            };
            let mu = law.friction;
            let ft = rec.tangential_force;
            let fn_ = c.normal_force;
            if fn_ < 1e-6 * mean_fn {
                counts.nearly_open_1e6 += 1;
            }
            if fn_ < 1e-3 * mean_fn {
                counts.nearly_open_1e3 += 1;
            }
            let mobilised = mu > 0.0 && mu.is_finite() && c.tangential_stiffness > 0.0 && ft.norm() >= (1.0 - tol) * mu * fn_;
            let mut lim = CoulombLimit { s: D::Vector::ZERO, mu: 0.0, s_r: D::AngVector::ZERO, mu_r: 0.0, gamma: 0.0 };
            if mobilised {
                if fn_ > 0.0 && ft.norm() > 0.0 {
                    lim.s = ft / ft.norm();
                    lim.mu = mu;
                    counts.at_limit += 1;
                } else {
                    counts.unloaded += 1;
                }
            }
            if options.rolling_cap {
                if let Rolling::SpringDashpot(grainwave_core::contact::rolling::SpringDashpot { friction: mu_r, .. }) = law.rolling {
                    let r_eff = match c.j {
                        Partner::Grain(j) => radii[c.i] * radii[j] / (radii[c.i] + radii[j]),
                        Partner::Wall(_) => radii[c.i],
                    };
                    let m = rec.rolling_torque;
                    let cap = mu_r * r_eff * fn_;
                    if c.rolling_stiffness > 0.0 && mu_r.is_finite() && fn_ > 0.0 && m.norm() > 0.0 && m.norm() >= (1.0 - tol) * cap {
                        lim.s_r = m / m.norm();
                        lim.mu_r = mu_r * r_eff;
                        counts.at_rolling_cap += 1;
                    }
                }
            }
            if options.wall_damping {
                if let Partner::Wall(w) = c.j {
                    if let NormalDamping::Dashpot(grainwave_core::contact::damping::normal::Dashpot { coefficient }) = snapshot.domain.walls[w as usize].law.damping {
                        let is_piston = piston.is_some_and(|(pc, _)| pc.wall == w);
                        if !is_piston {
                            lim.gamma = coefficient;
                        }
                    }
                }
            }
            limits.push(lim);
        }
        // time step: Gershgorin bound of the all-stick network, and the piston's own springs
        let stiffness = dm.stiffness();
        let (rp, ci, val) = (stiffness.symbolic().row_ptr(), stiffness.symbolic().col_idx(), stiffness.val());
        let m = dm.mass();
        let mut w2 = (0..dm.dofs()).map(|r| (rp[r]..rp[r + 1]).map(|e| val[e].abs() / (m[r] * m[ci[e]]).sqrt()).sum::<f64>()).fold(0.0, f64::max);
        if let Some((pc, _)) = piston {
            let k: f64 = dm.contacts().iter().filter(|c| c.j == Partner::Wall(pc.wall)).map(|c| c.normal_stiffness).sum();
            w2 = w2.max(2.0 * k / pc.mass);
        }
        let dt_max = if w2 > 0.0 { 2.0 * PI / (w2.sqrt() * options.steps_per_period) } else { f64::INFINITY };
        let n = dm.dofs();
        let contacts = dm.contacts().to_vec();
        let (adjacency_start, adjacency) = crate::dynamical::contact_adjacency(snapshot.len(), &contacts);
        let history = (0..contacts.len()).filter(|&k| limits[k].mu > 0.0 || limits[k].mu_r > 0.0).map(|k| BranchHistory { contact: k, ..Default::default() }).collect();
        Ok(IncrementalPropagator {
            states: vec![IncrementState::ZERO; contacts.len()],
            contacts,
            limits,
            history,
            adjacency_start,
            adjacency,
            p: dm.layout().per_grain(),
            inv_mass: m.iter().map(|x| 1.0 / x).collect(),
            piston,
            u: vec![0.0; n],
            v: vec![0.0; n],
            acc: vec![0.0; n],
            q: 0.0,
            qdot: 0.0,
            qacc: 0.0,
            time: 0.0,
            steps: 0,
            dt_max,
            counts,
            rule: options.branches,
        })
    }

    /// Sets the velocities (all dofs, translations and rotations per grain) at the current time.
    pub fn set_velocity(&mut self, v: &[f64]) -> Result<()> {
        LinearError::check_len("velocity", self.v.len(), v.len())?;
        self.v.copy_from_slice(v);
        Ok(())
    }

    /// Sets the piston's velocity along the wall's inward normal (a δ pulse of impulse J gives
    /// J/M_w). Error without a piston.
    pub fn set_piston_velocity(&mut self, v: f64) -> Result<()> {
        if self.piston.is_none() {
            return Err(LinearError::Inconsistent("the network has no piston to set in motion".into()));
        }
        self.qdot = v;
        Ok(())
    }

    /// The linearized contacts (assembled with every contact sticking).
    pub fn contacts(&self) -> &[LinearContact<D>] {
        &self.contacts
    }

    /// Contact counts of the state.
    pub fn counts(&self) -> StateCounts {
        self.counts
    }

    /// Whether contact `k` is at the Coulomb limit (two-branch tangential rule).
    pub fn at_limit(&self, k: usize) -> bool {
        self.limits[k].mu > 0.0
    }

    /// Branch histories of the contacts at the limit (tangential or rolling), in contact order.
    pub fn history(&self) -> &[BranchHistory] {
        &self.history
    }

    /// Contacts on the slip branch (tangential) at the last step.
    pub fn slipping(&self) -> usize {
        self.states.iter().filter(|s| s.slipping).count()
    }

    /// Contacts on the rolling slip branch at the last step.
    pub fn rolling_slipping(&self) -> usize {
        self.states.iter().filter(|s| s.rolling_slipping).count()
    }

    /// Tangential force increment on i of contact `k` (spring part).
    pub fn tangential_increment(&self, k: usize) -> D::Vector {
        self.states[k].df_t
    }

    /// Displacements (all dofs).
    pub fn displacement(&self) -> &[f64] {
        &self.u
    }

    /// Velocities (all dofs).
    pub fn velocity(&self) -> &[f64] {
        &self.v
    }

    /// Piston displacement and velocity along the inward normal.
    pub fn piston_state(&self) -> (f64, f64) {
        (self.q, self.qdot)
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Steps done.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Largest step.
    pub fn max_step(&self) -> f64 {
        self.dt_max
    }

    /// Contact forces at the current displacements, updating every contact's branch state.
    fn forces(&mut self) {
        let rule = self.rule;
        let p = self.p;
        let (u, v, q) = (&self.u, &self.v, self.q);
        let piston = self.piston;
        let loads: Vec<ContactLoads<D>> = self
            .contacts
            .par_iter()
            .zip(self.limits.par_iter())
            .zip(self.states.par_iter_mut())
            .with_min_len(256)
            .map(|((c, lim), st)| {
                let ui = grain_u::<D>(u, p, c.i);
                let ti = grain_theta::<D>(u, p, c.i);
                let (uj, tj) = match c.j {
                    Partner::Grain(j) => (grain_u::<D>(u, p, j), grain_theta::<D>(u, p, j)),
                    Partner::Wall(w) => match piston {
                        Some((pc, nn)) if pc.wall == w => (nn * q, D::AngVector::ZERO),
                        _ => (D::Vector::ZERO, D::AngVector::ZERO),
                    },
                };
                contact_step(c, lim, st, rule, ui, ti, uj, tj, if lim.gamma > 0.0 { grain_u::<D>(v, p, c.i) } else { D::Vector::ZERO })
            })
            .collect();
        let (start, adj) = (&self.adjacency_start, &self.adjacency);
        let inv = &self.inv_mass;
        self.acc.par_chunks_mut(p).enumerate().with_min_len(256).for_each(|(g, ag)| {
            let mut f = D::Vector::ZERO;
            let mut t = D::AngVector::ZERO;
            for &e in &adj[start[g] as usize..start[g + 1] as usize] {
                let l = &loads[(e >> 1) as usize];
                if e & 1 == 0 {
                    f += l.force_i;
                    t += l.torque_i;
                } else {
                    f += -l.force_i;
                    t += l.torque_j;
                }
            }
            for k in 0..D::D {
                ag[k] = f.get(k) * inv[g * p + k];
            }
            for k in 0..D::ROT {
                ag[D::D + k] = t.get(k) * inv[g * p + D::D + k];
            }
        });
        if let Some((pc, nn)) = self.piston {
            // force on the wall = −(force on i), projected on the inward normal; contact order
            let mut f = 0.0;
            for (c, l) in self.contacts.iter().zip(&loads) {
                if c.j == Partner::Wall(pc.wall) {
                    f -= l.force_i.dot(nn);
                }
            }
            self.qacc = f / pc.mass;
        }
        // branch histories (sequential, in contact order)
        for h in self.history.iter_mut() {
            let st = &self.states[h.contact];
            let now = st.slipping || st.rolling_slipping;
            if now {
                h.slip_steps += 1;
                if h.first_slip.is_none() {
                    h.first_slip = Some(self.time);
                }
            }
            if now != h.slipping {
                h.switches += 1;
                h.last_switch = Some(self.time);
            }
            h.slipping = now;
        }
    }

    fn step(&mut self, h: f64) {
        let half = 0.5 * h;
        self.v.par_iter_mut().zip(self.acc.par_iter()).with_min_len(4096).for_each(|(v, a)| *v += half * a);
        self.u.par_iter_mut().zip(self.v.par_iter()).with_min_len(4096).for_each(|(u, v)| *u += h * v);
        self.qdot += half * self.qacc;
        self.q += h * self.qdot;
        self.time += h;
        self.forces();
        self.v.par_iter_mut().zip(self.acc.par_iter()).with_min_len(4096).for_each(|(v, a)| *v += half * a);
        self.qdot += half * self.qacc;
        self.steps += 1;
    }

    /// Advances to time `t` (≥ the current time) in equal steps no longer than the maximal step.
    pub fn advance_to(&mut self, t: f64) -> Result<()> {
        if !(t >= self.time) || !t.is_finite() {
            return Err(LinearError::invalid("time", t, format!("a finite time ≥ the current time {}", self.time)));
        }
        let start = self.time;
        let span = t - start;
        if span == 0.0 {
            return Ok(());
        }
        let n = ((span / self.dt_max) * (1.0 - 1e-12)).ceil().max(1.0) as u64;
        let h = span / n as f64;
        for k in 0..n {
            self.step(h);
            // no drift of the clock: the k-th step ends at start + (k+1) h
            self.time = start + (k + 1) as f64 * h;
        }
        self.time = t;
        let check: f64 = self.u.iter().step_by(97).chain(self.v.iter().step_by(97)).sum::<f64>() + self.q;
        if !check.is_finite() {
            return Err(LinearError::Unstable { time: t, step: self.steps, dt: h });
        }
        Ok(())
    }
}

#[inline]
fn grain_u<D: Dim>(x: &[f64], p: usize, g: usize) -> D::Vector {
    D::Vector::from_slice(&x[g * p..g * p + D::D])
}

#[inline]
fn grain_theta<D: Dim>(x: &[f64], p: usize, g: usize) -> D::AngVector {
    D::AngVector::from_slice(&x[g * p + D::D..g * p + D::D + D::ROT])
}

/// One contact: the load increments for displacements (u_i, θ_i), (u_j, θ_j) (the wall's
/// displacement as u_j for a moving wall) with the branch update of `st` (see the module docs);
/// `vel_i` the velocity of i, used by a wall dashpot only. Called once per time step: the
/// tangential and rolling increments since the last call are what the branch rule integrates.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn contact_step<D: Dim>(c: &LinearContact<D>, lim: &CoulombLimit<D>, st: &mut IncrementState<D>, rule: BranchRule, ui: D::Vector, ti: D::AngVector, uj: D::Vector, tj: D::AngVector, vel_i: D::Vector) -> ContactLoads<D> {
    let n = c.normal;
    let (delta, _) = c.relative(ui, ti, uj, tj, D::Vector::ZERO);
    let dn = delta.dot(n);
    let delta_t = delta - n * dn;
    // ΔF_n = −k_n Δ·n̂ (ξ decreases by Δ·n̂)
    let dfn = -c.normal_stiffness * dn;
    let trial = st.df_t + (delta_t - st.delta_t) * c.tangential_stiffness;
    st.delta_t = delta_t;
    st.slipping = false;
    st.df_t = if lim.mu > 0.0 {
        let s = lim.s;
        match rule {
            BranchRule::Stick => trial,
            BranchRule::Free => trial - s * trial.dot(s),
            BranchRule::Slip => {
                st.slipping = true;
                trial + s * (lim.mu * dfn - s.dot(trial))
            }
            BranchRule::Incremental => {
                let d = lim.mu * dfn - s.dot(trial);
                if d < 0.0 {
                    st.slipping = true;
                    trial + s * d
                } else {
                    trial
                }
            }
        }
    } else {
        trial
    };
    // rolling: M on i = k_r (θ_j − θ_i)_⊥ (+ twist), with the cap rule on its own direction
    let th = tj - ti;
    let theta_r = D::ang_perp(th, n);
    let trial_r = st.dm_r + (theta_r - st.theta_r) * c.rolling_stiffness;
    st.theta_r = theta_r;
    st.rolling_slipping = false;
    st.dm_r = if lim.mu_r > 0.0 {
        let s = lim.s_r;
        match rule {
            BranchRule::Stick => trial_r,
            BranchRule::Free => trial_r - s * trial_r.dot(s),
            BranchRule::Slip => {
                st.rolling_slipping = true;
                trial_r + s * (lim.mu_r * dfn - s.dot(trial_r))
            }
            BranchRule::Incremental => {
                let d = lim.mu_r * dfn - s.dot(trial_r);
                if d < 0.0 {
                    st.rolling_slipping = true;
                    trial_r + s * d
                } else {
                    trial_r
                }
            }
        }
    } else {
        trial_r
    };
    let m = st.dm_r + D::about_normal(c.twisting_stiffness * D::twist(th, n), n);
    let mut f = n * (c.normal_stiffness * dn) + st.df_t;
    if lim.gamma > 0.0 {
        // wall dashpot on the normal velocity of i: −γ (v_i·n̂) n̂
        f -= n * (lim.gamma * vel_i.dot(n));
    }
    let tq = D::cross(n, st.df_t);
    ContactLoads { force_i: f, torque_i: tq * c.lever_i + m, torque_j: tq * c.lever_j - m }
}
