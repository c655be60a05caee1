//! AVX-512 parts of the windowed force pass: finding the touching pairs of an owner eight
//! candidates at a time, then loading the partners' data of a window and storing its histories.
//!
//! Every lane performs exactly the floating-point operations of the scalar path
//! ([`super::push_pair`], [`super::eval_window`]) in the same order — the nearest-image shift by
//! the same 1.5·2⁵² rounding, the squared distance summed x, y, z, the test `!(d² ≥ (rᵢ+rⱼ)²)` —
//! so the window receives the same pairs with the same bits and the run is bitwise that of the
//! scalar path (tested on whole runs, `tests/force_blocks.rs`). Used when the processor has
//! AVX-512 F and VL and the cell is not sheared (the sheared image also shifts velocities; the
//! scalar path handles it).
//!
//! Lane arrays are written eight lanes at a time from `len`: the caller keeps `len + 8 ≤ CAP`
//! before [`push_chunk`]. Lanes at and past `len` hold stale values that the kernel computes and
//! every consumer ignores.

use super::{Body, ForceStats, History, Inputs, Velocities};
use crate::dim::{Dim, VectorOps};
use crate::sim::lanes::{Window, CAP};
use std::arch::x86_64::*;

/// True when the processor has the AVX-512 subsets used here (F and VL).
pub(super) fn available() -> bool {
    std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl")
}

/// The constants of [`crate::domain::nearest_integer`].
const SHIFT: f64 = 6_755_399_441_055_744.0;
const LIMIT: f64 = 2_251_799_813_685_248.0;

/// Mask of the first `n` lanes (n ≤ 8).
#[inline(always)]
fn first(n: usize) -> __mmask8 {
    (0xffu32 >> (8 - n.min(8))) as __mmask8
}

/// Looks at candidate pairs `p0..p1` (at most 8) of owner `i` (`a`), as [`super::push_pair`]
/// does one by one: the touching ones are appended to the window in pair order (geometry, indices
/// and the owner's data; the partner's data comes with [`fill`]), the others forget a history
/// they may still hold.
///
/// # Safety
/// `p0 < p1 ≤ p0 + 8`, `w.len + 8 ≤ CAP`, the pairs belong to `h`, their partners index
/// `inp.pos`, and the cell is not sheared.
#[inline]
#[target_feature(enable = "avx512f,avx512vl,popcnt")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn push_chunk<D: Dim>(w: &mut Window, inp: &Inputs<D>, h: &mut History<D>, a: &Body<D>, i: usize, p0: usize, p1: usize, st: &mut ForceStats) {
    debug_assert!(p0 < p1 && p1 - p0 <= 8 && w.len + 8 <= CAP && !inp.image.sheared);
    debug_assert!(p1 <= inp.partner.len() && p0 >= h.base && p1 - h.base <= h.overlap.len());
    let dd = D::D;
    let m = first(p1 - p0);
    let k = w.len;
    // SAFETY: the caller's contract; the window stores write lanes k..k + 8 ≤ CAP.
    unsafe {
        let j = _mm256_maskz_loadu_epi32(m, inp.partner.as_ptr().add(p0) as *const i32);
        let pos = inp.pos.as_ptr() as *const f64;
        // nearest-image vector, component by component (`PeriodicImage::displacement_velocity`)
        let mut d = [_mm512_setzero_pd(); 3];
        let mut xs = [_mm512_setzero_pd(); 3];
        // partner of each lane (lane 0's partner in the unused lanes)
        let pp = inp.partner.as_ptr().add(p0);
        let n = p1 - p0;
        let mut jl = [0usize; 8];
        for (l, x) in jl.iter_mut().enumerate() {
            *x = *pp.add(if l < n { l } else { 0 }) as usize;
        }
        let r = inp.radius.as_ptr();
        let rj = _mm512_maskz_mov_pd(
            m,
            _mm512_setr_pd(*r.add(jl[0]), *r.add(jl[1]), *r.add(jl[2]), *r.add(jl[3]), *r.add(jl[4]), *r.add(jl[5]), *r.add(jl[6]), *r.add(jl[7])),
        );
        // positions as rows, then a transposition: loads and shuffles are cheaper than gathers
        if dd == 2 {
            let row = |l: usize| _mm_loadu_pd(pos.add(2 * jl[l]));
            let quad = |l: usize| _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(row(l)), row(l + 1));
            let a = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(quad(0)), quad(2));
            let b = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(quad(4)), quad(6));
            xs[0] = _mm512_permutex2var_pd(a, _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), b);
            xs[1] = _mm512_permutex2var_pd(a, _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15), b);
        } else {
            let row = |l: usize| _mm256_maskz_loadu_pd(0b0111, pos.add(3 * jl[l]));
            let a0 = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(row(0)), row(4));
            let a1 = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(row(1)), row(5));
            let a2 = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(row(2)), row(6));
            let a3 = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(row(3)), row(7));
            let t0 = _mm512_unpacklo_pd(a0, a1);
            let t1 = _mm512_unpackhi_pd(a0, a1);
            let t2 = _mm512_unpacklo_pd(a2, a3);
            let t3 = _mm512_unpackhi_pd(a2, a3);
            let lo = _mm512_setr_epi64(0, 1, 8, 9, 4, 5, 12, 13);
            let hi = _mm512_setr_epi64(2, 3, 10, 11, 6, 7, 14, 15);
            xs[0] = _mm512_permutex2var_pd(t0, lo, t2);
            xs[1] = _mm512_permutex2var_pd(t1, lo, t3);
            xs[2] = _mm512_permutex2var_pd(t0, hi, t2);
        }
        for c in 0..dd {
            let xj = xs[c];
            let dk = _mm512_sub_pd(xj, _mm512_set1_pd(a.x.get(c)));
            let t = _mm512_mul_pd(dk, _mm512_set1_pd(inp.image.inverse.get(c)));
            let t = _mm512_min_pd(_mm512_max_pd(t, _mm512_set1_pd(-LIMIT)), _mm512_set1_pd(LIMIT));
            let t = _mm512_sub_pd(_mm512_add_pd(t, _mm512_set1_pd(SHIFT)), _mm512_set1_pd(SHIFT));
            d[c] = _mm512_sub_pd(dk, _mm512_mul_pd(_mm512_set1_pd(inp.image.length.get(c)), t));
        }
        // |r|² in the order of `VectorOps::dot`
        let mut dist2 = _mm512_add_pd(_mm512_mul_pd(d[0], d[0]), _mm512_mul_pd(d[1], d[1]));
        if dd == 3 {
            dist2 = _mm512_add_pd(dist2, _mm512_mul_pd(d[2], d[2]));
        }
        let sum = _mm512_add_pd(_mm512_set1_pd(a.r), rj);
        // touching: !(d² ≥ sum²), true for NaN as in the scalar test
        let touch = _mm512_mask_cmp_pd_mask::<_CMP_NGE_UQ>(m, dist2, _mm512_mul_pd(sum, sum));
        let q0 = p0 - h.base;
        let old = _mm512_maskz_loadu_pd(m, h.overlap.as_ptr().add(q0));
        let mut opened = _mm512_mask_cmp_pd_mask::<_CMP_GT_OQ>(m & !touch, old, _mm512_setzero_pd());
        while opened != 0 {
            h.forget(q0 + opened.trailing_zeros() as usize, st);
            opened &= opened - 1;
        }
        let iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let pair = _mm256_add_epi32(_mm256_set1_epi32(p0 as i32), iota);
        _mm256_storeu_si256(w.pair.as_mut_ptr().add(k) as *mut __m256i, _mm256_maskz_compress_epi32(touch, pair));
        _mm256_storeu_si256(w.i.as_mut_ptr().add(k) as *mut __m256i, _mm256_set1_epi32(i as i32));
        _mm256_storeu_si256(w.j.as_mut_ptr().add(k) as *mut __m256i, _mm256_maskz_compress_epi32(touch, j));
        for c in 0..dd {
            _mm512_storeu_pd(w.r[c].as_mut_ptr().add(k), _mm512_maskz_compress_pd(touch, d[c]));
        }
        _mm512_storeu_pd(w.dist2.as_mut_ptr().add(k), _mm512_maskz_compress_pd(touch, dist2));
        _mm512_storeu_pd(w.rad_j.as_mut_ptr().add(k), _mm512_maskz_compress_pd(touch, rj));
        _mm512_storeu_pd(w.rad_i.as_mut_ptr().add(k), _mm512_set1_pd(a.r));
        _mm512_storeu_pd(w.mass_i.as_mut_ptr().add(k), _mm512_set1_pd(a.m));
        // v_i for now: `fill` turns it into v_j − v_i
        for c in 0..dd {
            _mm512_storeu_pd(w.v_rel[c].as_mut_ptr().add(k), _mm512_set1_pd(a.v.get(c)));
        }
        for c in 0..<D::AngVector as VectorOps>::LEN {
            _mm512_storeu_pd(w.w_i[c].as_mut_ptr().add(k), _mm512_set1_pd(a.w.get(c)));
        }
        w.len = k + touch.count_ones() as usize;
    }
}

/// Completes the inputs of the window's contacts with their partners' data and the stored
/// history: v_j − v_i, ω_j, m_j, the tangential spring and the overlap at the last evaluation
/// (`was`). Scalar loads: gather instructions measured slower on the processor used.
///
/// # Safety
/// The window was filled by [`push_chunk`] with pairs of `h` whose partners lie in `v` (from
/// `v.base`) and index `inp.mass`.
#[inline]
#[target_feature(enable = "avx512f,avx512vl,popcnt")]
pub(super) unsafe fn fill<D: Dim>(w: &mut Window, inp: &Inputs<D>, h: &History<D>, v: Velocities<D>) {
    for k in 0..w.len {
        let (j, q) = (w.j[k] as usize, w.pair[k] as usize - h.base);
        // SAFETY: the caller's contract.
        unsafe {
            let vj = *v.vel.get_unchecked(j - v.base);
            for c in 0..D::D {
                w.v_rel[c][k] = vj.get(c) - w.v_rel[c][k];
            }
            crate::sim::lanes::put(&mut w.w_j, k, *v.omega.get_unchecked(j - v.base));
            w.mass_j[k] = *inp.mass.get_unchecked(j);
            crate::sim::lanes::put(&mut w.spring, k, *h.spring.get_unchecked(q));
            w.was[k] = *h.overlap.get_unchecked(q);
        }
    }
}

/// Stores the new springs and overlaps of the window's contacts into their histories, and counts
/// the contacts that formed (overlap ≤ 0 at the last evaluation), as the scalar loop of
/// [`super::eval_window`].
///
/// # Safety
/// As [`fill`].
#[inline]
#[target_feature(enable = "avx512f,avx512vl,popcnt")]
pub(super) unsafe fn store<D: Dim>(w: &Window, h: &mut History<D>) -> u64 {
    let mut formed = 0;
    for k in 0..w.len {
        let q = w.pair[k] as usize - h.base;
        // SAFETY: the caller's contract.
        unsafe {
            *h.spring.get_unchecked_mut(q) = crate::sim::lanes::get(&w.new_spring, k);
            *h.overlap.get_unchecked_mut(q) = w.overlap[k];
        }
        formed += (w.was[k] <= 0.0) as u64;
    }
    formed
}
