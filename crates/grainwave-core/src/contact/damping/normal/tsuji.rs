//! Tsuji, Tanaka & Ishida (1992): γ_n = α √(m* k̄) with k̄ = F_el/ξ the secant stiffness of the
//! normal law (Hooke: k_n; Hertz: (4/3) E*_ij √(R* ξ), so γ_n ∝ ξ^¼). α follows from a
//! restitution coefficient through [`tsuji_alpha`](crate::contact::tsuji_alpha). This is
//! LAMMPS's `damping tsuji`.

use crate::contact::NormalDampingLaw;
use crate::error::{require_non_negative, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// Tsuji, Tanaka & Ishida (1992): γ_n = α √(m* k̄) with k̄ = F_el/ξ the secant stiffness of the
/// normal law (Hooke: k_n; Hertz: (4/3) E*_ij √(R* ξ), so γ_n ∝ ξ^¼). α follows from a
/// restitution coefficient through [`tsuji_alpha`](crate::contact::tsuji_alpha). This is
/// LAMMPS's `damping tsuji`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tsuji {
    /// α (dimensionless), ≥ 0.
    pub alpha: f64,
}

impl NormalDampingLaw for Tsuji {
    /// `alpha` ≥ 0, named `{field}.tsuji_alpha`.
    fn validate(&self, field: &str) -> Result<()> {
        require_non_negative(&format!("{field}.tsuji_alpha"), self.alpha)
    }

    #[inline(always)]
    fn coefficient_lanes<R: Real>(&self, m_eff: R, _k_n: R, secant: R) -> R {
        R::splat(self.alpha) * (m_eff * secant).sqrt()
    }
}
