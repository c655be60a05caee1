//! Normal elastic part (SPEC §2.1): Hooke and Hertz.

use super::HystereticNormal;
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// Normal elastic force law F_el(ξ) and its differential stiffness k_n = dF_el/dξ.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NormalElastic {
    /// F = k_n ξ.
    Hooke {
        /// Stiffness k_n (force/length).
        stiffness: f64,
    },
    /// F = (4/3) E*_ij √R* ξ^{3/2}; k_n = 2 E*_ij √(R* ξ).
    Hertz {
        /// Effective modulus E*_ij of the pair (grain–grain: (1/E*_i + 1/E*_j)⁻¹; rigid wall: E*_i).
        effective_modulus: f64,
    },
    /// Hysteretic linear law with per-contact history ([`HystereticNormal`]).
    Hysteretic(HystereticNormal),
}

/// What the normal elastic part gives at one overlap (`R` = `f64`), or at one overlap per lane
/// (the engine's vector paths).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalResponse<R = f64> {
    /// Elastic force F_el(ξ) ≥ 0.
    pub force: R,
    /// Differential stiffness k_n = dF_el/dξ.
    pub stiffness: R,
    /// Secant stiffness F_el/ξ (Hooke: k_n; Hertz: (4/3) E*_ij √(R* ξ) = ⅔ k_n).
    pub secant: R,
}

impl NormalElastic {
    /// Elastic force (≥ 0) and differential stiffness at overlap `xi` > 0 for effective radius `r_eff`.
    #[inline]
    pub fn force_stiffness(&self, xi: f64, r_eff: f64) -> (f64, f64) {
        let r = self.response(xi, r_eff);
        (r.force, r.stiffness)
    }

    /// Elastic force, differential and secant stiffness at overlap `xi` > 0 for effective radius
    /// `r_eff`.
    #[inline]
    pub fn response(&self, xi: f64, r_eff: f64) -> NormalResponse {
        self.response_lanes(xi, r_eff)
    }

    /// [`NormalElastic::response`] on every lane: the one implementation of the normal law, run
    /// by the general kernel (`f64`) and by the engine's vector paths (the match is on the law's
    /// parameters, the same for every lane; the arithmetic is lane by lane).
    #[inline(always)]
    pub(crate) fn response_lanes<R: Real>(&self, xi: R, r_eff: R) -> NormalResponse<R> {
        match *self {
            NormalElastic::Hooke { stiffness } => {
                let k = R::splat(stiffness);
                NormalResponse { force: k * xi, stiffness: k, secant: k }
            }
            NormalElastic::Hertz { effective_modulus } => {
                let a = (r_eff * xi).sqrt(); // contact radius
                let secant = R::splat(4.0 / 3.0 * effective_modulus) * a;
                NormalResponse { force: secant * xi, stiffness: R::splat(2.0 * effective_modulus) * a, secant }
            }
            NormalElastic::Hysteretic(h) => h.response_lanes(xi),
        }
    }

    /// Stored elastic energy ∫₀^ξ F dξ: ½ k ξ² (Hooke), (8/15) E* √R* ξ^{5/2} (Hertz).
    pub fn energy(&self, xi: f64, r_eff: f64) -> f64 {
        match *self {
            NormalElastic::Hooke { stiffness } => 0.5 * stiffness * xi * xi,
            NormalElastic::Hertz { effective_modulus } => 8.0 / 15.0 * effective_modulus * r_eff.sqrt() * xi.powf(2.5),
            NormalElastic::Hysteretic(h) => h.energy(xi),
        }
    }
}
