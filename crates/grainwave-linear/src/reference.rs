//! Reference systems of SPEC §5.6, built as ordinary grainwave packings so that the generic
//! machinery (packing → contacts → D → modes) can be checked against closed forms.
//!
//! # 1D chain
//!
//! N balls of mass m on a line (x axis), spacing ℓ, joined by springs K (Hooke contacts, k_n = K),
//! the first and the last tied to fixed walls by the same spring. The chain is a 2D packing of disks
//! whose transverse translations and rotations are constrained ([`ChainSpec::constraints`]). Closed
//! form (monodisperse):
//!
//! ```text
//! k_n = nπ/((N+1)ℓ),  ω_n = 2√(K/m) sin(k_n ℓ/2),  c = ℓ√(K/m),
//! φ_n(k) = √(2/(m(N+1))) sin(nπk/(N+1))          (mass-normalized mode, grain k = 1 … N)
//! F(t) = K u_N(t) = K Σ_n φ_n(N) φ_n(1) m [u₁(0) cos ω_n t + u̇₁(0) sin(ω_n t)/ω_n]
//! ```
//!
//! with (A) u̇₁(0) = c ([`ChainSpec::impulse`]) or (B) u₁(0) = ℓ ([`ChainSpec::displacement`]).
//! A polydisperse chain draws radii uniformly in [R̄(1−a), R̄(1+a)] (R̄ = 0.505 ℓ), gives each ball the
//! mass m (R/R̄)³ and keeps every spring at the same compression (equal forces: a static state).
//!
//! # Triangular lattice
//!
//! `rows` × `columns` identical Hertz–Mindlin `sphere2d` balls on a triangular lattice with one
//! lattice direction along x (periodic), between a bottom wall and a top wall (fixed or a piston),
//! under the 3D pressure p (piston force p L_x d̄). For monodisperse balls the state is built exactly
//! in equilibrium: every grain–grain contact carries F = 2 R a p/√3 (a the lattice spacing,
//! a = 2R − ξ), every wall contact √3 F, with the overlaps of the Hertz law. Polydisperse lattices
//! (diameters uniform in [d̄(1−a), d̄(1+a)]) are placed without overlap at the spacing of the largest
//! diameter and must be compressed and relaxed by molecular dynamics (`Simulation::run`, top wall a
//! piston).

use crate::dofs::{Constraints, DofLayout};
use crate::error::{LinearError, Result};
use crate::pulse::InitialCondition;
use glam::DVec2;
use grainwave_core::contact::{ContactParams, Partner};
use grainwave_core::dim::D2;
use grainwave_core::domain::{Domain, TimeFunction, Wall, WallMotion};
use grainwave_core::grains::{GrainKind, Grains, SizeDistribution};
use grainwave_core::sim::{Simulation, SimulationBuilder};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The 1D chain of SPEC §5.6.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ChainSpec {
    /// Number of balls N.
    pub grains: usize,
    /// Spacing ℓ of the centres (monodisperse).
    pub spacing: f64,
    /// Spring stiffness K.
    pub stiffness: f64,
    /// Mass m of a ball (monodisperse; the mean-radius ball when polydisperse).
    pub mass: f64,
    /// Relative half-width a of the radius distribution (0: monodisperse).
    pub polydispersity: f64,
    /// Seed of the radius draws.
    pub seed: u64,
}

impl Default for ChainSpec {
    fn default() -> Self {
        ChainSpec { grains: 10, spacing: 1.0, stiffness: 1.0, mass: 1.0, polydispersity: 0.0, seed: 0 }
    }
}

impl ChainSpec {
    fn validate(&self) -> Result<()> {
        if self.grains == 0 {
            return Err(LinearError::invalid("chain.grains", self.grains, "at least 1"));
        }
        for (k, v) in [("chain.spacing", self.spacing), ("chain.stiffness", self.stiffness), ("chain.mass", self.mass)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(LinearError::invalid(k, v, "a finite number > 0"));
            }
        }
        if !(0.0..0.5).contains(&self.polydispersity) {
            return Err(LinearError::invalid("chain.polydispersity", self.polydispersity, "a number in [0, 0.5)"));
        }
        Ok(())
    }

    /// Radii of the balls (R̄ = 0.505 ℓ, so that neighbours overlap by 1 % of ℓ).
    pub fn radii(&self) -> Vec<f64> {
        let r = 0.505 * self.spacing;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        (0..self.grains)
            .map(|_| if self.polydispersity > 0.0 { r * (1.0 + self.polydispersity * (2.0 * rng.random::<f64>() - 1.0)) } else { r })
            .collect()
    }

    /// The chain as a static packing (disks on the x axis, Hooke law k_n = K, frictionless,
    /// undamped; walls `left` = 0 and `right` = 1).
    pub fn build(&self) -> Result<Simulation<D2>> {
        self.validate()?;
        let radii = self.radii();
        let r_mean = 0.505 * self.spacing;
        let overlap = 0.01 * self.spacing;
        let mut params = ContactParams::preset("hooke_cundall_strack");
        params.normal_stiffness = Some(self.stiffness);
        params.friction = Some(0.0);
        let law = params.build(Partner::Grain, "contact").map_err(|e| LinearError::Inconsistent(e.to_string()))?;
        let wall_law = params.build(Partner::Wall, "contact.wall").map_err(|e| LinearError::Inconsistent(e.to_string()))?;
        let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        let left = 0.0;
        let mut x = left + radii[0] - overlap;
        for (k, &r) in radii.iter().enumerate() {
            if k > 0 {
                x += radii[k - 1] + r - overlap;
            }
            grains.push_with_mass(DVec2::new(x, 0.0), r, self.mass * (r / r_mean).powi(3), DVec2::ZERO);
        }
        let right = x + radii[self.grains - 1] - overlap;
        let r_max = radii.iter().cloned().fold(0.0, f64::max);
        let domain = Domain::new(DVec2::new(left, -4.0 * r_max), DVec2::new(right, 4.0 * r_max), [false; 3])
            .with_wall(Wall::axis_aligned("left", 0, left, true, wall_law))
            .with_wall(Wall::axis_aligned("right", 0, right, false, wall_law));
        SimulationBuilder::new(grains, domain, law).max_initial_overlap(0.5).build().map_err(|e| LinearError::Inconsistent(e.to_string()))
    }

    /// Constraints that reduce the packing to the 1D chain: transverse translations and rotations
    /// of every ball held at zero.
    pub fn constraints(&self) -> Constraints {
        let layout = DofLayout::of::<D2>(self.grains);
        let mut c = Constraints::new();
        c.fix_component_everywhere(&layout, 1);
        c.fix_component_everywhere(&layout, 2);
        c
    }

    /// Sound speed c = ℓ√(K/m).
    pub fn sound_speed(&self) -> f64 {
        self.spacing * (self.stiffness / self.mass).sqrt()
    }

    /// Closed-form angular frequencies ω_n = 2√(K/m) sin(nπ/(2(N+1))), n = 1 … N (monodisperse).
    pub fn frequencies(&self) -> Vec<f64> {
        let n1 = (self.grains + 1) as f64;
        (1..=self.grains).map(|n| 2.0 * (self.stiffness / self.mass).sqrt() * (n as f64 * PI / (2.0 * n1)).sin()).collect()
    }

    /// Initial condition A with u̇₁(0) = c: impulse strength h = c m / K.
    pub fn impulse(&self) -> InitialCondition {
        InitialCondition::Impulse { strength: self.sound_speed() * self.mass / self.stiffness }
    }

    /// Initial condition B with u₁(0) = ℓ.
    pub fn displacement(&self) -> InitialCondition {
        InitialCondition::Displacement { amplitude: self.spacing }
    }

    /// Closed-form F(t) = K u_N(t) of the monodisperse chain for initial condition `ic`
    /// (A: u̇₁(0) = h K/m; B: u₁(0) = δ).
    pub fn closed_form_signal(&self, t: f64, ic: &InitialCondition) -> f64 {
        let n = self.grains;
        let n1 = (n + 1) as f64;
        let (u1, v1) = match *ic {
            InitialCondition::Impulse { strength } => (0.0, strength * self.stiffness / self.mass),
            InitialCondition::Displacement { amplitude } => (amplitude, 0.0),
        };
        let omega = self.frequencies();
        let mut s = 0.0;
        for (k, w) in omega.iter().enumerate() {
            let m = (k + 1) as f64;
            // φ_n(N) φ_n(1) m = (2/(N+1)) sin(nπ/(N+1)) sin(nπN/(N+1))
            let shape = 2.0 / n1 * (m * PI / n1).sin() * (m * PI * n as f64 / n1).sin();
            s += shape * (u1 * (w * t).cos() + v1 * (w * t).sin() / w);
        }
        self.stiffness * s
    }
}

/// The triangular lattice of SPEC §5.6.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TriangularLatticeSpec {
    /// Number of rows (along y).
    pub rows: usize,
    /// Balls per row (periodic along x).
    pub columns: usize,
    /// Mean diameter d̄.
    pub diameter: f64,
    /// 3D pressure p (units of E*).
    pub pressure: f64,
    /// Young's modulus E.
    pub young: f64,
    /// Poisson's ratio ν.
    pub poisson: f64,
    /// Friction coefficient μ (0: frictionless).
    pub friction: f64,
    /// Grain density ρ.
    pub density: f64,
    /// Relative half-width of the diameter distribution (0: monodisperse, exact equilibrium).
    pub polydispersity: f64,
    /// Top wall as a piston under p L_x d̄ (mass: one row of balls); otherwise fixed.
    pub piston: bool,
    /// Seed of the diameter draws.
    pub seed: u64,
}

impl Default for TriangularLatticeSpec {
    fn default() -> Self {
        TriangularLatticeSpec {
            rows: 10,
            columns: 10,
            diameter: 1.0,
            pressure: 1e-4,
            young: 1.0,
            poisson: 0.0,
            friction: 0.5,
            density: 1.0,
            polydispersity: 0.0,
            piston: false,
            seed: 0,
        }
    }
}

/// Geometry of a monodisperse lattice at equilibrium.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LatticeGeometry {
    /// Lattice spacing a = 2R − ξ.
    pub spacing: f64,
    /// Grain–grain overlap ξ.
    pub overlap: f64,
    /// Grain–wall overlap ξ_w.
    pub wall_overlap: f64,
    /// Grain–grain contact force F.
    pub contact_force: f64,
}

impl TriangularLatticeSpec {
    /// Contact parameters (Hertz–Mindlin).
    pub fn contact_params(&self) -> ContactParams {
        let mut p = ContactParams::preset("hertz_mindlin");
        p.young = Some(self.young);
        p.poisson = Some(self.poisson);
        p.friction = Some(self.friction);
        p
    }

    /// Closed-form longitudinal speed of the lattice at small pressure (SPEC §5.6), in units of
    /// √(E*/ρ) with d̄ = 1: c_nofric = 3^(19/12)/(2^(3/2) π^(1/2)) (p/E*)^(1/6), and with friction
    /// c_fric = c_nofric √(1 + η/3), η = k_t/k_n = 1 − ν/(2 − ν) (Mindlin).
    ///
    /// Derivation: central springs k on a triangular lattice of spacing a give
    /// λ + 2μ = 3√3 k/4 (tangential springs k_t add √3 k_t/4), and the 2D density is m/(√3a²/2),
    /// so c² = 9 k a²/(8m) (× (1 + k_t/(3k))); with a → d̄ = 1, m = πρ/6, the bond force
    /// F = a p/√3 and the Hertz law F = (E*/3) ξ^(3/2) between two unit spheres, k = (3/2) F/ξ =
    /// (3/2) 3^(−5/6) p^(1/3) E*^(2/3), hence c² = 3^(19/6)/(8π) p^(1/3). Valid to O(ξ/d̄) ~ p^(2/3).
    pub fn closed_form_speed(&self) -> f64 {
        let e_star = self.young / (1.0 - self.poisson * self.poisson);
        let c = 3f64.powf(19.0 / 12.0) / (2f64.powf(1.5) * std::f64::consts::PI.sqrt()) * (self.pressure / e_star).powf(1.0 / 6.0) * (e_star / self.density).sqrt();
        if self.friction > 0.0 {
            let eta = 1.0 - self.poisson / (2.0 - self.poisson);
            c * (1.0 + eta / 3.0).sqrt()
        } else {
            c
        }
    }

    /// Equilibrium geometry of the monodisperse lattice: F = 2 R a p/√3, Hertz overlaps.
    pub fn geometry(&self) -> LatticeGeometry {
        let r = 0.5 * self.diameter;
        let e_star = self.young / (1.0 - self.poisson * self.poisson);
        let (e_pair, r_pair) = (0.5 * e_star, 0.5 * r);
        let mut a = 2.0 * r;
        let mut f = 0.0;
        let mut xi = 0.0;
        for _ in 0..100 {
            f = 2.0 * r * a * self.pressure / 3f64.sqrt();
            xi = (f / (4.0 / 3.0 * e_pair * r_pair.sqrt())).powf(2.0 / 3.0);
            let a_new = 2.0 * r - xi;
            if (a_new - a).abs() <= 1e-16 * a {
                a = a_new;
                break;
            }
            a = a_new;
        }
        let xi_w = (3f64.sqrt() * f / (4.0 / 3.0 * e_star * r.sqrt())).powf(2.0 / 3.0);
        LatticeGeometry { spacing: a, overlap: xi, wall_overlap: xi_w, contact_force: f }
    }

    /// Builds the lattice (walls `bottom` = 0, `top` = 1).
    pub fn build(&self) -> Result<Simulation<D2>> {
        if self.rows < 2 || self.columns < 3 {
            return Err(LinearError::invalid("lattice.rows/columns", format!("{} × {}", self.rows, self.columns), "at least 2 rows and 3 columns"));
        }
        for (k, v) in [("lattice.diameter", self.diameter), ("lattice.pressure", self.pressure), ("lattice.young", self.young), ("lattice.density", self.density)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(LinearError::invalid(k, v, "a finite number > 0"));
            }
        }
        let params = self.contact_params();
        let law = params.build(Partner::Grain, "contact").map_err(|e| LinearError::Inconsistent(e.to_string()))?;
        let wall_law = params.build(Partner::Wall, "contact.wall").map_err(|e| LinearError::Inconsistent(e.to_string()))?;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let n = self.rows * self.columns;
        let (radii, a, wall_gap) = if self.polydispersity > 0.0 {
            let dist = SizeDistribution::UniformDiameter { mean_diameter: self.diameter, spread: self.polydispersity };
            let radii = dist.sample(n, &mut rng).map_err(|e| LinearError::Inconsistent(e.to_string()))?;
            let d_max = 2.0 * radii.iter().cloned().fold(0.0, f64::max);
            (radii, d_max, 0.5 * d_max)
        } else {
            let g = self.geometry();
            (vec![0.5 * self.diameter; n], g.spacing, 0.5 * self.diameter - g.wall_overlap)
        };
        let dy = a * 3f64.sqrt() / 2.0;
        let mut grains = Grains::<D2>::new(GrainKind::Sphere2d);
        let y0 = wall_gap;
        for row in 0..self.rows {
            for col in 0..self.columns {
                let x = (col as f64 + 0.25 + if row % 2 == 1 { 0.5 } else { 0.0 }) * a;
                let y = y0 + row as f64 * dy;
                grains.push(DVec2::new(x, y), radii[row * self.columns + col], self.density, DVec2::ZERO);
            }
        }
        let lx = self.columns as f64 * a;
        let top = y0 + (self.rows - 1) as f64 * dy + wall_gap;
        let mut top_wall = Wall::axis_aligned("top", 1, top, false, wall_law);
        if self.piston {
            let row_mass: f64 = grains.mass[..self.columns].iter().sum();
            top_wall = top_wall.with_motion(WallMotion::Piston { mass: row_mass, force: TimeFunction::constant(self.pressure * lx * self.diameter) });
        }
        let domain = Domain::new(DVec2::ZERO, DVec2::new(lx, top), [true, false, false])
            .with_wall(Wall::axis_aligned("bottom", 1, 0.0, true, wall_law))
            .with_wall(top_wall);
        SimulationBuilder::new(grains, domain, law).max_initial_overlap(0.5).seed(self.seed).build().map_err(|e| LinearError::Inconsistent(e.to_string()))
    }
}
