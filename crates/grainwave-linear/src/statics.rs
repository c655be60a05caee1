//! Static linear response (SPEC §5.3, §5.4): solve D_ff u_f = f_f − D_fc u_c.
//!
//! Packings have zero modes, and a static solver must not crash on them:
//!
//! 1. **zero rows** of D — dofs of grains without contacts (rattlers), rotations of frictionless
//!    grains — are removed before solving (their displacement is reported as 0 and the load on them
//!    as unbalanced);
//! 2. **rigid translations** — a uniform translation along axis k is tested as a null vector
//!    (‖D t_k‖ ≤ 1e-10 max|D_rr| ‖t_k‖): in a periodic packing without walls (or with frictionless
//!    walls parallel to k) it costs no energy. Such modes are projected out of the load and of the
//!    iterates (the solution has no net rigid translation);
//! 3. the rest is solved by Jacobi-preconditioned conjugate gradient ([`crate::linalg::cg`]). A
//!    remaining floppy mode that the load excites stops the solver with
//!    [`LinearError::NotPositiveDefinite`] — unless a Tikhonov regularization D + η diag(D) is asked
//!    for, which returns the (large, η-dependent) regularized displacement.
//!
//! ```
//! use grainwave_linear::prelude::*;
//! # use grainwave_linear::reference::ChainSpec;
//! // pull the last grain of a 10-grain chain (springs K = 1 between two walls) by a unit force
//! let chain = ChainSpec { grains: 10, stiffness: 1.0, ..ChainSpec::default() };
//! let snap = chain.build().unwrap().snapshot();
//! let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
//! let system = dm.free_system(&chain.constraints(), ZeroRows::Drop).unwrap();
//! let mut f = vec![0.0; system.dofs()];
//! let last = system.free_index(dm.layout().translation(9, 0)).unwrap();
//! f[last] = 1.0;
//! let sol = solve_static(&system, &f, &StaticOptions::default()).unwrap();
//! // 10 springs in series on the left (compliance 10/K) in parallel with 1 on the right
//! assert!((sol.displacement[last] - 10.0 / 11.0).abs() < 1e-10);
//! ```

use crate::dynamical::LinearSystem;
use crate::error::{LinearError, Result};
use crate::linalg::cg;
use serde::{Deserialize, Serialize};

/// Options of [`solve_static`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StaticOptions {
    /// Relative residual ‖f − D u‖/‖f‖ to reach (default 1e-11).
    pub tolerance: f64,
    /// Iteration limit (default 20 × dofs + 100).
    pub max_iterations: Option<usize>,
    /// Project out rigid translations that are null vectors of D (default true).
    pub deflate_rigid_translations: bool,
    /// Tikhonov regularization η: solve (D + η diag D) u = f (default 0: none). The regularized
    /// matrix has a condition number ~1/η, so its attainable relative residual is ~1e-16/η: raise
    /// `tolerance` accordingly.
    pub regularization: f64,
}

impl Default for StaticOptions {
    fn default() -> Self {
        StaticOptions { tolerance: 1e-11, max_iterations: None, deflate_rigid_translations: true, regularization: 0.0 }
    }
}

/// Solution of a static problem.
#[derive(Clone, Debug)]
pub struct StaticSolution {
    /// u_f over the free dofs of the system (0 on zero rows).
    pub displacement: Vec<f64>,
    /// CG iterations.
    pub iterations: usize,
    /// ‖f − D u‖/‖f‖ on the solved subspace.
    pub relative_residual: f64,
    /// Free dofs (indices into the system) whose row of D is zero and were left at 0.
    pub zero_rows: Vec<usize>,
    /// Number of rigid translations projected out.
    pub rigid_modes: usize,
    /// Norm of the load that no displacement can balance (on zero rows and rigid modes).
    pub unbalanced_load: f64,
}

/// Solves D_ff u = `load` + (−D_fc u_c) on the free dofs of `system` (the load of the imposed
/// displacements is added automatically).
pub fn solve_static(system: &LinearSystem, load: &[f64], options: &StaticOptions) -> Result<StaticSolution> {
    system.require_symmetric("the static solver (conjugate gradient)")?;
    let n = system.dofs();
    LinearError::check_len("load", n, load.len())?;
    if !(options.tolerance > 0.0) {
        return Err(LinearError::invalid("static.tolerance", options.tolerance, "a tolerance > 0"));
    }
    if !(options.regularization >= 0.0 && options.regularization.is_finite()) {
        return Err(LinearError::invalid("static.regularization", options.regularization, "a finite number ≥ 0"));
    }
    let d = system.stiffness();
    let s = d.symbolic();
    let (rp, ci, val) = (s.row_ptr(), s.col_idx(), d.val());
    let f: Vec<f64> = load.iter().zip(system.constraint_load()).map(|(a, b)| a + b).collect();
    // 1. zero rows
    let zero_rows: Vec<usize> = (0..n).filter(|&r| val[rp[r]..rp[r + 1]].iter().all(|&v| v == 0.0)).collect();
    let mut keep = vec![usize::MAX; n];
    let mut kept = Vec::with_capacity(n);
    {
        let mut z = zero_rows.iter().peekable();
        for r in 0..n {
            if z.peek() == Some(&&r) {
                z.next();
            } else {
                keep[r] = kept.len();
                kept.push(r);
            }
        }
    }
    let mut unbalanced2: f64 = zero_rows.iter().map(|&r| f[r] * f[r]).sum();
    let m = kept.len();
    let mut displacement = vec![0.0; n];
    if m == 0 {
        return Ok(StaticSolution { displacement, iterations: 0, relative_residual: 0.0, zero_rows, rigid_modes: 0, unbalanced_load: unbalanced2.sqrt() });
    }
    let diag_full = system.diagonal();
    let eta = options.regularization;
    let diag: Vec<f64> = kept.iter().map(|&r| diag_full[r] * (1.0 + eta)).collect();
    if let Some(k) = diag.iter().position(|&x| !(x > 0.0)) {
        return Err(LinearError::NotPositiveDefinite { iteration: 0, curvature: diag[k] });
    }
    let apply = |x: &[f64], y: &mut [f64]| {
        // y = D_kk x, rows of kept dofs, columns restricted to kept dofs
        use rayon::prelude::*;
        y.par_iter_mut().enumerate().with_min_len(512).for_each(|(a, ya)| {
            let r = kept[a];
            let mut acc = 0.0;
            for e in rp[r]..rp[r + 1] {
                let c = keep[ci[e]];
                if c != usize::MAX {
                    acc += val[e] * x[c];
                }
            }
            *ya = acc + eta * diag_full[r] * x[a];
        });
    };
    let b: Vec<f64> = kept.iter().map(|&r| f[r]).collect();
    // 2. rigid translations
    let mut null: Vec<Vec<f64>> = Vec::new();
    if options.deflate_rigid_translations && eta == 0.0 {
        let layout = system.layout();
        let free = system.free_dofs();
        let scale = diag.iter().cloned().fold(0.0, f64::max);
        for axis in 0..layout.translational {
            let t: Vec<f64> = kept.iter().map(|&r| if layout.component_of(free[r]) == axis { 1.0 } else { 0.0 }).collect();
            let norm = t.iter().map(|x| x * x).sum::<f64>().sqrt();
            if norm == 0.0 {
                continue;
            }
            let mut dt = vec![0.0; m];
            apply(&t, &mut dt);
            let dn = dt.iter().map(|x| x * x).sum::<f64>().sqrt();
            if dn <= 1e-10 * scale * norm {
                null.push(t.iter().map(|x| x / norm).collect());
            }
        }
    }
    let max_iterations = options.max_iterations.unwrap_or(20 * m + 100);
    let sol = cg::solve(&apply, &diag, &b, &null, options.tolerance, max_iterations)?;
    unbalanced2 += sol.null_load * sol.null_load;
    for (a, &r) in kept.iter().enumerate() {
        displacement[r] = sol.x[a];
    }
    Ok(StaticSolution {
        displacement,
        iterations: sol.iterations,
        relative_residual: sol.relative_residual,
        zero_rows,
        rigid_modes: null.len(),
        unbalanced_load: unbalanced2.sqrt(),
    })
}
