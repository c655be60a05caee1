//! AVX-512 helpers shared by the per-grain passes (drift, orientations, displacement checks)
//! and the force pass: 3D vectors stored as consecutive (x, y, z) rows, eight of them — 24 f64,
//! three 512-bit vectors — at a time. Every function here only moves data; the arithmetic stays
//! with the callers, which perform the operations of their element-wise twins.
//!
//! All functions are compiled into callers that enable AVX-512 F (`#[target_feature]`).

use std::arch::x86_64::*;

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

/// [`crate::domain::nearest_integer`] lane by lane: clamped to ±2⁵¹ keeping NaN (the constant
/// first: NaN is the second operand of min and max), then shifted and back.
///
/// # Safety
/// AVX-512 F is available.
#[inline(always)]
pub(crate) unsafe fn nearest_integer(t: __m512d) -> __m512d {
    use crate::domain::{ROUND_LIMIT, ROUND_SHIFT};
    // SAFETY: the caller's contract.
    unsafe {
        let (limit, shift) = (_mm512_set1_pd(ROUND_LIMIT), _mm512_set1_pd(ROUND_SHIFT));
        let t = _mm512_min_pd(limit, _mm512_max_pd(_mm512_set1_pd(-ROUND_LIMIT), t));
        _mm512_sub_pd(_mm512_add_pd(t, shift), shift)
    }
}
