//! Validated construction of a [`Simulation`].

use super::{Counters, Integrator, Safety, Simulation, Workspace};
use crate::contact::ContactLaw;
use crate::dim::{Dim, VectorOps};
use crate::domain::{Domain, TimeFunction};
use crate::error::{require_finite, require_positive, CoreError, Result};
use crate::grains::Grains;
use crate::neighbor::NeighborList;
use crate::timestep::suggest_timestep;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// An external force and torque on one grain, scaled in time by `profile` (SPEC §1.3):
/// F(t) = force × profile(t), τ(t) = torque × profile(t).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct ExternalLoad<D: Dim> {
    /// Stable id of the grain.
    pub grain: u32,
    /// Force at full load.
    pub force: D::Vector,
    /// Torque at full load.
    pub torque: D::AngVector,
    /// Load factor in time (e.g. a ramp from 0 to 1).
    pub profile: TimeFunction,
}

/// Builder that validates every input before a [`Simulation`] exists.
#[derive(Clone, Debug)]
pub struct SimulationBuilder<D: Dim> {
    grains: Grains<D>,
    domain: Domain<D>,
    law: ContactLaw,
    gravity: D::Vector,
    loads: Vec<ExternalLoad<D>>,
    integrator: Integrator,
    dt: Option<f64>,
    dt_fraction: f64,
    expected_overlap: f64,
    skin: Option<f64>,
    max_initial_overlap: f64,
    safety: Safety,
    seed: u64,
}

impl<D: Dim> SimulationBuilder<D> {
    /// Starts from grains, a domain (with walls) and the grain–grain law.
    pub fn new(grains: Grains<D>, domain: Domain<D>, law: ContactLaw) -> Self {
        SimulationBuilder {
            grains,
            domain,
            law,
            gravity: D::Vector::ZERO,
            loads: Vec::new(),
            integrator: Integrator::VelocityVerlet,
            dt: None,
            dt_fraction: 0.02,
            expected_overlap: 0.01,
            skin: None,
            max_initial_overlap: 0.02,
            safety: Safety::default(),
            seed: 0,
        }
    }

    /// Gravitational acceleration (any direction).
    pub fn gravity(mut self, g: D::Vector) -> Self {
        self.gravity = g;
        self
    }

    /// Adds an external load on one grain.
    pub fn load(mut self, load: ExternalLoad<D>) -> Self {
        self.loads.push(load);
        self
    }

    /// Integration scheme (default velocity Verlet).
    pub fn integrator(mut self, integrator: Integrator) -> Self {
        self.integrator = integrator;
        self
    }

    /// Fixed time step (default: the suggested one).
    pub fn dt(mut self, dt: f64) -> Self {
        self.dt = Some(dt);
        self
    }

    /// Fraction f of the shortest contact period used for the suggested step (default 0.02).
    pub fn dt_fraction(mut self, f: f64) -> Self {
        self.dt_fraction = f;
        self
    }

    /// Largest expected overlap as a fraction of the largest radius, for the stiffness of Hertz
    /// contacts in the time-step suggestion (default 0.01).
    pub fn expected_overlap(mut self, fraction: f64) -> Self {
        self.expected_overlap = fraction;
        self
    }

    /// Verlet skin (default 0.2 × largest radius).
    pub fn skin(mut self, skin: f64) -> Self {
        self.skin = Some(skin);
        self
    }

    /// Largest initial overlap accepted, as a fraction of the smaller radius (default 0.02).
    pub fn max_initial_overlap(mut self, fraction: f64) -> Self {
        self.max_initial_overlap = fraction;
        self
    }

    /// Blow-up limits.
    pub fn safety(mut self, safety: Safety) -> Self {
        self.safety = safety;
        self
    }

    /// Seed of the simulation's random generator (recorded in outputs).
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Validates everything, builds the neighbor list, checks initial overlaps and computes the
    /// initial forces.
    pub fn build(self) -> Result<Simulation<D>> {
        let mut grains = self.grains;
        grains.kind.validate(D::D)?;
        if grains.is_empty() {
            return Err(CoreError::invalid("grains.count", 0, "at least one grain"));
        }
        for k in 0..grains.len() {
            let id = grains.id[k];
            let r = grains.radius[k];
            if !(r.is_finite() && r > 0.0) {
                return Err(CoreError::invalid(format!("grains.radius (grain id {id})"), r, "a finite radius > 0"));
            }
            let m = grains.mass[k];
            if !(m.is_finite() && m > 0.0) {
                return Err(CoreError::invalid(format!("grains.mass (grain id {id})"), m, "a finite mass > 0 (check the density)"));
            }
            if !grains.pos[k].is_finite_vec() || !grains.vel[k].is_finite_vec() || !grains.omega[k].is_finite_vec() {
                return Err(CoreError::invalid(
                    format!("grains.position/velocity (grain id {id})"),
                    format!("{:?} / {:?}", grains.pos[k], grains.vel[k]),
                    "finite numbers",
                ));
            }
        }
        let mut sorted_ids = grains.id.clone();
        sorted_ids.sort_unstable();
        if sorted_ids.windows(2).any(|w| w[0] == w[1]) {
            return Err(CoreError::Inconsistent("grain ids are not unique".into()));
        }
        self.law.validate("contact")?;
        for k in 0..D::D {
            require_finite(&format!("gravity[{k}]"), self.gravity.get(k))?;
        }
        if !(self.dt_fraction > 0.0 && self.dt_fraction <= 0.2) {
            return Err(CoreError::invalid("dt_fraction", self.dt_fraction, "a fraction of the contact period in (0, 0.2]"));
        }
        require_positive("expected_overlap", self.expected_overlap)?;
        if !(self.max_initial_overlap >= 0.0 && self.max_initial_overlap < 1.0) {
            return Err(CoreError::invalid("max_initial_overlap", self.max_initial_overlap, "a fraction in [0, 1)"));
        }
        if !(self.safety.max_overlap_fraction > 0.0 && self.safety.max_overlap_fraction <= 1.0) {
            return Err(CoreError::invalid("max_overlap_fraction", self.safety.max_overlap_fraction, "a fraction in (0, 1]"));
        }
        let (_, r_max) = grains.radius_range();
        let skin = self.skin.unwrap_or(0.2 * r_max);
        require_positive("skin", skin)?;
        self.domain.validate(2.0 * r_max + skin)?;
        for (k, load) in self.loads.iter().enumerate() {
            if grains.index_of(load.grain).is_none() {
                return Err(CoreError::invalid(format!("loads[{k}].grain"), load.grain, "the id of an existing grain"));
            }
            if !load.force.is_finite_vec() || !load.torque.is_finite_vec() {
                return Err(CoreError::invalid(format!("loads[{k}].force"), format!("{:?}", load.force), "finite numbers"));
            }
            load.profile.validate(&format!("loads[{k}].profile"))?;
        }
        let suggested = suggest_timestep(&grains, &self.law, &self.domain.walls, self.dt_fraction, self.expected_overlap);
        let dt = match self.dt {
            Some(dt) => {
                if !(dt.is_finite() && dt > 0.0) {
                    return Err(CoreError::invalid("dt", dt, "a finite time step > 0"));
                }
                dt
            }
            None => suggested,
        };
        // Wrap into the periodic cell; refuse grains behind walls.
        for k in 0..grains.len() {
            let (mut x, mut im) = (grains.pos[k], grains.image[k]);
            self.domain.wrap(&mut x, &mut im);
            grains.pos[k] = x;
            grains.image[k] = im;
            for wall in &self.domain.walls {
                if wall.distance(x) < 0.0 {
                    return Err(CoreError::Inconsistent(format!(
                        "grain id {} at {:?} is behind wall `{}`",
                        grains.id[k], x, wall.name
                    )));
                }
            }
        }
        let mut sim = Simulation {
            grains,
            domain: self.domain,
            law: self.law,
            gravity: self.gravity,
            loads: self.loads,
            integrator: self.integrator,
            dt,
            suggested_dt: suggested,
            dt_fraction: self.dt_fraction,
            expected_overlap: self.expected_overlap,
            time: 0.0,
            step: 0,
            safety: self.safety,
            nlist: NeighborList::new(skin),
            prev_acc: Vec::new(),
            prev_ang_acc: Vec::new(),
            counters: Counters::default(),
            seed: self.seed,
            rng: ChaCha8Rng::seed_from_u64(self.seed),
            warnings: Vec::new(),
            work: Workspace::default(),
        };
        if dt > suggested {
            sim.warn(format!(
                "time step {dt:.4e} exceeds the suggested {suggested:.4e} ({} of the shortest contact period)",
                self.dt_fraction
            ));
        }
        sim.check_initial_overlaps(self.max_initial_overlap)?;
        sim.refresh_forces()?;
        // Building is not a step: contacts present at the start did not "form".
        sim.counters.network_changes = 0;
        Ok(sim)
    }
}

impl<D: Dim> Simulation<D> {
    /// Refuses initial overlaps beyond `tolerance` × the smaller radius (walls: × the radius).
    fn check_initial_overlaps(&mut self, tolerance: f64) -> Result<()> {
        self.prepare_neighbors(None)?;
        let g = &self.grains;
        for p in self.nlist.pairs() {
            let (i, j) = (p.i as usize, p.j as usize);
            let d = self.domain.displacement(g.pos[i], g.pos[j]).norm();
            let xi = g.radius[i] + g.radius[j] - d;
            let rel = xi / g.radius[i].min(g.radius[j]);
            if rel > tolerance {
                return Err(CoreError::InitialOverlap { id_a: g.id[i], id_b: g.id[j], overlap: xi, relative: rel, tolerance });
            }
        }
        for wp in &self.nlist.wall_pairs {
            let gi = wp.grain as usize;
            let wall = &self.domain.walls[wp.wall as usize];
            let xi = g.radius[gi] - wall.distance(g.pos[gi]);
            if xi / g.radius[gi] > tolerance {
                return Err(CoreError::Inconsistent(format!(
                    "grain id {} overlaps wall `{}` by {xi:.6e} = {:.4} of its radius at the start (allowed: {tolerance}, key `max_initial_overlap`)",
                    g.id[gi],
                    wall.name,
                    xi / g.radius[gi]
                )));
            }
        }
        Ok(())
    }
}
