//! Tangential part with history (SPEC §2.3): linear (Cundall–Strack) and incremental Mindlin.
//!
//! Sign convention: `v_t` is the tangential velocity of grain j relative to grain i at the contact
//! point, and the history and forces are those acting **on grain i**: a Cundall–Strack spring
//! stores s = ∫ v_t dt and pulls i along, F_t(on i) = k_t s + γ_t v_t (equivalently, on j,
//! −k_t s − γ_t v_t as in SPEC §2.3).

use super::coulomb::coulomb_cap_lanes;
use crate::dim::VectorOps;
use crate::error::{CoreError, Result};
use crate::real::{select3, Real, Vec3};
use serde::{Deserialize, Serialize};

mod slip_activation;
pub(crate) use slip_activation::validate as validate_slip_activation;
pub use slip_activation::SlipActivationParams;

/// The tangential history of one contact as it is stored (on grain i of the pair), whose unit
/// depends on the law that wrote it: a length for [`Tangential::Linear`] (the spring
/// elongation s), a force for [`Tangential::Mindlin`] (the elastic tangential force). It is
/// read only through that law ([`Tangential::read`]), which says which of the two it is
/// ([`HistoryValue`]), and made only from a value of the law's kind ([`Tangential::history`]),
/// so a length is never taken for a force. (Inside the engine the force kernels copy its
/// components in and out of their lanes without reading them; the law's parts interpret them.)
///
/// Stored as the bare vector (`#[serde(transparent)]`, `#[repr(transparent)]`): checkpoints
/// encode it exactly as the untyped vector they held before, and the engine's vector paths
/// gather and scatter its components in place.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
#[repr(transparent)]
pub struct TangentialHistory<V>(pub(crate) V);

impl<V: VectorOps> TangentialHistory<V> {
    /// No history (a fresh contact): zero for every law.
    pub const ZERO: Self = TangentialHistory(V::ZERO);

    /// True when nothing is stored (every component exactly zero); the same for every law.
    #[inline]
    pub fn is_zero(&self) -> bool {
        self.0 == V::ZERO
    }
}

/// The same history seen from the other grain of the pair (the pair's grains swapped).
impl<V: VectorOps> std::ops::Neg for TangentialHistory<V> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        TangentialHistory(-self.0)
    }
}

/// A tangential history read through its law: the value with its unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HistoryValue<V> {
    /// The law has no tangential part ([`Tangential::None`]): nothing is stored.
    None,
    /// Spring elongation s of the linear (Cundall–Strack) law, a length, on grain i.
    Displacement(V),
    /// Elastic tangential force of the incremental Mindlin law, a force, on grain i.
    Force(V),
}

impl Tangential {
    /// The history `h` of a contact of this law, with its unit.
    #[inline]
    pub fn read<V: VectorOps>(&self, h: TangentialHistory<V>) -> HistoryValue<V> {
        match self {
            Tangential::None => HistoryValue::None,
            Tangential::Linear { .. } | Tangential::SlipActivation { .. } => HistoryValue::Displacement(h.0),
            Tangential::Mindlin { .. } => HistoryValue::Force(h.0),
        }
    }

    /// The stored history that holds `value` for a contact of this law; an error when `value`
    /// is of the other kind (a displacement given to the Mindlin law, a force to the linear
    /// law, or anything but [`HistoryValue::None`] to a law without a tangential part).
    pub fn history<V: VectorOps>(&self, value: HistoryValue<V>) -> Result<TangentialHistory<V>> {
        match (self, value) {
            (Tangential::None, HistoryValue::None) => Ok(TangentialHistory::ZERO),
            (Tangential::Linear { .. } | Tangential::SlipActivation { .. }, HistoryValue::Displacement(s)) => Ok(TangentialHistory(s)),
            (Tangential::Mindlin { .. }, HistoryValue::Force(f)) => Ok(TangentialHistory(f)),
            (law, value) => {
                let allowed = match law {
                    Tangential::None => "none (the law has no tangential part)",
                    Tangential::Linear { .. } | Tangential::SlipActivation { .. } => "a displacement (the linear law stores its spring elongation)",
                    Tangential::Mindlin { .. } => "a force (the Mindlin law stores its elastic tangential force)",
                };
                Err(CoreError::InvalidParameter {
                    field: format!("tangential history of the {law:?} law"),
                    value: format!("{value:?}"),
                    allowed: allowed.into(),
                })
            }
        }
    }

    /// The elastic part of the tangential force on grain i held by the history `h` (before
    /// the Coulomb cap, without damping): k_t s for the linear law, the stored force for
    /// Mindlin, zero without a tangential part.
    #[inline]
    pub fn elastic_force<V: VectorOps>(&self, h: TangentialHistory<V>) -> V {
        match *self {
            Tangential::None => V::ZERO,
            Tangential::Linear { stiffness } | Tangential::SlipActivation { stiffness, .. } => h.0 * stiffness,
            Tangential::Mindlin { .. } => h.0,
        }
    }
}

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
    /// Linear spring with a slip-activation time τ (the E2 paper's proposed law, its Eq. 13):
    /// the spring elongation D_t obeys
    ///
    /// Ḋ_t = v_t − Θ(|D_t| − D_tᶜ) (D_t − D_tᶜ)/τ,  D_tᶜ = μ F_n/K_t (along D_t),
    ///
    /// so a contact may hold more than μ F_n for a time of order τ: it slides at loading time
    /// scales (≫ τ) and sticks at acoustic ones (≪ τ). τ → 0 is the Coulomb cap of
    /// [`Tangential::Linear`]. Integrated by backward Euler over each step (unconditionally
    /// stable, exact steady slide D_t = D_tᶜ + v_t τ). Its parameter, checks and step past the
    /// cap are in `contact/tangential/slip_activation.rs` ([`SlipActivationParams`]). History: the
    /// spring D_t (a length), as the linear law. (Appended last: the encoding of the other
    /// variants, and so of every earlier checkpoint, is unchanged.)
    SlipActivation {
        /// K_t (force/length).
        stiffness: f64,
        /// τ (time), > 0.
        activation_time: f64,
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
            Tangential::Linear { stiffness } | Tangential::SlipActivation { stiffness, .. } => R::splat(stiffness),
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
            Tangential::Linear { .. } | Tangential::SlipActivation { .. } => {
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
            Tangential::Linear { stiffness } | Tangential::SlipActivation { stiffness, .. } => {
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
    let at_cap = law.history_for_force_lanes::<R, N>(f);
    if let Tangential::SlipActivation { activation_time, .. } = *law {
        let (force, history) = slip_activation::relax_lanes::<R, N>(activation_time, dt, f, at_cap, trial, kept, sliding);
        return (force, history, sliding);
    }
    let history = select3::<R>(sliding, at_cap, kept);
    (f, history, sliding)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::{pair_kinematics, ContactParams, ContactState, Partner};
    use crate::dim::D3;
    use glam::DVec3;

    /// The law says what its history is: a displacement for the linear law, a force for
    /// Mindlin; a value of the other kind is refused with the law and what it allows.
    #[test]
    fn the_history_is_read_and_made_through_its_law() {
        let v = DVec3::new(1e-4, -2e-4, 0.5e-4);
        let linear = Tangential::Linear { stiffness: 3e4 };
        let mindlin = Tangential::Mindlin { effective_shear_modulus: 1e6, rescale_on_unloading: false };
        let s = linear.history(HistoryValue::Displacement(v)).unwrap();
        assert_eq!(linear.read(s), HistoryValue::Displacement(v));
        assert_eq!(linear.elastic_force(s), v * 3e4);
        let f = mindlin.history(HistoryValue::Force(v)).unwrap();
        assert_eq!(mindlin.read(f), HistoryValue::Force(v));
        assert_eq!(mindlin.elastic_force(f), v);
        assert_eq!(Tangential::None.read(f), HistoryValue::None);
        assert!(Tangential::None.history(HistoryValue::None::<DVec3>).unwrap().is_zero());
        let e = mindlin.history(HistoryValue::Displacement(v)).unwrap_err().to_string();
        assert!(e.contains("Mindlin") && e.contains("Displacement") && e.contains("a force"), "{e}");
        let e = linear.history(HistoryValue::Force(v)).unwrap_err().to_string();
        assert!(e.contains("Linear") && e.contains("Force") && e.contains("a displacement"), "{e}");
        assert!(Tangential::None.history(HistoryValue::Force(v)).is_err());
        // the other grain's view
        assert_eq!(linear.read(-s), HistoryValue::Displacement(-v));
    }

    /// What each law stores after one step of pure tangential loading (below the Coulomb cap),
    /// against the closed forms: s = v_t Δt (a length) for the linear law, F = k_t(ξ) v_t Δt
    /// (a force) for Mindlin, and the elastic force k_t s or F of each.
    #[test]
    fn each_law_stores_its_own_kind_of_history() {
        let (r, xi, v, dt) = (0.5, 1e-3, 1e-2, 1e-4);
        for name in ["hooke_cundall_strack", "hertz_mindlin"] {
            // each preset with only its own keys
            let mut p = ContactParams::preset(name);
            if name == "hooke_cundall_strack" {
                p.normal_stiffness = Some(1e4);
            } else {
                p.young = Some(1e7);
                p.poisson = Some(0.3);
            }
            p.friction = Some(0.5);
            let law = p.build(Partner::Grain, "contact").unwrap();
            let kin = pair_kinematics::<D3>(DVec3::new(2.0 * r - xi, 0.0, 0.0), r, r, 1.0, 1.0, DVec3::ZERO, DVec3::new(0.0, v, 0.0), DVec3::ZERO, DVec3::ZERO).unwrap();
            let mut state = ContactState::<D3>::default();
            let k_t = law.tangential.stiffness(kin.overlap, kin.r_eff);
            let out = law.evaluate(&kin, &mut state, dt);
            assert!(!out.sliding && k_t > 0.0);
            // (one multiplication or two: a few ulps)
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs();
            let elastic = law.tangential.elastic_force(state.spring);
            match law.tangential.read(state.spring) {
                HistoryValue::Displacement(s) => {
                    assert_eq!(name, "hooke_cundall_strack");
                    assert!(close(s.y, v * dt) && s.x == 0.0 && s.z == 0.0, "s {s}");
                    assert!(close(elastic.y, k_t * v * dt), "k_t s {elastic}");
                }
                HistoryValue::Force(f) => {
                    assert_eq!(name, "hertz_mindlin");
                    assert!(close(f.y, k_t * v * dt) && f.x == 0.0 && f.z == 0.0, "F {f}");
                    assert_eq!(elastic, f);
                }
                HistoryValue::None => panic!("{name} has a tangential part"),
            }
        }
    }

    /// The stored history is encoded as the bare vector, so checkpoints written before it was
    /// typed decode to the same bits (bincode, the checkpoint encoding, and JSON).
    #[test]
    fn the_typed_history_keeps_the_checkpoint_encoding() {
        #[derive(Serialize)]
        struct Untyped {
            spring: DVec3,
            rolling: DVec3,
            twist: f64,
            overlap: f64,
            sliding: bool,
        }
        let v = DVec3::new(0.1, -0.2, 0.3e-9);
        let old = Untyped { spring: v, rolling: -v, twist: 0.25, overlap: 1e-3, sliding: true };
        let new = ContactState::<D3> { spring: TangentialHistory(v), rolling: -v, twist: 0.25, overlap: 1e-3, sliding: true };
        let bytes = bincode::serialize(&old).unwrap();
        assert_eq!(bincode::serialize(&new).unwrap(), bytes);
        let back: ContactState<D3> = bincode::deserialize(&bytes).unwrap();
        assert_eq!(back, new);
        assert_eq!(serde_json::to_string(&new).unwrap(), serde_json::to_string(&old).unwrap());
    }
}
