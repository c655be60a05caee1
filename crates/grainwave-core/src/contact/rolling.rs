//! Rolling resistance (SPEC §2.5) and twisting resistance: spring–dashpots on the relative
//! rolling and twisting rotations, capped.
//!
//! The relative rolling angular velocity is w_r = (ω_j − ω_i) with its component along the
//! normal removed (no twisting). The spring θ_r = ∫ w_r dt gives a torque on grain i
//! M_r = k_r θ_r + γ_r w_r (and −M_r on j), with |M_r| ≤ μ_r R* F_n; when capped the spring is
//! reset to θ_r = M_r / k_r. Two grains rotating rigidly together feel no rolling torque.

use serde::{Deserialize, Serialize};

/// Rolling resistance law.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Rolling {
    /// No rolling resistance (default).
    None,
    /// Spring–dashpot with a Coulomb-like cap.
    SpringDashpot {
        /// k_r (torque/radian).
        stiffness: f64,
        /// γ_r (torque·time/radian).
        damping: f64,
        /// μ_r (dimensionless); the cap is μ_r R* F_n.
        friction: f64,
    },
}

/// Twisting (torsional) resistance, 3D only: resists the relative spin about the contact normal.
///
/// Without it, a sphere spinning about the normal of its only contact (e.g. alone on a floor)
/// feels no torque and never stops — a frictional 3D packing could then never reach zero kinetic
/// energy. With w_tw = (ω_j − ω_i)·n̂ and the spring φ = ∫ w_tw dt, the torque on i is
/// M_tw n̂ with M_tw = k_tw φ + γ_tw w_tw, |M_tw| ≤ μ_tw R* F_n (spring reset when capped);
/// −M_tw n̂ on j. Off by default; no effect in 2D.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Twisting {
    /// No twisting resistance (default).
    None,
    /// Spring–dashpot with a Coulomb-like cap.
    SpringDashpot {
        /// k_tw (torque/radian).
        stiffness: f64,
        /// γ_tw (torque·time/radian).
        damping: f64,
        /// μ_tw (dimensionless); the cap is μ_tw R* F_n.
        friction: f64,
    },
}
