//! The floating-point lanes that lane-generic engine code is written for.
//!
//! [`Real`] is `f64` (one value: the scalar paths, and the window loops the compiler vectorizes)
//! or a vector of several values (the explicit AVX2 and AVX-512 paths). Code written once over
//! `R: Real` — the minimum image ([`crate::domain::PeriodicImage::displacement_velocity_lanes`]),
//! the specialised contact law (`sim::lanes::contact`) — runs on every path. Every operation is
//! the IEEE operation of `f64` lane by lane (no fused multiply–add), so the results have the same
//! bits on every path.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Floating-point lanes: `f64` or a vector of f64 whose every operation is the `f64` one lane by
/// lane (see the module documentation).
pub(crate) trait Real: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self> {
    /// Per-lane truth value.
    type Mask: Copy;
    /// Every lane `x`.
    fn splat(x: f64) -> Self;
    /// √x lane by lane.
    fn sqrt(self) -> Self;
    /// `self.max(0.0)`: 0 for NaN.
    fn max_zero(self) -> Self;
    /// `self < o ? self : o` lane by lane (`o` when either is NaN: the x86 `min` instructions).
    fn min(self, o: Self) -> Self;
    /// `self > o ? self : o` lane by lane (`o` when either is NaN: the x86 `max` instructions).
    fn max(self, o: Self) -> Self;
    /// `self == o` (false for NaN).
    fn eq(self, o: Self) -> Self::Mask;
    /// `self > o` (false for NaN).
    fn gt(self, o: Self) -> Self::Mask;
    /// `if m { a } else { b }` lane by lane.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// `f` lane by lane (the general damping parts).
    fn map3(a: Self, b: Self, c: Self, f: impl Fn(f64, f64, f64) -> f64) -> Self;
}

impl Real for f64 {
    type Mask = bool;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn max_zero(self) -> Self {
        self.max(0.0)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // not `f64::min`, which ignores a NaN operand
        if self < o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // not `f64::max`, which ignores a NaN operand
        if self > o {
            self
        } else {
            o
        }
    }
    #[inline(always)]
    fn eq(self, o: Self) -> bool {
        self == o
    }
    #[inline(always)]
    fn gt(self, o: Self) -> bool {
        self > o
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn map3(a: Self, b: Self, c: Self, f: impl Fn(f64, f64, f64) -> f64) -> Self {
        f(a, b, c)
    }
}

#[cfg(test)]
mod tests {
    use super::Real;

    #[test]
    fn scalar_min_and_max_are_the_vector_instructions() {
        // `a < b ? a : b` / `a > b ? a : b`: the second operand when either is NaN, the second of
        // two zeros — what `minpd`/`maxpd` do, unlike `f64::min`/`f64::max`
        let nan = f64::NAN;
        assert!(Real::min(1.0, nan).is_nan() && Real::max(1.0, nan).is_nan());
        assert_eq!(Real::min(nan, 1.0), 1.0);
        assert_eq!(Real::max(nan, 1.0), 1.0);
        assert_eq!(Real::min(-0.0, 0.0).to_bits(), 0.0f64.to_bits());
        assert_eq!(Real::max(0.0, -0.0).to_bits(), (-0.0f64).to_bits());
        assert_eq!(Real::min(2.0, 3.0), 2.0);
        assert_eq!(Real::max(2.0, 3.0), 3.0);
    }
}
