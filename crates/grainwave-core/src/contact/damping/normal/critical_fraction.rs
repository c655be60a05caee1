//! A fraction of critical damping: γ_n = ζ · 2 √(m* k_n(ξ)) at every instant, with k_n the
//! current differential stiffness of the normal law.

use crate::contact::damping::tangential;
use crate::contact::{DampingContext, DampingParams, NormalDamping, NormalDampingLaw, TangentialDamping};
use crate::error::{require_non_negative, CoreError, Result};
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

/// `[contact.damping]` with `law = "critical_fraction"`: γ_n = 2ζ√(m* k_n) and the same
/// fraction on the tangential part, γ_t = 2ζ√(m* k_t), unless (beside a linear normal law) a
/// tangential ratio or rate is given. Beside the Hertz law ζ = 0 is no damping at all. The flat
/// key `damping_fraction`, to the bit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct CriticalFractionTable {
    /// ζ ≥ 0.
    pub fraction: f64,
    /// γ_t / γ_n (linear normal laws).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_ratio: Option<f64>,
    /// γ_t / m* [1/time] (linear normal laws).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_rate: Option<f64>,
}

impl DampingParams for CriticalFractionTable {
    /// ζ ≥ 0; beside the Hertz law no tangential ratio or rate (ζ applies to both parts).
    fn build(&self, at: &DampingContext) -> Result<(NormalDamping, TangentialDamping)> {
        let zeta = self.fraction;
        require_non_negative(&at.key("fraction"), zeta)?;
        let both: (NormalDamping, TangentialDamping) = (CriticalFraction { zeta }.into(), tangential::CriticalFraction { zeta }.into());
        if at.is_hertz() {
            for (k, v) in [("tangential_ratio", self.tangential_ratio), ("tangential_rate", self.tangential_rate)] {
                if let Some(v) = v {
                    return Err(CoreError::Inconsistent(format!(
                        "`{}` = {v} does not apply beside the Hertz normal law: the fraction ζ applies to both parts (a ratio goes with `law = \"tsuji\"`)",
                        at.key(k)
                    )));
                }
            }
            return Ok(if zeta > 0.0 { both } else { (NormalDamping::None, TangentialDamping::None) });
        }
        let tangential = at.tangential(self.tangential_ratio, self.tangential_rate, both.1)?;
        Ok((both.0, tangential))
    }
}
