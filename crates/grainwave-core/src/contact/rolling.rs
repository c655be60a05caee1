//! Rolling resistance (SPEC §2.5): spring–dashpot on the relative rolling rotation, capped.
//!
//! The relative rolling angular velocity is w_r = (ω_j − ω_i) with its component along the
//! normal removed (no twisting). The spring θ_r = ∫ w_r dt gives a torque on grain i
//! M_r = k_r θ_r + γ_r w_r (and −M_r on j), with |M_r| ≤ μ_r R* F_n; when capped the spring is
//! reset to θ_r = M_r / k_r. Two grains rotating rigidly together feel no rolling torque.

use serde::{Deserialize, Serialize};

/// Rolling resistance law.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "law", rename_all = "snake_case")]
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
