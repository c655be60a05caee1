//! Tangential part with history (SPEC §2.3): linear (Cundall–Strack) and incremental Mindlin.
//!
//! Sign convention: `v_t` is the tangential velocity of grain j relative to grain i at the contact
//! point, and the history and forces are those acting **on grain i**: a Cundall–Strack spring
//! stores s = ∫ v_t dt and pulls i along, F_t(on i) = k_t s + γ_t v_t (equivalently, on j,
//! −k_t s − γ_t v_t as in SPEC §2.3).

use serde::{Deserialize, Serialize};

/// Tangential elastic law.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Tangential {
    /// No tangential force (frictionless).
    None,
    /// Linear spring on the tangential displacement s (Cundall–Strack): F_t = k_t s + γ_t v_t.
    /// History: the spring s.
    Linear {
        /// k_t (force/length).
        stiffness: f64,
    },
    /// Incremental Mindlin: ΔF_t = k_t(ξ) v_t Δt with k_t(ξ) = 8 G*_ij √(R* ξ).
    /// History: the elastic tangential force.
    Mindlin {
        /// Effective shear modulus G*_ij (grain–grain: (1/G*_i + 1/G*_j)⁻¹; rigid wall: G*_i).
        effective_shear_modulus: f64,
        /// When the overlap decreases, rescale the stored force by k_t(new)/k_t(old)
        /// (default off: the stored force is kept, as in the plain incremental law).
        rescale_on_unloading: bool,
    },
}

impl Tangential {
    /// Tangential stiffness at overlap `xi` for effective radius `r_eff`.
    #[inline]
    pub fn stiffness(&self, xi: f64, r_eff: f64) -> f64 {
        match *self {
            Tangential::None => 0.0,
            Tangential::Linear { stiffness } => stiffness,
            Tangential::Mindlin { effective_shear_modulus, .. } => 8.0 * effective_shear_modulus * (r_eff * xi).sqrt(),
        }
    }
}

/// Tangential viscous damping γ_t.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TangentialDamping {
    /// No tangential damping.
    None,
    /// Constant γ_t.
    Coefficient {
        /// γ_t (force/velocity).
        coefficient: f64,
    },
    /// γ_t = ratio × γ_n (E2 and the classic Hooke law use ½).
    FractionOfNormal {
        /// γ_t / γ_n.
        ratio: f64,
    },
    /// γ_t = ζ · 2 √(m* k_t) (E1: the same ζ as the normal part).
    CriticalFraction {
        /// ζ.
        zeta: f64,
    },
    /// γ_t = rate × m* (LAMMPS `gran/hooke/history`'s `gamma_t`, in 1/time).
    MassProportional {
        /// γ_t / m* (1/time).
        rate: f64,
    },
}

impl TangentialDamping {
    /// γ_t for effective mass `m_eff`, tangential stiffness `k_t` and normal coefficient `gamma_n`.
    #[inline]
    pub fn coefficient(&self, m_eff: f64, k_t: f64, gamma_n: f64) -> f64 {
        match *self {
            TangentialDamping::None => 0.0,
            TangentialDamping::Coefficient { coefficient } => coefficient,
            TangentialDamping::FractionOfNormal { ratio } => ratio * gamma_n,
            TangentialDamping::CriticalFraction { zeta } => zeta * 2.0 * (m_eff * k_t).sqrt(),
            TangentialDamping::MassProportional { rate } => rate * m_eff,
        }
    }
}
