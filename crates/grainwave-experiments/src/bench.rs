//! Throughput benchmarks, side by side with LAMMPS on the same packings.
//!
//! The three cases of the LAMMPS decks `bench3d.lmp` and `bench2d.lmp` (dense packings stored as
//! LAMMPS data files) are reproduced with the same grains, contact law, time step, skin and
//! number of steps:
//!
//! | case | packing | law (LAMMPS) | grainwave preset | dt |
//! |---|---|---|---|---|
//! | `hertz3d` | `pack3d_062.data.gz`, 32 000 spheres | `granular hertz/material 1e5 0.5 0.3 tangential mindlin NULL 1.0 0.5 damping tsuji` | `hertz_mindlin`, E = 1e5, ν = 0.3, Tsuji e = 0.5, γ_t = γ_n, μ = 0.5 | 1e-3 |
//! | `hooke3d` | same | `gran/hooke/history 1e4 NULL 50 NULL 0.5 1` | `hooke_cundall_strack`, k_n = 1e4, k_t = 2/7 k_n, γ_n = 50 m*, γ_t = γ_n/2, μ = 0.5 | 1e-3 |
//! | `hooke2d` | `pack2d_084.data.gz`, 16 384 disks | `gran/hooke/history 2e4 NULL 50 NULL 0.2 1` | same with k_n = 2e4, μ = 0.2 | 2e-4 |
//! | `walled2d` | the 2D packing inside four walls | — | E2 law: Hooke, e = 0.92, k_t = k_n/2, μ = 0.2, weak rolling resistance, frictionless walls | 2e-4 |
//! | `piston2d` | the 2D packing as E1 `sphere2d` balls, periodic in x, floor and piston at p = 1e-4 | — | E1 law: Hertz–Mindlin, E* = 1, ν = 0, μ = 0.5, ζ = 0.2 | E1's: 0.05 × the contact time at the expected overlap |
//! | `slab2d` | E3 lattice slab, 128 rows of 128 disks, floor and side walls, gravity | — | E3 law: Hooke k_N = 3000, k_T = 0.8 k_N, dashpots √(m̄k), μ = 0.5; Beeman | 5e-4 |
//!
//! The last three are the studies' own set-ups at the size of `hooke2d` (no LAMMPS deck): their
//! throughput per contact, against the periodic cases, is what the studies' laws, walls, pistons
//! and gravity cost.
//! Every case starts, like the decks, with all translational velocities set to zero (angular
//! velocities are kept from the file) and uses a Verlet skin of 0.1 checked every step.
//! Throughput is N × steps / (wall-clock time of the stepping loop), as LAMMPS's "Loop time".
//!
//! The sheared variants (`shear` > 0, LAMMPS `fix deform 1 xy erate shear remap v`) tilt the
//! periodic cell at the engineering shear rate `shear` (tilt rate = shear × L_y): Lees–Edwards
//! boundaries, the grains themselves are not moved.
//!
//! `replicate = [n_x, n_y, n_z]` tiles the periodic cases' packing n_x × n_y × n_z times
//! ([`replicate`]): the 32 000-sphere packing tiled 4 × 4 × 2 is a 1 024 000-grain packing with
//! the same local structure, to measure how memory and throughput scale with size alone.

use crate::Result;
use glam::DVec2;
use grainwave_core::contact::{ContactParams, Partner};
use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::domain::{Domain, Wall};
use grainwave_core::grains::Grains;
use grainwave_core::sim::SimulationBuilder;
use grainwave_core::CoreError;
use grainwave_io::lammps::{read_data, read_text, ImportOptions};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// A benchmark case.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BenchCase {
    /// 3D Hertz–Mindlin with Tsuji damping on the 32 000-sphere packing.
    Hertz3d,
    /// 3D Hooke + Cundall–Strack on the 32 000-sphere packing.
    Hooke3d,
    /// 2D Hooke + Cundall–Strack on the 16 384-disk periodic packing.
    Hooke2d,
    /// 2D E2-style walled packing: the 16 384 disks inside four frictionless walls.
    Walled2d,
    /// 2D E1-style packing: the 16 384 disks as `sphere2d` balls under a piston.
    Piston2d,
    /// E3 lattice slab of 16 384 disks under gravity.
    Slab2d,
}

impl BenchCase {
    /// All cases, in order.
    pub const ALL: [BenchCase; 6] = [BenchCase::Hertz3d, BenchCase::Hooke3d, BenchCase::Hooke2d, BenchCase::Walled2d, BenchCase::Piston2d, BenchCase::Slab2d];

    /// Name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            BenchCase::Hertz3d => "hertz3d",
            BenchCase::Hooke3d => "hooke3d",
            BenchCase::Hooke2d => "hooke2d",
            BenchCase::Walled2d => "walled2d",
            BenchCase::Piston2d => "piston2d",
            BenchCase::Slab2d => "slab2d",
        }
    }

    /// Parses a case name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == name)
    }

    /// Packing file inside the benchmark directory (`None`: the case builds its own).
    pub fn data_file(self) -> Option<&'static str> {
        match self {
            BenchCase::Hertz3d | BenchCase::Hooke3d => Some("pack3d_062.data.gz"),
            BenchCase::Hooke2d | BenchCase::Walled2d | BenchCase::Piston2d => Some("pack2d_084.data.gz"),
            BenchCase::Slab2d => None,
        }
    }

    /// Number of steps of the LAMMPS decks' reference runs.
    pub fn default_steps(self) -> u64 {
        match self {
            BenchCase::Hertz3d | BenchCase::Hooke3d => 2000,
            BenchCase::Hooke2d | BenchCase::Walled2d | BenchCase::Piston2d | BenchCase::Slab2d => 5000,
        }
    }

    /// Time step of the cases that fix it (`piston2d` takes E1's rule, `slab2d` E3's default).
    pub fn dt(self) -> Option<f64> {
        match self {
            BenchCase::Hertz3d | BenchCase::Hooke3d => Some(1e-3),
            BenchCase::Hooke2d | BenchCase::Walled2d => Some(2e-4),
            BenchCase::Piston2d | BenchCase::Slab2d => None,
        }
    }

    /// The LAMMPS deck and its variables, when LAMMPS can run this case.
    fn lammps_deck(self) -> Option<(&'static str, Vec<(&'static str, &'static str)>)> {
        match self {
            BenchCase::Hertz3d => Some(("bench3d.lmp", vec![("law", "hertz")])),
            BenchCase::Hooke3d => Some(("bench3d.lmp", vec![("law", "hooke")])),
            BenchCase::Hooke2d => Some(("bench2d.lmp", vec![])),
            BenchCase::Walled2d | BenchCase::Piston2d | BenchCase::Slab2d => None,
        }
    }

    /// Grain–grain contact parameters (same law as the LAMMPS deck; the study's law for the
    /// study cases).
    pub fn contact(self) -> ContactParams {
        match self {
            BenchCase::Hertz3d => ContactParams {
                young: Some(1.0e5),
                poisson: Some(0.3),
                tsuji_restitution: Some(0.5),
                tangential_damping_ratio: Some(1.0),
                friction: Some(0.5),
                ..ContactParams::preset("hertz_mindlin")
            },
            BenchCase::Hooke3d => ContactParams {
                normal_stiffness: Some(1.0e4),
                normal_damping_rate: Some(50.0),
                friction: Some(0.5),
                ..ContactParams::preset("hooke_cundall_strack")
            },
            BenchCase::Hooke2d => ContactParams {
                normal_stiffness: Some(2.0e4),
                normal_damping_rate: Some(50.0),
                friction: Some(0.2),
                ..ContactParams::preset("hooke_cundall_strack")
            },
            // E2 (SPEC §6.1): γ_n for e ≈ 0.92, k_t = k_n/2, γ_t = γ_n/2, μ = 0.2, weak rolling
            // resistance (k_r = 0.01 k_n R̄², μ_r = 0.01).
            BenchCase::Walled2d => ContactParams {
                normal_stiffness: Some(2.0e4),
                restitution: Some(0.92),
                tangential_stiffness_ratio: Some(0.5),
                friction: Some(0.2),
                rolling_stiffness: Some(0.01 * 2.0e4 * 0.25),
                rolling_friction: Some(0.01),
                ..ContactParams::preset("hooke_cundall_strack")
            },
            // E1 (SPEC §5.1): E* = 1 (E = 1 − ν² with ν = 0), μ = 0.5, ζ = 0.2 (the preparation's)
            BenchCase::Piston2d => crate::e1::prepare::hertz_params(PISTON_FRICTION, 0.0, PISTON_DAMPING),
            // E3 (SPEC §7.1): the default material (its dashpot coefficients are not preset keys)
            BenchCase::Slab2d => {
                let m = slab_material();
                let mut p = ContactParams::preset("hooke_cundall_strack");
                p.normal_stiffness = Some(m.normal_stiffness);
                p.tangential_stiffness_ratio = Some(m.ratio);
                p.friction = Some(m.friction);
                p
            }
        }
    }
}

/// `piston2d`: E1's friction, preparation damping and a pressure of its series.
const PISTON_FRICTION: f64 = 0.5;
const PISTON_DAMPING: f64 = 0.2;
const PISTON_PRESSURE: f64 = 1e-4;
/// `slab2d`: rows × grains per row (16 384 disks, as `hooke2d`).
const SLAB_SIZE: usize = 128;
/// `slab2d`: steps run before the timed ones.
const SLAB_WARMUP: u64 = 1000;
/// Steps between the contact samples of a timed run.
const CONTACT_SAMPLE: u64 = 100;

fn slab_material() -> crate::e3::slab::Material {
    let m = crate::e3::config::MaterialConfig::default();
    crate::e3::slab::Material::resolve(&m, m.friction, m.tangential_stiffness_ratio)
}

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// The case.
    pub case: BenchCase,
    /// Directory holding the packings (`pack3d_062.data.gz`, `pack2d_084.data.gz`) and decks.
    pub dir: PathBuf,
    /// Number of steps (default: the case's).
    pub steps: Option<u64>,
    /// Engineering shear rate of the periodic cell (0: static box).
    pub shear: f64,
    /// Storage order of the grains.
    pub order: GrainOrder,
    /// Vector path of the force pass (0 portable, 1 the fused AVX2 pass, 2 the AVX-512 windows;
    /// `None`: the engine's default, 1). Results are the same bits on every path.
    pub simd: Option<u8>,
    /// Copies of the periodic packing along x, y, z (`[1, 1, 1]`: as read; see [`replicate`]).
    /// The periodic cases only (`hertz3d`, `hooke3d`, `hooke2d`); z stays 1 in 2D.
    pub replicate: [u32; 3],
}

/// Storage order of the grains in a benchmark run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum GrainOrder {
    /// As in the packing file (LAMMPS writes atoms binned in space).
    #[default]
    File,
    /// Bin order ([`grainwave_core::sim::Simulation::sort_spatially`]).
    Sorted,
    /// A seeded random permutation: no locality at all.
    Shuffled,
}

impl GrainOrder {
    /// Parses `file`, `sorted` or `shuffled`.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "file" => Some(GrainOrder::File),
            "sorted" => Some(GrainOrder::Sorted),
            "shuffled" => Some(GrainOrder::Shuffled),
            _ => None,
        }
    }
}

/// Applies the seeded random permutation of [`GrainOrder::Shuffled`].
fn shuffle<D: Dim>(g: &mut Grains<D>) {
    use rand::seq::SliceRandom;
    use rand::SeedableRng;
    let mut perm: Vec<usize> = (0..g.len()).collect();
    perm.shuffle(&mut rand_chacha::ChaCha8Rng::seed_from_u64(1));
    fn apply<T: Copy>(v: &mut Vec<T>, perm: &[usize]) {
        *v = perm.iter().map(|&k| v[k]).collect();
    }
    apply(&mut g.id, &perm);
    apply(&mut g.radius, &perm);
    apply(&mut g.mass, &perm);
    apply(&mut g.inertia, &perm);
    apply(&mut g.pos, &perm);
    apply(&mut g.vel, &perm);
    apply(&mut g.omega, &perm);
    apply(&mut g.orientation, &perm);
    apply(&mut g.image, &perm);
    apply(&mut g.force, &perm);
    apply(&mut g.torque, &perm);
}

/// What one run measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchResult {
    /// `grainwave` or `lammps`.
    pub code: String,
    /// Case name.
    pub case: String,
    /// Engineering shear rate.
    pub shear: f64,
    /// Storage order of the grains (grainwave).
    pub order: GrainOrder,
    /// Number of grains.
    pub grains: usize,
    /// Steps timed.
    pub steps: u64,
    /// Worker threads (grainwave) or MPI processes (LAMMPS).
    pub workers: usize,
    /// Wall-clock time of the stepping loop (s).
    pub loop_seconds: f64,
    /// N × steps / loop time.
    pub particle_steps_per_second: f64,
    /// Mean number of grain–grain contacts per grain at the end (each contact counted for both
    /// grains, walls not counted), as LAMMPS's `compute contact/atom`.
    pub contacts_per_grain: f64,
    /// Grain–grain contacts (each counted once; grainwave: the mean of samples taken every
    /// 100 steps, LAMMPS: at the end) × steps / loop time: the throughput per contact, to compare
    /// cases whose packings have different contact numbers.
    pub contact_steps_per_second: f64,
    /// Neighbor-list builds during the loop.
    pub neighbor_rebuilds: u64,
    /// Peak memory (bytes): grainwave's resident set high-water mark (whole process so far);
    /// LAMMPS's own per-rank estimate × ranks.
    pub peak_memory_bytes: u64,
    /// Translational kinetic energy at the end.
    pub kinetic_energy: f64,
    /// grainwave: fingerprint of the final state ([`grainwave_core::sim::Simulation::state_hash`]),
    /// equal for any number of threads; empty for LAMMPS.
    pub state_hash: String,
}

/// Runs one grainwave benchmark (in the current rayon pool).
pub fn run_grainwave(cfg: &BenchConfig) -> Result<BenchResult> {
    let steps = cfg.steps.unwrap_or(cfg.case.default_steps());
    let periodic = matches!(cfg.case, BenchCase::Hertz3d | BenchCase::Hooke3d | BenchCase::Hooke2d);
    if cfg.shear != 0.0 && !periodic {
        return Err(CoreError::invalid("--shear", cfg.shear, "0 for the walled and study cases (a shearing cell needs a periodic case: hertz3d, hooke3d, hooke2d)").into());
    }
    if cfg.replicate != [1, 1, 1] && !periodic {
        return Err(CoreError::invalid("--replicate", format_replicate(cfg.replicate), "1x1x1 for the walled and study cases (tiling needs a periodic case: hertz3d, hooke3d, hooke2d)").into());
    }
    if cfg.case == BenchCase::Slab2d {
        return time_sim(cfg, slab(cfg)?, steps);
    }
    let path = cfg.dir.join(cfg.case.data_file().unwrap_or_default());
    let data = read_data(&path).map_err(|e| CoreError::Inconsistent(e.to_string()))?;
    let opts = ImportOptions::default();
    match cfg.case {
        BenchCase::Hertz3d | BenchCase::Hooke3d => {
            let (grains, domain) = data.to_packing_3d(&opts).map_err(|e| CoreError::Inconsistent(e.to_string()))?;
            let (grains, domain) = replicate(grains, domain, cfg.replicate)?;
            time_run(cfg, grains, domain, steps)
        }
        BenchCase::Hooke2d => {
            let (grains, domain) = data.to_packing_2d(&opts).map_err(|e| CoreError::Inconsistent(e.to_string()))?;
            let (grains, domain) = replicate(grains, domain, cfg.replicate)?;
            time_run(cfg, grains, domain, steps)
        }
        BenchCase::Walled2d => {
            let (grains, domain) = data.to_packing_2d(&opts).map_err(|e| CoreError::Inconsistent(e.to_string()))?;
            let (grains, domain) = walled(grains, domain, &cfg.case.contact())?;
            time_run(cfg, grains, domain, steps)
        }
        BenchCase::Piston2d => {
            let (disks, domain) = data.to_packing_2d(&opts).map_err(|e| CoreError::Inconsistent(e.to_string()))?;
            time_sim(cfg, piston(cfg, disks, &domain)?, steps)
        }
        BenchCase::Slab2d => unreachable!("built above"),
    }
}

/// `4x4x2` for `[4, 4, 2]`.
fn format_replicate(n: [u32; 3]) -> String {
    format!("{}x{}x{}", n[0], n[1], n[2])
}

/// Tiles a periodic packing `n[0] × n[1] × n[2]` times: the box grows by those factors, and copy
/// (i, j, k) of grain g sits at x_g + (i L_x, j L_y, k L_z) with g's radius, mass, velocity and
/// spin. Copies are stored tile after tile (x fastest), each in the original's order; ids are the
/// storage indices, image flags start at zero. Because the box is periodic along every tiled
/// axis, each grain of the tiled packing has the neighbours, at the same distances, that its
/// original had among the original's periodic images: the same contacts and overlaps, a bigger
/// sample of the same structure. `[1, 1, 1]` returns the packing unchanged.
///
/// Refused (naming `--replicate`, the value and what is allowed) for a factor of 0, a factor
/// other than 1 along an axis that is not periodic or beyond the dimension, a tilted cell, or
/// more than [`crate::limits::MAX_GRAINS`] grains in all — checked before anything is allocated.
pub fn replicate<D: Dim>(grains: Grains<D>, domain: Domain<D>, n: [u32; 3]) -> Result<(Grains<D>, Domain<D>)> {
    if n == [1, 1, 1] {
        return Ok((grains, domain));
    }
    let shown = format_replicate(n);
    for (k, &f) in n.iter().enumerate() {
        if f == 0 {
            return Err(CoreError::invalid("--replicate", &shown, "factors of at least 1 (e.g. 4x4x2)").into());
        }
        if f > 1 && (k >= D::D || !domain.is_periodic(k)) {
            return Err(CoreError::invalid("--replicate", &shown, format!("1 along axis {k}: the packing is not periodic there (or has no such axis)")).into());
        }
    }
    if domain.tilt.iter().any(|&t| t != 0.0) {
        return Err(CoreError::invalid("--replicate", &shown, "1x1x1 for a tilted cell (tiling needs a rectangular periodic box)").into());
    }
    let copies = n.iter().map(|&f| f as f64).product::<f64>();
    let total = copies * grains.len() as f64;
    if total > crate::limits::MAX_GRAINS {
        return Err(CoreError::invalid("--replicate", &shown, format!("at most {:.0} grains in all (this gives {total:.0})", crate::limits::MAX_GRAINS)).into());
    }
    if let Some(free) = crate::limits::available_memory() {
        let need = total * crate::limits::BYTES_PER_GRAIN;
        if need > free {
            return Err(CoreError::invalid("--replicate", &shown, format!("a packing that fits in memory: {total:.0} grains need ≈ {:.1} GiB, {:.1} GiB available", need / 1073741824.0, free / 1073741824.0)).into());
        }
    }
    let len: Vec<f64> = (0..3).map(|k| if k < D::D { domain.length(k) } else { 0.0 }).collect();
    let mut tiled = Grains::<D>::new(grains.kind);
    let cap = total as usize;
    tiled.id.reserve_exact(cap);
    tiled.radius.reserve_exact(cap);
    tiled.mass.reserve_exact(cap);
    tiled.inertia.reserve_exact(cap);
    tiled.pos.reserve_exact(cap);
    tiled.vel.reserve_exact(cap);
    tiled.omega.reserve_exact(cap);
    tiled.orientation.reserve_exact(cap);
    tiled.image.reserve_exact(cap);
    tiled.force.reserve_exact(cap);
    tiled.torque.reserve_exact(cap);
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let mut shift = D::Vector::ZERO;
                for (axis, t) in [i, j, k].into_iter().enumerate().take(D::D) {
                    shift.set(axis, t as f64 * len[axis]);
                }
                for g in 0..grains.len() {
                    let c = tiled.push_with_mass(grains.pos[g] + shift, grains.radius[g], grains.mass[g], grains.vel[g]);
                    let c = c as usize;
                    tiled.inertia[c] = grains.inertia[g];
                    tiled.omega[c] = grains.omega[g];
                    tiled.orientation[c] = grains.orientation[g];
                }
            }
        }
    }
    let mut hi = domain.hi;
    for (axis, &f) in n.iter().enumerate().take(D::D) {
        hi.set(axis, domain.lo.get(axis) + f as f64 * len[axis]);
    }
    let mut big = domain;
    big.hi = hi;
    Ok((tiled, big))
}

/// `piston2d`: the disks of the periodic packing as E1's `sphere2d` balls (unit density, so unit
/// mean diameter as in E1), periodic in x only, a fixed floor touching the lowest ball and a
/// piston of one layer's mass touching the highest, pushing with p L_x d̄ (E1's piston,
/// `e1::prepare::build_gas`); time step by E1's rule for that pressure.
fn piston(cfg: &BenchConfig, disks: Grains<grainwave_core::dim::D2>, domain: &Domain<grainwave_core::dim::D2>) -> Result<grainwave_core::sim::Simulation<grainwave_core::dim::D2>> {
    use crate::e1::prepare::default_expected_overlap;
    use grainwave_core::domain::{TimeFunction, WallMotion};
    use grainwave_core::grains::GrainKind;
    let mut grains = Grains::<grainwave_core::dim::D2>::new(GrainKind::Sphere2d);
    for (p, &r) in disks.pos.iter().zip(&disks.radius) {
        grains.push(*p, r, 1.0, DVec2::ZERO);
    }
    if cfg.order == GrainOrder::Shuffled {
        shuffle(&mut grains);
    }
    let params = cfg.case.contact();
    let law = params.build(Partner::Grain, "contact")?;
    let wall_law = params.build(Partner::Wall, "contact.wall")?;
    let lo = grains.pos.iter().zip(&grains.radius).map(|(p, r)| p.y - r).fold(f64::INFINITY, f64::min);
    let hi = grains.pos.iter().zip(&grains.radius).map(|(p, r)| p.y + r).fold(f64::NEG_INFINITY, f64::max);
    let width = domain.hi.x - domain.lo.x;
    let n = grains.len() as f64;
    let mean_diameter = 2.0 * grains.radius.iter().sum::<f64>() / n;
    let r_max = grains.radius.iter().cloned().fold(0.0, f64::max);
    let piston_mass = width / mean_diameter * grains.total_mass() / n;
    let force = PISTON_PRESSURE * width * mean_diameter;
    let d = Domain::new(DVec2::new(domain.lo.x, lo), DVec2::new(domain.hi.x, hi), [true, false, false])
        .with_wall(Wall::axis_aligned("bottom", 1, lo, true, wall_law))
        .with_wall(Wall::axis_aligned("top", 1, hi, false, wall_law).with_motion(WallMotion::Piston { mass: piston_mass, force: TimeFunction::constant(force) }));
    let preparation = crate::e1::config::PreparationConfig::default();
    let sim = SimulationBuilder::new(grains, d, law)
        .dt_fraction(preparation.dt_fraction)
        .expected_overlap(default_expected_overlap(PISTON_PRESSURE, r_max))
        .skin(0.1)
        .max_initial_overlap(0.3)
        .build()?;
    Ok(sim)
}

/// `slab2d`: E3's slab (SPEC §7.2.1: full rows on a triangular lattice of spacing 2R̄, floor and
/// side walls, gravity), 128 rows of 128 equal disks at rest, E3's default material and
/// integration (`e3::slab::build`).
fn slab(cfg: &BenchConfig) -> Result<grainwave_core::sim::Simulation<grainwave_core::dim::D2>> {
    use crate::e3::config::{IntegrationConfig, RowLayout};
    use crate::e3::slab::{build, Shape, Sites};
    let sites = Sites::of(Shape::Slab { layers: SLAB_SIZE, grains_per_layer: SLAB_SIZE, rows: RowLayout::Full });
    let radii = vec![1.0; sites.positions.len()];
    let mut sim = build(&sites, &radii, &slab_material(), &IntegrationConfig::default(), 1)?;
    if cfg.order == GrainOrder::Shuffled {
        shuffle(&mut sim.grains);
        sim.refresh()?;
    }
    // Untimed: the touching lattice sinks under its weight (a contact period 2π √(m̄/2k_N)
    // ≈ 0.08 τ = 160 steps). After 1 000 steps the inclined contacts carry the weight (≈ 4 per
    // grain); the horizontal ones close as the slab keeps settling between the side walls
    // (≈ 5.6 per grain 5 000 steps later), which the per-contact throughput follows.
    sim.steps(SLAB_WARMUP)?;
    Ok(sim)
}

/// The periodic 2D packing closed by four frictionless walls, each touching the outermost disk
/// along its axis (no grain overlaps a wall at the start; the grains near the walls lose the
/// contacts they had across the periodic boundary).
fn walled(grains: Grains<grainwave_core::dim::D2>, domain: Domain<grainwave_core::dim::D2>, params: &ContactParams) -> Result<(Grains<grainwave_core::dim::D2>, Domain<grainwave_core::dim::D2>)> {
    let mut wall_params = params.clone();
    wall_params.friction = Some(0.0);
    wall_params.rolling_stiffness = None;
    wall_params.rolling_friction = None;
    let wall_law = wall_params.build(Partner::Wall, "contact.wall")?;
    let lo = grains.pos.iter().zip(&grains.radius).fold(DVec2::splat(f64::INFINITY), |m, (p, r)| m.min(*p - DVec2::splat(*r)));
    let hi = grains.pos.iter().zip(&grains.radius).fold(DVec2::splat(f64::NEG_INFINITY), |m, (p, r)| m.max(*p + DVec2::splat(*r)));
    let mut d = Domain::new(lo.min(domain.lo), hi.max(domain.hi), [false; 3]);
    d = d
        .with_wall(Wall::axis_aligned("left", 0, lo.x, true, wall_law))
        .with_wall(Wall::axis_aligned("right", 0, hi.x, false, wall_law))
        .with_wall(Wall::axis_aligned("bottom", 1, lo.y, true, wall_law))
        .with_wall(Wall::axis_aligned("top", 1, hi.y, false, wall_law));
    Ok((grains, d))
}

fn time_run<D: Dim>(cfg: &BenchConfig, mut grains: Grains<D>, mut domain: Domain<D>, steps: u64) -> Result<BenchResult> {
    for v in grains.vel.iter_mut() {
        *v = D::Vector::ZERO; // `velocity all set 0 0 0`
    }
    if cfg.shear != 0.0 {
        domain.set_shear_rate(cfg.shear)?;
    }
    if cfg.order == GrainOrder::Shuffled {
        shuffle(&mut grains);
    }
    let law = cfg.case.contact().build(Partner::Grain, "contact")?;
    let dt = cfg.case.dt().ok_or_else(|| CoreError::Inconsistent(format!("case `{}` has no fixed time step", cfg.case.name())))?;
    let sim = SimulationBuilder::new(grains, domain, law).dt(dt).skin(0.1).max_initial_overlap(0.3).build()?;
    time_sim(cfg, sim, steps)
}

/// Times `steps` steps of `sim` (the storage order and vector path of `cfg` applied first).
fn time_sim<D: Dim>(cfg: &BenchConfig, mut sim: grainwave_core::sim::Simulation<D>, steps: u64) -> Result<BenchResult> {
    if let Some(level) = cfg.simd {
        sim.set_simd_level(level);
    }
    if cfg.order == GrainOrder::Sorted {
        sim.sort_spatially();
        sim.refresh_forces()?;
    }
    // grain–grain contacts now (the pass counts walls too)
    let grain_contacts = |sim: &grainwave_core::sim::Simulation<D>| {
        let wall_contacts = sim.nlist.wall_pairs.iter().filter(|p| p.state.in_contact()).count() as u64;
        (sim.counters.contacts - wall_contacts) as f64
    };
    let builds0 = sim.nlist.builds;
    // steps in chunks (the same bits as one call), the contacts sampled after each: their mean
    // over the run for the throughput per contact (a settling packing gains contacts as it goes)
    let (mut done, mut contact_sum, mut samples) = (0, 0.0, 0u64);
    let start = Instant::now();
    while done < steps {
        let k = CONTACT_SAMPLE.min(steps - done);
        sim.steps(k)?;
        done += k;
        contact_sum += grain_contacts(&sim) * k as f64;
        samples += k;
    }
    let loop_seconds = start.elapsed().as_secs_f64();
    let n = sim.len();
    let ke = grainwave_core::util::det_sum(n, |k| 0.5 * sim.grains.mass[k] * sim.grains.vel[k].norm2());
    // grain–grain contacts at the end, each counted for both grains (LAMMPS `compute contact/atom`)
    let grain_contacts_end = grain_contacts(&sim);
    let mean_contacts = if samples > 0 { contact_sum / samples as f64 } else { grain_contacts_end };
    Ok(BenchResult {
        code: "grainwave".into(),
        case: cfg.case.name().into(),
        shear: cfg.shear,
        order: cfg.order,
        grains: n,
        steps,
        workers: rayon::current_num_threads(),
        loop_seconds,
        particle_steps_per_second: n as f64 * steps as f64 / loop_seconds,
        contacts_per_grain: 2.0 * grain_contacts_end / n as f64,
        contact_steps_per_second: mean_contacts * steps as f64 / loop_seconds,
        neighbor_rebuilds: sim.nlist.builds - builds0,
        peak_memory_bytes: peak_rss_bytes(),
        kinetic_energy: ke,
        state_hash: format!("{:016x}", sim.state_hash()),
    })
}

/// Resident-set high-water mark of this process (Linux `VmHWM`), 0 where unknown.
pub fn peak_rss_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("VmHWM:")).and_then(|l| l.split_whitespace().nth(1)?.parse::<u64>().ok()))
        .map_or(0, |kib| kib * 1024)
}

/// How to start LAMMPS.
#[derive(Clone, Debug)]
pub struct LammpsCommand {
    /// The LAMMPS executable (e.g. `lmp`).
    pub executable: String,
    /// MPI processes (1: run directly; more: through `mpirun`).
    pub processes: usize,
}

/// Runs the LAMMPS deck of `cfg.case` and reads its loop time and final thermo line. The
/// packing is decompressed into a temporary directory first.
pub fn run_lammps(cfg: &BenchConfig, lmp: &LammpsCommand) -> Result<BenchResult> {
    let (deck, vars) = cfg
        .case
        .lammps_deck()
        .ok_or_else(|| CoreError::Inconsistent(format!("case `{}` has no LAMMPS deck", cfg.case.name())))?;
    let steps = cfg.steps.unwrap_or(cfg.case.default_steps());
    let tmp = std::env::temp_dir().join(format!("grainwave-bench-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).map_err(|e| io_error("cannot create", &tmp, e))?;
    let file = cfg.case.data_file().ok_or_else(|| CoreError::Inconsistent(format!("case `{}` has no packing file", cfg.case.name())))?;
    let data_gz = cfg.dir.join(file);
    let data = tmp.join(file.trim_end_matches(".gz"));
    if !data.exists() {
        let text = read_text(&data_gz).map_err(|e| CoreError::Inconsistent(e.to_string()))?;
        std::fs::write(&data, text).map_err(|e| io_error("cannot write", &data, e))?;
    }
    let mut cmd = if lmp.processes > 1 {
        let mut c = Command::new("mpirun");
        c.args(["--allow-run-as-root", "--mca", "btl", "self,tcp", "-np", &lmp.processes.to_string(), &lmp.executable]);
        c
    } else {
        Command::new(&lmp.executable)
    };
    cmd.current_dir(&tmp).args(["-log", "none", "-in"]).arg(cfg.dir.join(deck).canonicalize().map_err(|e| io_error("cannot find", &cfg.dir.join(deck), e))?);
    let shear = format!("{}", cfg.shear);
    let nsteps = steps.to_string();
    let data_name = data.file_name().unwrap().to_string_lossy().into_owned();
    let mut all_vars = vec![("data", data_name.as_str()), ("nsteps", nsteps.as_str()), ("shear", shear.as_str())];
    all_vars.extend(vars);
    for (k, v) in all_vars {
        cmd.args(["-var", k, v]);
    }
    let out = cmd.output().map_err(|e| io_error("cannot start", Path::new(&lmp.executable), e))?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    if !out.status.success() {
        return Err(CoreError::Inconsistent(format!("LAMMPS failed ({}):\n{}{}", out.status, text, String::from_utf8_lossy(&out.stderr))).into());
    }
    parse_lammps_output(&text, cfg, lmp.processes)
}

fn io_error(action: &str, path: &Path, error: std::io::Error) -> crate::ExperimentError {
    CoreError::Io { action: action.into(), path: path.display().to_string(), error }.into()
}

/// Reads "Loop time of T on P procs for S steps with N atoms", the last thermo line
/// (step ke c_zave ...), "Neighbor list builds = B" and the per-rank memory estimate.
fn parse_lammps_output(text: &str, cfg: &BenchConfig, procs: usize) -> Result<BenchResult> {
    let bad = |what: &str| CoreError::Inconsistent(format!("cannot find {what} in the LAMMPS output:\n{text}"));
    let loop_line = text.lines().find(|l| l.starts_with("Loop time of")).ok_or_else(|| bad("the loop time"))?;
    let w: Vec<&str> = loop_line.split_whitespace().collect();
    let num = |k: usize| w.get(k).and_then(|s| s.parse::<f64>().ok()).ok_or_else(|| bad("the loop time"));
    let (seconds, steps, atoms) = (num(3)?, num(8)? as u64, num(11)? as usize);
    let loop_at = text.find("Loop time of").unwrap_or(0);
    let thermo = text[..loop_at]
        .lines()
        .rev()
        .map(|l| l.split_whitespace().collect::<Vec<_>>())
        .find(|w| w.len() >= 3 && w[0].parse::<u64>().is_ok_and(|s| s == steps) && w[1].parse::<f64>().is_ok())
        .ok_or_else(|| bad("the last thermo line"))?;
    let builds = text
        .lines()
        .find_map(|l| l.strip_prefix("Neighbor list builds = ")?.trim().parse::<u64>().ok())
        .ok_or_else(|| bad("the neighbor list builds"))?;
    let memory_mib = text
        .lines()
        .find_map(|l| {
            let rest = l.split("allocation (min/avg/max) = ").nth(1)?;
            rest.split('|').nth(2)?.split_whitespace().next()?.parse::<f64>().ok()
        })
        .unwrap_or(0.0);
    Ok(BenchResult {
        code: "lammps".into(),
        case: cfg.case.name().into(),
        shear: cfg.shear,
        order: GrainOrder::File,
        grains: atoms,
        steps,
        workers: procs,
        loop_seconds: seconds,
        particle_steps_per_second: atoms as f64 * steps as f64 / seconds,
        contacts_per_grain: thermo[2].parse().unwrap_or(f64::NAN),
        contact_steps_per_second: thermo[2].parse::<f64>().map_or(f64::NAN, |z| 0.5 * z * atoms as f64 * steps as f64 / seconds),
        neighbor_rebuilds: builds,
        peak_memory_bytes: (memory_mib * procs as f64 * 1024.0 * 1024.0) as u64,
        kinetic_energy: thermo[1].parse().unwrap_or(f64::NAN),
        state_hash: String::new(),
    })
}

/// Writes results as a JSON array (atomically).
pub fn write_results(path: &Path, results: &[BenchResult]) -> Result<()> {
    grainwave_io::write_json_atomic(path, &results)?;
    Ok(())
}

/// Median of `values` (the mean of the middle two for an even count); NaN when empty.
pub fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_lammps_log() {
        let log = "\
Per MPI rank memory allocation (min/avg/max) = 24.02 | 24.02 | 24.02 Mbytes
Step KinEng c_zave v_phinow Press 
       0            0      5.90875         0.62    194.58159 
    2000    2.6993005      5.95275         0.62    183.21134 
Loop time of 15.2738 on 1 procs for 2000 steps with 32000 atoms

Neighbor list builds = 10
";
        let cfg = BenchConfig { case: BenchCase::Hertz3d, dir: PathBuf::new(), steps: None, shear: 0.0, order: GrainOrder::File, simd: None, replicate: [1, 1, 1] };
        let r = parse_lammps_output(log, &cfg, 1).unwrap();
        assert_eq!((r.grains, r.steps, r.neighbor_rebuilds), (32000, 2000, 10));
        assert_eq!(r.loop_seconds, 15.2738);
        assert_eq!(r.contacts_per_grain, 5.95275);
        assert_eq!(r.kinetic_energy, 2.6993005);
        assert!((r.particle_steps_per_second - 32000.0 * 2000.0 / 15.2738).abs() < 1e-6);
        assert_eq!(r.peak_memory_bytes, (24.02 * 1024.0 * 1024.0) as u64);
    }

    /// `slab2d` builds E3's slab itself (no packing file): after its warm-up the lattice carries
    /// its weight on the inclined contacts (4 per interior disk of the triangular lattice; the
    /// 6 of a fully closed lattice are the bound), the run is deterministic, and the
    /// per-contact throughput uses the contacts sampled along the run.
    #[test]
    fn the_slab_case_runs_the_loaded_lattice() {
        let cfg = BenchConfig { case: BenchCase::Slab2d, dir: PathBuf::from("/nonexistent"), steps: Some(250), shear: 0.0, order: GrainOrder::File, simd: None, replicate: [1, 1, 1] };
        let a = run_grainwave(&cfg).unwrap();
        assert_eq!((a.grains, a.steps), (128 * 128, 250));
        assert!(a.contacts_per_grain > 3.9 && a.contacts_per_grain < 6.0, "{}", a.contacts_per_grain);
        // samples at 100, 200 and 250 steps, each between the same bounds
        let per_grain = 2.0 * a.contact_steps_per_second / a.particle_steps_per_second;
        assert!(per_grain > 3.9 && per_grain < 6.0 && per_grain != a.contacts_per_grain, "{per_grain}");
        assert_eq!(run_grainwave(&cfg).unwrap().state_hash, a.state_hash);
    }

    /// Only the periodic cases can shear; the others say so before reading anything.
    #[test]
    fn shear_is_refused_outside_the_periodic_cases() {
        for case in [BenchCase::Walled2d, BenchCase::Piston2d, BenchCase::Slab2d] {
            let cfg = BenchConfig { case, dir: PathBuf::from("/nonexistent"), steps: Some(1), shear: 0.1, order: GrainOrder::File, simd: None, replicate: [1, 1, 1] };
            let e = run_grainwave(&cfg).unwrap_err().to_string();
            assert!(e.contains("--shear") && e.contains("0.1") && e.contains("hooke2d"), "{e}");
        }
        assert!(BenchCase::Slab2d.data_file().is_none() && BenchCase::Slab2d.lammps_deck().is_none());
    }

    #[test]
    fn replicating_a_periodic_packing_keeps_every_grain_s_neighbourhood() {
        use grainwave_core::dim::D2;
        use grainwave_core::grains::GrainKind;
        // three disks in a periodic 4 × 3 box, one straddling the x boundary through its image
        let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        for (x, y) in [(0.3, 0.5), (3.8, 0.6), (2.0, 2.2)] {
            g.push(DVec2::new(x, y), 0.5, 1.0, DVec2::new(x, -y));
        }
        let d = Domain::<D2>::new(DVec2::new(0.0, 0.0), DVec2::new(4.0, 3.0), [true, true, false]);
        let (t, big) = replicate(g.clone(), d.clone(), [3, 2, 1]).unwrap();
        assert_eq!(t.len(), 18);
        assert_eq!((big.hi.x, big.hi.y), (12.0, 6.0));
        assert_eq!(t.id, (0..18).collect::<Vec<u32>>());
        // every tiled grain's neighbours closer than 1.4 (under half the original box, so that at
        // most one image of a grain is that close) are at its original's distances: compare the
        // sorted distances
        let near = |grains: &Grains<D2>, dom: &Domain<D2>, a: usize| {
            let mut v: Vec<f64> = Vec::new();
            for b in 0..grains.len() {
                if b != a {
                    let r = dom.displacement(grains.pos[a], grains.pos[b]).norm();
                    if r < 1.4 {
                        v.push(r);
                    }
                }
            }
            v.sort_by(f64::total_cmp);
            v
        };
        for a in 0..t.len() {
            let o = a % 3;
            let mine = near(&t, &big, a);
            let orig = near(&g, &d, o);
            assert_eq!(mine.len(), orig.len(), "grain {a}");
            assert_eq!(mine.is_empty(), o == 2, "grain {a}: the pair across the x boundary is found");
            for (x, y) in mine.iter().zip(&orig) {
                assert!((x - y).abs() < 1e-12, "grain {a}: {x} vs {y}");
            }
            assert_eq!(t.vel[a], g.vel[o]);
            assert_eq!(t.radius[a], g.radius[o]);
        }
        // 1x1x1 changes nothing; bad factors are refused naming the option
        let (same, _) = replicate(g.clone(), d.clone(), [1, 1, 1]).unwrap();
        assert_eq!(same.pos, g.pos);
        for bad in [[0, 1, 1], [1, 1, 2]] {
            let e = replicate(g.clone(), d.clone(), bad).unwrap_err().to_string();
            assert!(e.contains("--replicate"), "{e}");
        }
        let open = Domain::<D2>::new(DVec2::new(0.0, 0.0), DVec2::new(4.0, 3.0), [true, false, false]);
        assert!(replicate(g.clone(), open, [1, 2, 1]).is_err());
        assert!(replicate(g, d, [10_000, 10_000, 1]).unwrap_err().to_string().contains("at most"));
    }

    #[test]
    fn medians() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }
}
