//! A contact law seen through its parts, so that the force kernel can be compiled once per
//! common combination of parts (branch-free) and once for the general [`ContactLaw`].
//!
//! [`evaluate_parts`](super::evaluate_parts) is written against [`LawParts`]. [`ContactLaw`]
//! implements it by reading its enum fields at run time; [`HertzMindlin`] and
//! [`HookeCundallStrack`] fix the normal and tangential parts and switch rolling and twisting
//! off at compile time; [`WithRolling`] adds a rolling spring–dashpot to either (E2's law). Each part computes the same expression in every implementation, so a
//! specialised kernel gives exactly the bits of the general one (tested).

use super::rolling::SpringDashpot;
use super::tangential::{Linear, Mindlin, SlipActivation};
use super::{ContactLaw, Hertz, Hooke, LawHistory, TangentialLaw, NormalDamping, NormalElastic, NormalLaw, NormalResponse, Rolling, Tangential, TangentialDamping, Twisting};
use crate::real::{Real, Vec3};

/// The parts of a contact law, as [`evaluate_parts`](super::evaluate_parts) reads them.
pub trait LawParts: Copy + Send + Sync {
    /// The law's per-contact history beyond the shared parts ([`LawHistory`]): `()` for every
    /// law without one, which then compiles to the code of a law without history.
    type Extra: LawHistory;
    /// The normal elastic response at overlap `xi` reading and updating the law's own history
    /// `extra` (one value per lane). The default: the stateless [`LawParts::normal`] part.
    #[inline(always)]
    fn normal_response<R: Real>(&self, xi: R, r_eff: R, extra: &mut <Self::Extra as LawHistory>::Lanes<R>) -> NormalResponse<R> {
        let _ = extra;
        self.normal().response_lanes(xi, r_eff)
    }
    /// The elastic energy of the normal part at overlap `xi` with the law's own history
    /// `extra` ([`NormalLaw::energy`]). The default: the stateless [`LawParts::normal`] part's.
    #[inline]
    fn normal_energy(&self, xi: f64, r_eff: f64, extra: &Self::Extra) -> f64 {
        let _ = extra;
        self.normal().energy(xi, r_eff)
    }
    /// One step of the tangential part ([`TangentialLaw::step_lanes`]) reading and updating
    /// the law's own history `extra`: the tangential force on i, the spring to store and where
    /// the contact slides. The default: the [`LawParts::tangential`] part's step, for a law
    /// without a tangential history of its own.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn tangential_step<R: Real, const N: usize>(
        &self,
        rotated: Vec3<R>,
        v_t: Vec3<R>,
        k_t: R,
        gamma_t: R,
        dt: f64,
        cap: R,
        extra: &mut <Self::Extra as LawHistory>::Lanes<R>,
    ) -> (Vec3<R>, Vec3<R>, R::Mask) {
        let _ = extra;
        self.tangential().step_lanes::<R, N>(rotated, v_t, k_t, gamma_t, dt, cap)
    }
    /// Normal elastic part.
    fn normal(&self) -> NormalElastic;
    /// Normal damping part.
    fn damping(&self) -> NormalDamping;
    /// Tangential elastic part.
    fn tangential(&self) -> Tangential;
    /// Tangential damping part.
    fn tangential_damping(&self) -> TangentialDamping;
    /// Coulomb coefficient.
    fn friction(&self) -> f64;
    /// Rolling resistance.
    fn rolling(&self) -> Rolling;
    /// Twisting resistance.
    fn twisting(&self) -> Twisting;
}

impl LawParts for ContactLaw {
    type Extra = ();
    #[inline(always)]
    fn normal(&self) -> NormalElastic {
        self.normal
    }
    #[inline(always)]
    fn damping(&self) -> NormalDamping {
        self.damping
    }
    #[inline(always)]
    fn tangential(&self) -> Tangential {
        self.tangential
    }
    #[inline(always)]
    fn tangential_damping(&self) -> TangentialDamping {
        self.tangential_damping
    }
    #[inline(always)]
    fn friction(&self) -> f64 {
        self.friction
    }
    #[inline(always)]
    fn rolling(&self) -> Rolling {
        self.rolling
    }
    #[inline(always)]
    fn twisting(&self) -> Twisting {
        self.twisting
    }
}

/// Something run with the parts of a contact law as a type (`NormalElastic::route`; the
/// engine's force passes).
pub trait VisitParts {
    /// What the run gives.
    type Out;
    /// Runs with the parts `law`.
    fn visit<P: LawParts>(self, law: &P) -> Self::Out;
}

/// The accessors of [`LawParts`] named, each read from the inner law `self.law` (a composition
/// that changes some parts of a law and keeps the others).
macro_rules! delegate_parts {
    ($($part:ident: $ty:ty),* $(,)?) => {
        $(
            #[inline(always)]
            fn $part(&self) -> $ty {
                self.law.$part()
            }
        )*
    };
}

/// A contact law whose normal part `N` keeps a per-contact history: the normal response reads
/// and updates it ([`LawParts::Extra`] = `N::History`); every other part is that of `law`, read
/// at each contact as on the general kernel. The engine runs a law with such a normal part
/// through this composition (`NormalElastic::route`, the default of
/// [`LawHistory::route_normal`]), one per registered law with history, written once.
#[derive(Clone, Copy, Debug)]
pub struct WithNormal<N> {
    pub(crate) law: ContactLaw,
    pub(crate) normal: N,
}

impl<N: NormalLaw> LawParts for WithNormal<N> {
    type Extra = N::History;
    #[inline(always)]
    fn normal_response<R: Real>(&self, xi: R, r_eff: R, extra: &mut <Self::Extra as LawHistory>::Lanes<R>) -> NormalResponse<R> {
        self.normal.response_lanes(xi, r_eff, extra)
    }
    #[inline]
    fn normal_energy(&self, xi: f64, r_eff: f64, extra: &N::History) -> f64 {
        self.normal.energy(xi, r_eff, extra)
    }
    delegate_parts!(normal: NormalElastic, damping: NormalDamping, tangential: Tangential, tangential_damping: TangentialDamping, friction: f64, rolling: Rolling, twisting: Twisting);
}

/// A contact law whose tangential part `T` keeps a per-contact history of its own (and whose
/// normal part none): the tangential step reads and updates it ([`LawParts::Extra`] =
/// `T::Extra`); every other part is that of `law`. The engine runs such a law through this
/// composition (`Tangential::route`, [`LawHistory::route_tangential`]), one per registered
/// tangential law with history, written once.
#[derive(Clone, Copy, Debug)]
pub struct WithTangential<T> {
    pub(crate) law: ContactLaw,
    pub(crate) tangential: T,
}

impl<T: TangentialLaw> LawParts for WithTangential<T> {
    type Extra = T::Extra;
    #[inline(always)]
    fn tangential_step<R: Real, const N: usize>(
        &self,
        rotated: Vec3<R>,
        v_t: Vec3<R>,
        k_t: R,
        gamma_t: R,
        dt: f64,
        cap: R,
        extra: &mut <Self::Extra as LawHistory>::Lanes<R>,
    ) -> (Vec3<R>, Vec3<R>, R::Mask) {
        self.tangential.step_lanes::<R, N>(rotated, v_t, k_t, gamma_t, dt, cap, extra)
    }
    delegate_parts!(normal: NormalElastic, damping: NormalDamping, tangential: Tangential, tangential_damping: TangentialDamping, friction: f64, rolling: Rolling, twisting: Twisting);
}

/// A contact law whose normal part `N` and tangential part `T` both keep a per-contact history:
/// the law's history is the pair of theirs ([`LawParts::Extra`] = `(N::History, T::Extra)`, one
/// column written under `"<normal>+<tangential>"`), the normal response reading and updating
/// the first, the tangential step the second; every other part is that of `law`
/// ([`LawHistory::route_both`]).
#[derive(Clone, Copy, Debug)]
pub struct WithBoth<N, T> {
    pub(crate) law: ContactLaw,
    pub(crate) normal: N,
    pub(crate) tangential: T,
}

impl<N: NormalLaw, T: TangentialLaw> LawParts for WithBoth<N, T> {
    type Extra = (N::History, T::Extra);
    #[inline(always)]
    fn normal_response<R: Real>(&self, xi: R, r_eff: R, extra: &mut <Self::Extra as LawHistory>::Lanes<R>) -> NormalResponse<R> {
        self.normal.response_lanes(xi, r_eff, &mut extra.0)
    }
    #[inline]
    fn normal_energy(&self, xi: f64, r_eff: f64, extra: &Self::Extra) -> f64 {
        self.normal.energy(xi, r_eff, &extra.0)
    }
    #[inline(always)]
    fn tangential_step<R: Real, const N2: usize>(
        &self,
        rotated: Vec3<R>,
        v_t: Vec3<R>,
        k_t: R,
        gamma_t: R,
        dt: f64,
        cap: R,
        extra: &mut <Self::Extra as LawHistory>::Lanes<R>,
    ) -> (Vec3<R>, Vec3<R>, R::Mask) {
        self.tangential.step_lanes::<R, N2>(rotated, v_t, k_t, gamma_t, dt, cap, &mut extra.1)
    }
    delegate_parts!(normal: NormalElastic, damping: NormalDamping, tangential: Tangential, tangential_damping: TangentialDamping, friction: f64, rolling: Rolling, twisting: Twisting);
}

/// Something run with a normal law that keeps a per-contact history as its type
/// (`NormalElastic::route_history`, [`LawHistory::route_history`]): the specialised kernels of
/// [`HistoryNormal`].
pub trait VisitNormal {
    /// What the run gives.
    type Out;
    /// Runs with the normal law `normal` (its [`NormalLaw::History`] not `()`).
    fn visit<N: NormalLaw>(self, normal: N) -> Self::Out;
    /// Runs for a normal law without history, which this route does not compile kernels for.
    fn without_history(self) -> Self::Out;
}

/// Something run with a tangential law that keeps a per-contact history as its type
/// (`Tangential::route_history`, [`LawHistory::route_tangential_history`]): the specialised
/// kernels of [`HistoryTangential`].
pub trait VisitTangential {
    /// What the run gives.
    type Out;
    /// Runs with the tangential law `tangential` (its [`TangentialLaw::Extra`] not `()`).
    fn visit<T: TangentialLaw>(self, tangential: T) -> Self::Out;
    /// Runs for a tangential law without history (or none), which this route does not compile
    /// kernels for.
    fn without_history(self) -> Self::Out;
}

/// A normal law `N` with its own per-contact history in place of the normal part of a
/// specialised law `L` without history ([`HookeCundallStrack`], [`HookeSlipActivation`], with
/// or without [`WithRolling`]): the normal response is `N`'s, reading and updating the history
/// ([`LawParts::Extra`] = `N::History`); every other part is a constant variant of `L`, whose own
/// normal part is not read. The window and fused kernels of such a law are those of `L` with
/// the history gathered and scattered beside the tangential spring; one composition for every
/// registered normal law with history (`Specialized::NormalHistory`).
#[derive(Clone, Copy, Debug)]
pub struct HistoryNormal<N, L> {
    pub(crate) normal: N,
    /// `normal` as the contact law's enum ([`LawParts::normal`]).
    pub(crate) elastic: NormalElastic,
    pub(crate) law: L,
}

impl<N: NormalLaw, L: LawParts<Extra = ()>> LawParts for HistoryNormal<N, L> {
    type Extra = N::History;
    #[inline(always)]
    fn normal_response<R: Real>(&self, xi: R, r_eff: R, extra: &mut <Self::Extra as LawHistory>::Lanes<R>) -> NormalResponse<R> {
        self.normal.response_lanes(xi, r_eff, extra)
    }
    #[inline(always)]
    fn normal(&self) -> NormalElastic {
        self.elastic
    }
    delegate_parts!(damping: NormalDamping, tangential: Tangential, tangential_damping: TangentialDamping, friction: f64, rolling: Rolling, twisting: Twisting);
}

/// The parts beside a normal law with its own history that have specialised kernels
/// ([`HistoryNormal`]): the tangential laws of the Hooke composition, with and without rolling
/// resistance. Their normal stiffness is NaN: it is not read (the normal part is the law's).
#[derive(Clone, Copy, Debug)]
pub enum HistoryRest {
    /// The linear Cundall–Strack spring.
    Linear(HookeCundallStrack),
    /// The linear spring with rolling resistance.
    LinearRolling(WithRolling<HookeCundallStrack>),
    /// The linear spring with a slip-activation time.
    SlipActivation(HookeSlipActivation),
    /// The slip-activation spring with rolling resistance.
    SlipActivationRolling(WithRolling<HookeSlipActivation>),
}

/// A tangential law `T` with its own per-contact history in place of the tangential part of a
/// specialised law `L` without history (the Hooke normal force of [`HookeCundallStrack`], with
/// or without [`WithRolling`]): the tangential step is `T`'s, reading and updating the history
/// ([`LawParts::Extra`] = `T::Extra`), and so are k_t and the step on unloading (its constant
/// variant of [`Tangential`]); every other part is a constant variant of `L`, whose own
/// tangential part is not read. The window and fused kernels of such a law are those of `L`
/// with the history gathered and scattered beside the tangential spring; one composition for
/// every registered tangential law with history (`Specialized::TangentialHistory`).
#[derive(Clone, Copy, Debug)]
pub struct HistoryTangential<T, L> {
    pub(crate) tangential: T,
    pub(crate) law: L,
}

impl<T: TangentialLaw, L: LawParts<Extra = ()>> LawParts for HistoryTangential<T, L> {
    type Extra = T::Extra;
    #[inline(always)]
    fn tangential_step<R: Real, const N: usize>(
        &self,
        rotated: Vec3<R>,
        v_t: Vec3<R>,
        k_t: R,
        gamma_t: R,
        dt: f64,
        cap: R,
        extra: &mut <Self::Extra as LawHistory>::Lanes<R>,
    ) -> (Vec3<R>, Vec3<R>, R::Mask) {
        self.tangential.step_lanes::<R, N>(rotated, v_t, k_t, gamma_t, dt, cap, extra)
    }
    #[inline(always)]
    fn tangential(&self) -> Tangential {
        self.tangential.into()
    }
    delegate_parts!(normal: NormalElastic, damping: NormalDamping, tangential_damping: TangentialDamping, friction: f64, rolling: Rolling, twisting: Twisting);
}

/// The parts beside a tangential law with its own history that have specialised kernels
/// ([`HistoryTangential`]): the Hooke normal force, with and without rolling resistance. Their
/// tangential stiffness is NaN: it is not read (the tangential part is the law's).
#[derive(Clone, Copy, Debug)]
pub enum TangentialRest {
    /// The Hooke normal force.
    Hooke(HookeCundallStrack),
    /// The Hooke normal force with rolling resistance.
    HookeRolling(WithRolling<HookeCundallStrack>),
}

/// Hertz normal force, incremental Mindlin (no rescaling on unloading), any damping, Coulomb
/// friction, no rolling or twisting resistance: the `hertz_mindlin` preset.
#[derive(Clone, Copy, Debug)]
pub struct HertzMindlin {
    pub(crate) effective_modulus: f64,
    pub(crate) effective_shear_modulus: f64,
    pub(crate) damping: NormalDamping,
    pub(crate) tangential_damping: TangentialDamping,
    pub(crate) friction: f64,
}

/// Hooke normal force, linear Cundall–Strack spring, any damping, Coulomb friction, no rolling
/// or twisting resistance: the `hooke_cundall_strack` preset.
#[derive(Clone, Copy, Debug)]
pub struct HookeCundallStrack {
    pub(crate) normal_stiffness: f64,
    pub(crate) tangential_stiffness: f64,
    pub(crate) damping: NormalDamping,
    pub(crate) tangential_damping: TangentialDamping,
    pub(crate) friction: f64,
}

/// [`HookeCundallStrack`] with the slip-activation time τ of [`SlipActivation`]:
/// the `hooke_cundall_strack` preset with `slip_activation_time` > 0.
#[derive(Clone, Copy, Debug)]
pub struct HookeSlipActivation {
    pub(crate) normal_stiffness: f64,
    pub(crate) tangential_stiffness: f64,
    pub(crate) activation_time: f64,
    pub(crate) damping: NormalDamping,
    pub(crate) tangential_damping: TangentialDamping,
    pub(crate) friction: f64,
}

macro_rules! common_parts {
    () => {
        #[inline(always)]
        fn damping(&self) -> NormalDamping {
            self.damping
        }
        #[inline(always)]
        fn tangential_damping(&self) -> TangentialDamping {
            self.tangential_damping
        }
        #[inline(always)]
        fn friction(&self) -> f64 {
            self.friction
        }
        #[inline(always)]
        fn rolling(&self) -> Rolling {
            Rolling::None
        }
        #[inline(always)]
        fn twisting(&self) -> Twisting {
            Twisting::None
        }
    };
}

impl LawParts for HertzMindlin {
    type Extra = ();
    #[inline(always)]
    fn normal(&self) -> NormalElastic {
        NormalElastic::Hertz(Hertz { effective_modulus: self.effective_modulus })
    }
    #[inline(always)]
    fn tangential(&self) -> Tangential {
        Tangential::Mindlin(Mindlin { effective_shear_modulus: self.effective_shear_modulus, rescale_on_unloading: false })
    }
    common_parts!();
}

impl LawParts for HookeCundallStrack {
    type Extra = ();
    #[inline(always)]
    fn normal(&self) -> NormalElastic {
        NormalElastic::Hooke(Hooke { stiffness: self.normal_stiffness })
    }
    #[inline(always)]
    fn tangential(&self) -> Tangential {
        Tangential::Linear(Linear { stiffness: self.tangential_stiffness })
    }
    common_parts!();
}

impl LawParts for HookeSlipActivation {
    type Extra = ();
    #[inline(always)]
    fn normal(&self) -> NormalElastic {
        NormalElastic::Hooke(Hooke { stiffness: self.normal_stiffness })
    }
    #[inline(always)]
    fn tangential(&self) -> Tangential {
        Tangential::SlipActivation(SlipActivation { stiffness: self.tangential_stiffness, activation_time: self.activation_time })
    }
    common_parts!();
}

/// A specialised law `L` with rolling resistance added: a spring–dashpot on the relative rolling
/// rotation, capped at μ_r R* F_n ([`SpringDashpot`]), no twisting resistance. E2's law
/// (SPEC §6.1) is `WithRolling<HookeCundallStrack>`.
#[derive(Clone, Copy, Debug)]
pub struct WithRolling<L> {
    pub(crate) law: L,
    /// k_r, γ_r, μ_r.
    pub(crate) stiffness: f64,
    pub(crate) damping: f64,
    pub(crate) friction: f64,
}

impl<L: LawParts> LawParts for WithRolling<L> {
    type Extra = L::Extra;
    #[inline(always)]
    fn normal_response<R: Real>(&self, xi: R, r_eff: R, extra: &mut <Self::Extra as LawHistory>::Lanes<R>) -> NormalResponse<R> {
        self.law.normal_response(xi, r_eff, extra)
    }
    delegate_parts!(normal: NormalElastic, damping: NormalDamping, tangential: Tangential, tangential_damping: TangentialDamping, friction: f64);
    #[inline(always)]
    fn rolling(&self) -> Rolling {
        Rolling::SpringDashpot(SpringDashpot { stiffness: self.stiffness, damping: self.damping, friction: self.friction })
    }
    #[inline(always)]
    fn twisting(&self) -> Twisting {
        Twisting::None
    }
}

/// A law recognised as one of the specialised combinations, or the general law.
#[derive(Clone, Copy, Debug)]
pub enum Specialized {
    /// See [`HertzMindlin`].
    HertzMindlin(HertzMindlin),
    /// See [`HookeCundallStrack`].
    HookeCundallStrack(HookeCundallStrack),
    /// [`HertzMindlin`] with rolling resistance.
    HertzMindlinRolling(WithRolling<HertzMindlin>),
    /// [`HookeCundallStrack`] with rolling resistance (E2's law).
    HookeCundallStrackRolling(WithRolling<HookeCundallStrack>),
    /// See [`HookeSlipActivation`].
    HookeSlipActivation(HookeSlipActivation),
    /// [`HookeSlipActivation`] with rolling resistance (E2's law with a slip-activation time).
    HookeSlipActivationRolling(WithRolling<HookeSlipActivation>),
    /// A normal law with its own per-contact history and the parts `HistoryRest` beside it: run
    /// as [`HistoryNormal`] with the law's normal part as its type (`NormalElastic::route_history`).
    NormalHistory(ContactLaw, HistoryRest),
    /// A tangential law with its own per-contact history beside the Hooke normal force (and a
    /// normal law without history), with or without rolling resistance: run as
    /// [`HistoryTangential`] with the tangential law as its type (`Tangential::route_history`).
    TangentialHistory(ContactLaw, TangentialRest),
    /// Anything else (twisting resistance, no friction, rescaled Mindlin, mixed parts, a
    /// normal law with its own history beside other parts): evaluated through [`ContactLaw`]
    /// itself, or through [`WithNormal`] for a normal law with history (`NormalElastic::route`).
    General(ContactLaw),
}

impl Specialized {
    /// True for the compositions with window and fused kernels (`sim::lanes::WindowLaw`).
    pub fn has_window_kernel(&self) -> bool {
        !matches!(self, Specialized::General(_))
    }
}

impl ContactLaw {
    /// The general kernel for this law: [`Specialized::General`] (a normal law with history
    /// is routed to its composition [`WithNormal`] when the force pass runs).
    pub fn general(&self) -> Specialized {
        Specialized::General(*self)
    }

    /// The fastest evaluation path for this law.
    pub fn specialize(&self) -> Specialized {
        if self.twisting != Twisting::None {
            return self.general();
        }
        let (damping, tangential_damping, friction) = (self.damping, self.tangential_damping, self.friction);
        let rolling = match self.rolling {
            Rolling::None => None,
            Rolling::SpringDashpot(SpringDashpot { stiffness, damping, friction }) => Some((stiffness, damping, friction)),
        };
        if self.normal.has_history() {
            // the normal part is the law's own (`HistoryNormal`): the rest's is not read
            let normal_stiffness = f64::NAN;
            let rest = match (self.tangential, rolling) {
                (Tangential::Linear(Linear { stiffness: tangential_stiffness }), r) => {
                    let law = HookeCundallStrack { normal_stiffness, tangential_stiffness, damping, tangential_damping, friction };
                    match r {
                        None => HistoryRest::Linear(law),
                        Some((stiffness, damping, friction)) => HistoryRest::LinearRolling(WithRolling { law, stiffness, damping, friction }),
                    }
                }
                (Tangential::SlipActivation(SlipActivation { stiffness: tangential_stiffness, activation_time }), r) => {
                    let law = HookeSlipActivation { normal_stiffness, tangential_stiffness, activation_time, damping, tangential_damping, friction };
                    match r {
                        None => HistoryRest::SlipActivation(law),
                        Some((stiffness, damping, friction)) => HistoryRest::SlipActivationRolling(WithRolling { law, stiffness, damping, friction }),
                    }
                }
                _ => return self.general(),
            };
            return Specialized::NormalHistory(*self, rest);
        }
        if self.tangential.has_history() {
            // the tangential part is the law's own (`HistoryTangential`): the rest's is not read
            let NormalElastic::Hooke(Hooke { stiffness: normal_stiffness }) = self.normal else { return self.general() };
            let law = HookeCundallStrack { normal_stiffness, tangential_stiffness: f64::NAN, damping, tangential_damping, friction };
            let rest = match rolling {
                None => TangentialRest::Hooke(law),
                Some((stiffness, damping, friction)) => TangentialRest::HookeRolling(WithRolling { law, stiffness, damping, friction }),
            };
            return Specialized::TangentialHistory(*self, rest);
        }
        match (self.normal, self.tangential, rolling) {
            (NormalElastic::Hertz(Hertz { effective_modulus }), Tangential::Mindlin(Mindlin { effective_shear_modulus, rescale_on_unloading: false }), r) => {
                let law = HertzMindlin { effective_modulus, effective_shear_modulus, damping, tangential_damping, friction };
                match r {
                    None => Specialized::HertzMindlin(law),
                    Some((stiffness, damping, friction)) => Specialized::HertzMindlinRolling(WithRolling { law, stiffness, damping, friction }),
                }
            }
            (NormalElastic::Hooke(Hooke { stiffness: normal_stiffness }), Tangential::Linear(Linear { stiffness: tangential_stiffness }), r) => {
                let law = HookeCundallStrack { normal_stiffness, tangential_stiffness, damping, tangential_damping, friction };
                match r {
                    None => Specialized::HookeCundallStrack(law),
                    Some((stiffness, damping, friction)) => Specialized::HookeCundallStrackRolling(WithRolling { law, stiffness, damping, friction }),
                }
            }
            (NormalElastic::Hooke(Hooke { stiffness: normal_stiffness }), Tangential::SlipActivation(SlipActivation { stiffness: tangential_stiffness, activation_time }), r) => {
                let law = HookeSlipActivation { normal_stiffness, tangential_stiffness, activation_time, damping, tangential_damping, friction };
                match r {
                    None => Specialized::HookeSlipActivation(law),
                    Some((stiffness, damping, friction)) => Specialized::HookeSlipActivationRolling(WithRolling { law, stiffness, damping, friction }),
                }
            }
            _ => Specialized::General(*self),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::{evaluate_parts, pair_kinematics, ContactParams, ContactState, Partner};
    use crate::dim::{Dim, VectorOps, D2, D3};
    use glam::{DVec2, DVec3};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Random contacts (overlaps, velocities, spins, stored histories, some sliding) evaluated
    /// through the specialised parts and through the general law: same bits, same histories.
    fn same_bits<D: Dim, P: LawParts>(special: &P, general: &ContactLaw, mk: impl Fn(&mut ChaCha8Rng) -> (D::Vector, D::Vector, D::AngVector, D::Vector)) {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (mut contacts, mut sliding) = (0, 0);
        for _ in 0..2000 {
            let (r, v, w, spring) = mk(&mut rng);
            let (ri, rj) = (0.4 + 0.2 * rng.random::<f64>(), 0.4 + 0.2 * rng.random::<f64>());
            let Some(kin) = pair_kinematics::<D>(r, ri, rj, 1.0 + rng.random::<f64>(), 0.5 + rng.random::<f64>(), D::Vector::ZERO, v, w, w * 0.3) else {
                continue;
            };
            let spring = crate::contact::TangentialHistory(spring);
            let state = ContactState::<D> { spring, overlap: if rng.random::<f64>() < 0.2 { 0.0 } else { kin.overlap * 1.01 }, ..Default::default() };
            let (mut a, mut b) = (state, state);
            let oa = evaluate_parts(special, &kin, &mut a, &mut Default::default(), 1e-3);
            let ob = evaluate_parts(general, &kin, &mut b, &mut (), 1e-3);
            assert_eq!(format!("{oa:?} {a:?}"), format!("{ob:?} {b:?}"));
            contacts += 1;
            sliding += oa.sliding as usize;
        }
        assert!(contacts > 1000 && sliding > 200 && sliding < contacts - 200, "{contacts} contacts, {sliding} sliding");
    }

    /// Random contacts with a random stored history of the law's own (`extra`) evaluated through
    /// a specialised composition and through the general one: same bits, same histories.
    fn same_bits_with_history<D: Dim, P: LawParts, G: LawParts<Extra = P::Extra>>(
        special: &P,
        general: &G,
        mk: impl Fn(&mut ChaCha8Rng) -> (D::Vector, D::Vector, D::AngVector, D::Vector),
        extra: impl Fn(&mut ChaCha8Rng, f64) -> P::Extra,
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let (mut contacts, mut sliding) = (0, 0);
        for _ in 0..2000 {
            let (r, v, w, spring) = mk(&mut rng);
            let (ri, rj) = (0.4 + 0.2 * rng.random::<f64>(), 0.4 + 0.2 * rng.random::<f64>());
            let Some(kin) = pair_kinematics::<D>(r, ri, rj, 1.0 + rng.random::<f64>(), 0.5 + rng.random::<f64>(), D::Vector::ZERO, v, w, w * 0.3) else {
                continue;
            };
            let spring = crate::contact::TangentialHistory(spring);
            let state = ContactState::<D> { spring, overlap: if rng.random::<f64>() < 0.2 { 0.0 } else { kin.overlap * 1.01 }, ..Default::default() };
            let e = extra(&mut rng, kin.overlap);
            let (mut a, mut b, mut ea, mut eb) = (state, state, e, e);
            let oa = evaluate_parts(special, &kin, &mut a, &mut ea, 1e-3);
            let ob = evaluate_parts(general, &kin, &mut b, &mut eb, 1e-3);
            assert_eq!(format!("{oa:?} {a:?} {ea:?}"), format!("{ob:?} {b:?} {eb:?}"));
            contacts += 1;
            sliding += oa.sliding as usize;
        }
        assert!(contacts > 1000 && sliding > 100 && sliding < contacts - 100, "{contacts} contacts, {sliding} sliding");
    }

    /// The specialised compositions of a normal law with history (`HistoryNormal`, every
    /// `HistoryRest`) give the bits of its general composition (`WithNormal`), loading (ξ_max
    /// below the overlap), unloading (above) and with a contact that has just formed (0).
    #[test]
    fn history_compositions_give_the_bits_of_the_general_law() {
        use crate::contact::{Hysteretic, MaxOverlap, NormalTable};
        let mut seen = [false; 4];
        for (slip, rolling) in [(None, false), (None, true), (Some(1e-2), false), (Some(1e-2), true)] {
            let hysteretic = Hysteretic { loading_stiffness: 1e4, unloading_stiffness: 3e4 };
            let mut p = ContactParams { normal: Some(NormalTable::Hysteretic(hysteretic)), ..Default::default() };
            (p.friction, p.normal_damping_rate, p.slip_activation_time) = (Some(0.3), Some(50.0), slip);
            if rolling {
                (p.rolling_stiffness, p.rolling_friction) = (Some(50.0), Some(0.01));
            }
            let law = p.build(Partner::Grain, "contact").unwrap();
            let Specialized::NormalHistory(_, rest) = law.specialize() else { panic!("{law:?} should be specialised") };
            let NormalElastic::Hysteretic(normal) = law.normal else { panic!("{law:?}") };
            let general = WithNormal { law, normal };
            let v3 = |rng: &mut ChaCha8Rng| DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
            let mk3 = |rng: &mut ChaCha8Rng| (DVec3::new(0.9 + 0.1 * rng.random::<f64>(), 0.2 * rng.random::<f64>(), 0.1), v3(rng), v3(rng), v3(rng) * 10f64.powf(7.0 * rng.random::<f64>() - 3.0));
            let mk2 = |rng: &mut ChaCha8Rng| {
                let v = DVec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
                (DVec2::new(0.9 + 0.1 * rng.random::<f64>(), 0.2 * rng.random::<f64>()), v, rng.random::<f64>() - 0.5, v * 10f64.powf(7.0 * rng.random::<f64>() - 3.0))
            };
            let extra = |rng: &mut ChaCha8Rng, xi: f64| {
                let u = rng.random::<f64>();
                MaxOverlap(if u < 0.2 { 0.0 } else { xi * (0.5 + 1.5 * u) })
            };
            let elastic = law.normal;
            match rest {
                HistoryRest::Linear(l) => {
                    let s = HistoryNormal { normal, elastic, law: l };
                    same_bits_with_history::<D3, _, _>(&s, &general, mk3, extra);
                    same_bits_with_history::<D2, _, _>(&s, &general, mk2, extra);
                    seen[0] = true;
                }
                HistoryRest::LinearRolling(l) => {
                    let s = HistoryNormal { normal, elastic, law: l };
                    same_bits_with_history::<D3, _, _>(&s, &general, mk3, extra);
                    same_bits_with_history::<D2, _, _>(&s, &general, mk2, extra);
                    seen[1] = true;
                }
                HistoryRest::SlipActivation(l) => {
                    let s = HistoryNormal { normal, elastic, law: l };
                    same_bits_with_history::<D3, _, _>(&s, &general, mk3, extra);
                    same_bits_with_history::<D2, _, _>(&s, &general, mk2, extra);
                    seen[2] = true;
                }
                HistoryRest::SlipActivationRolling(l) => {
                    let s = HistoryNormal { normal, elastic, law: l };
                    same_bits_with_history::<D3, _, _>(&s, &general, mk3, extra);
                    same_bits_with_history::<D2, _, _>(&s, &general, mk2, extra);
                    seen[3] = true;
                }
            }
        }
        assert_eq!(seen, [true; 4]);
        // frictionless (no tangential part) and twisting resistance keep the general kernel
        let hysteretic = Hysteretic { loading_stiffness: 1e4, unloading_stiffness: 3e4 };
        let mut p = ContactParams { normal: Some(NormalTable::Hysteretic(hysteretic)), ..Default::default() };
        p.friction = Some(0.0);
        assert!(matches!(p.build(Partner::Grain, "contact").unwrap().specialize(), Specialized::General(_)));
        (p.friction, p.rolling_stiffness, p.twisting_stiffness) = (Some(0.3), Some(1.0), Some(1.0));
        assert!(matches!(p.build(Partner::Grain, "contact").unwrap().specialize(), Specialized::General(_)));
    }

    /// The specialised compositions of a tangential law with history (`HistoryTangential`, both
    /// `TangentialRest`) give the bits of its general composition (`WithTangential`), for
    /// slip-weakening friction with a random accumulated slip (none, part of D_c, past it);
    /// beside a normal law with history, a Hertz normal law or twisting resistance the law keeps
    /// the general kernel.
    #[test]
    fn tangential_history_compositions_give_the_bits_of_the_general_law() {
        use crate::contact::tangential::{Slip, SlipWeakening};
        use crate::contact::{Hysteretic, NormalTable};
        let mut seen = [false; 2];
        for rolling in [false, true] {
            let mut p = ContactParams::preset("hooke_cundall_strack");
            (p.normal_stiffness, p.friction, p.normal_damping_rate) = (Some(1e4), Some(0.3), Some(50.0));
            if rolling {
                (p.rolling_stiffness, p.rolling_friction) = (Some(50.0), Some(0.01));
            }
            let tangential = SlipWeakening { stiffness: 3e3, residual_ratio: 0.3, weakening_distance: 1e-3 };
            let law = ContactLaw { tangential: tangential.into(), ..p.build(Partner::Grain, "contact").unwrap() };
            let Specialized::TangentialHistory(_, rest) = law.specialize() else { panic!("{law:?} should be specialised") };
            let general = WithTangential { law, tangential };
            let v3 = |rng: &mut ChaCha8Rng| DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
            let mk3 = |rng: &mut ChaCha8Rng| (DVec3::new(0.9 + 0.1 * rng.random::<f64>(), 0.2 * rng.random::<f64>(), 0.1), v3(rng), v3(rng), v3(rng) * 10f64.powf(7.0 * rng.random::<f64>() - 3.0));
            let mk2 = |rng: &mut ChaCha8Rng| {
                let v = DVec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
                (DVec2::new(0.9 + 0.1 * rng.random::<f64>(), 0.2 * rng.random::<f64>()), v, rng.random::<f64>() - 0.5, v * 10f64.powf(7.0 * rng.random::<f64>() - 3.0))
            };
            let extra = |rng: &mut ChaCha8Rng, _xi: f64| {
                let u = rng.random::<f64>();
                Slip(if u < 0.2 { 0.0 } else { 2e-3 * u })
            };
            match rest {
                TangentialRest::Hooke(l) => {
                    let s = HistoryTangential { tangential, law: l };
                    same_bits_with_history::<D3, _, _>(&s, &general, mk3, extra);
                    same_bits_with_history::<D2, _, _>(&s, &general, mk2, extra);
                    seen[0] = true;
                }
                TangentialRest::HookeRolling(l) => {
                    let s = HistoryTangential { tangential, law: l };
                    same_bits_with_history::<D3, _, _>(&s, &general, mk3, extra);
                    same_bits_with_history::<D2, _, _>(&s, &general, mk2, extra);
                    seen[1] = true;
                }
            }
            // beside a normal law with history: the general kernel (`WithBoth`)
            let hysteretic = Hysteretic { loading_stiffness: 1e4, unloading_stiffness: 3e4 };
            let mut h = ContactParams { normal: Some(NormalTable::Hysteretic(hysteretic)), ..Default::default() };
            h.friction = Some(0.3);
            let both = ContactLaw { tangential: tangential.into(), ..h.build(Partner::Grain, "contact").unwrap() };
            assert!(matches!(both.specialize(), Specialized::General(_)), "{both:?}");
            // with twisting resistance: the general kernel
            let twisting = ContactLaw { twisting: crate::contact::Twisting::SpringDashpot(crate::contact::rolling::SpringDashpot { stiffness: 1.0, damping: 0.0, friction: f64::INFINITY }), ..law };
            assert!(matches!(twisting.specialize(), Specialized::General(_)));
        }
        assert_eq!(seen, [true; 2]);
    }

    #[test]
    fn specialised_kernels_give_the_bits_of_the_general_law() {
        let mut hertz = ContactParams::preset("hertz_mindlin");
        hertz.young = Some(1e5);
        hertz.poisson = Some(0.3);
        hertz.tsuji_restitution = Some(0.5);
        let mut hooke = ContactParams::preset("hooke_cundall_strack");
        hooke.normal_stiffness = Some(1e4);
        hooke.normal_damping_rate = Some(50.0);
        hooke.friction = Some(0.3);
        let mut hertz_zeta = hertz.clone();
        hertz_zeta.tsuji_restitution = None;
        hertz_zeta.damping_fraction = Some(0.1);
        let mut hooke_e = hooke.clone();
        hooke_e.normal_damping_rate = None;
        hooke_e.restitution = Some(0.8);
        // rolling resistance on both (E2's law is `hooke_e` with it)
        let mut hertz_rolling = hertz_zeta.clone();
        hertz_rolling.rolling_stiffness = Some(2e-3);
        hertz_rolling.rolling_damping = Some(1e-4);
        hertz_rolling.rolling_friction = Some(0.05);
        let mut hooke_rolling = hooke_e.clone();
        hooke_rolling.rolling_stiffness = Some(50.0);
        hooke_rolling.rolling_friction = Some(0.01);
        // the slip-activation time on both Hooke variants (τ = 10 steps of the test's Δt)
        let mut hooke_slip = hooke.clone();
        hooke_slip.slip_activation_time = Some(1e-2);
        let mut hooke_rolling_slip = hooke_rolling.clone();
        hooke_rolling_slip.slip_activation_time = Some(1e-2);
        let mut checked = 0;
        for p in [hertz, hooke, hertz_zeta, hooke_e, hertz_rolling, hooke_rolling, hooke_slip, hooke_rolling_slip] {
            let law = p.build(Partner::Grain, "contact").unwrap();
            let v3 = |rng: &mut ChaCha8Rng| DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
            let mk3 = |rng: &mut ChaCha8Rng| (DVec3::new(0.9 + 0.1 * rng.random::<f64>(), 0.2 * rng.random::<f64>(), 0.1), v3(rng), v3(rng), v3(rng) * 10f64.powf(7.0 * rng.random::<f64>() - 3.0));
            let mk2 = |rng: &mut ChaCha8Rng| {
                let v = DVec2::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
                (DVec2::new(0.9 + 0.1 * rng.random::<f64>(), 0.2 * rng.random::<f64>()), v, rng.random::<f64>() - 0.5, v * 10f64.powf(7.0 * rng.random::<f64>() - 3.0))
            };
            match law.specialize() {
                Specialized::HertzMindlin(s) => {
                    same_bits::<D3, _>(&s, &law, mk3);
                    same_bits::<D2, _>(&s, &law, mk2);
                }
                Specialized::HookeCundallStrack(s) => {
                    same_bits::<D3, _>(&s, &law, mk3);
                    same_bits::<D2, _>(&s, &law, mk2);
                }
                Specialized::HertzMindlinRolling(s) => {
                    same_bits::<D3, _>(&s, &law, mk3);
                    same_bits::<D2, _>(&s, &law, mk2);
                }
                Specialized::HookeCundallStrackRolling(s) => {
                    same_bits::<D3, _>(&s, &law, mk3);
                    same_bits::<D2, _>(&s, &law, mk2);
                }
                Specialized::HookeSlipActivation(s) => {
                    same_bits::<D3, _>(&s, &law, mk3);
                    same_bits::<D2, _>(&s, &law, mk2);
                }
                Specialized::HookeSlipActivationRolling(s) => {
                    same_bits::<D3, _>(&s, &law, mk3);
                    same_bits::<D2, _>(&s, &law, mk2);
                }
                Specialized::NormalHistory(..) | Specialized::TangentialHistory(..) | Specialized::General(_) => panic!("{law:?} should be specialised"),
            }
            checked += 1;
        }
        assert_eq!(checked, 8);
        // the composition a normal law with history runs through (`WithNormal`), here with the
        // laws without history, gives the bits of the general law (the normal part called
        // directly instead of through the enum; every other part that of the law)
        let mut with_rolling = ContactParams::preset("hertz_mindlin");
        (with_rolling.young, with_rolling.damping_fraction, with_rolling.mindlin_rescale) = (Some(1e5), Some(0.1), Some(true));
        (with_rolling.rolling_stiffness, with_rolling.twisting_stiffness) = (Some(2e-3), Some(1e-3));
        let mut hooke_twist = ContactParams::preset("hooke_cundall_strack");
        (hooke_twist.normal_stiffness, hooke_twist.restitution, hooke_twist.twisting_stiffness) = (Some(1e4), Some(0.7), Some(1.0));
        for p in [with_rolling, hooke_twist] {
            let law = p.build(Partner::Grain, "contact").unwrap();
            let v3 = |rng: &mut ChaCha8Rng| DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
            let mk3 = |rng: &mut ChaCha8Rng| (DVec3::new(0.9 + 0.1 * rng.random::<f64>(), 0.2 * rng.random::<f64>(), 0.1), v3(rng), v3(rng), v3(rng) * 10f64.powf(7.0 * rng.random::<f64>() - 3.0));
            match law.normal {
                NormalElastic::Hertz(normal) => same_bits::<D3, _>(&WithNormal { law, normal }, &law, mk3),
                NormalElastic::Hooke(normal) => same_bits::<D3, _>(&WithNormal { law, normal }, &law, mk3),
                other => panic!("{other:?}"),
            }
        }
        // twisting resistance keeps the general path
        let mut p = ContactParams::preset("hooke_cundall_strack");
        p.normal_stiffness = Some(1e4);
        p.rolling_stiffness = Some(1.0);
        p.twisting_stiffness = Some(1.0);
        assert!(matches!(p.build(Partner::Grain, "contact").unwrap().specialize(), Specialized::General(_)));
    }
}
