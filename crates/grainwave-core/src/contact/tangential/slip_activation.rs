//! The slip-activation law ([`SlipActivation`]): a linear tangential spring whose excess over
//! the Coulomb length relaxes in a time τ instead of being cut at once (the E2 paper's Eq. 13).
//! The law, its parameter (τ, with its checks), the validation of a law made in code and its
//! step past the Coulomb cap are here; the history (the spring elongation D_t, a length) and
//! the increment are the linear law's (`contact/tangential/linear.rs`).
//!
//! The law: with D_tᶜ = μ F_n/K_t along D_t,
//!
//! Ḋ_t = v_t − Θ(|D_t| − D_tᶜ) (D_t − D_tᶜ)/τ,
//!
//! so a contact may hold more than μ F_n for a time of order τ: it slides at loading time scales
//! (≫ τ) and sticks at acoustic ones (≪ τ); τ → 0 is the Coulomb cap of [`Linear`].

use super::linear::linear_spring_parts;
use super::linear::spring_stiffness;
use super::{HistoryKind, Linear, Tangential, TangentialContext, TangentialLaw};
use crate::error::{CoreError, Result};
use crate::real::{select3, Real, Vec3};
use serde::{Deserialize, Serialize};

/// Linear spring with a slip-activation time τ (the E2 paper's proposed law, its Eq. 13): the
/// spring elongation D_t obeys
///
/// Ḋ_t = v_t − Θ(|D_t| − D_tᶜ) (D_t − D_tᶜ)/τ,  D_tᶜ = μ F_n/K_t (along D_t),
///
/// so a contact may hold more than μ F_n for a time of order τ: it slides at loading time
/// scales (≫ τ) and sticks at acoustic ones (≪ τ). τ → 0 is the Coulomb cap of [`Linear`].
/// Integrated by backward Euler over each step (unconditionally stable, exact steady slide
/// D_t = D_tᶜ + v_t τ). History: the spring D_t (a length), as the linear law.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SlipActivation {
    /// K_t (force/length).
    pub stiffness: f64,
    /// τ (time), > 0.
    pub activation_time: f64,
}

impl SlipActivation {
    /// The spring without the slip activation: the linear law of the same K_t, whose history,
    /// stiffness, elastic force and increment this law shares.
    #[inline(always)]
    fn spring(&self) -> Linear {
        Linear { stiffness: self.stiffness }
    }
}

/// `[contact.tangential]` with `law = "slip_activation"`: K_t = `stiffness_ratio` × k_n of the
/// linear normal law and τ = `slip_activation_time` > 0 — the law `law = "linear"` gives with
/// the same keys and τ > 0, written by its own name.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct SlipActivationTable {
    /// K_t / k_n, default 2/7.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness_ratio: Option<f64>,
    /// τ [time], finite and > 0.
    pub slip_activation_time: f64,
}

impl TangentialLaw for SlipActivation {
    const HISTORY: HistoryKind = HistoryKind::Displacement;
    type Extra = ();
    type Params = SlipActivationTable;

    fn build(params: &SlipActivationTable, at: &TangentialContext) -> Result<Tangential> {
        let stiffness = spring_stiffness(params.stiffness_ratio, at, "slip_activation")?;
        let tau = params.slip_activation_time;
        if !(tau > 0.0 && tau.is_finite()) {
            // (τ = 0, the Coulomb cap, is `law = "linear"`)
            return Err(CoreError::invalid(at.key("slip_activation_time"), tau, "a finite time τ > 0 (the Coulomb cap, τ = 0, is `law = \"linear\"`)"));
        }
        let law = SlipActivation { stiffness, activation_time: tau };
        law.validate(&format!("{}.tangential", at.field))?;
        Ok(law.into())
    }

    /// K_t > 0 (the linear law's check) and finite τ > 0 (a law with τ = 0 is the linear law
    /// and is written as one).
    fn validate(&self, field: &str) -> Result<()> {
        self.spring().validate(field)?;
        if !(self.activation_time > 0.0 && self.activation_time.is_finite()) {
            return Err(CoreError::invalid(
                format!("{field}.slip_activation_time"),
                self.activation_time,
                "a finite time τ > 0 (0 is the Coulomb cap: leave the key out or set 0)",
            ));
        }
        Ok(())
    }

    linear_spring_parts!();

    /// The excess over the cap relaxed by τ/(τ + Δt) ([`relax_lanes`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn sliding_lanes<R: Real, const N: usize>(&self, dt: f64, f: Vec3<R>, at_cap: Vec3<R>, trial: Vec3<R>, kept: Vec3<R>, sliding: R::Mask) -> (Vec3<R>, Vec3<R>) {
        relax_lanes::<R, N>(self.activation_time, dt, f, at_cap, trial, kept, sliding)
    }
}

/// The slip-activation parameter as a config gives it: the key `slip_activation_time`, τ
/// [time], ≥ 0, absent or 0 for the Coulomb cap (the plain linear law, bit for bit). Read from
/// the flat key `slip_activation_time` of the `hooke_cundall_strack` preset or from
/// `[contact.tangential]` with `law = "linear"`; unknown keys are refused.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct SlipActivationParams {
    /// τ [time], ≥ 0 (0: the Coulomb cap).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slip_activation_time: Option<f64>,
}

impl SlipActivationParams {
    /// The activation time τ checked: `None` for the Coulomb cap (absent or exactly 0), `Some(τ)`
    /// for a finite τ > 0; anything else an error naming `key` (the key the value was read
    /// from, e.g. `contact.slip_activation_time`), the value and what is allowed.
    pub fn activation_time(&self, key: &str) -> Result<Option<f64>> {
        match self.slip_activation_time {
            None => Ok(None),
            Some(t) if t == 0.0 => Ok(None),
            Some(t) if t > 0.0 && t.is_finite() => Ok(Some(t)),
            Some(t) => Err(CoreError::invalid(key, t, "a finite time τ ≥ 0 (0: the Coulomb cap)")),
        }
    }

    /// The tangential law with spring stiffness K_t = `stiffness` [force/length]: the linear law
    /// for the Coulomb cap (τ absent or 0), the slip-activation law otherwise; errors as
    /// [`SlipActivationParams::activation_time`].
    pub fn build(&self, stiffness: f64, key: &str) -> Result<Tangential> {
        Ok(match self.activation_time(key)? {
            None => Linear { stiffness }.into(),
            Some(activation_time) => SlipActivation { stiffness, activation_time }.into(),
        })
    }
}

/// The step of a sliding contact, on every lane, by backward Euler over the step `dt`: with
/// x = |D_t| − D_tᶜ the excess over the history that holds the Coulomb force,
/// x_new = x_old + v_t Δt − (Δt/τ) x_new, i.e. x_new = w x_trial with w = τ/(τ + Δt)
/// (x_trial = x_old + v_t Δt, the excess of the incremented spring). Unconditionally stable;
/// steady sliding keeps x = v_t τ exactly; τ → 0 gives w = 0, the Coulomb cap. The force is the
/// capped force plus the same fraction of the trial force's excess (F = K_t D_t + γ_t v_t,
/// linear in D_t).
///
/// From the capped force `f` and the history that holds it (`at_cap`), the trial force and
/// the incremented history (`trial`, `kept`) and where the contact slides: the force on i and
/// the history to store (the relaxed ones where it slides, the trial ones where it sticks).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn relax_lanes<R: Real, const N: usize>(
    activation_time: f64,
    dt: f64,
    f: Vec3<R>,
    at_cap: Vec3<R>,
    trial: Vec3<R>,
    kept: Vec3<R>,
    sliding: R::Mask,
) -> (Vec3<R>, Vec3<R>) {
    let w = R::splat(activation_time / (activation_time + dt));
    let (mut history, mut force) = ([R::splat(0.0); 3], [R::splat(0.0); 3]);
    for c in 0..N {
        history[c] = at_cap[c] + w * (kept[c] - at_cap[c]);
        force[c] = f[c] + w * (trial[c] - f[c]);
    }
    (select3::<R>(sliding, force, f), select3::<R>(sliding, history, kept))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// τ absent or 0 is the linear law; τ > 0 the slip-activation law with the same K_t;
    /// negative, infinite or NaN τ are refused naming the key, the value and what is allowed;
    /// a misspelt key is refused.
    #[test]
    fn params_build_the_law_or_name_the_key() {
        let p = |t| SlipActivationParams { slip_activation_time: t };
        let key = "contact.tangential.slip_activation_time";
        assert_eq!(p(None).build(3.0, key).unwrap(), Tangential::Linear(Linear { stiffness: 3.0 }));
        assert_eq!(p(Some(0.0)).build(3.0, key).unwrap(), Tangential::Linear(Linear { stiffness: 3.0 }));
        assert_eq!(p(Some(0.25)).build(3.0, key).unwrap(), Tangential::SlipActivation(SlipActivation { stiffness: 3.0, activation_time: 0.25 }));
        for bad in [-1.0, f64::INFINITY, f64::NAN] {
            let e = p(Some(bad)).build(3.0, key).unwrap_err().to_string();
            assert!(e.contains(key) && e.contains("τ ≥ 0"), "{e}");
        }
        let e = serde_json::from_str::<SlipActivationParams>(r#"{"slip_activation_tme": 1.0}"#).unwrap_err().to_string();
        assert!(e.contains("slip_activation_tme"), "{e}");
        let law = |stiffness, activation_time| SlipActivation { stiffness, activation_time };
        assert!(law(3.0, 0.25).validate("contact").is_ok());
        let e = law(3.0, 0.0).validate("contact").unwrap_err().to_string();
        assert!(e.contains("contact.slip_activation_time") && e.contains("τ > 0"), "{e}");
        assert!(law(0.0, 0.25).validate("contact").unwrap_err().to_string().contains("contact.tangential_stiffness"));
    }

    /// One sliding step against the closed form: excess x_new = τ/(τ + Δt) x_trial, on the
    /// history and (F linear in D_t) on the force; a sticking lane keeps the trial values.
    #[test]
    fn a_sliding_step_relaxes_the_excess_by_tau_over_tau_plus_dt() {
        let (tau, dt, k) = (3.0e-3, 1.0e-3, 2.0);
        let at_cap = [0.5, 0.0, 0.0];
        let kept = [0.9, 0.0, 0.0];
        let f = [k * 0.5, 0.0, 0.0];
        let trial = [k * 0.9, 0.0, 0.0];
        let (force, history) = relax_lanes::<f64, 3>(tau, dt, f, at_cap, trial, kept, true);
        let w = tau / (tau + dt); // ¾
        assert_eq!(history[0], 0.5 + w * (0.9 - 0.5));
        assert_eq!(force[0], k * 0.5 + w * (k * 0.9 - k * 0.5));
        assert!((history[0] - 0.8).abs() < 1e-15 && (force[0] - 1.6).abs() < 1e-15);
        let (force, history) = relax_lanes::<f64, 3>(tau, dt, f, at_cap, trial, kept, false);
        assert_eq!((force, history), (f, kept));
    }
}
