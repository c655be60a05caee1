//! A dashpot proportional to the effective mass: γ_n = rate × m*. This is the damping of
//! LAMMPS's `gran/hooke/history` (its `gamma_n`, in 1/time, multiplies m*).

use crate::contact::damping::tangential::FractionOfNormal;
use crate::contact::{DampingContext, DampingParams, NormalDamping, NormalDampingLaw, TangentialDamping};
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

/// `[contact.damping]` with `law = "mass_proportional"`: γ_n = rate × m* (linear normal laws),
/// γ_t = ½ γ_n unless a tangential ratio or rate is given. The flat keys `normal_damping_rate`
/// and `tangential_damping_rate` (LAMMPS `gran/hooke/history`'s `gamma_n`, `gamma_t`), to the bit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct MassProportionalTable {
    /// γ_n / m* [1/time], ≥ 0.
    pub rate: f64,
    /// γ_t / γ_n, default ½.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_ratio: Option<f64>,
    /// γ_t / m* instead of a ratio [1/time].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_rate: Option<f64>,
}

impl DampingParams for MassProportionalTable {
    /// rate ≥ 0; refused beside the Hertz law.
    fn build(&self, at: &DampingContext) -> Result<(NormalDamping, TangentialDamping)> {
        at.linear_only("mass_proportional")?;
        require_non_negative(&at.key("rate"), self.rate)?;
        let tangential = at.tangential(self.tangential_ratio, self.tangential_rate, FractionOfNormal { ratio: 0.5 }.into())?;
        Ok((MassProportional { rate: self.rate }.into(), tangential))
    }
}
