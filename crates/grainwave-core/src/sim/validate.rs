//! Consistency of a decoded simulation: the invariants the force passes, the integrators and the
//! energy and inspection paths rely on, checked once when a [`Simulation`] is deserialized (from
//! a checkpoint, a study state holding one, a message).
//!
//! A checkpoint's CRC guards against accidents, not against a crafted file: bincode decodes any
//! bytes of the right shape, so a changed length, index or offset would otherwise reach code
//! that indexes without checking (the AVX2 and AVX-512 force passes read through raw pointers)
//! or allocates from an offset. Every index that code reads is checked here, in safe code,
//! before the simulation exists. The checks only read: a valid state decodes to exactly the
//! state that was saved (a resumed run stays bit-identical).
//!
//! What is checked (see also `docs/hardening.md`):
//! * **Grains**: every per-grain array (`id`, `radius`, `mass`, `inertia`, `pos`, `vel`,
//!   `omega`, `orientation`, `image`, `force`, `torque`) has one entry per grain; fewer than
//!   2³² grains; ids unique; radius, mass and moment of inertia finite and > 0; position,
//!   velocity, angular velocity and orientation finite; the grain kind fits the dimension.
//! * **Pair list** (CSR): `owner_start` is empty (with no pairs) or has one entry per owner plus
//!   one, starts at 0, never decreases and ends at the number of pairs; the partners of each
//!   owner are strictly increasing, larger than the owner and below the number of owners; the
//!   owners are the grains (one entry per grain plus one) whenever the list would be used without
//!   a rebuild, and never more than the grains; every history array (`spring`, `overlap`,
//!   `sliding`, `rolling`, `twist`, and the law's own history where stored) has one entry per pair.
//! * **Wall pairs**: grain index below the number of grains, wall index below the number of
//!   walls, sorted strictly by (grain, wall) (the per-grain wall index assumes it).
//! * **Domain**: finite lengths > 0 on every axis, finite tilt factors and rates, walls with
//!   finite non-zero normals, finite positions, origins, speeds and accelerations, valid motions.
//! * **Run parameters**: finite time step > 0, finite time, finite skin > 0, finite gravity,
//!   valid external-load profiles, Beeman's previous accelerations empty or one per grain.

use super::Simulation;
use crate::dim::{Dim, VectorOps};
use crate::domain::WallMotion;
use crate::neighbor::PairList;

/// A description of the first inconsistency found (e.g. "grains.radius has 299 entries for 300
/// grains").
pub(crate) type Inconsistency = String;

impl<D: Dim> Simulation<D> {
    /// Checks every invariant a decoded simulation must satisfy before the engine uses it (see
    /// the module documentation of `sim::validate`). `Err` names the first inconsistency found.
    pub(crate) fn check_decoded(&self) -> Result<(), Inconsistency> {
        let n = self.check_grains()?;
        self.check_domain()?;
        let nl = &self.nlist;
        if !(nl.skin.is_finite() && nl.skin > 0.0) {
            return Err(format!("neighbor skin is {}, must be a finite length > 0", nl.skin));
        }
        // the list is used as it is (no rebuild) only when all three hold; then its owners must
        // be the grains
        let used_as_is = !nl.stale && nl.ref_pos.len() == n && nl.ref_wall_pos.len() == self.domain.walls.len();
        nl.list.check_structure(n, used_as_is)?;
        let walls = self.domain.walls.len();
        let mut last: Option<(u32, u32)> = None;
        for (k, wp) in nl.wall_pairs.iter().enumerate() {
            if wp.grain as usize >= n {
                return Err(format!("wall pair {k} names grain {} of {n}", wp.grain));
            }
            if wp.wall as usize >= walls {
                return Err(format!("wall pair {k} names wall {} of {walls}", wp.wall));
            }
            if last.is_some_and(|l| l >= (wp.grain, wp.wall)) {
                return Err(format!("wall pairs are not sorted by (grain, wall) at entry {k}"));
            }
            last = Some((wp.grain, wp.wall));
        }
        // the wall laws' own history: at most one column per wall, each stored one an entry per
        // wall pair (a shorter one would be silently reset to fresh contacts)
        if nl.wall_extra.0.len() > walls {
            return Err(format!("{} grain–wall history columns for {walls} walls", nl.wall_extra.0.len()));
        }
        for (w, c) in nl.wall_extra.0.iter().enumerate() {
            if c.is_stored() && c.len() != nl.wall_pairs.len() {
                return Err(format!("the grain–wall history of wall {w} has {} entries for {} wall pairs", c.len(), nl.wall_pairs.len()));
            }
        }
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(format!("time step dt = {}, must be finite and > 0", self.dt));
        }
        if !self.time.is_finite() {
            return Err(format!("time = {}, must be finite", self.time));
        }
        if !self.gravity.is_finite_vec() {
            return Err(format!("gravity {:?} is not finite", self.gravity));
        }
        for (k, load) in self.loads.iter().enumerate() {
            if !load.force.is_finite_vec() || !load.torque.is_finite_vec() {
                return Err(format!("external load {k} has a non-finite force or torque"));
            }
            load.profile.validate(&format!("loads[{k}].profile")).map_err(|e| e.to_string())?;
        }
        if !(self.prev_acc.is_empty() || self.prev_acc.len() == n) || !(self.prev_ang_acc.is_empty() || self.prev_ang_acc.len() == n) {
            return Err(format!(
                "previous accelerations have {} and {} entries, must be 0 or one per grain ({n})",
                self.prev_acc.len(),
                self.prev_ang_acc.len()
            ));
        }
        Ok(())
    }

    /// The per-grain arrays (see the module documentation); returns the number of grains.
    fn check_grains(&self) -> Result<usize, Inconsistency> {
        let g = &self.grains;
        let n = g.id.len();
        if n > u32::MAX as usize {
            return Err(format!("{n} grains, at most 2^32 - 1 allowed"));
        }
        let lens = [
            ("radius", g.radius.len()),
            ("mass", g.mass.len()),
            ("inertia", g.inertia.len()),
            ("pos", g.pos.len()),
            ("vel", g.vel.len()),
            ("omega", g.omega.len()),
            ("orientation", g.orientation.len()),
            ("image", g.image.len()),
            ("force", g.force.len()),
            ("torque", g.torque.len()),
        ];
        for (name, len) in lens {
            if len != n {
                return Err(format!("grains.{name} has {len} entries for {n} grains (grains.id)"));
            }
        }
        g.kind.validate(D::D).map_err(|e| e.to_string())?;
        for k in 0..n {
            let positive = |name: &str, x: f64| if x.is_finite() && x > 0.0 { Ok(()) } else { Err(format!("grain {k} (id {}): {name} {x}, must be finite and > 0", g.id[k])) };
            positive("radius", g.radius[k])?;
            positive("mass", g.mass[k])?;
            positive("moment of inertia", g.inertia[k])?;
            if !g.pos[k].is_finite_vec() || !g.vel[k].is_finite_vec() || !g.omega[k].is_finite_vec() {
                return Err(format!("grain {k} (id {}): non-finite position, velocity or angular velocity", g.id[k]));
            }
            if !D::orientation_rotation_vector(g.orientation[k]).iter().all(|c| c.is_finite()) {
                return Err(format!("grain {k} (id {}): non-finite orientation", g.id[k]));
            }
        }
        let mut ids = g.id.clone();
        ids.sort_unstable();
        if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
            return Err(format!("grain id {} appears more than once", w[0]));
        }
        Ok(n)
    }

    /// The domain's extents, tilt and walls (see the module documentation).
    fn check_domain(&self) -> Result<(), Inconsistency> {
        let d = &self.domain;
        for k in 0..D::D {
            let l = d.length(k);
            if !(l.is_finite() && l > 0.0) {
                return Err(format!("domain length along axis {k} is {l}, must be finite and > 0"));
            }
        }
        if !d.tilt.iter().chain(&d.tilt_rate).all(|t| t.is_finite()) {
            return Err(format!("domain tilt {:?} / rate {:?} not finite", d.tilt, d.tilt_rate));
        }
        for (w, wall) in d.walls.iter().enumerate() {
            let bad = |what: &str| Err(format!("wall {w}: {what}"));
            if !(wall.normal.is_finite_vec() && wall.normal.norm2() > 0.0) {
                return bad("normal is zero or not finite");
            }
            if !(wall.position.is_finite_vec() && wall.origin.is_finite_vec()) {
                return bad("position or origin not finite");
            }
            if !(wall.speed.is_finite() && wall.accel.is_finite() && wall.prev_accel.is_finite()) {
                return bad("speed or acceleration not finite");
            }
            match &wall.motion {
                WallMotion::Fixed => {}
                WallMotion::Velocity { speed } => speed.validate(&format!("walls[{w}].speed")).map_err(|e| e.to_string())?,
                WallMotion::Piston { mass, force } => {
                    if !(mass.is_finite() && *mass > 0.0) {
                        return bad(&format!("piston mass {mass}, must be finite and > 0"));
                    }
                    force.validate(&format!("walls[{w}].force")).map_err(|e| e.to_string())?;
                }
            }
        }
        Ok(())
    }
}

impl<D: Dim> PairList<D> {
    /// The CSR structure of the list for `n` grains (see the module documentation of
    /// `sim::validate`): with `exact`, the owners must be exactly the `n` grains (the list is
    /// about to be used by the force pass); without, at most `n` (a stale list, only read by a
    /// rebuild and by the energy and inspection paths). O(pairs).
    pub(crate) fn check_structure(&self, n: usize, exact: bool) -> Result<(), Inconsistency> {
        let pairs = self.partner.len();
        for (name, len) in [("spring", self.spring.len()), ("overlap", self.overlap.len()), ("sliding", self.sliding.len()), ("rolling", self.rolling.len()), ("twist", self.twist.len())] {
            if len != pairs {
                return Err(format!("pair history `{name}` has {len} entries for {pairs} pairs"));
            }
        }
        if self.extra.is_stored() && self.extra.len() != pairs {
            return Err(format!("the law's pair history has {} entries for {pairs} pairs", self.extra.len()));
        }
        if self.owner_start.is_empty() {
            if pairs != 0 || (exact && n != 0) {
                return Err(format!("pair list has {pairs} pairs but no owner offsets for {n} grains"));
            }
            return Ok(());
        }
        let owners = self.owner_start.len() - 1;
        if (exact && owners != n) || owners > n {
            return Err(format!("pair list has offsets for {owners} grains, the simulation {n}"));
        }
        if self.owner_start[0] != 0 || self.owner_start[owners] as usize != pairs {
            return Err(format!(
                "pair offsets run from {} to {}, must run from 0 to the number of pairs ({pairs})",
                self.owner_start[0], self.owner_start[owners]
            ));
        }
        for i in 0..owners {
            let (s, e) = (self.owner_start[i] as usize, self.owner_start[i + 1] as usize);
            if e < s || e > pairs {
                return Err(format!("pair offsets of grain {i} run from {s} to {e}: offsets must not decrease nor pass the number of pairs ({pairs})"));
            }
            let mut prev = i as u64;
            for (p, &j) in self.partner[s..e].iter().enumerate() {
                if j as u64 <= prev || j as usize >= owners {
                    return Err(format!(
                        "pair {} of grain {i} has partner {j}: partners must be increasing, above the owner and below {owners}",
                        s + p
                    ));
                }
                prev = j as u64;
            }
        }
        Ok(())
    }
}
