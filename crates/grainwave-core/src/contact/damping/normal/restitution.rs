//! The `[contact.damping]` table `law = "restitution"`: the fraction of critical damping
//! ([`CriticalFraction`]) whose clamped linear contact has the restitution coefficient e of a
//! binary collision exactly ([`critical_fraction_for_restitution`](crate::contact::critical_fraction_for_restitution)),
//! beside a linear normal law. The flat key `restitution` of `hooke_cundall_strack`, to the bit.

use super::CriticalFraction;
use crate::contact::damping::tangential::FractionOfNormal;
use crate::contact::{DampingContext, DampingParams, NormalDamping, TangentialDamping};
use crate::error::{CoreError, Result};
use serde::{Deserialize, Serialize};

/// `[contact.damping]` with `law = "restitution"`: γ_n = 2ζ(e)√(m* k_n) with ζ(e) the fraction
/// of critical damping that gives restitution e (linear normal laws), γ_t = ½ γ_n unless a
/// tangential ratio or rate is given.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct RestitutionTable {
    /// e ∈ [e⁻², 1].
    pub restitution: f64,
    /// γ_t / γ_n, default ½.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_ratio: Option<f64>,
    /// γ_t / m* instead of a ratio [1/time].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_rate: Option<f64>,
}

impl DampingParams for RestitutionTable {
    /// e ∈ (0, 1], and ≥ e⁻² (below it a linear dashpot without attraction never lets the
    /// grains separate); refused beside the Hertz law.
    fn build(&self, at: &DampingContext) -> Result<(NormalDamping, TangentialDamping)> {
        at.linear_only("restitution")?;
        let e = self.restitution;
        if !(e > 0.0 && e <= 1.0) {
            return Err(CoreError::invalid(at.key("restitution"), e, "a restitution coefficient in (0, 1]"));
        }
        let normal: NormalDamping = NormalDamping::from_restitution(e).ok_or_else(|| {
            CoreError::invalid(
                at.key("restitution"),
                e,
                "a restitution coefficient in [0.1353, 1]: below e^-2 a linear dashpot without attraction never lets grains separate",
            )
        })?;
        debug_assert!(matches!(normal, NormalDamping::CriticalFraction(CriticalFraction { .. })));
        let tangential = at.tangential(self.tangential_ratio, self.tangential_rate, FractionOfNormal { ratio: 0.5 }.into())?;
        Ok((normal, tangential))
    }
}
