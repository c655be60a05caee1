//! Changes of the contact network between two snapshots of the same grains (SPEC §7.2.5): which
//! contacts opened, which were created, which slide, and the contact-force difference field.
//!
//! Contacts are matched by their grains' stable ids: a grain pair is keyed (smaller id, larger id),
//! a wall contact (grain id, wall index). For every contact present in either snapshot,
//! [`ContactChange`] holds its state before and after; forces are expressed as the force on the
//! key's first grain (the smaller id, or the grain of a wall contact), so that the vector difference
//! after − before is meaningful whichever grain the engine listed first.
//!
//! The **region of opened contacts** around a reference point r₀ (e.g. the loaded grain in the
//! reference state) is the set of opened contacts connected to r₀: the opened contacts whose
//! contact point (in the reference state) lies within `seed` of r₀, and every opened contact whose
//! point lies within `link` of one already in the region (a cluster grown by distance; with `link`
//! a little more than a grain radius, contacts sharing a grain are linked). Contacts that open far
//! away — a weak contact near a wall relieved by the load — are counted but not part of the region.
//! Its **depth** is the largest (r₀ − r_c)·up over its contacts and its **width** the extent
//! max − min of their horizontal coordinate.
//!
//! ```
//! use grainwave_analysis::network::ContactKey;
//! use grainwave_core::snapshot::Counterpart;
//! assert_eq!(ContactKey::new(7, Counterpart::Grain(3)), ContactKey::Pair(3, 7));
//! assert_eq!(ContactKey::new(7, Counterpart::Wall(1)), ContactKey::Wall(7, 1));
//! ```

use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::snapshot::{ContactRecord, Counterpart, Snapshot};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Identity of a contact across snapshots.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactKey {
    /// Two grains (smaller id first).
    Pair(u32, u32),
    /// A grain and a wall (grain id, wall index).
    Wall(u32, u32),
}

impl ContactKey {
    /// The key of a contact between grain `i` and `j`.
    pub fn new(i: u32, j: Counterpart) -> Self {
        match j {
            Counterpart::Grain(j) => ContactKey::Pair(i.min(j), i.max(j)),
            Counterpart::Wall(w) => ContactKey::Wall(i, w),
        }
    }

    /// The grain whose force is reported.
    pub fn first(&self) -> u32 {
        match *self {
            ContactKey::Pair(i, _) | ContactKey::Wall(i, _) => i,
        }
    }
}

/// One side (before or after) of a contact.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct ContactSide<D: Dim> {
    /// Force on the key's first grain.
    pub force: D::Vector,
    /// Normal force F_n ≥ 0.
    pub normal_force: f64,
    /// Overlap ξ.
    pub overlap: f64,
    /// Contact point.
    pub point: D::Vector,
    /// Branch vector from the key's first grain (towards the other grain or the wall contact point).
    pub branch: D::Vector,
    /// Sliding flag.
    pub sliding: bool,
}

/// A contact present in at least one of two snapshots.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct ContactChange<D: Dim> {
    /// Which contact.
    pub key: ContactKey,
    /// State in the first snapshot, if in contact there.
    pub before: Option<ContactSide<D>>,
    /// State in the second snapshot, if in contact there.
    pub after: Option<ContactSide<D>>,
}

impl<D: Dim> ContactChange<D> {
    /// In contact before, not after.
    pub fn opened(&self) -> bool {
        self.before.is_some() && self.after.is_none()
    }

    /// In contact after, not before.
    pub fn created(&self) -> bool {
        self.before.is_none() && self.after.is_some()
    }

    /// Sliding after.
    pub fn sliding_after(&self) -> bool {
        self.after.is_some_and(|a| a.sliding)
    }

    /// Force after minus force before (a missing side counts as zero force).
    pub fn force_difference(&self) -> D::Vector {
        let f = |s: &Option<ContactSide<D>>| s.map_or(D::Vector::ZERO, |s| s.force);
        f(&self.after) - f(&self.before)
    }

    /// The contact point before, or after for a created contact.
    pub fn point(&self) -> D::Vector {
        self.before.or(self.after).map(|s| s.point).unwrap_or(D::Vector::ZERO)
    }

    /// The branch vector before, or after for a created contact.
    pub fn branch(&self) -> D::Vector {
        self.before.or(self.after).map(|s| s.branch).unwrap_or(D::Vector::ZERO)
    }
}

/// Counts of a network comparison.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct NetworkCounts {
    /// Contacts before.
    pub before: usize,
    /// Contacts after.
    pub after: usize,
    /// Opened (before, not after).
    pub opened: usize,
    /// Created (after, not before).
    pub created: usize,
    /// Sliding after.
    pub sliding: usize,
    /// Sliding before.
    pub sliding_before: usize,
}

/// Size of the region of opened contacts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionSize {
    /// Number of opened contacts in the region (connected to the reference point).
    pub count: usize,
    /// Largest depth below the reference point (0 when none opened).
    pub depth: f64,
    /// Horizontal extent of the opened contact points (0 when fewer than two).
    pub width: f64,
}

/// All contacts of two snapshots, matched.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct NetworkChanges<D: Dim> {
    /// Every contact present in either snapshot, ordered by key.
    pub contacts: Vec<ContactChange<D>>,
}

fn sides<D: Dim>(snapshot: &Snapshot<D>) -> BTreeMap<ContactKey, ContactSide<D>> {
    let index = snapshot.index_by_id();
    let side = |c: &ContactRecord<D>| {
        let key = ContactKey::new(c.i, c.j);
        let pos = snapshot.pos[index[c.i as usize]];
        let point = pos + c.normal * c.lever_i;
        let flip = key.first() != c.i;
        let (force, branch) = if flip { (-c.force_on_i(), -c.branch) } else { (c.force_on_i(), c.branch) };
        (key, ContactSide { force, normal_force: c.normal_force, overlap: c.overlap, point, branch, sliding: c.sliding })
    };
    snapshot.contacts.iter().map(side).collect()
}

/// Matches the contacts of `before` and `after` (snapshots of the same grains).
pub fn compare_networks<D: Dim>(before: &Snapshot<D>, after: &Snapshot<D>) -> NetworkChanges<D> {
    let a = sides(before);
    let mut b = sides(after);
    let mut contacts = Vec::with_capacity(a.len().max(b.len()));
    for (key, s) in a {
        contacts.push(ContactChange { key, before: Some(s), after: b.remove(&key) });
    }
    for (key, s) in b {
        contacts.push(ContactChange { key, before: None, after: Some(s) });
    }
    contacts.sort_by_key(|c| c.key);
    NetworkChanges { contacts }
}

/// Default relative tolerance of [`mark_mobilized`]: a contact at rest counts as sliding when
/// |F_t| ≥ (1 − 1e-6) μ F_n.
pub const MOBILIZED_TOLERANCE: f64 = 1e-6;

/// Marks the contacts (of a snapshot) of a state **at rest** whose friction is fully mobilized as sliding:
/// |F_t| ≥ (1 − `tolerance`) μ F_n with μ > 0 and F_n > 0, where μ = `friction(counterpart)`.
///
/// The engine's sliding flag says that the Coulomb cap acted at the last force evaluation (the
/// trial force exceeded μ F_n). At rest a contact that slid into place holds |F_t| = μ F_n up to
/// rounding, and whether the trial force lands just above or just below the cap is a matter of
/// the last bit, so the flag alone undercounts sliding contacts of a static state; this marks them
/// (SPEC §7.2.5). Flags already set are kept.
pub fn mark_mobilized<D: Dim>(contacts: &mut [ContactRecord<D>], friction: impl Fn(Counterpart) -> f64, tolerance: f64) {
    for c in contacts {
        let mu = friction(c.j);
        if mu > 0.0 && c.normal_force > 0.0 && c.tangential_force.norm() >= (1.0 - tolerance) * mu * c.normal_force {
            c.sliding = true;
        }
    }
}

impl<D: Dim> NetworkChanges<D> {
    /// Counts of contacts, opened, created and sliding.
    pub fn counts(&self) -> NetworkCounts {
        let mut n = NetworkCounts::default();
        for c in &self.contacts {
            n.before += c.before.is_some() as usize;
            n.after += c.after.is_some() as usize;
            n.opened += c.opened() as usize;
            n.created += c.created() as usize;
            n.sliding += c.sliding_after() as usize;
            n.sliding_before += c.before.is_some_and(|s| s.sliding) as usize;
        }
        n
    }

    /// Depth and width of the region of opened contacts connected to `origin` (see the module
    /// docs): opened contacts within `seed` of `origin` start it, contacts within `link` of a member
    /// join it; `vertical` is the index of the vertical axis (pointing up), `horizontal` that of the
    /// horizontal axis.
    pub fn opened_region(&self, origin: D::Vector, vertical: usize, horizontal: usize, seed: f64, link: f64) -> RegionSize {
        let points: Vec<D::Vector> = self.contacts.iter().filter(|c| c.opened()).map(|c| c.point()).collect();
        let mut member: Vec<bool> = points.iter().map(|p| (*p - origin).norm() <= seed).collect();
        let mut frontier: Vec<usize> = (0..points.len()).filter(|&k| member[k]).collect();
        while let Some(k) = frontier.pop() {
            for j in 0..points.len() {
                if !member[j] && (points[j] - points[k]).norm() <= link {
                    member[j] = true;
                    frontier.push(j);
                }
            }
        }
        let mut r = RegionSize::default();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (p, _) in points.iter().zip(&member).filter(|(_, &m)| m) {
            r.count += 1;
            r.depth = r.depth.max(origin.get(vertical) - p.get(vertical));
            lo = lo.min(p.get(horizontal));
            hi = hi.max(p.get(horizontal));
        }
        if r.count >= 2 {
            r.width = hi - lo;
        }
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;
    use grainwave_core::dim::D2;

    #[test]
    fn mobilized_contacts_at_rest_count_as_sliding() {
        use grainwave_core::snapshot::ContactRecord;
        let record = |j: Counterpart, ft: f64, fnormal: f64| ContactRecord::<D2> {
            i: 0,
            j,
            normal: DVec2::X,
            branch: DVec2::X,
            overlap: 0.01,
            lever_i: 1.0,
            lever_j: 1.0,
            normal_force: fnormal,
            tangential_force: DVec2::new(0.0, ft),
            rolling_torque: 0.0,
            normal_stiffness: 1.0,
            tangential_stiffness: 1.0,
            sliding: false,
        };
        // μ = 0.2 between grains, 0.5 on wall 0, 0 on wall 1
        let mut contacts = vec![
            record(Counterpart::Grain(1), 0.2 * 3.0 * (1.0 - 1e-12), 3.0), // at the cone to rounding
            record(Counterpart::Grain(2), 0.2 * 3.0 * 0.99, 3.0),          // 1 % inside the cone
            record(Counterpart::Wall(0), 0.5 * 2.0, 2.0),                  // at the wall's cone
            record(Counterpart::Wall(1), 1.0, 2.0),                        // frictionless wall: never
            record(Counterpart::Grain(3), 0.0, 0.0),                       // no load: never
        ];
        mark_mobilized(&mut contacts, |j| match j { Counterpart::Grain(_) => 0.2, Counterpart::Wall(0) => 0.5, Counterpart::Wall(_) => 0.0 }, MOBILIZED_TOLERANCE);
        let flags: Vec<bool> = contacts.iter().map(|c| c.sliding).collect();
        assert_eq!(flags, [true, false, true, false, false]);
    }

    fn opened_at(x: f64, y: f64, i: u32) -> ContactChange<D2> {
        let side = ContactSide { force: DVec2::ZERO, normal_force: 1.0, overlap: 0.01, point: DVec2::new(x, y), branch: DVec2::new(2.0, 0.0), sliding: false };
        ContactChange { key: ContactKey::Pair(i, i + 1), before: Some(side), after: None }
    }

    #[test]
    fn the_region_is_the_cluster_connected_to_the_load() {
        // a V below the load at (0, 10), one contact opening far away near a wall
        let mut contacts = vec![opened_at(-1.0, 10.0, 0), opened_at(1.0, 10.0, 2), opened_at(-1.5, 8.3, 4), opened_at(1.5, 8.3, 6), opened_at(-2.5, 6.6, 8)];
        contacts.push(opened_at(40.0, 1.0, 10));
        let changes = NetworkChanges { contacts };
        let r = changes.opened_region(DVec2::new(0.0, 10.0), 1, 0, 3.0, 2.5);
        assert_eq!(r.count, 5);
        assert!((r.depth - 3.4).abs() < 1e-12 && (r.width - 4.0).abs() < 1e-12, "{r:?}");
        assert_eq!(changes.counts().opened, 6);
        // nothing near the load: no region
        let r = changes.opened_region(DVec2::new(20.0, 10.0), 1, 0, 3.0, 2.5);
        assert_eq!(r, RegionSize::default());
    }
}
