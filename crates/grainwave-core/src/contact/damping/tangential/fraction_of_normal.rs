//! A fraction of the normal coefficient: γ_t = ratio × γ_n (E2 and the classic Hooke law use ½).

use crate::contact::TangentialDampingLaw;
use crate::error::{require_non_negative, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// A fraction of the normal coefficient: γ_t = ratio × γ_n (E2 and the classic Hooke law use ½).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FractionOfNormal {
    /// γ_t / γ_n, ≥ 0.
    pub ratio: f64,
}

impl TangentialDampingLaw for FractionOfNormal {
    /// `ratio` ≥ 0, named `{field}.tangential_damping_ratio`.
    fn validate(&self, field: &str) -> Result<()> {
        require_non_negative(&format!("{field}.tangential_damping_ratio"), self.ratio)
    }

    #[inline(always)]
    fn coefficient_lanes<R: Real>(&self, _m_eff: R, _k_t: R, gamma_n: R) -> R {
        R::splat(self.ratio) * gamma_n
    }
}
