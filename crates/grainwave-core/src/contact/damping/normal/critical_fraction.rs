//! A fraction of critical damping: γ_n = ζ · 2 √(m* k_n(ξ)) at every instant, with k_n the
//! current differential stiffness of the normal law.

use crate::contact::NormalDampingLaw;
use crate::error::{require_non_negative, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// A fraction of critical damping: γ_n = ζ · 2 √(m* k_n(ξ)) at every instant, with k_n the
/// current differential stiffness of the normal law.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CriticalFraction {
    /// ζ (dimensionless), ≥ 0.
    pub zeta: f64,
}

impl NormalDampingLaw for CriticalFraction {
    /// `zeta` ≥ 0, named `{field}.damping_fraction`.
    fn validate(&self, field: &str) -> Result<()> {
        require_non_negative(&format!("{field}.damping_fraction"), self.zeta)
    }

    #[inline(always)]
    fn coefficient_lanes<R: Real>(&self, m_eff: R, k_n: R, _secant: R) -> R {
        R::splat(self.zeta * 2.0) * (m_eff * k_n).sqrt()
    }
}
