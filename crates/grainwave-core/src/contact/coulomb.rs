//! Coulomb limit (SPEC §2.4): |F_t| ≤ μ F_n, with the stored spring reset while sliding.

use crate::dim::VectorOps;

/// Caps the trial force `trial` at magnitude `cap` (= μ F_n or μ_r R* F_n).
///
/// Returns the force and whether it was capped (the contact is *sliding*). The caller resets its
/// stored history so that it holds exactly the capped force (linear law: s = F_t/k_t).
#[inline]
pub fn coulomb_cap<V: VectorOps>(trial: V, cap: f64) -> (V, bool) {
    let t2 = trial.norm2();
    if t2 > cap * cap {
        if cap > 0.0 {
            (trial * (cap / t2.sqrt()), true)
        } else {
            (V::ZERO, true)
        }
    } else {
        (trial, false)
    }
}
