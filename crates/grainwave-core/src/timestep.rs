//! Automatic time-step suggestion (SPEC §3).

use crate::contact::ContactLaw;
use crate::dim::Dim;
use crate::domain::Wall;
use crate::grains::Grains;
use std::f64::consts::PI;

/// Suggested time step: `fraction` × T_min with T_min = 2π/ω_max the shortest oscillation period of
/// a single contact, ω_max² = max(k_n/m*, k_t(1 + mR²/I)/m*, …) over grain–grain and grain–wall
/// laws, with m* of the lightest pair (two smallest grains; a grain on a wall) and, for Hertz,
/// the stiffness at overlap `expected_overlap` × R_max.
pub fn suggest_timestep<D: Dim>(grains: &Grains<D>, law: &ContactLaw, walls: &[Wall<D>], fraction: f64, expected_overlap: f64) -> f64 {
    let (r_min, r_max) = grains.radius_range();
    let m_min = grains.mass.iter().cloned().fold(f64::INFINITY, f64::min);
    let k = grains.inertia.iter().zip(&grains.mass).zip(&grains.radius).map(|((i, m), r)| m * r * r / i).fold(0.0, f64::max);
    let xi = expected_overlap * r_max;
    let mut w2 = law.max_frequency_sq(0.5 * m_min, 0.5 * r_max, xi, k);
    // rolling springs act on the smallest grains most
    w2 = w2.max(law.max_frequency_sq(0.5 * m_min, 0.5 * r_min.max(1e-300), xi, k));
    for w in walls {
        w2 = w2.max(w.law.max_frequency_sq(m_min, r_max, xi, k));
    }
    fraction * 2.0 * PI / w2.sqrt()
}
