//! Normal damping part (SPEC §2.2) and the conversion from a restitution coefficient.

use crate::real::Real;

/// The normal force on every lane, F_n = max(0, F_el − γ_n v_n): the damping adds while the
/// grains approach (v_n < 0) and the contact never pulls. The one statement of the clamp, run by
/// the general kernel (`f64`) and the engine's vector paths.
#[inline(always)]
pub(crate) fn clamped_normal_force_lanes<R: Real>(f_el: R, gamma_n: R, v_n: R) -> R {
    (f_el - gamma_n * v_n).max_zero()
}
use super::{Composition, ParamsSchema};
use crate::error::{require_non_negative, CoreError, Result};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::fmt::Debug;

/// A normal damping law: the coefficient γ_n of the dashpot −γ_n v_n that acts while the grains
/// approach, from the pair's effective mass m*, the normal law's differential stiffness k_n and
/// its secant stiffness F_el/ξ. Register it in the list of `contact/damping/normal.rs`.
pub trait NormalDampingLaw: Copy + Debug + PartialEq + Serialize + DeserializeOwned + Send + Sync + 'static {
    /// Checks the law (also one made in code); errors name `{field}.<key>`, the value and what
    /// is allowed.
    fn validate(&self, field: &str) -> Result<()>;
    /// γ_n on every lane: the one implementation, run by the general kernel (`f64`) and the
    /// engine's vector paths.
    fn coefficient_lanes<R: Real>(&self, m_eff: R, k_n: R, secant: R) -> R;
}

/// A tangential damping law: the coefficient γ_t of the tangential dashpot γ_t v_t, from the
/// pair's effective mass m*, the tangential stiffness k_t and the normal coefficient γ_n.
/// Register it in the list of `contact/damping/tangential.rs`.
pub trait TangentialDampingLaw: Copy + Debug + PartialEq + Serialize + DeserializeOwned + Send + Sync + 'static {
    /// Checks the law (also one made in code); errors name `{field}.<key>`, the value and what
    /// is allowed.
    fn validate(&self, field: &str) -> Result<()>;
    /// γ_t on every lane: the one implementation, run by the general kernel (`f64`) and the
    /// engine's vector paths.
    fn coefficient_lanes<R: Real>(&self, m_eff: R, k_t: R, gamma_n: R) -> R;
}

/// The registry of a damping family: `module::Type` per law, the module a file
/// `contact/damping/<family>/<module>.rs` and its name the law's name in the encoding (the snake
/// case of `Type`). Generates the modules, the family's enum (the variant `None` first, then one
/// per law in registry order: checkpoints encode the variant's index, so a new law is appended
/// last) and its dispatch: the enum implements the family's trait, so a contact law's own
/// dampers (the pair of enums) and a preset's (a pair of law types, `sim::lanes`) run the same
/// code.
macro_rules! damping_laws {
    ($(#[$doc:meta])* $Enum:ident: $Trait:ident { $($module:ident :: $Law:ident),* $(,)? }) => {
        use crate::error::Result;
        use crate::real::Real;

        $(
            mod $module;
            pub use $module::$Law;
        )*

        family_enum! {
            $(#[$doc])*
            $Enum { [None: "No damping."] $($module::$Law),* }
        }

        impl $Trait for $Enum {
            fn validate(&self, field: &str) -> Result<()> {
                match self {
                    $Enum::None => Ok(()),
                    $($Enum::$Law(l) => l.validate(field),)*
                }
            }

            #[inline(always)]
            fn coefficient_lanes<R: Real>(&self, m_eff: R, k: R, c: R) -> R {
                match self {
                    $Enum::None => R::splat(0.0),
                    $($Enum::$Law(l) => l.coefficient_lanes(m_eff, k, c),)*
                }
            }
        }
    };
}

/// The registry of `[contact.damping]` tables: `Variant(module::Params)` per table, the module
/// a file of `contact/damping/normal/` (the normal damping law's own, or a table of its own such
/// as `restitution`) and its name the table's `law = "<module>"` (the snake case of `Variant`).
/// Generates [`DampingTable`] (`law = "none"` first, then one variant per table), its `name`,
/// `build` and JSON schema: a new damping law reaches the configs through its table's
/// [`DampingParams`] and this one line.
macro_rules! damping_tables {
    ($($Variant:ident($module:ident :: $Params:ident)),* $(,)?) => {
        $(pub use $module::$Params;)*

        /// The damping as a family table, `[contact.damping]`: `law = "none"` or
        /// `law = "<name>"` of a registered table and its keys ([`DampingParams`]): a normal
        /// damping law and the tangential damper that goes with it.
        #[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
        #[serde(tag = "law", rename_all = "snake_case")]
        pub enum DampingTable {
            /// `law = "none"`: no damping.
            None(super::NoDamping),
            $(
                #[doc = concat!("`law = \"", stringify!($module), "\"`: [`", stringify!($Params), "`].")]
                $Variant($Params),
            )*
        }

        impl DampingTable {
            /// The tables' names, `none` first, then in registry order.
            pub const NAMES: &'static [&'static str] = &["none", $(stringify!($module)),*];

            /// The name of this table (its `law`).
            pub fn name(&self) -> &'static str {
                match self {
                    DampingTable::None(_) => "none",
                    $(DampingTable::$Variant(_) => stringify!($module),)*
                }
            }

            /// The normal and tangential damping laws of this table beside the normal law of
            /// `at`, checked ([`DampingParams::build`]; none for `none`).
            pub fn build(&self, at: &super::DampingContext) -> crate::error::Result<(NormalDamping, super::TangentialDamping)> {
                match self {
                    DampingTable::None(_) => Ok((NormalDamping::None, super::TangentialDamping::None)),
                    $(DampingTable::$Variant(p) => super::DampingParams::build(p, at),)*
                }
            }
        }

        #[cfg(feature = "schema")]
        impl schemars::JsonSchema for DampingTable {
            fn schema_name() -> std::borrow::Cow<'static, str> {
                "DampingTable".into()
            }
            fn json_schema(generator: &mut schemars::SchemaGenerator) -> schemars::Schema {
                let alternatives = vec![
                    crate::contact::normal::tagged_table::<super::NoDamping>(generator, "none"),
                    $(crate::contact::normal::tagged_table::<$Params>(generator, stringify!($module))),*
                ];
                schemars::json_schema!({
                    "description": "The damping as a family table, `[contact.damping]`.",
                    "oneOf": alternatives
                })
            }
        }
    };
}

pub mod normal;
pub mod tangential;

pub use normal::{DampingTable, NormalDamping};
pub use tangential::TangentialDamping;

/// The table `law = "none"` of `[contact.damping]`: no keys.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct NoDamping {}

/// Where a `[contact.damping]` table is built: under which key, beside which normal law.
#[derive(Clone, Copy, Debug)]
pub struct DampingContext<'a> {
    /// The contact law's key (`contact`, `contact.wall`, …): the table's keys are
    /// `{field}.damping.<key>`.
    pub field: &'a str,
    /// The normal law's composition, which sets the defaults of the tangential damper and the
    /// laws allowed.
    pub composition: Composition,
}

impl DampingContext<'_> {
    /// `{field}.damping.<k>`.
    pub fn key(&self, k: &str) -> String {
        format!("{}.damping.{k}", self.field)
    }

    /// True beside a Hertz normal law.
    pub fn is_hertz(&self) -> bool {
        matches!(self.composition, Composition::Hertz { .. })
    }

    /// Refuses table `law` beside a Hertz normal law (a dashpot defined for the linear normal
    /// law), naming `{field}.damping.law` and the tables that are allowed there.
    pub fn linear_only(&self, law: &str) -> Result<()> {
        if self.is_hertz() {
            return Err(CoreError::invalid(
                self.key("law"),
                format!("\"{law}\""),
                "beside the Hertz normal law \"none\", \"critical_fraction\" or \"tsuji\" (this dashpot is defined for a linear normal law)",
            ));
        }
        Ok(())
    }

    /// The tangential damper of a table: γ_t = `tangential_ratio` × γ_n, or
    /// γ_t = `tangential_rate` × m* (at most one of them, each ≥ 0), or else `default`.
    pub fn tangential(&self, ratio: Option<f64>, rate: Option<f64>, default: TangentialDamping) -> Result<TangentialDamping> {
        match (ratio, rate) {
            (Some(_), Some(_)) => Err(CoreError::Inconsistent(format!(
                "give at most one of `{}`, `{}`",
                self.key("tangential_ratio"),
                self.key("tangential_rate")
            ))),
            (Some(r), None) => {
                require_non_negative(&self.key("tangential_ratio"), r)?;
                Ok(tangential::FractionOfNormal { ratio: r }.into())
            }
            (None, Some(rate)) => {
                require_non_negative(&self.key("tangential_rate"), rate)?;
                Ok(tangential::MassProportional { rate }.into())
            }
            (None, None) => Ok(default),
        }
    }
}

/// The keys of one `[contact.damping]` table (besides `law`), with `deny_unknown_fields`: a
/// way of choosing the normal damping law, and the tangential damper that goes with it.
/// Register it in the list of `contact/damping/normal.rs`.
pub trait DampingParams: Clone + Debug + PartialEq + Serialize + DeserializeOwned + ParamsSchema {
    /// The normal and tangential damping laws of the table beside the normal law of `at`,
    /// checked: errors name the key (`{field}.damping.<key>`), the value and what is allowed.
    fn build(&self, at: &DampingContext) -> Result<(NormalDamping, TangentialDamping)>;
}

impl NormalDamping {
    /// γ_n for a pair of effective mass `m_eff`, current differential normal stiffness `k_n`
    /// and secant stiffness `k_secant` = F_el/ξ (see [`NormalElastic::response`](super::NormalElastic::response)).
    #[inline]
    pub fn coefficient(&self, m_eff: f64, k_n: f64, k_secant: f64) -> f64 {
        self.coefficient_lanes(m_eff, k_n, k_secant)
    }

    /// Damping for a linear (Hooke) contact that gives restitution coefficient `e`, exactly, for
    /// the contact law as it is integrated (normal force clamped at zero).
    pub fn from_restitution(e: f64) -> Option<Self> {
        critical_fraction_for_restitution(e).map(|zeta| normal::CriticalFraction { zeta }.into())
    }
}

impl TangentialDamping {
    /// γ_t for effective mass `m_eff`, tangential stiffness `k_t` and normal coefficient `gamma_n`.
    #[inline]
    pub fn coefficient(&self, m_eff: f64, k_t: f64, gamma_n: f64) -> f64 {
        self.coefficient_lanes(m_eff, k_t, gamma_n)
    }
}

/// Tsuji's damping constant α for restitution coefficient `e` ∈ [0, 1]: the polynomial fit
///
/// α(e) = 1.2728 − 4.2783 e + 11.087 e² − 22.348 e³ + 27.467 e⁴ − 18.022 e⁵ + 4.8218 e⁶
///
/// used by LAMMPS (`pair_style granular`, `damping tsuji`), evaluated in the same expanded form.
/// It is a fit to Tsuji et al.'s numerical solutions of the Hertz contact with γ_n ∝ ξ^¼, whose
/// force may turn attractive at the end of the contact; with grainwave's clamped normal force
/// the measured restitution is somewhat larger than `e` (see the tests).
pub fn tsuji_alpha(e: f64) -> f64 {
    1.2728 - 4.2783 * e + 11.087 * e * e - 22.348 * e * e * e + 27.467 * e * e * e * e - 18.022 * e * e * e * e * e
        + 4.8218 * e * e * e * e * e * e
}

/// Textbook relation ζ(e) = −ln e / √(π² + ln² e) for a linear spring–dashpot whose force may become
/// attractive at the end of the contact (contact ends at ξ = 0).
///
/// grainwave clamps the normal force at zero (SPEC §2), so with this ζ the measured restitution is
/// *larger* than e (e = 0.5 gives 0.550). Use [`critical_fraction_for_restitution`] instead; this
/// function is kept for reference and comparison with other codes.
pub fn textbook_critical_fraction(e: f64) -> f64 {
    let l = e.ln();
    -l / (PI * PI + l * l).sqrt()
}

/// Restitution of a linear spring–dashpot contact with damping ratio `zeta` < 1 when the normal
/// force is clamped at zero (no attraction).
///
/// With ω₀ = √(k/m*), ω_d = ω₀√(1−ζ²), the overlap is ξ(t) = (v₀/ω_d) e^{−ζω₀t} sin ω_d t until the
/// force k ξ + γ ξ̇ vanishes at ω_d t₁ = π − atan2(2ζ√(1−ζ²), 1 − 2ζ²); after that the grains fly
/// apart at constant speed. Hence e = −ξ̇(t₁)/v₀ = −e^{−ζω₀t₁} [cos ω_d t₁ − ζ/√(1−ζ²) sin ω_d t₁].
/// It decreases from 1 (ζ = 0) to e⁻² ≈ 0.1353 (ζ → 1); for ζ ≥ 1 the grains never separate.
pub fn clamped_restitution(zeta: f64) -> f64 {
    if zeta <= 0.0 {
        return 1.0;
    }
    if zeta >= 1.0 {
        return (-2.0_f64).exp();
    }
    let s = (1.0 - zeta * zeta).sqrt();
    let th = PI - (2.0 * zeta * s).atan2(1.0 - 2.0 * zeta * zeta);
    let t1 = th / s; // in units of 1/ω₀
    -(-zeta * t1).exp() * (th.cos() - zeta / s * th.sin())
}

/// Duration (in units of 1/ω₀) of a clamped linear spring–dashpot contact with damping ratio
/// `zeta` < 1: the time t₁ until the force vanishes plus the free flight ξ(t₁)/|ξ̇(t₁)| to ξ = 0.
pub fn clamped_contact_time(zeta: f64) -> f64 {
    if zeta <= 0.0 {
        return PI;
    }
    let s = (1.0 - zeta * zeta).sqrt();
    let th = PI - (2.0 * zeta * s).atan2(1.0 - 2.0 * zeta * zeta);
    let t1 = th / s;
    let decay = (-zeta * t1).exp();
    let xi = decay * th.sin() / s; // ξ(t₁) ω₀ / v₀
    let v = decay * (th.cos() - zeta / s * th.sin()); // ξ̇(t₁)/v₀ (negative)
    t1 + xi / (-v)
}

/// The damping ratio ζ for which a clamped linear contact has restitution `e`, or `None` when
/// `e` ∉ [e⁻², 1] (below e⁻² ≈ 0.1353 a linear dashpot without attraction cannot separate grains).
pub fn critical_fraction_for_restitution(e: f64) -> Option<f64> {
    let e_min = (-2.0_f64).exp();
    if !(e.is_finite() && e >= e_min && e <= 1.0) {
        return None;
    }
    if e == 1.0 {
        return Some(0.0);
    }
    // clamped_restitution is strictly decreasing on [0, 1): bisection to machine precision.
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid == lo || mid == hi {
            break;
        }
        if clamped_restitution(mid) > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// Normal and tangential damping coefficients γ_n, γ_t of a law: a pair of damping laws — its own
/// damping parts (the pair `(NormalDamping, TangentialDamping)`, which matches on them at every
/// contact), or a pair of law types, the same formulas resolved at compile time for the
/// presets' combinations (`sim::lanes`).
pub(crate) trait Dampers: Copy {
    /// γ_n from m*, k_n and the secant stiffness (as `NormalDamping::coefficient`).
    fn normal<R: Real>(&self, m_eff: R, k_n: R, secant: R) -> R;
    /// γ_t (as `TangentialDamping::coefficient`).
    fn tangential<R: Real>(&self, m_eff: R, k_t: R, gamma_n: R) -> R;
}

impl<N: NormalDampingLaw, T: TangentialDampingLaw> Dampers for (N, T) {
    #[inline(always)]
    fn normal<R: Real>(&self, m_eff: R, k_n: R, secant: R) -> R {
        self.0.coefficient_lanes(m_eff, k_n, secant)
    }
    #[inline(always)]
    fn tangential<R: Real>(&self, m_eff: R, k_t: R, gamma_n: R) -> R {
        self.1.coefficient_lanes(m_eff, k_t, gamma_n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each family's registered laws keep the encoding — bincode (checkpoints) and JSON
    /// (outputs) — and the `Debug` text of the enums of struct variants they replaced, variant
    /// indices included; each law's name is its module's.
    #[test]
    fn the_registries_keep_the_names_and_the_encoding_of_every_law() {
        #[derive(Serialize, Debug)]
        #[serde(rename_all = "snake_case")]
        enum NormalBefore {
            None,
            Dashpot { coefficient: f64 },
            CriticalFraction { zeta: f64 },
            MassProportional { rate: f64 },
            Tsuji { alpha: f64 },
        }
        #[derive(Serialize, Debug)]
        #[serde(rename_all = "snake_case")]
        enum TangentialBefore {
            None,
            Coefficient { coefficient: f64 },
            FractionOfNormal { ratio: f64 },
            CriticalFraction { zeta: f64 },
            MassProportional { rate: f64 },
        }
        let n = [
            (NormalDamping::None, NormalBefore::None),
            (normal::Dashpot { coefficient: 0.5 }.into(), NormalBefore::Dashpot { coefficient: 0.5 }),
            (normal::CriticalFraction { zeta: 0.1 }.into(), NormalBefore::CriticalFraction { zeta: 0.1 }),
            (normal::MassProportional { rate: 3.0 }.into(), NormalBefore::MassProportional { rate: 3.0 }),
            (normal::Tsuji { alpha: 0.7 }.into(), NormalBefore::Tsuji { alpha: 0.7 }),
        ];
        assert_eq!(n.len(), NormalDamping::NAMES.len() + 1);
        for (law, before) in n {
            crate::contact::registry::assert_same_encoding(&law, &before, law.name());
        }
        let t = [
            (TangentialDamping::None, TangentialBefore::None),
            (tangential::Coefficient { coefficient: 0.5 }.into(), TangentialBefore::Coefficient { coefficient: 0.5 }),
            (tangential::FractionOfNormal { ratio: 0.5 }.into(), TangentialBefore::FractionOfNormal { ratio: 0.5 }),
            (tangential::CriticalFraction { zeta: 0.1 }.into(), TangentialBefore::CriticalFraction { zeta: 0.1 }),
            (tangential::MassProportional { rate: 3.0 }.into(), TangentialBefore::MassProportional { rate: 3.0 }),
        ];
        assert_eq!(t.len(), TangentialDamping::NAMES.len() + 1);
        for (law, before) in t {
            crate::contact::registry::assert_same_encoding(&law, &before, law.name());
        }
    }

    /// Each law's coefficient against its formula, and the pair of law types (a preset's
    /// dampers) giving the bits of the pair of enums (a contact law's own).
    #[test]
    fn each_damping_law_gives_its_formula_and_the_typed_pair_the_same_bits() {
        let (m, k, s, g) = (0.7, 1.3e4, 0.9e4, 2.5);
        assert_eq!(NormalDamping::None.coefficient(m, k, s), 0.0);
        assert_eq!(NormalDamping::from(normal::Dashpot { coefficient: 0.5 }).coefficient(m, k, s), 0.5);
        assert_eq!(NormalDamping::from(normal::CriticalFraction { zeta: 0.1 }).coefficient(m, k, s), 0.2 * (m * k).sqrt());
        assert_eq!(NormalDamping::from(normal::MassProportional { rate: 3.0 }).coefficient(m, k, s), 3.0 * m);
        assert_eq!(NormalDamping::from(normal::Tsuji { alpha: 0.7 }).coefficient(m, k, s), 0.7 * (m * s).sqrt());
        assert_eq!(TangentialDamping::None.coefficient(m, k, g), 0.0);
        assert_eq!(TangentialDamping::from(tangential::Coefficient { coefficient: 0.5 }).coefficient(m, k, g), 0.5);
        assert_eq!(TangentialDamping::from(tangential::FractionOfNormal { ratio: 0.5 }).coefficient(m, k, g), 0.5 * g);
        assert_eq!(TangentialDamping::from(tangential::CriticalFraction { zeta: 0.1 }).coefficient(m, k, g), 0.2 * (m * k).sqrt());
        assert_eq!(TangentialDamping::from(tangential::MassProportional { rate: 3.0 }).coefficient(m, k, g), 3.0 * m);
        let typed = (normal::Tsuji { alpha: 0.7 }, tangential::FractionOfNormal { ratio: 0.5 });
        let enums = (NormalDamping::from(typed.0), TangentialDamping::from(typed.1));
        assert_eq!(typed.normal(m, k, s).to_bits(), enums.normal(m, k, s).to_bits());
        assert_eq!(typed.tangential(m, k, g).to_bits(), enums.tangential(m, k, g).to_bits());
        // a negative value is refused naming the flat key
        let e = NormalDamping::from(normal::MassProportional { rate: -1.0 }).validate("contact").unwrap_err().to_string();
        assert!(e.contains("contact.normal_damping_rate"), "{e}");
        let e = TangentialDamping::from(tangential::FractionOfNormal { ratio: -1.0 }).validate("contact").unwrap_err().to_string();
        assert!(e.contains("contact.tangential_damping_ratio"), "{e}");
    }

    #[test]
    fn restitution_inversion_round_trips() {
        for &e in &[0.14, 0.3, 0.5, 0.9, 0.92, 0.999] {
            let z = critical_fraction_for_restitution(e).unwrap();
            assert!((clamped_restitution(z) - e).abs() < 1e-12, "e = {e}");
        }
        assert!(critical_fraction_for_restitution(0.1).is_none());
        assert!(critical_fraction_for_restitution(0.0).is_none());
        assert!(critical_fraction_for_restitution(1.2).is_none());
        // Weak damping: the clamp hardly matters and the textbook formula is recovered.
        let z = critical_fraction_for_restitution(0.999).unwrap();
        assert!((z - textbook_critical_fraction(0.999)).abs() < 1e-6);
    }

    #[test]
    fn tsuji_alpha_matches_the_published_fit() {
        // Values of the polynomial computed by hand: α(1) ≈ 0 (elastic), α(0) = 1.2728, and
        // α(0.5) = 1.2728 − 2.13915 + 2.77175 − 2.7935 + 1.71669 − 0.563188 + 0.0753406.
        assert!(tsuji_alpha(1.0).abs() < 1e-3);
        assert_eq!(tsuji_alpha(0.0), 1.2728);
        let a = 1.2728 - 2.13915 + 2.77175 - 2.7935 + 1.716_687_5 - 0.563_187_5 + 0.075_340_625;
        assert!((tsuji_alpha(0.5) - a).abs() < 1e-12, "{}", tsuji_alpha(0.5));
        // decreasing on [0, 1]: more damping for smaller restitution
        for k in 0..100 {
            let e = k as f64 / 100.0;
            assert!(tsuji_alpha(e) > tsuji_alpha(e + 0.01), "e = {e}");
        }
    }
}
