//! The demo: a gravity-settled pile of polydisperse disks in a box.
//!
//! A loose gas of disks is placed at random (without overlaps) in the upper part of a box with
//! four fixed walls. The disks fall under gravity, collide (Hooke normal spring with a dashpot,
//! Cundall–Strack friction between grains) and settle until static equilibrium. The side walls
//! are frictionless, so at equilibrium the floor carries the entire weight W = Σ_i m_i g:
//!
//! F_floor = W, exactly up to the residual accelerations,
//!
//! because the vertical momentum balance of all grains reads F_floor − W = Σ_i m_i a_i,y (the
//! frictionless side walls push horizontally only, the floor's friction and rolling resistance
//! act horizontally and on rotations, the top wall is not touched). The stop criterion bounds the
//! largest acceleration, |a_i| < a_tol, hence |F_floor/W − 1| < a_tol/g. Horizontally, the
//! loads on the left and right walls differ by the shear force on the floor.
//!
//! Outputs (in the output directory): `summary.json` (the [`DemoReport`]) and `grains.csv`
//! (one row per grain, see [`grainwave_io::grains_csv`]).

use crate::error::Result;
use glam::DVec2;
use grainwave_core::contact::ContactParams;
use grainwave_core::placement::random_gas;
use grainwave_core::prelude::*;
use grainwave_core::CoreError;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Name of the summary file in the output directory.
pub const SUMMARY_FILE: &str = "summary.json";
/// Name of the per-grain table in the output directory.
pub const GRAINS_FILE: &str = "grains.csv";

/// Random placement attempts per grain before the gas is declared too dense for its region.
const PLACEMENT_ATTEMPTS: usize = 100_000;

/// Units note written into every summary.
pub const UNITS_NOTE: &str = "All quantities are in the units of the config. With the defaults (mean diameter d = 1, \
density ρ = 1 per unit thickness W = 1, g = 1): lengths in d, masses in ρ W d², times in √(d/g), forces in ρ W d² g, \
energies in ρ W d³ g, stiffnesses in ρ W d g. A disk of diameter 1 has mass π/4.";

/// Parameters of the demo. Every field has a default, so `{}` is a valid config.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DemoConfig {
    /// Number of disks (default 300).
    pub grains: usize,
    /// Distribution of radii (default: diameters uniform in [0.8, 1.2], i.e. mean diameter 1,
    /// spread 0.2).
    pub sizes: SizeDistribution,
    /// Density ρ (mass per unit area per unit thickness; default 1).
    pub density: f64,
    /// Disk thickness W (default 1: masses are per unit thickness).
    pub thickness: f64,
    /// Inner width of the box, walls at x = 0 and x = `box_width` (default 20).
    pub box_width: f64,
    /// Inner height of the box, walls at y = 0 and y = `box_height` (default 45).
    pub box_height: f64,
    /// The gas is placed in the region `gas_bottom` ≤ y ≤ `box_height` (default 10).
    pub gas_bottom: f64,
    /// Magnitude g of gravity, pointing along −y (default 1).
    pub gravity: f64,
    /// Grain–grain contact parameters (default: preset `hooke_cundall_strack`, normal stiffness
    /// 1e4, restitution 0.5, friction 0.3).
    pub contact: ContactParams,
    /// Floor contact: `contact` with these fields replaced (default: same friction as the
    /// grains, plus rolling resistance k_r = 700, γ_r = 5, μ_r = 0.1). The floor pushes along its
    /// normal (vertically), so neither its friction nor its rolling resistance changes the
    /// vertical balance. They stop the grains that end up on the floor in a gap between two
    /// neighbours: on a frictionless floor such a grain keeps spinning and sliding, on a floor
    /// without rolling resistance it keeps rolling, and the kinetic energy takes very long to
    /// vanish (measured: 3e-12 per grain still at t ≈ 800 for the default seed).
    pub floor: WallContact,
    /// Side and top walls: `contact` with these fields replaced (default: friction 0). Friction
    /// on the side walls would let them carry part of the weight (Janssen effect), and the floor
    /// would no longer carry all of it.
    pub walls: WallContact,
    /// Fraction of the shortest contact period used as time step (default 0.02).
    pub dt_fraction: f64,
    /// Seed of the random placement and radii (default 42).
    pub seed: u64,
    /// When to stop (default: kinetic energy per grain < 1e-12 and largest acceleration
    /// < 1e-7 g, checked every 100 steps, at most 2,000,000 steps).
    pub stop: StopCriteria,
}

impl Default for DemoConfig {
    fn default() -> Self {
        let mut contact = ContactParams::preset("hooke_cundall_strack");
        contact.normal_stiffness = Some(1e4);
        contact.restitution = Some(0.5);
        contact.friction = Some(0.3);
        DemoConfig {
            grains: 300,
            sizes: SizeDistribution::UniformDiameter { mean_diameter: 1.0, spread: 0.2 },
            density: 1.0,
            thickness: 1.0,
            box_width: 20.0,
            box_height: 45.0,
            gas_bottom: 10.0,
            gravity: 1.0,
            contact,
            floor: WallContact {
                friction: None,
                rolling_stiffness: Some(700.0),
                rolling_damping: Some(5.0),
                rolling_friction: Some(0.1),
            },
            walls: WallContact { friction: Some(0.0), ..Default::default() },
            dt_fraction: 0.02,
            seed: 42,
            stop: StopCriteria {
                step_limit: Some(2_000_000),
                kinetic_energy_per_grain: Some(1e-12),
                max_acceleration: Some(1e-7),
                check_every: 100,
                ..Default::default()
            },
        }
    }
}

impl DemoConfig {
    /// Checks every parameter that the engine does not check itself; errors name the key
    /// (`demo.<field>`), the value and what is allowed.
    pub fn validate(&self) -> Result<()> {
        let positive = |key: &str, v: f64| -> Result<()> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(CoreError::invalid(format!("demo.{key}"), v, "a finite number > 0").into())
            }
        };
        if self.grains == 0 {
            return Err(CoreError::invalid("demo.grains", 0, "at least one grain").into());
        }
        positive("density", self.density)?;
        positive("thickness", self.thickness)?;
        positive("box_width", self.box_width)?;
        positive("box_height", self.box_height)?;
        positive("gravity", self.gravity)?;
        if !(self.gas_bottom.is_finite() && self.gas_bottom >= 0.0 && self.gas_bottom < self.box_height) {
            return Err(CoreError::invalid("demo.gas_bottom", self.gas_bottom, format!("a height in [0, box_height = {})", self.box_height)).into());
        }
        self.stop.validate()?;
        Ok(())
    }

    /// Total weight the floor should carry at equilibrium: Σ m_i g.
    fn weight(&self, grains: &Grains<D2>) -> f64 {
        grains.total_mass() * self.gravity
    }

    /// Builds the simulation: radii and positions drawn with `ChaCha8Rng::seed_from_u64(seed)`
    /// (radii first, then positions), four fixed walls, gravity along −y.
    pub fn build(&self) -> Result<Simulation<D2>> {
        self.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let radii = self.sizes.sample(self.grains, &mut rng).map_err(|e| rename_size_error(e, "demo.sizes"))?;
        let lo = DVec2::new(0.0, self.gas_bottom);
        let hi = DVec2::new(self.box_width, self.box_height);
        let positions = random_gas::<D2>(&radii, lo, hi, [false; 3], &mut rng, PLACEMENT_ATTEMPTS)?;
        let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: self.thickness });
        for (x, r) in positions.into_iter().zip(&radii) {
            grains.push(x, *r, self.density, DVec2::ZERO);
        }
        let law = self.contact.build(Partner::Grain, "demo.contact")?;
        let floor_law = self.floor.apply(&self.contact).build(Partner::Wall, "demo.floor")?;
        let wall_law = self.walls.apply(&self.contact).build(Partner::Wall, "demo.walls")?;
        let (w, h) = (self.box_width, self.box_height);
        let domain = Domain::new(DVec2::ZERO, DVec2::new(w, h), [false; 3])
            .with_wall(Wall::axis_aligned("bottom", 1, 0.0, true, floor_law))
            .with_wall(Wall::axis_aligned("left", 0, 0.0, true, wall_law))
            .with_wall(Wall::axis_aligned("right", 0, w, false, wall_law))
            .with_wall(Wall::axis_aligned("top", 1, h, false, wall_law));
        let sim = SimulationBuilder::new(grains, domain, law)
            .gravity(DVec2::new(0.0, -self.gravity))
            .dt_fraction(self.dt_fraction)
            .seed(self.seed)
            .build()?;
        Ok(sim)
    }
}

/// The parameters of a wall's contact law that may differ from the grain–grain ones; the law is
/// built from `contact` with every field given here replaced.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WallContact {
    /// Coulomb friction coefficient μ.
    pub friction: Option<f64>,
    /// Rolling stiffness k_r (torque per radian); rolling resistance is on when given.
    pub rolling_stiffness: Option<f64>,
    /// Rolling damping γ_r (torque × time per radian).
    pub rolling_damping: Option<f64>,
    /// Rolling friction μ_r: the rolling torque is capped at μ_r R F_n.
    pub rolling_friction: Option<f64>,
}

impl WallContact {
    /// `base` with the fields given here replaced.
    pub fn apply(&self, base: &ContactParams) -> ContactParams {
        ContactParams {
            friction: self.friction.or(base.friction),
            rolling_stiffness: self.rolling_stiffness.or(base.rolling_stiffness),
            rolling_damping: self.rolling_damping.or(base.rolling_damping),
            rolling_friction: self.rolling_friction.or(base.rolling_friction),
            ..base.clone()
        }
    }
}

/// Prefixes the key of a size-distribution error with its place in the config.
fn rename_size_error(e: CoreError, prefix: &str) -> CoreError {
    match e {
        CoreError::InvalidParameter { field, value, allowed } => {
            CoreError::InvalidParameter { field: format!("{prefix}.{field}"), value, allowed }
        }
        other => other,
    }
}

/// Index of each wall in the domain built by [`DemoConfig::build`].
const BOTTOM: u32 = 0;
const LEFT: u32 = 1;
const RIGHT: u32 = 2;
const TOP: u32 = 3;

/// Contacts of the final state, by kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ContactCounts {
    /// Grain–grain contacts.
    pub grain_grain: usize,
    /// Grain–wall contacts.
    pub grain_wall: usize,
    /// Contacts at the Coulomb limit.
    pub sliding: usize,
}

/// Normal loads the grains exert on each wall (positive: pushing the wall outwards).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WallLoads {
    /// Floor (y = 0).
    pub bottom: f64,
    /// Left wall (x = 0).
    pub left: f64,
    /// Right wall (x = box width).
    pub right: f64,
    /// Top wall (y = box height).
    pub top: f64,
}

/// What the demo found; written as `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DemoReport {
    /// Version of the engine that produced the results.
    pub grainwave_version: String,
    /// Dimension of the simulation (`2d`).
    pub dimension: String,
    /// Seed of the placement.
    pub seed: u64,
    /// Number of grains.
    pub grains: usize,
    /// Steps integrated.
    pub steps: u64,
    /// Time step.
    pub time_step: f64,
    /// Simulated time at the end.
    pub simulated_time: f64,
    /// Why the run stopped (`converged` when every equilibrium criterion held).
    pub stop_reason: StopReason,
    /// Total kinetic energy (translation + rotation) at the end.
    pub kinetic_energy: f64,
    /// Kinetic energy per grain at the end (a stop criterion).
    pub kinetic_energy_per_grain: f64,
    /// Largest grain acceleration max(|F|/m, |τ| R/I) at the end (a stop criterion).
    pub max_acceleration: f64,
    /// Total weight Σ m g.
    pub total_weight: f64,
    /// Normal force of the grains on the floor at the last force evaluation.
    pub floor_force: f64,
    /// `floor_force / total_weight`: 1 at static equilibrium with frictionless walls.
    pub floor_force_over_weight: f64,
    /// Normal loads on all four walls.
    pub wall_loads: WallLoads,
    /// Horizontal (x) force of the grains on the floor, from the floor's friction. At
    /// equilibrium it balances the side walls: `floor_shear_force` = left − right load.
    pub floor_shear_force: f64,
    /// Contacts at the end.
    pub contacts: ContactCounts,
    /// Height of the pile: the highest point of any grain, max(y + R).
    pub pile_height: f64,
    /// Units of every number above.
    pub units: String,
    /// Warnings raised by the engine during the run (e.g. about the time step).
    pub warnings: Vec<String>,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
    /// The complete config the run used (defaults filled in).
    pub config: DemoConfig,
}

impl DemoReport {
    /// Measures the final state of `sim`, whose snapshot is `snap`.
    fn from_simulation(cfg: &DemoConfig, sim: &Simulation<D2>, snap: &Snapshot<D2>, outcome: &RunOutcome) -> Self {
        let weight = cfg.weight(&sim.grains);
        // `+ 0.0` turns the −0.0 of a wall without contacts into 0.0.
        let load = |w: u32| sim.domain.walls[w as usize].normal_load() + 0.0;
        let floor = load(BOTTOM);
        let grain_wall = snap.contacts.iter().filter(|c| matches!(c.j, Counterpart::Wall(_))).count();
        let pile_height = (0..snap.len()).map(|k| snap.pos[k].y + snap.radius[k]).fold(f64::NEG_INFINITY, f64::max);
        let ke = sim.kinetic_energy();
        DemoReport {
            grainwave_version: grainwave_core::VERSION.to_string(),
            dimension: D2::NAME.to_string(),
            seed: cfg.seed,
            grains: sim.len(),
            steps: sim.step,
            time_step: sim.dt,
            simulated_time: sim.time,
            stop_reason: outcome.reason,
            kinetic_energy: ke,
            kinetic_energy_per_grain: ke / sim.len() as f64,
            max_acceleration: outcome.last.max_acceleration,
            total_weight: weight,
            floor_force: floor,
            floor_force_over_weight: floor / weight,
            wall_loads: WallLoads { bottom: floor, left: load(LEFT), right: load(RIGHT), top: load(TOP) },
            floor_shear_force: sim.domain.walls[BOTTOM as usize].force.x + 0.0,
            contacts: ContactCounts {
                grain_grain: snap.contacts.len() - grain_wall,
                grain_wall,
                sliding: snap.contacts.iter().filter(|c| c.sliding).count(),
            },
            pile_height,
            units: UNITS_NOTE.to_string(),
            warnings: sim.warnings.clone(),
            files: vec![SUMMARY_FILE.to_string(), GRAINS_FILE.to_string()],
            config: cfg.clone(),
        }
    }
}

/// Runs the demo and writes `summary.json` and `grains.csv` into `out_dir` (created if needed).
///
/// `progress` is called at every stop-criterion check (every `stop.check_every` steps) with the
/// current step, time, kinetic energy per grain and accelerations; returning
/// [`Control::Stop`] ends the run early — the outputs are still written and the report says
/// `interrupted`.
pub fn run_demo(cfg: &DemoConfig, out_dir: &Path, progress: &mut dyn FnMut(&Progress) -> Control) -> Result<DemoReport> {
    let mut sim = cfg.build()?;
    let outcome = sim.run(&cfg.stop, progress)?;
    let snap = sim.snapshot();
    let report = DemoReport::from_simulation(cfg, &sim, &snap, &outcome);
    grainwave_io::write_grains_csv(&out_dir.join(GRAINS_FILE), &snap)?;
    // The summary goes last: its presence means the run completed and every file is in place.
    grainwave_io::write_json_atomic(&out_dir.join(SUMMARY_FILE), &report)?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_config_means_defaults() {
        let cfg: DemoConfig = serde_json::from_str("{}").unwrap();
        assert_eq!(cfg, DemoConfig::default());
        cfg.validate().unwrap();
    }

    #[test]
    fn config_round_trips_through_json() {
        let cfg = DemoConfig { grains: 17, seed: 7, ..Default::default() };
        let back: DemoConfig = serde_json::from_str(&serde_json::to_string(&cfg).unwrap()).unwrap();
        assert_eq!(back, cfg);
    }

    #[test]
    fn unknown_keys_are_refused() {
        let err = serde_json::from_str::<DemoConfig>(r#"{"grain": 10}"#).unwrap_err().to_string();
        assert!(err.contains("grain"), "{err}");
    }

    #[test]
    fn invalid_values_name_the_key() {
        let cases: Vec<(DemoConfig, &str)> = vec![
            (DemoConfig { grains: 0, ..Default::default() }, "demo.grains"),
            (DemoConfig { box_width: -1.0, ..Default::default() }, "demo.box_width"),
            (DemoConfig { gravity: f64::NAN, ..Default::default() }, "demo.gravity"),
            (DemoConfig { gas_bottom: 45.0, ..Default::default() }, "demo.gas_bottom"),
            (DemoConfig { walls: WallContact { friction: Some(-0.1), ..Default::default() }, ..Default::default() }, "demo.walls.friction"),
            (DemoConfig { floor: WallContact { rolling_friction: Some(0.1), ..Default::default() }, ..Default::default() }, "demo.floor.rolling_stiffness"),
            (DemoConfig { sizes: SizeDistribution::UniformDiameter { mean_diameter: 1.0, spread: 1.5 }, ..Default::default() }, "demo.sizes.spread"),
            (DemoConfig { stop: StopCriteria::default(), ..Default::default() }, "stop.step_limit"),
        ];
        for (cfg, key) in cases {
            let err = cfg.build().unwrap_err();
            assert!(err.is_input_error(), "{err}");
            assert!(err.to_string().contains(&format!("`{key}`")), "expected key `{key}` in: {err}");
        }
    }

    #[test]
    fn too_dense_gas_is_an_input_error() {
        let cfg = DemoConfig { grains: 2000, ..Default::default() };
        let err = cfg.build().unwrap_err();
        assert!(err.is_input_error() && err.to_string().contains("too dense"), "{err}");
    }

    #[test]
    fn build_places_every_grain_inside_the_gas_region() {
        let cfg = DemoConfig::default();
        let sim = cfg.build().unwrap();
        assert_eq!(sim.len(), 300);
        for k in 0..sim.len() {
            let (x, r) = (sim.grains.pos[k], sim.grains.radius[k]);
            assert!((0.4..=0.6).contains(&r), "radius {r}");
            assert!(x.x >= r && x.x <= cfg.box_width - r, "{x:?}");
            assert!(x.y >= cfg.gas_bottom + r && x.y <= cfg.box_height - r, "{x:?}");
        }
        assert_eq!(sim.domain.walls.len(), 4);
        assert_eq!(sim.domain.walls[BOTTOM as usize].name, "bottom");
        assert_eq!(sim.domain.walls[TOP as usize].name, "top");
        assert_eq!(sim.domain.walls[BOTTOM as usize].law.friction, 0.3);
        for w in [LEFT, RIGHT, TOP] {
            assert_eq!(sim.domain.walls[w as usize].law.friction, 0.0);
        }
        assert_eq!(sim.law.friction, 0.3);
        // Same seed, same grains.
        let again = cfg.build().unwrap();
        assert_eq!(again.state_hash(), sim.state_hash());
    }
}
