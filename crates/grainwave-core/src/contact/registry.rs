//! What every family's registry generates alike: the enum of the registered laws, its `Debug`,
//! `From` each law, and the laws' names. Each family's registry macro (`normal_laws!`,
//! `tangential_laws!`, `damping_laws!`, `resistance_laws!`) calls [`family_enum!`] and adds
//! only its own dispatch.

/// The enum of a family's registered laws: one newtype variant per law (`module::Type`, the
/// module a file of the family's folder and its name the law's name), in registry order, after
/// a unit variant `None` where the family has one (`[None: "its doc"]` before the list). Encoded as
/// the variant's name in snake case and the law's fields (`"none"` for `None`): checkpoints
/// encode the variant's index, so a new law is appended last. Generates the enum, a `Debug` that
/// prints the law's own, `From<Law>`, `NAMES` (the laws' names in registry order, without
/// `none`) and `name()`.
macro_rules! family_enum {
    ($(#[$doc:meta])* $Enum:ident { $([None: $none:literal])? $($module:ident :: $Law:ident),* $(,)? }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
        #[serde(rename_all = "snake_case")]
        pub enum $Enum {
            $(
                #[doc = $none]
                None,
            )?
            $(
                #[doc = concat!("See [`", stringify!($Law), "`] (`", stringify!($module), "`).")]
                $Law($Law),
            )*
        }

        impl std::fmt::Debug for $Enum {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                match self {
                    $($Enum::None => family_enum!(@none $none, f.write_str("None")),)?
                    $($Enum::$Law(l) => std::fmt::Debug::fmt(l, f),)*
                }
            }
        }

        impl $Enum {
            /// The names of the registered laws, in registry order (without `none`).
            pub const NAMES: &'static [&'static str] = &[$(stringify!($module)),*];

            /// The name of this law (`"none"` for `None`).
            pub fn name(&self) -> &'static str {
                match self {
                    $($Enum::None => family_enum!(@none $none, "none"),)?
                    $($Enum::$Law(_) => stringify!($module),)*
                }
            }
        }

        $(
            impl From<$Law> for $Enum {
                fn from(l: $Law) -> Self {
                    $Enum::$Law(l)
                }
            }
        )*
    };
    // the arm of `None`, present where the family has one (`$none`, its doc, only selects it)
    (@none $none:literal, $e:expr) => {
        $e
    };
}

/// Test helper for the registries: `law` (a family's enum) has the encoding — bincode
/// (checkpoints) and JSON (outputs) — and the `Debug` text of `before` (the same law in the
/// enum of struct variants the registry replaced, variant index included), decodes from both to
/// itself, and its JSON starts with `name`.
#[cfg(test)]
pub(crate) fn assert_same_encoding<L, B>(law: &L, before: &B, name: &str)
where
    L: serde::Serialize + serde::de::DeserializeOwned + std::fmt::Debug + PartialEq,
    B: serde::Serialize + std::fmt::Debug,
{
    let bytes = bincode::serialize(before).unwrap();
    assert_eq!(bincode::serialize(law).unwrap(), bytes, "{law:?}");
    assert_eq!(&bincode::deserialize::<L>(&bytes).unwrap(), law);
    let json = serde_json::to_string(before).unwrap();
    assert_eq!(serde_json::to_string(law).unwrap(), json);
    assert_eq!(&serde_json::from_str::<L>(&json).unwrap(), law);
    assert_eq!(format!("{law:?}"), format!("{before:?}"));
    assert!(json.starts_with(&format!("{{\"{name}\"")) || json == format!("\"{name}\""), "{json}");
}
