//! Tangential part with history (SPEC §2.3): linear (Cundall–Strack) and incremental Mindlin.
//!
//! Sign convention: `v_t` is the tangential velocity of grain j relative to grain i at the contact
//! point, and the history and forces are those acting **on grain i**: a Cundall–Strack spring
//! stores s = ∫ v_t dt and pulls i along, F_t(on i) = k_t s + γ_t v_t (equivalently, on j,
//! −k_t s − γ_t v_t as in SPEC §2.3).

use super::coulomb::coulomb_cap_lanes;
use crate::real::{select3, Real, Vec3};
use serde::{Deserialize, Serialize};

/// Tangential elastic law.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Tangential {
    /// No tangential force (frictionless).
    None,
    /// Linear spring on the tangential displacement s (Cundall–Strack): F_t = k_t s + γ_t v_t.
    /// History: the spring s.
    Linear {
        /// k_t (force/length).
        stiffness: f64,
    },
    /// Incremental Mindlin: ΔF_t = k_t(ξ) v_t Δt with k_t(ξ) = 8 G*_ij √(R* ξ).
    /// History: the elastic tangential force.
    Mindlin {
        /// Effective shear modulus G*_ij (grain–grain: (1/G*_i + 1/G*_j)⁻¹; rigid wall: G*_i).
        effective_shear_modulus: f64,
        /// When the overlap decreases, rescale the stored force by k_t(new)/k_t(old)
        /// (default off: the stored force is kept, as in the plain incremental law).
        rescale_on_unloading: bool,
    },
}

impl Tangential {
    /// Tangential stiffness at overlap `xi` for effective radius `r_eff`.
    #[inline]
    pub fn stiffness(&self, xi: f64, r_eff: f64) -> f64 {
        self.stiffness_lanes(xi, r_eff)
    }

    /// [`Tangential::stiffness`] on every lane: the one implementation, run by the general kernel
    /// (`f64`) and the engine's vector paths.
    #[inline(always)]
    pub(crate) fn stiffness_lanes<R: Real>(&self, xi: R, r_eff: R) -> R {
        match *self {
            Tangential::None => R::splat(0.0),
            Tangential::Linear { stiffness } => R::splat(stiffness),
            Tangential::Mindlin { effective_shear_modulus, .. } => R::splat(8.0 * effective_shear_modulus) * (r_eff * xi).sqrt(),
        }
    }

    /// One step of the spring, on every lane, from the stored history already rotated into the
    /// current tangent plane (`rotated`), the tangential velocity `v_t`, k_t, γ_t and the step
    /// `dt`: the trial force on i (before the Coulomb cap) and the history to keep when the
    /// contact does not slide. The history is law-specific:
    ///
    /// - `Linear` (Cundall–Strack) stores the spring elongation s (a length):
    ///   s ← s + v_t Δt, trial F_t = k_t s + γ_t v_t;
    /// - `Mindlin` stores the elastic tangential force (a force):
    ///   F_el ← F_el + k_t v_t Δt, trial F_t = F_el + γ_t v_t;
    /// - `None` keeps its (zero) history and gives no force.
    ///
    /// The one implementation of both laws' increments (general kernel and vector paths).
    #[inline(always)]
    pub(crate) fn trial_lanes<R: Real, const N: usize>(&self, rotated: Vec3<R>, v_t: Vec3<R>, k_t: R, gamma_t: R, dt: f64) -> (Vec3<R>, Vec3<R>) {
        let zero = R::splat(0.0);
        let (mut kept, mut trial) = ([zero; 3], [zero; 3]);
        match *self {
            Tangential::None => kept = rotated,
            Tangential::Linear { .. } => {
                for c in 0..N {
                    kept[c] = rotated[c] + v_t[c] * R::splat(dt);
                    trial[c] = kept[c] * k_t + v_t[c] * gamma_t;
                }
            }
            Tangential::Mindlin { .. } => {
                let kdt = k_t * R::splat(dt);
                for c in 0..N {
                    kept[c] = rotated[c] + v_t[c] * kdt;
                    trial[c] = kept[c] + v_t[c] * gamma_t;
                }
            }
        }
        (trial, kept)
    }

    /// The history that holds exactly the tangential force `f` (kept when the contact slides,
    /// so that the spring is reset to the Coulomb cap): s = F_t/k_t for the linear law, F_t
    /// itself for Mindlin (zero for `None`).
    #[inline(always)]
    pub(crate) fn history_for_force_lanes<R: Real, const N: usize>(&self, f: Vec3<R>) -> Vec3<R> {
        let mut h = [R::splat(0.0); 3];
        match *self {
            Tangential::None => {}
            Tangential::Linear { stiffness } => {
                for c in 0..N {
                    h[c] = f[c] / R::splat(stiffness);
                }
            }
            Tangential::Mindlin { .. } => h = f,
        }
        h
    }
}

/// Tangential viscous damping γ_t.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TangentialDamping {
    /// No tangential damping.
    None,
    /// Constant γ_t.
    Coefficient {
        /// γ_t (force/velocity).
        coefficient: f64,
    },
    /// γ_t = ratio × γ_n (E2 and the classic Hooke law use ½).
    FractionOfNormal {
        /// γ_t / γ_n.
        ratio: f64,
    },
    /// γ_t = ζ · 2 √(m* k_t) (E1: the same ζ as the normal part).
    CriticalFraction {
        /// ζ.
        zeta: f64,
    },
    /// γ_t = rate × m* (LAMMPS `gran/hooke/history`'s `gamma_t`, in 1/time).
    MassProportional {
        /// γ_t / m* (1/time).
        rate: f64,
    },
}

impl TangentialDamping {
    /// γ_t for effective mass `m_eff`, tangential stiffness `k_t` and normal coefficient `gamma_n`.
    #[inline]
    pub fn coefficient(&self, m_eff: f64, k_t: f64, gamma_n: f64) -> f64 {
        self.coefficient_lanes(m_eff, k_t, gamma_n)
    }

    /// [`TangentialDamping::coefficient`] on every lane: the one implementation, run by the
    /// general kernel (`f64`) and the engine's vector paths.
    #[inline(always)]
    pub(crate) fn coefficient_lanes<R: Real>(&self, m_eff: R, k_t: R, gamma_n: R) -> R {
        match *self {
            TangentialDamping::None => R::splat(0.0),
            TangentialDamping::Coefficient { coefficient } => R::splat(coefficient),
            TangentialDamping::FractionOfNormal { ratio } => R::splat(ratio) * gamma_n,
            TangentialDamping::CriticalFraction { zeta } => R::splat(zeta * 2.0) * (m_eff * k_t).sqrt(),
            TangentialDamping::MassProportional { rate } => R::splat(rate) * m_eff,
        }
    }
}

/// One step of the tangential spring with its Coulomb limit, on every lane: the increment
/// ([`Tangential::trial_lanes`]), the cap |F_t| ≤ `cap` ([`coulomb_cap_lanes`]) and the history
/// to store — the incremented one, or where the contact slides the one that holds exactly the
/// capped force ([`Tangential::history_for_force_lanes`]). Returns the tangential force on i,
/// the new history and where the contact slides. The one implementation, run by the general
/// kernel (`f64`) and the engine's vector paths.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn spring_step<R: Real, const N: usize>(
    law: &Tangential,
    rotated: Vec3<R>,
    v_t: Vec3<R>,
    k_t: R,
    gamma_t: R,
    dt: f64,
    cap: R,
) -> (Vec3<R>, Vec3<R>, R::Mask) {
    let (trial, kept) = law.trial_lanes::<R, N>(rotated, v_t, k_t, gamma_t, dt);
    let (f, sliding) = coulomb_cap_lanes::<R, N>(trial, cap);
    if R::branch_unless(sliding) {
        return (f, kept, sliding);
    }
    let history = select3::<R>(sliding, law.history_for_force_lanes::<R, N>(f), kept);
    (f, history, sliding)
}
