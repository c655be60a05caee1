//! Coulomb limit (SPEC §2.4): |F_t| ≤ μ F_n, with the stored spring reset while sliding.

use crate::dim::VectorOps;
use crate::real::{by_len, dot, from_lanes, to_lanes, Real, Vec3};

/// Caps the trial force `trial` at magnitude `cap` (= μ F_n or μ_r R* F_n).
///
/// Returns the force and whether it was capped (the contact is *sliding*). The caller resets its
/// stored history so that it holds exactly the capped force (linear law: s = F_t/k_t).
#[inline]
pub fn coulomb_cap<V: VectorOps>(trial: V, cap: f64) -> (V, bool) {
    let (f, sliding) = by_len!(V, coulomb_cap_lanes(to_lanes(trial), cap));
    (from_lanes(f), sliding)
}

/// [`coulomb_cap`] on every lane (vectors of `N` components): where |trial|² > cap² the force
/// trial · cap/|trial| (zero when cap ≤ 0), else `trial`; and where it was capped. The one
/// implementation, run by the general kernel (`f64`) and the engine's vector paths.
///
/// Branch-free on vectors: the capped force is computed on every lane and selected where the
/// lane slides; on one lane (`f64`) it is computed only when the contact slides
/// ([`Real::branch_unless`]). The same bits either way.
#[inline(always)]
pub(crate) fn coulomb_cap_lanes<R: Real, const N: usize>(trial: Vec3<R>, cap: R) -> (Vec3<R>, R::Mask) {
    let zero = R::splat(0.0);
    let t2 = dot::<R, N>(trial, trial);
    let sliding = t2.gt(cap * cap);
    if R::branch_unless(sliding) {
        return (trial, sliding);
    }
    let shrink = cap / t2.sqrt();
    let cap_pos = cap.gt(zero);
    let mut f = [zero; 3];
    for c in 0..N {
        let capped = R::select(cap_pos, trial[c] * shrink, zero);
        f[c] = R::select(sliding, capped, trial[c]);
    }
    (f, sliding)
}
