//! All eigenmodes of a [`LinearSystem`]: the generalized symmetric eigenproblem
//!
//! ```text
//! D v_n = ω_n² M v_n,      v_mᵀ M v_n = δ_mn      (mass-normalized modes)
//! ```
//!
//! solved densely: with M diagonal and positive, A = M^{-1/2} D M^{-1/2} is symmetric with the same
//! eigenvalues; faer's self-adjoint eigensolver gives A = W Λ Wᵀ and v_n = M^{-1/2} w_n. Cost
//! O(n³) time and 2–3 dense n × n matrices of memory (n = free dofs): 1 800 dofs (600 grains in 2D)
//! take about a second, 6 000 dofs tens of seconds.
//!
//! **Participation ratio** of mode n: with e_g = Σ_{k ∈ g} m_k v_{kn}² the share of grain g in the
//! mode's kinetic energy (Σ_g e_g = 1, translations and rotations together),
//!
//! ```text
//! P_n = (Σ_g e_g)² / (N Σ_g e_g²) = 1 / (N Σ_g e_g²)
//! ```
//!
//! over the N grains that have a free dof: 1 when every grain moves alike, ~1/N for a mode
//! localized on one grain.

use crate::dynamical::LinearSystem;
use crate::error::{LinearError, Result};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd;
use faer::diag::Diag;
use faer::{Mat, MatRef, Par};
use serde::{Deserialize, Serialize};

/// Options of [`Modes::compute`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EigenOptions {
    /// Refuse dense decompositions of more free dofs than this (default 20 000 ≈ 10 GiB).
    pub max_dense_dofs: usize,
    /// Threads of the dense eigensolver: `None` (default) follows faer's global setting (all
    /// threads of the current rayon pool), `Some(1)` runs on one thread, `Some(n)` on n. faer's
    /// blocked algorithms split the work by thread count, so the modes are reproducible bit for bit
    /// only at a fixed count: `Some(1)` makes them independent of the pool (E1 ensembles, which
    /// run samples in parallel anyway).
    pub threads: Option<usize>,
}

impl Default for EigenOptions {
    fn default() -> Self {
        EigenOptions { max_dense_dofs: 20_000, threads: None }
    }
}

/// The zero space of [`Modes`] split by where it lives ([`Modes::zero_space_split`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ZeroSpaceSplit {
    /// Zero modes: |ω²| ≤ tolerance × max |ω²|.
    pub zero_modes: usize,
    /// Dimension of the part of the zero space on the selected dofs: eigenvalues of
    /// P = Zᵀ M_S Z at or above the weight threshold.
    pub localized: usize,
    /// Eigenvalues of P (the selected dofs' share of the kinetic energy along the principal
    /// directions of the zero space), decreasing, each in [0, 1] up to rounding.
    pub weights: Vec<f64>,
}

/// Eigenmodes of a linear system, sorted by increasing ω².
#[derive(Clone, Debug)]
pub struct Modes {
    omega_squared: Vec<f64>,
    vectors: Mat<f64>,
    participation: Vec<f64>,
    mass: Vec<f64>,
    free: Vec<usize>,
}

impl Modes {
    /// Solves D v = ω² M v for every mode of `system`.
    pub fn compute(system: &LinearSystem, options: &EigenOptions) -> Result<Modes> {
        system.require_symmetric("the eigen-decomposition")?;
        let n = system.dofs();
        if n > options.max_dense_dofs {
            return Err(LinearError::TooLargeForDense { dofs: n, limit: options.max_dense_dofs, gib: 3.0 * (n * n * 8) as f64 / (1u64 << 30) as f64 });
        }
        let mass = system.mass().to_vec();
        let inv_sqrt: Vec<f64> = mass.iter().map(|m| 1.0 / m.sqrt()).collect();
        let mut a = Mat::<f64>::zeros(n, n);
        let d = system.stiffness();
        let s = d.symbolic();
        let (rp, ci, v) = (s.row_ptr(), s.col_idx(), d.val());
        for r in 0..n {
            for e in rp[r]..rp[r + 1] {
                let c = ci[e];
                a[(r, c)] = v[e] * inv_sqrt[r] * inv_sqrt[c];
            }
        }
        let par = match options.threads {
            None => faer::get_global_parallelism(),
            Some(0 | 1) => Par::Seq,
            Some(t) => Par::rayon(t),
        };
        let mut u = Mat::<f64>::zeros(n, n);
        let mut s = Diag::<f64>::zeros(n);
        let scratch = evd::self_adjoint_evd_scratch::<f64>(n, evd::ComputeEigenvectors::Yes, par, Default::default());
        evd::self_adjoint_evd(a.as_ref(), s.as_mut(), Some(u.as_mut()), par, MemStack::new(&mut MemBuffer::new(scratch)), Default::default())
            .map_err(|e| LinearError::Eigen { dofs: n, reason: format!("{e:?}") })?;
        drop(a);
        let omega_squared: Vec<f64> = (0..n).map(|k| s[k]).collect();
        let mut vectors = Mat::<f64>::zeros(n, n);
        for c in 0..n {
            for r in 0..n {
                vectors[(r, c)] = u[(r, c)] * inv_sqrt[r];
            }
        }
        drop(u);
        let free = system.free_dofs().to_vec();
        let per_grain = system.layout().per_grain();
        let participation = participation_ratios(vectors.as_ref(), &mass, &free, per_grain);
        Ok(Modes { omega_squared, vectors, participation, mass, free })
    }

    /// Number of modes (= free dofs).
    pub fn len(&self) -> usize {
        self.omega_squared.len()
    }

    /// True when there is no mode.
    pub fn is_empty(&self) -> bool {
        self.omega_squared.is_empty()
    }

    /// Eigenvalues ω_n² (increasing; tiny negative values are round-off of zero modes, larger
    /// negative ones instabilities of a pre-stressed system).
    pub fn omega_squared(&self) -> &[f64] {
        &self.omega_squared
    }

    /// Angular frequencies ω_n = √max(ω_n², 0).
    pub fn frequencies(&self) -> Vec<f64> {
        self.omega_squared.iter().map(|&w| w.max(0.0).sqrt()).collect()
    }

    /// Mass-normalized modes as the columns of a (free dofs × modes) matrix.
    pub fn vectors(&self) -> MatRef<'_, f64> {
        self.vectors.as_ref()
    }

    /// Mode `n` over the free dofs.
    pub fn mode(&self, n: usize) -> Vec<f64> {
        (0..self.len()).map(|r| self.vectors[(r, n)]).collect()
    }

    /// Participation ratios P_n.
    pub fn participation(&self) -> &[f64] {
        &self.participation
    }

    /// Diagonal of M over the free dofs.
    pub fn mass(&self) -> &[f64] {
        &self.mass
    }

    /// Full dof index of each free dof.
    pub fn free_dofs(&self) -> &[usize] {
        &self.free
    }

    /// The largest |ω²| of a zero mode: `tolerance` × max |ω²|.
    fn zero_threshold(&self, tolerance: f64) -> f64 {
        tolerance * self.omega_squared.iter().fold(0.0_f64, |a, &b| a.max(b.abs()))
    }

    /// Number of modes with |ω²| ≤ `tolerance` × max |ω²| (the zero modes).
    pub fn zero_modes(&self, tolerance: f64) -> usize {
        let threshold = self.zero_threshold(tolerance);
        self.omega_squared.iter().filter(|&&w| w.abs() <= threshold).count()
    }

    /// The gap above the zero modes: the smallest |ω²| that is not a zero mode (see
    /// [`Modes::zero_modes`]) over max |ω²|; ∞ when every mode is a zero mode.
    pub fn zero_mode_gap(&self, tolerance: f64) -> f64 {
        let scale = self.zero_threshold(1.0);
        let threshold = tolerance * scale;
        self.omega_squared.iter().map(|w| w.abs()).filter(|&w| w > threshold).fold(f64::INFINITY, f64::min) / scale
    }

    /// Splits the zero space (the modes with |ω²| ≤ `tolerance` × max |ω²|) by where it lives: the
    /// dimension of its part carried by the `selected` free dofs (e.g. the rattlers' dofs).
    ///
    /// With Z = [v_n] the k M-normalized zero modes (Zᵀ M Z = I) and M_S the mass restricted to the
    /// selected dofs, the k × k matrix
    ///
    /// ```text
    /// P = Zᵀ M_S Z,      P_ab = Σ_{r selected} m_r v_ra v_rb
    /// ```
    ///
    /// has eigenvalues cos² θ_a ∈ [0, 1], θ_a the principal angles (in the M inner product)
    /// between the zero space and the selected dofs: an eigenvalue 1 is a zero-energy motion
    /// entirely on the selected dofs, 0 one without any part there. Its eigenvalues do not
    /// depend on which basis the eigensolver chose inside the (degenerate) zero space, where the
    /// weight Σ m_r v_rn² of single modes does: a rattler's free translation can come out mixed
    /// with a backbone mechanism. `localized` counts the eigenvalues ≥ `weight` (e.g. 0.99: at
    /// least 99 % of the kinetic energy on the selected dofs).
    pub fn zero_space_split(&self, tolerance: f64, selected: &[bool], weight: f64) -> Result<ZeroSpaceSplit> {
        LinearError::check_len("selected", self.len(), selected.len())?;
        let threshold = self.zero_threshold(tolerance);
        let zero: Vec<usize> = (0..self.len()).filter(|&n| self.omega_squared[n].abs() <= threshold).collect();
        let k = zero.len();
        let rows: Vec<usize> = (0..self.len()).filter(|&r| selected[r]).collect();
        let mut p = Mat::<f64>::zeros(k, k);
        for a in 0..k {
            let va = self.vectors.col(zero[a]);
            for b in 0..=a {
                let vb = self.vectors.col(zero[b]);
                let s: f64 = rows.iter().map(|&r| self.mass[r] * va[r] * vb[r]).sum();
                p[(a, b)] = s;
                p[(b, a)] = s;
            }
        }
        let mut s = Diag::<f64>::zeros(k);
        if k > 0 {
            let scratch = evd::self_adjoint_evd_scratch::<f64>(k, evd::ComputeEigenvectors::No, Par::Seq, Default::default());
            evd::self_adjoint_evd(p.as_ref(), s.as_mut(), None, Par::Seq, MemStack::new(&mut MemBuffer::new(scratch)), Default::default())
                .map_err(|e| LinearError::Eigen { dofs: k, reason: format!("{e:?}") })?;
        }
        let mut weights: Vec<f64> = (0..k).map(|a| s[a]).collect();
        weights.sort_by(|a, b| b.total_cmp(a));
        let localized = weights.iter().filter(|&&w| w >= weight).count();
        Ok(ZeroSpaceSplit { zero_modes: k, localized, weights })
    }

    /// Projections v_nᵀ M x of a free-dof vector on every mode.
    pub fn project(&self, x: &[f64]) -> Result<Vec<f64>> {
        LinearError::check_len("x", self.len(), x.len())?;
        let mx: Vec<f64> = x.iter().zip(&self.mass).map(|(a, m)| a * m).collect();
        Ok(self.transpose_times(&mx))
    }

    /// Vᵀ y for a free-dof vector y (e.g. couplings b_n = v_nᵀ c of a detector).
    pub fn transpose_times(&self, y: &[f64]) -> Vec<f64> {
        let n = self.len();
        let mut out = vec![0.0; n];
        for (c, o) in out.iter_mut().enumerate() {
            let col = self.vectors.col(c);
            let mut s = 0.0;
            for r in 0..n {
                s += col[r] * y[r];
            }
            *o = s;
        }
        out
    }
}

fn participation_ratios(v: MatRef<'_, f64>, mass: &[f64], free: &[usize], per_grain: usize) -> Vec<f64> {
    // group free dofs by grain
    let mut grain_of = Vec::with_capacity(free.len());
    let mut count = 0usize;
    let mut last = usize::MAX;
    for &f in free {
        let g = f / per_grain;
        if g != last {
            count += 1;
            last = g;
        }
        grain_of.push(count - 1);
    }
    let n = free.len();
    let mut share = vec![0.0; count];
    (0..v.ncols())
        .map(|c| {
            share.iter_mut().for_each(|s| *s = 0.0);
            let col = v.col(c);
            for r in 0..n {
                share[grain_of[r]] += mass[r] * col[r] * col[r];
            }
            let total: f64 = share.iter().sum();
            let sq: f64 = share.iter().map(|e| e * e).sum();
            total * total / (count as f64 * sq)
        })
        .collect()
}
