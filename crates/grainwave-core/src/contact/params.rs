//! Named presets: the keyword table at the boundary between configs and contact laws.

use super::damping::{normal as nd, tangential as td};
use super::rolling::SpringDashpot;
use super::tangential::Mindlin;
use super::families::ResistanceTable;
use super::{ContactLaw, DampingChoice, DampingContext, DampingTable, Hertz, Hooke, NormalContext, NormalDamping, NormalElastic, NormalTable, Rolling, SlipActivationParams, Tangential, TangentialContext, TangentialDamping, TangentialTable, Twisting};
use crate::error::{require_non_negative, require_positive, CoreError, Result};
use serde::{Deserialize, Serialize};

/// Names of the available presets.
pub const PRESETS: &[&str] = &["hertz_mindlin", "hooke_cundall_strack"];

/// Which partner a law is built for: another grain or a rigid wall.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Partner {
    /// Grain–grain contacts (identical materials).
    Grain,
    /// Grain–wall contacts (rigid wall, R_wall = ∞, E_wall = ∞).
    Wall,
}

/// Contact parameters by name, as they appear in configs (`[contact]`, `[contact.wall]`).
///
/// * `hertz_mindlin`: Hertz normal force with E* = E/(1−ν²) per grain, incremental Mindlin
///   tangential law with G* = E/[2(1+ν)(2−ν)] per grain; grain–grain pairs use E*_ij = E*/2 and
///   G*_ij = G*/2, rigid walls E*_i and G*_i. Damping as a fraction ζ of critical on both parts
///   (`damping_fraction`, default 0), or Tsuji damping from a restitution coefficient
///   (`tsuji_restitution`, γ_n = α(e)√(m* k̄), see [`super::tsuji_alpha`]) with
///   γ_t = `tangential_damping_ratio` × γ_n (default 1).
/// * `hooke_cundall_strack`: linear normal spring `normal_stiffness`, linear tangential spring
///   k_t = `tangential_stiffness_ratio` × k_n (default 2/7), normal dashpot from `restitution`
///   (exact for the clamped law, see [`super::critical_fraction_for_restitution`]), `normal_damping` γ_n,
///   `damping_fraction` ζ, `normal_damping_rate` (γ_n = rate × m*, LAMMPS `gran/hooke/history`)
///   or `tsuji_restitution`; tangential damping γ_t = `tangential_damping_ratio` × γ_n (default ½)
///   or γ_t = `tangential_damping_rate` × m*.
///
/// Both: Coulomb `friction` μ (default 0.5; 0 removes the tangential force), optional rolling
/// resistance (`rolling_stiffness`, `rolling_damping`, `rolling_friction`) and, in 3D, optional
/// twisting resistance (`twisting_stiffness`, `twisting_damping`, `twisting_friction`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct ContactParams {
    /// Preset name: `hertz_mindlin` or `hooke_cundall_strack` (required in `[contact]`; in wall
    /// overrides, leave it out to keep the grain–grain preset).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub preset: String,
    /// Young's modulus E of the grains (Hertz).
    pub young: Option<f64>,
    /// Poisson's ratio ν of the grains (Hertz), default 0.
    pub poisson: Option<f64>,
    /// Normal stiffness k_n (Hooke).
    pub normal_stiffness: Option<f64>,
    /// k_t / k_n (Hooke), default 2/7.
    pub tangential_stiffness_ratio: Option<f64>,
    /// Restitution coefficient e ∈ [e⁻², 1] (Hooke).
    pub restitution: Option<f64>,
    /// Normal dashpot coefficient γ_n (Hooke).
    pub normal_damping: Option<f64>,
    /// Damping as a fraction ζ of critical, on the normal and tangential parts.
    pub damping_fraction: Option<f64>,
    /// γ_t / γ_n, default ½ (Hooke) or 1 (Hertz with Tsuji damping).
    pub tangential_damping_ratio: Option<f64>,
    /// γ_n / m* (1/time): a dashpot proportional to the effective mass (Hooke; LAMMPS
    /// `gran/hooke/history`'s `gamma_n`).
    pub normal_damping_rate: Option<f64>,
    /// γ_t / m* (1/time) (Hooke; LAMMPS `gran/hooke/history`'s `gamma_t`); default γ_t = ½ γ_n.
    pub tangential_damping_rate: Option<f64>,
    /// Restitution coefficient e ∈ [0, 1] of Tsuji damping, γ_n = α(e) √(m* F_el/ξ) (LAMMPS
    /// `damping tsuji`).
    pub tsuji_restitution: Option<f64>,
    /// Coulomb friction coefficient μ, default 0.5.
    pub friction: Option<f64>,
    /// Rescale the stored Mindlin force by k_t(new)/k_t(old) when the overlap decreases (default false).
    pub mindlin_rescale: Option<bool>,
    /// Slip-activation time τ (Hooke; time, ≥ 0, default 0): the spring's excess over the
    /// Coulomb length μF_n/k_t relaxes in a time τ instead of being cut at once, so contacts
    /// slide at time scales ≫ τ and stick at shorter ones (the friction law proposed in the
    /// E2 study, docs/engine.md); 0 is the Coulomb cap, bit for bit.
    pub slip_activation_time: Option<f64>,
    /// Rolling stiffness k_r; rolling resistance is on when given.
    pub rolling_stiffness: Option<f64>,
    /// Rolling damping γ_r, default 0.
    pub rolling_damping: Option<f64>,
    /// Rolling friction μ_r, default ∞ (no cap).
    pub rolling_friction: Option<f64>,
    /// Twisting stiffness k_tw; twisting resistance (3D) is on when given.
    pub twisting_stiffness: Option<f64>,
    /// Twisting damping γ_tw, default 0.
    pub twisting_damping: Option<f64>,
    /// Twisting friction μ_tw, default ∞ (no cap).
    pub twisting_friction: Option<f64>,
    /// The normal law as a family table, `[contact.normal]` (`law = "…"` names one of the laws
    /// listed in the type column, the other keys are that law's): the family form of the law,
    /// in place of `preset` and the flat keys (docs/engine.md, "The contact law by family");
    /// required when any family table is given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal: Option<NormalTable>,
    /// The damping as a family table, `[contact.damping]` (`law = "none"`, `"restitution"`,
    /// `"dashpot"`, `"critical_fraction"`, `"mass_proportional"` or `"tsuji"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<DampingTable>,
    /// The tangential law as a family table, `[contact.tangential]` (`law = "none"` or the name
    /// of a registered tangential law, with that law's keys; default: the one of the normal
    /// law's composition).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tangential: Option<TangentialTable>,
    /// Rolling resistance as a family table, `[contact.rolling]` (`stiffness`, `damping`, `friction`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rolling: Option<ResistanceTable>,
    /// Twisting resistance (3D) as a family table, `[contact.twisting]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub twisting: Option<ResistanceTable>,
}

/// Default Coulomb friction coefficient.
pub const DEFAULT_FRICTION: f64 = 0.5;

impl ContactParams {
    /// Parameters of preset `name` with everything else left at its default.
    pub fn preset(name: &str) -> Self {
        ContactParams { preset: name.to_string(), ..Default::default() }
    }

    /// The flat keys that choose a normal damping law, each with the name of that law in
    /// `[contact.damping]` and its value (`None`: not given), in the order of precedence.
    pub(crate) fn flat_damping(&self) -> [(&'static str, &'static str, Option<f64>); 5] {
        [
            ("restitution", "restitution", self.restitution),
            ("normal_damping", "dashpot", self.normal_damping),
            ("damping_fraction", "critical_fraction", self.damping_fraction),
            ("normal_damping_rate", "mass_proportional", self.normal_damping_rate),
            ("tsuji_restitution", "tsuji", self.tsuji_restitution),
        ]
    }

    /// Tsuji's α from `tsuji_restitution`, if given (checked to lie in [0, 1]).
    fn tsuji_alpha(&self, key: &dyn Fn(&str) -> String) -> Result<Option<f64>> {
        match self.tsuji_restitution {
            None => Ok(None),
            Some(e) if (0.0..=1.0).contains(&e) => Ok(Some(super::tsuji_alpha(e))),
            Some(e) => Err(CoreError::invalid(key("tsuji_restitution"), e, "a restitution coefficient in [0, 1]")),
        }
    }

    /// Builds the law for `partner`; `field` prefixes key names in errors (e.g. "contact").
    pub fn build(&self, partner: Partner, field: &str) -> Result<ContactLaw> {
        if self.has_families() {
            // the family form: read into the keys of the composition it names, reported under
            // the families' key names
            let (flat, renames) = self.lower_families(field)?;
            let mut law = flat.build(partner, field).map_err(|e| super::families::rename_keys(e, field, &renames))?;
            // the normal law itself: built from its own table by its own type
            if let Some(normal) = &self.normal {
                law.normal = normal.build(&NormalContext { partner, field, damping: DampingChoice::of(self.damping.as_ref(), self, field) })?;
                // the damping, from its own table beside the normal law's composition
                if let Some(damping) = &self.damping {
                    (law.damping, law.tangential_damping) = damping.build(&DampingContext { field, composition: normal.composition() })?;
                }
                // the tangential law too, beside the normal law's composition (checked even
                // where `friction = 0` leaves no tangential force, as the flat keys are)
                if let Some(tangential) = &self.tangential {
                    let built = tangential.build(&TangentialContext { partner, field, composition: normal.composition() })?;
                    if law.friction > 0.0 {
                        law.tangential = built;
                    }
                }
            }
            return Ok(law);
        }
        let key = |k: &str| format!("{field}.{k}");
        let friction = self.friction.unwrap_or(DEFAULT_FRICTION);
        if !(friction >= 0.0) || friction.is_nan() {
            return Err(CoreError::invalid(key("friction"), friction, "a number ≥ 0 (may be inf)"));
        }
        let resistance = |what: &str, stiffness: Option<f64>, damping: Option<f64>, cap: Option<f64>| -> Result<Option<(f64, f64, f64)>> {
            match stiffness {
                None => {
                    for (name, v) in [(format!("{what}_damping"), damping), (format!("{what}_friction"), cap)] {
                        if let Some(v) = v {
                            return Err(CoreError::Inconsistent(format!(
                                "`{}` = {v} is given but `{}` is not: set the {what} stiffness to enable {what} resistance",
                                key(&name),
                                key(&format!("{what}_stiffness"))
                            )));
                        }
                    }
                    Ok(None)
                }
                Some(k) => {
                    require_positive(&key(&format!("{what}_stiffness")), k)?;
                    let d = damping.unwrap_or(0.0);
                    require_non_negative(&key(&format!("{what}_damping")), d)?;
                    let mu = cap.unwrap_or(f64::INFINITY);
                    if !(mu >= 0.0) || mu.is_nan() {
                        return Err(CoreError::invalid(key(&format!("{what}_friction")), mu, "a number ≥ 0 (may be inf)"));
                    }
                    Ok(Some((k, d, mu)))
                }
            }
        };
        let rolling = match resistance("rolling", self.rolling_stiffness, self.rolling_damping, self.rolling_friction)? {
            None => Rolling::None,
            Some((stiffness, damping, friction)) => SpringDashpot { stiffness, damping, friction }.into(),
        };
        let twisting = match resistance("twisting", self.twisting_stiffness, self.twisting_damping, self.twisting_friction)? {
            None => Twisting::None,
            Some((stiffness, damping, friction)) => SpringDashpot { stiffness, damping, friction }.into(),
        };
        let forbid = |name: &str, v: Option<f64>, why: &str| -> Result<()> {
            match v {
                Some(v) => Err(CoreError::Inconsistent(format!("`{}` = {v} does not apply to preset `{}`: {why}", key(name), self.preset))),
                None => Ok(()),
            }
        };
        let law = match self.preset.as_str() {
            "hertz_mindlin" => {
                forbid("normal_stiffness", self.normal_stiffness, "Hertz stiffness follows from `young` and `poisson`")?;
                forbid("tangential_stiffness_ratio", self.tangential_stiffness_ratio, "Mindlin's k_t/k_n follows from `poisson`")?;
                forbid("restitution", self.restitution, "use `damping_fraction` (fraction of critical damping) or `tsuji_restitution`")?;
                forbid("normal_damping", self.normal_damping, "use `damping_fraction` (fraction of critical damping)")?;
                forbid("normal_damping_rate", self.normal_damping_rate, "use `damping_fraction` or `tsuji_restitution`")?;
                forbid("tangential_damping_rate", self.tangential_damping_rate, "use `damping_fraction` or `tsuji_restitution`")?;
                forbid(
                    "slip_activation_time",
                    self.slip_activation_time,
                    "the slip-activation law is defined for the linear tangential spring (hooke_cundall_strack)",
                )?;
                if self.tsuji_restitution.is_none() {
                    forbid(
                        "tangential_damping_ratio",
                        self.tangential_damping_ratio,
                        "the same `damping_fraction` applies to both parts (the ratio applies to Tsuji damping)",
                    )?;
                } else if self.damping_fraction.is_some() {
                    return Err(CoreError::Inconsistent(format!(
                        "give at most one of `{0}.damping_fraction`, `{0}.tsuji_restitution`",
                        field
                    )));
                }
                let young = self.young.ok_or_else(|| CoreError::invalid(key("young"), "(missing)", "Young's modulus E > 0, required by hertz_mindlin"))?;
                require_modulus(&key("young"), young)?;
                let nu = self.poisson.unwrap_or(0.0);
                if !(nu.is_finite() && (-1.0..0.5).contains(&nu)) {
                    return Err(CoreError::invalid(key("poisson"), nu, "a Poisson ratio in [-1, 0.5)"));
                }
                let zeta = self.damping_fraction.unwrap_or(0.0);
                require_non_negative(&key("damping_fraction"), zeta)?;
                let tsuji = self.tsuji_alpha(&key)?;
                let (damping, tangential_damping) = match tsuji {
                    Some(alpha) => {
                        let ratio = self.tangential_damping_ratio.unwrap_or(1.0);
                        require_non_negative(&key("tangential_damping_ratio"), ratio)?;
                        (nd::Tsuji { alpha }.into(), td::FractionOfNormal { ratio }.into())
                    }
                    None if zeta > 0.0 => (nd::CriticalFraction { zeta }.into(), td::CriticalFraction { zeta }.into()),
                    None => (NormalDamping::None, TangentialDamping::None),
                };
                let e_star = young / (1.0 - nu * nu);
                let factor = match partner {
                    Partner::Grain => 0.5,
                    Partner::Wall => 1.0,
                };
                ContactLaw {
                    normal: NormalElastic::Hertz(Hertz { effective_modulus: factor * e_star }),
                    damping,
                    tangential: if friction > 0.0 {
                        Mindlin::of_grains(young, nu, partner, self.mindlin_rescale.unwrap_or(false)).into()
                    } else {
                        Tangential::None
                    },
                    tangential_damping,
                    friction,
                    rolling,
                    twisting,
                }
            }
            "hooke_cundall_strack" => {
                forbid("young", self.young, "Hooke stiffness is `normal_stiffness`")?;
                forbid("poisson", self.poisson, "Hooke stiffness is `normal_stiffness`")?;
                if self.mindlin_rescale.is_some() {
                    return Err(CoreError::Inconsistent(format!("`{}` applies to hertz_mindlin only", key("mindlin_rescale"))));
                }
                let k_n = self
                    .normal_stiffness
                    .ok_or_else(|| CoreError::invalid(key("normal_stiffness"), "(missing)", "k_n > 0, required by hooke_cundall_strack"))?;
                require_modulus(&key("normal_stiffness"), k_n)?;
                let ratio = self.tangential_stiffness_ratio.unwrap_or(2.0 / 7.0);
                require_positive(&key("tangential_stiffness_ratio"), ratio)?;
                // the product is checked under the key the file has (1e308 × k_n overflowed and was
                // blamed on `tangential_stiffness`, which no file has)
                // (finite and normal: a vanishing ratio such as 1e-300, a "no tangential spring",
                // stays allowed)
                let k_t = ratio * k_n;
                if !(k_t.is_finite() && k_t.is_normal()) {
                    return Err(CoreError::invalid(
                        key("tangential_stiffness_ratio"),
                        format!("{ratio:?}"),
                        format!("a ratio that makes k_t = ratio × normal_stiffness a finite, normal number (here {k_t:?})"),
                    ));
                }
                // τ = 0 (or absent) is the Coulomb cap itself: the linear law, not a limit of the other
                let slip = SlipActivationParams { slip_activation_time: self.slip_activation_time };
                let tangential = slip.build(ratio * k_n, &key("slip_activation_time"))?;
                let given: Vec<&str> = self.flat_damping().iter().filter(|(_, _, v)| v.is_some()).map(|(key, _, _)| *key).collect();
                if given.len() > 1 {
                    return Err(CoreError::Inconsistent(format!(
                        "give at most one of `{0}.restitution`, `{0}.normal_damping`, `{0}.damping_fraction`, \
                         `{0}.normal_damping_rate`, `{0}.tsuji_restitution` (got {1})",
                        field,
                        given.join(", ")
                    )));
                }
                if self.tangential_damping_ratio.is_some() && self.tangential_damping_rate.is_some() {
                    return Err(CoreError::Inconsistent(format!(
                        "give at most one of `{0}.tangential_damping_ratio`, `{0}.tangential_damping_rate`",
                        field
                    )));
                }
                let damping = if let Some(e) = self.restitution {
                    if !(e > 0.0 && e <= 1.0) {
                        return Err(CoreError::invalid(key("restitution"), e, "a restitution coefficient in (0, 1]"));
                    }
                    NormalDamping::from_restitution(e).ok_or_else(|| {
                        CoreError::invalid(
                            key("restitution"),
                            e,
                            "a restitution coefficient in [0.1353, 1]: below e^-2 a linear dashpot without attraction never lets grains separate",
                        )
                    })?
                } else if let Some(g) = self.normal_damping {
                    require_non_negative(&key("normal_damping"), g)?;
                    nd::Dashpot { coefficient: g }.into()
                } else if let Some(z) = self.damping_fraction {
                    require_non_negative(&key("damping_fraction"), z)?;
                    nd::CriticalFraction { zeta: z }.into()
                } else if let Some(rate) = self.normal_damping_rate {
                    require_non_negative(&key("normal_damping_rate"), rate)?;
                    nd::MassProportional { rate }.into()
                } else if let Some(alpha) = self.tsuji_alpha(&key)? {
                    nd::Tsuji { alpha }.into()
                } else {
                    NormalDamping::None
                };
                let tangential_damping = match (self.tangential_damping_ratio, self.tangential_damping_rate, damping) {
                    (Some(r), _, _) => {
                        require_non_negative(&key("tangential_damping_ratio"), r)?;
                        td::FractionOfNormal { ratio: r }.into()
                    }
                    (None, Some(rate), _) => {
                        require_non_negative(&key("tangential_damping_rate"), rate)?;
                        td::MassProportional { rate }.into()
                    }
                    (None, None, NormalDamping::CriticalFraction(nd::CriticalFraction { zeta })) if self.damping_fraction.is_some() => {
                        td::CriticalFraction { zeta }.into()
                    }
                    (None, None, NormalDamping::None) => TangentialDamping::None,
                    (None, None, _) => td::FractionOfNormal { ratio: 0.5 }.into(),
                };
                ContactLaw {
                    normal: NormalElastic::Hooke(Hooke { stiffness: k_n }),
                    damping,
                    tangential: if friction > 0.0 { tangential } else { Tangential::None },
                    tangential_damping,
                    friction,
                    rolling,
                    twisting,
                }
            }
            other => {
                return Err(CoreError::UnknownName {
                    what: format!("contact preset (key `{}`)", key("preset")),
                    name: other.to_string(),
                    available: PRESETS.join(", "),
                })
            }
        };
        law.validate(field)?;
        Ok(law)
    }
}


/// Checks a stiffness or modulus: finite and within [1e-100, 1e100]. Every other stiffness,
/// damping and time step follows from it by ratios and square roots; outside this range (far
/// beyond any unit system) the derived values underflow or overflow, and the error would name a
/// derived key the config does not have.
pub(crate) fn require_modulus(field: &str, value: f64) -> Result<()> {
    if value.is_finite() && (1e-100..=1e100).contains(&value) {
        Ok(())
    } else {
        Err(CoreError::invalid(field, value, "a finite number in [1e-100, 1e100] (stiffnesses derived from it must stay representable)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hertz_mindlin_moduli() {
        let mut p = ContactParams::preset("hertz_mindlin");
        p.young = Some(1.0);
        p.poisson = Some(0.25);
        let g = p.build(Partner::Grain, "contact").unwrap();
        let w = p.build(Partner::Wall, "contact.wall").unwrap();
        let es = 1.0 / (1.0 - 0.0625);
        assert_eq!(g.normal, NormalElastic::Hertz(Hertz { effective_modulus: es / 2.0 }));
        assert_eq!(w.normal, NormalElastic::Hertz(Hertz { effective_modulus: es }));
        // η = k_t/k_n = 1 − ν/(2−ν)
        let kt = g.tangential.stiffness(1e-3, 0.5);
        let kn = g.normal.force_stiffness(1e-3, 0.5).1;
        assert!((kt / kn - (1.0 - 0.25 / 1.75)).abs() < 1e-14);
    }

    #[test]
    fn unknown_preset_names_alternatives() {
        let err = ContactParams::preset("hertz").build(Partner::Grain, "contact").unwrap_err().to_string();
        assert!(err.contains("`hertz`") && err.contains("hertz_mindlin") && err.contains("contact.preset"), "{err}");
    }
}
