//! Coulomb limit (SPEC §2.4): |F_t| ≤ μ F_n, with the stored spring reset while sliding.

use crate::dim::VectorOps;
use crate::real::{by_len, dot, from_lanes, select3, to_lanes, Real, Vec3};

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
/// lane slides (a branch skipping it when no lane of a vector slides was mispredicted often
/// enough to cost 3–4 % on `hooke2d`, BENCHMARKS.md); on one lane (`f64`) it is computed only
/// when the contact slides ([`Real::choose`]). The same bits either way.
#[inline(always)]
pub(crate) fn coulomb_cap_lanes<R: Real, const N: usize>(trial: Vec3<R>, cap: R) -> (Vec3<R>, R::Mask) {
    let zero = R::splat(0.0);
    let t2 = dot::<R, N>(trial, trial);
    let sliding = t2.gt(cap * cap);
    let capped = || {
        let shrink = cap / t2.sqrt();
        let mut f = [zero; 3];
        for c in 0..N {
            f[c] = trial[c] * shrink;
        }
        R::choose(cap.gt(zero), || f, || [zero; 3], select3::<R>)
    };
    (R::choose(sliding, capped, || trial, select3::<R>), sliding)
}
