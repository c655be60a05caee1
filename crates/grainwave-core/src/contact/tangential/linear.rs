//! The linear tangential law (Cundall–Strack, SPEC §2.3): a spring on the tangential
//! displacement, F_t = k_t s + γ_t v_t on grain i with s ← s + v_t Δt, capped at μ F_n (the
//! spring reset to s = F_t/k_t where the contact slides). History: the spring elongation s, a
//! length.

use super::{HistoryKind, SlipActivationParams, Tangential, TangentialContext, TangentialLaw};
use crate::dim::VectorOps;
use crate::error::{require_positive, CoreError, Result};
use crate::real::{Real, Vec3};
use serde::{Deserialize, Serialize};

/// Linear spring on the tangential displacement s (Cundall–Strack): F_t = k_t s + γ_t v_t.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Linear {
    /// k_t (force/length).
    pub stiffness: f64,
}

/// `[contact.tangential]` with `law = "linear"`: k_t = `stiffness_ratio` × k_n of the linear
/// normal law (`hooke`, or `hysteretic`'s loading stiffness), capped at μ F_n — or, with
/// `slip_activation_time` τ > 0, the slip-activation law of the same spring
/// ([`SlipActivation`](super::SlipActivation)); the flat keys `tangential_stiffness_ratio` and
/// `slip_activation_time` of `hooke_cundall_strack`, to the bit.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct LinearTable {
    /// k_t / k_n, default 2/7.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness_ratio: Option<f64>,
    /// Slip-activation time τ ≥ 0 (0: the Coulomb cap), see docs/engine.md.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slip_activation_time: Option<f64>,
}

/// k_t = ratio × k_n (ratio default 2/7) for the law `law` of a `[contact.tangential]` table
/// beside a linear normal law: the ratio > 0 and the product a finite, normal number, errors
/// naming `{field}.tangential.stiffness_ratio`. The one reading of `stiffness_ratio` of the
/// laws built on the linear spring.
pub(crate) fn spring_stiffness(stiffness_ratio: Option<f64>, at: &TangentialContext, law: &str) -> Result<f64> {
    let k_n = at.hooke_stiffness(law)?;
    let key = at.key("stiffness_ratio");
    let ratio = stiffness_ratio.unwrap_or(2.0 / 7.0);
    require_positive(&key, ratio)?;
    // the product checked under the key the file has (a vanishing ratio such as 1e-300, a
    // "no tangential spring", stays allowed)
    let k_t = ratio * k_n;
    if !(k_t.is_finite() && k_t.is_normal()) {
        return Err(CoreError::invalid(key, format!("{ratio:?}"), format!("a ratio that makes k_t = ratio × k_n a finite, normal number (here {k_t:?})")));
    }
    Ok(k_t)
}

impl TangentialLaw for Linear {
    const HISTORY: HistoryKind = HistoryKind::Displacement;
    type Extra = ();
    type Params = LinearTable;

    /// k_t = ratio × k_n; the slip-activation law where τ > 0 (as the flat keys).
    fn build(params: &LinearTable, at: &TangentialContext) -> Result<Tangential> {
        let k_t = spring_stiffness(params.stiffness_ratio, at, "linear")?;
        SlipActivationParams { slip_activation_time: params.slip_activation_time }.build(k_t, &at.key("slip_activation_time"))
    }

    fn validate(&self, field: &str) -> Result<()> {
        require_positive(&format!("{field}.tangential_stiffness"), self.stiffness)
    }

    #[inline(always)]
    fn stiffness_lanes<R: Real>(&self, _xi: R, _r_eff: R) -> R {
        R::splat(self.stiffness)
    }

    #[inline]
    fn elastic_force<V: VectorOps>(&self, h: V) -> V {
        h * self.stiffness
    }

    /// s ← s + v_t Δt, trial F_t = k_t s + γ_t v_t.
    #[inline(always)]
    fn trial_lanes<R: Real, const N: usize>(&self, rotated: Vec3<R>, v_t: Vec3<R>, k_t: R, gamma_t: R, dt: f64) -> (Vec3<R>, Vec3<R>) {
        let zero = R::splat(0.0);
        let (mut kept, mut trial) = ([zero; 3], [zero; 3]);
        for c in 0..N {
            kept[c] = rotated[c] + v_t[c] * R::splat(dt);
            trial[c] = kept[c] * k_t + v_t[c] * gamma_t;
        }
        (trial, kept)
    }

    /// s = F_t/k_t.
    #[inline(always)]
    fn history_for_force_lanes<R: Real, const N: usize>(&self, f: Vec3<R>) -> Vec3<R> {
        let mut h = [R::splat(0.0); 3];
        for c in 0..N {
            h[c] = f[c] / R::splat(self.stiffness);
        }
        h
    }
}

/// The parts of `impl TangentialLaw` that a law built on the linear spring shares with it —
/// its stiffness, elastic force, increment (s ← s + v_t Δt, trial F_t = k_t s + γ_t v_t) and
/// reset (s = F_t/k_t) — delegated to the law's `fn spring(&self) -> Linear` (the linear law
/// of the same k_t). Written inside the law's `impl TangentialLaw` block:
/// `linear_spring_parts!();` (the slip-activation and slip-weakening laws).
macro_rules! linear_spring_parts {
    () => {
        #[inline(always)]
        fn stiffness_lanes<R: $crate::real::Real>(&self, xi: R, r_eff: R) -> R {
            self.spring().stiffness_lanes(xi, r_eff)
        }

        #[inline]
        fn elastic_force<V: $crate::dim::VectorOps>(&self, h: V) -> V {
            self.spring().elastic_force(h)
        }

        /// The linear law's: s ← s + v_t Δt, trial F_t = k_t s + γ_t v_t.
        #[inline(always)]
        fn trial_lanes<R: $crate::real::Real, const N: usize>(
            &self,
            rotated: $crate::real::Vec3<R>,
            v_t: $crate::real::Vec3<R>,
            k_t: R,
            gamma_t: R,
            dt: f64,
        ) -> ($crate::real::Vec3<R>, $crate::real::Vec3<R>) {
            self.spring().trial_lanes::<R, N>(rotated, v_t, k_t, gamma_t, dt)
        }

        /// The linear law's: s = F_t/k_t.
        #[inline(always)]
        fn history_for_force_lanes<R: $crate::real::Real, const N: usize>(&self, f: $crate::real::Vec3<R>) -> $crate::real::Vec3<R> {
            self.spring().history_for_force_lanes::<R, N>(f)
        }
    };
}
pub(crate) use linear_spring_parts;
