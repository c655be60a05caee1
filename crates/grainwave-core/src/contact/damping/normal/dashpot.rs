//! A constant normal dashpot: γ_n = `coefficient` (force/velocity).

use crate::contact::NormalDampingLaw;
use crate::error::{require_non_negative, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// A constant normal dashpot: γ_n = `coefficient` (force/velocity).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Dashpot {
    /// γ_n (force/velocity), ≥ 0.
    pub coefficient: f64,
}

impl NormalDampingLaw for Dashpot {
    /// `coefficient` ≥ 0, named `{field}.normal_damping`.
    fn validate(&self, field: &str) -> Result<()> {
        require_non_negative(&format!("{field}.normal_damping"), self.coefficient)
    }

    #[inline(always)]
    fn coefficient_lanes<R: Real>(&self, _m_eff: R, _k_n: R, _secant: R) -> R {
        R::splat(self.coefficient)
    }
}
