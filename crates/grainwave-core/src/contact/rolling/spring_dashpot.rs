//! The spring–dashpot resistance with a Coulomb-like cap (SPEC §2.5), as rolling or twisting
//! resistance: with the stored rotation θ (θ_r in the tangent plane, or φ about the normal) and
//! the relative angular velocity w, θ ← θ + w Δt and the torque on grain i is
//! M = k θ + γ w, capped at |M| ≤ μ R* F_n; where capped the spring is reset to θ = M/k.

use crate::contact::{coulomb_cap_lanes, ResistanceLaw};
use crate::error::{require_non_negative, require_positive, CoreError, Result};
use crate::real::{Real, Vec3};
use serde::{Deserialize, Serialize};

/// Spring–dashpot with a Coulomb-like cap μ R* F_n.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpringDashpot {
    /// k (torque/radian), > 0.
    pub stiffness: f64,
    /// γ (torque·time/radian), ≥ 0.
    pub damping: f64,
    /// μ (dimensionless), ≥ 0, may be ∞ (no cap); the cap is μ R* F_n.
    pub friction: f64,
}

impl ResistanceLaw for SpringDashpot {
    /// `{key}_stiffness` > 0, `{key}_damping` ≥ 0, `{key}_friction` ≥ 0 (may be ∞).
    fn validate(&self, key: &str) -> Result<()> {
        require_positive(&format!("{key}_stiffness"), self.stiffness)?;
        require_non_negative(&format!("{key}_damping"), self.damping)?;
        if !(self.friction >= 0.0) || self.friction.is_nan() {
            return Err(CoreError::invalid(format!("{key}_friction"), self.friction, "a number ≥ 0 (may be inf)"));
        }
        Ok(())
    }

    fn max_stiffness(&self) -> f64 {
        self.stiffness
    }

    /// ½ k |θ|².
    fn energy(&self, rotation_sq: f64) -> f64 {
        0.5 * self.stiffness * rotation_sq
    }

    #[inline(always)]
    fn step_lanes<R: Real, const N: usize>(&self, stored: Vec3<R>, w: Vec3<R>, r_eff: R, f_n: R, dt: f64) -> (Vec3<R>, Vec3<R>) {
        let zero = R::splat(0.0);
        let (k, gamma, dt) = (R::splat(self.stiffness), R::splat(self.damping), R::splat(dt));
        let (mut theta, mut trial) = ([zero; 3], [zero; 3]);
        for c in 0..N {
            theta[c] = stored[c] + w[c] * dt;
            trial[c] = theta[c] * k + w[c] * gamma;
        }
        let (m, slid) = coulomb_cap_lanes::<R, N>(trial, R::splat(self.friction) * r_eff * f_n);
        let mut rotation = stored;
        for c in 0..N {
            rotation[c] = R::select(slid, m[c] / k, theta[c]);
        }
        (m, rotation)
    }
}
