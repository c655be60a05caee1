//! A constant tangential dashpot: γ_t = `coefficient` (force/velocity).

use crate::contact::TangentialDampingLaw;
use crate::error::{require_non_negative, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// A constant tangential dashpot: γ_t = `coefficient` (force/velocity).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Coefficient {
    /// γ_t (force/velocity), ≥ 0.
    pub coefficient: f64,
}

impl TangentialDampingLaw for Coefficient {
    /// `coefficient` ≥ 0, named `{field}.tangential_damping`.
    fn validate(&self, field: &str) -> Result<()> {
        require_non_negative(&format!("{field}.tangential_damping"), self.coefficient)
    }

    #[inline(always)]
    fn coefficient_lanes<R: Real>(&self, _m_eff: R, _k_t: R, _gamma_n: R) -> R {
        R::splat(self.coefficient)
    }
}
