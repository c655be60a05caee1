//! The floating-point lanes that lane-generic engine code is written for.
//!
//! [`Real`] is `f64` (one value: the scalar paths, and the window loops the compiler vectorizes)
//! or a vector of several values (the explicit AVX2 and AVX-512 paths). Code written once over
//! `R: Real` — the minimum image ([`crate::domain::PeriodicImage::displacement_velocity_lanes`]),
//! the parts of the contact law (`contact::*_lanes`, assembled by the general kernel on `f64`
//! and by `sim::lanes::contact` on every lane type) — runs on every path. Every operation is
//! the IEEE operation of `f64` lane by lane (no fused multiply–add), so the results have the same
//! bits on every path.

use crate::dim::VectorOps;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Floating-point lanes: `f64` or a vector of f64 whose every operation is the `f64` one lane by
/// lane (see the module documentation). Nominally `pub` (the module is not) because the
/// lane-generic hooks of the public `LawParts` and `LawHistory` name it in their bounds.
pub trait Real: Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self> {
    /// Per-lane truth value.
    type Mask: Copy;
    /// Number of lanes.
    const LANES: usize;
    /// The lanes `f(0), f(1), …` in order (a per-contact value gathered lane by lane: the
    /// law's own history, `LawHistory::gather`).
    fn from_fn(f: impl FnMut(usize) -> f64) -> Self;
    /// `f(l, x)` for every lane `l` and its value `x`, in lane order (a per-contact value
    /// scattered lane by lane: `LawHistory::scatter`).
    fn for_each_lane(self, f: impl FnMut(usize, f64));
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
    /// `m`, on one lane (`f64`), where the one-lane instance of a lane-generic part may branch
    /// past work that it does not need; `false` on vector types, which stay branch-free (a
    /// branch taken only when no lane of a vector needs the work was mispredicted often enough
    /// to cost 3–4 % on `hooke2d`, docs/bench-history.md). Either way the result has the same bits: the
    /// code after the branch selects the same values.
    #[inline(always)]
    fn branch_if(_m: Self::Mask) -> bool {
        false
    }
    /// `!m` on one lane (`f64`), `false` on vector types (see [`Real::branch_if`]).
    #[inline(always)]
    fn branch_unless(_m: Self::Mask) -> bool {
        false
    }
}

impl Real for f64 {
    type Mask = bool;
    const LANES: usize = 1;
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> Self {
        f(0)
    }
    #[inline(always)]
    fn for_each_lane(self, mut f: impl FnMut(usize, f64)) {
        f(0, self)
    }
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
    fn branch_if(m: bool) -> bool {
        m
    }
    #[inline(always)]
    fn branch_unless(m: bool) -> bool {
        !m
    }
}

/// A vector over lanes: component `c` of every lane in `v[c]`; the components at and past the
/// dimension are unused.
pub(crate) type Vec3<R> = [R; 3];

/// a·b over the first `N` components, in the component order of `VectorOps::dot`.
#[inline(always)]
pub(crate) fn dot<R: Real, const N: usize>(a: Vec3<R>, b: Vec3<R>) -> R {
    let mut s = a[0] * b[0];
    for c in 1..N {
        s = s + a[c] * b[c];
    }
    s
}

/// `if m { a } else { b }` lane by lane on every component of a [`Vec3`].
#[inline(always)]
pub(crate) fn select3<R: Real>(m: R::Mask, a: Vec3<R>, b: Vec3<R>) -> Vec3<R> {
    [R::select(m, a[0], b[0]), R::select(m, a[1], b[1]), R::select(m, a[2], b[2])]
}

/// The components of `v` as a one-lane [`Vec3`] (zero past `V::LEN`).
#[inline(always)]
pub(crate) fn to_lanes<V: VectorOps>(v: V) -> Vec3<f64> {
    let mut a = [0.0; 3];
    for (c, x) in a.iter_mut().enumerate().take(V::LEN) {
        *x = v.get(c);
    }
    a
}

/// The vector whose components are the first `V::LEN` of `a`.
#[inline(always)]
pub(crate) fn from_lanes<V: VectorOps>(a: Vec3<f64>) -> V {
    let mut v = V::ZERO;
    for (c, &x) in a.iter().enumerate().take(V::LEN) {
        v.set(c, x);
    }
    v
}

/// Runs the lane-generic `$f::<f64, N>` with `N = <$v as VectorOps>::LEN` (1, 2 or 3), chosen at
/// compile time: the one-lane instance of a function written over `[R; 3]` vectors.
macro_rules! by_len {
    ($v:ty, $f:ident ( $($arg:expr),* $(,)? )) => {
        match <$v as $crate::dim::VectorOps>::LEN {
            1 => $f::<f64, 1>($($arg),*),
            2 => $f::<f64, 2>($($arg),*),
            _ => $f::<f64, 3>($($arg),*),
        }
    };
}
pub(crate) use by_len;

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
