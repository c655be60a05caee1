//! The keys of an `e2` config (SPEC §6). Units: pressure p* (force per length in 2D), total mass M*
//! of the grains, and the derived L* = √(M*/ρ*), t* = √(M*/p*), v_a and t_a (see
//! [`super::model::Units`]); grain sizes in mean diameters d̄.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// An `e2` config: acoustics of a 2D packing under biaxial loading, with frictional sliding.
///
/// Without `[source]`, a run prepares a packing, loads it biaxially (writing checkpoints every
/// `loading.checkpoint_strain`) and then runs every `[[replays]]` entry from the checkpoints it
/// wrote. With `source.dir`, it skips preparation and loading and replays checkpoints of that
/// earlier run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct E2Config {
    /// Which protocol this file configures: `e2`.
    pub experiment: String,
    /// Seed of the packing (radii, gas positions).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// The packing.
    #[serde(default)]
    pub packing: PackingConfig,
    /// Contact parameters (SPEC §6.1).
    #[serde(default)]
    pub material: MaterialConfig,
    /// Preparation by two pistons (SPEC §6.2).
    #[serde(default)]
    pub preparation: PreparationConfig,
    /// The biaxial test (SPEC §6.2).
    #[serde(default)]
    pub loading: LoadingConfig,
    /// Replay checkpoints of an earlier `e2` run instead of preparing and loading a new packing.
    #[serde(default)]
    pub source: SourceConfig,
    /// Replays of checkpoints, each with exactly one modification (SPEC §6.3–6.5).
    #[serde(default)]
    pub replays: Vec<ReplayConfig>,
    /// The Δc/c₀ decomposition of SPEC §6.6 from four wall-pulse replays with equal amplitudes.
    #[serde(default)]
    pub static_limit: StaticLimitConfig,
    /// The anisotropy A = 2(c₁ − c₂)/(c₁ + c₂) (SPEC §6.6) from two wall-pulse replays with equal
    /// amplitudes, along y (c₁, the compression axis) and along x (c₂).
    #[serde(default)]
    pub anisotropy: AnisotropyConfig,
    /// What to write.
    #[serde(default)]
    pub output: OutputConfig,
}

fn default_seed() -> u64 {
    1
}

/// The packing: N = columns × rows disks (SPEC §6.1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PackingConfig {
    /// Grains per row of the (roughly square) packing; N = columns × rows.
    pub columns: usize,
    /// Rows of grains.
    pub rows: usize,
    /// Polydispersity a: diameters uniform in [d̄(1 − a), d̄(1 + a)], in [0, 1).
    pub polydispersity: f64,
    /// Solid fraction of the initial granular gas (random sequential addition; keep it below ≈ 0.5).
    pub gas_fraction: f64,
    /// How the grains are stored in memory: `"placement"` (as the gas was placed, at random in
    /// space; the default, and every run before this key) or `"sorted"` (bin by bin, once the
    /// gas is placed and again when the preparation has converged). The same physics and ids;
    /// sums over contacts run in another order, so results differ by rounding (another
    /// realisation). Sorted runs the 16 384-disk loading faster, and lets a second thread help
    /// (docs/e2.md, "Grain order and threads").
    pub grain_order: GrainOrder,
}

impl Default for PackingConfig {
    fn default() -> Self {
        PackingConfig { columns: 128, rows: 128, polydispersity: 0.2, gas_fraction: 0.4, grain_order: GrainOrder::Placement }
    }
}

/// The order the grains are stored in (`packing.grain_order`). It changes no physics: grain ids,
/// outputs and the protocol are the same, but sums over contacts are taken in another order, so
/// results differ by rounding (another realisation of the same packing statistics, not the same
/// bits).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum GrainOrder {
    /// In the order the gas was placed, which is random in space (every run before this key
    /// existed).
    #[default]
    Placement,
    /// Bin by bin in space (`Simulation::sort_spatially`), once the gas is placed and again when
    /// the preparation has converged, so that grains close in space are close in memory. Once
    /// the grains' data outgrow the processor's cache (the 128 × 128 packing), the placement
    /// order makes most contacts a cache miss; see docs/e2.md for the measured effect.
    Sorted,
}

/// Linear spring–dashpot contacts (SPEC §6.1). Walls: the same normal spring and dashpot,
/// frictionless, no rolling resistance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct MaterialConfig {
    /// Normal stiffness K_n [p*].
    pub normal_stiffness: f64,
    /// Restitution coefficient e of a binary collision, which sets the normal dashpot
    /// γ_n = 2ζ√(m* K_n) per pair (ζ chosen so that the clamped law restitutes exactly e), in (e⁻², 1].
    pub restitution: f64,
    /// K_t / K_n.
    pub tangential_stiffness_ratio: f64,
    /// γ_t / γ_n.
    pub tangential_damping_ratio: f64,
    /// Grain–grain Coulomb friction μ, switched on after the preparation.
    pub friction: f64,
    /// Rolling stiffness k_r / (K_n d̄²) (0: no rolling resistance).
    pub rolling_stiffness: f64,
    /// Rolling friction μ_r: the rolling torque is capped at μ_r R* F_n.
    pub rolling_friction: f64,
    /// Slip-activation time τ of the grain–grain friction [t_a] (0, the default: the Coulomb
    /// cap of SPEC §6.1). τ > 0 is the friction law the published study proposes but does not
    /// simulate (its Eq. 13): a contact's spring may exceed the Coulomb length μF_n/K_t and
    /// relaxes back to it in a time τ, so contacts slide at loading time scales (≫ τ) and stick at
    /// acoustic ones (≪ τ). It applies from the loading on (t_a is fixed by the prepared packing)
    /// and in every replay; the preparation is frictionless. Not part of the canonical protocol.
    pub slip_activation_time: f64,
    /// Absorbing walls (SPEC §6.7): the bottom, left and top walls get soft, damped contacts
    /// (stiffness K_n/√N, dashpot `absorbing_damping` √(m̄ K_n)); the pulse-emitting right wall stays
    /// stiff. The preparation compresses the gas with stiff walls, then relaxes the packing into
    /// the absorbing ones; the loading and every replay run with them. On by default, as in the
    /// canonical protocol (false: stiff reflecting walls, a deviation).
    pub absorbing_walls: bool,
    /// Dashpot of an absorbing-wall contact [√(m̄ K_n)]. The default 0.85 makes the dashpots per unit
    /// wall length equal to the packing's acoustic impedance ρ* c ≈ (4Φ/π)(c/v_a)√(m̄K_n)/d̄ for
    /// Φ ≈ 0.83, c ≈ 0.8 v_a and one contact per diameter, which absorbs plane waves.
    pub absorbing_damping: f64,
}

impl Default for MaterialConfig {
    fn default() -> Self {
        MaterialConfig {
            normal_stiffness: 2000.0,
            restitution: 0.92,
            tangential_stiffness_ratio: 0.5,
            tangential_damping_ratio: 0.5,
            friction: 0.2,
            rolling_stiffness: 1e-4,
            rolling_friction: 0.01,
            slip_activation_time: 0.0,
            absorbing_walls: true,
            absorbing_damping: 0.85,
        }
    }
}

/// Preparation (SPEC §6.2): a frictionless granular gas in a box with the bottom and left walls
/// fixed and the top and right walls pistons under p* × their length, with a weak gravity along
/// (−1, −1)/√2, relaxed until equilibrium; then μ is switched on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PreparationConfig {
    /// Mass of each piston [M*].
    pub wall_mass: f64,
    /// Strength of the diagonal gravity as M* g / (p* L*): the weight of the packing over the force
    /// on one wall (0: no gravity). It stays on for the whole run unless `remove_gravity`.
    pub gravity: f64,
    /// Switch the gravity off once the packing has converged under it (after the walls became
    /// absorbing) and relax again, frictionless, to the same equilibrium tolerance before μ is
    /// switched on: the biaxial test and every replay then run without gravity. SPEC §6.2 is
    /// silent on gravity after the preparation and the published study names it only there;
    /// false (the default) keeps it on throughout, true is the variant that tests whether it
    /// matters.
    pub remove_gravity: bool,
    /// Equilibrium when every grain's |F_i| and every piston's |M a| are below this [p* d̄].
    pub max_force: f64,
    /// Check equilibrium (and update the piston forces p* × length) every this many steps [steps].
    pub check_every: u64,
    /// Give up after this much simulated time [t*].
    pub max_time: f64,
    /// Time step as a fraction of the shortest contact period 2π√(m*_min/K_n).
    pub dt_fraction: f64,
}

impl Default for PreparationConfig {
    fn default() -> Self {
        PreparationConfig { wall_mass: 0.01, gravity: 0.01, remove_gravity: false, max_force: 1e-4, check_every: 200, max_time: 200.0, dt_fraction: 0.05 }
    }
}

/// Direction of the biaxial test.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// The top wall moves down.
    #[default]
    Compression,
    /// The top wall moves up.
    Extension,
}

impl Direction {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Direction::Compression => "compression",
            Direction::Extension => "extension",
        }
    }
}

/// The biaxial test (SPEC §6.2): the top wall moves at a constant speed, the right wall stays a
/// piston under p* × its length, the bottom and left walls are fixed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct LoadingConfig {
    /// `compression` (top wall down) or `extension` (top wall up).
    pub direction: Direction,
    /// Strain rate |ε̇_yy|: the top wall moves at ε̇ × (initial height) [1/t*]. The published rate
    /// is 2e-5 (SPEC §6.2); a faster one is a deviation whose static-limit chain must slow down to
    /// the published final rate (`velocity_scale` replays with `rate = 2e-8`).
    pub strain_rate: f64,
    /// Stop when |ε_yy| (from grain displacements) reaches this.
    pub final_strain: f64,
    /// Write a checkpoint every this much |ε_yy| (SPEC: 1e-5); 0 writes none.
    pub checkpoint_strain: f64,
    /// Keep the complete (compressed) state only in checkpoint 0, every this-many-th checkpoint
    /// and the last; the others are references (step and strain, a few hundred bytes) whose
    /// state a replay regenerates, to the bit, by running the loading on from the full
    /// checkpoint before it (at most this many − 1 checkpoint intervals of loading). 1 keeps
    /// every state [checkpoints].
    pub full_checkpoint_every: u64,
    /// Re-reference the displacements of the strain regression each time the strain since the
    /// last reference exceeds this (SPEC: 1e-5).
    pub reference_strain: f64,
    /// Record the series (stresses, strain, M_s, kinetic energy) every this many steps [steps].
    pub sample_every: u64,
}

impl Default for LoadingConfig {
    fn default() -> Self {
        LoadingConfig {
            direction: Direction::Compression,
            strain_rate: 2e-5,
            final_strain: 0.01,
            checkpoint_strain: 1e-5,
            full_checkpoint_every: 10,
            reference_strain: 1e-5,
            sample_every: 20,
        }
    }
}

/// An earlier `e2` run whose checkpoints are replayed.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SourceConfig {
    /// Output directory of that run (holding `checkpoints/index.csv`); relative paths are taken
    /// from the current directory.
    pub dir: Option<String>,
}

/// Shape of a wall pulse.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PulseShape {
    /// f = p_a δ(t − t₀), p_a a time in t*: the impulse p_a · p* · L_wall · t* delivered in one step.
    #[default]
    Delta,
    /// f(t) = p_a (3 − 6τ² + τ⁴) e^{−τ²/2}, τ = (t − t₀)/T.
    Wavelet,
}

/// How the arrival of a wall pulse at a grain is defined (SPEC §6.5 and its extension for
/// deforming states; see `docs/e2.md`, "Arrival in a deforming packing").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ArrivalDefinition {
    /// SPEC §6.5: the time of the maximum of |δv_x| over the whole record.
    #[default]
    Maximum,
    /// The time of the peak of the first lobe of δv_x in the direction of the incident pulse
    /// whose value reaches `lobe_threshold` × the incident amplitude (and 10× the round-off floor).
    /// Equal to `maximum` (within 3 %, typically 1 %, in the measured static states) where the
    /// pulse is the largest signal, and still the
    /// pulse's own peak in a deforming packing, where the perturbation keeps growing behind the
    /// front and the overall maximum comes late.
    FirstLobe,
}

/// The wall a pulse comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PulseWall {
    /// The right wall (a piston under p*).
    #[default]
    Right,
    /// The top wall (after a `top_piston` replay).
    Top,
}

/// The one modification of a replay.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Modification {
    /// Pressure pulse on the right wall, p(t) = p*[1 + f(t)] (paired replay).
    #[default]
    WallPulse,
    /// The radius of the grain nearest the centre × (1 + amplitude) (paired replay).
    Radius,
    /// All velocities (grains, walls, and the top wall's speed) × `factor` (single replay).
    VelocityScale,
    /// Grain–grain friction set to `friction` (single replay).
    Friction,
    /// The top wall stops smoothly, v(t) = v₀(1 + cos(πt/t_s))/2 for t ≤ t_s = `stop_time` (single replay).
    WallStop,
    /// The top wall becomes a piston of mass `preparation.wall_mass` M* under its current load, so
    /// that later replays can pulse it (`pulse_wall = "top"`) (single replay).
    TopPiston,
    /// The exact small-amplitude limit of a δ wall pulse (`shape = "delta"`) on a static state:
    /// the linearized contact network with the two-branch rule of contacts at the Coulomb limit
    /// (`branches`), integrated instead of the engine; outputs as a wall-pulse replay. The
    /// response is positively homogeneous in p_a, so `amplitudes = [1, -1]` gives the limits
    /// p_a → 0⁺ and 0⁻ (δv per unit p_a) (paired-replay outputs, no engine run).
    Incremental,
}

/// Branch rule of an `incremental` replay for the contacts at the Coulomb limit
/// (|F_t| ≥ (1 − 1e−6) μ F_n, and rolling torques at μ_r R* F_n).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum IncrementalBranches {
    /// Slip while the increment pushes the contact on (ΔF_t along the sliding direction follows
    /// μ ΔF_n), stick (k_t) once it unloads, switching as the pulse passes: the exact limit.
    #[default]
    Incremental,
    /// Every contact sticks (k_t): the upper bound, the linear network of `SlidingContacts::Stick`.
    Stick,
    /// Contacts at the limit have no tangential (nor, at the rolling cap, rolling) stiffness:
    /// the lower bound, the linear network of `SlidingContacts::Free`.
    Free,
    /// Contacts at the limit follow the slip branch in both directions (bilateral).
    Slip,
}

impl Modification {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Modification::WallPulse => "wall_pulse",
            Modification::Radius => "radius",
            Modification::VelocityScale => "velocity_scale",
            Modification::Friction => "friction",
            Modification::WallStop => "wall_stop",
            Modification::TopPiston => "top_piston",
            Modification::Incremental => "incremental",
        }
    }

    /// True for the perturbations replayed in pairs (with and without), whose difference is the
    /// perturbed velocity field.
    pub fn paired(self) -> bool {
        matches!(self, Modification::WallPulse | Modification::Radius | Modification::Incremental)
    }
}

/// One replay of a checkpoint (SPEC §6.3–6.5).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ReplayConfig {
    /// Name of the replay (its output directory `replays/<name>/`; default `r<k>`).
    pub name: Option<String>,
    /// Index of the checkpoint to replay (0 is the state just after μ was switched on; k the one
    /// written at |ε_yy| ≈ k × `checkpoint_strain`; −1 the last one).
    pub checkpoint: i64,
    /// Start from the final state of this earlier single replay of the same config instead of a
    /// checkpoint (chains such as velocities × γ → wall stop → pulses, SPEC §6.6). With
    /// `source.dir`, it may also name a single replay of that earlier run (its
    /// `replays/<from>/final.gwck`).
    pub from: Option<String>,
    /// The modification: `wall_pulse`, `radius`, `velocity_scale`, `friction`, `wall_stop`,
    /// `top_piston` or `incremental`.
    pub modification: Modification,
    /// `wall_pulse`: `delta` or `wavelet`.
    pub shape: PulseShape,
    /// `wall_pulse`: the wall that emits it, `right` (propagation along x) or `top` (along y; the
    /// top wall must be a piston: start `from` a `top_piston` replay).
    pub pulse_wall: PulseWall,
    /// Amplitudes of the paired replay, each its own pair. `wall_pulse` with `shape = "delta"`:
    /// p_a, a time in t* (SPEC §6.4: p(t) = p*[1 + p_a δ(t)], the impulse p_a · p* · L_wall · t*
    /// delivered in one step) [t*]; with `shape = "wavelet"`: the dimensionless peak of f(t).
    /// Positive: compression, negative: rarefaction. `radius`: the relative radius change.
    pub amplitudes: Vec<f64>,
    /// Wavelet width T [t_a].
    pub width: f64,
    /// Pulse time t₀ after the start of the replay (default: 0 for `delta`, 6 T for `wavelet`) [t_a].
    pub delay: Option<f64>,
    /// `velocity_scale`: the factor γ.
    pub factor: f64,
    /// `velocity_scale`: instead of `factor`, the strain rate to reach [1/t*]: γ = `rate` / the
    /// current rate |v_top|/H of the top wall (SPEC §6.6: the final rates 2e-6, 2e-7, 2e-8 of the
    /// published loading at 2e-5 × γ = 0.1, 0.01, 0.001, whatever rate the loading ran at).
    pub rate: Option<f64>,
    /// `velocity_scale`: instead of `duration`, run for the time of this extra strain Δε at the
    /// reduced rate (SPEC §6.6: 2e-6, which restores the sliding contacts the scaling released).
    pub extra_strain: Option<f64>,
    /// `friction`: the new μ.
    pub friction: f64,
    /// `wall_stop`: the stopping time t_s [t_a].
    pub stop_time: f64,
    /// Duration of the replay [t_a].
    pub duration: f64,
    /// Interval Δt between samples of the perturbed velocity field [t_a].
    pub sample_interval: f64,
    /// Number of strips perpendicular to the propagation for the pulse speed.
    pub strips: usize,
    /// Fit the strip arrivals between these fractions of the largest distance from the source.
    pub fit_range: [f64; 2],
    /// Grey bands J of the arrival-time maps (grey = frac(J t_i/t_f)).
    pub bands: f64,
    /// Wall pulses: which arrival defines the pulse speed, `maximum` (SPEC §6.5: time of the
    /// maximum of |δv_x|) or `first_lobe` (peak of the first lobe of δv_x in the pulse's direction
    /// above `lobe_threshold` of the incident amplitude). Both speeds are always reported.
    pub arrival: ArrivalDefinition,
    /// `first_lobe`: a lobe counts from this fraction of the incident amplitude (the largest
    /// |δv_x| next to the pulsing wall as the pulse enters), in (0, 1].
    pub lobe_threshold: f64,
    /// `incremental`: the branch rule of the contacts at the Coulomb limit, `incremental` (the
    /// exact limit), or the bounds `stick` (all k_t), `free` (no tangential stiffness at the
    /// limit) and `slip` (slip branch both ways).
    pub branches: IncrementalBranches,
    /// `incremental`: velocity Verlet steps per shortest period 2π/ω_max of the all-stick network
    /// (ω_max from the Gershgorin bound), > π [steps].
    pub steps_per_period: f64,
}

impl Default for ReplayConfig {
    fn default() -> Self {
        ReplayConfig {
            name: None,
            checkpoint: -1,
            from: None,
            modification: Modification::WallPulse,
            shape: PulseShape::Delta,
            pulse_wall: PulseWall::Right,
            amplitudes: vec![1e-6],
            width: 0.05,
            delay: None,
            factor: 0.1,
            rate: None,
            extra_strain: None,
            friction: 2.0,
            stop_time: 1.0,
            duration: 2.0,
            sample_interval: 0.005,
            strips: 128,
            fit_range: [0.1, 0.9],
            bands: 4.0,
            arrival: ArrivalDefinition::Maximum,
            lobe_threshold: 0.01,
            branches: IncrementalBranches::Incremental,
            steps_per_period: 50.0,
        }
    }
}

/// Names of four wall-pulse replays (same amplitudes) whose speeds decompose the pulse-speed loss
/// Δc/c₀ = (c₀ − c_d)/c₀ (SPEC §6.6) into contact loss (c₀ − c_ns)/c₀, sliding (c_ns − c_s)/c₀ and
/// strain rate (c_s − c_d)/c₀. Leave out to skip the table.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct StaticLimitConfig {
    /// Replay of the undeformed packing (checkpoint 0): c₀.
    pub undeformed: Option<String>,
    /// Replay of the static deformed packing with μ = 2 (non-sliding): c_ns.
    pub non_sliding: Option<String>,
    /// Replay of the static deformed packing: c_s.
    pub static_state: Option<String>,
    /// Replay of the deforming packing (a checkpoint of the loading): c_d.
    pub deforming: Option<String>,
    /// More wall-pulse replays (e.g. the static states stopped over other t_s, or reached from
    /// other γ) drawn with the four states in `static_limit_speeds` (speed against |p_a|, the
    /// Fig. 10/11 style of the published study).
    pub variants: Vec<String>,
}

/// Names of two wall-pulse replays of the same state with equal amplitudes, and of more such
/// pairs (`states`) for the anisotropy of each state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct AnisotropyConfig {
    /// Replay with `pulse_wall = "top"`: c₁ along y.
    pub along_y: Option<String>,
    /// Replay with `pulse_wall = "right"`: c₂ along x.
    pub along_x: Option<String>,
    /// Label of the state of `along_y`/`along_x` in `anisotropy.csv`.
    pub state: String,
    /// More states, each a pair of replays like `along_y`/`along_x`.
    pub states: Vec<AnisotropyPair>,
}

impl Default for AnisotropyConfig {
    fn default() -> Self {
        AnisotropyConfig { along_y: None, along_x: None, state: "static".into(), states: Vec::new() }
    }
}

/// One state of the anisotropy table.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct AnisotropyPair {
    /// Label of the state in `anisotropy.csv`.
    pub state: String,
    /// Replay with `pulse_wall = "top"`: c₁ along y.
    pub along_y: String,
    /// Replay with `pulse_wall = "right"`: c₂ along x.
    pub along_x: String,
}

impl AnisotropyConfig {
    /// Every configured state: (label, along_y, along_x).
    pub fn pairs(&self) -> Vec<(String, String, String)> {
        let mut v = Vec::new();
        if let (Some(y), Some(x)) = (&self.along_y, &self.along_x) {
            v.push((self.state.clone(), y.clone(), x.clone()));
        }
        v.extend(self.states.iter().map(|p| (p.state.clone(), p.along_y.clone(), p.along_x.clone())));
        v
    }
}

/// What to write.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct OutputConfig {
    /// Draw plots (PNG and SVG).
    pub plots: bool,
    /// Write the perturbed velocity fields of paired replays (`field.npy`, float32, shape
    /// [samples, grains, 2]).
    pub fields: bool,
    /// Save the protocol state for `grainwave resume` at least every this many wall-clock seconds [s].
    pub save_every: f64,
}

impl Default for OutputConfig {
    fn default() -> Self {
        OutputConfig { plots: true, fields: true, save_every: 300.0 }
    }
}
