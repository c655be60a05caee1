//! The incremental Mindlin tangential law (SPEC §2.3, Hertz–Mindlin contacts): the elastic
//! tangential force itself is the history, F_el ← F_el + k_t(ξ) v_t Δt with
//! k_t(ξ) = 8 G*_ij √(R* ξ), trial F_t = F_el + γ_t v_t, capped at μ F_n (F_el reset to the
//! capped force where the contact slides). History: the elastic tangential force, a force.

use super::{HistoryKind, Tangential, TangentialContext, TangentialLaw};
use crate::contact::Partner;
use crate::dim::VectorOps;
use crate::error::{require_positive, Result};
use crate::real::{Real, Vec3};
use serde::{Deserialize, Serialize};

/// Incremental Mindlin: ΔF_t = k_t(ξ) v_t Δt with k_t(ξ) = 8 G*_ij √(R* ξ).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mindlin {
    /// Effective shear modulus G*_ij (grain–grain: (1/G*_i + 1/G*_j)⁻¹; rigid wall: G*_i).
    pub effective_shear_modulus: f64,
    /// When the overlap decreases, rescale the stored force by k_t(new)/k_t(old)
    /// (default off: the stored force is kept, as in the plain incremental law).
    pub rescale_on_unloading: bool,
}

impl Mindlin {
    /// The law of grains of Young's modulus E and Poisson's ratio ν (SPEC §2.3):
    /// G* = E/[2(1 + ν)(2 − ν)] per grain, halved for a grain–grain pair (two equal grains),
    /// whole against a rigid wall.
    pub fn of_grains(young: f64, poisson: f64, partner: Partner, rescale_on_unloading: bool) -> Mindlin {
        let g_star = young / (2.0 * (1.0 + poisson) * (2.0 - poisson));
        let factor = match partner {
            Partner::Grain => 0.5,
            Partner::Wall => 1.0,
        };
        Mindlin { effective_shear_modulus: factor * g_star, rescale_on_unloading }
    }
}

/// `[contact.tangential]` with `law = "mindlin"`: G* from the Hertz normal law's E and ν
/// ([`Mindlin::of_grains`]); the flat key `mindlin_rescale` of `hertz_mindlin`, to the bit.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct MindlinTable {
    /// Rescale the stored force by k_t(new)/k_t(old) when the overlap decreases (default false).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rescale_on_unloading: Option<bool>,
}

impl TangentialLaw for Mindlin {
    const HISTORY: HistoryKind = HistoryKind::Force;
    type Extra = ();
    type Params = MindlinTable;

    fn build(params: &MindlinTable, at: &TangentialContext) -> Result<Tangential> {
        let (young, poisson) = at.hertz_moduli("mindlin")?;
        Ok(Mindlin::of_grains(young, poisson, at.partner, params.rescale_on_unloading.unwrap_or(false)).into())
    }

    fn validate(&self, field: &str) -> Result<()> {
        require_positive(&format!("{field}.shear_modulus"), self.effective_shear_modulus)
    }

    #[inline(always)]
    fn stiffness_lanes<R: Real>(&self, xi: R, r_eff: R) -> R {
        R::splat(8.0 * self.effective_shear_modulus) * (r_eff * xi).sqrt()
    }

    #[inline]
    fn elastic_force<V: VectorOps>(&self, h: V) -> V {
        h
    }

    /// F_el ← F_el + k_t v_t Δt, trial F_t = F_el + γ_t v_t.
    #[inline(always)]
    fn trial_lanes<R: Real, const N: usize>(&self, rotated: Vec3<R>, v_t: Vec3<R>, k_t: R, gamma_t: R, dt: f64) -> (Vec3<R>, Vec3<R>) {
        let zero = R::splat(0.0);
        let (mut kept, mut trial) = ([zero; 3], [zero; 3]);
        let kdt = k_t * R::splat(dt);
        for c in 0..N {
            kept[c] = rotated[c] + v_t[c] * kdt;
            trial[c] = kept[c] + v_t[c] * gamma_t;
        }
        (trial, kept)
    }

    /// F_el = F_t.
    #[inline(always)]
    fn history_for_force_lanes<R: Real, const N: usize>(&self, f: Vec3<R>) -> Vec3<R> {
        f
    }

    /// With `rescale_on_unloading`: k_t ∝ √ξ, so where the overlap decreased (ξ_old > 0 and
    /// ξ < ξ_old) the stored force × √(ξ/ξ_old), elsewhere × 1 (the same bits).
    #[inline(always)]
    fn unloading_lanes<R: Real, const N: usize>(&self, rotated: Vec3<R>, was: R, overlap: R) -> Vec3<R> {
        if !self.rescale_on_unloading {
            return rotated;
        }
        let (zero, one) = (R::splat(0.0), R::splat(1.0));
        let scale = R::select(was.gt(overlap), (overlap / was).sqrt(), one);
        let scale = R::select(was.gt(zero), scale, one);
        let mut out = rotated;
        for c in 0..N {
            out[c] = rotated[c] * scale;
        }
        out
    }
}
