//! Force evaluation: every pair writes its own slot of a pair buffer (in parallel), then every
//! grain sums its slots in the fixed adjacency order (in parallel over grains). No floating-point
//! sum depends on how work is split among threads, so results are bitwise identical for any
//! thread count.

use super::{PairForce, Simulation, WallForce};
use crate::contact::{pair_kinematics, wall_kinematics, ContactLaw, ContactOutput, ContactState, Kinematics};
use crate::dim::{Dim, VectorOps};
use crate::domain::WallMotion;
use crate::error::{CoreError, Result};
use crate::grains::Grains;
use rayon::prelude::*;

/// Per-evaluation statistics, merged associatively (so deterministically).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ForceStats {
    pub changes: u64,
    pub contacts: u64,
    pub sliding: u64,
    /// (overlap / smaller radius, is_wall, index) of the deepest contact.
    pub deepest: (f64, u8, usize),
}

impl ForceStats {
    fn merge(a: Self, b: Self) -> Self {
        let deepest = if b.deepest.0 > a.deepest.0 || (b.deepest.0 == a.deepest.0 && (b.deepest.1, b.deepest.2) < (a.deepest.1, a.deepest.2)) {
            b.deepest
        } else {
            a.deepest
        };
        ForceStats {
            changes: a.changes + b.changes,
            contacts: a.contacts + b.contacts,
            sliding: a.sliding + b.sliding,
            deepest,
        }
    }
}

/// Evaluates one contact given its kinematics (or `None` when apart), updating the state.
#[inline]
fn contact<D: Dim>(
    law: &ContactLaw,
    kin: Option<Kinematics<D>>,
    state: &mut ContactState<D>,
    dt: f64,
) -> Option<(Kinematics<D>, ContactOutput<D>, bool)> {
    match kin {
        None => {
            if state.in_contact() {
                *state = ContactState::default();
            }
            None
        }
        Some(kin) => {
            let formed = !state.in_contact();
            let out = law.evaluate(&kin, state, dt);
            Some((kin, out, formed))
        }
    }
}

impl<D: Dim> Simulation<D> {
    /// Rebuilds the neighbor list if needed, and the derived adjacency and buffers.
    pub(crate) fn prepare_neighbors(&mut self) -> Result<()> {
        if self.nlist.needs_rebuild(&self.grains.pos, &self.domain) {
            self.check_confinement()?;
            self.nlist.rebuild(&self.grains.pos, &self.grains.radius, &self.grains.id, &self.domain);
        }
        if self.work.adjacency_builds != self.nlist.builds || self.work.pair_force.len() != self.nlist.pairs.len() {
            self.work.adjacency = self.nlist.adjacency(self.grains.len());
            self.work.pair_force = vec![PairForce::default(); self.nlist.pairs.len()];
            self.work.wall_force = vec![WallForce::default(); self.nlist.wall_pairs.len()];
            self.work.adjacency_builds = self.nlist.builds;
        }
        Ok(())
    }

    /// Blow-up check done at every rebuild: finite positions, no grain behind a wall.
    fn check_confinement(&self) -> Result<()> {
        let g = &self.grains;
        if let Some(k) = (0..g.len()).into_par_iter().find_first(|&k| !g.pos[k].is_finite_vec() || !g.vel[k].is_finite_vec()) {
            return Err(self.blow_up(k, "non-finite position or velocity".into()));
        }
        for wall in &self.domain.walls {
            if let Some(k) = (0..g.len()).into_par_iter().find_first(|&k| wall.distance(g.pos[k]) < 0.0) {
                return Err(self.blow_up(k, format!("the grain left the domain through wall `{}`", wall.name)));
            }
        }
        Ok(())
    }

    /// Builds the blow-up error for grain (storage index) `k`.
    pub(crate) fn blow_up(&self, k: usize, reason: String) -> CoreError {
        let g = &self.grains;
        CoreError::BlowUp {
            step: self.step,
            time: self.time,
            grain: g.id[k],
            reason,
            position: g.pos[k].to_array3(),
            velocity: g.vel[k].to_array3(),
            force: g.force[k].to_array3(),
        }
    }

    /// Computes all forces and torques at the current positions. Contact histories advance by
    /// `dt_hist` (0 re-evaluates without advancing). With `use_eval` the velocities in the
    /// workspace (Beeman's predicted velocities) are used instead of the grains' own.
    pub(crate) fn compute_forces(&mut self, dt_hist: f64, use_eval: bool) -> Result<()> {
        let Simulation { grains, domain, law, nlist, work, gravity, loads, time, safety, .. } = self;
        let Grains { pos, radius, mass, force, torque, .. } = grains;
        let (vel, omega) = if use_eval { (&work.vel_eval, &work.omega_eval) } else { (&grains.vel, &grains.omega) };
        let (pos, radius, mass) = (&*pos, &*radius, &*mass);
        let law = &*law;
        let dom = &*domain;

        let pair_stats = nlist
            .pairs
            .par_iter_mut()
            .zip(work.pair_force.par_iter_mut())
            .enumerate()
            .with_min_len(512)
            .map(|(k, (p, out))| {
                let (i, j) = (p.i as usize, p.j as usize);
                let r = dom.displacement(pos[i], pos[j]);
                let kin = pair_kinematics::<D>(r, radius[i], radius[j], mass[i], mass[j], vel[i], vel[j], omega[i], omega[j]);
                let was = p.state.in_contact();
                match contact(law, kin, &mut p.state, dt_hist) {
                    None => {
                        *out = PairForce::default();
                        ForceStats { changes: was as u64, ..Default::default() }
                    }
                    Some((kin, o, formed)) => {
                        let n = kin.normal;
                        let t = D::cross(n, o.tangential_force);
                        out.force = o.tangential_force - n * o.normal_force;
                        out.torque_i = t * kin.lever_i + o.rolling_torque;
                        out.torque_j = t * kin.lever_j - o.rolling_torque;
                        ForceStats {
                            changes: formed as u64,
                            contacts: 1,
                            sliding: o.sliding as u64,
                            deepest: (kin.overlap / radius[i].min(radius[j]), 0, k),
                        }
                    }
                }
            })
            .reduce(ForceStats::default, ForceStats::merge);

        let walls = &domain.walls;
        let wall_stats = nlist
            .wall_pairs
            .par_iter_mut()
            .zip(work.wall_force.par_iter_mut())
            .enumerate()
            .with_min_len(512)
            .map(|(k, (wp, out))| {
                let g = wp.grain as usize;
                let wall = &walls[wp.wall as usize];
                let kin = wall_kinematics::<D>(wall.distance(pos[g]), wall.normal, wall.velocity(), radius[g], mass[g], vel[g], omega[g]);
                let was = wp.state.in_contact();
                match contact(&wall.law, kin, &mut wp.state, dt_hist) {
                    None => {
                        *out = WallForce::default();
                        ForceStats { changes: was as u64, ..Default::default() }
                    }
                    Some((kin, o, formed)) => {
                        let n = kin.normal;
                        out.force = o.tangential_force - n * o.normal_force;
                        out.torque = D::cross(n, o.tangential_force) * kin.lever_i + o.rolling_torque;
                        ForceStats {
                            changes: formed as u64,
                            contacts: 1,
                            sliding: o.sliding as u64,
                            deepest: (kin.overlap / radius[g], 1, k),
                        }
                    }
                }
            })
            .reduce(ForceStats::default, ForceStats::merge);
        let stats = ForceStats::merge(pair_stats, wall_stats);

        // Fixed-order reduction per grain.
        let adj = &work.adjacency;
        let pf = &work.pair_force;
        let wf = &work.wall_force;
        let g_acc = *gravity;
        force.par_iter_mut().zip(torque.par_iter_mut()).enumerate().with_min_len(1024).for_each(|(g, (f, t))| {
            let mut fs = D::Vector::ZERO;
            let mut ts = D::AngVector::ZERO;
            for &e in &adj.entries[adj.start[g] as usize..adj.start[g + 1] as usize] {
                let p = &pf[(e >> 1) as usize];
                if e & 1 == 0 {
                    fs += p.force;
                    ts += p.torque_i;
                } else {
                    fs -= p.force;
                    ts += p.torque_j;
                }
            }
            for w in &wf[adj.wall_start[g] as usize..adj.wall_start[g + 1] as usize] {
                fs += w.force;
                ts += w.torque;
            }
            *f = fs + g_acc * mass[g];
            *t = ts;
        });
        for load in loads.iter() {
            if let Some(k) = grains.index_of(load.grain) {
                let s = load.profile.eval(*time);
                grains.force[k] += load.force * s;
                grains.torque[k] += load.torque * s;
            }
        }
        // Forces on walls, in list order.
        for w in domain.walls.iter_mut() {
            w.force = D::Vector::ZERO;
        }
        for (wp, out) in nlist.wall_pairs.iter().zip(work.wall_force.iter()) {
            domain.walls[wp.wall as usize].force -= out.force;
        }

        self.counters.network_changes = stats.changes;
        self.counters.contacts = stats.contacts;
        self.counters.sliding = stats.sliding;
        if stats.deepest.0 > self.counters.max_overlap_ratio_seen {
            self.counters.max_overlap_ratio_seen = stats.deepest.0;
        }
        let g = &self.grains;
        if let Some(k) = (0..g.len()).into_par_iter().find_first(|&k| !g.force[k].is_finite_vec() || !g.torque[k].is_finite_vec()) {
            return Err(self.blow_up(k, "non-finite force or torque".into()));
        }
        if stats.deepest.0 > safety.max_overlap_fraction {
            let (ratio, is_wall, idx) = stats.deepest;
            let (k, partner) = if is_wall == 0 {
                let p = &self.nlist.pairs[idx];
                (p.i as usize, format!("grain id {}", self.grains.id[p.j as usize]))
            } else {
                let wp = &self.nlist.wall_pairs[idx];
                (wp.grain as usize, format!("wall `{}`", self.domain.walls[wp.wall as usize].name))
            };
            return Err(self.blow_up(
                k,
                format!(
                    "overlap with {partner} reached {ratio:.3} of the smaller radius (limit {}, key `max_overlap_fraction`)",
                    self.safety.max_overlap_fraction
                ),
            ));
        }
        Ok(())
    }

    /// Piston accelerations from the current wall forces: M a = F_ext(t) + F_grains·n̂.
    pub(crate) fn update_piston_accelerations(&mut self) {
        let t = self.time;
        for w in &mut self.domain.walls {
            if let WallMotion::Piston { mass, force } = &w.motion {
                w.accel = (force.eval(t) + w.force.dot(w.normal)) / mass;
            }
        }
    }
}
