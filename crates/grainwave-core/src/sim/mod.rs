//! The simulation: grains + domain + contact laws + contact store + integrator.

mod builder;
mod forces;
mod integrate;
mod lanes;
mod run;
mod sort;
mod validate;

pub use builder::{ExternalLoad, SimulationBuilder};
pub use run::{Control, Progress, RunHooks, RunOutcome, StopCriteria, StopReason};

use crate::contact::{ContactLaw, ContactState};
use crate::dim::{Dim, VectorOps};
use crate::domain::Domain;
use crate::grains::Grains;
use crate::neighbor::{NeighborList, WallIndex};
use crate::util::Fnv64;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Time integration scheme (SPEC §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Integrator {
    /// Velocity Verlet (default): kick–drift–kick; forces see half-step velocities.
    VelocityVerlet,
    /// Beeman's predictor–corrector: x += v dt + (4a − a_prev) dt²/6,
    /// v += (2a_new + 5a − a_prev) dt/6; forces see the predicted velocity v + (3a − a_prev) dt/2.
    Beeman,
}

impl Integrator {
    /// Parses `velocity_verlet` or `beeman`.
    pub fn from_name(name: &str) -> crate::Result<Self> {
        match name {
            "velocity_verlet" => Ok(Integrator::VelocityVerlet),
            "beeman" => Ok(Integrator::Beeman),
            _ => Err(crate::CoreError::UnknownName {
                what: "integrator".into(),
                name: name.into(),
                available: "velocity_verlet, beeman".into(),
            }),
        }
    }
}

/// Numerical safety settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Safety {
    /// A contact whose overlap exceeds this fraction of the smaller radius stops the run (blow-up).
    pub max_overlap_fraction: f64,
}

impl Default for Safety {
    fn default() -> Self {
        Safety { max_overlap_fraction: 0.3 }
    }
}

/// Counters updated every step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Counters {
    /// Contacts that formed or broke at the last step.
    pub network_changes: u64,
    /// Consecutive steps (up to now) without any contact forming or breaking.
    pub steps_network_unchanged: u64,
    /// Contacts in contact at the last step (grain–grain + grain–wall).
    pub contacts: u64,
    /// Sliding contacts at the last step.
    pub sliding: u64,
    /// Largest overlap / smaller radius seen since the start.
    pub max_overlap_ratio_seen: f64,
}

/// A discrete-element simulation in dimension `D`.
///
/// Everything that influences the future is a serialized field, so a checkpoint of this struct
/// continues bit for bit; the `work` buffers are derived and rebuilt on demand.
///
/// Deserializing goes through [`Decoded`] (the same fields in the same order, so the encoding is
/// unchanged) and checks every invariant the engine relies on (`sim::validate`): a crafted or
/// corrupted state is refused with "inconsistent: …", it never reaches the force passes.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "", try_from = "Decoded<D>")]
pub struct Simulation<D: Dim> {
    /// Grains (structure of arrays).
    pub grains: Grains<D>,
    /// Periodicity and walls (each wall carries its own contact law).
    pub domain: Domain<D>,
    /// Grain–grain contact law.
    pub law: ContactLaw,
    /// Gravitational acceleration.
    pub gravity: D::Vector,
    /// Per-grain external forces and torques.
    pub loads: Vec<ExternalLoad<D>>,
    /// Time integration scheme.
    pub integrator: Integrator,
    /// Time step.
    pub dt: f64,
    /// The time step suggested for this system (fraction × shortest contact period).
    pub suggested_dt: f64,
    /// Fraction of the shortest contact period used for suggestions.
    pub dt_fraction: f64,
    /// Expected largest overlap (fraction of the largest radius) used for Hertz stiffness.
    pub expected_overlap: f64,
    /// Simulated time.
    pub time: f64,
    /// Steps done.
    pub step: u64,
    /// Safety settings.
    pub safety: Safety,
    /// Neighbor list and contact histories.
    pub nlist: NeighborList<D>,
    /// Translational accelerations of the previous step (Beeman only).
    pub prev_acc: Vec<D::Vector>,
    /// Angular accelerations of the previous step (Beeman only).
    pub prev_ang_acc: Vec<D::AngVector>,
    /// Step counters.
    pub counters: Counters,
    /// Seed the run was started with.
    pub seed: u64,
    /// Random generator (its state is part of checkpoints).
    pub rng: ChaCha8Rng,
    /// Warnings raised so far (each once).
    pub warnings: Vec<String>,
    #[serde(skip)]
    work: Workspace<D>,
}

/// The serialized fields of a [`Simulation`], in its order, as decoded, before the checks of
/// `sim::validate`. Keep it in step with [`Simulation`]: a field added there must be added here
/// at the same place (the conversion below names every field, so a missing one does not compile;
/// the checkpoint round-trip tests catch a different order).
#[derive(Deserialize)]
#[serde(bound = "")]
struct Decoded<D: Dim> {
    grains: Grains<D>,
    domain: Domain<D>,
    law: ContactLaw,
    gravity: D::Vector,
    loads: Vec<ExternalLoad<D>>,
    integrator: Integrator,
    dt: f64,
    suggested_dt: f64,
    dt_fraction: f64,
    expected_overlap: f64,
    time: f64,
    step: u64,
    safety: Safety,
    nlist: NeighborList<D>,
    prev_acc: Vec<D::Vector>,
    prev_ang_acc: Vec<D::AngVector>,
    counters: Counters,
    seed: u64,
    rng: ChaCha8Rng,
    warnings: Vec<String>,
}

impl<D: Dim> TryFrom<Decoded<D>> for Simulation<D> {
    type Error = String;

    /// The simulation, when it passes every check of `sim::validate`; otherwise
    /// "inconsistent: " and what is wrong (the decoders report it as a checkpoint error).
    fn try_from(d: Decoded<D>) -> Result<Self, String> {
        let Decoded { grains, domain, law, gravity, loads, integrator, dt, suggested_dt, dt_fraction, expected_overlap, time, step, safety, nlist, prev_acc, prev_ang_acc, counters, seed, rng, warnings } = d;
        let sim = Simulation {
            grains,
            domain,
            law,
            gravity,
            loads,
            integrator,
            dt,
            suggested_dt,
            dt_fraction,
            expected_overlap,
            time,
            step,
            safety,
            nlist,
            prev_acc,
            prev_ang_acc,
            counters,
            seed,
            rng,
            warnings,
            work: Workspace::default(),
        };
        sim.check_decoded().map_err(|e| format!("{INCONSISTENT}{e}"))?;
        Ok(sim)
    }
}

/// Prefix of the message of a decoded simulation that fails the checks of `sim::validate`.
pub(crate) const INCONSISTENT: &str = "inconsistent: ";

/// Most steps a protocol runs between two looks at its interrupt flag when it steps in chunks of
/// a user-chosen length (`check_every`): a chunk of 2³² steps must not make Ctrl-C wait for it.
/// 100 steps of a 16 384-grain packing take a fraction of a second on one core.
pub const INTERRUPT_POLL_STEPS: u64 = 100;

/// Derived buffers, rebuilt when needed (allocated once, not per step).
#[derive(Clone, Debug)]
struct Workspace<D: Dim> {
    /// Cross-block pairs of the force pass.
    cross: CrossIndex<D>,
    /// Grains per block of the force pass, when fixed by hand (tests).
    block_len: Option<usize>,
    /// Evaluate every law with the general kernel (tests).
    general_kernel: bool,
    /// Vector path of the specialised kernels when the processor has it: 0 none (portable), 1
    /// the fused AVX2 pass, 2 the AVX-512 windows, 3 the fused pass on 512-bit lanes (default;
    /// the next lower level where the processor lacks it). Tests and benchmarks set it.
    simd: u8,
    /// External loads of the current evaluation: (grain index, force, torque).
    loads: Vec<(usize, D::Vector, D::AngVector)>,
    wall_force: Vec<WallForce<D>>,
    wall_index: WallIndex,
    wall_index_builds: u64,
    /// Beeman: predicted velocities seen by the forces.
    vel_eval: Vec<D::Vector>,
    omega_eval: Vec<D::AngVector>,
    /// Beeman: accelerations a(t) of the current step.
    acc: Vec<D::Vector>,
    ang_acc: Vec<D::AngVector>,
    /// Beeman: wall accelerations of the current step.
    wall_accel: Vec<f64>,
}

impl<D: Dim> Default for Workspace<D> {
    fn default() -> Self {
        Workspace {
            cross: CrossIndex::default(),
            block_len: None,
            general_kernel: false,
            simd: 3,
            loads: Vec::new(),
            wall_force: Vec::new(),
            wall_index: WallIndex::default(),
            wall_index_builds: u64::MAX,
            vel_eval: Vec::new(),
            omega_eval: Vec::new(),
            acc: Vec::new(),
            ang_acc: Vec::new(),
            wall_accel: Vec::new(),
        }
    }
}

/// Force on i and torques on i and j of a pair whose grains are in different blocks of the force
/// pass (see `forces`).
#[derive(Clone, Copy, Debug, Default)]
struct CrossForce<D: Dim> {
    force: D::Vector,
    torque_i: D::AngVector,
    torque_j: D::AngVector,
}

/// Which pairs of the neighbor list cross block boundaries, and where their forces go.
#[derive(Clone, Debug)]
struct CrossIndex<D: Dim> {
    /// Neighbor-list build this index was made for.
    builds: u64,
    /// Grains per block.
    block_len: usize,
    /// Number of grains.
    n: usize,
    /// Per pair: its first grain (the owner).
    owner: Vec<u32>,
    /// Per grain: its first pair whose partner lies in a later block.
    cross_begin: Vec<u32>,
    /// Per grain: buffer slot of that pair (its cross pairs use consecutive slots).
    cross_slot: Vec<u32>,
    /// First slot of each block.
    block_slot_start: Vec<u32>,
    /// Pair of each slot.
    slot_pair: Vec<u32>,
    /// Slots whose partner is grain j: `in_slot[in_start[j]..in_start[j + 1]]`, by owner.
    in_start: Vec<u32>,
    in_slot: Vec<u32>,
    /// The buffer.
    forces: Vec<CrossForce<D>>,
    /// The close list (see `forces`, "Close list"): per block, the intra-block pairs that may
    /// touch before the grains move `close_margin / 2` from `close_ref`:
    /// `close_pair[close_start[b]..close_start[b + 1]]` in list order, with their owners and
    /// partners.
    close_start: Vec<u32>,
    close_pair: Vec<u32>,
    close_owner: Vec<u32>,
    close_partner: Vec<u32>,
    /// Per entry of the close list: the radii of owner and partner and the reduced mass
    /// m_i m_j / (m_i + m_j), read when the list is built (a group of the fused pass loads them
    /// as consecutive lanes instead of gathering four values per pair and dividing).
    close_rad_i: Vec<f64>,
    close_rad_j: Vec<f64>,
    close_m_eff: Vec<f64>,
    /// Positions and cell tilt when the close list was built.
    close_ref: Vec<D::Vector>,
    close_tilt: [f64; 3],
    /// Its margin (length); 0: no close list is kept (built on demand).
    close_margin: f64,
    /// The close list is valid for the current pair list and blocks.
    close_ok: bool,
    /// max|x − close_ref|² when already measured for the current positions (by the drift
    /// pass); taken by the next force evaluation.
    close_known: Option<f64>,
    /// Close-list builds so far (a diagnostic).
    close_builds: u64,
}

impl<D: Dim> Default for CrossIndex<D> {
    fn default() -> Self {
        CrossIndex {
            builds: u64::MAX,
            block_len: 0,
            n: 0,
            owner: Vec::new(),
            cross_begin: Vec::new(),
            cross_slot: Vec::new(),
            block_slot_start: Vec::new(),
            slot_pair: Vec::new(),
            in_start: Vec::new(),
            in_slot: Vec::new(),
            forces: Vec::new(),
            close_start: Vec::new(),
            close_pair: Vec::new(),
            close_owner: Vec::new(),
            close_partner: Vec::new(),
            close_rad_i: Vec::new(),
            close_rad_j: Vec::new(),
            close_m_eff: Vec::new(),
            close_ref: Vec::new(),
            close_tilt: [0.0; 3],
            close_margin: 0.0,
            close_ok: false,
            close_known: None,
            close_builds: 0,
        }
    }
}

/// Force and torque of one grain–wall contact on the grain.
#[derive(Clone, Copy, Debug, Default)]
struct WallForce<D: Dim> {
    force: D::Vector,
    torque: D::AngVector,
}

impl<D: Dim> Simulation<D> {
    /// Number of grains.
    pub fn len(&self) -> usize {
        self.grains.len()
    }

    /// True when there are no grains.
    pub fn is_empty(&self) -> bool {
        self.grains.is_empty()
    }

    /// Kinetic energy (translational + rotational).
    pub fn kinetic_energy(&self) -> f64 {
        let g = &self.grains;
        crate::util::det_sum(g.len(), |k| 0.5 * g.mass[k] * g.vel[k].norm2() + 0.5 * g.inertia[k] * g.omega[k].norm2())
    }

    /// Elastic energy stored in all contacts (normal, tangential and rolling springs).
    pub fn elastic_energy(&self) -> f64 {
        let g = &self.grains;
        let pairs: Vec<crate::neighbor::Pair<D>> = self.nlist.pairs().collect();
        // the law's own history column is in list order, the order of `pairs`
        let history = &self.nlist.list.extra;
        let e_pairs = crate::util::det_sum(pairs.len(), |k| {
            let p = &pairs[k];
            let (i, j) = (p.i as usize, p.j as usize);
            let d = self.domain.displacement(g.pos[i], g.pos[j]).norm();
            let xi = g.radius[i] + g.radius[j] - d;
            let r_eff = g.radius[i] * g.radius[j] / (g.radius[i] + g.radius[j]);
            self.law.elastic_energy_stored(xi, r_eff, &p.state, history, pairs.len(), k)
        });
        let mut e_walls = 0.0;
        let wall_pairs = &self.nlist.wall_pairs;
        for (k, wp) in wall_pairs.iter().enumerate() {
            let gi = wp.grain as usize;
            let wall = &self.domain.walls[wp.wall as usize];
            let xi = g.radius[gi] - wall.distance(g.pos[gi]);
            let history = self.nlist.wall_extra.column(wp.wall as usize);
            e_walls += wall.law.elastic_energy_stored(xi, g.radius[gi], &wp.state, history, wall_pairs.len(), k);
        }
        e_pairs + e_walls
    }

    /// Potential energy in the gravity field, −Σ m g·x (unwrapped positions).
    pub fn gravitational_energy(&self) -> f64 {
        let g = &self.grains;
        crate::util::det_sum(g.len(), |k| -g.mass[k] * self.gravity.dot(self.domain.unwrapped(g.pos[k], g.image[k])))
    }

    /// Fingerprint of the complete dynamic state (positions, velocities, rotations, histories,
    /// walls, time): equal hashes ⇔ (with overwhelming probability) identical bits.
    pub fn state_hash(&self) -> u64 {
        let mut h = Fnv64::default();
        let g = &self.grains;
        h.write_f64(self.time);
        h.write(&self.step.to_le_bytes());
        for k in 0..g.len() {
            h.write(&g.id[k].to_le_bytes());
            for c in g.pos[k].to_array3().into_iter().chain(g.vel[k].to_array3()).chain(g.omega[k].to_array3()) {
                h.write_f64(c);
            }
            for c in g.force[k].to_array3().into_iter().chain(g.torque[k].to_array3()) {
                h.write_f64(c);
            }
            for c in D::orientation_rotation_vector(g.orientation[k]) {
                h.write_f64(c);
            }
        }
        let mut hist = |s: &ContactState<D>| {
            for c in s.spring.0.to_array3().into_iter().chain(s.rolling.to_array3()) {
                h.write_f64(c);
            }
            h.write_f64(s.twist);
            h.write_f64(s.overlap);
            h.write(&[s.sliding as u8]);
        };
        for p in self.nlist.pairs() {
            hist(&p.state);
        }
        for p in &self.nlist.wall_pairs {
            hist(&p.state);
        }
        // the law's own history, where it has one (none for the laws without: their hashes
        // are those of before history columns existed)
        for c in self.nlist.list.extra.values() {
            h.write_f64(c);
        }
        for c in self.nlist.wall_extra.values() {
            h.write_f64(c);
        }
        for w in &self.domain.walls {
            for c in w.position.to_array3() {
                h.write_f64(c);
            }
            h.write_f64(w.speed);
        }
        h.finish()
    }

    /// Fixes the number of grains per block of the force pass (`None`: chosen from the number of
    /// threads). Results do not depend on it — this exists to test exactly that.
    #[doc(hidden)]
    pub fn set_force_block_len(&mut self, len: Option<usize>) {
        self.work.block_len = len.map(|l| l.max(1));
    }

    /// Evaluates every contact with the general kernel instead of a specialised one. Results do
    /// not depend on it — this exists to test exactly that.
    #[doc(hidden)]
    pub fn set_general_kernel(&mut self, on: bool) {
        self.work.general_kernel = on;
    }

    /// Lets the specialised kernels use the processor's vector extensions (default), or keeps
    /// them on the portable path. Results do not depend on it — this exists to test exactly that.
    #[doc(hidden)]
    pub fn set_simd(&mut self, on: bool) {
        self.work.simd = if on { 3 } else { 0 };
    }

    /// The vector path of the specialised kernels, when the processor has it: 0 none (the
    /// portable path), 1 the fused AVX2 pass, 2 the AVX-512 windows, 3 the fused pass on
    /// 512-bit lanes (the default; each level falls back to the next lower one the processor
    /// has). Results do not depend on it — this exists to test exactly that, and to compare the
    /// paths' speed.
    #[doc(hidden)]
    pub fn set_simd_level(&mut self, level: u8) {
        self.work.simd = level;
    }

    /// A fingerprint of the force pass's close list as it stands (pairs, owners, partners, block
    /// starts, radii and reduced masses; 0 when there is none). Not part of the state: it exists to test that the
    /// element-wise and AVX-512 filters build the same list.
    #[doc(hidden)]
    pub fn close_list_fingerprint(&self) -> u64 {
        let c = &self.work.cross;
        if !c.close_ok {
            return 0;
        }
        let mut h = crate::util::Fnv64::default();
        for a in [&c.close_start, &c.close_pair, &c.close_owner, &c.close_partner] {
            h.write(&(a.len() as u64).to_le_bytes());
            for &x in a.iter() {
                h.write(&x.to_le_bytes());
            }
        }
        for a in [&c.close_rad_i, &c.close_rad_j, &c.close_m_eff] {
            h.write(&(a.len() as u64).to_le_bytes());
            for &x in a.iter() {
                h.write(&x.to_le_bytes());
            }
        }
        h.finish()
    }

    /// How many times the force pass's close list was built (a diagnostic: the fused AVX2 pass
    /// keeps it, see `sim::forces`, "Close list"; 0 on the other paths). Not part of the state.
    pub fn close_list_builds(&self) -> u64 {
        self.work.cross.close_builds
    }

    /// Adds a warning once. A warning starting like an earlier one (same first four words, e.g.
    /// an updated time-step warning) replaces it.
    pub(crate) fn warn(&mut self, message: String) {
        let head = |m: &str| m.split_whitespace().take(4).collect::<Vec<_>>().join(" ");
        let h = head(&message);
        self.warnings.retain(|w| head(w) != h);
        self.warnings.push(message);
    }

    /// Marks the neighbor list stale (after changing radii, masses or the domain by hand) and
    /// recomputes forces without advancing time or histories.
    pub fn refresh(&mut self) -> crate::Result<()> {
        self.nlist.stale = true;
        self.refresh_forces()
    }

    /// Recomputes forces and torques at the current state without advancing time or histories
    /// (use after changing parameters, masses, velocities or loads by hand: the close list,
    /// which keeps radii and reduced masses of its pairs, is rebuilt).
    pub fn refresh_forces(&mut self) -> crate::Result<()> {
        D::engine_refresh_forces(self)
    }

    /// [`Simulation::refresh_forces`], compiled here for D2 and D3 ([`Dim::engine_step`]).
    pub(crate) fn refresh_forces_here(&mut self) -> crate::Result<()> {
        self.work.cross.close_ok = false;
        self.prepare_neighbors(None)?;
        self.compute_forces(0.0, false, None)?;
        self.update_piston_accelerations();
        if self.integrator == Integrator::Beeman {
            self.prev_acc = (0..self.len()).map(|k| self.grains.force[k] / self.grains.mass[k]).collect();
            self.prev_ang_acc = (0..self.len()).map(|k| self.grains.torque[k] / self.grains.inertia[k]).collect();
            for w in &mut self.domain.walls {
                w.prev_accel = w.accel;
            }
        }
        Ok(())
    }
}
