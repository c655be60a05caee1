//! AVX-512 helpers shared by the per-grain passes (drift, orientations, displacement checks)
//! and the force pass: 3D vectors stored as consecutive (x, y, z) rows, eight of them — 24 f64,
//! three 512-bit vectors — at a time; and [`Wide8`], eight f64 lanes, on which the lane-generic
//! arithmetic (the domain's minimum image, the contact law) runs. The functions here only move
//! data; the arithmetic stays with the callers, which perform the operations of their
//! element-wise twins.
//!
//! All functions are compiled into callers that enable AVX-512 F (`#[target_feature]`).

use crate::real::Real;
use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Eight i64 lanes (permutation indices).
///
/// # Safety
/// AVX-512 F is available.
#[inline(always)]
pub(crate) unsafe fn idx(a: [i64; 8]) -> __m512i {
    // SAFETY: the caller's contract.
    unsafe { _mm512_setr_epi64(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]) }
}

/// x, y and z of eight consecutive rows, from the three vectors `a`, `b`, `c` holding them
/// (a = x0 y0 z0 x1 y1 z1 x2 y2, b = z2 … x5, c = y5 … z7).
///
/// # Safety
/// AVX-512 F is available.
#[inline(always)]
pub(crate) unsafe fn deinterleave3(a: __m512d, b: __m512d, c: __m512d) -> [__m512d; 3] {
    // SAFETY: the caller's contract.
    unsafe {
        let x = _mm512_permutex2var_pd(a, idx([0, 3, 6, 9, 12, 15, 0, 0]), b);
        let y = _mm512_permutex2var_pd(a, idx([1, 4, 7, 10, 13, 0, 0, 0]), b);
        let z = _mm512_permutex2var_pd(a, idx([2, 5, 8, 11, 14, 0, 0, 0]), b);
        [
            _mm512_permutex2var_pd(x, idx([0, 1, 2, 3, 4, 5, 10, 13]), c),
            _mm512_permutex2var_pd(y, idx([0, 1, 2, 3, 4, 8, 11, 14]), c),
            _mm512_permutex2var_pd(z, idx([0, 1, 2, 3, 4, 9, 12, 15]), c),
        ]
    }
}

/// A per-coordinate constant (x, y, z) laid out like three vectors of eight consecutive rows:
/// element k of vector r is `v[(8 r + k) mod 3]`.
///
/// # Safety
/// AVX-512 F is available.
#[inline(always)]
pub(crate) unsafe fn per_coordinate(v: [f64; 3]) -> [__m512d; 3] {
    let e = |r: usize, k: usize| v[(8 * r + k) % 3];
    // SAFETY: the caller's contract.
    unsafe { std::array::from_fn(|r| _mm512_setr_pd(e(r, 0), e(r, 1), e(r, 2), e(r, 3), e(r, 4), e(r, 5), e(r, 6), e(r, 7))) }
}

/// Mask of the first `n` of eight lanes (all eight for `n` ≥ 8).
#[inline(always)]
pub(crate) fn first_lanes(n: usize) -> __mmask8 {
    (0xffu32 >> (8 - n.min(8))) as __mmask8
}

/// Eight f64 lanes in one 512-bit register: the lane type of the fused pass on processors with
/// AVX-512 F and VL (`Path::Fused512`), and of the AVX-512 passes over grains and candidate
/// pairs (displacement checks, neighbor search, close list). Only used inside functions compiled
/// with AVX-512 F (the operations are inlined there). Every operation is the IEEE operation of
/// `f64` lane by lane ([`Real`]): the same bits as the scalar code.
#[derive(Clone, Copy)]
pub(crate) struct Wide8(pub(crate) __m512d);

macro_rules! binary_wide {
    ($trait:ident, $f:ident, $op:ident) => {
        impl $trait for Wide8 {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                // SAFETY: only used in code compiled with AVX-512 F, on processors that have it.
                unsafe { Wide8($op(self.0, o.0)) }
            }
        }
    };
}
binary_wide!(Add, add, _mm512_add_pd);
binary_wide!(Sub, sub, _mm512_sub_pd);
binary_wide!(Mul, mul, _mm512_mul_pd);
binary_wide!(Div, div, _mm512_div_pd);

impl Neg for Wide8 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        // SAFETY: as above. Flips the sign bit, as f64 negation (integer xor: AVX-512 F only).
        unsafe { Wide8(_mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(self.0), _mm512_set1_epi64(i64::MIN)))) }
    }
}

impl Real for Wide8 {
    type Mask = __mmask8;
    const LANES: usize = 8;
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> Self {
        let a = [f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7)];
        // SAFETY: as above; unaligned load of eight f64.
        unsafe { Wide8(_mm512_loadu_pd(a.as_ptr())) }
    }
    #[inline(always)]
    fn for_each_lane(self, mut f: impl FnMut(usize, f64)) {
        for (l, x) in self.lanes().into_iter().enumerate() {
            f(l, x);
        }
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        // SAFETY: as above.
        unsafe { Wide8(_mm512_set1_pd(x)) }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        // SAFETY: as above.
        unsafe { Wide8(_mm512_sqrt_pd(self.0)) }
    }
    #[inline(always)]
    fn max_zero(self) -> Self {
        // SAFETY: as above. `x > 0 ? x : 0`: 0 for NaN, as f64::max.
        unsafe { Wide8(_mm512_max_pd(self.0, _mm512_setzero_pd())) }
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // SAFETY: as above. `self < o ? self : o`.
        unsafe { Wide8(_mm512_min_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: as above. `self > o ? self : o`.
        unsafe { Wide8(_mm512_max_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn eq(self, o: Self) -> __mmask8 {
        // SAFETY: as above.
        unsafe { _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn gt(self, o: Self) -> __mmask8 {
        // SAFETY: as above.
        unsafe { _mm512_cmp_pd_mask::<_CMP_GT_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn select(m: __mmask8, a: Self, b: Self) -> Self {
        // SAFETY: as above (lanes of `a` where `m` is set).
        unsafe { Wide8(_mm512_mask_blend_pd(m, b.0, a.0)) }
    }
}

impl Wide8 {
    /// The eight lanes.
    #[inline(always)]
    pub(crate) fn lanes(self) -> [f64; 8] {
        let mut a = [0.0; 8];
        // SAFETY: as above; unaligned store into eight f64.
        unsafe { _mm512_storeu_pd(a.as_mut_ptr(), self.0) };
        a
    }
}
