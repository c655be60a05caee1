//! Value types shared by experiment configs.

use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::domain::TimeFunction;
use schemars::JsonSchema;
use serde::{Deserialize, Deserializer, Serialize};

/// A vector given as a list of 2 or 3 numbers (one per axis of the simulation).
pub type VectorConfig = Vec<f64>;

/// Converts a config vector to the simulation's vector type, or describes what is wrong.
pub fn to_vector<D: Dim>(v: &[f64]) -> Result<D::Vector, String> {
    if v.len() != D::D {
        return Err(format!("{v:?} has {} components; a {}D run needs {} (one per axis)", v.len(), D::D, D::D));
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(format!("{v:?} has a non-finite component"));
    }
    Ok(D::Vector::from_slice(v))
}

/// A coordinate axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// First axis.
    X,
    /// Second axis.
    Y,
    /// Third axis (3D only).
    Z,
}

impl Axis {
    /// Index 0, 1 or 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// A function of time: a plain number (constant) or a table with a `type`:
/// `{ type = "ramp", from, to, start, end }` (linear between `start` and `end`),
/// `{ type = "cosine_stop", value, start, duration }` (value·(1 + cos(π(t−start)/duration))/2,
/// then 0), `{ type = "table", times = [...], values = [...] }` (piecewise linear).
#[derive(Clone, Debug, PartialEq, Serialize, JsonSchema)]
#[serde(untagged)]
pub enum TimeFunctionConfig {
    /// A constant.
    Constant(f64),
    /// A tagged function.
    Function(TaggedTimeFunction),
}

/// The tagged forms of [`TimeFunctionConfig`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum TaggedTimeFunction {
    /// Linear from `from` (t ≤ start) to `to` (t ≥ end).
    Ramp {
        /// Value before the ramp.
        from: f64,
        /// Value after the ramp.
        to: f64,
        /// Start time [time].
        start: f64,
        /// End time [time].
        end: f64,
    },
    /// Smooth stop.
    CosineStop {
        /// Value before the stop.
        value: f64,
        /// Start time [time].
        start: f64,
        /// Duration of the stop [time].
        duration: f64,
    },
    /// Piecewise linear.
    Table {
        /// Increasing times [time].
        times: Vec<f64>,
        /// Values at those times.
        values: Vec<f64>,
    },
}

impl<'de> Deserialize<'de> for TimeFunctionConfig {
    fn deserialize<Dz: Deserializer<'de>>(d: Dz) -> Result<Self, Dz::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = TimeFunctionConfig;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number, or a table with `type` = \"ramp\", \"cosine_stop\" or \"table\"")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Self::Value, E> {
                Ok(TimeFunctionConfig::Constant(v))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Self::Value, E> {
                Ok(TimeFunctionConfig::Constant(v as f64))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Self::Value, E> {
                Ok(TimeFunctionConfig::Constant(v as f64))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
                TaggedTimeFunction::deserialize(serde::de::value::MapAccessDeserializer::new(map)).map(TimeFunctionConfig::Function)
            }
        }
        d.deserialize_any(V)
    }
}

impl TimeFunctionConfig {
    /// The engine's time function.
    pub fn to_core(&self) -> TimeFunction {
        match self.clone() {
            TimeFunctionConfig::Constant(value) => TimeFunction::Constant { value },
            TimeFunctionConfig::Function(TaggedTimeFunction::Ramp { from, to, start, end }) => TimeFunction::Ramp { from, to, start, end },
            TimeFunctionConfig::Function(TaggedTimeFunction::CosineStop { value, start, duration }) => {
                TimeFunction::CosineStop { value, start, duration }
            }
            TimeFunctionConfig::Function(TaggedTimeFunction::Table { times, values }) => TimeFunction::Table { times, values },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize)]
    struct T {
        f: TimeFunctionConfig,
    }

    #[test]
    fn number_or_table() {
        let t: T = toml::from_str("f = 2").unwrap();
        assert_eq!(t.f, TimeFunctionConfig::Constant(2.0));
        let t: T = toml::from_str("f = { type = \"ramp\", from = 0, to = 1, start = 0, end = 2 }").unwrap();
        assert_eq!(t.f.to_core().eval(1.0), 0.5);
        let e = toml::from_str::<T>("f = { type = \"rmp\" }").unwrap_err();
        assert!(e.message().contains("rmp"), "{}", e.message());
        let e = toml::from_str::<T>("f = \"fast\"").unwrap_err();
        assert!(e.message().contains("a number, or a table"), "{}", e.message());
    }
}
