//! The config of the `e3` protocol: every key, its documentation, unit and default.
//!
//! Units are those of SPEC §7.1: length R̄ (the largest grain radius), mass m̄ (the mass of a disk
//! of radius R̄), time τ = √(R̄/g); forces are in m̄g, stiffnesses in m̄g/R̄, dashpots in m̄/τ,
//! energies in m̄gR̄. `[units]` converts them to SI for the summary.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Default threshold of the **asymmetric** flag on the antisymmetric fraction A_s (see
/// [`crate::measure::Symmetry`]; `response.asymmetry_threshold`).
pub const ASYMMETRY_THRESHOLD: f64 = 0.05;
/// Default factor over the small-force A_s of the **asymmetric** flag (`response.asymmetry_factor`).
pub const ASYMMETRY_FACTOR: f64 = 3.0;

/// E3 (SPEC §7): the response of a gravity-loaded 2D granular slab to a localized force. Disks on
/// a triangular lattice settle under gravity between two side walls on a floor (the reference
/// state); a force is ramped onto one grain of the top row and the packing relaxes again; the
/// response is the change of the floor forces, of the coarse-grained stress and of the contact
/// network. Modes: `slab` (one slab, one or more forces), `sweep` (ensembles over forces,
/// friction, stiffness ratio, polydispersity and size, with a single/double-peak classifier and
/// crossover diagrams), `superposition` (two forces separately and together), `pile` (a
/// triangular pile under gravity) and `lattice_elasticity` (moduli of a spring lattice). Lengths
/// in R̄, masses in m̄, times in τ = √(R̄/g), forces in m̄g.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct E3Config {
    /// Which protocol this file configures: `e3`.
    pub experiment: String,
    /// What to run: `slab`, `sweep`, `superposition`, `pile` or `lattice_elasticity`.
    #[serde(default)]
    pub mode: Mode,
    /// Seed of the first disorder realization; sample k uses seed + k.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Number of disorder realizations per parameter set (seeds seed … seed + samples − 1). An
    /// ordered lattice (δ = 0) has no disorder and is run once.
    #[serde(default = "one_usize")]
    pub samples: usize,
    /// The slab: lattice size and polydispersity.
    #[serde(default)]
    pub slab: SlabConfig,
    /// Contact parameters of grains and walls (SPEC §7.1).
    #[serde(default)]
    pub material: MaterialConfig,
    /// Time integration.
    #[serde(default)]
    pub integration: IntegrationConfig,
    /// Relaxation to static equilibrium (reference state and response alike).
    #[serde(default)]
    pub relaxation: RelaxationConfig,
    /// The localized force.
    #[serde(default)]
    pub load: LoadConfig,
    /// What is measured and how it is coarse-grained.
    #[serde(default)]
    pub response: ResponseConfig,
    /// First-opening force below the load by bisection on F_ext (modes `slab` and `sweep`).
    #[serde(default)]
    pub first_opening: FirstOpeningConfig,
    /// Parameter lists of mode `sweep` (each list replaces the single value of `[slab]`,
    /// `[material]`; the forces are `load.forces`).
    #[serde(default)]
    pub sweep: SweepConfig,
    /// Mode `superposition`: two forces at a distance.
    #[serde(default)]
    pub superposition: SuperpositionConfig,
    /// Mode `pile`: the shape of the pile.
    #[serde(default)]
    pub pile: PileConfig,
    /// Mode `lattice_elasticity`: a periodic spring lattice.
    #[serde(default)]
    pub lattice: LatticeConfig,
    /// The physical values of the units, for conversions in the summary.
    #[serde(default)]
    pub units: UnitsConfig,
    /// What to write.
    #[serde(default)]
    pub output: OutputConfig,
}

fn default_seed() -> u64 {
    1
}
fn one_usize() -> usize {
    1
}

/// What an `e3` run does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// One slab; one or more forces (`load.forces`), each applied to the reference state.
    #[default]
    Slab,
    /// Ensembles over `[sweep]` lists × `load.forces`; classifier verdicts and crossover diagrams.
    Sweep,
    /// Forces at x₀ − d/2 (left), x₀ + d/2 (right), and both together.
    Superposition,
    /// A triangular pile under gravity: floor stress.
    Pile,
    /// Affine moduli (a, b, c, d) and r of a periodic spring lattice (no simulation).
    LatticeElasticity,
}

impl Mode {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Slab => "slab",
            Mode::Sweep => "sweep",
            Mode::Superposition => "superposition",
            Mode::Pile => "pile",
            Mode::LatticeElasticity => "lattice_elasticity",
        }
    }
}

/// The slab (SPEC §7.2.1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SlabConfig {
    /// Number of layers L (rows of the triangular lattice).
    pub layers: usize,
    /// Grains M per row (`rows = "full"`), or in the longer rows (`"alternating_m_and_m_minus_1"`).
    pub grains_per_layer: usize,
    /// Polydispersity δ: radii uniform in [R̄(1 − δ), R̄] (0: monodisperse), in [0, 1).
    pub delta: f64,
    /// Row layout: `full` (SPEC §7.2.1, default: every row holds M grains, successive rows
    /// shifted by R̄, box (2M + 1)R̄ wide, each row touching one side wall; 900 grains for 15 × 60)
    /// or `alternating_m_and_m_minus_1` (rows of M and M − 1 grains in turn, box 2MR̄ wide,
    /// mirror-symmetric, both walls touched by the long rows only; 892 grains for 15 × 60 — a
    /// different system).
    pub rows: RowLayout,
}

/// How the rows of a slab are filled (SPEC §7.2.1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RowLayout {
    /// Every row holds M grains; rows start alternately at x = R̄ and 2R̄; W = (2M + 1)R̄.
    #[default]
    Full,
    /// Rows of M and M − 1 grains in turn, symmetric about x = MR̄; W = 2MR̄.
    #[serde(rename = "alternating_m_and_m_minus_1")]
    AlternatingMAndMMinus1,
}

impl RowLayout {
    /// Name as written in configs.
    pub fn name(self) -> &'static str {
        match self {
            RowLayout::Full => "full",
            RowLayout::AlternatingMAndMMinus1 => "alternating_m_and_m_minus_1",
        }
    }
}

impl Default for SlabConfig {
    fn default() -> Self {
        SlabConfig { layers: 15, grains_per_layer: 60, delta: 0.0, rows: RowLayout::Full }
    }
}

/// Contact parameters (SPEC §7.1). Grain–grain: linear normal spring k_N with dashpot γ_N,
/// linear tangential spring k_T = ratio × k_N with dashpot γ_T, Coulomb friction μ. Walls: k_N^wall
/// = `wall_stiffness_ratio` × k_N, the same k_T/k_N, their own friction and dashpots.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct MaterialConfig {
    /// Normal stiffness k_N [m̄g/R̄].
    pub normal_stiffness: f64,
    /// k_T/k_N (also for walls).
    pub tangential_stiffness_ratio: f64,
    /// Grain–grain friction coefficient μ (0: frictionless, no tangential force).
    pub friction: f64,
    /// Floor friction μ_wall (default: μ).
    pub wall_friction: Option<f64>,
    /// Side-wall friction (default: the floor's).
    pub side_wall_friction: Option<f64>,
    /// k_N^wall / k_N.
    pub wall_stiffness_ratio: f64,
    /// Grain–grain normal dashpot γ_N (default √(m̄ k_N): "ν = √k" in these units) [m̄/τ].
    pub normal_damping: Option<f64>,
    /// Grain–grain tangential dashpot γ_T (default √(m̄ k_T)) [m̄/τ].
    pub tangential_damping: Option<f64>,
    /// Grain–wall normal dashpot (default √(m̄ k_N^wall)) [m̄/τ].
    pub wall_normal_damping: Option<f64>,
    /// Grain–wall tangential dashpot (default √(m̄ k_T^wall)) [m̄/τ].
    pub wall_tangential_damping: Option<f64>,
}

impl Default for MaterialConfig {
    fn default() -> Self {
        MaterialConfig {
            normal_stiffness: 3000.0,
            tangential_stiffness_ratio: 0.8,
            friction: 0.5,
            wall_friction: None,
            side_wall_friction: None,
            wall_stiffness_ratio: 2.0,
            normal_damping: None,
            tangential_damping: None,
            wall_normal_damping: None,
            wall_tangential_damping: None,
        }
    }
}

/// Integration scheme name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum IntegratorName {
    /// Velocity Verlet.
    VelocityVerlet,
    /// Beeman (E3's published runs used it).
    #[default]
    Beeman,
}

/// Time integration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct IntegrationConfig {
    /// Time step [τ].
    pub dt: f64,
    /// `beeman` or `velocity_verlet`.
    pub integrator: IntegratorName,
}

impl Default for IntegrationConfig {
    fn default() -> Self {
        IntegrationConfig { dt: 5e-4, integrator: IntegratorName::Beeman }
    }
}

/// Relaxation to static equilibrium: molecular dynamics until every criterion holds (checked
/// every `check_every` steps), then, for frictionless packings, Newton iterations on the static
/// force balance (SPEC §3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct RelaxationConfig {
    /// Kinetic energy per grain below which the packing is at rest (default 1e-13 for ordered
    /// lattices, 1e-9 when δ > 0, SPEC §7.2.2); a response uses this × min(1, F_ext/m̄g)², since
    /// its motion scales with the force [m̄gR̄].
    pub kinetic_energy_per_grain: Option<f64>,
    /// Largest grain acceleration max_i max(|F_i|/m_i, |τ_i|R_i/I_i) allowed in the reference state.
    /// It bounds the force imbalance of every grain (|floor load/weight − 1| ≤ this), which the
    /// kinetic energy alone does not [g].
    pub max_acceleration: f64,
    /// The same limit for a response, per unit applied force: the limit is this × F_ext/(m̄g), so
    /// that the relative precision of a response does not depend on its size [g].
    pub response_max_acceleration: f64,
    /// Check the criteria every this many steps [steps].
    pub check_every: u64,
    /// Give up (and report the state as not converged) after this much simulated time [τ].
    pub max_time: f64,
    /// Finish frictionless packings (μ = μ_wall = 0) with Newton iterations on the linearized force
    /// balance, updating the contacts until none is in tension.
    pub static_solve: bool,
    /// Newton iterations stop when the largest displacement increment is below this [R̄].
    pub static_tolerance: f64,
    /// At most this many Newton iterations.
    pub static_iterations: usize,
}

impl Default for RelaxationConfig {
    fn default() -> Self {
        RelaxationConfig {
            kinetic_energy_per_grain: None,
            max_acceleration: 1e-6,
            response_max_acceleration: 1e-6,
            check_every: 200,
            max_time: 2000.0,
            static_solve: true,
            static_tolerance: 1e-14,
            static_iterations: 40,
        }
    }
}

/// The localized force (SPEC §7.2.3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct LoadConfig {
    /// Magnitudes F_ext; each is applied to the reference state in its own run [m̄g].
    pub forces: Vec<f64>,
    /// Direction of the force, in degrees from the downward vertical (positive: tilted towards +x).
    pub angle: f64,
    /// Torque on the loaded grain, counter-clockwise, ramped with the force [m̄gR̄].
    pub torque: f64,
    /// Id of the loaded grain (default: the grain of the top row nearest the slab's axis).
    pub grain: Option<u32>,
    /// The force grows linearly from 0 to F_ext over this time, then the packing relaxes [τ].
    pub ramp_time: f64,
}

impl Default for LoadConfig {
    fn default() -> Self {
        LoadConfig { forces: vec![10.0], angle: 0.0, torque: 0.0, grain: None, ramp_time: 10.0 }
    }
}

/// What is measured (SPEC §7.2.4, §7.2.5, §7.3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ResponseConfig {
    /// Widths w of the Gaussian (1/(w√π)) e^{−(x/w)²} smoothing the floor forces [R̄].
    pub widths: Vec<f64>,
    /// Spacing of the x grid of the smoothed floor profiles [R̄].
    pub profile_step: f64,
    /// Width of the coarse-grained stress field σ_αβ(x, z) [R̄].
    pub stress_width: f64,
    /// Spacing of the grid of the stress field [R̄].
    pub stress_step: f64,
    /// Compute the coarse-grained stress field (default: yes, except in mode `sweep`).
    pub stress_field: Option<bool>,
    /// Width of the smoothed profile the classifier reads (default: the first of `widths`) [R̄].
    pub classifier_width: Option<f64>,
    /// A peak is significant when its prominence is at least this fraction of the profile's maximum.
    pub prominence: f64,
    /// Width of the layer along the walls and the free surface left out of the moduli window [R̄].
    pub boundary_layer: f64,
    /// A response whose antisymmetric fraction A_s (mirror symmetry of the floor response about
    /// the load, SPEC §7.2.5) exceeds this — and `asymmetry_factor` times its small-force value —
    /// is reported **asymmetric**, whatever its peak count.
    pub asymmetry_threshold: f64,
    /// "Well above its small-force value": under a vertical load without torque, a response is
    /// asymmetric only when its A_s also exceeds this factor times the A_s of the smallest force
    /// of its packing (the asymmetry the packing itself has: walls, disorder). Inclined loads and
    /// torques, asymmetric by construction, are judged on `asymmetry_threshold` alone.
    pub asymmetry_factor: f64,
}

impl Default for ResponseConfig {
    fn default() -> Self {
        ResponseConfig {
            widths: vec![3.0, 6.0],
            profile_step: 0.25,
            stress_width: 2.0,
            stress_step: 0.5,
            stress_field: None,
            classifier_width: None,
            prominence: 0.05,
            boundary_layer: 4.0,
            asymmetry_threshold: ASYMMETRY_THRESHOLD,
            asymmetry_factor: ASYMMETRY_FACTOR,
        }
    }
}

/// First-opening force (SPEC §7.2.5): the smallest F_ext at which a contact opens in the region
/// below the load (the opened contacts connected to the loaded grain, docs/e3.md), found per
/// reference state by bisection on F_ext, every bracket end verified by a run of its own.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct FirstOpeningConfig {
    /// Run the bisection (after the runs of `load.forces`).
    pub bisection: bool,
    /// Initial bracket [F_low, F_high]: the bisection needs no opening below the load at F_low and
    /// one at F_high (both are run and checked; otherwise the summary says which end failed) [m̄g].
    pub bracket: [f64; 2],
    /// Stop when F_high/F_low − 1 is below this; the midpoint is the geometric mean.
    pub relative_tolerance: f64,
}

impl Default for FirstOpeningConfig {
    fn default() -> Self {
        FirstOpeningConfig { bisection: false, bracket: [0.05, 50.0], relative_tolerance: 0.02 }
    }
}

/// Parameter lists of mode `sweep`; an empty list keeps the single value of `[slab]` or
/// `[material]`. Runs: every combination × `load.forces` × samples.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SweepConfig {
    /// Friction coefficients μ (the walls follow unless `material.wall_friction` is given).
    pub frictions: Vec<f64>,
    /// Ratios k_T/k_N.
    pub stiffness_ratios: Vec<f64>,
    /// Polydispersities δ.
    pub deltas: Vec<f64>,
    /// Sizes as [layers, grains_per_layer] pairs.
    pub sizes: Vec<[usize; 2]>,
}

/// Mode `superposition` (SPEC §7.2.7).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SuperpositionConfig {
    /// Distance d between the two loaded grains, centred on the slab's axis (each is the top-row
    /// grain nearest x₀ ∓ d/2) [R̄].
    pub separation: f64,
}

impl Default for SuperpositionConfig {
    fn default() -> Self {
        SuperpositionConfig { separation: 8.0 }
    }
}

/// Mode `pile` (SPEC §7.2.9): a triangular pile on the floor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PileConfig {
    /// Number of layers.
    pub layers: usize,
    /// Grains in the top layer; each layer below holds one more, the bottom one touching both side
    /// walls.
    pub top_grains: usize,
    /// Polydispersity δ of the pile's grains, in [0, 1).
    pub delta: f64,
    /// Width w of the Gaussian (1/(w√π)) e^{−(x/w)²} of the coarse-grained floor stress σ_zz(x)
    /// on which the pile is judged (SPEC §7.2.9) [R̄].
    pub verdict_width: f64,
}

impl Default for PileConfig {
    fn default() -> Self {
        PileConfig { layers: 11, top_grains: 1, delta: 0.0, verdict_width: 2.0 }
    }
}

/// Mode `lattice_elasticity` (SPEC §7.3): a periodic triangular spring lattice with one lattice
/// direction horizontal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct LatticeConfig {
    /// Lattice spacing [R̄].
    pub spacing: f64,
    /// Horizontal bonds [kⁿ, kᵗ] (0 for opened horizontal contacts) [m̄g/R̄].
    pub horizontal: [f64; 2],
    /// Oblique bonds (±60°) [kⁿ, kᵗ] [m̄g/R̄].
    pub oblique: [f64; 2],
    /// Also tabulate r against these kᵗ/kⁿ (applied to every bond, the normal stiffnesses kept),
    /// with the horizontal bonds as given and with them removed.
    pub tangential_ratios: Vec<f64>,
}

impl Default for LatticeConfig {
    fn default() -> Self {
        LatticeConfig { spacing: 2.0, horizontal: [3000.0, 2400.0], oblique: [3000.0, 2400.0], tangential_ratios: Vec::new() }
    }
}

/// Physical values of the units (SPEC §7.1 reference parameters), used only to convert results.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct UnitsConfig {
    /// R̄ in metres [m].
    pub radius: f64,
    /// Disk thickness W in metres [m].
    pub thickness: f64,
    /// Density ρ [kg/m³].
    pub density: f64,
    /// Gravitational acceleration g [m/s²].
    pub gravity: f64,
}

impl Default for UnitsConfig {
    fn default() -> Self {
        UnitsConfig { radius: 3.75e-3, thickness: 6.6e-3, density: 1.15e3, gravity: 9.8 }
    }
}

/// What to write.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct OutputConfig {
    /// Write a directory `runs/<label>/` per run with its floor contacts, profiles, contact changes,
    /// stress field and pictures (default: yes, except in mode `sweep`).
    pub runs: Option<bool>,
    /// Write VTK files (grains and the contact-force difference network) for ParaView.
    pub vtk: bool,
    /// Draw plots (PNG and SVG).
    pub plots: bool,
}

impl Default for OutputConfig {
    fn default() -> Self {
        OutputConfig { runs: None, vtk: true, plots: true }
    }
}
