//! The largest eigenvalue ω²_max of M⁻¹D, which sets the stable time step of direct propagation.
//!
//! Lanczos iteration on the symmetric S = M^{-1/2} D M^{-1/2} from a seeded random start vector:
//! k steps build the tridiagonal T_k = Q_kᵀ S Q_k; its largest eigenvalue θ (a Ritz value) is a lower
//! bound of λ_max that converges fast, and θ + β_{k+1}|s_k| (s the Ritz vector of θ in the Lanczos
//! basis) bounds the distance to an eigenvalue of S — used as the estimate. The Gershgorin bound
//! max_r Σ_c |D_rc|/√(m_r m_c), an upper bound, caps it when available. No reorthogonalization is
//! needed for the extreme eigenvalue (lost orthogonality only produces copies of converged Ritz
//! values).

use faer::{Mat, Side};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Estimate of ω²_max = λ_max(M⁻¹D).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpectralBound {
    /// Largest Ritz value θ (≤ λ_max).
    pub ritz: f64,
    /// Residual bound β_{k+1}|s_k| of that Ritz value.
    pub residual: f64,
    /// Gershgorin upper bound, when known.
    pub gershgorin: Option<f64>,
    /// The estimate used: min(θ + residual, Gershgorin).
    pub estimate: f64,
    /// Lanczos steps done.
    pub iterations: usize,
}

/// Estimates λ_max of M⁻¹D with `iterations` Lanczos steps; `apply(x, y)` computes y = D x.
pub fn largest_eigenvalue(apply: &dyn Fn(&[f64], &mut [f64]), mass: &[f64], iterations: usize, gershgorin: Option<f64>, seed: u64) -> SpectralBound {
    let n = mass.len();
    let k_max = iterations.clamp(1, n.max(1));
    let inv_sqrt: Vec<f64> = mass.iter().map(|m| 1.0 / m.sqrt()).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut q: Vec<f64> = (0..n).map(|_| 2.0 * rng.random::<f64>() - 1.0).collect();
    let norm = q.iter().map(|x| x * x).sum::<f64>().sqrt();
    q.iter_mut().for_each(|x| *x /= norm);
    let mut q_prev = vec![0.0; n];
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let mut alpha = Vec::with_capacity(k_max);
    let mut beta: Vec<f64> = Vec::with_capacity(k_max);
    let mut beta_prev = 0.0;
    for _ in 0..k_max {
        for r in 0..n {
            x[r] = q[r] * inv_sqrt[r];
        }
        apply(&x, &mut w);
        for r in 0..n {
            w[r] = w[r] * inv_sqrt[r] - beta_prev * q_prev[r];
        }
        let a: f64 = w.iter().zip(&q).map(|(a, b)| a * b).sum();
        for r in 0..n {
            w[r] -= a * q[r];
        }
        alpha.push(a);
        let b = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        beta.push(b);
        if !(b > 1e-300) {
            break;
        }
        std::mem::swap(&mut q_prev, &mut q);
        for r in 0..n {
            q[r] = w[r] / b;
        }
        beta_prev = b;
    }
    let k = alpha.len();
    let mut t = Mat::<f64>::zeros(k, k);
    for i in 0..k {
        t[(i, i)] = alpha[i];
        if i + 1 < k {
            t[(i + 1, i)] = beta[i];
            t[(i, i + 1)] = beta[i];
        }
    }
    let (ritz, residual) = match t.self_adjoint_eigen(Side::Lower) {
        Ok(evd) => {
            let last = k - 1;
            let theta = evd.S().column_vector()[last];
            let s_k = evd.U()[(k - 1, last)];
            (theta, beta[k - 1] * s_k.abs())
        }
        Err(_) => {
            // fall back on the largest diagonal entry of T (still a lower bound)
            (alpha.iter().cloned().fold(f64::NEG_INFINITY, f64::max), f64::INFINITY)
        }
    };
    let mut estimate = ritz + residual;
    if let Some(g) = gershgorin {
        estimate = estimate.min(g);
    }
    SpectralBound { ritz, residual, gershgorin, estimate, iterations: k }
}
