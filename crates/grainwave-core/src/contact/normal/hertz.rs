//! Hertz normal law: F_el = (4/3) E* √R* ξ^{3/2}, k_n = 2 E* √(R* ξ), secant (4/3) E* √(R* ξ).

use super::{Composition, NormalContext, NormalLaw, NormalResponse};
use crate::contact::params::require_modulus;
use crate::contact::Partner;
use crate::error::{require_positive, CoreError, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// Hertz F_el = (4/3) E*_ij √R* ξ^{3/2}; k_n = 2 E*_ij √(R* ξ); stored energy
/// (8/15) E*_ij √R* ξ^{5/2} (the `hertz_mindlin` composition).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Hertz {
    /// Effective modulus E*_ij of the pair (grain–grain: (1/E*_i + 1/E*_j)⁻¹ = E*/2 for one
    /// material; rigid wall: E*_i), E* = E/(1 − ν²).
    pub effective_modulus: f64,
}

/// The `[contact.normal]` table of the Hertz law: the grains' material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct HertzParams {
    /// Young's modulus E of the grains.
    pub young: f64,
    /// Poisson's ratio ν, default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poisson: Option<f64>,
}

impl NormalLaw for Hertz {
    type Params = HertzParams;
    type History = ();

    fn composition(params: &HertzParams) -> Composition {
        Composition::Hertz { young: params.young, poisson: params.poisson }
    }

    /// E*_ij = factor × E/(1 − ν²), factor ½ between two grains and 1 against a rigid wall.
    fn build(params: &HertzParams, at: &NormalContext) -> Result<Self> {
        let key = |k: &str| format!("{}.normal.{k}", at.field);
        require_modulus(&key("young"), params.young)?;
        let nu = params.poisson.unwrap_or(0.0);
        if !(nu.is_finite() && (-1.0..0.5).contains(&nu)) {
            return Err(CoreError::invalid(key("poisson"), nu, "a Poisson ratio in [-1, 0.5)"));
        }
        let e_star = params.young / (1.0 - nu * nu);
        let factor = match at.partner {
            Partner::Grain => 0.5,
            Partner::Wall => 1.0,
        };
        Ok(Hertz { effective_modulus: factor * e_star })
    }

    fn validate(&self, field: &str) -> Result<()> {
        require_positive(&format!("{field}.young"), self.effective_modulus)
    }

    #[inline(always)]
    fn response_lanes<R: Real>(&self, xi: R, r_eff: R, _history: &mut ()) -> NormalResponse<R> {
        let a = (r_eff * xi).sqrt(); // contact radius
        let secant = R::splat(4.0 / 3.0 * self.effective_modulus) * a;
        NormalResponse { force: secant * xi, stiffness: R::splat(2.0 * self.effective_modulus) * a, secant }
    }

    fn energy(&self, xi: f64, r_eff: f64, _history: &()) -> f64 {
        8.0 / 15.0 * self.effective_modulus * r_eff.sqrt() * xi.powf(2.5)
    }

    fn max_stiffness(&self, xi: f64, r_eff: f64) -> f64 {
        self.response_lanes(xi, r_eff, &mut ()).stiffness
    }
}
