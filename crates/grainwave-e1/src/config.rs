//! The config of the `e1` protocol: every key, its documentation, unit and default.
//!
//! Units are E1's reduced units (SPEC §5.1): length = mean diameter d̄, grain density ρ = 1,
//! pressure = E* = E/(1 − ν²) (so E = 1 − ν²), time = d̄ √(ρ/E*).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Pulse transmission through confined, pressurized Hertz–Mindlin packings (SPEC §5): packings
/// prepared by piston compression (or reference lattices and chains), characterized, their elastic
/// moduli, and the signal of a pulse emitted by the bottom wall and received by the top wall, over
/// ensembles of samples, heights and pressures. Exactly one of `[packing]`, `[lattice]` and `[chain]`
/// says what is studied. Numbers are in E1 units: length = mean diameter d̄, density ρ = 1,
/// pressure = E*, time = d̄ √(ρ/E*).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct E1Config {
    /// Which protocol this file configures: `e1`.
    pub experiment: String,
    /// First seed s₀: sample k uses seed s₀ + k (radii, gas positions and velocities).
    #[serde(default = "one_u64")]
    pub seed: u64,
    /// Number of samples N for each size and pressure (seeds s₀ … s₀ + N − 1).
    #[serde(default = "one_usize")]
    pub samples: usize,
    /// Samples prepared and analysed at the same time (default: the number of worker threads).
    /// Results do not depend on it.
    #[serde(default)]
    pub parallel_samples: Option<usize>,
    /// Disordered packings prepared by piston compression (SPEC §5.1).
    #[serde(default)]
    pub packing: Option<PackingConfig>,
    /// Triangular lattices of Hertz–Mindlin balls between two walls (SPEC §5.6).
    #[serde(default)]
    pub lattice: Option<LatticeConfig>,
    /// The 1D chain of balls and springs between two walls (SPEC §5.6).
    #[serde(default)]
    pub chain: Option<ChainConfig>,
    /// Preparation by piston compression (packings, polydisperse lattices).
    #[serde(default)]
    pub preparation: PreparationConfig,
    /// Static characterization (SPEC §5.2).
    #[serde(default)]
    pub characterization: CharacterizationConfig,
    /// Elastic moduli (SPEC §5.3).
    #[serde(default)]
    pub moduli: ModuliConfig,
    /// Pulse transmission (SPEC §5.4–5.5).
    #[serde(default)]
    pub pulse: PulseConfig,
    /// The same pulse by full nonlinear molecular dynamics with damping (SPEC §5.7); off when absent.
    #[serde(default)]
    pub damped: Option<DampedConfig>,
    /// What to write.
    #[serde(default)]
    pub output: OutputConfig,
}

fn one_u64() -> u64 {
    1
}
fn one_usize() -> usize {
    1
}
fn yes() -> bool {
    true
}

/// Grain kind of E1 packings.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PackingKind {
    /// Spheres whose centres lie in a plane (2D motion, 3D Hertz contacts and inertia).
    Sphere2d,
    /// 3D spheres; the piston moves along z, x and y are periodic.
    Sphere,
}

/// Disordered packings: a granular gas compressed by a piston under constant force.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PackingConfig {
    /// `sphere2d` (default) or `sphere`.
    #[serde(default = "default_kind")]
    pub kind: PackingKind,
    /// Pressures p, one packing per pressure and size (3D pressure: piston force p L_x d̄ for
    /// `sphere2d`, p L_x L_y in 3D) [force/area].
    pub pressures: Vec<f64>,
    /// Target heights L (source–detector distances); the grain count of each is
    /// `estimated_fraction` × box volume / mean grain volume. Give `heights` or `grains` [length].
    #[serde(default)]
    pub heights: Option<Vec<f64>>,
    /// Grain counts, one packing size each (instead of `heights`).
    #[serde(default)]
    pub grains: Option<Vec<usize>>,
    /// Periodic width L_x (3D: L_x = L_y) (default 24 for `sphere2d`, 8 for `sphere`) [length].
    #[serde(default)]
    pub width: Option<f64>,
    /// Relative half-width a of the diameters, uniform in [d̄(1 − a), d̄(1 + a)] (default 0.2 for
    /// `sphere2d`, 0 — monodisperse — for `sphere`).
    #[serde(default)]
    pub spread: Option<f64>,
    /// Coulomb friction μ between grains and with the walls (0: frictionless).
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Poisson's ratio ν of the grains (E = 1 − ν² so that E* = 1).
    #[serde(default)]
    pub poisson: f64,
    /// Packing fraction used to turn `heights` into grain counts: area fraction for `sphere2d`
    /// (default 0.82), volume fraction for `sphere` (default 0.62).
    #[serde(default)]
    pub estimated_fraction: Option<f64>,
}

fn default_kind() -> PackingKind {
    PackingKind::Sphere2d
}
fn default_friction() -> f64 {
    0.5
}

/// Triangular lattices: `rows` × `columns` identical Hertz–Mindlin `sphere2d` balls, one lattice
/// direction along the walls, built in exact equilibrium (monodisperse) or compressed by the piston
/// (polydisperse).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LatticeConfig {
    /// Pressures p [force/area].
    pub pressures: Vec<f64>,
    /// Numbers of rows, one lattice size each (height ≈ rows × √3/2).
    pub rows: Vec<usize>,
    /// Balls per row (periodic along x).
    #[serde(default = "default_columns")]
    pub columns: usize,
    /// Coulomb friction μ (0: frictionless).
    #[serde(default = "default_friction")]
    pub friction: f64,
    /// Poisson's ratio ν.
    #[serde(default)]
    pub poisson: f64,
    /// Relative half-width of the diameters (0: monodisperse, built in exact equilibrium; > 0: placed
    /// on a loose lattice and compressed by the piston as in `[preparation]`).
    #[serde(default)]
    pub polydispersity: f64,
}

fn default_columns() -> usize {
    20
}

/// The 1D chain: N balls of mass m, spacing ℓ, springs K, the end balls tied to the walls by the same
/// spring; pulse computed by the generic machinery and, when monodisperse, by the closed-form mode sum.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ChainConfig {
    /// Chain lengths N, one size each.
    pub grains: Vec<usize>,
    /// Spring stiffness K [force/length].
    #[serde(default = "one_f64")]
    pub stiffness: f64,
    /// Ball mass m [mass].
    #[serde(default = "one_f64")]
    pub mass: f64,
    /// Spacing ℓ [length].
    #[serde(default = "one_f64")]
    pub spacing: f64,
    /// Relative half-width of the radii (0: monodisperse); masses ∝ R³, equal spring compressions.
    #[serde(default)]
    pub polydispersity: f64,
}

fn one_f64() -> f64 {
    1.0
}

/// Preparation by piston compression (SPEC §5.1): a gas of grains at random non-overlapping
/// positions with random velocities, a fixed bottom wall, periodic sides, a piston on top under a
/// constant force, Hertz–Mindlin contacts damped at a fraction of critical, until the largest
/// acceleration of the grains and of the piston is below `max_acceleration`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PreparationConfig {
    /// Solid fraction of the initial gas (area fraction for `sphere2d`, volume fraction in 3D).
    pub gas_fraction: f64,
    /// Initial velocities: each component uniform in [−v₀, v₀] (default v₀ = √(p/ρ), the velocity
    /// scale of the pressure) [length/time].
    pub initial_speed: Option<f64>,
    /// Damping ζ of the contacts during preparation, as a fraction of critical (normal and tangential).
    pub damping: f64,
    /// Piston mass (default: one layer of grains, L_x/d̄ (3D: L_x L_y/d̄²) mean grain masses) [mass].
    pub piston_mass: Option<f64>,
    /// Equilibrium: the largest grain acceleration max(|F|/m, |τ|R/I) and the piston's must fall
    /// below this [length/time²].
    pub max_acceleration: f64,
    /// Velocity quenching, a **deviation** from SPEC §5.1 (off by default): every `check_every`
    /// steps, if the power of the forces on grains and piston is negative, all velocities are set
    /// to zero (a FIRE-like accelerator of the relaxation). It changes the packing (the shear
    /// modulus C₃₃ rises markedly), so the published-protocol configs leave it off; false (default):
    /// plain damped molecular dynamics, dissipation only through the contact dashpots.
    pub quench: bool,
    /// Steps between quench and equilibrium checks.
    pub check_every: u64,
    /// Time step as a fraction of the shortest contact period (at `expected_overlap`).
    pub dt_fraction: f64,
    /// Largest expected overlap, as a fraction of the largest radius, for the time step (default
    /// 4 (3p)^{2/3} / R_max: four times the Hertz overlap of two mean grains under the force p d̄²).
    pub expected_overlap: Option<f64>,
    /// A preparation still out of equilibrium after this many steps fails.
    pub step_limit: u64,
    /// Time step of the **tail** of the relaxation, as a multiple of the preparation's (1: off).
    /// Once the kinetic energy per grain is below `tail_kinetic_energy` × p d̄³ (the gas starts
    /// at ≈ 0.26 p d̄³ per grain with v₀ = √p) and at most `tail_sliding_fraction` of the contacts
    /// slide, the force-carrying network has settled (measured: contact count and piston height
    /// fixed), and what keeps the largest acceleration above the tolerance is the slow bouncing
    /// of rattlers in their cages, a physical time that takes 50–80 % of the steps; the step is
    /// then multiplied by this factor and set back when the preparation converges (the packing
    /// keeps the preparation's step for what follows). The run stays plain damped MD with the same
    /// equilibrium criterion; `dt_fraction × tail_dt_factor` must stay ≤ 0.15 of the shortest
    /// contact period at the expected overlap (measured: at 0.2 one packing of 20 at p = 1e-6
    /// fell into a slow cycle and did not converge in 3e6 steps; at 0.15 all converged).
    pub tail_dt_factor: f64,
    /// Kinetic energy per grain, in units of p d̄³ (E1 units: p E* d̄³ with E* = 1), below which
    /// the tail time step may apply.
    pub tail_kinetic_energy: f64,
    /// Largest fraction of the contacts sliding at which the tail time step may apply.
    pub tail_sliding_fraction: f64,
}

impl Default for PreparationConfig {
    fn default() -> Self {
        PreparationConfig {
            gas_fraction: 0.3,
            initial_speed: None,
            damping: 0.2,
            piston_mass: None,
            max_acceleration: 1e-10,
            quench: false,
            check_every: 10,
            dt_fraction: 0.05,
            expected_overlap: None,
            step_limit: 50_000_000,
            tail_dt_factor: 3.0,
            tail_kinetic_energy: 1e-5,
            tail_sliding_fraction: 0.01,
        }
    }
}

/// Static characterization (SPEC §4, §5.2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct CharacterizationConfig {
    /// Boundary layer l next to each wall excluded from bulk statistics [length].
    pub boundary_layer: f64,
    /// Force-carrying contacts a grain needs not to be a rattler (default 2 with friction, d + 1
    /// without).
    pub rattler_min_contacts: Option<usize>,
    /// Bins of the angle, force and stiffness histograms.
    pub histogram_bins: usize,
}

impl Default for CharacterizationConfig {
    fn default() -> Self {
        CharacterizationConfig { boundary_layer: 3.0, rattler_min_contacts: None, histogram_bins: 30 }
    }
}

/// Elastic moduli (SPEC §5.3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ModuliConfig {
    /// Compute the global moduli (C₁₁, C₁₂, C₂₂, C₃₃; 3D: the 6 × 6 Voigt matrix) and the continuum
    /// speeds c_ℓ = √(C₂₂/Φ₃*), c_t = √(C₃₃/Φ₃*).
    pub enabled: bool,
    /// Also the local moduli: body force sin(nπy/L₂) (n = 1, 2) and imposed lines (n = 1, 3), along
    /// x (C₃₃) and y (C₂₂).
    pub local: bool,
}

impl Default for ModuliConfig {
    fn default() -> Self {
        ModuliConfig { enabled: true, local: false }
    }
}

/// Initial condition of the pulse.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum InitialConditionName {
    /// A: the grains touching the bottom wall are kicked along its inward normal in proportion to
    /// their wall stiffness (impulse h k_iw, h = 1).
    Impulse,
    /// B: the same grains displaced instead (a grain with the mean wall stiffness by δ = 1).
    Displacement,
}

/// How the signal is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PulseMethod {
    /// Sum over all eigenmodes (dense; up to ~20 000 free dofs).
    Modal,
    /// Time integration of the linear system with the sparse D (any size).
    Direct,
}

/// Geometric pre-stress term of the linearization.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum PreStressName {
    /// Stiffnesses only (SPEC default).
    None,
    /// −F_n/|r_ij| on relative transverse displacements.
    Normal,
    /// `normal` plus the terms of the stored tangential forces (not symmetric: `direct` only).
    Full,
}

/// What happens to rattlers in the linear problem.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RattlerHandling {
    /// Keep them (zero modes).
    Keep,
    /// Remove them and their contacts.
    Remove,
}

/// Pulse transmission (SPEC §5.4–5.5): the bottom wall emits, the top wall receives; both are
/// fixed during propagation. The signal F_sig(t) = F_top(t) − F_top(0⁻) is sampled on
/// `time_samples` equally spaced times from 0 to the end time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PulseConfig {
    /// Compute the pulse.
    pub enabled: bool,
    /// `impulse` (A) or `displacement` (B).
    pub initial_condition: InitialConditionName,
    /// `modal` (sum over all modes) or `direct` (time integration).
    pub method: PulseMethod,
    /// Pre-stress term: `none`, `normal` or `full` (`full` needs `method = "direct"`).
    pub prestress: PreStressName,
    /// Rattlers: `keep` (zero modes) or `remove`.
    pub rattlers: RattlerHandling,
    /// End of the time grid (default: `transits` × L/c_H, with c_H = d̄ √(k/m̄) the speed of a chain
    /// of mean grains whose contacts carry p d̄²; chains: `transits` × N ℓ/c) [time].
    pub end_time: Option<f64>,
    /// End of the default time grid in transit times L/c_H.
    pub transits: f64,
    /// Number of times on the grid (including t = 0).
    pub time_samples: usize,
    /// Fraction of the first peak that defines the leading edge.
    pub edge_fraction: f64,
    /// Floor of the first coherent peak (SPEC §5.5): the peak is the first local maximum that
    /// reaches this fraction of the record's largest value and is a lobe (the signal falls to half
    /// of it before exceeding it) — not the largest peak: the Airy front of lattices and chains is
    /// smaller than the oscillations behind it (default 0.1).
    pub peak_threshold: Option<f64>,
    /// Reference heights of c_tof: the two heights of the series closest to these [length].
    pub tof_heights: [f64; 2],
    /// Bootstrap replicates of the exponent intervals (resampling the samples of every height;
    /// 0: no intervals). Series need at least two heights with at least two samples each.
    pub bootstrap: usize,
    /// An exponent is too wide to call when the half-width of its 95 % bootstrap interval exceeds
    /// this fraction of its value.
    pub exponent_resolution: f64,
    /// Times of the displacement-field snapshots, as fractions of the first-peak time of the first
    /// sample of each size and pressure.
    pub field_times: Vec<f64>,
}

impl Default for PulseConfig {
    fn default() -> Self {
        PulseConfig {
            enabled: true,
            initial_condition: InitialConditionName::Impulse,
            method: PulseMethod::Modal,
            prestress: PreStressName::None,
            rattlers: RattlerHandling::Keep,
            end_time: None,
            transits: 3.0,
            time_samples: 2001,
            edge_fraction: 0.1,
            peak_threshold: None,
            tof_heights: [8.0, 25.0],
            bootstrap: 1000,
            exponent_resolution: 0.25,
            field_times: vec![0.5, 1.0],
        }
    }
}

/// Damped propagation by nonlinear molecular dynamics (SPEC §5.7): the packing with its piston
/// frozen, all contacts damped at ζ of critical, the bottom-wall grains kicked as in initial
/// condition A with a small strength h; the signal (top-wall load of the kicked run minus that of an
/// identical unkicked run, divided by h) is comparable to the linear signal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct DampedConfig {
    /// Damping fractions ζ ∈ [0, 1], one MD run each.
    pub damping_fractions: Vec<f64>,
    /// Kick strength relative to the wall contacts: h = amplitude × ⟨ξ_w⟩/ω_w (⟨ξ_w⟩ the mean
    /// overlap of the bottom-wall contacts, ω_w = √(⟨k_w⟩/m̄)), i.e. the kicked grains move by about
    /// `amplitude` × their wall overlap. The weakest contacts of a packing are strongly nonlinear:
    /// the MD–linear difference grows in proportion to the amplitude (measured on a 60-grain packing
    /// at p = 1e-4: 0.33 % at 1e-5, 11 % at 1e-4).
    pub amplitude: f64,
    /// Number of samples (the first ones) that get the MD runs.
    pub samples: usize,
}

impl Default for DampedConfig {
    fn default() -> Self {
        DampedConfig { damping_fractions: vec![0.0, 0.1, 0.3, 1.0], amplitude: 1e-6, samples: 1 }
    }
}

/// What to write.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct OutputConfig {
    /// VTK files (first sample of each size and pressure: grains, contacts, displacement fields).
    pub vtk: bool,
    /// Plots (PNG and SVG).
    pub plots: bool,
    /// Keep `preparing.gwck` files at most this many seconds old while preparations run, so that a
    /// killed run loses little [s].
    pub save_every_seconds: f64,
}

impl Default for OutputConfig {
    fn default() -> Self {
        OutputConfig { vtk: yes(), plots: true, save_every_seconds: 60.0 }
    }
}
