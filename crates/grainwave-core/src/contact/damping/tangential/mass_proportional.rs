//! A dashpot proportional to the effective mass: γ_t = rate × m* (LAMMPS `gran/hooke/history`'s
//! `gamma_t`, in 1/time).

use crate::contact::TangentialDampingLaw;
use crate::error::{require_non_negative, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// A dashpot proportional to the effective mass: γ_t = rate × m* (LAMMPS `gran/hooke/history`'s
/// `gamma_t`, in 1/time).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MassProportional {
    /// γ_t / m* (1/time), ≥ 0.
    pub rate: f64,
}

impl TangentialDampingLaw for MassProportional {
    /// `rate` ≥ 0, named `{field}.tangential_damping_rate`.
    fn validate(&self, field: &str) -> Result<()> {
        require_non_negative(&format!("{field}.tangential_damping_rate"), self.rate)
    }

    #[inline(always)]
    fn coefficient_lanes<R: Real>(&self, m_eff: R, _k_t: R, _gamma_n: R) -> R {
        R::splat(self.rate) * m_eff
    }
}
