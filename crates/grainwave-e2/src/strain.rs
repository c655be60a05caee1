//! Strain from grain displacements (SPEC §4, §6.2): least squares of u_α,i = −ε_αα x_α,i + b over
//! all grains, with u_i = x_i − x_i^ref the displacement from a reference configuration. Strains
//! are counted positive in compression. The reference is renewed each time the strain since the
//! last one exceeds a threshold, and the increments add up ([`StrainTracker`]).

use glam::DVec2;
use serde::{Deserialize, Serialize};

/// The slope a of the least-squares line u = a x + b through the points (x_k, u_k):
/// a = Σ(x − x̄)(u − ū) / Σ(x − x̄)². Summed in the given order (deterministic). Returns 0 when the
/// x_k are all equal.
pub fn regression_slope(x: &[f64], u: &[f64]) -> f64 {
    let n = x.len() as f64;
    if x.is_empty() {
        return 0.0;
    }
    let mx = x.iter().sum::<f64>() / n;
    let mu = u.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (xi, ui) in x.iter().zip(u) {
        sxy += (xi - mx) * (ui - mu);
        sxx += (xi - mx) * (xi - mx);
    }
    if sxx > 0.0 {
        sxy / sxx
    } else {
        0.0
    }
}

/// Strains (ε_xx, ε_yy), compression positive, of the displacement from `reference` to `current`
/// (positions in the same order): ε_xx = −slope of u_x against x, ε_yy = −slope of u_y against y.
pub fn strain_between(reference: &[DVec2], current: &[DVec2]) -> (f64, f64) {
    let xs: Vec<f64> = reference.iter().map(|p| p.x).collect();
    let ys: Vec<f64> = reference.iter().map(|p| p.y).collect();
    let ux: Vec<f64> = reference.iter().zip(current).map(|(r, c)| c.x - r.x).collect();
    let uy: Vec<f64> = reference.iter().zip(current).map(|(r, c)| c.y - r.y).collect();
    (-regression_slope(&xs, &ux), -regression_slope(&ys, &uy))
}

/// Accumulated strain with re-referencing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StrainTracker {
    /// Positions (by grain id) of the current reference.
    pub reference: Vec<DVec2>,
    /// Strain (ε_xx, ε_yy) accumulated up to the current reference.
    pub accumulated: (f64, f64),
    /// Renew the reference when |ε_yy since the reference| exceeds this.
    pub threshold: f64,
}

impl StrainTracker {
    /// A tracker starting at `positions` (by grain id) with zero strain.
    pub fn new(positions: Vec<DVec2>, threshold: f64) -> Self {
        StrainTracker { reference: positions, accumulated: (0.0, 0.0), threshold }
    }

    /// The total strain at `positions` (by grain id); renews the reference when the strain since it
    /// exceeds the threshold.
    pub fn update(&mut self, positions: &[DVec2]) -> (f64, f64) {
        let (dx, dy) = strain_between(&self.reference, positions);
        let total = (self.accumulated.0 + dx, self.accumulated.1 + dy);
        if dy.abs() > self.threshold || dx.abs() > self.threshold {
            self.accumulated = total;
            self.reference = positions.to_vec();
        }
        total
    }
}

/// Positions ordered by grain id.
pub fn positions_by_id(g: &grainwave_core::grains::Grains<grainwave_core::dim::D2>) -> Vec<DVec2> {
    let mut p = vec![DVec2::ZERO; g.len()];
    for k in 0..g.len() {
        p[g.id[k] as usize] = g.pos[k];
    }
    p
}
