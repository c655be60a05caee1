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

fn record<D: Dim>(law: &ContactLaw, kin: &Kinematics<D>, state: &ContactState<D>, i: u32, j: Counterpart, branch: D::Vector) -> ContactRecord<D> {
    // Re-evaluate on a copy with dt = 0: histories are not advanced.
    let mut s = *state;
    let o = law.evaluate(kin, &mut s, 0.0);
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
        let mut pairs: Vec<crate::neighbor::Pair<D>> = self
            .nlist
            .pairs()
            .filter(|p| p.state.in_contact())
            .map(|mut p| {
                if p.i > p.j {
                    std::mem::swap(&mut p.i, &mut p.j);
                    p.state.spring = -p.state.spring;
                    p.state.rolling = -p.state.rolling;
                }
                p
            })
            .collect();
        pairs.sort_unstable_by_key(|p| (p.i, p.j));
        for p in &pairs {
            let (i, j) = (p.i as usize, p.j as usize);
            let r = self.domain.displacement(g.pos[i], g.pos[j]);
            if let Some(kin) = pair_kinematics::<D>(r, g.radius[i], g.radius[j], g.mass[i], g.mass[j], g.vel[i], g.vel[j], g.omega[i], g.omega[j]) {
                out.push(record(&self.law, &kin, &p.state, g.id[i], Counterpart::Grain(g.id[j]), r));
            }
        }
        for wp in &self.nlist.wall_pairs {
            if !wp.state.in_contact() {
                continue;
            }
            let k = wp.grain as usize;
            let wall = &self.domain.walls[wp.wall as usize];
            let h = wall.distance(g.pos[k]);
            if let Some(kin) = wall_kinematics::<D>(h, wall.normal, wall.velocity(), g.radius[k], g.mass[k], g.vel[k], g.omega[k]) {
                let branch = kin.normal * h;
                out.push(record(&wall.law, &kin, &wp.state, g.id[k], Counterpart::Wall(wp.wall), branch));
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
    pub fn index_by_id(&self) -> Vec<usize> {
        let len = self.id.iter().copied().max().map_or(0, |m| m as usize + 1);
        let mut index = vec![usize::MAX; len];
        for (k, &id) in self.id.iter().enumerate() {
            index[id as usize] = k;
        }
        index
    }

    /// Sum of the normal loads of all contacts with wall `w`: the force the grains exert on it
    /// along its outward direction (equal to the push of the wall on the grains along its normal).
    pub fn wall_load(&self, w: u32) -> f64 {
        let n = self.domain.walls[w as usize].normal;
        self.contacts.iter().filter(|c| c.j == Counterpart::Wall(w)).map(|c| c.force_on_i().dot(n)).sum()
    }
}
