//! Contact laws composed of independent parts (SPEC §2).
//!
//! A [`ContactLaw`] is a normal elastic part ([`NormalElastic`]), a normal damping part
//! ([`NormalDamping`]), a tangential part with history ([`Tangential`], [`TangentialDamping`]),
//! a Coulomb limit (`friction`) and rolling resistance ([`Rolling`]). [`ContactLaw::evaluate`] is a
//! pure function of the contact [`Kinematics`] and the pair's [`ContactState`] and fixes the order:
//!
//! 1. normal: F_n = max(0, F_el(ξ) − γ_n v_n) (damping adds while approaching, v_n < 0);
//! 2. tangential: rotate the history into the current tangent plane keeping its length, add the
//!    increment, trial force, Coulomb cap |F_t| ≤ μ F_n with history reset when sliding;
//! 3. rolling: same pattern with the rolling spring and the cap μ_r R* F_n;
//! 4. twisting (3D): same pattern with the twist spring and the cap μ_tw R* F_n.
//!
//! Forces on grain i: −F_n n̂ + F_t; on j the opposite. Torques: τ_i = a_i n̂ × F_t + M_r,
//! τ_j = a_j n̂ × F_t − M_r with the lever arms a of [`Kinematics`], M_r the rolling plus
//! twisting resistance torque on i.
//!
//! Named presets: `hertz_mindlin` and `hooke_cundall_strack` ([`ContactParams`]).

mod coulomb;
mod damping;
mod kinematics;
mod normal;
mod params;
mod parts;
mod rolling;
mod tangential;

pub use coulomb::coulomb_cap;
pub use damping::{
    clamped_contact_time, clamped_restitution, critical_fraction_for_restitution, textbook_critical_fraction, tsuji_alpha,
    NormalDamping,
};
pub use kinematics::{pair_kinematics, wall_kinematics, Kinematics};
pub use normal::{NormalElastic, NormalResponse};
pub use params::{ContactParams, Partner, PRESETS};
pub use parts::{HertzMindlin, HookeCundallStrack, HookeSlipActivation, LawParts, Specialized, WithRolling};
pub use rolling::{Rolling, Twisting};
pub use tangential::{HistoryValue, Tangential, TangentialDamping, TangentialHistory};
pub(crate) use coulomb::coulomb_cap_lanes;
pub(crate) use damping::clamped_normal_force_lanes;
pub(crate) use kinematics::{into_tangent_plane_lanes, pair_kinematics_lanes};
pub(crate) use tangential::spring_step;

use crate::real::{by_len, from_lanes, to_lanes, Real, Vec3};

use crate::dim::{Dim, VectorOps};
use crate::error::{require_non_negative, require_positive, CoreError, Result};
use serde::{Deserialize, Serialize};

/// A complete contact law for one class of contacts (grain–grain, or grains with one wall).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactLaw {
    /// Normal elastic part.
    pub normal: NormalElastic,
    /// Normal damping part.
    pub damping: NormalDamping,
    /// Tangential elastic part.
    pub tangential: Tangential,
    /// Tangential damping.
    pub tangential_damping: TangentialDamping,
    /// Coulomb friction coefficient μ (static = dynamic).
    pub friction: f64,
    /// Rolling resistance.
    pub rolling: Rolling,
    /// Twisting resistance (3D).
    pub twisting: Twisting,
}

/// Per-contact state carried from step to step (and across neighbor-list rebuilds).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct ContactState<D: Dim> {
    /// Tangential history on grain i: the spring s (linear law, a length) or the elastic
    /// tangential force (Mindlin, a force), read through the law ([`Tangential::read`]).
    pub spring: TangentialHistory<D::Vector>,
    /// Rolling spring θ_r.
    pub rolling: D::AngVector,
    /// Twisting spring φ (3D).
    pub twist: f64,
    /// Overlap at the last evaluation; 0 when the pair is not in contact.
    pub overlap: f64,
    /// The contact was sliding (Coulomb cap reached) at the last evaluation.
    pub sliding: bool,
}

impl<D: Dim> ContactState<D> {
    /// True when the pair was in contact at the last evaluation.
    #[inline]
    pub fn in_contact(&self) -> bool {
        self.overlap > 0.0
    }
}

/// What a contact law returns for one contact.
#[derive(Clone, Copy, Debug)]
pub struct ContactOutput<D: Dim> {
    /// Total normal force F_n ≥ 0 (elastic + damping, clamped), repulsive.
    pub normal_force: f64,
    /// Tangential force on grain i.
    pub tangential_force: D::Vector,
    /// Rolling + twisting resistance torque on grain i.
    pub rolling_torque: D::AngVector,
    /// Differential normal stiffness k_n = dF_el/dξ.
    pub normal_stiffness: f64,
    /// Tangential stiffness k_t.
    pub tangential_stiffness: f64,
    /// The Coulomb cap was reached.
    pub sliding: bool,
}

/// Rotates `v` into the plane perpendicular to `n`, preserving its length
/// ([`into_tangent_plane_lanes`] on one lane).
#[inline]
fn into_tangent_plane<V: VectorOps>(v: V, n: V) -> V {
    from_lanes(by_len!(V, into_tangent_plane_lanes(to_lanes(v), to_lanes(n))))
}

/// Evaluates a contact law given by its parts (see [`LawParts`]): the general kernel, and the
/// reference for the engine's specialised kernels (`sim::lanes::contact`). Both are assembled
/// from the same lane-generic parts — [`NormalElastic::response_lanes`],
/// [`NormalDamping::coefficient_lanes`], [`Tangential::stiffness_lanes`],
/// [`TangentialDamping::coefficient_lanes`], the spring step `spring_step` (increment,
/// Coulomb cap, history kept) and the rotation into the tangent plane — run here on one lane (`f64`), so both give the same bits.
#[inline(always)]
pub(crate) fn evaluate_parts<D: Dim, P: LawParts>(law: &P, kin: &Kinematics<D>, state: &mut ContactState<D>, dt: f64) -> ContactOutput<D> {
    let n = kin.normal;
    let NormalResponse { force: f_el, stiffness: k_n, secant } = law.normal().response_lanes(kin.overlap, kin.r_eff);
    let gamma_n = law.damping().coefficient_lanes(kin.m_eff, k_n, secant);
    let f_n = clamped_normal_force_lanes(f_el, gamma_n, kin.v_n);

    let tangential = law.tangential();
    let k_t = tangential.stiffness_lanes(kin.overlap, kin.r_eff);
    let mut sliding = false;
    let f_t = match tangential {
        Tangential::None => D::Vector::ZERO,
        Tangential::Linear { .. } | Tangential::Mindlin { .. } | Tangential::SlipActivation { .. } => {
            let gamma_t = law.tangential_damping().coefficient_lanes(kin.m_eff, k_t, gamma_n);
            let mut rotated = into_tangent_plane(state.spring.0, n);
            if let Tangential::Mindlin { rescale_on_unloading: true, .. } = tangential {
                if state.overlap > 0.0 && kin.overlap < state.overlap {
                    // k_t ∝ √ξ
                    rotated *= (kin.overlap / state.overlap).sqrt();
                }
            }
            let cap = law.friction() * f_n;
            let (f, history, slid) = by_len!(D::Vector, spring_step(&tangential, to_lanes(rotated), to_lanes(kin.v_t), k_t, gamma_t, dt, cap));
            sliding = slid;
            state.spring = TangentialHistory(from_lanes(history));
            from_lanes(f)
        }
    };

    let mut m_r = match law.rolling() {
        Rolling::None => D::AngVector::ZERO,
        Rolling::SpringDashpot { stiffness, damping, friction } => {
            let theta = into_tangent_plane_ang::<D>(state.rolling, n) + kin.w_roll * dt;
            let trial = theta * stiffness + kin.w_roll * damping;
            let (m, slid) = coulomb_cap(trial, friction * kin.r_eff * f_n);
            state.rolling = if slid { m / stiffness } else { theta };
            m
        }
    };
    if let Twisting::SpringDashpot { stiffness, damping, friction } = law.twisting() {
        let phi = state.twist + kin.w_twist * dt;
        let trial = phi * stiffness + kin.w_twist * damping;
        let (m, slid) = coulomb_cap(trial, friction * kin.r_eff * f_n);
        state.twist = if slid { m / stiffness } else { phi };
        m_r += D::about_normal(m, n);
    }
    state.overlap = kin.overlap;
    state.sliding = sliding;
    ContactOutput {
        normal_force: f_n,
        tangential_force: f_t,
        rolling_torque: m_r,
        normal_stiffness: k_n,
        tangential_stiffness: k_t,
        sliding,
    }
}

/// The loads of one contact on every lane, from its normal n̂, tangential force F_t and normal
/// force F_n on grain i, the lever arms a_i, a_j and the rolling plus twisting torque M_r on i:
///
/// F_i = F_t − F_n n̂ (on j: −F_i), τ_i = a_i n̂ × F_t + M_r, τ_j = a_j n̂ × F_t − M_r,
///
/// with `DIM` force components and `ROT` torque components (n̂ × F_t is the z component in 2D,
/// `ROT` = 1). The one statement of the assembly: the general kernel ([`contact_loads`], one
/// lane) and the lane kernels (with M_r = 0, as their laws have no rolling resistance: adding
/// the zero keeps the bits of the general kernel, −0 + 0 = +0 included).
#[inline(always)]
pub(crate) fn contact_loads_lanes<R: Real, const DIM: usize, const ROT: usize>(n: Vec3<R>, f_t: Vec3<R>, f_n: R, lever_i: R, lever_j: R, m_r: Vec3<R>) -> (Vec3<R>, Vec3<R>, Vec3<R>) {
    let zero = R::splat(0.0);
    // n̂ × F_t, as `Dim::cross`
    let mut t = [zero; 3];
    if DIM == 3 {
        t[0] = n[1] * f_t[2] - f_t[1] * n[2];
        t[1] = n[2] * f_t[0] - f_t[2] * n[0];
        t[2] = n[0] * f_t[1] - f_t[0] * n[1];
    } else {
        t[0] = n[0] * f_t[1] - n[1] * f_t[0];
    }
    let (mut force, mut torque_i, mut torque_j) = ([zero; 3], [zero; 3], [zero; 3]);
    for c in 0..DIM {
        force[c] = f_t[c] - n[c] * f_n;
    }
    for c in 0..ROT {
        torque_i[c] = t[c] * lever_i + m_r[c];
        torque_j[c] = t[c] * lever_j - m_r[c];
    }
    (force, torque_i, torque_j)
}

/// [`contact_loads_lanes`] on one lane for a contact evaluated by [`ContactLaw::evaluate`]:
/// the force on i and the torques on i and j (for a wall contact only the first two are used).
#[inline(always)]
pub(crate) fn contact_loads<D: Dim>(kin: &Kinematics<D>, o: &ContactOutput<D>) -> (D::Vector, D::AngVector, D::AngVector) {
    let (n, f_t, m_r) = (to_lanes(kin.normal), to_lanes(o.tangential_force), to_lanes(o.rolling_torque));
    let (f, ti, tj) = if D::D == 2 {
        contact_loads_lanes::<f64, 2, 1>(n, f_t, o.normal_force, kin.lever_i, kin.lever_j, m_r)
    } else {
        contact_loads_lanes::<f64, 3, 3>(n, f_t, o.normal_force, kin.lever_i, kin.lever_j, m_r)
    };
    (from_lanes(f), from_lanes(ti), from_lanes(tj))
}

impl ContactLaw {
    /// Evaluates the law for a contact with kinematics `kin` over a step `dt`, updating `state`.
    /// Assumes `kin.overlap > 0`.
    #[inline]
    pub fn evaluate<D: Dim>(&self, kin: &Kinematics<D>, state: &mut ContactState<D>, dt: f64) -> ContactOutput<D> {
        evaluate_parts(self, kin, state, dt)
    }

    /// Elastic energy stored in a contact: normal part + tangential spring (½ k_t s² for the
    /// linear law, |F|²/(2 k_t) for Mindlin) + rolling spring ½ k_r θ².
    pub fn elastic_energy<D: Dim>(&self, overlap: f64, r_eff: f64, state: &ContactState<D>) -> f64 {
        if overlap <= 0.0 {
            return 0.0;
        }
        let mut e = self.normal.energy(overlap, r_eff);
        let k_t = self.tangential.stiffness(overlap, r_eff);
        match self.tangential.read(state.spring) {
            HistoryValue::None => {}
            HistoryValue::Displacement(s) => e += 0.5 * k_t * s.norm2(),
            HistoryValue::Force(f) => {
                if k_t > 0.0 {
                    e += 0.5 * f.norm2() / k_t
                }
            }
        }
        if let Rolling::SpringDashpot { stiffness, .. } = self.rolling {
            e += 0.5 * stiffness * state.rolling.norm2();
        }
        if let Twisting::SpringDashpot { stiffness, .. } = self.twisting {
            e += 0.5 * stiffness * state.twist * state.twist;
        }
        e
    }

    /// Largest angular frequency² of a single contact of this law between bodies of effective mass
    /// `m_eff` and radius `r_eff` at overlap `overlap`, used for time-step suggestions: the normal
    /// mode k_n/m*, and the tangential mode k_t (1 + m R²/I)/m* which couples translation and
    /// rotation (`inertia_factor` = m R²/I: 2 for disks, 5/2 for spheres).
    pub fn max_frequency_sq(&self, m_eff: f64, r_eff: f64, overlap: f64, inertia_factor: f64) -> f64 {
        let (_, k_n) = self.normal.force_stiffness(overlap, r_eff);
        let k_t = self.tangential.stiffness(overlap, r_eff);
        let mut w2 = k_n / m_eff;
        w2 = w2.max(k_t * (1.0 + inertia_factor) / m_eff);
        if let Rolling::SpringDashpot { stiffness, .. } = self.rolling {
            // rotational spring acting on a moment of inertia I = m R² / inertia_factor
            w2 = w2.max(stiffness * inertia_factor / (m_eff * r_eff * r_eff));
        }
        if let Twisting::SpringDashpot { stiffness, .. } = self.twisting {
            w2 = w2.max(stiffness * inertia_factor / (m_eff * r_eff * r_eff));
        }
        w2
    }

    /// Checks every parameter; `field` prefixes the names in error messages.
    pub fn validate(&self, field: &str) -> Result<()> {
        match self.normal {
            NormalElastic::Hooke { stiffness } => require_positive(&format!("{field}.normal_stiffness"), stiffness)?,
            NormalElastic::Hertz { effective_modulus } => require_positive(&format!("{field}.young"), effective_modulus)?,
        }
        match self.damping {
            NormalDamping::None => {}
            NormalDamping::Dashpot { coefficient } => require_non_negative(&format!("{field}.normal_damping"), coefficient)?,
            NormalDamping::CriticalFraction { zeta } => require_non_negative(&format!("{field}.damping_fraction"), zeta)?,
            NormalDamping::MassProportional { rate } => require_non_negative(&format!("{field}.normal_damping_rate"), rate)?,
            NormalDamping::Tsuji { alpha } => require_non_negative(&format!("{field}.tsuji_alpha"), alpha)?,
        }
        match self.tangential {
            Tangential::None => {}
            Tangential::Linear { stiffness } => require_positive(&format!("{field}.tangential_stiffness"), stiffness)?,
            Tangential::SlipActivation { stiffness, activation_time } => {
                require_positive(&format!("{field}.tangential_stiffness"), stiffness)?;
                if !(activation_time > 0.0 && activation_time.is_finite()) {
                    return Err(CoreError::invalid(
                        format!("{field}.slip_activation_time"),
                        activation_time,
                        "a finite time τ > 0 (0 is the Coulomb cap: leave the key out or set 0)",
                    ));
                }
            }
            Tangential::Mindlin { effective_shear_modulus, .. } => {
                require_positive(&format!("{field}.shear_modulus"), effective_shear_modulus)?
            }
        }
        match self.tangential_damping {
            TangentialDamping::None => {}
            TangentialDamping::Coefficient { coefficient } => {
                require_non_negative(&format!("{field}.tangential_damping"), coefficient)?
            }
            TangentialDamping::FractionOfNormal { ratio } => {
                require_non_negative(&format!("{field}.tangential_damping_ratio"), ratio)?
            }
            TangentialDamping::CriticalFraction { zeta } => require_non_negative(&format!("{field}.damping_fraction"), zeta)?,
            TangentialDamping::MassProportional { rate } => {
                require_non_negative(&format!("{field}.tangential_damping_rate"), rate)?
            }
        }
        if !(self.friction >= 0.0) || self.friction.is_nan() {
            return Err(CoreError::invalid(format!("{field}.friction"), self.friction, "a number ≥ 0 (may be inf)"));
        }
        if let Rolling::SpringDashpot { stiffness, damping, friction } = self.rolling {
            require_positive(&format!("{field}.rolling_stiffness"), stiffness)?;
            require_non_negative(&format!("{field}.rolling_damping"), damping)?;
            if !(friction >= 0.0) || friction.is_nan() {
                return Err(CoreError::invalid(format!("{field}.rolling_friction"), friction, "a number ≥ 0 (may be inf)"));
            }
        }
        if let Twisting::SpringDashpot { stiffness, damping, friction } = self.twisting {
            require_positive(&format!("{field}.twisting_stiffness"), stiffness)?;
            require_non_negative(&format!("{field}.twisting_damping"), damping)?;
            if !(friction >= 0.0) || friction.is_nan() {
                return Err(CoreError::invalid(format!("{field}.twisting_friction"), friction, "a number ≥ 0 (may be inf)"));
            }
        }
        Ok(())
    }
}

/// Same as `into_tangent_plane` for angular vectors (3D); the identity in 2D.
#[inline]
fn into_tangent_plane_ang<D: Dim>(theta: D::AngVector, n: D::Vector) -> D::AngVector {
    if D::ROT == 1 {
        return theta;
    }
    from_lanes(into_tangent_plane_lanes::<f64, 3>(to_lanes(theta), to_lanes(n)))
}
