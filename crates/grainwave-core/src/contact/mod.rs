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

#[macro_use]
mod registry;
mod coulomb;
pub mod damping;
mod families;
mod history;
mod kinematics;
mod normal;
mod params;
mod parts;
pub mod rolling;
pub mod tangential;

pub use coulomb::coulomb_cap;
pub(crate) use damping::Dampers;
pub use damping::{
    clamped_contact_time, clamped_restitution, critical_fraction_for_restitution, textbook_critical_fraction, tsuji_alpha, DampingContext,
    DampingParams, DampingTable, NoDamping, NormalDamping, NormalDampingLaw, TangentialDamping, TangentialDampingLaw,
};
pub use kinematics::{pair_kinematics, wall_kinematics, Kinematics};
pub use normal::*;
pub use families::ResistanceTable;
pub use history::{HistoryColumn, LawHistory, WallHistory};
pub(crate) use history::{decoding_version, scalar_history, zero_sized_slice};
pub(crate) use tangential::spring_step;
pub use params::{ContactParams, Partner, PRESETS};
pub use parts::{
    HertzMindlin, HistoryNormal, HistoryRest, HistoryTangential, HookeCundallStrack, HookeSlipActivation, LawParts, Specialized, TangentialRest, VisitNormal, VisitParts, VisitTangential, WithBoth,
    WithNormal, WithRolling, WithTangential,
};
pub use rolling::{ResistanceLaw, Rolling, Twisting};
pub use tangential::{HistoryKind, HistoryValue, NoTangential, SlipActivationParams, Tangential, TangentialContext, TangentialHistory, TangentialLaw, TangentialTable};
pub(crate) use coulomb::coulomb_cap_lanes;
pub(crate) use damping::clamped_normal_force_lanes;
pub(crate) use kinematics::{into_tangent_plane_lanes, pair_kinematics_lanes};

use crate::real::{from_lanes, to_lanes, Real, Vec3};

use crate::dim::{Dim, VectorOps};
use crate::error::{CoreError, Result};
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

/// The inputs of a contact law for one contact per lane: the kinematics it reads (as
/// [`Kinematics`]) and the pair's stored history (as [`ContactState`]); components past the
/// dimension unused.
#[derive(Clone, Copy)]
pub(crate) struct LawIn<R> {
    /// Unit normal n̂ from i towards j (towards the wall for wall contacts).
    pub normal: Vec3<R>,
    /// Overlap ξ > 0, R*, m*.
    pub overlap: R,
    pub r_eff: R,
    pub m_eff: R,
    /// Relative normal velocity (negative while approaching) and tangential velocity of j
    /// relative to i at the contact point.
    pub v_n: R,
    pub v_t: Vec3<R>,
    /// Relative rolling angular velocity (`ROT` components) and twist rate: read only by laws
    /// with rolling or twisting resistance.
    pub w_roll: Vec3<R>,
    pub w_twist: R,
    /// Stored tangential history, rolling spring θ_r, twist spring φ.
    pub spring: Vec3<R>,
    pub rolling: Vec3<R>,
    pub twist: R,
    /// Overlap at the last evaluation (read only by the Mindlin law that rescales on unloading).
    pub was: R,
}

/// What a contact law gives for one contact per lane: the forces on grain i and the history to
/// store (unchanged for the parts the law does not have).
#[derive(Clone, Copy)]
pub(crate) struct LawOut<R: Real> {
    /// F_n ≥ 0 (elastic + damping, clamped), k_n = dF_el/dξ, k_t.
    pub normal_force: R,
    pub normal_stiffness: R,
    pub tangential_stiffness: R,
    /// F_t on i, and where the Coulomb cap was reached.
    pub tangential_force: Vec3<R>,
    pub sliding: R::Mask,
    /// Rolling plus twisting resistance torque M_r on i.
    pub torque: Vec3<R>,
    /// The histories to store: tangential, rolling, twist.
    pub spring: Vec3<R>,
    pub rolling: Vec3<R>,
    pub twist: R,
}

/// The contact law, written once: one contact per lane, for every lane type — the general kernel
/// ([`evaluate_parts`], one lane) and the engine's window and fused kernels
/// (`sim::lanes::contact`) all run this sequence, so they give the same bits:
///
/// 1. normal: F_n = max(0, F_el(ξ) − γ_n v_n);
/// 2. tangential: the history rotated into the tangent plane (rescaled by √(ξ/ξ_old) on
///    unloading for the Mindlin law that asks for it), the spring step of the law (increment,
///    trial force, Coulomb cap at μF_n, history kept);
/// 3. rolling: θ_r rotated into the tangent plane (3D) plus w_r Δt, trial k_r θ_r + γ_r w_r,
///    capped at μ_r R* F_n, the spring reset to M_r/k_r where capped;
/// 4. twisting: φ + w_tw Δt, trial k_tw φ + γ_tw w_tw, capped at μ_tw R* F_n, added about n̂.
///
/// `damp` gives γ_n and γ_t (the law's own damping parts, or the same formulas resolved at
/// compile time for the presets). Every `match` on a part folds away for a law whose parts are
/// constants of its type ([`LawParts`]). `extra` is the law's own history ([`LawParts::Extra`],
/// `()` for the laws without), read and updated by its normal part and its tangential step.
#[inline(always)]
pub(crate) fn law_lanes<R: Real, const DIM: usize, const ROT: usize, P: LawParts, Q: Dampers>(
    law: &P,
    damp: Q,
    x: &LawIn<R>,
    extra: &mut <P::Extra as LawHistory>::Lanes<R>,
    dt: f64,
) -> LawOut<R> {
    let zero = R::splat(0.0);
    let n = x.normal;
    let NormalResponse { force: f_el, stiffness: k_n, secant } = law.normal_response(x.overlap, x.r_eff, extra);
    let gamma_n = damp.normal(x.m_eff, k_n, secant);
    let f_n = clamped_normal_force_lanes(f_el, gamma_n, x.v_n);
    let tangential = law.tangential();
    let k_t = tangential.stiffness_lanes(x.overlap, x.r_eff);

    let (tangential_force, spring, sliding) = if let Tangential::None = tangential {
        ([zero; 3], x.spring, zero.gt(zero))
    } else {
        let gamma_t = damp.tangential(x.m_eff, k_t, gamma_n);
        let mut rotated = into_tangent_plane_lanes::<R, DIM>(x.spring, n);
        rotated = tangential.unloading_lanes::<R, DIM>(rotated, x.was, x.overlap);
        let cap = R::splat(law.friction()) * f_n;
        law.tangential_step::<R, DIM>(rotated, x.v_t, k_t, gamma_t, dt, cap, extra)
    };

    let (mut torque, mut rolling) = ([zero; 3], x.rolling);
    let resist = law.rolling();
    if !matches!(resist, Rolling::None) {
        // the stored rotation turned into the current tangent plane (3D), then the law's step
        let stored = if ROT == 3 { into_tangent_plane_lanes::<R, 3>(x.rolling, n) } else { x.rolling };
        (torque, rolling) = resist.step_lanes::<R, ROT>(stored, x.w_roll, x.r_eff, f_n, dt);
    }

    let mut twist = x.twist;
    let resist = law.twisting();
    if !matches!(resist, Twisting::None) {
        let (m, phi) = resist.step_lanes::<R, 1>([x.twist, zero, zero], [x.w_twist, zero, zero], x.r_eff, f_n, dt);
        twist = phi[0];
        // M_r += m n̂ (`Dim::about_normal`: zero in 2D, still added)
        for c in 0..ROT {
            torque[c] = torque[c] + if ROT == 3 { n[c] * m[0] } else { zero };
        }
    }
    LawOut { normal_force: f_n, normal_stiffness: k_n, tangential_stiffness: k_t, tangential_force, sliding, torque, spring, rolling, twist }
}

/// Evaluates a contact law given by its parts (see [`LawParts`]) on one contact: [`law_lanes`]
/// on one lane (`f64`) with the law's own damping parts, updating the shared `state` and the
/// law's own history `extra`. The general kernel of the engine, and the reference its
/// specialised kernels are tested against.
#[inline(always)]
pub(crate) fn evaluate_parts<D: Dim, P: LawParts>(law: &P, kin: &Kinematics<D>, state: &mut ContactState<D>, extra: &mut P::Extra, dt: f64) -> ContactOutput<D> {
    let x = LawIn {
        normal: to_lanes(kin.normal),
        overlap: kin.overlap,
        r_eff: kin.r_eff,
        m_eff: kin.m_eff,
        v_n: kin.v_n,
        v_t: to_lanes(kin.v_t),
        w_roll: to_lanes(kin.w_roll),
        w_twist: kin.w_twist,
        spring: to_lanes(state.spring.0),
        rolling: to_lanes(state.rolling),
        twist: state.twist,
        was: state.overlap,
    };
    let damp = (law.damping(), law.tangential_damping());
    let mut h = extra.to_lane();
    let o = if D::D == 2 { law_lanes::<f64, 2, 1, P, _>(law, damp, &x, &mut h, dt) } else { law_lanes::<f64, 3, 3, P, _>(law, damp, &x, &mut h, dt) };
    *extra = P::Extra::from_lane(h);
    state.spring = TangentialHistory(from_lanes(o.spring));
    state.rolling = from_lanes(o.rolling);
    state.twist = o.twist;
    state.overlap = kin.overlap;
    state.sliding = o.sliding;
    ContactOutput {
        normal_force: o.normal_force,
        tangential_force: from_lanes(o.tangential_force),
        rolling_torque: from_lanes(o.torque),
        normal_stiffness: o.normal_stiffness,
        tangential_stiffness: o.tangential_stiffness,
        sliding: o.sliding,
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
    /// True when a part of the law keeps a per-contact history of its own (the normal law's
    /// [`NormalLaw::History`], the tangential law's [`TangentialLaw::Extra`]), which the engine
    /// stores beside the neighbor list.
    pub fn has_history(&self) -> bool {
        self.normal.has_history() || self.tangential.has_history()
    }

    /// Evaluates the law for a contact with kinematics `kin` over a step `dt`, updating `state`.
    /// Assumes `kin.overlap > 0`. A normal or tangential law with its own history is evaluated
    /// here as for a contact that has just formed (its history the default): the engine runs
    /// such laws through their compositions ([`WithNormal`], [`WithTangential`], [`WithBoth`]),
    /// which keep the history.
    #[inline]
    pub fn evaluate<D: Dim>(&self, kin: &Kinematics<D>, state: &mut ContactState<D>, dt: f64) -> ContactOutput<D> {
        evaluate_parts(self, kin, state, &mut (), dt)
    }

    /// [`ContactLaw::evaluate`] for pair `pair` of a list of `len` pairs whose law history
    /// column is `history` (for a normal law with history: the response on the branch its
    /// stored history puts it on; `reversed` where the pair is seen from its other grain,
    /// [`LawHistory::reversed`]). The history read is not written back: with `dt = 0` nothing
    /// of the contact advances (what contact records and snapshots evaluate).
    pub fn evaluate_stored<D: Dim>(&self, kin: &Kinematics<D>, state: &mut ContactState<D>, history: &HistoryColumn, len: usize, pair: usize, reversed: bool, dt: f64) -> ContactOutput<D> {
        struct Stored<'a, D: Dim> {
            kin: &'a Kinematics<D>,
            state: &'a mut ContactState<D>,
            history: &'a HistoryColumn,
            len: usize,
            pair: usize,
            reversed: bool,
            dt: f64,
        }
        impl<D: Dim> VisitParts for Stored<'_, D> {
            type Out = ContactOutput<D>;
            fn visit<P: LawParts>(self, law: &P) -> ContactOutput<D> {
                let mut h: P::Extra = self.history.get(self.len, self.pair);
                if self.reversed {
                    h = h.reversed();
                }
                evaluate_parts(law, self.kin, self.state, &mut h, self.dt)
            }
        }
        NormalElastic::route(self, Stored { kin, state, history, len, pair, reversed, dt })
    }

    /// Elastic energy stored in a contact: normal part + tangential spring (½ k_t s² for the
    /// linear law, |F|²/(2 k_t) for Mindlin) + rolling spring ½ k_r θ². A normal law with its
    /// own history is read as for a contact that has just formed (its history the default);
    /// [`ContactLaw::elastic_energy_stored`] reads the contact's stored history.
    pub fn elastic_energy<D: Dim>(&self, overlap: f64, r_eff: f64, state: &ContactState<D>) -> f64 {
        if overlap <= 0.0 {
            return 0.0;
        }
        self.elastic_energy_with(self.normal.energy(overlap, r_eff), overlap, r_eff, state)
    }

    /// [`ContactLaw::elastic_energy`] of pair `pair` of a list of `len` pairs whose law history
    /// column is `history`: the normal part's energy reads the stored history (for the
    /// hysteretic law, ½ k₂ (ξ − ξ₀)² with ξ₀ from the stored ξ_max, not the loading branch's).
    pub fn elastic_energy_stored<D: Dim>(&self, overlap: f64, r_eff: f64, state: &ContactState<D>, history: &HistoryColumn, len: usize, pair: usize) -> f64 {
        if overlap <= 0.0 {
            return 0.0;
        }
        struct Normal<'a> {
            history: &'a HistoryColumn,
            len: usize,
            pair: usize,
            overlap: f64,
            r_eff: f64,
        }
        impl VisitParts for Normal<'_> {
            type Out = f64;
            fn visit<P: LawParts>(self, law: &P) -> f64 {
                law.normal_energy(self.overlap, self.r_eff, &self.history.get(self.len, self.pair))
            }
        }
        let normal = NormalElastic::route(self, Normal { history, len, pair, overlap, r_eff });
        self.elastic_energy_with(normal, overlap, r_eff, state)
    }

    /// The energy of a contact at `overlap` (> 0) whose normal part holds `normal`, plus its
    /// tangential, rolling and twisting springs.
    fn elastic_energy_with<D: Dim>(&self, normal: f64, overlap: f64, r_eff: f64, state: &ContactState<D>) -> f64 {
        let mut e = normal;
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
        e += self.rolling.energy(state.rolling.norm2());
        e += self.twisting.energy(state.twist * state.twist);
        e
    }

    /// Largest angular frequency² of a single contact of this law between bodies of effective mass
    /// `m_eff` and radius `r_eff` at overlap `overlap`, used for time-step suggestions: the normal
    /// mode k_n/m*, and the tangential mode k_t (1 + m R²/I)/m* which couples translation and
    /// rotation (`inertia_factor` = m R²/I: 2 for disks, 5/2 for spheres).
    pub fn max_frequency_sq(&self, m_eff: f64, r_eff: f64, overlap: f64, inertia_factor: f64) -> f64 {
        let k_n = self.normal.max_stiffness(overlap, r_eff);
        let k_t = self.tangential.stiffness(overlap, r_eff);
        let mut w2 = k_n / m_eff;
        w2 = w2.max(k_t * (1.0 + inertia_factor) / m_eff);
        for stiffness in [self.rolling.max_stiffness(), self.twisting.max_stiffness()].into_iter().flatten() {
            // rotational spring acting on a moment of inertia I = m R² / inertia_factor
            w2 = w2.max(stiffness * inertia_factor / (m_eff * r_eff * r_eff));
        }
        w2
    }

    /// Checks every parameter; `field` prefixes the names in error messages.
    pub fn validate(&self, field: &str) -> Result<()> {
        self.normal.validate(field)?;
        self.damping.validate(field)?;
        self.tangential.validate(field)?;
        self.tangential_damping.validate(field)?;
        if !(self.friction >= 0.0) || self.friction.is_nan() {
            return Err(CoreError::invalid(format!("{field}.friction"), self.friction, "a number ≥ 0 (may be inf)"));
        }
        self.rolling.validate(&format!("{field}.rolling"))?;
        self.twisting.validate(&format!("{field}.twisting"))?;
        Ok(())
    }
}
