//! Normal damping part (SPEC §2.2) and the conversion from a restitution coefficient.

use crate::real::Real;

/// The normal force on every lane, F_n = max(0, F_el − γ_n v_n): the damping adds while the
/// grains approach (v_n < 0) and the contact never pulls. The one statement of the clamp, run by
/// the general kernel (`f64`) and the engine's vector paths.
#[inline(always)]
pub(crate) fn clamped_normal_force_lanes<R: Real>(f_el: R, gamma_n: R, v_n: R) -> R {
    (f_el - gamma_n * v_n).max_zero()
}
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Normal viscous damping: a force γ_n |v_n| opposing the relative normal velocity.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NormalDamping {
    /// No damping.
    None,
    /// Constant coefficient γ_n (force/velocity).
    Dashpot {
        /// γ_n.
        coefficient: f64,
    },
    /// γ_n = ζ · 2 √(m* k_n(ξ)) at every instant, with k_n the current differential stiffness.
    CriticalFraction {
        /// ζ (dimensionless).
        zeta: f64,
    },
    /// γ_n = rate × m*: a dashpot proportional to the effective mass. This is the damping of
    /// LAMMPS's `gran/hooke/history` (its `gamma_n`, in 1/time, multiplies m*).
    MassProportional {
        /// γ_n / m* (1/time).
        rate: f64,
    },
    /// Tsuji, Tanaka & Ishida (1992): γ_n = α √(m* k̄) with k̄ = F_el/ξ the secant stiffness of
    /// the normal law (Hooke: k_n; Hertz: (4/3) E*_ij √(R* ξ), so γ_n ∝ ξ^¼). α follows from a
    /// restitution coefficient through [`tsuji_alpha`]. This is LAMMPS's `damping tsuji`.
    Tsuji {
        /// α (dimensionless).
        alpha: f64,
    },
}

impl NormalDamping {
    /// γ_n for a pair of effective mass `m_eff`, current differential normal stiffness `k_n`
    /// and secant stiffness `k_secant` = F_el/ξ (see [`NormalElastic::response`](super::NormalElastic::response)).
    #[inline]
    pub fn coefficient(&self, m_eff: f64, k_n: f64, k_secant: f64) -> f64 {
        self.coefficient_lanes(m_eff, k_n, k_secant)
    }

    /// [`NormalDamping::coefficient`] on every lane: the one implementation, run by the general
    /// kernel (`f64`) and the engine's vector paths.
    #[inline(always)]
    pub(crate) fn coefficient_lanes<R: Real>(&self, m_eff: R, k_n: R, k_secant: R) -> R {
        match *self {
            NormalDamping::None => R::splat(0.0),
            NormalDamping::Dashpot { coefficient } => R::splat(coefficient),
            NormalDamping::CriticalFraction { zeta } => R::splat(zeta * 2.0) * (m_eff * k_n).sqrt(),
            NormalDamping::MassProportional { rate } => R::splat(rate) * m_eff,
            NormalDamping::Tsuji { alpha } => R::splat(alpha) * (m_eff * k_secant).sqrt(),
        }
    }

    /// Damping for a linear (Hooke) contact that gives restitution coefficient `e`, exactly, for
    /// the contact law as it is integrated (normal force clamped at zero).
    pub fn from_restitution(e: f64) -> Option<Self> {
        critical_fraction_for_restitution(e).map(|zeta| NormalDamping::CriticalFraction { zeta })
    }
}

/// Tsuji's damping constant α for restitution coefficient `e` ∈ [0, 1]: the polynomial fit
///
/// α(e) = 1.2728 − 4.2783 e + 11.087 e² − 22.348 e³ + 27.467 e⁴ − 18.022 e⁵ + 4.8218 e⁶
///
/// used by LAMMPS (`pair_style granular`, `damping tsuji`), evaluated in the same expanded form.
/// It is a fit to Tsuji et al.'s numerical solutions of the Hertz contact with γ_n ∝ ξ^¼, whose
/// force may turn attractive at the end of the contact; with grainwave's clamped normal force
/// the measured restitution is somewhat larger than `e` (see the tests).
pub fn tsuji_alpha(e: f64) -> f64 {
    1.2728 - 4.2783 * e + 11.087 * e * e - 22.348 * e * e * e + 27.467 * e * e * e * e - 18.022 * e * e * e * e * e
        + 4.8218 * e * e * e * e * e * e
}

/// Textbook relation ζ(e) = −ln e / √(π² + ln² e) for a linear spring–dashpot whose force may become
/// attractive at the end of the contact (contact ends at ξ = 0).
///
/// grainwave clamps the normal force at zero (SPEC §2), so with this ζ the measured restitution is
/// *larger* than e (e = 0.5 gives 0.550). Use [`critical_fraction_for_restitution`] instead; this
/// function is kept for reference and comparison with other codes.
pub fn textbook_critical_fraction(e: f64) -> f64 {
    let l = e.ln();
    -l / (PI * PI + l * l).sqrt()
}

/// Restitution of a linear spring–dashpot contact with damping ratio `zeta` < 1 when the normal
/// force is clamped at zero (no attraction).
///
/// With ω₀ = √(k/m*), ω_d = ω₀√(1−ζ²), the overlap is ξ(t) = (v₀/ω_d) e^{−ζω₀t} sin ω_d t until the
/// force k ξ + γ ξ̇ vanishes at ω_d t₁ = π − atan2(2ζ√(1−ζ²), 1 − 2ζ²); after that the grains fly
/// apart at constant speed. Hence e = −ξ̇(t₁)/v₀ = −e^{−ζω₀t₁} [cos ω_d t₁ − ζ/√(1−ζ²) sin ω_d t₁].
/// It decreases from 1 (ζ = 0) to e⁻² ≈ 0.1353 (ζ → 1); for ζ ≥ 1 the grains never separate.
pub fn clamped_restitution(zeta: f64) -> f64 {
    if zeta <= 0.0 {
        return 1.0;
    }
    if zeta >= 1.0 {
        return (-2.0_f64).exp();
    }
    let s = (1.0 - zeta * zeta).sqrt();
    let th = PI - (2.0 * zeta * s).atan2(1.0 - 2.0 * zeta * zeta);
    let t1 = th / s; // in units of 1/ω₀
    -(-zeta * t1).exp() * (th.cos() - zeta / s * th.sin())
}

/// Duration (in units of 1/ω₀) of a clamped linear spring–dashpot contact with damping ratio
/// `zeta` < 1: the time t₁ until the force vanishes plus the free flight ξ(t₁)/|ξ̇(t₁)| to ξ = 0.
pub fn clamped_contact_time(zeta: f64) -> f64 {
    if zeta <= 0.0 {
        return PI;
    }
    let s = (1.0 - zeta * zeta).sqrt();
    let th = PI - (2.0 * zeta * s).atan2(1.0 - 2.0 * zeta * zeta);
    let t1 = th / s;
    let decay = (-zeta * t1).exp();
    let xi = decay * th.sin() / s; // ξ(t₁) ω₀ / v₀
    let v = decay * (th.cos() - zeta / s * th.sin()); // ξ̇(t₁)/v₀ (negative)
    t1 + xi / (-v)
}

/// The damping ratio ζ for which a clamped linear contact has restitution `e`, or `None` when
/// `e` ∉ [e⁻², 1] (below e⁻² ≈ 0.1353 a linear dashpot without attraction cannot separate grains).
pub fn critical_fraction_for_restitution(e: f64) -> Option<f64> {
    let e_min = (-2.0_f64).exp();
    if !(e.is_finite() && e >= e_min && e <= 1.0) {
        return None;
    }
    if e == 1.0 {
        return Some(0.0);
    }
    // clamped_restitution is strictly decreasing on [0, 1): bisection to machine precision.
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid == lo || mid == hi {
            break;
        }
        if clamped_restitution(mid) > e {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// Normal and tangential damping coefficients γ_n, γ_t of a law: its own damping parts (the pair
/// `(NormalDamping, TangentialDamping)`, which matches on them at every contact), or the same
/// formulas resolved at compile time for the presets' combinations (`sim::lanes`).
pub(crate) trait Dampers: Copy {
    /// γ_n from m*, k_n and the secant stiffness (as `NormalDamping::coefficient`).
    fn normal<R: Real>(&self, m_eff: R, k_n: R, secant: R) -> R;
    /// γ_t (as `TangentialDamping::coefficient`).
    fn tangential<R: Real>(&self, m_eff: R, k_t: R, gamma_n: R) -> R;
}

impl Dampers for (NormalDamping, super::TangentialDamping) {
    #[inline(always)]
    fn normal<R: Real>(&self, m_eff: R, k_n: R, secant: R) -> R {
        self.0.coefficient_lanes(m_eff, k_n, secant)
    }
    #[inline(always)]
    fn tangential<R: Real>(&self, m_eff: R, k_t: R, gamma_n: R) -> R {
        self.1.coefficient_lanes(m_eff, k_t, gamma_n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restitution_inversion_round_trips() {
        for &e in &[0.14, 0.3, 0.5, 0.9, 0.92, 0.999] {
            let z = critical_fraction_for_restitution(e).unwrap();
            assert!((clamped_restitution(z) - e).abs() < 1e-12, "e = {e}");
        }
        assert!(critical_fraction_for_restitution(0.1).is_none());
        assert!(critical_fraction_for_restitution(0.0).is_none());
        assert!(critical_fraction_for_restitution(1.2).is_none());
        // Weak damping: the clamp hardly matters and the textbook formula is recovered.
        let z = critical_fraction_for_restitution(0.999).unwrap();
        assert!((z - textbook_critical_fraction(0.999)).abs() < 1e-6);
    }

    #[test]
    fn tsuji_alpha_matches_the_published_fit() {
        // Values of the polynomial computed by hand: α(1) ≈ 0 (elastic), α(0) = 1.2728, and
        // α(0.5) = 1.2728 − 2.13915 + 2.77175 − 2.7935 + 1.71669 − 0.563188 + 0.0753406.
        assert!(tsuji_alpha(1.0).abs() < 1e-3);
        assert_eq!(tsuji_alpha(0.0), 1.2728);
        let a = 1.2728 - 2.13915 + 2.77175 - 2.7935 + 1.716_687_5 - 0.563_187_5 + 0.075_340_625;
        assert!((tsuji_alpha(0.5) - a).abs() < 1e-12, "{}", tsuji_alpha(0.5));
        // decreasing on [0, 1]: more damping for smaller restitution
        for k in 0..100 {
            let e = k as f64 / 100.0;
            assert!(tsuji_alpha(e) > tsuji_alpha(e + 0.01), "e = {e}");
        }
    }
}
