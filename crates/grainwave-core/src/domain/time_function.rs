//! Prescribed functions of time: wall speeds, piston forces, load ramps.

use crate::error::{require_finite, require_non_negative, require_positive, CoreError, Result};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A scalar function of simulated time t.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeFunction {
    /// f(t) = value.
    Constant {
        /// The value.
        value: f64,
    },
    /// Linear from `from` at t ≤ `start` to `to` at t ≥ `end`.
    Ramp {
        /// Value before the ramp.
        from: f64,
        /// Value after the ramp.
        to: f64,
        /// Start time of the ramp.
        start: f64,
        /// End time of the ramp (> start).
        end: f64,
    },
    /// Smooth stop: `value` before `start`, value·(1 + cos(π (t−start)/duration))/2 during the stop,
    /// 0 after (SPEC §6.6).
    CosineStop {
        /// Value before the stop.
        value: f64,
        /// Start of the stop.
        start: f64,
        /// Duration t_s of the stop (> 0).
        duration: f64,
    },
    /// Piecewise linear through (times[k], values[k]); constant beyond the ends.
    Table {
        /// Increasing times.
        times: Vec<f64>,
        /// Values at those times.
        values: Vec<f64>,
    },
}

impl TimeFunction {
    /// A constant.
    pub fn constant(value: f64) -> Self {
        TimeFunction::Constant { value }
    }

    /// Value at time `t`.
    pub fn eval(&self, t: f64) -> f64 {
        match self {
            TimeFunction::Constant { value } => *value,
            TimeFunction::Ramp { from, to, start, end } => {
                if t <= *start {
                    *from
                } else if t >= *end {
                    *to
                } else {
                    from + (to - from) * (t - start) / (end - start)
                }
            }
            TimeFunction::CosineStop { value, start, duration } => {
                if t <= *start {
                    *value
                } else if t >= start + duration {
                    0.0
                } else {
                    value * 0.5 * (1.0 + (PI * (t - start) / duration).cos())
                }
            }
            TimeFunction::Table { times, values } => {
                if t <= times[0] {
                    return values[0];
                }
                let last = times.len() - 1;
                if t >= times[last] {
                    return values[last];
                }
                let k = times.partition_point(|&x| x <= t) - 1;
                values[k] + (values[k + 1] - values[k]) * (t - times[k]) / (times[k + 1] - times[k])
            }
        }
    }

    /// Checks the parameters; `field` names the function in error messages.
    pub fn validate(&self, field: &str) -> Result<()> {
        match self {
            TimeFunction::Constant { value } => require_finite(&format!("{field}.value"), *value),
            TimeFunction::Ramp { from, to, start, end } => {
                require_finite(&format!("{field}.from"), *from)?;
                require_finite(&format!("{field}.to"), *to)?;
                require_finite(&format!("{field}.start"), *start)?;
                if !(end.is_finite() && end > start) {
                    return Err(CoreError::invalid(format!("{field}.end"), end, format!("a finite time > start = {start}")));
                }
                Ok(())
            }
            TimeFunction::CosineStop { value, start, duration } => {
                require_finite(&format!("{field}.value"), *value)?;
                require_non_negative(&format!("{field}.start"), *start)?;
                require_positive(&format!("{field}.duration"), *duration)
            }
            TimeFunction::Table { times, values } => {
                if times.is_empty() || times.len() != values.len() {
                    return Err(CoreError::invalid(
                        format!("{field}.times"),
                        format!("{} times, {} values", times.len(), values.len()),
                        "as many times as values, at least one",
                    ));
                }
                if times.windows(2).any(|w| !(w[1] > w[0])) || times.iter().chain(values).any(|x| !x.is_finite()) {
                    return Err(CoreError::invalid(format!("{field}.times"), format!("{times:?}"), "finite, strictly increasing times"));
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn functions_evaluate_as_documented() {
        let r = TimeFunction::Ramp { from: 0.0, to: 2.0, start: 1.0, end: 3.0 };
        assert_eq!(r.eval(0.0), 0.0);
        assert_eq!(r.eval(2.0), 1.0);
        assert_eq!(r.eval(5.0), 2.0);
        let c = TimeFunction::CosineStop { value: 4.0, start: 1.0, duration: 2.0 };
        assert_eq!(c.eval(0.5), 4.0);
        assert!((c.eval(2.0) - 2.0).abs() < 1e-14);
        assert_eq!(c.eval(3.5), 0.0);
        let t = TimeFunction::Table { times: vec![0.0, 1.0, 3.0], values: vec![0.0, 1.0, -1.0] };
        assert_eq!(t.eval(2.0), 0.0);
        assert_eq!(t.eval(-1.0), 0.0);
        assert_eq!(t.eval(9.0), -1.0);
        assert!(TimeFunction::Ramp { from: 0.0, to: 1.0, start: 1.0, end: 1.0 }.validate("f").is_err());
    }
}
