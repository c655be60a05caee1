//! The fused force pass: candidate pairs a group at a time, straight from the pair list to the
//! grains' sums, with no window in between.
//!
//! Each group of consecutive pairs of the list (across owners; in 3D, of the block's close list)
//! is looked at in registers: rows of positions and velocities are loaded and transposed into one
//! vector per component, the nearest image, the distance test and — when a lane touches — the
//! whole specialised contact law ([`lanes::contact`] on the lane type) run on all lanes at once,
//! and the results go back to the history and to the force and torque sums of both grains in
//! list order. Every lane performs exactly the floating-point operations of the scalar path
//! ([`super::push_pair`], [`lanes::contact`] on `f64`, [`super::flush_block`]) in the same order,
//! and every grain's sum receives its terms in the same order (list order), so the run is bitwise
//! that of the other paths (tested on whole runs, `tests/force_blocks.rs`, sheared cells
//! included).
//!
//! Two lane types: [`F64x8`], eight lanes as two 256-bit vectors (AVX2; level 1), and
//! [`Wide16`], sixteen lanes as two 512-bit vectors (AVX-512 F and VL; level 3, the default
//! where the processor has it). Two vectors side by side let the long square-root and division
//! chains of two groups overlap (one 512-bit vector of eight lanes was 5–16 % slower, three or
//! four spilled registers and were 10–20 % slower, `docs/bench-history.md`). On 512-bit lanes the 3D
//! results go back as rows (x, y, z) with two-element and one-element vector loads and stores,
//! the owner's sums kept in registers over its lanes of a group. The passes are written once,
//! generic over the lane type, with one wrapper per lane type compiled for its extensions.
//!
//! Used on x86-64 processors with AVX2, for packings of fewer than 2³²/3 grains and pairs
//! (indices, and three times them, are held in 32-bit lanes; larger ones take the portable path).

use super::{finish_grain, start_block, CrossForce, CrossIndex, Finish, ForceStats, Grain, History, Inputs, Velocities};
use crate::contact::{LawHistory, LawParts, TangentialHistory};
use crate::dim::{Dim, VectorOps};
use crate::domain::nearest_image_axis;
use crate::sim::lanes::{self, ContactIn, Dampers, Real, WindowLaw, WithDampers};
use crate::simd512::Wide8;
use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// True when the processor has AVX2.
pub(super) fn available() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

/// True when the processor also has AVX-512 F and VL (the pass on 512-bit lanes, [`Wide8`]).
pub(super) fn wide_available() -> bool {
    available() && std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl")
}

/// Four f64 lanes. Only used inside functions compiled with AVX2 (the operations are inlined
/// there).
#[derive(Clone, Copy)]
pub(super) struct F64x4(__m256d);

macro_rules! binary {
    ($trait:ident, $f:ident, $op:ident) => {
        impl $trait for F64x4 {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                // SAFETY: only used in code compiled with AVX2, on processors that have it.
                unsafe { F64x4($op(self.0, o.0)) }
            }
        }
    };
}
binary!(Add, add, _mm256_add_pd);
binary!(Sub, sub, _mm256_sub_pd);
binary!(Mul, mul, _mm256_mul_pd);
binary!(Div, div, _mm256_div_pd);

impl Neg for F64x4 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        // SAFETY: as above. Flips the sign bit, as f64 negation.
        unsafe { F64x4(_mm256_xor_pd(self.0, _mm256_set1_pd(-0.0))) }
    }
}

impl Real for F64x4 {
    type Mask = __m256d;
    const LANES: usize = 4;
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> Self {
        let a = [f(0), f(1), f(2), f(3)];
        // SAFETY: as above; unaligned load of four f64.
        unsafe { F64x4(_mm256_loadu_pd(a.as_ptr())) }
    }
    #[inline(always)]
    fn for_each_lane(self, mut f: impl FnMut(usize, f64)) {
        for (l, x) in lanes_of(self.0).into_iter().enumerate() {
            f(l, x);
        }
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        // SAFETY: as above.
        unsafe { F64x4(_mm256_set1_pd(x)) }
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        // SAFETY: as above.
        unsafe { F64x4(_mm256_sqrt_pd(self.0)) }
    }
    #[inline(always)]
    fn max_zero(self) -> Self {
        // SAFETY: as above. `x > 0 ? x : 0`: 0 for NaN, as f64::max.
        unsafe { F64x4(_mm256_max_pd(self.0, _mm256_setzero_pd())) }
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // SAFETY: as above. `self < o ? self : o`.
        unsafe { F64x4(_mm256_min_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: as above. `self > o ? self : o`.
        unsafe { F64x4(_mm256_max_pd(self.0, o.0)) }
    }
    #[inline(always)]
    fn eq(self, o: Self) -> __m256d {
        // SAFETY: as above.
        unsafe { _mm256_cmp_pd::<_CMP_EQ_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn gt(self, o: Self) -> __m256d {
        // SAFETY: as above.
        unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn select(m: __m256d, a: Self, b: Self) -> Self {
        // SAFETY: as above.
        unsafe { F64x4(_mm256_blendv_pd(b.0, a.0, m)) }
    }
}

#[inline(always)]
fn lanes_of(x: __m256d) -> [f64; 4] {
    let mut a = [0.0; 4];
    // SAFETY: as above; unaligned store into four f64.
    unsafe { _mm256_storeu_pd(a.as_mut_ptr(), x) };
    a
}

/// Lanes of several contacts: what the fused pass needs beyond [`Real`].
pub(super) trait Lanes: Real {
    /// Number of lanes (a multiple of 8).
    const N: usize;
    /// One f64, u32 or row per lane (`[T; N]`).
    type F: Array<f64>;
    type U: Array<u32>;
    type R: Array<__m256d>;
    /// Rows of `n` (1, 2 or 3) consecutive f64 at `base + off[l]`, one vector per component.
    ///
    /// # Safety
    /// Every row lies in one allocation (`base` itself may point outside it); AVX2 is available.
    unsafe fn rows(base: *const f64, n: usize, off: &Self::U) -> [Self; 3];
    /// The `n` (≤ N) consecutive f64 at `p` in the first lanes, zero in the others (nothing
    /// past them is read).
    ///
    /// # Safety
    /// The `n` values are readable; AVX2 is available.
    unsafe fn first(p: *const f64, n: usize) -> Self;
    /// The lanes.
    fn array(self) -> Self::F;
    /// Bit l set when lane l of `m` is true.
    fn bits(m: Self::Mask) -> u32;
    /// `!(self ≥ o)`: true for NaN.
    fn nge(self, o: Self) -> Self::Mask;
    /// Whether [`Lanes::rows3`] is available: 3D results go back as rows with masked vector
    /// loads and stores (AVX-512 VL) instead of element by element.
    const ROWS: bool = false;
    /// The lanes of the components (x, y, z) as rows (x, y, z, 0), lane l in row l. Only called
    /// when [`Lanes::ROWS`].
    ///
    /// # Safety
    /// What the lane type needs is available.
    unsafe fn rows3(_c: [Self; 3]) -> Self::R {
        unreachable!("rows3 without ROWS")
    }
}

/// One value per lane of a group: `[T; N]`.
pub(super) trait Array<T: Copy>: Copy + AsRef<[T]> + AsMut<[T]> + std::ops::Index<usize, Output = T> + std::ops::IndexMut<usize> {
    /// Every lane `x`.
    fn filled(x: T) -> Self;
}

impl<T: Copy, const M: usize> Array<T> for [T; M] {
    #[inline(always)]
    fn filled(x: T) -> Self {
        [x; M]
    }
}

/// The three f64 at `p` as (x, y, z, 0) (the fourth element is not read): a two-element and a
/// one-element load, so that both can be forwarded from the stores of [`store3`] (a masked
/// vector store is not forwarded to a later load of the same row on the processors measured,
/// and a grain's row is often stored and loaded again a few pairs apart).
///
/// # Safety
/// `p..p + 3` is readable; AVX2 is available.
#[inline(always)]
unsafe fn load3(p: *const f64) -> __m256d {
    // SAFETY: the caller's contract.
    unsafe { _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(_mm_loadu_pd(p)), _mm_load_sd(p.add(2))) }
}

/// Stores x, y, z of `r` at `p` (the fourth element is not written), as a two-element and a
/// one-element store (see [`load3`]).
///
/// # Safety
/// `p..p + 3` is writable; AVX2 is available.
#[inline(always)]
unsafe fn store3(p: *mut f64, r: __m256d) {
    // SAFETY: the caller's contract.
    unsafe {
        _mm_storeu_pd(p, _mm256_castpd256_pd128(r));
        _mm_store_sd(p.add(2), _mm256_extractf128_pd::<1>(r));
    }
}

/// Eight lanes `8h..8h + 8` of a group's array.
#[inline(always)]
fn half<T: Copy, A: Array<T>>(a: &A, h: usize) -> &[T; 8] {
    a.as_ref()[8 * h..8 * h + 8].try_into().unwrap()
}

/// What [`F64x8`] needs of its halves beyond [`Real`].
impl F64x4 {
    /// Bit l set when lane l of `m` is true.
    #[inline(always)]
    fn bits(m: __m256d) -> u32 {
        // SAFETY: only used in code compiled with AVX2.
        unsafe { _mm256_movemask_pd(m) as u32 }
    }
    /// `!(self ≥ o)`.
    #[inline(always)]
    fn nge(self, o: Self) -> __m256d {
        // SAFETY: as above.
        unsafe { _mm256_cmp_pd::<_CMP_NGE_UQ>(self.0, o.0) }
    }
}

/// Two lane vectors side by side: two groups of contacts evaluated together, so that the long
/// dependency chains of the law (square roots, divisions) of the two overlap. Every operation
/// is that of the halves.
#[derive(Clone, Copy)]
pub(super) struct Pair<H>(H, H);

/// Eight f64 lanes as two [`F64x4`] (AVX2).
pub(super) type F64x8 = Pair<F64x4>;

/// Sixteen f64 lanes as two [`Wide8`] (AVX-512).
pub(super) type Wide16 = Pair<Wide8>;

macro_rules! binary_pair {
    ($trait:ident, $f:ident) => {
        impl<H: Real> $trait for Pair<H> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                Pair(self.0.$f(o.0), self.1.$f(o.1))
            }
        }
    };
}
binary_pair!(Add, add);
binary_pair!(Sub, sub);
binary_pair!(Mul, mul);
binary_pair!(Div, div);

impl<H: Real> Neg for Pair<H> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Pair(-self.0, -self.1)
    }
}

impl<H: Real> Real for Pair<H> {
    type Mask = (H::Mask, H::Mask);
    const LANES: usize = 2 * H::LANES;
    #[inline(always)]
    fn from_fn(mut f: impl FnMut(usize) -> f64) -> Self {
        let a = H::from_fn(&mut f);
        Pair(a, H::from_fn(|l| f(H::LANES + l)))
    }
    #[inline(always)]
    fn for_each_lane(self, mut f: impl FnMut(usize, f64)) {
        self.0.for_each_lane(&mut f);
        self.1.for_each_lane(|l, x| f(H::LANES + l, x));
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Pair(H::splat(x), H::splat(x))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Pair(self.0.sqrt(), self.1.sqrt())
    }
    #[inline(always)]
    fn max_zero(self) -> Self {
        Pair(self.0.max_zero(), self.1.max_zero())
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        Pair(self.0.min(o.0), self.1.min(o.1))
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        Pair(self.0.max(o.0), self.1.max(o.1))
    }
    #[inline(always)]
    fn eq(self, o: Self) -> Self::Mask {
        (self.0.eq(o.0), self.1.eq(o.1))
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self::Mask {
        (self.0.gt(o.0), self.1.gt(o.1))
    }
    #[inline(always)]
    fn select(m: Self::Mask, a: Self, b: Self) -> Self {
        Pair(H::select(m.0, a.0, b.0), H::select(m.1, a.1, b.1))
    }
}

impl Lanes for F64x8 {
    const N: usize = 8;
    type F = [f64; 8];
    type U = [u32; 8];
    type R = [__m256d; 8];
    #[inline(always)]
    unsafe fn rows(base: *const f64, n: usize, off: &[u32; 8]) -> [Self; 3] {
        // SAFETY: the caller's contract.
        unsafe {
            let a = rows(base, n, [off[0], off[1], off[2], off[3]]);
            let b = rows(base, n, [off[4], off[5], off[6], off[7]]);
            [Pair(F64x4(a[0]), F64x4(b[0])), Pair(F64x4(a[1]), F64x4(b[1])), Pair(F64x4(a[2]), F64x4(b[2]))]
        }
    }
    #[inline(always)]
    unsafe fn first(p: *const f64, n: usize) -> Self {
        // SAFETY: the caller's contract; masked-off elements are not read.
        unsafe {
            let lane = _mm256_setr_epi64x(0, 1, 2, 3);
            let live = |h: i64| _mm256_cmpgt_epi64(_mm256_set1_epi64x(n as i64 - h), lane);
            Pair(F64x4(_mm256_maskload_pd(p, live(0))), F64x4(_mm256_maskload_pd(p.wrapping_add(4), live(4))))
        }
    }
    #[inline(always)]
    fn array(self) -> [f64; 8] {
        let (a, b) = (lanes_of(self.0 .0), lanes_of(self.1 .0));
        [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]]
    }
    #[inline(always)]
    fn bits(m: Self::Mask) -> u32 {
        F64x4::bits(m.0) | F64x4::bits(m.1) << 4
    }
    #[inline(always)]
    fn nge(self, o: Self) -> Self::Mask {
        (self.0.nge(o.0), self.1.nge(o.1))
    }
}

/// [`Lanes::rows`] for eight lanes of 512 bits ([`super::window512::rows_at`]).
///
/// # Safety
/// As [`Lanes::rows`]; AVX-512 F and VL are available.
#[inline(always)]
unsafe fn wide_rows(base: *const f64, n: usize, off: &[u32; 8]) -> [Wide8; 3] {
    // SAFETY: the caller's contract.
    unsafe { super::window512::rows_at(n, |l| base.wrapping_add(off[l] as usize)).map(Wide8) }
}

impl Lanes for Wide8 {
    const N: usize = 8;
    type F = [f64; 8];
    type U = [u32; 8];
    type R = [__m256d; 8];
    #[inline(always)]
    unsafe fn rows(base: *const f64, n: usize, off: &[u32; 8]) -> [Self; 3] {
        // SAFETY: the caller's contract.
        unsafe { wide_rows(base, n, off) }
    }
    #[inline(always)]
    unsafe fn first(p: *const f64, n: usize) -> Self {
        // SAFETY: the caller's contract; masked-off elements are not read.
        unsafe { Wide8(_mm512_maskz_loadu_pd(crate::simd512::first_lanes(n), p)) }
    }
    #[inline(always)]
    fn array(self) -> [f64; 8] {
        self.lanes()
    }
    #[inline(always)]
    fn bits(m: __mmask8) -> u32 {
        m as u32
    }
    #[inline(always)]
    fn nge(self, o: Self) -> __mmask8 {
        // SAFETY: as above.
        unsafe { _mm512_cmp_pd_mask::<_CMP_NGE_UQ>(self.0, o.0) }
    }
    const ROWS: bool = true;
    #[inline(always)]
    unsafe fn rows3(c: [Self; 3]) -> [__m256d; 8] {
        // SAFETY: the caller's contract (AVX-512 F).
        unsafe {
            let (x, y, z) = (c[0].0, c[1].0, c[2].0);
            // (x_l, y_l) and (z_l, 0) pairs of even and odd lanes
            let xy_even = _mm512_unpacklo_pd(x, y);
            let xy_odd = _mm512_unpackhi_pd(x, y);
            let z_even = _mm512_unpacklo_pd(z, _mm512_setzero_pd());
            let z_odd = _mm512_unpackhi_pd(z, _mm512_setzero_pd());
            let lo = _mm512_setr_epi64(0, 1, 8, 9, 2, 3, 10, 11);
            let hi = _mm512_setr_epi64(4, 5, 12, 13, 6, 7, 14, 15);
            // rows 0 and 2, 4 and 6, 1 and 3, 5 and 7
            let r02 = _mm512_permutex2var_pd(xy_even, lo, z_even);
            let r46 = _mm512_permutex2var_pd(xy_even, hi, z_even);
            let r13 = _mm512_permutex2var_pd(xy_odd, lo, z_odd);
            let r57 = _mm512_permutex2var_pd(xy_odd, hi, z_odd);
            let (a, b) = (_mm512_castpd512_pd256, |v| _mm512_extractf64x4_pd::<1>(v));
            [a(r02), a(r13), b(r02), b(r13), a(r46), a(r57), b(r46), b(r57)]
        }
    }
}

impl Lanes for Wide16 {
    const N: usize = 16;
    type F = [f64; 16];
    type U = [u32; 16];
    type R = [__m256d; 16];
    #[inline(always)]
    unsafe fn rows(base: *const f64, n: usize, off: &[u32; 16]) -> [Self; 3] {
        // SAFETY: the caller's contract.
        unsafe {
            let (a, b) = (wide_rows(base, n, half(off, 0)), wide_rows(base, n, half(off, 1)));
            [Pair(a[0], b[0]), Pair(a[1], b[1]), Pair(a[2], b[2])]
        }
    }
    #[inline(always)]
    unsafe fn first(p: *const f64, n: usize) -> Self {
        // SAFETY: the caller's contract.
        unsafe { Pair(Wide8::first(p, n), Wide8::first(p.wrapping_add(8), n.saturating_sub(8))) }
    }
    #[inline(always)]
    fn array(self) -> [f64; 16] {
        let mut a = [0.0; 16];
        // SAFETY: as for `Wide8`; unaligned stores into sixteen f64.
        unsafe {
            _mm512_storeu_pd(a.as_mut_ptr(), self.0 .0);
            _mm512_storeu_pd(a.as_mut_ptr().add(8), self.1 .0);
        }
        a
    }
    #[inline(always)]
    fn bits(m: Self::Mask) -> u32 {
        m.0 as u32 | (m.1 as u32) << 8
    }
    #[inline(always)]
    fn nge(self, o: Self) -> Self::Mask {
        (self.0.nge(o.0), self.1.nge(o.1))
    }
    const ROWS: bool = true;
    #[inline(always)]
    unsafe fn rows3(c: [Self; 3]) -> [__m256d; 16] {
        // SAFETY: the caller's contract.
        unsafe {
            let a = Wide8::rows3([c[0].0, c[1].0, c[2].0]);
            let b = Wide8::rows3([c[0].1, c[1].1, c[2].1]);
            let mut r = [a[0]; 16];
            r[..8].copy_from_slice(&a);
            r[8..].copy_from_slice(&b);
            r
        }
    }
}

/// The lanes of the fused pass on processors with AVX-512 F and VL.
type WideLanes = Wide16;

/// Rows of `n` (1, 2 or 3) consecutive f64 at `base + off[l]`, as `n` vectors of four lanes
/// (lane l from the row at `off[l]`): two-element row loads and an unpack, the third component
/// (3D) element by element. Nothing outside the rows is read.
///
/// # Safety
/// Every row lies in one allocation (`base` itself may point outside it); AVX2 is available.
#[inline(always)]
unsafe fn rows(base: *const f64, n: usize, off: [u32; 4]) -> [__m256d; 3] {
    // SAFETY: the caller's contract.
    unsafe {
        let z = _mm256_setzero_pd();
        let at = |l: usize| base.wrapping_add(off[l] as usize);
        if n == 1 {
            return [_mm256_setr_pd(*at(0), *at(1), *at(2), *at(3)), z, z];
        }
        let row = |l: usize| _mm_loadu_pd(at(l));
        let a = _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(row(0)), row(2));
        let b = _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(row(1)), row(3));
        let third = if n == 3 { _mm256_setr_pd(*at(0).add(2), *at(1).add(2), *at(2).add(2), *at(3).add(2)) } else { z };
        [_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b), third]
    }
}

/// Candidate pairs of a group: pair index, first grain, second grain (lanes not looked at: a
/// valid pair and its owner twice), and the lanes looked at (bit l for lane l). Lanes past the
/// lane type's `N` are not used.
struct Group<V: Lanes> {
    pair: V::U,
    i: V::U,
    j: V::U,
    valid: u32,
}

impl<V: Lanes> Group<V> {
    #[inline(always)]
    fn new() -> Self {
        Group { pair: V::U::filled(0), i: V::U::filled(0), j: V::U::filled(0), valid: 0 }
    }

    /// Lanes `8h..8h + 8` from eight-lane vectors and their valid bits.
    #[inline(always)]
    fn set_half(&mut self, h: usize, pair: __m256i, i: __m256i, j: __m256i, valid: u32) {
        self.pair.as_mut()[8 * h..8 * h + 8].copy_from_slice(&u32s(pair));
        self.i.as_mut()[8 * h..8 * h + 8].copy_from_slice(&u32s(i));
        self.j.as_mut()[8 * h..8 * h + 8].copy_from_slice(&u32s(j));
        self.valid |= valid << (8 * h);
    }
}

/// `x` as eight u32 lanes.
#[inline(always)]
fn u32s(x: __m256i) -> [u32; 8] {
    let mut a = [0u32; 8];
    // SAFETY: only used in code compiled with AVX2; unaligned store into eight u32.
    unsafe { _mm256_storeu_si256(a.as_mut_ptr() as *mut __m256i, x) };
    a
}

/// Eight u32 lanes of `a`.
#[inline(always)]
fn load_u32s(a: &[u32; 8]) -> __m256i {
    // SAFETY: only used in code compiled with AVX2; unaligned load of eight u32.
    unsafe { _mm256_loadu_si256(a.as_ptr() as *const __m256i) }
}

/// n·x lane by lane (n = 1, 2 or 3; indices are far below 2³² / 3).
#[inline(always)]
fn times(x: __m256i, n: usize) -> [u32; 8] {
    // SAFETY: only used in code compiled with AVX2.
    unsafe {
        u32s(match n {
            1 => x,
            2 => _mm256_add_epi32(x, x),
            _ => _mm256_add_epi32(_mm256_add_epi32(x, x), x),
        })
    }
}

/// Forces and torques of a group, lane by lane (meaningful on the touching lanes only).
struct Out<V> {
    touch: u32,
    force: [V; 3],
    torque_i: [V; 3],
    torque_j: [V; 3],
}

impl<V: Lanes> Out<V> {
    fn new() -> Self {
        let z = V::splat(0.0);
        Out { touch: 0, force: [z; 3], torque_i: [z; 3], torque_j: [z; 3] }
    }
}

/// Lane `l` of component arrays as a vector.
#[inline(always)]
fn lane_of<T: VectorOps, A: Array<f64>>(a: &[A; 3], l: usize) -> T {
    let mut v = T::ZERO;
    for c in 0..T::LEN {
        v.set(c, a[c][l]);
    }
    v
}

/// The lanes of `v` as component arrays.
#[inline(always)]
fn arrays<V: Lanes>(v: &[V; 3], n: usize) -> [V::F; 3] {
    let mut a = [V::F::filled(0.0); 3];
    for c in 0..n {
        a[c] = v[c].array();
    }
    a
}

/// Looks at the pairs of `g` as [`super::push_pair`] does one by one, then evaluates and records
/// the touching ones as [`super::eval_window`] does: histories stored, opened contacts
/// forgotten, statistics counted in pair order. Returns false when no lane touches (`out` is
/// then untouched).
///
/// # Safety
/// The pairs belong to `h`; their grains index `inp.pos`; the grains looked at lie in `v` (from
/// `v.base`); AVX2 is available.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn eval_group<D: Dim, L: WindowLaw, P: Dampers, V: Lanes>(law: &L, damp: P, inp: &Inputs<D>, h: &mut History<D, L::Extra>, v: Velocities<D>, g: &Group<V>, known: Option<[V; 3]>, st: &mut ForceStats, out: &mut Out<V>) -> bool {
    let (dd, rot) = (D::D, <D::AngVector as VectorOps>::LEN);
    // SAFETY: the caller's contract.
    unsafe {
        debug_assert!(g.pair.as_ref().iter().all(|&p| p as usize >= h.base && p as usize - h.base < h.overlap.len()));
        // history index, and row offsets of vectors (f64 units)
        let z = V::U::filled(0);
        let (mut q, mut qd, mut oi, mut oj) = (z, z, z, z);
        for hf in 0..V::N / 8 {
            let r = 8 * hf..8 * hf + 8;
            let qv = _mm256_sub_epi32(load_u32s(half(&g.pair, hf)), _mm256_set1_epi32(h.base as i32));
            q.as_mut()[r.clone()].copy_from_slice(&u32s(qv));
            qd.as_mut()[r.clone()].copy_from_slice(&times(qv, dd));
            oi.as_mut()[r.clone()].copy_from_slice(&times(load_u32s(half(&g.i, hf)), dd));
            oj.as_mut()[r].copy_from_slice(&times(load_u32s(half(&g.j, hf)), dd));
        }
        let pos = inp.pos.as_ptr() as *const f64;
        let (xi, xj) = (V::rows(pos, dd, &oi), V::rows(pos, dd, &oj));
        // radii (and below the reduced mass) from the close list when it has them
        let (ri, rj) = match known {
            Some(k) => (k[0], k[1]),
            None => (V::rows(inp.radius.as_ptr(), 1, &g.i)[0], V::rows(inp.radius.as_ptr(), 1, &g.j)[0]),
        };
        // nearest-image vector and, in a shearing cell, the velocity of the image (the domain's
        // `PeriodicImage::displacement_velocity_lanes`)
        let image = &inp.image;
        let zero = V::splat(0.0);
        let mut d = [zero; 3];
        for c in 0..dd {
            d[c] = xj[c] - xi[c];
        }
        let (d, dv) = image.displacement_velocity_lanes(d);
        // |r|² in the order of `VectorOps::dot`
        let mut dist2 = d[0] * d[0] + d[1] * d[1];
        if dd == 3 {
            dist2 = dist2 + d[2] * d[2];
        }
        let sum = ri + rj;
        // touching: !(d² ≥ sum²), true for NaN as in the scalar test
        let touch = V::bits(dist2.nge(sum * sum)) & g.valid;
        let old = V::rows(h.overlap.as_ptr(), 1, &q)[0];
        let held = V::bits(old.gt(zero));
        let mut opened = g.valid & !touch & held;
        while opened != 0 {
            h.forget(q[opened.trailing_zeros() as usize] as usize, st);
            opened &= opened - 1;
        }
        if touch == 0 {
            return false;
        }
        // the velocity arrays start at grain v.base: index them by grain
        let vel = (v.vel.as_ptr() as *const f64).wrapping_sub(v.base * dd);
        let omega = (v.omega.as_ptr() as *const f64).wrapping_sub(v.base * rot);
        let (vi, vj) = (V::rows(vel, dd, &oi), V::rows(vel, dd, &oj));
        let mut v_rel = [zero; 3];
        for c in 0..dd {
            // the image of j moves with the cell in a shearing cell
            let vj = if image.sheared { vj[c] + dv[c] } else { vj[c] };
            v_rel[c] = vj - vi[c];
        }
        let input = ContactIn {
            r: d,
            dist2,
            v_rel,
            w_i: V::rows(omega, rot, if rot == dd { &oi } else { &g.i }),
            w_j: V::rows(omega, rot, if rot == dd { &oj } else { &g.j }),
            rad_i: ri,
            rad_j: rj,
            mass_i: if known.is_some() { zero } else { V::rows(inp.mass.as_ptr(), 1, &g.i)[0] },
            mass_j: if known.is_some() { zero } else { V::rows(inp.mass.as_ptr(), 1, &g.j)[0] },
            m_eff: known.map(|k| k[2]),
            spring: V::rows(h.spring.as_ptr() as *const f64, dd, &qd),
            rolling: if law.rolls() { V::rows(h.rolling.as_ptr() as *const f64, rot, if rot == dd { &qd } else { &q }) } else { [zero; 3] },
        };
        // the law's own histories, beside the springs (nothing for `()`: `at` is not called)
        let mut extra = L::Extra::gather::<V>(|l| {
            let k = q[l] as usize;
            debug_assert!(k < h.extra.len());
            *h.extra.get_unchecked(k)
        });
        let o = match dd {
            2 => lanes::contact::<V, 2, 1, L, P>(law, damp, &input, &mut extra, inp.dt),
            _ => lanes::contact::<V, 3, 3, L, P>(law, damp, &input, &mut extra, inp.dt),
        };
        out.touch = touch;
        out.force = o.force;
        out.torque_i = o.torque_i;
        out.torque_j = o.torque_j;
        // histories and statistics, in pair order (as `eval_window`, `eval_pair`)
        let overlap = o.overlap.array();
        let sliding = V::bits(o.sliding);
        let mut bits = touch;
        if V::ROWS && dd == 3 {
            // a row store per history (3D vectors are three consecutive f64)
            let spring = V::rows3(o.new_spring);
            let sp = h.spring.as_mut_ptr() as *mut f64;
            while bits != 0 {
                let l = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let k = q[l] as usize;
                debug_assert!(k < h.spring.len());
                store3(sp.add(3 * k), spring[l]);
                *h.overlap.get_unchecked_mut(k) = overlap[l];
                *h.sliding.get_unchecked_mut(k) = sliding >> l & 1 != 0;
            }
        } else {
            let spring = arrays(&o.new_spring, dd);
            while bits != 0 {
                let l = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let k = q[l] as usize;
                *h.spring.get_unchecked_mut(k) = TangentialHistory(lane_of(&spring, l));
                *h.overlap.get_unchecked_mut(k) = overlap[l];
                *h.sliding.get_unchecked_mut(k) = sliding >> l & 1 != 0;
            }
        }
        if law.rolls() {
            let rolling = arrays(&o.new_rolling, rot);
            let mut bits = touch;
            while bits != 0 {
                let l = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                *h.rolling.get_unchecked_mut(q[l] as usize) = lane_of(&rolling, l);
            }
        }
        // the touching lanes' histories back, in lane (list) order (nothing for `()`)
        L::Extra::scatter::<V>(extra, |l, x| {
            if touch >> l & 1 != 0 {
                let k = q[l] as usize;
                debug_assert!(k < h.extra.len());
                *h.extra.get_unchecked_mut(k) = x;
            }
        });
        // Deepest contact (as `eval_pair`: overlap / smaller radius, the first pair reaching a
        // new maximum). The division only where it may exceed the maximum so far d: for
        // positive o, m and d, fl(o/m) > d implies o > d·m·(1 − ε) > fl(fl(d·m)·(1 − 4ε)), so
        // the lanes failing `o > fl(fl(d·m)·(1 − 4ε))` cannot be deeper (NaN fails both tests).
        let smaller = ri.min(rj);
        let bound = smaller * V::splat(st.deepest.0) * V::splat(1.0 - 4.0 * f64::EPSILON);
        let mut deeper = V::bits(o.overlap.gt(bound)) & touch;
        if deeper != 0 {
            let ratio = (o.overlap / smaller).array();
            while deeper != 0 {
                let l = deeper.trailing_zeros() as usize;
                deeper &= deeper - 1;
                if ratio[l] > st.deepest.0 {
                    st.deepest = (ratio[l], 0, g.pair[l] as usize);
                }
            }
        }
        st.changes += (touch & !held).count_ones() as u64;
        st.contacts += touch.count_ones() as u64;
        st.sliding += (touch & sliding).count_ones() as u64;
        true
    }
}

/// Phase B for block `b` with the fused kernel: the block's pairs a group at a time across
/// owners (its cross-block pairs left out), each group's forces added to both grains in list
/// order; a grain is complete once all its intra-block pairs have been added (pairs where it is
/// the partner come earlier in the list).
///
/// # Safety
/// AVX2 is available.
#[target_feature(enable = "avx2,popcnt")]
#[allow(clippy::too_many_arguments)]
unsafe fn block<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, inp: &Inputs<D>, cross: &CrossIndex<D>, fin: &Finish<D>, b: usize, h: History<D, L::Extra>, g: Grain<D>) -> ForceStats {
    // SAFETY: AVX2 is enabled here (the caller's contract).
    unsafe {
        if cross.close_ok {
            return block_close::<D, L, P>(law, damp, inp, cross, fin, b, h, g);
        }
        block_plain::<D, L, P, F64x8>(law, damp, inp, cross, fin, b, h, g)
    }
}

/// [`block`] on 512-bit lanes ([`WideLanes`]).
///
/// # Safety
/// AVX-512 F and VL are available.
#[target_feature(enable = "avx2,avx512f,avx512vl,popcnt")]
#[allow(clippy::too_many_arguments)]
unsafe fn block_wide<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, inp: &Inputs<D>, cross: &CrossIndex<D>, fin: &Finish<D>, b: usize, h: History<D, L::Extra>, g: Grain<D>) -> ForceStats {
    // SAFETY: AVX-512 F and VL are enabled here (the caller's contract).
    unsafe {
        if cross.close_ok {
            return block_close_wide::<D, L, P>(law, damp, inp, cross, fin, b, h, g);
        }
        block_plain::<D, L, P, WideLanes>(law, damp, inp, cross, fin, b, h, g)
    }
}

/// The eight lanes `8 hf..8 hf + 8` of a group of `n` entries: their indices within the eight
/// (0..8) and the mask of those that hold an entry (lane `8 hf + l < n`), for the masked loads
/// of [`load_masked`] and [`load_live`].
///
/// # Safety
/// AVX2 is available.
#[inline(always)]
unsafe fn live_half(n: usize, hf: usize) -> (__m256i, __m256i) {
    // SAFETY: AVX2 is available (the caller's contract).
    unsafe {
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        (lane, _mm256_cmpgt_epi32(_mm256_set1_epi32(n as i32 - 8 * hf as i32), lane))
    }
}

/// The eight entries `a[s..s + 8]` where `live` ([`live_half`]) is set, zero elsewhere; the
/// entries outside `live` are not read (masked load), so `a` may end before `s + 8`.
///
/// # Safety
/// AVX2 is available; every entry where `live` is set exists.
#[inline(always)]
unsafe fn load_masked(a: &[u32], s: usize, live: __m256i) -> __m256i {
    // SAFETY: the caller's contract.
    unsafe { _mm256_maskload_epi32(a.as_ptr().wrapping_add(s) as *const i32, live) }
}

/// [`load_masked`] with `fallback`'s lanes where `live` is not set.
///
/// # Safety
/// As [`load_masked`].
#[inline(always)]
unsafe fn load_live(a: &[u32], s: usize, live: __m256i, fallback: __m256i) -> __m256i {
    // SAFETY: the caller's contract.
    unsafe { _mm256_blendv_epi8(fallback, load_masked(a, s, live), live) }
}

/// The body of [`block`] for lanes `V` (the list's pairs a group at a time).
///
/// # Safety
/// AVX2 and what `V` needs are available.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn block_plain<D: Dim, L: WindowLaw, P: Dampers, V: Lanes>(law: &L, damp: P, inp: &Inputs<D>, cross: &CrossIndex<D>, fin: &Finish<D>, b: usize, mut h: History<D, L::Extra>, g: Grain<D>) -> ForceStats {
    let mut st = ForceStats::new();
    let (g0, g1) = (b * cross.block_len, ((b + 1) * cross.block_len).min(cross.n));
    let Grain { force, torque, vel, omega, .. } = g;
    start_block(cross, g0, g1, force, torque);
    let mut load = fin.loads.partition_point(|l| l.0 < g0);
    let mut done = g0;
    let (mut p, e) = (inp.owner_start[g0] as usize, inp.owner_start[g1] as usize);
    let mut out = Out::new();
    while p < e {
        let n = (e - p).min(V::N);
        // lanes past n: the first pair and its owner; partners of the next blocks: not looked at
        let mut gr = Group::new();
        // eight lanes at a time
        for hf in 0..V::N / 8 {
            let s = p + 8 * hf;
            // SAFETY: AVX2 is enabled here; the masked loads read the pairs p..p + n only.
            unsafe {
                let (lane, live) = live_half(n, hf);
                let i = load_live(&cross.owner, s, live, _mm256_set1_epi32(cross.owner[p] as i32));
                let j = load_masked(inp.partner, s, live);
                // grain indices are below 2³¹ (i32 comparison)
                let inside = _mm256_and_si256(live, _mm256_cmpgt_epi32(_mm256_set1_epi32(g1 as i32), j));
                let j = _mm256_blendv_epi8(i, j, inside);
                let pair = _mm256_blendv_epi8(_mm256_set1_epi32(p as i32), _mm256_add_epi32(_mm256_set1_epi32(s as i32), lane), live);
                gr.set_half(hf, pair, i, j, _mm256_movemask_ps(_mm256_castsi256_ps(inside)) as u32);
            }
        }
        // SAFETY: the block's pairs are pairs of `h` with owners in the block; intra-block
        // partners lie in the block (cross index); AVX2 is enabled here.
        let touching = unsafe { eval_group::<D, L, P, V>(law, damp, inp, &mut h, Velocities { base: g0, vel: &*vel, omega: &*omega }, &gr, None, &mut st, &mut out) };
        if touching {
            add_group::<D, V>(&out, &gr.i, &gr.j, g0, force, torque);
        }
        p += n;
        while done < g1 && cross.cross_begin[done] as usize <= p {
            finish_grain(inp, cross, fin, done, g0, force, torque, vel, omega, &mut load, &mut st);
            done += 1;
        }
    }
    while done < g1 {
        finish_grain(inp, cross, fin, done, g0, force, torque, vel, omega, &mut load, &mut st);
        done += 1;
    }
    st
}

/// [`block`] through the close list (see `super`, "Close list"): its groups are taken from the
/// block's close list instead of consecutive pairs of the neighbor list, a grain is completed
/// once the next pair of the close list lies past its intra-block pairs; the same bits. A
/// function of its own (not inlined) so that the code of [`block`] is not changed by it.
///
/// # Safety
/// AVX2 is available.
#[target_feature(enable = "avx2,popcnt")]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
unsafe fn block_close<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, inp: &Inputs<D>, cross: &CrossIndex<D>, fin: &Finish<D>, b: usize, h: History<D, L::Extra>, g: Grain<D>) -> ForceStats {
    // SAFETY: AVX2 is enabled here (the caller's contract).
    unsafe { block_close_impl::<D, L, P, F64x8>(law, damp, inp, cross, fin, b, h, g) }
}

/// [`block_close`] on 512-bit lanes ([`Wide8`]).
///
/// # Safety
/// AVX-512 F and VL are available.
#[target_feature(enable = "avx2,avx512f,avx512vl,popcnt")]
#[inline(never)]
#[allow(clippy::too_many_arguments)]
unsafe fn block_close_wide<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, inp: &Inputs<D>, cross: &CrossIndex<D>, fin: &Finish<D>, b: usize, h: History<D, L::Extra>, g: Grain<D>) -> ForceStats {
    // SAFETY: AVX-512 F and VL are enabled here (the caller's contract).
    unsafe { block_close_impl::<D, L, P, WideLanes>(law, damp, inp, cross, fin, b, h, g) }
}

/// Groups ahead whose partners' rows [`block_close_impl`] prefetches.
const PREFETCH_GROUPS: usize = 2;

/// Pairs ahead whose partners' positions and radii [`close_filter_wide`] prefetches.
const FILTER_AHEAD: usize = 32;

/// The body of [`block_close`] for lanes `V`.
///
/// # Safety
/// AVX2 and what `V` needs are available.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn block_close_impl<D: Dim, L: WindowLaw, P: Dampers, V: Lanes>(law: &L, damp: P, inp: &Inputs<D>, cross: &CrossIndex<D>, fin: &Finish<D>, b: usize, mut h: History<D, L::Extra>, g: Grain<D>) -> ForceStats {
    let mut st = ForceStats::new();
    let (g0, g1) = (b * cross.block_len, ((b + 1) * cross.block_len).min(cross.n));
    let Grain { force, torque, vel, omega, .. } = g;
    start_block(cross, g0, g1, force, torque);
    let mut load = fin.loads.partition_point(|l| l.0 < g0);
    let mut done = g0;
    let e = inp.owner_start[g1] as usize;
    let mut out = Out::new();
    // The close list: the block's pairs that may touch, in list order (the others touch
    // nobody and hold no contact: skipping them changes no bit).
    let (mut k, ke) = (cross.close_start[b] as usize, cross.close_start[b + 1] as usize);
    while k < ke {
        let n = (ke - k).min(V::N);
        // Prefetch the partners' rows of the group after next: positions, velocities, spins and
        // sums. A partner lies ahead of the owners in memory (i < j), so its row is first
        // touched here; in a packing larger than the cache that is a trip to memory, which the
        // hardware prefetchers (they follow the owners' streams) do not foresee.
        let ahead = k + PREFETCH_GROUPS * V::N;
        if ahead < ke {
            let (pp, vp, wp, fp, tp) = (inp.pos.as_ptr(), vel.as_ptr(), omega.as_ptr(), force.as_ptr(), torque.as_ptr());
            for e in ahead..ahead + (ke - ahead).min(V::N) {
                // SAFETY: e < ke indexes the close list; its partners are grains of the block
                // (the rows prefetched exist; a prefetch changes no state).
                unsafe {
                    let j = *cross.close_partner.get_unchecked(e) as usize;
                    _mm_prefetch::<_MM_HINT_T0>(pp.add(j) as *const i8);
                    _mm_prefetch::<_MM_HINT_T0>(vp.add(j - g0) as *const i8);
                    _mm_prefetch::<_MM_HINT_T0>(wp.add(j - g0) as *const i8);
                    _mm_prefetch::<_MM_HINT_T0>(fp.add(j - g0) as *const i8);
                    _mm_prefetch::<_MM_HINT_T0>(tp.add(j - g0) as *const i8);
                }
            }
        }
        // lanes past n: the first pair and its owner (not looked at)
        let mut gr = Group::new();
        // eight lanes at a time
        for hf in 0..V::N / 8 {
            let s = k + 8 * hf;
            // SAFETY: AVX2 is enabled here; the masked loads read the entries k..k + n only.
            unsafe {
                let (_, live) = live_half(n, hf);
                let pair = load_live(&cross.close_pair, s, live, _mm256_set1_epi32(cross.close_pair[k] as i32));
                let i = load_live(&cross.close_owner, s, live, _mm256_set1_epi32(cross.close_owner[k] as i32));
                let j = load_live(&cross.close_partner, s, live, i);
                gr.set_half(hf, pair, i, j, _mm256_movemask_ps(_mm256_castsi256_ps(live)) as u32);
            }
        }
        // the radii and reduced masses of the group's pairs, consecutive in the close list
        // SAFETY: entries k..k + n exist; AVX2 (and what `V` needs) is enabled here.
        // (three calls, not an array `map`: its closure was not inlined into the AVX2 build)
        let known = unsafe {
            let at = |a: &Vec<f64>| a.as_ptr().wrapping_add(k);
            [V::first(at(&cross.close_rad_i), n), V::first(at(&cross.close_rad_j), n), V::first(at(&cross.close_m_eff), n)]
        };
        // SAFETY: as below (the close list holds intra-block pairs of the block).
        let touching = unsafe { eval_group::<D, L, P, V>(law, damp, inp, &mut h, Velocities { base: g0, vel: &*vel, omega: &*omega }, &gr, Some(known), &mut st, &mut out) };
        if touching {
            add_group::<D, V>(&out, &gr.i, &gr.j, g0, force, torque);
        }
        k += n;
        // every pair before `next` is added now
        let next = if k < ke { cross.close_pair[k] as usize } else { e };
        while done < g1 && cross.cross_begin[done] as usize <= next {
            finish_grain(inp, cross, fin, done, g0, force, torque, vel, omega, &mut load, &mut st);
            done += 1;
        }
    }
    while done < g1 {
        finish_grain(inp, cross, fin, done, g0, force, torque, vel, omega, &mut load, &mut st);
        done += 1;
    }
    st
}

/// Adds the forces and torques of a group's touching lanes to both grains, in lane (list) order.
#[inline(always)]
fn add_group<D: Dim, V: Lanes>(out: &Out<V>, gi: &V::U, gj: &V::U, g0: usize, force: &mut [D::Vector], torque: &mut [D::AngVector]) {
    let rot = <D::AngVector as VectorOps>::LEN;
    let mut bits = out.touch;
    if V::ROWS && D::D == 3 && rot == 3 {
        // Rows and masked vector updates. The owner's sums stay in registers over its lanes
        // of the group: its terms are still added in list order, as nothing else touches it
        // meanwhile (its pairs as a partner, i < j, all come before its own; owners do not
        // decrease along the list).
        // SAFETY: `ROWS` lane types run with AVX-512 F and VL; 3D vectors are three
        // consecutive f64; owners and intra-block partners lie in the block.
        unsafe {
            let (fr, tir, tjr) = (V::rows3(out.force), V::rows3(out.torque_i), V::rows3(out.torque_j));
            let (fp, tp) = (force.as_mut_ptr() as *mut f64, torque.as_mut_ptr() as *mut f64);
            // Branch-free: the owner's running sums stay in registers while the owner does not
            // change; every lane stores them — to the row of the owner it leaves when the owner
            // changes, to a scratch row otherwise — and blends in the row of its own owner when
            // that is a new one. The terms still arrive in list order.
            let mut scratch = [0.0f64; 8];
            let first = out.touch.trailing_zeros() as usize;
            let mut cur = gi[first.min(V::N - 1)] as usize - g0;
            let (mut acc_f, mut acc_t) = (load3(fp.add(3 * cur)), load3(tp.add(3 * cur)));
            while bits != 0 {
                let l = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let (li, lj) = (gi[l] as usize - g0, gj[l] as usize - g0);
                debug_assert!(li < force.len() && lj < force.len() && li != lj);
                let moved = li != cur;
                let (df, dt) = if moved { (fp.add(3 * cur), tp.add(3 * cur)) } else { (scratch.as_mut_ptr(), scratch.as_mut_ptr().add(4)) };
                store3(df, acc_f);
                store3(dt, acc_t);
                let k = (moved as u8).wrapping_neg() & 0xf;
                acc_f = _mm256_add_pd(_mm256_mask_mov_pd(acc_f, k, load3(fp.add(3 * li))), fr[l]);
                acc_t = _mm256_add_pd(_mm256_mask_mov_pd(acc_t, k, load3(tp.add(3 * li))), tir[l]);
                cur = li;
                store3(fp.add(3 * lj), _mm256_sub_pd(load3(fp.add(3 * lj)), fr[l]));
                store3(tp.add(3 * lj), _mm256_add_pd(load3(tp.add(3 * lj)), tjr[l]));
            }
            std::hint::black_box(&scratch);
            store3(fp.add(3 * cur), acc_f);
            store3(tp.add(3 * cur), acc_t);
        }
        return;
    }
    let (f, ti, tj) = (arrays(&out.force, D::D), arrays(&out.torque_i, rot), arrays(&out.torque_j, rot));
    while bits != 0 {
        let l = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let (li, lj) = (gi[l] as usize - g0, gj[l] as usize - g0);
        debug_assert!(li < force.len() && lj < force.len() && li != lj);
        let f: D::Vector = lane_of(&f, l);
        // SAFETY: owners and intra-block partners lie in the block.
        unsafe {
            *force.get_unchecked_mut(li) += f;
            *torque.get_unchecked_mut(li) += lane_of::<D::AngVector, _>(&ti, l);
            *force.get_unchecked_mut(lj) -= f;
            *torque.get_unchecked_mut(lj) += lane_of::<D::AngVector, _>(&tj, l);
        }
    }
}

/// Phase A for block `b` with the fused kernel: the block's cross-block pairs a group at a time
/// through their buffer slots (consecutive), each touching pair's force and torques into its
/// slot (the others were zeroed).
///
/// # Safety
/// AVX2 is available.
#[target_feature(enable = "avx2,popcnt")]
#[allow(clippy::too_many_arguments)]
unsafe fn cross_block<D: Dim, L: WindowLaw, P: Dampers>(p: CrossPass<'_, '_, D, L>, damp: P) -> ForceStats {
    // SAFETY: AVX2 is enabled here (the caller's contract).
    unsafe { cross_block_impl::<D, L, P, F64x8>(p.law, damp, p.inp, p.vel, p.omega, p.cross, p.b, p.h, p.out, p.slot_base) }
}

/// [`cross_block`] on 512-bit lanes ([`Wide8`]).
///
/// # Safety
/// AVX-512 F and VL are available.
#[target_feature(enable = "avx2,avx512f,avx512vl,popcnt")]
unsafe fn cross_block_wide<D: Dim, L: WindowLaw, P: Dampers>(p: CrossPass<'_, '_, D, L>, damp: P) -> ForceStats {
    // SAFETY: AVX-512 F and VL are enabled here (the caller's contract).
    unsafe { cross_block_impl::<D, L, P, WideLanes>(p.law, damp, p.inp, p.vel, p.omega, p.cross, p.b, p.h, p.out, p.slot_base) }
}

/// The body of [`cross_block`] for lanes `V`.
///
/// # Safety
/// AVX2 and what `V` needs are available.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn cross_block_impl<D: Dim, L: WindowLaw, P: Dampers, V: Lanes>(
    law: &L,
    damp: P,
    inp: &Inputs<D>,
    vel: &[D::Vector],
    omega: &[D::AngVector],
    cross: &CrossIndex<D>,
    b: usize,
    mut h: History<D, L::Extra>,
    out: &mut [CrossForce<D>],
    slot_base: usize,
) -> ForceStats {
    let mut st = ForceStats::new();
    let (mut s, e) = (cross.block_slot_start[b] as usize, cross.block_slot_start[b + 1] as usize);
    let mut lanes_out = Out::new();
    while s < e {
        let n = (e - s).min(V::N);
        let p0 = cross.slot_pair[s];
        let i0 = cross.owner[p0 as usize];
        let mut gr = Group::<V> { pair: V::U::filled(p0), i: V::U::filled(i0), j: V::U::filled(i0), valid: (1 << n) - 1 };
        for l in 0..n {
            let p = cross.slot_pair[s + l];
            gr.pair[l] = p;
            gr.i[l] = cross.owner[p as usize];
            gr.j[l] = inp.partner[p as usize];
        }
        // SAFETY: the slots of block b hold pairs of `h` (cross index); whole velocity arrays;
        // AVX2 is enabled here.
        let touching = unsafe { eval_group::<D, L, P, V>(law, damp, inp, &mut h, Velocities { base: 0, vel, omega }, &gr, None, &mut st, &mut lanes_out) };
        if touching {
            let rot = <D::AngVector as VectorOps>::LEN;
            let (f, ti, tj) = (arrays(&lanes_out.force, D::D), arrays(&lanes_out.torque_i, rot), arrays(&lanes_out.torque_j, rot));
            let mut bits = lanes_out.touch;
            while bits != 0 {
                let l = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                out[s + l - slot_base] = CrossForce { force: lane_of(&f, l), torque_i: lane_of(&ti, l), torque_j: lane_of(&tj, l) };
            }
        }
        s += n;
    }
    st
}

/// Phase B of one block through the fused kernel, with the law's dampers resolved.
pub(super) struct BlockPass<'a, 'b, D: Dim, L: LawParts> {
    pub law: &'a L,
    pub inp: &'a Inputs<'b, D>,
    pub cross: &'a CrossIndex<D>,
    pub fin: &'a Finish<'b, D>,
    pub b: usize,
    pub h: History<'a, D, L::Extra>,
    pub g: Grain<'a, D>,
    /// On 512-bit lanes ([`Wide8`]).
    pub wide: bool,
}

impl<D: Dim, L: WindowLaw> WithDampers for BlockPass<'_, '_, D, L> {
    type Out = ForceStats;
    fn run<P: Dampers>(self, damp: P) -> ForceStats {
        // the instructions of this path must exist on this processor (cheap: once per block)
        assert!(available() && (!self.wide || wide_available()), "fused pass chosen without its instruction set");
        // SAFETY: this path is chosen only when the processor has AVX2 (`available`), and
        // with `wide` only when it has AVX-512 F and VL (`wide_available`).
        unsafe {
            if self.wide {
                return block_wide::<D, L, P>(self.law, damp, self.inp, self.cross, self.fin, self.b, self.h, self.g);
            }
            block::<D, L, P>(self.law, damp, self.inp, self.cross, self.fin, self.b, self.h, self.g)
        }
    }
}

/// Phase A of one block through the fused kernel, with the law's dampers resolved.
pub(super) struct CrossPass<'a, 'b, D: Dim, L: LawParts> {
    pub law: &'a L,
    pub inp: &'a Inputs<'b, D>,
    pub vel: &'a [D::Vector],
    pub omega: &'a [D::AngVector],
    pub cross: &'a CrossIndex<D>,
    pub b: usize,
    pub h: History<'a, D, L::Extra>,
    pub out: &'a mut [CrossForce<D>],
    pub slot_base: usize,
    /// On 512-bit lanes ([`Wide8`]).
    pub wide: bool,
}

impl<D: Dim, L: WindowLaw> WithDampers for CrossPass<'_, '_, D, L> {
    type Out = ForceStats;
    fn run<P: Dampers>(self, damp: P) -> ForceStats {
        // the instructions of this path must exist on this processor (cheap: once per block)
        assert!(available() && (!self.wide || wide_available()), "fused pass chosen without its instruction set");
        // SAFETY: as for `BlockPass`.
        unsafe {
            if self.wide {
                return cross_block_wide::<D, L, P>(self, damp);
            }
            cross_block::<D, L, P>(self, damp)
        }
    }
}

/// The close-list filter of one block's intra-block pairs (`CrossIndex::ensure_close`), 3D in a
/// cell that is not sheared, eight pairs at a time on AVX-512: pair p of owner i and partner j
/// (`pairs`, with `owner[p]`, `partner[p]`) is kept when j < `g1` (intra-block) and
/// `!(|d|² ≥ (r_i + r_j + margin)²)` (true for NaN) or it holds a contact (`overlap[p] > 0`),
/// with d the nearest-image vector computed as [`crate::domain::PeriodicImage::displacement`]
/// does; kept pairs are appended in list order. The same decisions as the element-wise filter.
///
/// # Safety
/// Pairs and grains index the slices; `pos` holds three f64 per grain; AVX-512 F and VL are
/// available.
#[target_feature(enable = "avx2,avx512f,avx512vl,popcnt")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn close_filter_wide(
    pos: *const f64,
    radius: &[f64],
    owner: &[u32],
    partner: &[u32],
    overlap: &[f64],
    pairs: std::ops::Range<usize>,
    g1: usize,
    margin: f64,
    period: [f64; 3],
    inverse: [f64; 3],
    out: &mut [Vec<u32>; 3],
) {
    // SAFETY: the caller's contract; masked loads read pairs inside `pairs` only, and the
    // compressing stores write only the kept lanes, into reserved capacity.
    unsafe {
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        for o in out.iter_mut() {
            o.reserve(pairs.len());
        }
        let mut p = pairs.start;
        while p < pairs.end {
            let n = (pairs.end - p).min(8);
            // the partners' positions and radii, FILTER_AHEAD pairs on: this filter is the first
            // to touch them in a step (see `block_close_impl`)
            let ahead = p + FILTER_AHEAD;
            if ahead < pairs.end {
                for e in ahead..ahead + (pairs.end - ahead).min(8) {
                    let j = *partner.get_unchecked(e) as usize;
                    _mm_prefetch::<_MM_HINT_T0>(pos.add(3 * j) as *const i8);
                    _mm_prefetch::<_MM_HINT_T0>(radius.as_ptr().add(j) as *const i8);
                }
            }
            let live = _mm256_cmpgt_epi32_mask(_mm256_set1_epi32(n as i32), lane);
            // lanes past n: the first pair (valid indices), not kept
            let first = _mm256_set1_epi32(p as i32);
            let pv = _mm256_mask_add_epi32(first, live, first, lane);
            let i = _mm256_mask_loadu_epi32(_mm256_set1_epi32(owner[p] as i32), live, owner.as_ptr().add(p) as *const i32);
            let j = _mm256_mask_loadu_epi32(_mm256_set1_epi32(partner[p] as i32), live, partner.as_ptr().add(p) as *const i32);
            let intra = live & _mm256_cmplt_epu32_mask(j, _mm256_set1_epi32(g1 as i32));
            let (il, jl) = (u32s(i), u32s(j));
            let (xi, xj) = (wide_rows(pos, 3, &times(i, 3)), wide_rows(pos, 3, &times(j, 3)));
            let mut d = [xj[0] - xi[0], xj[1] - xi[1], xj[2] - xi[2]];
            // the domain's minimum image along each axis (the cell is not sheared here)
            for c in (0..3).rev() {
                d[c] = nearest_image_axis(d[c], Wide8::splat(period[c]), Wide8::splat(inverse[c])).0;
            }
            let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let ri = Wide8(_mm512_setr_pd(radius[il[0] as usize], radius[il[1] as usize], radius[il[2] as usize], radius[il[3] as usize], radius[il[4] as usize], radius[il[5] as usize], radius[il[6] as usize], radius[il[7] as usize]));
            let rj = Wide8(_mm512_setr_pd(radius[jl[0] as usize], radius[jl[1] as usize], radius[jl[2] as usize], radius[jl[3] as usize], radius[jl[4] as usize], radius[jl[5] as usize], radius[jl[6] as usize], radius[jl[7] as usize]));
            let cut = ri + rj + Wide8::splat(margin);
            let held = _mm512_mask_cmp_pd_mask::<_CMP_GT_OQ>(live, _mm512_maskz_loadu_pd(live, overlap.as_ptr().add(p)), _mm512_setzero_pd());
            let keep = intra & (d2.nge(cut * cut) | held);
            let k = keep.count_ones() as usize;
            if k != 0 {
                for (o, v) in out.iter_mut().zip([pv, i, j]) {
                    let len = o.len();
                    _mm256_mask_compressstoreu_epi32(o.as_mut_ptr().add(len) as *mut i32, keep, v);
                    o.set_len(len + k);
                }
            }
            p += n;
        }
    }
}
