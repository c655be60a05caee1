//! Symplectic splitting schemes for M ü = −D u (written as q̇ = v, v̇ = a(q) = −M⁻¹ D q).
//!
//! A step of length h is a palindromic sequence of kicks v += b_k h a(q) and drifts q += a_k h v:
//!
//! ```text
//! kick(b_0) drift(a_1) kick(b_1) … drift(a_s) kick(b_s)
//! ```
//!
//! The last kick of a step and the first of the next use the same positions, so a step costs s
//! products with D ("first same as last").
//!
//! * [`Scheme::VelocityVerlet`]: b = (½, ½), a = (1); 2nd order, 1 product per step, stable for
//!   ω h < 2.
//! * [`Scheme::BlanesMoan4`]: the 6-stage 4th-order Runge–Kutta–Nyström method SRKN₆ᵇ of
//!   S. Blanes and P. C. Moan, J. Comput. Appl. Math. 142, 313 (2002) — chosen for its very small
//!   error constant; 6 products per step, stable for ω h < 3.16 (0.53 per product, against 2 for
//!   Verlet, but at equal cost its phase error is ~1000 × smaller at 20 steps per period:
//!   1.5e-7 relative vs Verlet's 1.1e-4 at 120 steps per period).
//!
//! Both are symplectic and time-reversible: for a linear system they conserve a modified energy
//! exactly and their only error is a small frequency (phase) error, ~(ωh)²/24 relative for Verlet
//! and ~(ωh)⁴ × (small constant) for SRKN₆ᵇ.

use serde::{Deserialize, Serialize};

/// A symplectic integration scheme.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scheme {
    /// Velocity Verlet (2nd order).
    VelocityVerlet,
    /// Blanes–Moan SRKN₆ᵇ (4th order, default).
    #[default]
    BlanesMoan4,
}

const BM_A1: f64 = 0.245298957184271;
const BM_A2: f64 = 0.604872665711080;
const BM_A3: f64 = 0.5 - (BM_A1 + BM_A2);
const BM_B1: f64 = 0.0829844064174052;
const BM_B2: f64 = 0.396309801498368;
const BM_B3: f64 = -0.0390563049223486;
const BM_B4: f64 = 1.0 - 2.0 * (BM_B1 + BM_B2 + BM_B3);

impl Scheme {
    /// Kick coefficients b_0 … b_s and drift coefficients a_1 … a_s.
    pub fn coefficients(&self) -> (Vec<f64>, Vec<f64>) {
        match self {
            Scheme::VelocityVerlet => (vec![0.5, 0.5], vec![1.0]),
            Scheme::BlanesMoan4 => (
                vec![BM_B1, BM_B2, BM_B3, BM_B4, BM_B3, BM_B2, BM_B1],
                vec![BM_A1, BM_A2, BM_A3, BM_A3, BM_A2, BM_A1],
            ),
        }
    }

    /// Order of accuracy.
    pub fn order(&self) -> usize {
        match self {
            Scheme::VelocityVerlet => 2,
            Scheme::BlanesMoan4 => 4,
        }
    }

    /// Products with D per step.
    pub fn stages(&self) -> usize {
        self.coefficients().1.len()
    }

    /// One step of the scheme applied to the harmonic oscillator ẍ = −ω²x, as the 2 × 2 matrix
    /// acting on (x, v) with z = ω h (v in units of ω x).
    pub fn oscillator_matrix(&self, z: f64) -> [[f64; 2]; 2] {
        let (kicks, drifts) = self.coefficients();
        // state (x, y = v/ω): kick y −= b z x, drift x += a z y
        let mut m = [[1.0, 0.0], [0.0, 1.0]];
        let mul = |a: [[f64; 2]; 2], b: [[f64; 2]; 2]| {
            [
                [a[0][0] * b[0][0] + a[0][1] * b[1][0], a[0][0] * b[0][1] + a[0][1] * b[1][1]],
                [a[1][0] * b[0][0] + a[1][1] * b[1][0], a[1][0] * b[0][1] + a[1][1] * b[1][1]],
            ]
        };
        for k in 0..kicks.len() {
            m = mul([[1.0, 0.0], [-kicks[k] * z, 1.0]], m);
            if k < drifts.len() {
                m = mul([[1.0, drifts[k] * z], [0.0, 1.0]], m);
            }
        }
        m
    }

    /// Largest ω h below which the scheme is stable on the harmonic oscillator (|trace| < 2 of
    /// [`Scheme::oscillator_matrix`] on the whole interval), found by scanning in steps of 1e-4.
    pub fn stability_limit(&self) -> f64 {
        let mut z = 0.0;
        loop {
            let next = z + 1e-4;
            let m = self.oscillator_matrix(next);
            if (m[0][0] + m[1][1]).abs() >= 2.0 || next > 20.0 {
                return z;
            }
            z = next;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Local error of one step on the oscillator vs the exact rotation, for step z and z/2: the
    /// ratio must be 2^(order+1) (within 5 %: higher-order terms at z = 0.1).
    #[test]
    fn schemes_have_their_order() {
        for scheme in [Scheme::VelocityVerlet, Scheme::BlanesMoan4] {
            let err = |z: f64| {
                let m = scheme.oscillator_matrix(z);
                let e = [[z.cos(), z.sin()], [-z.sin(), z.cos()]];
                let mut s: f64 = 0.0;
                for i in 0..2 {
                    for j in 0..2 {
                        s = s.max((m[i][j] - e[i][j]).abs());
                    }
                }
                s
            };
            let ratio = err(0.1) / err(0.05);
            let expected = 2f64.powi(scheme.order() as i32 + 1);
            assert!((ratio / expected - 1.0).abs() < 0.05, "{scheme:?}: error ratio {ratio}, expected {expected}");
        }
    }

    #[test]
    fn coefficients_are_consistent_and_symplectic() {
        for scheme in [Scheme::VelocityVerlet, Scheme::BlanesMoan4] {
            let (b, a) = scheme.coefficients();
            assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            assert!((a.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            let m = scheme.oscillator_matrix(0.7);
            let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
            assert!((det - 1.0).abs() < 1e-14, "{scheme:?}: det {det}");
        }
        assert!((Scheme::VelocityVerlet.stability_limit() - 2.0).abs() < 2e-4);
        assert!((Scheme::BlanesMoan4.stability_limit() - 3.163).abs() < 2e-3);
    }
}
