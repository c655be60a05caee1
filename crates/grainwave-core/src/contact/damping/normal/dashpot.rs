//! A constant normal dashpot: γ_n = `coefficient` (force/velocity).

use crate::contact::damping::tangential::FractionOfNormal;
use crate::contact::{DampingContext, DampingParams, NormalDamping, NormalDampingLaw, TangentialDamping};
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

/// `[contact.damping]` with `law = "dashpot"`: a constant γ_n (linear normal laws), γ_t = ½ γ_n
/// unless a tangential ratio or rate is given. The flat key `normal_damping`, to the bit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct DashpotTable {
    /// γ_n [force·time/length], ≥ 0.
    pub coefficient: f64,
    /// γ_t / γ_n, default ½.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_ratio: Option<f64>,
    /// γ_t / m* instead of a ratio [1/time].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_rate: Option<f64>,
}

impl DampingParams for DashpotTable {
    /// γ_n ≥ 0; refused beside the Hertz law.
    fn build(&self, at: &DampingContext) -> Result<(NormalDamping, TangentialDamping)> {
        at.linear_only("dashpot")?;
        require_non_negative(&at.key("coefficient"), self.coefficient)?;
        let tangential = at.tangential(self.tangential_ratio, self.tangential_rate, FractionOfNormal { ratio: 0.5 }.into())?;
        Ok((Dashpot { coefficient: self.coefficient }.into(), tangential))
    }
}
