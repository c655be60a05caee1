//! Tsuji, Tanaka & Ishida (1992): γ_n = α √(m* k̄) with k̄ = F_el/ξ the secant stiffness of the
//! normal law (Hooke: k_n; Hertz: (4/3) E*_ij √(R* ξ), so γ_n ∝ ξ^¼). α follows from a
//! restitution coefficient through [`tsuji_alpha`](crate::contact::tsuji_alpha). This is
//! LAMMPS's `damping tsuji`.

use crate::contact::damping::tangential::FractionOfNormal;
use crate::contact::{tsuji_alpha, DampingContext, DampingParams, NormalDamping, NormalDampingLaw, TangentialDamping};
use crate::error::{require_non_negative, CoreError, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// Tsuji, Tanaka & Ishida (1992): γ_n = α √(m* k̄) with k̄ = F_el/ξ the secant stiffness of the
/// normal law (Hooke: k_n; Hertz: (4/3) E*_ij √(R* ξ), so γ_n ∝ ξ^¼). α follows from a
/// restitution coefficient through [`tsuji_alpha`](crate::contact::tsuji_alpha). This is
/// LAMMPS's `damping tsuji`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tsuji {
    /// α (dimensionless), ≥ 0.
    pub alpha: f64,
}

impl NormalDampingLaw for Tsuji {
    /// `alpha` ≥ 0, named `{field}.tsuji_alpha`.
    fn validate(&self, field: &str) -> Result<()> {
        require_non_negative(&format!("{field}.tsuji_alpha"), self.alpha)
    }

    #[inline(always)]
    fn coefficient_lanes<R: Real>(&self, m_eff: R, _k_n: R, secant: R) -> R {
        R::splat(self.alpha) * (m_eff * secant).sqrt()
    }
}

/// `[contact.damping]` with `law = "tsuji"`: α = α(e) from a restitution coefficient e
/// ([`tsuji_alpha`]), γ_t = ratio × γ_n with the ratio 1 beside the Hertz law and ½ beside a
/// linear one by default. The flat keys `tsuji_restitution` and `tangential_damping_ratio`, to
/// the bit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct TsujiTable {
    /// e ∈ [0, 1].
    pub restitution: f64,
    /// γ_t / γ_n, default 1 (Hertz) or ½ (linear normal laws).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential_ratio: Option<f64>,
}

impl DampingParams for TsujiTable {
    /// e ∈ [0, 1]; the ratio ≥ 0.
    fn build(&self, at: &DampingContext) -> Result<(NormalDamping, TangentialDamping)> {
        let e = self.restitution;
        if !(0.0..=1.0).contains(&e) {
            return Err(CoreError::invalid(at.key("restitution"), e, "a restitution coefficient in [0, 1]"));
        }
        let default = if at.is_hertz() { 1.0 } else { 0.5 };
        let tangential = at.tangential(self.tangential_ratio, None, FractionOfNormal { ratio: default }.into())?;
        Ok((Tsuji { alpha: tsuji_alpha(e) }.into(), tangential))
    }
}
