//! A dashpot proportional to the effective mass: γ_n = rate × m*. This is the damping of
//! LAMMPS's `gran/hooke/history` (its `gamma_n`, in 1/time, multiplies m*).

use crate::contact::NormalDampingLaw;
use crate::error::{require_non_negative, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// A dashpot proportional to the effective mass: γ_n = rate × m*. This is the damping of
/// LAMMPS's `gran/hooke/history` (its `gamma_n`, in 1/time, multiplies m*).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MassProportional {
    /// γ_n / m* (1/time), ≥ 0.
    pub rate: f64,
}

impl NormalDampingLaw for MassProportional {
    /// `rate` ≥ 0, named `{field}.normal_damping_rate`.
    fn validate(&self, field: &str) -> Result<()> {
        require_non_negative(&format!("{field}.normal_damping_rate"), self.rate)
    }

    #[inline(always)]
    fn coefficient_lanes<R: Real>(&self, m_eff: R, _k_n: R, _secant: R) -> R {
        R::splat(self.rate) * m_eff
    }
}
