//! Static equilibrium of a frictionless packing with Hooke contacts by active-set Newton
//! iterations (SPEC §3, "faster relaxation to static equilibrium").
//!
//! Frictionless packings relax slowly under damped dynamics: their softest modes barely stretch
//! any dashpot (a 15 × 60 lattice slab under gravity needs ~800 τ). Their static state, however, is
//! the minimum of an energy and can be computed directly. Around the current positions every pair
//! of grains closer than `gap` (and every grain closer than `gap` to a wall) is a *candidate*
//! contact c with gap g_c (negative when overlapping), normal n̂_c and stiffness k_c. To first
//! order in the displacements u the overlap is ξ_c(u) = −g_c − a_c·u (a_c·u = n̂·(u_j − u_i) for a
//! pair, n̂_wall·u_i for a wall, n̂_wall its inward normal), and the equilibrium minimizes the convex
//! function
//!
//! ```text
//! Φ(u) = Σ_c ½ k_c max(0, ξ_c(u))² − Σ_i f_i·u_i          (f: gravity and external forces)
//! ```
//!
//! A semi-smooth Newton iteration finds it: with the active set A = {c : ξ_c(u) > 0} fixed,
//! Σ_{c∈A} k_c a_c a_cᵀ u = f − Σ_{c∈A} k_c g_c a_c (sparse Cholesky); the step is shortened until
//! Φ decreases (Armijo), the active set is updated — a contact that the step would put in tension
//! leaves it, a gap that the step closes joins it — until it no longer changes. The grains then
//! move by u (at most `gap`/2 per outer iteration) and the geometry (normals, gaps, candidates) is
//! linearized again, until the largest increment is below `tolerance` (SPEC: 1e-14 R̄). Because
//! the candidates include contacts that are barely open, the active set is the physical one even
//! where the closed contacts alone would form an isostatic (nearly floppy) network — e.g. the
//! horizontal contacts of a lattice under gravity; and Φ being convex, every accepted step is a
//! descent step.
//!
//! Only Hooke normal laws are supported; rotations play no role (no tangential forces). A grain
//! with no active contact, if any, is held by a regularization of 1e-12 × the largest stiffness
//! (its step is then limited by the `gap`/2 cap).
//!
//! ```
//! use grainwave_linear::frictionless_equilibrium::{frictionless_equilibrium, EquilibriumOptions};
//! # use grainwave_core::prelude::*;
//! # use glam::DVec2;
//! // one disk (m = 1, g = 1) resting on a floor spring k = 100: it sinks by mg/k = 0.01
//! let mut p = ContactParams::preset("hooke_cundall_strack");
//! p.normal_stiffness = Some(100.0);
//! p.friction = Some(0.0);
//! let law = p.build(Partner::Grain, "contact").unwrap();
//! let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
//! g.push_with_mass(DVec2::new(0.0, 1.0), 1.0, 1.0, DVec2::ZERO);
//! let domain = Domain::new(DVec2::new(-5.0, 0.0), DVec2::new(5.0, 5.0), [false; 3])
//!     .with_wall(Wall::axis_aligned("floor", 1, 0.0, true, law));
//! let sim = SimulationBuilder::new(g, domain, law).build().unwrap();
//! let sol = frictionless_equilibrium(&sim.snapshot(), &[DVec2::new(0.0, -1.0)], &EquilibriumOptions::default()).unwrap();
//! assert!((sol.displacement[0].y + 0.01).abs() < 1e-15);
//! ```

use crate::error::{LinearError, Result};
use faer::linalg::solvers::Solve;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use glam::DVec2;
use grainwave_core::contact::{Hooke, NormalElastic};
use grainwave_core::dim::D2;
use grainwave_core::snapshot::Snapshot;
use serde::{Deserialize, Serialize};

/// Options of [`frictionless_equilibrium`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EquilibriumOptions {
    /// Candidate contacts: pairs (and grain–wall contacts) whose gap is below this (length).
    pub gap: f64,
    /// Stop when the largest increment of an outer iteration is below this (length).
    pub tolerance: f64,
    /// At most this many outer (geometric) iterations.
    pub max_iterations: usize,
    /// At most this many active-set updates per outer iteration.
    pub max_active_set_updates: usize,
}

impl Default for EquilibriumOptions {
    fn default() -> Self {
        EquilibriumOptions { gap: 0.05, tolerance: 1e-14, max_iterations: 60, max_active_set_updates: 200 }
    }
}

/// Result of [`frictionless_equilibrium`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EquilibriumSolution {
    /// Displacement of every grain (snapshot storage order) from the snapshot's positions.
    pub displacement: Vec<DVec2>,
    /// Outer iterations done.
    pub iterations: usize,
    /// Active-set updates over all outer iterations.
    pub active_set_updates: usize,
    /// Largest increment of the last outer iteration.
    pub last_increment: f64,
    /// Closed contacts (active set) at the end.
    pub contacts: usize,
    /// The tolerance was reached.
    pub converged: bool,
}

/// A candidate contact, linearized at the current positions.
struct Candidate {
    i: usize,
    /// Grain j, or None for a wall.
    j: Option<usize>,
    /// Direction a (on j for pairs; the wall's inward normal for walls): ξ = −g − a·(u_j − u_i) or
    /// ξ = −g − a·u_i.
    a: DVec2,
    gap: f64,
    k: f64,
}

impl Candidate {
    fn overlap(&self, u: &[DVec2]) -> f64 {
        match self.j {
            Some(j) => -self.gap - self.a.dot(u[j] - u[self.i]),
            None => -self.gap - self.a.dot(u[self.i]),
        }
    }
}

fn hooke(n: &NormalElastic, what: &str) -> Result<f64> {
    match *n {
        NormalElastic::Hooke(Hooke { stiffness }) => Ok(stiffness),
        _ => Err(LinearError::Inconsistent(format!("frictionless equilibrium needs Hooke contacts; the {what} law is {n:?}"))),
    }
}

fn candidates(snapshot: &Snapshot<D2>, pos: &[DVec2], gap: f64) -> Result<Vec<Candidate>> {
    let k_pair = hooke(&snapshot.law.normal, "grain–grain")?;
    let n = pos.len();
    let r = &snapshot.radius;
    let r_max = r.iter().cloned().fold(0.0, f64::max);
    let mut out = Vec::new();
    // sweep along x (all pairs when x is periodic)
    let periodic_x = snapshot.domain.is_periodic(0);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| pos[a].x.total_cmp(&pos[b].x).then(a.cmp(&b)));
    for (oi, &i) in order.iter().enumerate() {
        for &j in &order[oi + 1..] {
            if !periodic_x && pos[j].x - pos[i].x > 2.0 * r_max + gap {
                break;
            }
            let d = snapshot.domain.displacement(pos[i], pos[j]);
            let len = d.length();
            let g = len - r[i] - r[j];
            if g < gap && len > 0.0 {
                let (a, b) = if i < j { (i, j) } else { (j, i) };
                let sign = if a == i { 1.0 } else { -1.0 };
                out.push(Candidate { i: a, j: Some(b), a: d / len * sign, gap: g, k: k_pair });
            }
        }
    }
    for wall in &snapshot.domain.walls {
        let k = hooke(&wall.law.normal, &format!("wall `{}`", wall.name))?;
        for i in 0..n {
            let g = wall.distance(pos[i]) - r[i];
            if g < gap {
                out.push(Candidate { i, j: None, a: wall.normal, gap: g, k });
            }
        }
    }
    out.sort_by_key(|c| (c.i, c.j.map_or(usize::MAX, |j| j)));
    Ok(out)
}

fn phi(cands: &[Candidate], u: &[DVec2], f: &[DVec2]) -> f64 {
    let elastic: f64 = cands
        .iter()
        .map(|c| {
            let xi = c.overlap(u);
            if xi > 0.0 {
                0.5 * c.k * xi * xi
            } else {
                0.0
            }
        })
        .sum();
    elastic - f.iter().zip(u).map(|(a, b)| a.dot(*b)).sum::<f64>()
}

/// Solves the active-set system for u.
fn solve_active(cands: &[Candidate], active: &[bool], f: &[DVec2]) -> Result<Vec<DVec2>> {
    let n = f.len();
    let mut trip: Vec<Triplet<usize, usize, f64>> = Vec::new();
    let mut rhs = Mat::<f64>::from_fn(2 * n, 1, |r, _| if r % 2 == 0 { f[r / 2].x } else { f[r / 2].y });
    let k_max = cands.iter().map(|c| c.k).fold(0.0, f64::max).max(1.0);
    for (c, _) in cands.iter().zip(active).filter(|(_, &on)| on) {
        // K += k a aᵀ on (j, j), (i, i), −k a aᵀ on (i, j); rhs −= k g a on j, += k g a on i
        let aa = [[c.a.x * c.a.x, c.a.x * c.a.y], [c.a.y * c.a.x, c.a.y * c.a.y]];
        let mut add = |p: usize, q: usize, s: f64| {
            for (x, row) in aa.iter().enumerate() {
                for (y, v) in row.iter().enumerate() {
                    if 2 * p + x >= 2 * q + y {
                        trip.push(Triplet::new(2 * p + x, 2 * q + y, s * c.k * v));
                    }
                }
            }
        };
        match c.j {
            Some(j) => {
                add(c.i, c.i, 1.0);
                add(j, j, 1.0);
                if j > c.i {
                    add(j, c.i, -1.0);
                } else {
                    add(c.i, j, -1.0);
                }
                rhs[(2 * j, 0)] -= c.k * c.gap * c.a.x;
                rhs[(2 * j + 1, 0)] -= c.k * c.gap * c.a.y;
                rhs[(2 * c.i, 0)] += c.k * c.gap * c.a.x;
                rhs[(2 * c.i + 1, 0)] += c.k * c.gap * c.a.y;
            }
            None => {
                add(c.i, c.i, 1.0);
                rhs[(2 * c.i, 0)] -= c.k * c.gap * c.a.x;
                rhs[(2 * c.i + 1, 0)] -= c.k * c.gap * c.a.y;
            }
        }
    }
    // regularization: 1e-12 k_max on every diagonal entry (holds grains without active contacts)
    for r in 0..2 * n {
        trip.push(Triplet::new(r, r, 1e-12 * k_max));
    }
    let k = SparseColMat::<usize, f64>::try_new_from_triplets(2 * n, 2 * n, &trip)
        .map_err(|e| LinearError::Inconsistent(format!("cannot build the stiffness matrix: {e:?}")))?;
    let llt =
        k.sp_cholesky(Side::Lower).map_err(|e| LinearError::Inconsistent(format!("the stiffness of the active contacts is not positive definite ({e:?})")))?;
    llt.solve_in_place(rhs.as_mut());
    Ok((0..n).map(|g| DVec2::new(rhs[(2 * g, 0)], rhs[(2 * g + 1, 0)])).collect())
}

/// Displacements that bring the frictionless packing of `snapshot` to static equilibrium under
/// the per-grain forces `external` (gravity and loads, in snapshot storage order); see the module
/// docs.
pub fn frictionless_equilibrium(snapshot: &Snapshot<D2>, external: &[DVec2], options: &EquilibriumOptions) -> Result<EquilibriumSolution> {
    let n = snapshot.len();
    if external.len() != n {
        return Err(LinearError::LengthMismatch { what: "external forces".into(), expected: n, found: external.len() });
    }
    if !(options.gap > 0.0 && options.tolerance > 0.0) {
        return Err(LinearError::invalid("gap/tolerance", format!("{} / {}", options.gap, options.tolerance), "numbers > 0"));
    }
    let mut pos = snapshot.pos.clone();
    let mut total = vec![DVec2::ZERO; n];
    let mut updates = 0;
    let mut last = f64::INFINITY;
    let mut contacts = 0;
    let mut iterations = 0;
    let mut converged = false;
    while iterations < options.max_iterations {
        iterations += 1;
        let cands = candidates(snapshot, &pos, options.gap)?;
        let zero = vec![DVec2::ZERO; n];
        let mut u = zero.clone();
        let mut active: Vec<bool> = cands.iter().map(|c| c.overlap(&u) > 0.0).collect();
        let mut value = phi(&cands, &u, external);
        for _ in 0..options.max_active_set_updates {
            updates += 1;
            let target = solve_active(&cands, &active, external)?;
            // Armijo backtracking on Φ along target − u
            let dir: Vec<DVec2> = target.iter().zip(&u).map(|(t, x)| *t - *x).collect();
            let slope: f64 = {
                // ∇Φ·dir = Σ_c k ξ (∂ξ/∂u·dir) − f·dir
                let mut s = -external.iter().zip(&dir).map(|(a, b)| a.dot(*b)).sum::<f64>();
                for c in &cands {
                    let xi = c.overlap(&u);
                    if xi > 0.0 {
                        let dxi = match c.j {
                            Some(j) => -c.a.dot(dir[j] - dir[c.i]),
                            None => -c.a.dot(dir[c.i]),
                        };
                        s += c.k * xi * dxi;
                    }
                }
                s
            };
            let mut alpha: f64 = 1.0;
            let mut accepted = None;
            for _ in 0..60 {
                let trial: Vec<DVec2> = u.iter().zip(&dir).map(|(x, d)| *x + *d * alpha).collect();
                let v = phi(&cands, &trial, external);
                if v <= value + 1e-4 * alpha * slope || alpha < 1e-12 {
                    accepted = Some((trial, v));
                    break;
                }
                alpha *= 0.5;
            }
            let Some((trial, v)) = accepted else { break };
            u = trial;
            value = v;
            let next: Vec<bool> = cands.iter().map(|c| c.overlap(&u) > 0.0).collect();
            if next == active && alpha == 1.0 {
                break;
            }
            active = next;
        }
        contacts = active.iter().filter(|&&a| a).count();
        // move, at most gap/2 per outer iteration
        let largest = u.iter().fold(0.0_f64, |a, d| a.max(d.x.abs()).max(d.y.abs()));
        let scale = if largest > 0.5 * options.gap { 0.5 * options.gap / largest } else { 1.0 };
        for g in 0..n {
            let d = u[g] * scale;
            pos[g] += d;
            total[g] += d;
        }
        last = largest * scale;
        if last < options.tolerance {
            converged = true;
            break;
        }
    }
    Ok(EquilibriumSolution { displacement: total, iterations, active_set_updates: updates, last_increment: last, contacts, converged })
}

#[cfg(test)]
mod tests {
    use super::*;
    use grainwave_core::contact::Hertz;
    use grainwave_core::prelude::*;

    /// A column of three disks (m = 1, R = 1) on a floor, initially separated by `gap`.
    fn column(gap: f64) -> Snapshot<D2> {
        let mut p = ContactParams::preset("hooke_cundall_strack");
        p.normal_stiffness = Some(1000.0);
        p.friction = Some(0.0);
        let law = p.build(Partner::Grain, "contact").unwrap();
        let mut wall = law;
        wall.normal = NormalElastic::Hooke(Hooke { stiffness: 2000.0 });
        let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        for k in 0..3 {
            g.push_with_mass(DVec2::new(5.0, 1.0 + gap + k as f64 * (2.0 + gap)), 1.0, 1.0, DVec2::ZERO);
        }
        let domain = Domain::new(DVec2::ZERO, DVec2::new(10.0, 20.0), [false; 3]).with_wall(Wall::axis_aligned("floor", 1, 0.0, true, wall));
        SimulationBuilder::new(g, domain, law).build().unwrap().snapshot()
    }

    #[test]
    fn a_column_settles_onto_the_floor_with_the_closed_form_compressions() {
        for gap in [0.0, 0.01] {
            let snap = column(gap);
            let f = vec![DVec2::new(0.0, -1.0); 3];
            let sol = frictionless_equilibrium(&snap, &f, &EquilibriumOptions::default()).unwrap();
            assert!(sol.converged, "{sol:?}");
            assert_eq!(sol.contacts, 3);
            // floor carries 3 mg: ξ_w = 3/2000; the contacts 2 mg and mg: ξ = 2/1000, 1/1000
            let y: Vec<f64> = (0..3).map(|k| snap.pos[k].y + sol.displacement[k].y).collect();
            let expect = [1.0 - 3.0 / 2000.0, 3.0 - 3.0 / 2000.0 - 2.0 / 1000.0, 5.0 - 3.0 / 2000.0 - 3.0 / 1000.0];
            for k in 0..3 {
                // the closed form is exact for aligned Hooke springs: round-off of positions ~5
                assert!((y[k] - expect[k]).abs() < 1e-13, "gap {gap}, grain {k}: {} vs {}", y[k], expect[k]);
                assert_eq!(sol.displacement[k].x, 0.0);
            }
        }
    }

    #[test]
    fn hertz_contacts_are_refused() {
        let mut snap = column(0.0);
        snap.law.normal = NormalElastic::Hertz(Hertz { effective_modulus: 1.0 });
        let err = frictionless_equilibrium(&snap, &[DVec2::ZERO; 3], &EquilibriumOptions::default()).unwrap_err();
        assert!(err.to_string().contains("Hooke"), "{err}");
    }
}
