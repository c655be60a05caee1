//! Snapshots: the grains and the contact records (SPEC §2.6) that every analysis consumes.

use crate::contact::{pair_kinematics, wall_kinematics, ContactLaw, ContactState, Kinematics};
use crate::dim::{Dim, VectorOps};
use crate::domain::Domain;
use crate::grains::GrainKind;
use crate::sim::Simulation;
use serde::{Deserialize, Serialize};

/// The other side of a contact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Counterpart {
    /// Another grain (stable id).
    Grain(u32),
    /// A wall (index in the domain's wall list).
    Wall(u32),
}

impl Counterpart {
    /// The counterpart as one signed number, as tables write it: a grain's id (≥ 0), or
    /// −1 − k for wall k (< 0).
    pub fn signed_id(self) -> i64 {
        match self {
            Counterpart::Grain(id) => i64::from(id),
            Counterpart::Wall(w) => -1 - i64::from(w),
        }
    }
}

/// One contact as seen by analysis: geometry, forces, stiffnesses and sliding flag.
///
/// Conventions: `normal` n̂ points from grain i to its counterpart; `branch` is the vector from
/// the centre of i to the centre of j (nearest periodic image) or, for a wall, to the contact point
/// on the wall. The force on i is −`normal_force` n̂ + `tangential_force`; on j the opposite.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct ContactRecord<D: Dim> {
    /// Stable id of grain i.
    pub i: u32,
    /// Grain j or wall.
    pub j: Counterpart,
    /// Unit normal from i towards j.
    pub normal: D::Vector,
    /// Branch vector (see above).
    pub branch: D::Vector,
    /// Overlap ξ.
    pub overlap: f64,
    /// Distance from the centre of i to the contact point.
    pub lever_i: f64,
    /// Distance from the centre of j to the contact point (0 for walls).
    pub lever_j: f64,
    /// Normal force F_n ≥ 0 (elastic + damping), repulsive.
    pub normal_force: f64,
    /// Tangential force on i.
    pub tangential_force: D::Vector,
    /// Rolling + twisting resistance torque on i.
    pub rolling_torque: D::AngVector,
    /// Differential normal stiffness k_n = dF_n/dξ.
    pub normal_stiffness: f64,
    /// Tangential stiffness k_t.
    pub tangential_stiffness: f64,
    /// Coulomb cap reached.
    pub sliding: bool,
}

impl<D: Dim> ContactRecord<D> {
    /// Total force on grain i.
    pub fn force_on_i(&self) -> D::Vector {
        self.tangential_force - self.normal * self.normal_force
    }
}

/// A complete picture of the packing at one instant.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Snapshot<D: Dim> {
    /// Grain kind.
    pub kind: GrainKind,
    /// Step counter.
    pub step: u64,
    /// Simulated time.
    pub time: f64,
    /// Stable ids (all per-grain arrays are in this order).
    pub id: Vec<u32>,
    /// Radii.
    pub radius: Vec<f64>,
    /// Masses.
    pub mass: Vec<f64>,
    /// Moments of inertia.
    pub inertia: Vec<f64>,
    /// Positions (wrapped into the periodic cell).
    pub pos: Vec<D::Vector>,
    /// Periodic image counters.
    pub image: Vec<[i32; 3]>,
    /// Velocities.
    pub vel: Vec<D::Vector>,
    /// Angular velocities.
    pub omega: Vec<D::AngVector>,
    /// Orientations as rotation vectors.
    pub rotation: Vec<[f64; 3]>,
    /// Total forces (last evaluation).
    pub force: Vec<D::Vector>,
    /// Total torques (last evaluation).
    pub torque: Vec<D::AngVector>,
    /// Gravity.
    pub gravity: D::Vector,
    /// Domain, walls (with their forces) included.
    pub domain: Domain<D>,
    /// Grain–grain contact law.
    pub law: ContactLaw,
    /// Contacts with ξ > 0.
    pub contacts: Vec<ContactRecord<D>>,
}

/// The law's own history of a contact: the column of its list (the grain–grain pair list, or
/// the wall's column of the grain–wall pairs), the list's length, the pair's index and whether
/// the record sees the pair from its other grain.
type Stored<'a> = (&'a crate::contact::HistoryColumn, usize, usize, bool);

fn record<D: Dim>(law: &ContactLaw, kin: &Kinematics<D>, state: &ContactState<D>, stored: Stored<'_>, i: u32, j: Counterpart, branch: D::Vector) -> ContactRecord<D> {
    // Re-evaluate on a copy with dt = 0: histories are not advanced (a normal law with its own
    // history reads the stored one: the branch the contact is on)
    let mut s = *state;
    let (history, len, pair, reversed) = stored;
    let o = law.evaluate_stored(kin, &mut s, history, len, pair, reversed, 0.0);
    ContactRecord {
        i,
        j,
        normal: kin.normal,
        branch,
        overlap: kin.overlap,
        lever_i: kin.lever_i,
        lever_j: kin.lever_j,
        normal_force: o.normal_force,
        tangential_force: o.tangential_force,
        rolling_torque: o.rolling_torque,
        normal_stiffness: o.normal_stiffness,
        tangential_stiffness: o.tangential_stiffness,
        sliding: state.sliding || o.sliding,
    }
}

impl<D: Dim> Simulation<D> {
    /// Contact records of every contact with ξ > 0, evaluated at the current positions,
    /// velocities and stored histories (histories are not advanced). Grain–grain contacts come
    /// first (ordered by grain storage index), then grain–wall contacts.
    pub fn contact_records(&self) -> Vec<ContactRecord<D>> {
        let g = &self.grains;
        let mut out = Vec::new();
        // Grain i is the pair's lower storage index, whichever grain owns it in the list.
        // (pair, its index in the list, whether it was seen from its other grain)
        let mut pairs: Vec<(crate::neighbor::Pair<D>, usize, bool)> = self
            .nlist
            .pairs()
            .enumerate()
            .filter(|(_, p)| p.state.in_contact())
            .map(|(k, mut p)| {
                let swapped = p.i > p.j;
                if swapped {
                    std::mem::swap(&mut p.i, &mut p.j);
                    p.state.spring = -p.state.spring;
                    p.state.rolling = -p.state.rolling;
                }
                (p, k, swapped)
            })
            .collect();
        pairs.sort_unstable_by_key(|(p, _, _)| (p.i, p.j));
        let (history, len) = (&self.nlist.list.extra, self.nlist.list.len());
        for (p, k, swapped) in &pairs {
            let (i, j) = (p.i as usize, p.j as usize);
            let r = self.domain.displacement(g.pos[i], g.pos[j]);
            if let Some(kin) = pair_kinematics::<D>(r, g.radius[i], g.radius[j], g.mass[i], g.mass[j], g.vel[i], g.vel[j], g.omega[i], g.omega[j]) {
                out.push(record(&self.law, &kin, &p.state, (history, len, *k, *swapped), g.id[i], Counterpart::Grain(g.id[j]), r));
            }
        }
        let wall_pairs = &self.nlist.wall_pairs;
        for (n, wp) in wall_pairs.iter().enumerate() {
            if !wp.state.in_contact() {
                continue;
            }
            let k = wp.grain as usize;
            let wall = &self.domain.walls[wp.wall as usize];
            let h = wall.distance(g.pos[k]);
            if let Some(kin) = wall_kinematics::<D>(h, wall.normal, wall.velocity(), g.radius[k], g.mass[k], g.vel[k], g.omega[k]) {
                let branch = kin.normal * h;
                let history = self.nlist.wall_extra.column(wp.wall as usize);
                out.push(record(&wall.law, &kin, &wp.state, (history, wall_pairs.len(), n, false), g.id[k], Counterpart::Wall(wp.wall), branch));
            }
        }
        out
    }

    /// A snapshot of grains and contacts.
    pub fn snapshot(&self) -> Snapshot<D> {
        let g = &self.grains;
        Snapshot {
            kind: g.kind,
            step: self.step,
            time: self.time,
            id: g.id.clone(),
            radius: g.radius.clone(),
            mass: g.mass.clone(),
            inertia: g.inertia.clone(),
            pos: g.pos.clone(),
            image: g.image.clone(),
            vel: g.vel.clone(),
            omega: g.omega.clone(),
            rotation: g.orientation.iter().map(|&o| D::orientation_rotation_vector(o)).collect(),
            force: g.force.clone(),
            torque: g.torque.clone(),
            gravity: self.gravity,
            domain: self.domain.clone(),
            law: self.law,
            contacts: self.contact_records(),
        }
    }
}

impl<D: Dim> Snapshot<D> {
    /// Number of grains.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Storage index of every stable id: `index_by_id()[id]` is the position of grain `id` in the
    /// per-grain arrays (`usize::MAX` for ids not present). Contact records name grains by id.
    /// Its memory is bounded by the number of grains, whatever the ids ([`IdIndex`]).
    pub fn index_by_id(&self) -> IdIndex {
        IdIndex::new(&self.id)
    }

    /// Sum of the normal loads of all contacts with wall `w`: the force the grains exert on it
    /// along its outward direction (equal to the push of the wall on the grains along its normal).
    pub fn wall_load(&self, w: u32) -> f64 {
        let n = self.domain.walls[w as usize].normal;
        self.contacts.iter().filter(|c| c.j == Counterpart::Wall(w)).map(|c| c.force_on_i().dot(n)).sum()
    }
}

/// Storage index of the grains of a snapshot by stable id ([`Snapshot::index_by_id`]):
/// `index[id]` is the position of grain `id` in the per-grain arrays, `usize::MAX` for an id not
/// present; [`IdIndex::get`] is `None` beyond the largest id.
///
/// Dense (one entry per id up to the largest) when the ids are dense, as in any snapshot of a
/// simulation (ids are handed out in order; removed grains leave gaps): at most
/// [`IdIndex::DENSE_FACTOR`] entries per grain plus [`IdIndex::DENSE_SLACK`]. Sparser ids (a
/// checkpoint crafted with ids up to 2³²) are kept as sorted (id, position) pairs instead, so the
/// memory is bounded by the number of grains, never by the value of an id.
#[derive(Clone, Debug)]
pub struct IdIndex {
    dense: Vec<usize>,
    sparse: Vec<(u32, usize)>,
}

impl IdIndex {
    /// Largest number of dense entries per grain.
    pub const DENSE_FACTOR: usize = 4;
    /// Dense entries allowed beyond `DENSE_FACTOR` per grain (small snapshots with gaps).
    pub const DENSE_SLACK: usize = 1024;

    /// The index of `ids` (position k holds id `ids[k]`).
    pub fn new(ids: &[u32]) -> Self {
        let len = ids.iter().copied().max().map_or(0, |m| m as usize + 1);
        if len <= Self::DENSE_FACTOR.saturating_mul(ids.len()).saturating_add(Self::DENSE_SLACK) {
            let mut dense = vec![usize::MAX; len];
            for (k, &id) in ids.iter().enumerate() {
                dense[id as usize] = k;
            }
            IdIndex { dense, sparse: Vec::new() }
        } else {
            let mut sparse: Vec<(u32, usize)> = ids.iter().copied().zip(0..).collect();
            // a repeated id keeps its last position, as the dense index does
            sparse.sort_by_key(|&(id, k)| (id, std::cmp::Reverse(k)));
            sparse.dedup_by_key(|p| p.0);
            IdIndex { dense: Vec::new(), sparse }
        }
    }

    /// Position of grain `id`: `Some(usize::MAX)` for an id below the largest that is not
    /// present, `None` beyond the largest (as `Vec::get` of the dense index).
    pub fn get(&self, id: usize) -> Option<&usize> {
        if self.sparse.is_empty() {
            return self.dense.get(id);
        }
        let last = self.sparse.last().map_or(0, |p| p.0 as usize);
        if id > last {
            return None;
        }
        match self.sparse.binary_search_by_key(&id, |p| p.0 as usize) {
            Ok(k) => Some(&self.sparse[k].1),
            Err(_) => Some(&MISSING),
        }
    }

    /// Entries held (dense: largest id + 1; sparse: grains).
    pub fn stored(&self) -> usize {
        self.dense.len() + self.sparse.len()
    }
}

static MISSING: usize = usize::MAX;

impl std::ops::Index<usize> for IdIndex {
    type Output = usize;
    /// Position of grain `id`, `usize::MAX` when absent; panics beyond the largest id (as a `Vec`).
    fn index(&self, id: usize) -> &usize {
        match self.get(id) {
            Some(k) => k,
            None => panic!("grain id {id} is beyond the largest id of the snapshot"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::IdIndex;

    #[test]
    fn dense_ids_are_indexed_directly() {
        let ids = [3u32, 0, 5, 1];
        let index = IdIndex::new(&ids);
        for (k, &id) in ids.iter().enumerate() {
            assert_eq!(index[id as usize], k);
        }
        assert_eq!(index[2], usize::MAX, "an id in a gap is absent");
        assert_eq!(index.get(6), None, "beyond the largest id");
        assert_eq!(index.stored(), 6, "one entry per id up to the largest");
    }

    #[test]
    fn a_huge_id_allocates_by_the_grains_not_by_the_id() {
        // before: `vec![usize::MAX; max id + 1]`, 32 GiB for an id of 2³² − 1 (a crafted
        // checkpoint with a valid checksum)
        let ids = [7u32, u32::MAX - 1, 2, 7];
        let index = IdIndex::new(&ids);
        assert_eq!(index.stored(), 3, "sparse ids: one entry per distinct grain");
        assert_eq!(index[(u32::MAX - 1) as usize], 1);
        assert_eq!(index.get(u32::MAX as usize), None);
        // the answer of a plain scan (the last position of the id; absent: usize::MAX up to
        // the largest id, None beyond), for ids in the gaps, at the ends and repeated
        let scan = |id: usize| -> Option<usize> {
            if id > (u32::MAX - 1) as usize {
                return None;
            }
            Some(ids.iter().rposition(|&x| x as usize == id).unwrap_or(usize::MAX))
        };
        for id in [0usize, 1, 2, 3, 6, 7, 8, 1000, (u32::MAX - 2) as usize, (u32::MAX - 1) as usize, u32::MAX as usize] {
            assert_eq!(index.get(id).copied(), scan(id), "id {id}");
        }
    }
}
