//! AVX-512 parts of the windowed force pass: finding the touching pairs eight candidates at a
//! time (consecutive pairs of the list, across owners) with all the kernel's inputs.
//!
//! Every lane performs exactly the floating-point operations of the scalar path
//! ([`super::push_pair`], [`super::eval_window`]) in the same order — the nearest image by the
//! domain's own lane-generic code (with the tilt and image velocity of a shearing cell), the squared
//! distance summed x, y, z, the test `!(d² ≥ (rᵢ+rⱼ)²)` — so the window receives the same pairs
//! with the same bits and the run is bitwise that of the scalar path (tested on whole runs,
//! `tests/force_blocks.rs`, sheared cells included). Used when the processor has AVX-512 F and
//! VL.
//!
//! Lane arrays are written eight lanes at a time from `len`: the caller keeps `len + 8 ≤ CAP`
//! before [`push_pairs`]. Lanes at and past `len` hold stale values that the kernel computes and
//! every consumer ignores.

use super::{ForceStats, History, Inputs, Velocities};
use crate::contact::LawHistory;
use crate::dim::{Dim, VectorOps};
use crate::simd512::Wide8;
use crate::sim::lanes::{Window, CAP};
use std::arch::x86_64::*;

/// True when the processor has the AVX-512 subsets used here (F and VL).
pub(super) fn available() -> bool {
    std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl")
}

use crate::simd512::first_lanes as first;

/// Mask of the first `n` lanes, `n` clamped to 0..=8.
#[inline(always)]
fn first_clamped(n: isize) -> __mmask8 {
    first(n.clamp(0, 8) as usize)
}

/// The eight lanes of `v` as indices.
#[inline(always)]
fn indices(v: __m256i) -> [usize; 8] {
    let mut a = [0u32; 8];
    // SAFETY: `a` holds eight u32; the store is unaligned.
    unsafe { _mm256_storeu_si256(a.as_mut_ptr() as *mut __m256i, v) };
    a.map(|x| x as usize)
}

/// Rows of `n` (1, 2 or 3) consecutive f64 at `base + n·idx[l]`, as `n` vectors of eight lanes
/// (lane l from row `idx[l]`).
///
/// # Safety
/// Every row lies in one allocation starting at `base`.
#[inline]
#[target_feature(enable = "avx512f,avx512vl")]
unsafe fn rows(base: *const f64, n: usize, idx: &[usize; 8]) -> [__m512d; 3] {
    // SAFETY: the caller's contract.
    unsafe { rows_at(n, |l| base.add(n * idx[l])) }
}

/// Rows of `n` (1, 2 or 3) consecutive f64 at `at(l)`, as `n` vectors of eight lanes (lane l
/// from the row at `at(l)`): row loads (three elements masked: nothing past a row is read) and a
/// transposition, cheaper than gathers. Shared with the fused pass's 512-bit lanes.
///
/// # Safety
/// Every row is readable; AVX-512 F and VL are available (the caller is compiled with them).
#[inline(always)]
pub(super) unsafe fn rows_at(n: usize, at: impl Fn(usize) -> *const f64) -> [__m512d; 3] {
    let mut out = [_mm512_setzero_pd(); 3];
    // SAFETY: the caller's contract; masked-off elements are not read.
    unsafe {
        match n {
            1 => {
                let g = |l: usize| *at(l);
                out[0] = _mm512_setr_pd(g(0), g(1), g(2), g(3), g(4), g(5), g(6), g(7));
            }
            2 => {
                let row = |l: usize| _mm_loadu_pd(at(l));
                let quad = |l: usize| _mm256_insertf128_pd::<1>(_mm256_castpd128_pd256(row(l)), row(l + 1));
                let a = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(quad(0)), quad(2));
                let b = _mm512_insertf64x4::<1>(_mm512_castpd256_pd512(quad(4)), quad(6));
                out[0] = _mm512_permutex2var_pd(a, _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), b);
                out[1] = _mm512_permutex2var_pd(a, _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15), b);
            }
            _ => {
                let row = |l: usize| _mm256_maskz_loadu_pd(0b0111, at(l));
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
                out[0] = _mm512_permutex2var_pd(t0, lo, t2);
                out[1] = _mm512_permutex2var_pd(t1, lo, t3);
                out[2] = _mm512_permutex2var_pd(t0, hi, t2);
            }
        }
    }
    out
}

/// The first `count` (≤ 8) of the consecutive rows of `n` (2 or 3) f64 at `base`, as `n` vectors
/// (lanes from `count` on are zero): contiguous loads and a de-interleave.
///
/// # Safety
/// The `count` rows lie in one allocation.
#[inline]
#[target_feature(enable = "avx512f,avx512vl")]
unsafe fn contiguous(base: *const f64, n: usize, count: usize) -> [__m512d; 3] {
    let mut out = [_mm512_setzero_pd(); 3];
    let total = (n * count) as isize;
    // SAFETY: the caller's contract; masked-off elements are not read.
    unsafe {
        let a = _mm512_maskz_loadu_pd(first_clamped(total), base);
        let b = _mm512_maskz_loadu_pd(first_clamped(total - 8), base.add(8));
        if n == 2 {
            out[0] = _mm512_permutex2var_pd(a, _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), b);
            out[1] = _mm512_permutex2var_pd(a, _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15), b);
        } else {
            let c = _mm512_maskz_loadu_pd(first_clamped(total - 16), base.add(16));
            out = crate::simd512::deinterleave3(a, b, c);
        }
    }
    out
}

/// Looks at candidate pairs (at most 8) as [`super::push_pair`] does one by one, keeping the pairs
/// whose partner lies before grain `g1` (`intra`, phase B: the block ends at `g1`) or from `g1`
/// on (`!intra`, phase A). The candidates are the pairs `p0..p1` (consecutive in the list, of one
/// owner or several), or with `LIST` the pairs `list[p0..p1]` (increasing). The touching ones are
/// appended to the window in pair order with all the kernel's inputs (geometry, both grains'
/// velocities, spins, radii and masses, the stored history); the others forget a history they
/// may still hold. `owner[p]` is the first grain of pair `p`.
///
/// # Safety
/// `p0 < p1 ≤ p0 + 8`, `w.len + 8 ≤ CAP`, the pairs belong to `h`, their grains index
/// `inp.pos`, and the owners and the kept partners lie in `v` (from `v.base`).
#[inline]
#[target_feature(enable = "avx512f,avx512vl,popcnt")]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn push_pairs<D: Dim, H: LawHistory, const LIST: bool>(
    w: &mut Window,
    inp: &Inputs<D>,
    h: &mut History<D, H>,
    v: Velocities<D>,
    owner: &[u32],
    list: &[u32],
    g1: usize,
    intra: bool,
    p0: usize,
    p1: usize,
    st: &mut ForceStats,
) {
    debug_assert!(p0 < p1 && p1 - p0 <= 8 && w.len + 8 <= CAP);
    debug_assert!(LIST || (p1 <= inp.partner.len() && p1 <= owner.len() && p0 >= h.base && p1 - h.base <= h.overlap.len()));
    debug_assert!(!LIST || (p1 <= list.len() && list[p0..p1].iter().all(|&p| p as usize >= h.base && (p as usize) - h.base < h.overlap.len())));
    let (dd, rot) = (D::D, <D::AngVector as VectorOps>::LEN);
    let n = p1 - p0;
    let k = w.len;
    // SAFETY: the caller's contract; the window stores write lanes k..k + 8 ≤ CAP.
    unsafe {
        let all = first(n);
        // pair of each lane (lanes past n: the first pair)
        let pair = if LIST {
            _mm256_mask_loadu_epi32(_mm256_set1_epi32(*list.get_unchecked(p0) as i32), all, list.as_ptr().add(p0) as *const i32)
        } else {
            _mm256_add_epi32(_mm256_set1_epi32(p0 as i32), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7))
        };
        let pl = indices(pair);
        let ql = pl.map(|p| p - h.base);
        let (i, j) = if LIST {
            let g = |a: &[u32]| {
                let x = |l: usize| *a.get_unchecked(pl[l]) as i32;
                _mm256_setr_epi32(x(0), x(1), x(2), x(3), x(4), x(5), x(6), x(7))
            };
            (g(owner), g(inp.partner))
        } else {
            // lanes past n: the first owner (valid in the block)
            let i = _mm256_mask_loadu_epi32(_mm256_set1_epi32(*owner.get_unchecked(p0) as i32), all, owner.as_ptr().add(p0) as *const i32);
            (i, _mm256_maskz_loadu_epi32(all, inp.partner.as_ptr().add(p0) as *const i32))
        };
        let bound = _mm256_set1_epi32(g1 as i32);
        let side = if intra { _mm256_cmplt_epu32_mask(j, bound) } else { _mm256_cmpge_epu32_mask(j, bound) };
        let m = all & side;
        // the lanes not looked at read their owner's data (valid in the block)
        let jm = _mm256_mask_blend_epi32(m, i, j);
        let (il, jl) = (indices(i), indices(jm));
        let (ib, jb) = (il.map(|x| x - v.base), jl.map(|x| x - v.base));
        let pos = inp.pos.as_ptr() as *const f64;
        let (xi, xj) = (rows(pos, dd, &il), rows(pos, dd, &jl));
        let (ri, rj) = (rows(inp.radius.as_ptr(), 1, &il)[0], rows(inp.radius.as_ptr(), 1, &jl)[0]);
        // nearest-image vector and, in a shearing cell, the velocity of the image (the domain's
        // `PeriodicImage::displacement_velocity_lanes`)
        let image = &inp.image;
        let mut d = [Wide8(_mm512_setzero_pd()); 3];
        for c in 0..dd {
            d[c] = Wide8(_mm512_sub_pd(xj[c], xi[c]));
        }
        let (d, dv) = image.displacement_velocity_lanes(d);
        let (d, dv) = (d.map(|x| x.0), dv.map(|x| x.0));
        // |r|² in the order of `VectorOps::dot`
        let mut dist2 = _mm512_add_pd(_mm512_mul_pd(d[0], d[0]), _mm512_mul_pd(d[1], d[1]));
        if dd == 3 {
            dist2 = _mm512_add_pd(dist2, _mm512_mul_pd(d[2], d[2]));
        }
        let sum = _mm512_add_pd(ri, rj);
        // touching: !(d² ≥ sum²), true for NaN as in the scalar test
        let touch = _mm512_mask_cmp_pd_mask::<_CMP_NGE_UQ>(m, dist2, _mm512_mul_pd(sum, sum));
        let old = if LIST {
            _mm512_maskz_mov_pd(m, rows(h.overlap.as_ptr(), 1, &ql)[0])
        } else {
            _mm512_maskz_loadu_pd(m, h.overlap.as_ptr().add(ql[0]))
        };
        let mut opened = _mm512_mask_cmp_pd_mask::<_CMP_GT_OQ>(m & !touch, old, _mm512_setzero_pd());
        while opened != 0 {
            h.forget(ql[opened.trailing_zeros() as usize], st);
            opened &= opened - 1;
        }
        if touch == 0 {
            return;
        }
        let put = |dst: &mut [f64; CAP], x: __m512d| _mm512_storeu_pd(dst.as_mut_ptr().add(k), _mm512_maskz_compress_pd(touch, x));
        let put_i = |dst: &mut [u32; CAP], x: __m256i| _mm256_storeu_si256(dst.as_mut_ptr().add(k) as *mut __m256i, _mm256_maskz_compress_epi32(touch, x));
        put_i(&mut w.pair, pair);
        put_i(&mut w.i, i);
        put_i(&mut w.j, j);
        for c in 0..dd {
            put(&mut w.r[c], d[c]);
        }
        put(&mut w.dist2, dist2);
        put(&mut w.rad_i, ri);
        put(&mut w.rad_j, rj);
        put(&mut w.mass_i, rows(inp.mass.as_ptr(), 1, &il)[0]);
        put(&mut w.mass_j, rows(inp.mass.as_ptr(), 1, &jl)[0]);
        let (vi, vj) = (rows(v.vel.as_ptr() as *const f64, dd, &ib), rows(v.vel.as_ptr() as *const f64, dd, &jb));
        for c in 0..dd {
            // the image of j moves with the cell in a shearing cell
            let vj = if image.sheared { _mm512_add_pd(vj[c], dv[c]) } else { vj[c] };
            put(&mut w.v_rel[c], _mm512_sub_pd(vj, vi[c]));
        }
        let (wi, wj) = (rows(v.omega.as_ptr() as *const f64, rot, &ib), rows(v.omega.as_ptr() as *const f64, rot, &jb));
        for c in 0..rot {
            put(&mut w.w_i[c], wi[c]);
            put(&mut w.w_j[c], wj[c]);
        }
        let spring = if LIST { rows(h.spring.as_ptr() as *const f64, dd, &ql) } else { contiguous(h.spring.as_ptr().add(ql[0]) as *const f64, dd, n) };
        for c in 0..dd {
            put(&mut w.spring[c], spring[c]);
        }
        put(&mut w.was, old);
        w.len = k + touch.count_ones() as usize;
    }
}
