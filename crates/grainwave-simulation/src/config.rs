//! The config of the `simulation` protocol: every key, its documentation, unit and default.

use grainwave_study::config::{Axis, TimeFunctionConfig, VectorConfig};
use grainwave_core::contact::ContactParams;
use grainwave_core::sim::StopCriteria;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A general discrete-element run: grains placed in a domain with walls, a contact law, body
/// forces and loads, integrated until a stop criterion; writes time series, snapshots,
/// checkpoints and plots. Numbers are in the units of the user's choice (grainwave is
/// unit-agnostic); the `units` key records them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SimulationConfig {
    /// Which protocol this file configures: `simulation`.
    pub experiment: String,
    /// Seed of every random choice (radii, placement, initial velocities).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// The units the numbers are in, in words (recorded in the outputs; not interpreted).
    #[serde(default = "default_units")]
    pub units: String,
    /// The grains.
    pub grains: GrainsConfig,
    /// The domain: extent and periodic axes.
    pub domain: DomainConfig,
    /// Initial positions and velocities.
    #[serde(default)]
    pub placement: PlacementConfig,
    /// Grain–grain contact law (keys of the presets, see docs/engine.md).
    pub contact: ContactParams,
    /// Grain–wall contact law: the grain–grain keys given here replace those of `[contact]` for
    /// every wall (e.g. `friction = 0`); each wall may override further.
    #[serde(default)]
    pub wall_contact: ContactParams,
    /// Walls (each perpendicular to an axis).
    #[serde(default)]
    pub walls: Vec<WallConfig>,
    /// Gravitational acceleration, one component per axis [length/time²].
    #[serde(default)]
    pub gravity: Option<VectorConfig>,
    /// External forces and torques on single grains.
    #[serde(default)]
    pub loads: Vec<LoadConfig>,
    /// Time integration and numerical safety.
    #[serde(default)]
    pub integration: IntegrationConfig,
    /// When to stop: equilibrium criteria (all must hold) and step/time limits (at least one).
    pub stop: StopCriteria,
    /// What to write and how often.
    #[serde(default)]
    pub output: OutputConfig,
}

fn default_seed() -> u64 {
    42
}
fn default_units() -> String {
    "unspecified".into()
}
fn one() -> f64 {
    1.0
}

/// Grain kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum KindName {
    /// 2D disks.
    Disk,
    /// 3D spheres with centres in a plane (2D motion, 3D inertia and Hertz contacts).
    Sphere2d,
    /// 3D spheres.
    Sphere,
}

/// The grains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GrainsConfig {
    /// Grain kind: `disk` (2D), `sphere2d` (spheres with centres in a plane, 2D) or `sphere` (3D).
    pub kind: KindName,
    /// Number of grains.
    pub count: usize,
    /// Density ρ [mass/volume; disks: mass/area per unit thickness].
    #[serde(default = "one")]
    pub density: f64,
    /// Disk thickness W (disks only; 1 means masses per unit thickness) [length].
    #[serde(default = "one")]
    pub thickness: f64,
    /// Distribution of radii.
    pub size: SizeConfig,
}

/// Distribution of radii, chosen by `distribution`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(tag = "distribution", rename_all = "snake_case", deny_unknown_fields)]
pub enum SizeConfig {
    /// Every grain has radius `radius`.
    Monodisperse {
        /// Radius [length].
        radius: f64,
    },
    /// Diameters uniform in [d̄(1−a), d̄(1+a)].
    UniformDiameter {
        /// Mean diameter d̄ [length].
        mean_diameter: f64,
        /// Relative half-width a ∈ [0, 1).
        spread: f64,
    },
    /// Radii uniform in [R̄(1−δ), R̄].
    UniformRadius {
        /// Largest radius R̄ [length].
        max_radius: f64,
        /// Relative width δ ∈ [0, 1).
        delta: f64,
    },
    /// An explicit list, cycled if shorter than the grain count.
    Explicit {
        /// Radii [length].
        radii: Vec<f64>,
    },
}

/// The domain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct DomainConfig {
    /// Lower corner, one value per axis (default: the origin) [length].
    #[serde(default)]
    pub origin: Option<VectorConfig>,
    /// Edge lengths, one per axis [length].
    pub size: VectorConfig,
    /// Periodic axes, e.g. `["x"]`.
    #[serde(default)]
    pub periodic: Vec<Axis>,
}

/// How grains are placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PlacementMethod {
    /// Random positions without overlaps (random sequential addition), largest grains first.
    #[default]
    Gas,
    /// A lattice filling the region row by row: triangular in 2D, simple cubic in 3D.
    Lattice,
}

/// Initial positions and velocities.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PlacementConfig {
    /// `gas` or `lattice`.
    pub method: PlacementMethod,
    /// Lower corner of the region to fill (default: the domain's) [length].
    pub region_min: Option<VectorConfig>,
    /// Upper corner of the region to fill (default: the domain's) [length].
    pub region_max: Option<VectorConfig>,
    /// Lattice spacing (default: the largest diameter) [length].
    pub spacing: Option<f64>,
    /// Random initial velocities: each component uniform in [−speed, speed] [length/time].
    pub speed: f64,
    /// Random attempts per grain before a gas is declared too dense for its region.
    pub attempts: usize,
}

impl Default for PlacementConfig {
    fn default() -> Self {
        PlacementConfig { method: PlacementMethod::Gas, region_min: None, region_max: None, spacing: None, speed: 0.0, attempts: 100_000 }
    }
}

/// Which end of its axis a wall closes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// The lower end: grains are at larger coordinates.
    Low,
    /// The upper end: grains are at smaller coordinates.
    High,
}

/// How a wall moves (always along its axis).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum MotionKind {
    /// Does not move.
    #[default]
    Fixed,
    /// Prescribed speed `speed` into the domain.
    Velocity,
    /// A mass `mass` under a force `force` (or `pressure`) pushing into the domain.
    Piston,
}

/// A wall perpendicular to an axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WallConfig {
    /// Name used in outputs (e.g. `floor`): unique among the walls, at most 64 characters, without
    /// `/`, `\` or control characters (it becomes part of file names).
    pub name: String,
    /// Axis the wall is perpendicular to.
    pub axis: Axis,
    /// `low` (grains above the wall) or `high` (grains below it).
    pub side: Side,
    /// Coordinate of the wall along its axis (default: the domain's lower or upper end) [length].
    #[serde(default)]
    pub position: Option<f64>,
    /// `fixed`, `velocity` or `piston`.
    #[serde(default)]
    pub motion: MotionKind,
    /// Speed into the domain of a `velocity` wall: a number or a function of time [length/time].
    #[serde(default)]
    pub speed: Option<TimeFunctionConfig>,
    /// Mass of a piston [mass].
    #[serde(default)]
    pub mass: Option<f64>,
    /// Force of a piston into the domain: a number or a function of time [force].
    #[serde(default)]
    pub force: Option<TimeFunctionConfig>,
    /// Pressure on a piston instead of `force`: force = pressure × wall area, the area being the
    /// product of the domain lengths along the other axes, times the thickness for disks or the
    /// mean diameter for `sphere2d` (a 3D pressure) [force/area].
    #[serde(default)]
    pub pressure: Option<TimeFunctionConfig>,
    /// Contact keys replacing those of `[contact]` and `[wall_contact]` for this wall.
    #[serde(default)]
    pub contact: Option<ContactParams>,
}

/// An external force and torque on one grain, scaled in time by `profile`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LoadConfig {
    /// Grain id (0-based, in order of creation).
    pub grain: u32,
    /// Force at full load, one component per axis [force].
    #[serde(default)]
    pub force: Option<VectorConfig>,
    /// Torque at full load: one number in 2D, three in 3D [force·length].
    #[serde(default)]
    pub torque: Option<VectorConfig>,
    /// Load factor in time, e.g. `{ type = "ramp", from = 0, to = 1, start = 0, end = 10 }` (default 1).
    #[serde(default)]
    pub profile: Option<TimeFunctionConfig>,
}

/// Integration scheme name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum IntegratorName {
    /// Velocity Verlet.
    #[default]
    VelocityVerlet,
    /// Beeman.
    Beeman,
}

/// Time integration and numerical safety.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct IntegrationConfig {
    /// `velocity_verlet` or `beeman`.
    pub integrator: IntegratorName,
    /// Time step (default: `dt_fraction` of the shortest contact period) [time].
    pub dt: Option<f64>,
    /// Fraction of the shortest contact period used as suggested time step, in (0, 0.2].
    pub dt_fraction: f64,
    /// Largest expected overlap as a fraction of the largest radius (sets Hertz stiffness in the
    /// time-step suggestion).
    pub expected_overlap: f64,
    /// Verlet-list skin (default: 0.2 × largest radius) [length].
    pub skin: Option<f64>,
    /// Largest overlap accepted at the start, as a fraction of the smaller radius.
    pub max_initial_overlap: f64,
    /// An overlap beyond this fraction of the smaller radius stops the run as a blow-up.
    pub max_overlap_fraction: f64,
}

impl Default for IntegrationConfig {
    fn default() -> Self {
        IntegrationConfig {
            integrator: IntegratorName::VelocityVerlet,
            dt: None,
            dt_fraction: 0.02,
            expected_overlap: 0.01,
            skin: None,
            max_initial_overlap: 0.02,
            max_overlap_fraction: 0.3,
        }
    }
}

/// What to write.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct OutputConfig {
    /// Record a row of the time series every this many steps (0: start and end only) [steps].
    pub series_every: u64,
    /// Write a VTK snapshot every this many steps (0: the final state only) [steps].
    pub snapshot_every: u64,
    /// Write a checkpoint every this many steps (0: only when interrupted and at the end) [steps].
    pub checkpoint_every: u64,
    /// Write VTK snapshots (grains and contact network) for ParaView.
    pub vtk: bool,
    /// Draw plots (PNG and SVG).
    pub plots: bool,
}

impl Default for OutputConfig {
    fn default() -> Self {
        OutputConfig { series_every: 1000, snapshot_every: 0, checkpoint_every: 0, vtk: true, plots: true }
    }
}
