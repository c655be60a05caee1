//! Tangential part with history (SPEC §2.3): linear (Cundall–Strack) and incremental Mindlin.
//!
//! Sign convention: `v_t` is the tangential velocity of grain j relative to grain i at the contact
//! point, and the history and forces are those acting **on grain i**: a Cundall–Strack spring
//! stores s = ∫ v_t dt and pulls i along, F_t(on i) = k_t s + γ_t v_t (equivalently, on j,
//! −k_t s − γ_t v_t as in SPEC §2.3).

use super::coulomb::coulomb_cap_lanes;
use super::parts::VisitParts;
use super::normal::ParamsSchema;
use super::{Composition, ContactLaw, LawHistory, NormalLaw, Partner};
use crate::dim::VectorOps;
use crate::error::{CoreError, Result};
use crate::real::{select3, Real, Vec3};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::fmt::Debug;

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

/// What a tangential law's stored history holds ([`TangentialLaw::HISTORY`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HistoryKind {
    /// A length: the spring elongation (read as [`HistoryValue::Displacement`]).
    Displacement,
    /// A force: the elastic tangential force (read as [`HistoryValue::Force`]).
    Force,
}

/// Where a tangential law is built from its `[contact.tangential]` table: for which partner,
/// under which key, beside which normal law (the composition whose k_n, or E and ν, the
/// tangential stiffness is made from).
#[derive(Clone, Copy, Debug)]
pub struct TangentialContext<'a> {
    /// Grain–grain or grain–wall contacts.
    pub partner: Partner,
    /// The contact law's key (`contact`, `contact.wall`, …): the table's keys are
    /// `{field}.tangential.<key>`.
    pub field: &'a str,
    /// The normal law's composition.
    pub composition: Composition,
}

impl TangentialContext<'_> {
    /// The key `{field}.tangential.<name>` of the table, for errors.
    pub fn key(&self, name: &str) -> String {
        format!("{}.tangential.{name}", self.field)
    }

    /// k_n of a Hooke composition, for the law `law` (its config name), or the error that the
    /// law needs the Hooke normal law (`hooke` or `hysteretic`).
    pub fn hooke_stiffness(&self, law: &str) -> Result<f64> {
        match self.composition {
            Composition::Hooke { stiffness, .. } => Ok(stiffness),
            Composition::Hertz { .. } => Err(self.needs(law, "a Hooke normal law (`law = \"hooke\"` or `\"hysteretic\"`)")),
        }
    }

    /// E and ν (default 0) of a Hertz composition, for the law `law`, or the error that the law
    /// needs the Hertz normal law.
    pub fn hertz_moduli(&self, law: &str) -> Result<(f64, f64)> {
        match self.composition {
            Composition::Hertz { young, poisson } => Ok((young, poisson.unwrap_or(0.0))),
            Composition::Hooke { .. } => Err(self.needs(law, "the Hertz normal law (`law = \"hertz\"`)")),
        }
    }

    fn needs(&self, law: &str, normal: &str) -> CoreError {
        CoreError::Inconsistent(format!("`{}` = \"{law}\" needs {normal} (`{}.normal.law`)", self.key("law"), self.field))
    }
}

/// A tangential law with a per-contact history: the spring that carries the tangential force
/// below the Coulomb cap μ F_n, one step at a time.
///
/// The type is the law as the engine runs it (its fields in physical units, encoded in
/// checkpoints and outputs as the fields of its variant of [`Tangential`]). Register it in
/// [`tangential_laws!`] (the config name is the module's, the snake case of the type's name).
/// Each step of a contact runs, on every lane (`R = f64` for the general kernel, the vector
/// types for the window and fused kernels): the stored history rotated into the current tangent
/// plane, [`TangentialLaw::unloading_lanes`], [`TangentialLaw::trial_lanes`], the Coulomb cap,
/// and where the contact slides [`TangentialLaw::history_for_force_lanes`] and
/// [`TangentialLaw::sliding_lanes`] (`spring_step`).
pub trait TangentialLaw: Copy + Debug + PartialEq + Serialize + DeserializeOwned + Send + Sync + Into<Tangential> + 'static {
    /// What the stored history ([`TangentialHistory`]) holds: a length or a force.
    const HISTORY: HistoryKind;
    /// The law's per-contact history beyond the stored spring ([`LawHistory`]; `()` for a law
    /// without one, which then runs on the general law's kernels): kept beside the neighbor
    /// list, carried across rebuilds, reset when the contact opens and checkpointed by the
    /// engine, read and updated by [`TangentialLaw::step_lanes`].
    type Extra: LawHistory;
    /// The keys of its `[contact.tangential]` table (besides `law`), with
    /// `deny_unknown_fields`, in physical units or as ratios to the normal law's.
    type Params: Clone + Debug + PartialEq + Serialize + DeserializeOwned + ParamsSchema;
    /// The law from its table beside the normal law of `at`, checked: errors name the key
    /// (`{field}.tangential.<key>`, [`TangentialContext::key`]), the value and what is allowed,
    /// or the normal law the law needs. A [`Tangential`], so that a table may stand for the
    /// law of a neighbouring variant (the linear law's `slip_activation_time` > 0 is the
    /// slip-activation law).
    fn build(params: &Self::Params, at: &TangentialContext) -> Result<Tangential>;
    /// Checks the law (also one made in code); errors name `{field}.<key>`, the value and what
    /// is allowed.
    fn validate(&self, field: &str) -> Result<()>;
    /// k_t at overlap `xi` for effective radius `r_eff`, on every lane.
    fn stiffness_lanes<R: Real>(&self, xi: R, r_eff: R) -> R;
    /// The elastic part of the tangential force on grain i held by the stored history `h`
    /// (before the Coulomb cap, without damping).
    fn elastic_force<V: VectorOps>(&self, h: V) -> V;
    /// The increment of one step from the stored history already rotated into the current
    /// tangent plane (`rotated`), the tangential velocity `v_t`, k_t, γ_t and the step `dt`:
    /// the trial force on i (before the cap) and the history to keep where the contact sticks.
    fn trial_lanes<R: Real, const N: usize>(&self, rotated: Vec3<R>, v_t: Vec3<R>, k_t: R, gamma_t: R, dt: f64) -> (Vec3<R>, Vec3<R>);
    /// The history that holds exactly the tangential force `f` (the spring reset to the cap).
    fn history_for_force_lanes<R: Real, const N: usize>(&self, f: Vec3<R>) -> Vec3<R>;
    /// The rotated history adjusted for the change of overlap from `was` (the overlap of the
    /// last step, 0 for a contact that has just formed) to `overlap`, before the increment.
    /// Default: unchanged.
    #[inline(always)]
    fn unloading_lanes<R: Real, const N: usize>(&self, rotated: Vec3<R>, was: R, overlap: R) -> Vec3<R> {
        let _ = (was, overlap);
        rotated
    }
    /// The force on i and the history to store, from the capped force `f`, the history that
    /// holds it (`at_cap`), the trial force and history (`trial`, `kept`) and where the contact
    /// slides. Default: the Coulomb cap — `f`, and `at_cap` where it slides, `kept` elsewhere.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn sliding_lanes<R: Real, const N: usize>(&self, dt: f64, f: Vec3<R>, at_cap: Vec3<R>, trial: Vec3<R>, kept: Vec3<R>, sliding: R::Mask) -> (Vec3<R>, Vec3<R>) {
        let _ = (dt, trial);
        (f, select3::<R>(sliding, at_cap, kept))
    }
    /// One step of a contact from the stored spring rotated into the current tangent plane
    /// (`rotated`), v_t, k_t, γ_t, the step `dt`, the Coulomb cap μ F_n and the law's own
    /// history `extra` (read and updated): the tangential force on i, the spring to store and
    /// where the contact slides. Default: `spring_step` — the increment, the cap, the history
    /// past it — which a law without history of its own keeps; a law with one replaces it.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn step_lanes<R: Real, const N: usize>(
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
        spring_step::<R, N, Self>(self, rotated, v_t, k_t, gamma_t, dt, cap, |_, _, _| {})
    }
}

/// The registry of tangential laws: `module::Type` per law, the module a file
/// `contact/tangential/<module>.rs` and its name the law's name in [`Tangential`]'s encoding
/// (the snake case of `Type`). Generates the modules, [`Tangential`] (the variant
/// [`Tangential::None`] first, then one per law in registry order: checkpoints encode the
/// variant's index, so a new law is appended last) and its dispatch.
macro_rules! tangential_laws {
    ($($module:ident :: $Law:ident),* $(,)?) => {
        $(
            mod $module;
            pub use $module::*;
        )*

        family_enum! {
            /// The tangential elastic law of a contact law: none (frictionless) or one of the
            /// registered laws ([`TangentialLaw`]), encoded as the variant's name and the law's
            /// fields (`"none"` for none).
            Tangential { [None: "No tangential force (frictionless)."] $($module::$Law),* }
        }

        impl Tangential {
            /// What the stored history holds; `None` without a tangential part.
            #[inline]
            pub fn history_kind(&self) -> Option<HistoryKind> {
                match self {
                    Tangential::None => None,
                    $(Tangential::$Law(_) => Some(<$Law as TangentialLaw>::HISTORY),)*
                }
            }

            /// True when the law keeps a per-contact history of its own beyond the stored
            /// spring ([`TangentialLaw::Extra`] not `()`).
            pub fn has_history(&self) -> bool {
                match self {
                    Tangential::None => false,
                    $(Tangential::$Law(_) => <<$Law as TangentialLaw>::Extra as LawHistory>::WIDTH > 0,)*
                }
            }

            /// Checks the law ([`TangentialLaw::validate`]); `field` is the contact law's key.
            pub fn validate(&self, field: &str) -> Result<()> {
                match self {
                    Tangential::None => Ok(()),
                    $(Tangential::$Law(l) => l.validate(field),)*
                }
            }

            /// The elastic part of the tangential force on grain i held by the history `h`
            /// (before the Coulomb cap, without damping): k_t s for the linear laws, the stored
            /// force for Mindlin, zero without a tangential part.
            #[inline]
            pub fn elastic_force<V: VectorOps>(&self, h: TangentialHistory<V>) -> V {
                match self {
                    Tangential::None => V::ZERO,
                    $(Tangential::$Law(l) => l.elastic_force(h.0),)*
                }
            }

            /// [`Tangential::stiffness`] on every lane ([`TangentialLaw::stiffness_lanes`]; zero
            /// without a tangential part): the one implementation, run by the general kernel
            /// (`f64`) and the engine's vector paths.
            #[inline(always)]
            pub(crate) fn stiffness_lanes<R: Real>(&self, xi: R, r_eff: R) -> R {
                match self {
                    Tangential::None => R::splat(0.0),
                    $(Tangential::$Law(l) => l.stiffness_lanes(xi, r_eff),)*
                }
            }

            /// The rotated history adjusted for the change of overlap ([`TangentialLaw::unloading_lanes`]).
            #[inline(always)]
            pub(crate) fn unloading_lanes<R: Real, const N: usize>(&self, rotated: Vec3<R>, was: R, overlap: R) -> Vec3<R> {
                match self {
                    Tangential::None => rotated,
                    $(Tangential::$Law(l) => l.unloading_lanes::<R, N>(rotated, was, overlap),)*
                }
            }

            /// One step of the law ([`TangentialLaw::step_lanes`]), for a law with a history
            /// of its own ([`TangentialLaw::Extra`]) as for a contact that has just formed (its
            /// history the default): the engine runs such laws through the compositions that
            /// keep it ([`Tangential::route`]). Without a tangential part: no force, the
            /// (zero) spring kept, not sliding.
            #[allow(clippy::too_many_arguments)]
            #[inline(always)]
            pub(crate) fn step_lanes<R: Real, const N: usize>(&self, rotated: Vec3<R>, v_t: Vec3<R>, k_t: R, gamma_t: R, dt: f64, cap: R) -> (Vec3<R>, Vec3<R>, R::Mask) {
                match self {
                    Tangential::None => {
                        let zero = R::splat(0.0);
                        ([zero; 3], rotated, zero.gt(zero))
                    }
                    $(Tangential::$Law(l) => {
                        let mut extra = <<$Law as TangentialLaw>::Extra as LawHistory>::splat::<R>(Default::default());
                        l.step_lanes::<R, N>(rotated, v_t, k_t, gamma_t, dt, cap, &mut extra)
                    })*
                }
            }

            /// Runs `v` with the parts of `law` (whose normal part keeps no history) as a type
            /// that reaches the tangential law's own history: `law` itself where it keeps none,
            /// [`WithTangential`](super::WithTangential) otherwise ([`LawHistory::route_tangential`]).
            #[inline(always)]
            pub(crate) fn route<V: VisitParts>(law: &ContactLaw, v: V) -> V::Out {
                match law.tangential {
                    Tangential::None => v.visit(law),
                    $(Tangential::$Law(t) => <<$Law as TangentialLaw>::Extra as LawHistory>::route_tangential(law, t, v),)*
                }
            }

            /// Runs `v` with the tangential law as its type where it keeps a history of its
            /// own, `v.without_history()` otherwise ([`LawHistory::route_tangential_history`]):
            /// the specialised kernels of such laws (`Specialized::TangentialHistory`).
            #[inline(always)]
            pub(crate) fn route_history<V: super::VisitTangential>(&self, v: V) -> V::Out {
                match *self {
                    Tangential::None => v.without_history(),
                    $(Tangential::$Law(t) => <<$Law as TangentialLaw>::Extra as LawHistory>::route_tangential_history(t, v),)*
                }
            }

            /// [`Tangential::route`] for a law whose normal part `normal` keeps a history:
            /// [`WithNormal`](super::WithNormal), or [`WithBoth`](super::WithBoth) where the
            /// tangential law keeps one too ([`LawHistory::route_both`]).
            #[inline(always)]
            pub(crate) fn route_with_normal<N: NormalLaw, V: VisitParts>(law: &ContactLaw, normal: N, v: V) -> V::Out {
                match law.tangential {
                    Tangential::None => v.visit(&super::WithNormal { law: *law, normal }),
                    $(Tangential::$Law(t) => <<$Law as TangentialLaw>::Extra as LawHistory>::route_both(law, normal, t, v),)*
                }
            }
        }

        /// The tangential law as a family table, `[contact.tangential]`: `law = "none"` or
        /// `law = "<name>"` of a registered law and that law's keys ([`TangentialLaw::Params`]).
        #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
        #[serde(tag = "law", rename_all = "snake_case")]
        pub enum TangentialTable {
            /// `law = "none"`: no tangential force (frictionless: `friction` is then 0).
            None(NoTangential),
            $(
                #[doc = concat!("`law = \"", stringify!($module), "\"`: [`", stringify!($Law), "`].")]
                $Law(<$Law as TangentialLaw>::Params),
            )*
        }

        impl TangentialTable {
            /// The config name of the law of this table.
            pub fn name(&self) -> &'static str {
                match self {
                    TangentialTable::None(_) => "none",
                    $(TangentialTable::$Law(_) => stringify!($module),)*
                }
            }

            /// The law of this table beside the normal law of `at`, checked
            /// ([`TangentialLaw::build`]; [`Tangential::None`] for `none`).
            pub fn build(&self, at: &TangentialContext) -> Result<Tangential> {
                match self {
                    TangentialTable::None(_) => Ok(Tangential::None),
                    $(TangentialTable::$Law(p) => <$Law as TangentialLaw>::build(p, at),)*
                }
            }
        }

        #[cfg(feature = "schema")]
        impl schemars::JsonSchema for TangentialTable {
            fn schema_name() -> std::borrow::Cow<'static, str> {
                "TangentialTable".into()
            }
            fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
                let alternatives = vec![
                    super::normal::tagged_table::<NoTangential>(generator, "none"),
                    $(super::normal::tagged_table::<<$Law as TangentialLaw>::Params>(generator, stringify!($module))),*
                ];
                schemars::json_schema!({
                    "description": "The tangential law as a family table, `[contact.tangential]`.",
                    "oneOf": alternatives
                })
            }
        }
    };
}

/// The table `law = "none"` of `[contact.tangential]`: no keys.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct NoTangential {}

tangential_laws! {
    linear::Linear,
    mindlin::Mindlin,
    slip_activation::SlipActivation,
    slip_weakening::SlipWeakening,
}

impl Tangential {
    /// The history `h` of a contact of this law, with its unit.
    #[inline]
    pub fn read<V: VectorOps>(&self, h: TangentialHistory<V>) -> HistoryValue<V> {
        match self.history_kind() {
            None => HistoryValue::None,
            Some(HistoryKind::Displacement) => HistoryValue::Displacement(h.0),
            Some(HistoryKind::Force) => HistoryValue::Force(h.0),
        }
    }

    /// The stored history that holds `value` for a contact of this law; an error when `value`
    /// is of the other kind (a displacement given to the Mindlin law, a force to the linear
    /// law, or anything but [`HistoryValue::None`] to a law without a tangential part).
    pub fn history<V: VectorOps>(&self, value: HistoryValue<V>) -> Result<TangentialHistory<V>> {
        match (self.history_kind(), value) {
            (None, HistoryValue::None) => Ok(TangentialHistory::ZERO),
            (Some(HistoryKind::Displacement), HistoryValue::Displacement(s)) => Ok(TangentialHistory(s)),
            (Some(HistoryKind::Force), HistoryValue::Force(f)) => Ok(TangentialHistory(f)),
            (kind, value) => {
                let allowed = match kind {
                    None => "none (the law has no tangential part)",
                    Some(HistoryKind::Displacement) => "a displacement (the law stores its spring elongation)",
                    Some(HistoryKind::Force) => "a force (the law stores its elastic tangential force)",
                };
                Err(CoreError::InvalidParameter {
                    field: format!("tangential history of the {self:?} law"),
                    value: format!("{value:?}"),
                    allowed: allowed.into(),
                })
            }
        }
    }

    /// Tangential stiffness at overlap `xi` for effective radius `r_eff`.
    #[inline]
    pub fn stiffness(&self, xi: f64, r_eff: f64) -> f64 {
        self.stiffness_lanes(xi, r_eff)
    }
}

/// One step of the tangential spring of law `law` with its Coulomb limit, on every lane: the
/// increment ([`TangentialLaw::trial_lanes`]), the cap |F_t| ≤ `cap` ([`coulomb_cap_lanes`]) and
/// the history to store — the incremented one, or where the contact slides the one that holds
/// exactly the capped force ([`TangentialLaw::history_for_force_lanes`]) as the law's
/// [`TangentialLaw::sliding_lanes`] makes it. Where some lane slides, `on_slide` sees the
/// incremented history, the one at the cap and where the contact slides (before
/// `sliding_lanes`): a law with a history of its own reads the slip of the step there (the
/// length cut off the spring). Returns the tangential force on i, the new history and where
/// the contact slides. The one implementation of the step (the default of
/// [`TangentialLaw::step_lanes`]), run by the general kernel (`f64`) and the engine's vector
/// paths.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn spring_step<R: Real, const N: usize, T: TangentialLaw>(
    law: &T,
    rotated: Vec3<R>,
    v_t: Vec3<R>,
    k_t: R,
    gamma_t: R,
    dt: f64,
    cap: R,
    on_slide: impl FnOnce(Vec3<R>, Vec3<R>, R::Mask),
) -> (Vec3<R>, Vec3<R>, R::Mask) {
    let (trial, kept) = law.trial_lanes::<R, N>(rotated, v_t, k_t, gamma_t, dt);
    let (f, sliding) = coulomb_cap_lanes::<R, N>(trial, cap);
    if R::branch_unless(sliding) {
        return (f, kept, sliding);
    }
    let at_cap = law.history_for_force_lanes::<R, N>(f);
    on_slide(kept, at_cap, sliding);
    let (force, history) = law.sliding_lanes::<R, N>(dt, f, at_cap, trial, kept, sliding);
    (force, history, sliding)
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
        let linear = Tangential::from(Linear { stiffness: 3e4 });
        let mindlin = Tangential::from(Mindlin { effective_shear_modulus: 1e6, rescale_on_unloading: false });
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

    /// Each registered law's name in the encoding is its module's (the registry's) and the
    /// encoding of every law — bincode (checkpoints) and JSON (outputs) — is that of the enum
    /// of struct variants it replaced, variant indices included, so every earlier checkpoint
    /// and output reads the same; `Debug` prints the law as before.
    #[test]
    fn the_registry_keeps_the_names_and_the_encoding_of_every_law() {
        #[derive(Serialize, Debug)]
        #[serde(rename_all = "snake_case")]
        enum Before {
            None,
            Linear { stiffness: f64 },
            Mindlin { effective_shear_modulus: f64, rescale_on_unloading: bool },
            SlipActivation { stiffness: f64, activation_time: f64 },
            SlipWeakening { stiffness: f64, residual_ratio: f64, weakening_distance: f64 },
        }
        let pairs = [
            (Tangential::None, Before::None),
            (Linear { stiffness: 3e4 }.into(), Before::Linear { stiffness: 3e4 }),
            (
                Mindlin { effective_shear_modulus: 1e6, rescale_on_unloading: true }.into(),
                Before::Mindlin { effective_shear_modulus: 1e6, rescale_on_unloading: true },
            ),
            (SlipActivation { stiffness: 2.0, activation_time: 0.25 }.into(), Before::SlipActivation { stiffness: 2.0, activation_time: 0.25 }),
            (
                SlipWeakening { stiffness: 2.0, residual_ratio: 0.5, weakening_distance: 1e-3 }.into(),
                Before::SlipWeakening { stiffness: 2.0, residual_ratio: 0.5, weakening_distance: 1e-3 },
            ),
        ];
        assert_eq!(pairs.len(), Tangential::NAMES.len() + 1);
        for (i, (law, before)) in pairs.iter().enumerate() {
            crate::contact::registry::assert_same_encoding(law, before, law.name());
            if i > 0 {
                assert_eq!(law.name(), Tangential::NAMES[i - 1]);
            }
        }
        assert_eq!(Tangential::None.name(), "none");
        assert_eq!(serde_json::to_string(&Tangential::None).unwrap(), "\"none\"");
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
