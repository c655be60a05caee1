//! Linear normal spring (Hooke): F_el = k_n ξ, differential and secant stiffness k_n.

use super::{Composition, NormalContext, NormalLaw, NormalResponse};
use crate::contact::params::require_modulus;
use crate::error::{require_positive, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// Linear spring F_el = k_n ξ (the `hooke_cundall_strack` composition); stored energy ½ k_n ξ².
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct Hooke {
    /// k_n [force/length].
    pub stiffness: f64,
}

impl NormalLaw for Hooke {
    type Params = Hooke;
    type History = ();

    fn composition(params: &Hooke) -> Composition {
        Composition::Hooke { stiffness: params.stiffness, key: "stiffness" }
    }

    fn build(params: &Hooke, at: &NormalContext) -> Result<Self> {
        require_modulus(&format!("{}.normal.stiffness", at.field), params.stiffness)?;
        Ok(*params)
    }

    fn validate(&self, field: &str) -> Result<()> {
        require_positive(&format!("{field}.normal_stiffness"), self.stiffness)
    }

    #[inline(always)]
    fn response_lanes<R: Real>(&self, xi: R, _r_eff: R, _history: &mut ()) -> NormalResponse<R> {
        let k = R::splat(self.stiffness);
        NormalResponse { force: k * xi, stiffness: k, secant: k }
    }

    fn energy(&self, xi: f64, _r_eff: f64, _history: &()) -> f64 {
        0.5 * self.stiffness * xi * xi
    }

    fn max_stiffness(&self, _xi: f64, _r_eff: f64) -> f64 {
        self.stiffness
    }
}
