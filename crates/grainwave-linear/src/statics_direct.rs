//! Static linear response by sparse Cholesky factorization: D_ff u_f = f_f − D_fc u_c solved
//! directly, for stiffness matrices that are positive definite on the free dofs.
//!
//! The conjugate gradient of [`crate::solve_static`] handles zero modes and needs no
//! factorization, but its iteration count grows with the condition number of D: a slab of grains
//! under gravity (SPEC §7.2) — long, loaded by its own weight, with stiffnesses that differ by the
//! grain–wall ratio — takes tens of thousands of iterations to reach 1e-13. A sparse Cholesky
//! factorization (faer's supernodal LLᵀ with a fill-reducing ordering) solves the same system to
//! round-off in milliseconds for thousands of dofs, which makes Newton iterations on the static
//! force balance (SPEC §3, "faster relaxation to static equilibrium") cheap.
//!
//! Requirements: the system has no zero row (build it with [`crate::ZeroRows::Drop`]) and no
//! floppy mode (no rigid translation left free, no rattler): D_ff must be positive definite;
//! otherwise the factorization fails with [`LinearError::Inconsistent`] naming the reason.
//!
//! ```
//! use grainwave_linear::prelude::*;
//! use grainwave_linear::statics_direct::solve_static_direct;
//! # use grainwave_linear::reference::ChainSpec;
//! // a unit force on the last grain of a 10-grain chain between two walls (springs K = 1)
//! let chain = ChainSpec { grains: 10, stiffness: 1.0, ..ChainSpec::default() };
//! let snap = chain.build().unwrap().snapshot();
//! let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
//! let system = dm.free_system(&chain.constraints(), ZeroRows::Drop).unwrap();
//! let mut f = vec![0.0; system.dofs()];
//! let last = system.free_index(dm.layout().translation(9, 0)).unwrap();
//! f[last] = 1.0;
//! let sol = solve_static_direct(&system, &f).unwrap();
//! // 10 springs in series on the left in parallel with 1 on the right
//! assert!((sol.displacement[last] - 10.0 / 11.0).abs() < 1e-14);
//! ```

use crate::dynamical::LinearSystem;
use crate::error::{LinearError, Result};
use crate::statics::StaticSolution;
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

/// Solves D_ff u = `load` + (−D_fc u_c) on the free dofs of `system` by sparse Cholesky.
pub fn solve_static_direct(system: &LinearSystem, load: &[f64]) -> Result<StaticSolution> {
    solve_static_direct_regularized(system, load, 0.0)
}

/// Solves (D_ff + η diag D_ff) u = `load` + (−D_fc u_c) by sparse Cholesky: with η > 0 a
/// Levenberg–Marquardt step, which stays bounded along the soft modes of D (the residual is
/// reported for the regularized matrix).
pub fn solve_static_direct_regularized(system: &LinearSystem, load: &[f64], eta: f64) -> Result<StaticSolution> {
    let n = system.dofs();
    if load.len() != n {
        return Err(LinearError::LengthMismatch { what: "load".into(), expected: n, found: load.len() });
    }
    if !(eta >= 0.0 && eta.is_finite()) {
        return Err(LinearError::invalid("regularization", eta, "a finite number ≥ 0"));
    }
    let d = system.stiffness();
    let s = d.symbolic();
    let (rp, ci, val) = (s.row_ptr(), s.col_idx(), d.val());
    let mut triplets = Vec::with_capacity(val.len());
    for r in 0..n {
        for e in rp[r]..rp[r + 1] {
            let v = if ci[e] == r { val[e] * (1.0 + eta) } else { val[e] };
            triplets.push(faer::sparse::Triplet::new(r, ci[e], v));
        }
    }
    let matrix = faer::sparse::SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets)
        .map_err(|e| LinearError::Inconsistent(format!("cannot build the sparse matrix: {e:?}")))?;
    let llt = matrix
        .sp_cholesky(Side::Lower)
        .map_err(|e| LinearError::Inconsistent(format!("sparse Cholesky factorization of D ({n} dofs) failed ({e:?}): D is not positive definite on the free dofs (a zero row, a rattler or a free rigid motion?)")))?;
    let f: Vec<f64> = load.iter().zip(system.constraint_load()).map(|(a, b)| a + b).collect();
    let mut rhs = Mat::<f64>::from_fn(n, 1, |i, _| f[i]);
    llt.solve_in_place(rhs.as_mut());
    let displacement: Vec<f64> = (0..n).map(|i| rhs[(i, 0)]).collect();
    if displacement.iter().any(|x| !x.is_finite()) {
        return Err(LinearError::Inconsistent("the Cholesky solve produced non-finite displacements (D is singular to working precision)".into()));
    }
    let mut residual = vec![0.0; n];
    system.apply(&displacement, &mut residual);
    if eta > 0.0 {
        let diag = system.diagonal();
        for (k, r) in residual.iter_mut().enumerate() {
            *r += eta * diag[k] * displacement[k];
        }
    }
    let r2: f64 = residual.iter().zip(&f).map(|(a, b)| (a - b) * (a - b)).sum();
    let f2: f64 = f.iter().map(|x| x * x).sum();
    Ok(StaticSolution {
        displacement,
        iterations: 0,
        relative_residual: if f2 > 0.0 { (r2 / f2).sqrt() } else { r2.sqrt() },
        zero_rows: Vec::new(),
        rigid_modes: 0,
        unbalanced_load: 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prelude::*;
    use crate::reference::ChainSpec;

    #[test]
    fn agrees_with_conjugate_gradient_on_a_polydisperse_chain() {
        let chain = ChainSpec { grains: 40, stiffness: 3.0, polydispersity: 0.3, seed: 5, ..ChainSpec::default() };
        let snap = chain.build().unwrap().snapshot();
        let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
        let system = dm.free_system(&chain.constraints(), ZeroRows::Drop).unwrap();
        let f: Vec<f64> = (0..system.dofs()).map(|k| ((k * 7 % 11) as f64 - 5.0) * 0.1).collect();
        let direct = solve_static_direct(&system, &f).unwrap();
        let cg = solve_static(&system, &f, &StaticOptions { tolerance: 1e-14, ..Default::default() }).unwrap();
        assert!(direct.relative_residual < 1e-13, "{}", direct.relative_residual);
        let scale = cg.displacement.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
        for (a, b) in direct.displacement.iter().zip(&cg.displacement) {
            // both solve to ~1e-14 relative residual; the chain's condition number is ~N² = 1600
            assert!((a - b).abs() < 1e-10 * scale, "{a} vs {b}");
        }
    }

    #[test]
    fn a_singular_system_is_refused() {
        // the chain without its transverse constraints has free transverse and rotational motion
        let chain = ChainSpec { grains: 5, ..ChainSpec::default() };
        let snap = chain.build().unwrap().snapshot();
        let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
        let system = dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap();
        let err = solve_static_direct(&system, &vec![1.0; system.dofs()]).unwrap_err();
        assert!(err.to_string().contains("not positive definite"), "{err}");
    }
}
