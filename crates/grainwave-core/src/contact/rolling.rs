//! Rolling resistance (SPEC §2.5) and twisting resistance: one family of laws on a relative
//! rotation ([`ResistanceLaw`]), one file per law (`contact/rolling/<law>.rs`), and the registry
//! that makes the two enums a contact law holds, [`Rolling`] and [`Twisting`] (none, or one of
//! the registered laws), and their dispatch.
//!
//! The relative rolling angular velocity is w_r = (ω_j − ω_i) with its component along the
//! normal removed (no twisting); the relative twisting velocity is w_tw = (ω_j − ω_i)·n̂. A law
//! keeps a stored rotation per contact (θ_r = ∫ w_r dt, a vector in the tangent plane; φ = ∫ w_tw
//! dt, a scalar) and gives the torque on grain i (−torque on j): M_r for rolling, M_tw n̂ for
//! twisting. Two grains rotating rigidly together feel no resistance.
//!
//! Without twisting resistance, a sphere spinning about the normal of its only contact (e.g.
//! alone on a floor) feels no torque and never stops — a frictional 3D packing could then never
//! reach zero kinetic energy. Twisting resistance is off by default and has no effect in 2D.

use crate::error::Result;
use crate::real::{Real, Vec3};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::fmt::Debug;

/// A resistance to a relative rotation (rolling or twisting): the torque from the stored
/// rotation and the relative angular velocity, one step at a time. The same law serves as
/// rolling resistance (`N` = the number of rotation components: 1 in 2D, 3 in 3D, the stored
/// rotation already turned into the current tangent plane) and as twisting resistance (`N` = 1,
/// the rotation about the normal). Register it in `resistance_laws!` (`contact/rolling.rs`).
pub trait ResistanceLaw: Copy + Debug + PartialEq + Serialize + DeserializeOwned + Send + Sync + 'static {
    /// Checks the law (also one made in code); its keys are `{key}_<name>` (`key` is
    /// `contact.rolling` or `contact.twisting`): errors name the key, the value and what is
    /// allowed.
    fn validate(&self, key: &str) -> Result<()>;
    /// An upper bound of the angular stiffness (torque/radian) over every state, for
    /// time-step suggestions.
    fn max_stiffness(&self) -> f64;
    /// The elastic energy of a stored rotation of squared size `rotation_sq` (radian²).
    fn energy(&self, rotation_sq: f64) -> f64;
    /// One step on every lane: from the stored rotation `stored`, the relative angular velocity
    /// `w` (the first `N` components of each), R* and F_n of the contact and the step `dt`, the
    /// torque on grain i (first `N` components) and the rotation to store.
    fn step_lanes<R: Real, const N: usize>(&self, stored: Vec3<R>, w: Vec3<R>, r_eff: R, f_n: R, dt: f64) -> (Vec3<R>, Vec3<R>);
}

/// The registry of resistance laws: `module::Type` per law, the module a file
/// `contact/rolling/<module>.rs` and its name the law's name in the encoding (the snake case of
/// `Type`). Generates the modules and both enums, [`Rolling`] and [`Twisting`] (the variant
/// `None` first, then one per law in registry order: checkpoints encode the variant's index, so
/// a new law is appended last), with their dispatch.
macro_rules! resistance_laws {
    ($($module:ident :: $Law:ident),* $(,)?) => {
        $(
            mod $module;
            pub use $module::$Law;
        )*
        resistance_laws!(@family Rolling, "Rolling resistance: none (the default) or one of the registered laws ([`ResistanceLaw`]) on the relative rolling rotation; encoded as the variant's name and the law's fields (`\"none\"` for none).", $($module::$Law),*);
        resistance_laws!(@family Twisting, "Twisting (torsional) resistance, 3D only: none (the default) or one of the registered laws ([`ResistanceLaw`]) on the relative spin about the contact normal; encoded as the variant's name and the law's fields (`\"none\"` for none).", $($module::$Law),*);
    };
    (@family $Enum:ident, $doc:literal, $($module:ident :: $Law:ident),*) => {
        family_enum! {
            #[doc = $doc]
            $Enum { [None: "No resistance (default)."] $($module::$Law),* }
        }

        impl $Enum {
            /// Checks the law ([`ResistanceLaw::validate`]); `key` is `{field}.rolling` or
            /// `{field}.twisting`.
            pub fn validate(&self, key: &str) -> Result<()> {
                match self {
                    $Enum::None => Ok(()),
                    $($Enum::$Law(l) => l.validate(key),)*
                }
            }

            /// The law's angular stiffness bound ([`ResistanceLaw::max_stiffness`]); `None`
            /// without resistance.
            pub fn max_stiffness(&self) -> Option<f64> {
                match self {
                    $Enum::None => None,
                    $($Enum::$Law(l) => Some(l.max_stiffness()),)*
                }
            }

            /// The elastic energy of a stored rotation of squared size `rotation_sq`; 0 without
            /// resistance.
            pub fn energy(&self, rotation_sq: f64) -> f64 {
                match self {
                    $Enum::None => 0.0,
                    $($Enum::$Law(l) => l.energy(rotation_sq),)*
                }
            }

            /// One step ([`ResistanceLaw::step_lanes`]); without resistance no torque and the
            /// stored rotation kept.
            #[inline(always)]
            pub(crate) fn step_lanes<R: Real, const N: usize>(&self, stored: Vec3<R>, w: Vec3<R>, r_eff: R, f_n: R, dt: f64) -> (Vec3<R>, Vec3<R>) {
                match self {
                    $Enum::None => ([R::splat(0.0); 3], stored),
                    $($Enum::$Law(l) => l.step_lanes::<R, N>(stored, w, r_eff, f_n, dt),)*
                }
            }
        }
    };
}

resistance_laws! {
    spring_dashpot::SpringDashpot,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both enums keep the encoding — bincode (checkpoints) and JSON (outputs) — and the `Debug`
    /// text of the enums of struct variants the registry replaced; the law's name is its
    /// module's.
    #[test]
    fn the_registry_keeps_the_names_and_the_encoding_of_every_law() {
        #[derive(Serialize, Debug)]
        #[serde(rename_all = "snake_case")]
        enum Before {
            None,
            SpringDashpot { stiffness: f64, damping: f64, friction: f64 },
        }
        let law = SpringDashpot { stiffness: 2.0, damping: 0.5, friction: 0.4 };
        let before = Before::SpringDashpot { stiffness: 2.0, damping: 0.5, friction: 0.4 };
        for (rolling, twisting, b) in [(Rolling::None, Twisting::None, Before::None), (law.into(), law.into(), before)] {
            crate::contact::registry::assert_same_encoding(&rolling, &b, rolling.name());
            crate::contact::registry::assert_same_encoding(&twisting, &b, twisting.name());
        }
        // without a cap (the default without `rolling_friction`) the checkpoint encoding too;
        // JSON has no infinity (written as null), so outputs show an uncapped law as null
        let uncapped = SpringDashpot { friction: f64::INFINITY, ..law };
        let bytes = bincode::serialize(&Before::SpringDashpot { stiffness: 2.0, damping: 0.5, friction: f64::INFINITY }).unwrap();
        assert_eq!(bincode::serialize(&Rolling::from(uncapped)).unwrap(), bytes);
        assert_eq!(bincode::deserialize::<Rolling>(&bytes).unwrap(), uncapped.into());
        assert_eq!(Rolling::NAMES, ["spring_dashpot"]);
    }

    /// One step against the closed form: below the cap θ ← θ + wΔt and M = kθ + γw; above it
    /// |M| = μ R* F_n along the trial torque and θ = M/k; the energy ½k|θ|²; a bad value names
    /// its key.
    #[test]
    fn a_spring_dashpot_step_is_the_capped_spring() {
        let law = SpringDashpot { stiffness: 2.0, damping: 0.5, friction: 0.25 };
        let (dt, r, f_n) = (0.1, 0.5, 8.0); // cap 0.25 · 0.5 · 8 = 1
        let (m, theta) = law.step_lanes::<f64, 1>([0.1, 0.0, 0.0], [1.0, 0.0, 0.0], r, f_n, dt);
        assert_eq!(theta[0], 0.1 + 1.0 * 0.1);
        assert_eq!(m[0], 2.0 * 0.2 + 0.5 * 1.0);
        let (m, theta) = law.step_lanes::<f64, 1>([0.5, 0.0, 0.0], [1.0, 0.0, 0.0], r, f_n, dt);
        // trial 2 · 0.6 + 0.5 = 1.7 > 1: scaled to the cap (one rounding)
        assert!((m[0] - 1.0).abs() < 1e-15 && (theta[0] - 0.5).abs() < 1e-15, "{m:?} {theta:?}");
        assert_eq!(law.energy(0.25), 0.25);
        assert_eq!(Rolling::None.step_lanes::<f64, 1>([0.3, 0.0, 0.0], [1.0, 0.0, 0.0], r, f_n, dt), ([0.0; 3], [0.3, 0.0, 0.0]));
        let e = Twisting::from(SpringDashpot { stiffness: 2.0, damping: -1.0, friction: 0.0 }).validate("contact.twisting").unwrap_err().to_string();
        assert!(e.contains("contact.twisting_damping"), "{e}");
    }
}
