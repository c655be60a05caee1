//! The contact law written by family: `[contact.normal]`, `[contact.damping]`,
//! `[contact.tangential]`, `[contact.rolling]`, `[contact.twisting]`, each naming its law
//! (`law = "…"`) and that law's parameters, beside the flat keys of the presets
//! ([`ContactParams`]), which every existing config keeps using.
//!
//! ```toml
//! [contact]
//! friction = 0.3
//! [contact.normal]
//! law = "hooke"
//! stiffness = 1.0e4
//! [contact.damping]
//! law = "restitution"
//! restitution = 0.8
//! [contact.tangential]
//! law = "linear"
//! stiffness_ratio = 0.2857
//! [contact.rolling]
//! stiffness = 50.0
//! friction = 0.01
//! ```
//!
//! is the law of `preset = "hooke_cundall_strack"`, `normal_stiffness = 1.0e4`,
//! `restitution = 0.8`, `tangential_stiffness_ratio = 0.2857`, `rolling_stiffness = 50.0`,
//! `rolling_friction = 0.01`, to the bit: the rolling and twisting tables are read into the keys
//! of the composition the normal law names ([`ContactParams::lower_families`]), and the checks
//! of those keys report under the family's own key names (`contact.rolling.stiffness`, …); the
//! normal, damping and tangential laws are built from their own tables by their own types
//! ([`NormalLaw::build`](super::NormalLaw::build),
//! [`DampingParams::build`](super::DampingParams::build),
//! [`TangentialLaw::build`](super::TangentialLaw::build), the tables generated from the
//! registries), so a registered law such as `slip_weakening` is reached from a config with no
//! key of its own anywhere else. One form per family: a
//! family given as a table may not also be given by flat keys, and `preset` (a whole law) goes
//! with the flat form only. `friction` (the Coulomb coefficient μ) stays a key of `[contact]` in
//! both forms, so that wall overrides such as `friction = 0` apply to either.

use super::{Composition, ContactParams, NormalElastic, TangentialTable};
use crate::error::{CoreError, Result};
use serde::{Deserialize, Serialize};

/// A resistance to relative rotation (`[contact.rolling]`, `[contact.twisting]`): a
/// spring–dashpot capped at μ R* F_n.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct ResistanceTable {
    /// Stiffness k [torque/angle].
    pub stiffness: f64,
    /// Damping γ, default 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<f64>,
    /// Friction μ of the cap, default ∞ (no cap).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

/// Where the flat keys of a family's law came from: (flat key, the family table's key).
type Renames = Vec<(&'static str, String)>;

impl ContactParams {
    /// True when any family is given as a table.
    pub fn has_families(&self) -> bool {
        self.normal.is_some() || self.damping.is_some() || self.tangential.is_some() || self.rolling.is_some() || self.twisting.is_some()
    }

    /// The flat form of these parameters: each family table read into the keys of the
    /// composition it names, and the names those keys must be reported under (`field` prefixes
    /// them, e.g. `contact`). Parameters without family tables are returned as they are.
    pub(crate) fn lower_families(&self, field: &str) -> Result<(ContactParams, Renames)> {
        let mut p = self.clone();
        let mut renames: Renames = Vec::new();
        if !self.has_families() {
            return Ok((p, renames));
        }
        let key = |k: &str| format!("{field}.{k}");
        let both = |flat: &str, table: &str| {
            CoreError::Inconsistent(format!(
                "`{}` and the table `[{}]` both give the {table} law: write the family in one form",
                key(flat),
                key(table)
            ))
        };
        let given = |flat: &[(&'static str, bool)], table: &str| -> Result<()> {
            match flat.iter().find(|(_, g)| *g) {
                Some((name, _)) => Err(both(name, table)),
                None => Ok(()),
            }
        };
        if !self.preset.is_empty() {
            return Err(CoreError::Inconsistent(format!(
                "`{}` names a whole law; with family tables (`[{}]`, …) leave it out and give `[{}]`",
                key("preset"),
                key("normal"),
                key("normal")
            )));
        }
        // normal: names the composition
        let normal = self.normal.as_ref().ok_or_else(|| {
            let names: Vec<String> = NormalElastic::NAMES.iter().map(|n| format!("\"{n}\"")).collect();
            CoreError::invalid(key("normal"), "(missing)", format!("a table `[contact.normal]` with `law` one of {}, required with family tables", names.join(", ")))
        })?;
        given(&[("normal_stiffness", self.normal_stiffness.is_some()), ("young", self.young.is_some()), ("poisson", self.poisson.is_some())], "normal")?;
        // the other families go with the composition the normal law names
        let composition = normal.composition();
        match composition {
            Composition::Hooke { stiffness, key: k } => {
                p.preset = "hooke_cundall_strack".into();
                p.normal_stiffness = Some(stiffness);
                renames.push(("normal_stiffness", key(&format!("normal.{k}"))));
            }
            Composition::Hertz { young, poisson } => {
                p.preset = "hertz_mindlin".into();
                p.young = Some(young);
                p.poisson = poisson;
                renames.push(("young", key("normal.young")));
                renames.push(("poisson", key("normal.poisson")));
            }
        }
        if self.damping.is_some() {
            given(
                &[
                    ("restitution", self.restitution.is_some()),
                    ("normal_damping", self.normal_damping.is_some()),
                    ("damping_fraction", self.damping_fraction.is_some()),
                    ("normal_damping_rate", self.normal_damping_rate.is_some()),
                    ("tsuji_restitution", self.tsuji_restitution.is_some()),
                    ("tangential_damping_ratio", self.tangential_damping_ratio.is_some()),
                    ("tangential_damping_rate", self.tangential_damping_rate.is_some()),
                ],
                "damping",
            )?;
            // the damping itself is built from its own table by its own type
            // (`ContactParams::build`, `DampingParams::build`)
        }
        if let Some(t) = &self.tangential {
            given(
                &[
                    ("tangential_stiffness_ratio", self.tangential_stiffness_ratio.is_some()),
                    ("slip_activation_time", self.slip_activation_time.is_some()),
                    ("mindlin_rescale", self.mindlin_rescale.is_some()),
                ],
                "tangential",
            )?;
            // the law itself is built from its own table by its own type (`ContactParams::build`,
            // `TangentialLaw::build`); `none` is frictionless
            if let TangentialTable::None(_) = t {
                match self.friction {
                    Some(mu) if mu != 0.0 => {
                        return Err(CoreError::Inconsistent(format!(
                            "`{}` = \"none\" has no tangential force, but `{}` = {mu}: leave friction out or set it to 0",
                            key("tangential.law"),
                            key("friction")
                        )))
                    }
                    _ => p.friction = Some(0.0),
                }
            }
        }
        for (name, table, stiffness, damping, friction) in [
            ("rolling", &self.rolling, &mut p.rolling_stiffness, &mut p.rolling_damping, &mut p.rolling_friction),
            ("twisting", &self.twisting, &mut p.twisting_stiffness, &mut p.twisting_damping, &mut p.twisting_friction),
        ] {
            let Some(r) = table else { continue };
            if stiffness.is_some() || damping.is_some() || friction.is_some() {
                let flat = if name == "rolling" { "rolling_stiffness" } else { "twisting_stiffness" };
                return Err(both(flat, name));
            }
            *stiffness = Some(r.stiffness);
            *damping = r.damping;
            *friction = r.friction;
        }
        for (name, s, d, f) in [
            ("rolling", "rolling_stiffness", "rolling_damping", "rolling_friction"),
            ("twisting", "twisting_stiffness", "twisting_damping", "twisting_friction"),
        ] {
            let table = if name == "rolling" { &self.rolling } else { &self.twisting };
            if table.is_some() {
                renames.push((s, key(&format!("{name}.stiffness"))));
                renames.push((d, key(&format!("{name}.damping"))));
                renames.push((f, key(&format!("{name}.friction"))));
            }
        }
        p.normal = None;
        p.damping = None;
        p.tangential = None;
        p.rolling = None;
        p.twisting = None;
        Ok((p, renames))
    }
}

/// `e` with the flat key names of `renames` (prefixed by `field`) replaced by the family
/// tables' names: the error of a lowered law speaks of the keys its config has.
pub(crate) fn rename_keys(e: CoreError, field: &str, renames: &Renames) -> CoreError {
    if renames.is_empty() {
        return e;
    }
    let rename = |text: &str| -> String {
        let mut out = text.to_string();
        for (flat, table) in renames {
            let flat = format!("{field}.{flat}");
            // whole key names only (`contact.restitution` is not a prefix of another key here,
            // but `contact.rolling_damping` would be one of a longer name)
            out = replace_key(&out, &flat, table);
        }
        out
    };
    match e {
        CoreError::InvalidParameter { field, value, allowed } => CoreError::InvalidParameter { field: rename(&field), value, allowed: rename(&allowed) },
        CoreError::Inconsistent(m) => CoreError::Inconsistent(rename(&m)),
        other => other,
    }
}

/// `text` with every occurrence of the key `from` that is not part of a longer key name
/// (followed by a letter, digit, `_` or `.`) replaced by `to`.
fn replace_key(text: &str, from: &str, to: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(from) {
        let after = &rest[i + from.len()..];
        let longer = after.chars().next().is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '.');
        out.push_str(&rest[..i]);
        out.push_str(if longer { from } else { to });
        rest = after;
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::damping::normal::{CriticalFractionTable, DashpotTable, MassProportionalTable, RestitutionTable, TsujiTable};
    use crate::contact::tangential::{LinearTable, MindlinTable};
    use crate::contact::{DampingTable, Hooke, HertzParams, NoDamping, NoTangential, NormalDamping, NormalTable, Partner, TangentialDamping};

    fn flat(preset: &str) -> ContactParams {
        ContactParams::preset(preset)
    }
    fn family(normal: NormalTable) -> ContactParams {
        ContactParams { normal: Some(normal), ..Default::default() }
    }
    fn both_partners_equal(a: &ContactParams, b: &ContactParams) {
        for partner in [Partner::Grain, Partner::Wall] {
            let (la, lb) = (a.build(partner, "contact").unwrap(), b.build(partner, "contact").unwrap());
            assert_eq!(la, lb, "{partner:?}: {a:?} vs {b:?}");
        }
    }

    /// Every family of each composition, written as tables, builds the law of the flat keys to
    /// the bit (grain–grain and wall), defaults included.
    #[test]
    fn family_tables_build_the_law_of_the_flat_keys() {
        // Hooke, restitution, linear spring with its ratio, rolling resistance
        let mut a = flat("hooke_cundall_strack");
        (a.normal_stiffness, a.restitution, a.tangential_stiffness_ratio, a.friction) = (Some(1e4), Some(0.8), Some(0.3), Some(0.4));
        (a.rolling_stiffness, a.rolling_damping, a.rolling_friction) = (Some(50.0), Some(0.2), Some(0.01));
        let mut b = family(NormalTable::Hooke(Hooke { stiffness: 1e4 }));
        b.friction = Some(0.4);
        b.damping = Some(DampingTable::Restitution(RestitutionTable { restitution: 0.8, tangential_ratio: None, tangential_rate: None }));
        b.tangential = Some(TangentialTable::Linear(LinearTable { stiffness_ratio: Some(0.3), slip_activation_time: None }));
        b.rolling = Some(ResistanceTable { stiffness: 50.0, damping: Some(0.2), friction: Some(0.01) });
        both_partners_equal(&a, &b);
        // the default tangential law of the composition (no `[contact.tangential]`)
        b.tangential = None;
        a.tangential_stiffness_ratio = None;
        both_partners_equal(&a, &b);
        // mass-proportional damping with a tangential rate, and the slip-activation time
        let mut a = flat("hooke_cundall_strack");
        (a.normal_stiffness, a.normal_damping_rate, a.tangential_damping_rate, a.slip_activation_time) = (Some(2e3), Some(30.0), Some(10.0), Some(0.05));
        let mut b = family(NormalTable::Hooke(Hooke { stiffness: 2e3 }));
        b.damping = Some(DampingTable::MassProportional(MassProportionalTable { rate: 30.0, tangential_ratio: None, tangential_rate: Some(10.0) }));
        b.tangential = Some(TangentialTable::Linear(LinearTable { stiffness_ratio: None, slip_activation_time: Some(0.05) }));
        both_partners_equal(&a, &b);
        assert!(matches!(b.build(Partner::Grain, "contact").unwrap().tangential, crate::contact::Tangential::SlipActivation(_)));
        // a dashpot with a tangential ratio; Tsuji on Hooke
        let mut a = flat("hooke_cundall_strack");
        (a.normal_stiffness, a.normal_damping, a.tangential_damping_ratio) = (Some(1e3), Some(0.7), Some(0.25));
        let mut b = family(NormalTable::Hooke(Hooke { stiffness: 1e3 }));
        b.damping = Some(DampingTable::Dashpot(DashpotTable { coefficient: 0.7, tangential_ratio: Some(0.25), tangential_rate: None }));
        both_partners_equal(&a, &b);
        // Hertz with Tsuji damping and a tangential ratio
        let mut a = flat("hertz_mindlin");
        (a.young, a.poisson, a.tsuji_restitution, a.tangential_damping_ratio) = (Some(1e5), Some(0.3), Some(0.6), Some(0.5));
        let mut b = family(NormalTable::Hertz(HertzParams { young: 1e5, poisson: Some(0.3) }));
        b.damping = Some(DampingTable::Tsuji(TsujiTable { restitution: 0.6, tangential_ratio: Some(0.5) }));
        both_partners_equal(&a, &b);
        // Hertz, a fraction of critical damping, Mindlin rescaled on unloading, twisting resistance
        let mut a = flat("hertz_mindlin");
        (a.young, a.damping_fraction, a.mindlin_rescale) = (Some(3e4), Some(0.1), Some(true));
        (a.twisting_stiffness, a.twisting_friction) = (Some(2.0), Some(0.05));
        let mut b = family(NormalTable::Hertz(HertzParams { young: 3e4, poisson: None }));
        b.damping = Some(DampingTable::CriticalFraction(CriticalFractionTable { fraction: 0.1, tangential_ratio: None, tangential_rate: None }));
        b.tangential = Some(TangentialTable::Mindlin(MindlinTable { rescale_on_unloading: Some(true) }));
        b.twisting = Some(ResistanceTable { stiffness: 2.0, damping: None, friction: Some(0.05) });
        both_partners_equal(&a, &b);
        // frictionless: `law = "none"` is friction 0
        let mut a = flat("hooke_cundall_strack");
        (a.normal_stiffness, a.friction) = (Some(1e3), Some(0.0));
        let mut b = family(NormalTable::Hooke(Hooke { stiffness: 1e3 }));
        b.tangential = Some(TangentialTable::None(NoTangential {}));
        b.damping = Some(DampingTable::None(NoDamping {}));
        both_partners_equal(&a, &b);
    }

    /// Every `[contact.damping]` table, with its defaults and with each tangential key, builds
    /// the dampers of its flat keys to the bit beside the linear law (grain–grain and wall); the
    /// tables that apply beside the Hertz law (`critical_fraction`, also with ζ = 0, which is no
    /// damping there; `tsuji`, whose default ratio is 1 there and ½ beside the linear law) too;
    /// the linear-law dashpots beside Hertz, and a tangential ratio with `critical_fraction` there,
    /// are refused naming the table's key; each table's name is the one serde reads.
    #[test]
    fn every_damping_table_builds_the_dampers_of_its_flat_keys() {
        let hooke = || {
            let mut a = flat("hooke_cundall_strack");
            a.normal_stiffness = Some(2e3);
            a
        };
        let hertz = || {
            let mut a = flat("hertz_mindlin");
            (a.young, a.poisson) = (Some(1e5), Some(0.2));
            a
        };
        let by_family = |normal: NormalTable, table: &DampingTable| {
            let mut b = family(normal);
            b.damping = Some(table.clone());
            b
        };
        let linear = || NormalTable::Hooke(Hooke { stiffness: 2e3 });
        let hertzian = || NormalTable::Hertz(HertzParams { young: 1e5, poisson: Some(0.2) });
        type Set = Box<dyn Fn(&mut ContactParams)>;
        let mut names = Vec::new();
        for (ratio, rate) in [(None, None), (Some(0.3), None), (None, Some(7.0))] {
            let cases: [(DampingTable, Set); 4] = [
                (DampingTable::Restitution(RestitutionTable { restitution: 0.7, tangential_ratio: ratio, tangential_rate: rate }), Box::new(|p| p.restitution = Some(0.7))),
                (DampingTable::Dashpot(DashpotTable { coefficient: 0.4, tangential_ratio: ratio, tangential_rate: rate }), Box::new(|p| p.normal_damping = Some(0.4))),
                (DampingTable::CriticalFraction(CriticalFractionTable { fraction: 0.05, tangential_ratio: ratio, tangential_rate: rate }), Box::new(|p| p.damping_fraction = Some(0.05))),
                (DampingTable::MassProportional(MassProportionalTable { rate: 20.0, tangential_ratio: ratio, tangential_rate: rate }), Box::new(|p| p.normal_damping_rate = Some(20.0))),
            ];
            for (table, set) in cases {
                let mut a = hooke();
                set(&mut a);
                (a.tangential_damping_ratio, a.tangential_damping_rate) = (ratio, rate);
                let b = by_family(linear(), &table);
                both_partners_equal(&a, &b);
                // the dampers differ from the default (none): the table was read
                assert_ne!(b.build(Partner::Grain, "contact").unwrap().damping, NormalDamping::None);
                names.push(table.name());
                let beside_hertz = || err(&by_family(hertzian(), &table));
                match &table {
                    DampingTable::CriticalFraction(_) if ratio.is_none() && rate.is_none() => {
                        let mut a = hertz();
                        set(&mut a);
                        both_partners_equal(&a, &by_family(hertzian(), &table));
                    }
                    DampingTable::CriticalFraction(_) => {
                        let k = if ratio.is_some() { "`contact.damping.tangential_ratio`" } else { "`contact.damping.tangential_rate`" };
                        let e = beside_hertz();
                        assert!(e.contains(k) && e.contains("Hertz"), "{e}");
                    }
                    _ => {
                        let e = beside_hertz();
                        assert!(e.contains("`contact.damping.law`") && e.contains(&format!("\"{}\"", table.name())) && e.contains("\"tsuji\""), "{e}");
                    }
                }
            }
        }
        for ratio in [None, Some(0.3)] {
            let table = DampingTable::Tsuji(TsujiTable { restitution: 0.6, tangential_ratio: ratio });
            names.push(table.name());
            for (mut a, normal, default) in [(hooke(), linear(), 0.5), (hertz(), hertzian(), 1.0)] {
                (a.tsuji_restitution, a.tangential_damping_ratio) = (Some(0.6), ratio);
                let b = by_family(normal, &table);
                both_partners_equal(&a, &b);
                let law = b.build(Partner::Grain, "contact").unwrap();
                assert_eq!(law.tangential_damping, crate::contact::damping::tangential::FractionOfNormal { ratio: ratio.unwrap_or(default) }.into());
            }
        }
        // ζ = 0 beside Hertz: no damping (the flat key's meaning)
        let zero = DampingTable::CriticalFraction(CriticalFractionTable { fraction: 0.0, tangential_ratio: None, tangential_rate: None });
        let law = by_family(hertzian(), &zero).build(Partner::Wall, "contact").unwrap();
        assert_eq!((law.damping, law.tangential_damping), (NormalDamping::None, TangentialDamping::None));
        let mut a = hertz();
        a.damping_fraction = Some(0.0);
        both_partners_equal(&a, &by_family(hertzian(), &zero));
        // the names: every table reached, each the name serde reads and writes
        names.push(DampingTable::None(NoDamping {}).name());
        names.sort_unstable();
        names.dedup();
        let mut all = DampingTable::NAMES.to_vec();
        all.sort_unstable();
        assert_eq!(names, all);
        for name in DampingTable::NAMES {
            let keys = match *name {
                "none" => "",
                "dashpot" => r#", "coefficient": 1.0"#,
                "critical_fraction" => r#", "fraction": 0.1"#,
                "mass_proportional" => r#", "rate": 1.0"#,
                _ => r#", "restitution": 0.5"#,
            };
            let t: DampingTable = serde_json::from_str(&format!(r#"{{"law": "{name}"{keys}}}"#)).unwrap();
            assert_eq!(t.name(), *name);
            assert_eq!(serde_json::to_value(&t).unwrap()["law"], *name);
        }
        let e = serde_json::from_str::<DampingTable>(r#"{"law": "dashpot", "coefficient": 1.0, "coeficient": 2.0}"#).unwrap_err().to_string();
        assert!(e.contains("coeficient"), "{e}");
        let e = serde_json::from_str::<DampingTable>(r#"{"law": "tsuji", "restitution": 0.5, "tangential_rate": 2.0}"#).unwrap_err().to_string();
        assert!(e.contains("tangential_rate"), "{e}");
        // values out of range, named by the table's keys
        for (table, key) in [
            (DampingTable::Dashpot(DashpotTable { coefficient: -1.0, tangential_ratio: None, tangential_rate: None }), "contact.damping.coefficient"),
            (DampingTable::MassProportional(MassProportionalTable { rate: f64::NAN, tangential_ratio: None, tangential_rate: None }), "contact.damping.rate"),
            (DampingTable::CriticalFraction(CriticalFractionTable { fraction: -0.1, tangential_ratio: None, tangential_rate: None }), "contact.damping.fraction"),
            (DampingTable::Tsuji(TsujiTable { restitution: 1.2, tangential_ratio: None }), "contact.damping.restitution"),
            (DampingTable::Tsuji(TsujiTable { restitution: 0.5, tangential_ratio: Some(-2.0) }), "contact.damping.tangential_ratio"),
            (DampingTable::Restitution(RestitutionTable { restitution: 0.1, tangential_ratio: None, tangential_rate: None }), "contact.damping.restitution"),
            (DampingTable::Restitution(RestitutionTable { restitution: 0.5, tangential_ratio: None, tangential_rate: Some(-1.0) }), "contact.damping.tangential_rate"),
        ] {
            let e = err(&by_family(linear(), &table));
            assert!(e.contains(&format!("`{key}`")), "{e}");
            assert!(!e.contains("normal_damping") && !e.contains("damping_fraction") && !e.contains("tsuji_restitution"), "{e}");
        }
        assert!(err(&by_family(linear(), &DampingTable::Restitution(RestitutionTable { restitution: 0.1, tangential_ratio: None, tangential_rate: None }))).contains("0.1353"));
    }

    fn err(p: &ContactParams) -> String {
        p.build(Partner::Grain, "contact").unwrap_err().to_string()
    }

    /// The checks of each family report under the family's key names; a family given in both
    /// forms, a preset beside family tables, a tangential law of the other composition and a
    /// frictionless law with a friction coefficient are refused naming the keys.
    #[test]
    fn family_errors_name_the_family_keys() {
        let e = err(&family(NormalTable::Hooke(Hooke { stiffness: -1.0 })));
        assert!(e.contains("contact.normal.stiffness") && e.contains("-1"), "{e}");
        let e = err(&family(NormalTable::Hertz(HertzParams { young: 1e5, poisson: Some(0.7) })));
        assert!(e.contains("contact.normal.poisson") && e.contains("0.7"), "{e}");
        let mut p = family(NormalTable::Hooke(Hooke { stiffness: 1e3 }));
        p.damping = Some(DampingTable::Restitution(RestitutionTable { restitution: 1.5, tangential_ratio: None, tangential_rate: None }));
        let e = err(&p);
        assert!(e.contains("`contact.damping.restitution`") || e.contains("contact.damping.restitution:"), "{e}");
        assert!(!e.contains("contact.restitution"), "{e}");
        p.damping = Some(DampingTable::Restitution(RestitutionTable { restitution: 0.5, tangential_ratio: Some(0.2), tangential_rate: Some(3.0) }));
        let e = err(&p);
        assert!(e.contains("contact.damping.tangential_ratio") && e.contains("contact.damping.tangential_rate"), "{e}");
        p.damping = None;
        p.rolling = Some(ResistanceTable { stiffness: 1.0, damping: Some(-2.0), friction: None });
        let e = err(&p);
        assert!(e.contains("contact.rolling.damping") && !e.contains("rolling_damping"), "{e}");
        p.rolling = Some(ResistanceTable { stiffness: 1.0, damping: None, friction: None });
        p.tangential = Some(TangentialTable::Linear(LinearTable { stiffness_ratio: None, slip_activation_time: Some(-1.0) }));
        let e = err(&p);
        assert!(e.contains("contact.tangential.slip_activation_time"), "{e}");
        // both forms
        let mut q = p.clone();
        q.tangential = None;
        q.rolling_stiffness = Some(3.0);
        let e = err(&q);
        assert!(e.contains("`contact.rolling_stiffness`") && e.contains("[contact.rolling]") && e.contains("one form"), "{e}");
        let mut q = family(NormalTable::Hooke(Hooke { stiffness: 1e3 }));
        q.normal_stiffness = Some(1e3);
        assert!(err(&q).contains("`contact.normal_stiffness`"), "{}", err(&q));
        // a preset beside family tables
        let mut q = family(NormalTable::Hooke(Hooke { stiffness: 1e3 }));
        q.preset = "hooke_cundall_strack".into();
        assert!(err(&q).contains("`contact.preset`"), "{}", err(&q));
        // no normal table
        let q = ContactParams { rolling: Some(ResistanceTable { stiffness: 1.0, damping: None, friction: None }), ..Default::default() };
        assert!(err(&q).contains("contact.normal") && err(&q).contains("required"), "{}", err(&q));
        // the other composition's tangential law
        let mut q = family(NormalTable::Hertz(HertzParams { young: 1e5, poisson: None }));
        q.tangential = Some(TangentialTable::Linear(LinearTable { stiffness_ratio: None, slip_activation_time: None }));
        assert!(err(&q).contains("contact.tangential.law") && err(&q).contains("Hooke"), "{}", err(&q));
        let mut q = family(NormalTable::Hooke(Hooke { stiffness: 1e3 }));
        q.tangential = Some(TangentialTable::Mindlin(MindlinTable { rescale_on_unloading: None }));
        assert!(err(&q).contains("Hertz"), "{}", err(&q));
        // frictionless with a friction coefficient
        q.tangential = Some(TangentialTable::None(NoTangential {}));
        q.friction = Some(0.3);
        assert!(err(&q).contains("`contact.friction` = 0.3"), "{}", err(&q));
    }

    /// A tangential law of the registry reached through its own table: `slip_weakening` and
    /// `slip_activation` are built by their own `build` with k_t = ratio × k_n of the normal
    /// law (Hooke or the hysteretic law's k₁), grain–grain and wall; `slip_activation` is the
    /// law `linear` gives with the same τ, to the bit; the table's checks name its keys; the
    /// table is read with `law = "<name>"` and unknown keys are refused.
    #[test]
    fn registered_tangential_laws_are_reached_by_their_tables() {
        use crate::contact::tangential::{SlipActivation, SlipActivationTable, SlipWeakening, SlipWeakeningTable};
        use crate::contact::{Hysteretic, Tangential};
        let weakening = SlipWeakeningTable { stiffness_ratio: Some(0.4), residual_ratio: 0.5, weakening_distance: 0.01 };
        for (normal, k_n) in [
            (NormalTable::Hooke(Hooke { stiffness: 2e3 }), 2e3),
            (NormalTable::Hysteretic(Hysteretic { loading_stiffness: 3e3, unloading_stiffness: 6e3 }), 3e3),
        ] {
            let mut p = family(normal);
            p.friction = Some(0.6);
            p.tangential = Some(TangentialTable::SlipWeakening(weakening.clone()));
            for partner in [Partner::Grain, Partner::Wall] {
                let law = p.build(partner, "contact").unwrap();
                assert_eq!(law.tangential, Tangential::from(SlipWeakening { stiffness: 0.4 * k_n, residual_ratio: 0.5, weakening_distance: 0.01 }));
                assert_eq!(law.friction, 0.6);
                assert!(law.tangential.has_history());
            }
            // friction 0: no tangential force, the table still checked
            p.friction = Some(0.0);
            assert_eq!(p.build(Partner::Grain, "contact").unwrap().tangential, Tangential::None);
            p.tangential = Some(TangentialTable::SlipWeakening(SlipWeakeningTable { residual_ratio: 1.5, ..weakening.clone() }));
            let e = err(&p);
            assert!(e.contains("contact.tangential.residual_ratio") && e.contains("1.5"), "{e}");
        }
        let mut p = family(NormalTable::Hooke(Hooke { stiffness: 1e3 }));
        p.tangential = Some(TangentialTable::SlipWeakening(SlipWeakeningTable { weakening_distance: 0.0, ..weakening.clone() }));
        assert!(err(&p).contains("contact.tangential.weakening_distance"), "{}", err(&p));
        p.tangential = Some(TangentialTable::SlipWeakening(SlipWeakeningTable { stiffness_ratio: Some(-0.1), ..weakening.clone() }));
        assert!(err(&p).contains("contact.tangential.stiffness_ratio") && err(&p).contains("-0.1"), "{}", err(&p));
        // beside the Hertz law: refused, naming the normal law it needs
        let mut q = family(NormalTable::Hertz(HertzParams { young: 1e5, poisson: None }));
        q.tangential = Some(TangentialTable::SlipWeakening(weakening.clone()));
        assert!(err(&q).contains("`contact.tangential.law` = \"slip_weakening\"") && err(&q).contains("Hooke"), "{}", err(&q));
        // slip activation by its own name = `linear` with τ > 0
        let mut a = family(NormalTable::Hooke(Hooke { stiffness: 1e3 }));
        a.tangential = Some(TangentialTable::Linear(LinearTable { stiffness_ratio: Some(0.2), slip_activation_time: Some(0.05) }));
        let mut b = a.clone();
        b.tangential = Some(TangentialTable::SlipActivation(SlipActivationTable { stiffness_ratio: Some(0.2), slip_activation_time: 0.05 }));
        both_partners_equal(&a, &b);
        assert_eq!(b.build(Partner::Grain, "contact").unwrap().tangential, Tangential::from(SlipActivation { stiffness: 0.2 * 1e3, activation_time: 0.05 }));
        b.tangential = Some(TangentialTable::SlipActivation(SlipActivationTable { stiffness_ratio: None, slip_activation_time: 0.0 }));
        assert!(err(&b).contains("contact.tangential.slip_activation_time") && err(&b).contains("law = \"linear\""), "{}", err(&b));
        // read from a table: the name selects the law, unknown keys are refused
        let t: TangentialTable = serde_json::from_str(r#"{"law": "slip_weakening", "residual_ratio": 0.5, "weakening_distance": 0.01}"#).unwrap();
        assert_eq!(t.name(), "slip_weakening");
        assert_eq!(t, TangentialTable::SlipWeakening(SlipWeakeningTable { stiffness_ratio: None, residual_ratio: 0.5, weakening_distance: 0.01 }));
        let e = serde_json::from_str::<TangentialTable>(r#"{"law": "slip_weakening", "residual_ratio": 0.5, "weakening_distanse": 0.01}"#).unwrap_err().to_string();
        assert!(e.contains("weakening_distanse"), "{e}");
        let e = serde_json::from_str::<TangentialTable>(r#"{"law": "none", "stiffness_ratio": 0.5}"#).unwrap_err().to_string();
        assert!(e.contains("stiffness_ratio"), "{e}");
        let e = serde_json::from_str::<TangentialTable>(r#"{"law": "coulomb"}"#).unwrap_err().to_string();
        assert!(e.contains("slip_weakening") && e.contains("linear"), "{e}");
    }

    #[test]
    fn keys_are_replaced_whole() {
        assert_eq!(replace_key("`c.rolling` and `c.rolling_damping` and c.rolling.", "c.rolling", "X"), "`X` and `c.rolling_damping` and c.rolling.");
        assert_eq!(replace_key("c.young: 5", "c.young", "c.normal.young"), "c.normal.young: 5");
    }
}
