//! The linear tangential law (Cundall–Strack, SPEC §2.3): a spring on the tangential
//! displacement, F_t = k_t s + γ_t v_t on grain i with s ← s + v_t Δt, capped at μ F_n (the
//! spring reset to s = F_t/k_t where the contact slides). History: the spring elongation s, a
//! length.

use super::{HistoryKind, TangentialLaw};
use crate::dim::VectorOps;
use crate::error::{require_positive, Result};
use crate::real::{Real, Vec3};
use serde::{Deserialize, Serialize};

/// Linear spring on the tangential displacement s (Cundall–Strack): F_t = k_t s + γ_t v_t.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Linear {
    /// k_t (force/length).
    pub stiffness: f64,
}

impl TangentialLaw for Linear {
    const HISTORY: HistoryKind = HistoryKind::Displacement;
    type Extra = ();

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
