//! A fraction of critical damping on the tangential spring: γ_t = ζ · 2 √(m* k_t) (E1: the same ζ
//! as the normal part).

use crate::contact::TangentialDampingLaw;
use crate::error::{require_non_negative, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// A fraction of critical damping on the tangential spring: γ_t = ζ · 2 √(m* k_t) (E1: the same ζ
/// as the normal part).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CriticalFraction {
    /// ζ (dimensionless), ≥ 0.
    pub zeta: f64,
}

impl TangentialDampingLaw for CriticalFraction {
    /// `zeta` ≥ 0, named `{field}.damping_fraction`.
    fn validate(&self, field: &str) -> Result<()> {
        require_non_negative(&format!("{field}.damping_fraction"), self.zeta)
    }

    #[inline(always)]
    fn coefficient_lanes<R: Real>(&self, m_eff: R, k_t: R, _gamma_n: R) -> R {
        R::splat(self.zeta * 2.0) * (m_eff * k_t).sqrt()
    }
}
