//! The normal elastic family (SPEC §2.1): one trait ([`NormalLaw`]), one type per law in its
//! own file (`contact/normal/<law>.rs`), and one registry ([`normal_laws!`]) that makes from the
//! list of laws everything the engine and the configs read:
//!
//! * [`NormalElastic`], the law of a [`ContactLaw`](super::ContactLaw) as a closed enum (one
//!   variant per law, encoded in checkpoints and outputs as before: the variant's name and the
//!   law's fields), with its dispatch (`response_lanes`, `energy`, `max_stiffness`, `validate`):
//!   static, one `match` on the law's parameters, the same for every lane;
//! * [`NormalTable`], the `[contact.normal]` table (`law = "<name>"` and the law's
//!   [`NormalLaw::Params`], unknown keys refused), its schema for the config reference and reader,
//!   and its build into the law ([`NormalLaw::build`]);
//! * the routing of a law with its own per-contact history ([`NormalLaw::History`]) to the
//!   force passes compiled for that history: the general kernel (`NormalElastic::route`) and
//!   the window and fused kernels (`NormalElastic::route_history`).
//!
//! A new normal law is one file here implementing [`NormalLaw`] and one line in the registry
//! at the end of this file.

use super::parts::{VisitNormal, VisitParts};
use super::{ContactLaw, DampingTable, LawHistory, Partner};
use crate::error::Result;
use crate::real::Real;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::fmt::Debug;

/// What the normal elastic part gives at one overlap (`R` = `f64`), or at one overlap per lane
/// (the engine's vector paths).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalResponse<R = f64> {
    /// Elastic force F_el(ξ) ≥ 0.
    pub force: R,
    /// Differential stiffness k_n = dF_el/dξ.
    pub stiffness: R,
    /// Secant stiffness F_el/ξ (Hooke: k_n; Hertz: (4/3) E*_ij √(R* ξ) = ⅔ k_n).
    pub secant: R,
}

/// The schema of a law's parameters, for the config reference and reader (a `JsonSchema` when
/// the `schema` feature is on; no requirement otherwise).
#[cfg(feature = "schema")]
pub trait ParamsSchema: schemars::JsonSchema {}
#[cfg(feature = "schema")]
impl<T: schemars::JsonSchema> ParamsSchema for T {}
/// The schema of a law's parameters (no requirement without the `schema` feature).
#[cfg(not(feature = "schema"))]
pub trait ParamsSchema {}
#[cfg(not(feature = "schema"))]
impl<T> ParamsSchema for T {}

/// The composition a normal law's table gives the other families' defaults and checks of:
/// the damping, tangential, rolling and twisting tables (or their defaults) are read into the
/// keys of this preset (`contact/families.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Composition {
    /// `hooke_cundall_strack` with k_n = `stiffness`, given by the law's table key `key`
    /// (the linear tangential spring k_t = ratio × k_n; the Hooke dampers).
    Hooke {
        /// k_n [force/length].
        stiffness: f64,
        /// The key of the law's table that holds it (errors of k_n name it).
        key: &'static str,
    },
    /// `hertz_mindlin` with Young's modulus E and Poisson's ratio ν of the grains (the Mindlin
    /// tangential law from the same E, ν; the Hertz dampers).
    Hertz {
        /// E.
        young: f64,
        /// ν (default 0).
        poisson: Option<f64>,
    },
}

/// Where a normal law is built: for which partner, under which key, beside which damping law.
#[derive(Clone, Debug)]
pub struct NormalContext<'a> {
    /// Grain–grain or grain–wall contacts.
    pub partner: Partner,
    /// The contact law's key (`contact`, `contact.wall`, …): the law's keys are
    /// `{field}.normal.<key>`.
    pub field: &'a str,
    /// The normal damping the contact is given, in either form of the config, if any.
    pub damping: Option<DampingChoice>,
}

/// A normal damping law as the config chose it: its name (the `law` of `[contact.damping]`:
/// `"restitution"`, `"tsuji"`, `"dashpot"`, `"critical_fraction"`, `"mass_proportional"`,
/// `"none"`), the key that chose it — `{field}.damping.law` for the table, the flat key
/// (`{field}.restitution`, `{field}.tsuji_restitution`, …) otherwise — and that key's value,
/// for errors to name.
#[derive(Clone, Debug, PartialEq)]
pub struct DampingChoice {
    /// The damping law's name in `[contact.damping]`.
    pub law: &'static str,
    /// The key that chose it.
    pub key: String,
    /// The key's value as the config wrote it (`"restitution"`, or the flat key's number).
    pub value: String,
}

impl DampingChoice {
    /// The damping given by a `[contact.damping]` table, or else by the flat keys, under `field`.
    pub(crate) fn of(table: Option<&DampingTable>, flat: &super::ContactParams, field: &str) -> Option<DampingChoice> {
        if let Some(t) = table {
            let law = t.name();
            return Some(DampingChoice { law, key: format!("{field}.damping.law"), value: format!("\"{law}\"") });
        }
        flat.flat_damping()
            .into_iter()
            .find_map(|(key, law, given)| given.map(|v| DampingChoice { law, key: format!("{field}.{key}"), value: v.to_string() }))
    }
}

/// A normal elastic law: F_el(ξ) ≥ 0 at overlap ξ > 0, its differential stiffness k_n = dF_el/dξ
/// and secant F_el/ξ, possibly depending on a per-contact history of its own.
///
/// The type is the law as the engine runs it (its fields in physical units, encoded in
/// checkpoints); [`NormalLaw::Params`] is its `[contact.normal]` table. Register it in
/// [`normal_laws!`] (the config name is the module's, the snake-case of the type's name).
pub trait NormalLaw: Copy + Debug + PartialEq + Serialize + DeserializeOwned + Send + Sync + 'static {
    /// The keys of its `[contact.normal]` table (besides `law`), with `deny_unknown_fields`.
    type Params: Clone + Debug + PartialEq + Serialize + DeserializeOwned + ParamsSchema;
    /// The per-contact history it reads and updates ([`LawHistory`]); `()` for none.
    type History: LawHistory;
    /// The composition whose other families go with this law.
    fn composition(params: &Self::Params) -> Composition;
    /// The law from its table, checked: errors name the key (`{field}.normal.<key>`), the value
    /// and what is allowed.
    fn build(params: &Self::Params, at: &NormalContext) -> Result<Self>;
    /// Checks the built law (also one made in code); `field` is the contact law's key.
    fn validate(&self, field: &str) -> Result<()>;
    /// The response at overlap `xi` for effective radius `r_eff`, on every lane, reading and
    /// updating the contact's history (one value per lane). The one implementation of the law,
    /// run by the general kernel (`f64`) and by the vector paths.
    fn response_lanes<R: Real>(&self, xi: R, r_eff: R, history: &mut <Self::History as LawHistory>::Lanes<R>) -> NormalResponse<R>;
    /// The elastic energy the contact returns on unloading from overlap `xi` with history
    /// `history` (∫ F_el dξ along the unloading branch down to F_el = 0).
    fn energy(&self, xi: f64, r_eff: f64, history: &Self::History) -> f64;
    /// An upper bound of k_n at overlap `xi` over every history (time-step suggestions).
    fn max_stiffness(&self, xi: f64, r_eff: f64) -> f64;
}

/// The registry of normal laws: `module::Type` per law, the module a file
/// `contact/normal/<module>.rs` and its name the law's config name (`law = "<module>"`, the
/// snake case of `Type`). Generates the modules, [`NormalElastic`], [`NormalTable`] and their
/// dispatch (see the module documentation).
macro_rules! normal_laws {
    ($($module:ident :: $Law:ident),* $(,)?) => {
        $(
            mod $module;
            pub use $module::*;
        )*

        family_enum! {
            /// The normal elastic law F_el(ξ) of a contact law, one variant per registered law
            /// ([`NormalLaw`]); encoded as the variant's name and the law's fields.
            NormalElastic { $($module::$Law),* }
        }

        impl NormalElastic {
            /// True when the law keeps a per-contact history ([`NormalLaw::History`] not `()`).
            pub fn has_history(&self) -> bool {
                match self {
                    $(NormalElastic::$Law(_) => <<$Law as NormalLaw>::History as LawHistory>::WIDTH > 0,)*
                }
            }

            /// The response of the law on every lane for a contact that has just formed (its
            /// history the default): the stateless part the general law reads.
            #[inline(always)]
            pub(crate) fn response_lanes<R: Real>(&self, xi: R, r_eff: R) -> NormalResponse<R> {
                match *self {
                    $(NormalElastic::$Law(l) => {
                        let mut h = <<$Law as NormalLaw>::History as Default>::default().splat::<R>();
                        l.response_lanes(xi, r_eff, &mut h)
                    })*
                }
            }

            /// Stored elastic energy of a contact that has just formed (history the default):
            /// ½ k ξ² (Hooke), (8/15) E* √R* ξ^{5/2} (Hertz), the loading branch's (k₁/k₂) ½ k₁ ξ²
            /// (hysteretic: what unloading returns).
            pub fn energy(&self, xi: f64, r_eff: f64) -> f64 {
                match self {
                    $(NormalElastic::$Law(l) => l.energy(xi, r_eff, &Default::default()),)*
                }
            }

            /// An upper bound of k_n at overlap `xi` over every history ([`NormalLaw::max_stiffness`]).
            pub fn max_stiffness(&self, xi: f64, r_eff: f64) -> f64 {
                match self {
                    $(NormalElastic::$Law(l) => l.max_stiffness(xi, r_eff),)*
                }
            }

            /// Checks the law ([`NormalLaw::validate`]); `field` is the contact law's key.
            pub fn validate(&self, field: &str) -> Result<()> {
                match self {
                    $(NormalElastic::$Law(l) => l.validate(field),)*
                }
            }

            /// Runs `v` with `law` as the parts of a force pass: the general law itself for a
            /// normal law without history, or its composition with the law's history
            /// ([`LawHistory::route_normal`]).
            #[inline(always)]
            pub(crate) fn route<V: VisitParts>(law: &ContactLaw, v: V) -> V::Out {
                match law.normal {
                    $(NormalElastic::$Law(n) => <<$Law as NormalLaw>::History as LawHistory>::route_normal(law, n, v),)*
                }
            }

            /// Runs `v` with this law as its type where it keeps a per-contact history, and
            /// `v.without_history()` otherwise ([`LawHistory::route_history`]): the specialised
            /// kernels of a normal law with history, compiled for those laws only.
            #[inline(always)]
            pub(crate) fn route_history<V: VisitNormal>(&self, v: V) -> V::Out {
                match *self {
                    $(NormalElastic::$Law(n) => <<$Law as NormalLaw>::History as LawHistory>::route_history(n, v),)*
                }
            }
        }

        /// The normal law as a family table, `[contact.normal]`: `law = "<name>"` and the keys
        /// of that law ([`NormalLaw::Params`]).
        #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
        #[serde(tag = "law", rename_all = "snake_case")]
        pub enum NormalTable {
            $(
                #[doc = concat!("`law = \"", stringify!($module), "\"`: [`", stringify!($Law), "`].")]
                $Law(<$Law as NormalLaw>::Params),
            )*
        }

        impl NormalTable {
            /// The config name of the law of this table.
            pub fn name(&self) -> &'static str {
                match self {
                    $(NormalTable::$Law(_) => stringify!($module),)*
                }
            }

            /// The composition of the other families ([`NormalLaw::composition`]).
            pub(crate) fn composition(&self) -> Composition {
                match self {
                    $(NormalTable::$Law(p) => <$Law as NormalLaw>::composition(p),)*
                }
            }

            /// The law of this table, checked ([`NormalLaw::build`]).
            pub(crate) fn build(&self, at: &NormalContext) -> Result<NormalElastic> {
                match self {
                    $(NormalTable::$Law(p) => <$Law as NormalLaw>::build(p, at).map(NormalElastic::$Law),)*
                }
            }
        }

        #[cfg(feature = "schema")]
        impl schemars::JsonSchema for NormalTable {
            fn schema_name() -> std::borrow::Cow<'static, str> {
                "NormalTable".into()
            }
            fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
                let alternatives = vec![$(tagged_table::<<$Law as NormalLaw>::Params>(generator, stringify!($module))),*];
                schemars::json_schema!({
                    "description": "The normal law as a family table, `[contact.normal]`.",
                    "oneOf": alternatives
                })
            }
        }
    };
}

impl NormalElastic {
    /// Elastic force (≥ 0) and differential stiffness at overlap `xi` > 0 for effective radius
    /// `r_eff`, for a contact that has just formed.
    #[inline]
    pub fn force_stiffness(&self, xi: f64, r_eff: f64) -> (f64, f64) {
        let r = self.response(xi, r_eff);
        (r.force, r.stiffness)
    }

    /// Elastic force, differential and secant stiffness at overlap `xi` > 0 for effective
    /// radius `r_eff`, for a contact that has just formed (the law's history the default).
    #[inline]
    pub fn response(&self, xi: f64, r_eff: f64) -> NormalResponse {
        self.response_lanes(xi, r_eff)
    }
}

/// The schema of one law's table: its parameters' object schema with `law = "<name>"` first
/// (as schemars writes an internally tagged struct variant).
#[cfg(feature = "schema")]
pub(super) fn tagged_table<P: schemars::JsonSchema>(generator: &mut schemars::SchemaGenerator, name: &str) -> serde_json::Value {
    use serde_json::{json, Map, Value};
    let mut schema = P::json_schema(generator);
    let obj = schema.ensure_object();
    obj.insert("type".into(), "object".into());
    if let Some(properties) = obj.entry("properties").or_insert(Value::Object(Map::new())).as_object_mut() {
        let fields = std::mem::take(properties);
        properties.insert("law".into(), json!({ "type": "string", "const": name }));
        properties.extend(fields.into_iter().filter(|(k, _)| k != "law"));
    }
    if let Some(required) = obj.entry("required").or_insert(Value::Array(Vec::new())).as_array_mut() {
        required.insert(0, "law".into());
    }
    schema.to_value()
}

normal_laws! {
    hooke::Hooke,
    hertz::Hertz,
    hysteretic::Hysteretic,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The config name of each law (its module) is the name serde gives its variant, in the
    /// contact law and in the table (both snake case of the type): a law registered under a
    /// module named otherwise would be refused here.
    #[test]
    fn registry_names_are_the_serde_names() {
        let laws = [
            NormalElastic::from(Hooke { stiffness: 1.0 }),
            NormalElastic::from(Hertz { effective_modulus: 1.0 }),
            NormalElastic::from(Hysteretic { loading_stiffness: 1.0, unloading_stiffness: 2.0 }),
        ];
        assert_eq!(laws.len(), NormalElastic::NAMES.len());
        for (law, name) in laws.iter().zip(NormalElastic::NAMES) {
            assert_eq!(law.name(), *name);
            let json = serde_json::to_value(law).unwrap();
            assert!(json.get(*name).is_some(), "{json}");
        }
        let t: NormalTable = serde_json::from_str(r#"{"law": "hertz", "young": 1.0}"#).unwrap();
        assert_eq!(t.name(), "hertz");
        let e = serde_json::from_str::<NormalTable>(r#"{"law": "hooke", "stiffness": 1.0, "stifness": 2.0}"#).unwrap_err().to_string();
        assert!(e.contains("stifness"), "{e}");
    }
}
