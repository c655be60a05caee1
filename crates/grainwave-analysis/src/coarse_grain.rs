//! Coarse-grained fields (SPEC §4): Gaussian smoothing of point values along a line, and the
//! Goldhirsch coarse-grained density and stress of a snapshot on a regular grid.
//!
//! # Along a line
//!
//! Point values v_k at positions x_k (e.g. the vertical force of each floor contact) become the
//! line density
//!
//! ```text
//! p(x) = Σ_k v_k φ_w(x − x_k),      φ_w(x) = (1/(w√π)) e^{−(x/w)²},      ∫ φ_w dx = 1,
//! ```
//!
//! so ∫ p dx = Σ_k v_k: the smoothed floor stress integrates to the total floor force.
//!
//! # Fields of a snapshot
//!
//! With the normalized Gaussian φ(r) = e^{−|r|²/w²}/(π^{d/2} w^d) of width w,
//!
//! ```text
//! ρ(r)    = Σ_i m_i φ(r − r_i)
//! σ_αβ(r) = − Σ_c f_α b_β ∫₀¹ φ(r − r_i − s b) ds  +  Σ_i m_i v'_α v'_β φ(r − r_i)   (kinetic part, optional)
//! ```
//!
//! where the first sum runs over contacts c (each once), f is the force on grain i of the contact
//! and b its branch vector (centre of i → centre of j, nearest image; for a wall contact, centre of
//! i → contact point on the wall), and v'_i = v_i − V(r) with V = (Σ m_i v_i φ)/ρ. This is the
//! SPEC's −½ Σ_{i,j} f_ij r_ij ∫ φ over ordered pairs with r_ij = r_j − r_i and the line integral
//! taken along the segment from r_i to r_j. **Compressive stresses are positive**: two grains
//! pushed together have f·b < 0. Integrated over all space the contact part gives −Σ_c f ⊗ b =
//! V σ_virial ([`crate::stress::contact_stress`]), and in a uniformly strained lattice the field
//! equals the virial stress wherever the Gaussian does not reach a boundary (up to a ripple
//! ∝ e^{−|G|²w²/4}, G the shortest reciprocal-lattice vector: 2e-6 for w equal to the spacing of a
//! triangular lattice).
//!
//! The line integral is exact:
//!
//! ```text
//! ∫₀¹ e^{−|d − s b|²/w²} ds = e^{−d_⊥²/w²} (w√π / (2|b|)) [erf(|b|(1 − s₀)/w) + erf(|b| s₀/w)],
//! d = r − r_i,  s₀ = d·b/|b|²,  d_⊥² = |d|² − (d·b)²/|b|².
//! ```
//!
//! Contributions are cut off beyond `cutoff` widths from a segment (default 6: relative error
//! e^{−36} ≈ 2e-16). Along periodic axes every image of a contact within the cut-off of the grid is
//! included. Each grid row is summed in parallel, contact by contact in a fixed order, so the
//! result does not depend on the number of threads.
//!
//! ```
//! use grainwave_analysis::coarse_grain::{gaussian_1d, smooth_1d};
//! let x = [-1.0, 0.0, 1.0];
//! let v = [1.0, 2.0, 1.0];
//! let grid: Vec<f64> = (-400..=400).map(|k| k as f64 * 0.05).collect();
//! let p = smooth_1d(&x, &v, 3.0, &grid);
//! let integral: f64 = p.iter().sum::<f64>() * 0.05;
//! assert!((integral - 4.0).abs() < 1e-9);
//! assert!((gaussian_1d(0.0, 2.0) - 1.0 / (2.0 * std::f64::consts::PI.sqrt())).abs() < 1e-15);
//! ```

use crate::special::erf_difference;
use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::snapshot::{Counterpart, Snapshot};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The normalized 1D Gaussian φ_w(x) = (1/(w√π)) e^{−(x/w)²}.
#[inline]
pub fn gaussian_1d(x: f64, width: f64) -> f64 {
    let u = x / width;
    (-u * u).exp() / (width * PI.sqrt())
}

/// p(x) = Σ_k v_k φ_w(x − x_k) at every point of `grid` (positions and values of equal length).
pub fn smooth_1d(positions: &[f64], values: &[f64], width: f64, grid: &[f64]) -> Vec<f64> {
    assert_eq!(positions.len(), values.len(), "positions and values must have the same length");
    grid.iter().map(|&x| positions.iter().zip(values).map(|(&xk, &vk)| vk * gaussian_1d(x - xk, width)).sum()).collect()
}

/// A regular grid: points `origin + (i₀ s₀, i₁ s₁[, i₂ s₂])`, i_k < `counts[k]`, stored with the
/// first index fastest (index = i₀ + n₀ (i₁ + n₁ i₂)). In 2D `counts[2]` must be 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Grid<D: Dim> {
    /// First point.
    pub origin: D::Vector,
    /// Spacing along each axis (> 0).
    pub spacing: D::Vector,
    /// Points along each axis (≥ 1; the third is 1 in 2D).
    pub counts: [usize; 3],
}

impl<D: Dim> Grid<D> {
    /// The grid covering [lo, hi] with spacing close to `step` (at least two points per axis
    /// where lo < hi).
    pub fn covering(lo: D::Vector, hi: D::Vector, step: f64) -> Self {
        let mut counts = [1usize; 3];
        let mut spacing = D::Vector::ZERO;
        for k in 0..D::D {
            let span = hi.get(k) - lo.get(k);
            let n = if span > 0.0 { ((span / step).round() as usize).max(1) + 1 } else { 1 };
            counts[k] = n;
            spacing.set(k, if n > 1 { span / (n - 1) as f64 } else { step });
        }
        Grid { origin: lo, spacing, counts }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.counts.iter().product()
    }

    /// True when the grid has no point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Coordinates of point `index`.
    pub fn point(&self, index: usize) -> D::Vector {
        let mut p = self.origin;
        let mut rest = index;
        for k in 0..D::D {
            let i = rest % self.counts[k];
            rest /= self.counts[k];
            p.set(k, self.origin.get(k) + i as f64 * self.spacing.get(k));
        }
        p
    }

    /// Coordinates along axis `k`.
    pub fn axis(&self, k: usize) -> Vec<f64> {
        (0..self.counts[k]).map(|i| self.origin.get(k) + i as f64 * self.spacing.get(k)).collect()
    }

    fn check(&self) {
        for k in 0..D::D {
            assert!(self.counts[k] >= 1 && self.spacing.get(k) > 0.0, "grid axis {k}: counts ≥ 1 and spacing > 0 required");
        }
        for k in D::D..3 {
            assert_eq!(self.counts[k], 1, "a {}D grid has counts[{k}] = 1", D::D);
        }
    }
}

/// Options of [`coarse_grain`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CoarseGrainOptions {
    /// Width w of the Gaussian (length).
    pub width: f64,
    /// Contributions farther than `cutoff` × w are neglected (default 6).
    pub cutoff: f64,
    /// Include the kinetic part Σ m v'v' φ (default false: static states).
    pub kinetic: bool,
    /// Include grain–wall contacts (default true; the segment ends at the contact point).
    pub walls: bool,
}

impl Default for CoarseGrainOptions {
    fn default() -> Self {
        CoarseGrainOptions { width: 1.0, cutoff: 6.0, kinetic: false, walls: true }
    }
}

/// Coarse-grained density and stress on a grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct CoarseGrainedFields<D: Dim> {
    /// The grid.
    pub grid: Grid<D>,
    /// ρ at every grid point (mass per area in 2D, per volume in 3D).
    pub density: Vec<f64>,
    /// σ at every grid point, d × d row-major per point (point-major), compression positive.
    pub stress: Vec<f64>,
}

impl<D: Dim> CoarseGrainedFields<D> {
    /// σ_αβ at grid point `index`.
    pub fn stress_at(&self, index: usize, alpha: usize, beta: usize) -> f64 {
        self.stress[index * D::D * D::D + alpha * D::D + beta]
    }

    /// The component σ_αβ over the whole grid.
    pub fn component(&self, alpha: usize, beta: usize) -> Vec<f64> {
        (0..self.grid.len()).map(|k| self.stress_at(k, alpha, beta)).collect()
    }

    /// Field difference `self − other` (same grid required).
    pub fn minus(&self, other: &Self) -> Self {
        assert_eq!(self.grid, other.grid, "fields on different grids");
        CoarseGrainedFields {
            grid: self.grid.clone(),
            density: self.density.iter().zip(&other.density).map(|(a, b)| a - b).collect(),
            stress: self.stress.iter().zip(&other.stress).map(|(a, b)| a - b).collect(),
        }
    }
}

/// One force-carrying segment (a contact, or a periodic image of one).
#[derive(Clone, Copy, Debug)]
struct Segment<V> {
    start: V,
    branch: V,
    force: V,
    lo: V,
    hi: V,
}

/// Grain data for the density and kinetic parts.
#[derive(Clone, Copy, Debug)]
struct Particle<V> {
    pos: V,
    mass: f64,
    vel: V,
}

/// Shifts along periodic axes that bring the box [lo, hi] within reach of the grid box.
fn image_shifts<D: Dim>(snapshot: &Snapshot<D>, lo: D::Vector, hi: D::Vector, glo: D::Vector, ghi: D::Vector) -> Vec<D::Vector> {
    let mut shifts = vec![D::Vector::ZERO];
    for k in 0..D::D {
        if !snapshot.domain.is_periodic(k) {
            continue;
        }
        let l = snapshot.domain.length(k);
        let n_min = ((glo.get(k) - hi.get(k)) / l).ceil() as i64;
        let n_max = ((ghi.get(k) - lo.get(k)) / l).floor() as i64;
        let mut next = Vec::new();
        for s in &shifts {
            for n in n_min..=n_max {
                let mut t = *s;
                t.set(k, n as f64 * l);
                next.push(t);
            }
        }
        shifts = next;
    }
    shifts
}

/// Coarse-grained density and stress of `snapshot` on `grid` (see the module docs).
pub fn coarse_grain<D: Dim>(snapshot: &Snapshot<D>, grid: &Grid<D>, options: &CoarseGrainOptions) -> CoarseGrainedFields<D> {
    grid.check();
    assert!(options.width > 0.0 && options.cutoff > 0.0, "width and cutoff must be > 0");
    let w = options.width;
    let reach = options.cutoff * w;
    let d = D::D;
    let glo = grid.origin;
    let mut ghi = grid.origin;
    for k in 0..d {
        ghi.set(k, grid.origin.get(k) + (grid.counts[k] - 1) as f64 * grid.spacing.get(k));
    }
    let widen = |a: D::Vector, b: D::Vector| {
        let (mut lo, mut hi) = (a, a);
        for k in 0..d {
            lo.set(k, a.get(k).min(b.get(k)) - reach);
            hi.set(k, a.get(k).max(b.get(k)) + reach);
        }
        (lo, hi)
    };
    let overlaps = |lo: D::Vector, hi: D::Vector| (0..d).all(|k| hi.get(k) >= glo.get(k) && lo.get(k) <= ghi.get(k));

    let index = snapshot.index_by_id();
    let mut segments = Vec::with_capacity(snapshot.contacts.len());
    for c in &snapshot.contacts {
        if !options.walls && matches!(c.j, Counterpart::Wall(_)) {
            continue;
        }
        let start = snapshot.pos[index[c.i as usize]];
        let (lo, hi) = widen(start, start + c.branch);
        for shift in image_shifts(snapshot, lo, hi, glo, ghi) {
            let (lo, hi) = (lo + shift, hi + shift);
            if overlaps(lo, hi) {
                segments.push(Segment { start: start + shift, branch: c.branch, force: c.force_on_i(), lo, hi });
            }
        }
    }
    let mut particles = Vec::with_capacity(snapshot.len());
    for k in 0..snapshot.len() {
        let p = snapshot.pos[k];
        let (lo, hi) = widen(p, p);
        for shift in image_shifts(snapshot, lo, hi, glo, ghi) {
            if overlaps(lo + shift, hi + shift) {
                particles.push(Particle { pos: p + shift, mass: snapshot.mass[k], vel: snapshot.vel[k] });
            }
        }
    }

    let norm = 1.0 / (PI.powf(0.5 * d as f64) * w.powi(d as i32));
    let inv_w2 = 1.0 / (w * w);
    // rows: all points sharing the indices of axes 1.. (the first axis runs inside a row)
    let n0 = grid.counts[0];
    let rows = grid.len() / n0;
    let row_results: Vec<(Vec<f64>, Vec<f64>)> = (0..rows)
        .into_par_iter()
        .map(|row| {
            let first = grid.point(row * n0);
            let in_row = |lo: D::Vector, hi: D::Vector| (1..d).all(|k| first.get(k) >= lo.get(k) && first.get(k) <= hi.get(k));
            let mut density = vec![0.0; n0];
            let mut momentum = vec![D::Vector::ZERO; n0];
            let mut stress = vec![0.0; n0 * d * d];
            let x_of = |i: usize| grid.origin.get(0) + i as f64 * grid.spacing.get(0);
            let range = |lo: f64, hi: f64| {
                let s = grid.spacing.get(0);
                let a = ((lo - grid.origin.get(0)) / s).ceil().max(0.0) as usize;
                let b = (((hi - grid.origin.get(0)) / s).floor() as i64).min(n0 as i64 - 1);
                if b < a as i64 {
                    a..a
                } else {
                    a..(b as usize + 1)
                }
            };
            for seg in &segments {
                if !in_row(seg.lo, seg.hi) {
                    continue;
                }
                let b2 = seg.branch.norm2();
                let bl = b2.sqrt();
                for i in range(seg.lo.get(0), seg.hi.get(0)) {
                    let mut r = first;
                    r.set(0, x_of(i));
                    let dv = r - seg.start;
                    let weight = if bl > 0.0 {
                        let s0 = dv.dot(seg.branch) / b2;
                        let perp2 = (dv.norm2() - s0 * s0 * b2).max(0.0);
                        let line = (w * PI.sqrt() / (2.0 * bl)) * erf_difference(-bl * s0 / w, bl * (1.0 - s0) / w);
                        norm * (-perp2 * inv_w2).exp() * line
                    } else {
                        norm * (-dv.norm2() * inv_w2).exp()
                    };
                    if weight == 0.0 {
                        continue;
                    }
                    let out = &mut stress[i * d * d..(i + 1) * d * d];
                    for a in 0..d {
                        for b in 0..d {
                            out[a * d + b] -= seg.force.get(a) * seg.branch.get(b) * weight;
                        }
                    }
                }
            }
            let mut weights: Vec<Vec<(usize, f64)>> = Vec::new();
            for p in &particles {
                let (lo, hi) = widen(p.pos, p.pos);
                if !in_row(lo, hi) {
                    if options.kinetic {
                        weights.push(Vec::new());
                    }
                    continue;
                }
                let mut ws = Vec::new();
                for i in range(lo.get(0), hi.get(0)) {
                    let mut r = first;
                    r.set(0, x_of(i));
                    let phi = norm * (-(r - p.pos).norm2() * inv_w2).exp();
                    density[i] += p.mass * phi;
                    momentum[i] += p.vel * (p.mass * phi);
                    if options.kinetic {
                        ws.push((i, phi));
                    }
                }
                if options.kinetic {
                    weights.push(ws);
                }
            }
            if options.kinetic {
                let mut kp = 0;
                for p in &particles {
                    let ws = &weights[kp];
                    kp += 1;
                    for &(i, phi) in ws {
                        let v_mean = if density[i] > 0.0 { momentum[i] / density[i] } else { D::Vector::ZERO };
                        let dv = p.vel - v_mean;
                        let out = &mut stress[i * d * d..(i + 1) * d * d];
                        for a in 0..d {
                            for b in 0..d {
                                out[a * d + b] += p.mass * dv.get(a) * dv.get(b) * phi;
                            }
                        }
                    }
                }
            }
            (density, stress)
        })
        .collect();
    let mut density = Vec::with_capacity(grid.len());
    let mut stress = Vec::with_capacity(grid.len() * d * d);
    for (rho, sigma) in row_results {
        density.extend(rho);
        stress.extend(sigma);
    }
    CoarseGrainedFields { grid: grid.clone(), density, stress }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_integral_matches_quadrature() {
        // the closed form of ∫₀¹ e^{−|d − s b|²/w²} ds against a fine midpoint rule
        let (w, b) = (0.7f64, [1.3f64, -0.4]);
        for d in [[0.2, 0.1], [2.5, -1.0], [-1.5, 0.3], [0.65, -0.2]] {
            let n = 200_000;
            let q: f64 = (0..n)
                .map(|k| {
                    let s = (k as f64 + 0.5) / n as f64;
                    let (x, y) = (d[0] - s * b[0], d[1] - s * b[1]);
                    (-(x * x + y * y) / (w * w)).exp()
                })
                .sum::<f64>()
                / n as f64;
            let b2 = b[0] * b[0] + b[1] * b[1];
            let bl = b2.sqrt();
            let s0 = (d[0] * b[0] + d[1] * b[1]) / b2;
            let perp2 = d[0] * d[0] + d[1] * d[1] - s0 * s0 * b2;
            let closed = (-perp2 / (w * w)).exp() * (w * PI.sqrt() / (2.0 * bl)) * erf_difference(-bl * s0 / w, bl * (1.0 - s0) / w);
            assert!((closed - q).abs() < 1e-10, "{closed} vs {q}");
        }
    }

    #[test]
    fn grid_points_and_axes() {
        use glam::DVec2;
        let g = Grid::<grainwave_core::dim::D2>::covering(DVec2::new(-1.0, 0.0), DVec2::new(1.0, 3.0), 0.5);
        assert_eq!(g.counts, [5, 7, 1]);
        assert_eq!(g.point(0), DVec2::new(-1.0, 0.0));
        assert_eq!(g.point(6), DVec2::new(-0.5, 0.5));
        assert_eq!(g.axis(1).last().copied(), Some(3.0));
    }
}
