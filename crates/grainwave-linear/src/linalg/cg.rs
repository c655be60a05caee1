//! Jacobi-preconditioned conjugate gradient for D x = b with D symmetric positive semi-definite,
//! projected off a set of known null vectors Z (orthonormal, D Z = 0).
//!
//! The right-hand side is projected, b ← (I − Z Zᵀ) b (the removed part is a load on a zero mode,
//! which no displacement can balance, and is reported), and every preconditioned residual is
//! projected too, so the iterates stay in the complement of Z where D is definite. The iteration
//! stops when ‖b − D x‖ ≤ tol ‖b‖. A search direction with pᵀDp ≤ 1e-14 pᵀ diag(D) p means a
//! floppy (or, with pre-stress, unstable) mode outside Z: the solver stops with
//! [`LinearError::NotPositiveDefinite`] instead of producing garbage.

use crate::error::{LinearError, Result};

/// Result of [`solve`].
#[derive(Clone, Debug)]
pub struct CgSolution {
    /// The solution.
    pub x: Vec<f64>,
    /// Iterations done.
    pub iterations: usize,
    /// ‖b − D x‖ / ‖b‖ (projected b).
    pub relative_residual: f64,
    /// ‖Zᵀ b‖: the part of the load on the null vectors, removed before solving.
    pub null_load: f64,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn project(v: &mut [f64], null: &[Vec<f64>]) -> f64 {
    let mut removed = 0.0;
    for z in null {
        let c = dot(v, z);
        removed += c * c;
        for (a, b) in v.iter_mut().zip(z) {
            *a -= c * b;
        }
    }
    removed.sqrt()
}

/// Solves D x = b (see the module docs). `apply(x, y)` computes y = D x; `diag` is the diagonal of
/// D (all entries > 0); `null` orthonormal null vectors of D.
pub fn solve(apply: &dyn Fn(&[f64], &mut [f64]), diag: &[f64], b: &[f64], null: &[Vec<f64>], tolerance: f64, max_iterations: usize) -> Result<CgSolution> {
    let n = b.len();
    let mut rhs = b.to_vec();
    let null_load = project(&mut rhs, null);
    let b_norm = dot(&rhs, &rhs).sqrt();
    let mut x = vec![0.0; n];
    if b_norm == 0.0 {
        return Ok(CgSolution { x, iterations: 0, relative_residual: 0.0, null_load });
    }
    let inv_diag: Vec<f64> = diag.iter().map(|d| 1.0 / d).collect();
    let mut r = rhs;
    let mut z: Vec<f64> = r.iter().zip(&inv_diag).map(|(a, b)| a * b).collect();
    project(&mut z, null);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut q = vec![0.0; n];
    let mut res = 1.0;
    for it in 0..max_iterations {
        apply(&p, &mut q);
        let pq = dot(&p, &q);
        let pdp: f64 = p.iter().zip(diag).map(|(a, d)| a * a * d).sum();
        if !(pq > 1e-14 * pdp) {
            return Err(LinearError::NotPositiveDefinite { iteration: it, curvature: pq / pdp });
        }
        let alpha = rz / pq;
        for k in 0..n {
            x[k] += alpha * p[k];
            r[k] -= alpha * q[k];
        }
        res = dot(&r, &r).sqrt() / b_norm;
        let mut restart = false;
        if res <= tolerance {
            // recompute the true residual once (recurrences drift)
            let mut dx = vec![0.0; n];
            apply(&x, &mut dx);
            let mut true_r: Vec<f64> = b.iter().zip(&dx).map(|(a, c)| a - c).collect();
            project(&mut true_r, null);
            let true_res = dot(&true_r, &true_r).sqrt() / b_norm;
            if true_res <= tolerance {
                return Ok(CgSolution { x, iterations: it + 1, relative_residual: true_res, null_load });
            }
            r = true_r;
            res = true_res;
            restart = true;
        }
        for k in 0..n {
            z[k] = r[k] * inv_diag[k];
        }
        project(&mut z, null);
        let rz_new = dot(&r, &z);
        let beta = if restart { 0.0 } else { rz_new / rz };
        rz = rz_new;
        for k in 0..n {
            p[k] = z[k] + beta * p[k];
        }
    }
    Err(LinearError::NoConvergence { iterations: max_iterations, residual: res, tolerance })
}
