//! Preparation and biaxial test (SPEC §6.2), with checkpoints every Δε of strain.
//!
//! **Preparation.** The gas of [`super::model::build_gas`] is run in chunks of `check_every` steps
//! (at absolute step numbers, so that an interrupted and resumed preparation is bit-identical).
//! At each chunk boundary the piston forces are set to p* × the current wall lengths, and when the
//! power Σ F_i·v_i + Σ M a_w v_w of the forces is negative every velocity (pistons included) is set
//! to zero (quench). Equilibrium: every |F_i| and every piston's |M a_w| below `max_force` p* d̄.
//! With `remove_gravity`, the gravity is then switched off and the packing relaxes once more to the
//! same tolerance. Then friction is switched on (the tangential springs start at zero).
//!
//! **Loading.** The top wall moves at the constant speed ε̇ H₀ (down in compression, up in
//! extension), the right wall is a piston whose force p* × height is set before every step. Every
//! `sample_every` steps the strain is measured by regression on the grain displacements
//! ([`super::strain`]) and a row of the series is recorded; each time |ε_yy| passes a multiple of
//! `checkpoint_strain` a checkpoint is written to `checkpoints/ck-KKKKKK.gwck` and listed in
//! `checkpoints/index.csv`.

use super::config::{Direction, E2Config};
use super::model::{self, Drive, PistonLoad, Units, RIGHT, TOP};
use super::strain::{positions_by_id, StrainTracker};
use grainwave_study::{ExperimentError, Result};
use grainwave_study::protocol::RunContext;
use grainwave_core::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Content tag of an uncompressed strain checkpoint (the bincode of a [`StrainCheckpoint`]):
/// written by earlier versions, still read.
pub const CHECKPOINT_TAG: &str = "e2-strain-checkpoint";
/// Content tag of a compressed strain checkpoint: the payload is the raw-deflate stream of the
/// bincode of a [`StrainCheckpoint`] (see [`save_checkpoint`]).
pub const COMPRESSED_TAG: &str = "e2-strain-checkpoint-deflate";
/// Content tag of a reference checkpoint ([`CheckpointReference`]): no state, only where the
/// loading was; the state is regenerated from the full checkpoint before it.
pub const REFERENCE_TAG: &str = "e2-strain-checkpoint-reference";

/// A checkpoint kept as a reference (`loading.full_checkpoint_every` > 1): the state at `step`
/// is the full checkpoint `base` run on by the loading's own steps ([`Drive::step`]) up to
/// `step`. The loading between checkpoints changes nothing but the engine state, and the engine
/// is deterministic, so the regenerated state is the one the loading had, to the bit (tested).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointReference {
    /// Index k.
    pub index: u64,
    /// Index of the full checkpoint the state is regenerated from.
    pub base: u64,
    /// Engine step of this checkpoint.
    pub step: u64,
    /// Strain (ε_xx, ε_yy) at this checkpoint (from the loading's strain tracker, whose
    /// reference configurations the engine state does not hold).
    pub strain: (f64, f64),
}

/// What a checkpoint file holds.
#[derive(Clone, Debug)]
pub enum StoredCheckpoint {
    /// The complete state.
    Full(Box<StrainCheckpoint>),
    /// A reference to be regenerated from a full checkpoint.
    Reference(CheckpointReference),
}

/// Writes a strain checkpoint, compressed (raw deflate, level 6, of its bincode), atomically.
/// Positions, velocities and contact histories are float64 values with mostly random low
/// bytes, so the gain is modest (≈ 30 %; measured in docs/e2.md) but free: compressing a
/// 128 × 128 state takes a fraction of a second.
pub fn save_checkpoint(path: &Path, ck: &StrainCheckpoint) -> Result<()> {
    use std::io::Write;
    let raw = bincode::serialize(ck).map_err(|e| CoreError::Inconsistent(format!("cannot serialize checkpoint: {e}")))?;
    let mut enc = flate2::write::DeflateEncoder::new(Vec::with_capacity(raw.len() / 2), flate2::Compression::new(6));
    enc.write_all(&raw).and_then(|_| enc.flush()).map_err(|e| CoreError::Inconsistent(format!("cannot compress checkpoint: {e}")))?;
    let z = enc.finish().map_err(|e| CoreError::Inconsistent(format!("cannot compress checkpoint: {e}")))?;
    grainwave_core::checkpoint::save(path, COMPRESSED_TAG, &z)?;
    Ok(())
}

/// Writes a reference checkpoint atomically.
pub fn save_reference(path: &Path, r: &CheckpointReference) -> Result<()> {
    grainwave_core::checkpoint::save(path, REFERENCE_TAG, r)?;
    Ok(())
}

/// Decodes checkpoint file bytes of any of the three kinds (`path` names the file in errors).
pub fn decode_checkpoint(bytes: &[u8], path: &str) -> Result<StoredCheckpoint> {
    use grainwave_core::checkpoint::{decode, verify};
    let (tag, _) = verify(bytes, path)?;
    let bad = |reason: String| CoreError::Checkpoint { path: path.into(), reason };
    match tag.as_str() {
        CHECKPOINT_TAG => Ok(StoredCheckpoint::Full(Box::new(decode(bytes, CHECKPOINT_TAG, path)?))),
        REFERENCE_TAG => Ok(StoredCheckpoint::Reference(decode(bytes, REFERENCE_TAG, path)?)),
        COMPRESSED_TAG => {
            use bincode::Options;
            use std::io::Read;
            let z: Vec<u8> = decode(bytes, COMPRESSED_TAG, path)?;
            // deflate expands at most ≈ 1032:1; the bound keeps a corrupted stream from
            // allocating more than any valid one could
            let limit = 1100 * z.len() as u64 + 4096;
            let mut raw = Vec::new();
            flate2::read::DeflateDecoder::new(&z[..])
                .take(limit)
                .read_to_end(&mut raw)
                .map_err(|e| bad(format!("cannot decompress state: {e}")))?;
            let ck = bincode::DefaultOptions::new()
                .with_fixint_encoding()
                .allow_trailing_bytes()
                .with_limit(raw.len() as u64)
                .deserialize(&raw)
                .map_err(|e| bad(format!("cannot decode state: {e}")))?;
            Ok(StoredCheckpoint::Full(Box::new(ck)))
        }
        other => Err(bad(format!("holds `{other}`, expected an e2 strain checkpoint (`{COMPRESSED_TAG}`, `{REFERENCE_TAG}` or `{CHECKPOINT_TAG}`)")).into()),
    }
}

/// Reads a checkpoint file of any of the three kinds.
pub fn read_checkpoint(path: &Path) -> Result<StoredCheckpoint> {
    let bytes = grainwave_core::checkpoint::read_bytes(path)?;
    decode_checkpoint(&bytes, &path.display().to_string())
}

/// Reads a checkpoint file that must hold a complete state (a replay's `final.gwck`, or a full
/// strain checkpoint).
pub fn read_full_checkpoint(path: &Path) -> Result<StrainCheckpoint> {
    match read_checkpoint(path)? {
        StoredCheckpoint::Full(ck) => Ok(*ck),
        StoredCheckpoint::Reference(r) => Err(CoreError::Checkpoint {
            path: path.display().to_string(),
            reason: format!("is a reference to full checkpoint {}, not a complete state", r.base),
        }
        .into()),
    }
}

/// Regenerates the state of reference `r` from its full checkpoint `base`: the loading's steps
/// (the drive of the checkpoint, set before every step) from `base.sim.step` to `r.step`.
/// `interrupted` is asked every 1000 steps; None when it says yes.
pub fn regenerate(base: StrainCheckpoint, r: &CheckpointReference, interrupted: &mut dyn FnMut() -> bool) -> Result<Option<StrainCheckpoint>> {
    if base.index != r.base || base.sim.step > r.step {
        return Err(CoreError::Inconsistent(format!(
            "checkpoint {} refers to full checkpoint {} at a step ≤ {}, but that file holds checkpoint {} at step {}",
            r.index, r.base, r.step, base.index, base.sim.step
        ))
        .into());
    }
    let StrainCheckpoint { sim, drive, units, .. } = base;
    let mut sim = sim;
    while sim.step < r.step {
        if sim.step % 1000 == 0 && interrupted() {
            return Ok(None);
        }
        drive.step(&mut sim)?;
    }
    Ok(Some(StrainCheckpoint { index: r.index, sim, drive, strain: r.strain, units }))
}

/// A checkpoint of the biaxial test: everything a replay needs.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StrainCheckpoint {
    /// Index k (0: the state at the start of the loading).
    pub index: u64,
    /// The engine state.
    pub sim: Simulation<D2>,
    /// How the walls are driven.
    pub drive: Drive,
    /// Strain (ε_xx, ε_yy) at this checkpoint.
    pub strain: (f64, f64),
    /// Units of the run.
    pub units: Units,
}

/// Path of checkpoint `k` in output directory `dir`.
pub fn checkpoint_path(dir: &Path, k: u64) -> std::path::PathBuf {
    dir.join("checkpoints").join(format!("ck-{k:06}.gwck"))
}

/// One line of `checkpoints/index.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointEntry {
    /// Index k.
    pub index: u64,
    /// Engine step.
    pub step: u64,
    /// Time since the start of the loading [t*].
    pub time: f64,
    /// ε_yy (compression positive).
    pub strain_yy: f64,
    /// ε_xx (compression positive).
    pub strain_xx: f64,
    /// σ_yy [p*].
    pub stress_yy: f64,
    /// σ_xx [p*].
    pub stress_xx: f64,
    /// Sliding contacts M_s.
    pub sliding: u64,
    /// A full checkpoint (false: a [`CheckpointReference`]). States saved by versions that
    /// wrote only full checkpoints read as full.
    #[serde(default = "full_default")]
    pub full: bool,
}

fn full_default() -> bool {
    true
}

/// Columns of the loading series.
pub const SERIES_COLUMNS: [&str; 9] = ["time", "strain_yy", "strain_xx", "stress_yy", "stress_xx", "sliding", "contacts", "kinetic_energy", "step"];

/// The state of the loading.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Loading {
    /// Strain measurement.
    pub tracker: StrainTracker,
    /// Wall drive.
    pub drive: Drive,
    /// Simulated time at the start of the loading.
    pub start_time: f64,
    /// Next checkpoint index.
    pub next_checkpoint: u64,
    /// Rows of the series (see [`SERIES_COLUMNS`]).
    pub series: Vec<[f64; 9]>,
    /// Checkpoints written.
    pub checkpoints: Vec<CheckpointEntry>,
    /// Finished.
    pub done: bool,
    /// Wall-clock seconds spent, summed over resumes [s].
    pub seconds: f64,
}

/// How the preparation went.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PreparationInfo {
    /// Reached equilibrium.
    pub converged: bool,
    /// Steps.
    pub steps: u64,
    /// Simulated time [t*].
    pub time: f64,
    /// Quenches.
    pub quenches: u64,
    /// Largest |F_i| at the end [p* d̄].
    pub max_force: f64,
    /// Largest piston |M a_w| at the end [p* d̄].
    pub max_piston_force: f64,
    /// Packing fraction at the end.
    pub packing_fraction: f64,
    /// Wall-clock seconds, summed over resumes [s].
    pub seconds: f64,
}

fn max_grain_force(sim: &Simulation<D2>) -> f64 {
    sim.grains.force.iter().map(|f| f.length()).fold(0.0, f64::max)
}

fn max_piston_force(sim: &Simulation<D2>) -> f64 {
    sim.domain.walls.iter().filter_map(|w| if let WallMotion::Piston { mass, .. } = w.motion { Some((mass * w.accel).abs()) } else { None }).fold(0.0, f64::max)
}

/// Packing fraction Σπ R²/(W H).
pub fn packing_fraction(sim: &Simulation<D2>) -> f64 {
    let (w, h) = model::box_size(sim);
    sim.grains.radius.iter().map(|r| std::f64::consts::PI * r * r).sum::<f64>() / (w * h)
}

/// Relaxes the gas under the pistons (see the module docs). Returns false when interrupted.
pub fn prepare(
    sim: &mut Simulation<D2>,
    info: &mut PreparationInfo,
    cfg: &E2Config,
    ctx: &mut RunContext<'_>,
    save: &mut dyn FnMut(&mut RunContext<'_>, &Simulation<D2>, &PreparationInfo) -> Result<()>,
) -> Result<bool> {
    let pc = &cfg.preparation;
    let drive = Drive { pressure: 1.0, pistons: vec![(RIGHT, PistonLoad::Height), (TOP, PistonLoad::Width)], pulse_wall: RIGHT, pulse: None };
    let t_star = sim.grains.total_mass().sqrt();
    let started = std::time::Instant::now();
    let base = info.seconds;
    let mut last_save = std::time::Instant::now();
    let mut last_report = 0u64;
    ctx.reporter.stage("preparation", None);
    loop {
        if sim.step % pc.check_every == 0 {
            drive.set_forces(sim);
            sim.refresh_forces()?;
            info.steps = sim.step;
            info.time = sim.time / t_star;
            info.max_force = max_grain_force(sim);
            info.max_piston_force = max_piston_force(sim);
            info.packing_fraction = packing_fraction(sim);
            info.seconds = base + started.elapsed().as_secs_f64();
            if info.max_force < pc.max_force && info.max_piston_force < pc.max_force {
                // stiff walls while the pistons compress the gas; then the bottom, left and top
                // walls become absorbing (SPEC §6.7) and the packing relaxes into them before
                // the loading starts
                if model::make_walls_absorbing(sim, &cfg.material) {
                    // a full refresh (neighbour lists and forces), as a reloaded checkpoint does,
                    // so that a run resumed after this point continues with the same bits
                    sim.refresh()?;
                    ctx.log(&format!(
                        "preparation: converged with stiff walls at step {} ({:.3} t*); bottom, left and top walls now absorbing",
                        sim.step, info.time
                    ));
                    continue;
                }
                if pc.remove_gravity && sim.gravity != glam::DVec2::ZERO {
                    // the gravity-free variant: relax once more, without gravity, to the same
                    // tolerance (the state carries its gravity, so a resumed run continues here)
                    sim.gravity = glam::DVec2::ZERO;
                    sim.refresh()?;
                    ctx.log(&format!("preparation: converged under gravity at step {} ({:.3} t*); gravity now off (`preparation.remove_gravity`)", sim.step, info.time));
                    continue;
                }
                info.converged = true;
                return Ok(true);
            }
            if sim.step >= last_report + 20 * pc.check_every {
                last_report = sim.step;
                ctx.reporter.progress(&sim.progress(&StopCriteria::default()));
                ctx.log_quiet(&format!(
                    "preparation: t = {:.3} t*, Φ = {:.4}, max |F| = {:.3e}, piston {:.3e}, {} quenches",
                    info.time, info.packing_fraction, info.max_force, info.max_piston_force, info.quenches
                ));
            }
        }
        if ctx.interrupted() {
            return Ok(false);
        }
        if sim.time > pc.max_time * t_star {
            // found only by running: a failure of the run (exit 1), not bad input
            return Err(grainwave_study::ExperimentError::NotReached(format!(
                "the preparation reached no equilibrium within {} t* (`preparation.max_time`): max |F| = {:.3e}, piston {:.3e} (tolerance `preparation.max_force` = {:.1e} p* d̄)",
                pc.max_time, info.max_force, info.max_piston_force, pc.max_force
            )));
        }
        if last_save.elapsed().as_secs_f64() >= cfg.output.save_every {
            save(ctx, sim, info)?;
            last_save = std::time::Instant::now();
        }
        // to the next multiple of `check_every`, looking at the interrupt flag on the way
        // (resuming runs on to the same multiple)
        if !sim.steps_until(pc.check_every - sim.step % pc.check_every, || ctx.interrupted())? {
            return Ok(false);
        }
        let g = &sim.grains;
        let mut power = grainwave_core::util::det_sum(g.len(), |k| g.force[k].dot(g.vel[k]) + g.torque[k] * g.omega[k]);
        for w in &sim.domain.walls {
            if let WallMotion::Piston { mass, .. } = w.motion {
                power += mass * w.accel * w.speed;
            }
        }
        if power < 0.0 {
            info.quenches += 1;
            sim.grains.vel.iter_mut().for_each(|v| *v = glam::DVec2::ZERO);
            sim.grains.omega.iter_mut().for_each(|w| *w = 0.0);
            sim.domain.walls.iter_mut().for_each(|w| w.speed = 0.0);
        }
    }
}

/// Switches friction on and sets up the loading: the top wall moves at ε̇ H₀, the right wall
/// is a piston under p* × height.
pub fn start_loading(sim: &mut Simulation<D2>, cfg: &E2Config) -> Result<Loading> {
    let acoustic_time = model::Units::of(sim, 1.0, cfg.material.normal_stiffness).acoustic_time;
    sim.law = model::grain_law(&cfg.material, cfg.material.friction, acoustic_time);
    let (_, h) = model::box_size(sim);
    let t_star = sim.grains.total_mass().sqrt();
    let speed = cfg.loading.strain_rate / t_star * h * if cfg.loading.direction == Direction::Compression { 1.0 } else { -1.0 };
    sim.domain.walls[TOP].motion = WallMotion::Velocity { speed: TimeFunction::constant(speed) };
    sim.domain.walls[TOP].speed = speed;
    let drive = Drive::biaxial(1.0);
    drive.set_forces(sim);
    sim.refresh_forces()?;
    Ok(Loading {
        tracker: StrainTracker::new(positions_by_id(&sim.grains), cfg.loading.reference_strain),
        drive,
        start_time: sim.time,
        next_checkpoint: 0,
        series: Vec::new(),
        checkpoints: Vec::new(),
        done: false,
        seconds: 0.0,
    })
}

fn write_index(dir: &Path, entries: &[CheckpointEntry]) -> Result<()> {
    // grainwave-io's table writer: numbers in the shortest form that reads back to the same bits
    let mut t = grainwave_io::CsvTable::new();
    t.push_u64("index", entries.iter().map(|e| e.index))?;
    t.push_u64("step", entries.iter().map(|e| e.step))?;
    t.push_f64("time", entries.iter().map(|e| e.time))?;
    t.push_f64("strain_yy", entries.iter().map(|e| e.strain_yy))?;
    t.push_f64("strain_xx", entries.iter().map(|e| e.strain_xx))?;
    t.push_f64("stress_yy", entries.iter().map(|e| e.stress_yy))?;
    t.push_f64("stress_xx", entries.iter().map(|e| e.stress_xx))?;
    t.push_u64("sliding", entries.iter().map(|e| e.sliding))?;
    t.push_text("file", entries.iter().map(|e| format!("checkpoints/ck-{:06}.gwck", e.index)))?;
    t.push_text("kind", entries.iter().map(|e| if e.full { "full" } else { "reference" }))?;
    grainwave_io::write_csv_atomic(&dir.join("checkpoints").join("index.csv"), &t)?;
    Ok(())
}

/// Runs the loading until `final_strain` (see the module docs). Returns false when interrupted.
pub fn load(
    sim: &mut Simulation<D2>,
    loading: &mut Loading,
    units: &Units,
    cfg: &E2Config,
    ctx: &mut RunContext<'_>,
    save: &mut dyn FnMut(&mut RunContext<'_>, &Simulation<D2>, &Loading) -> Result<()>,
) -> Result<bool> {
    let lc = &cfg.loading;
    let dir = ctx.out_dir().to_path_buf();
    std::fs::create_dir_all(dir.join("checkpoints")).map_err(|e| CoreError::Io {
        action: "cannot create".into(),
        path: dir.join("checkpoints").display().to_string(),
        error: e,
    })?;
    let started = std::time::Instant::now();
    let base = loading.seconds;
    let mut last_save = std::time::Instant::now();
    ctx.reporter.stage("loading", None);
    let energy_unit = units.pressure * units.length * units.length;
    loop {
        {
            if (sim.step - loading.series.first().map(|r| r[8] as u64).unwrap_or(sim.step)) % lc.sample_every == 0 {
                // interruption and periodic saves come before the sample: a saved state is one
                // whose sample is still to be taken, so a resumed run takes it exactly once (a
                // state saved after its sample was sampled again on resume: a duplicated row of
                // the series, and a second strain update)
                if ctx.interrupted() {
                    loading.seconds = base + started.elapsed().as_secs_f64();
                    return Ok(false);
                }
                if last_save.elapsed().as_secs_f64() >= cfg.output.save_every {
                    loading.seconds = base + started.elapsed().as_secs_f64();
                    save(ctx, sim, loading)?;
                    last_save = std::time::Instant::now();
                }
                let (exx, eyy) = loading.tracker.update(&positions_by_id(&sim.grains));
                let (sxx, syy) = model::wall_stresses(sim);
                let row = [
                    (sim.time - loading.start_time) / units.time,
                    eyy,
                    exx,
                    syy / units.pressure,
                    sxx / units.pressure,
                    sim.counters.sliding as f64,
                    sim.counters.contacts as f64,
                    sim.kinetic_energy() / energy_unit,
                    sim.step as f64,
                ];
                loading.series.push(row);
                let due = lc.checkpoint_strain > 0.0 && (loading.next_checkpoint == 0 || eyy.abs() >= loading.next_checkpoint as f64 * lc.checkpoint_strain);
                if due {
                    let k = loading.next_checkpoint;
                    // full checkpoints at k = 0, every `full_checkpoint_every`-th index and at the
                    // end of the loading (the states replays start from); references in between
                    let last = eyy.abs() >= lc.final_strain;
                    let every = lc.full_checkpoint_every.max(1);
                    let base = loading.checkpoints.iter().rev().find(|e| e.full).map(|e| e.index);
                    let full = k == 0 || last || base.is_none() || base.is_some_and(|b| k >= b + every);
                    if full {
                        let ck = StrainCheckpoint { index: k, sim: sim.clone(), drive: loading.drive.clone(), strain: (exx, eyy), units: *units };
                        save_checkpoint(&checkpoint_path(&dir, k), &ck)?;
                    } else {
                        let r = CheckpointReference { index: k, base: base.expect("a full checkpoint before"), step: sim.step, strain: (exx, eyy) };
                        save_reference(&checkpoint_path(&dir, k), &r)?;
                    }
                    loading.checkpoints.push(CheckpointEntry {
                        index: k,
                        step: sim.step,
                        time: row[0],
                        strain_yy: eyy,
                        strain_xx: exx,
                        stress_yy: row[3],
                        stress_xx: row[4],
                        sliding: sim.counters.sliding,
                        full,
                    });
                    write_index(&dir, &loading.checkpoints)?;
                    loading.next_checkpoint = (eyy.abs() / lc.checkpoint_strain).floor() as u64 + 1;
                }
                if eyy.abs() >= lc.final_strain {
                    loading.done = true;
                    loading.seconds = base + started.elapsed().as_secs_f64();
                    return Ok(true);
                }
                let every = (ctx.report_every / lc.sample_every).max(1) as usize;
                if loading.series.len() % every == 0 {
                    let mut p = sim.progress(&StopCriteria::default());
                    p.fraction_of_limit = (eyy.abs() / lc.final_strain).min(1.0);
                    ctx.reporter.progress(&p);
                }
            }
        }
        loading.drive.step(sim)?;
    }
}

/// Checkpoint indices present in `dir/checkpoints`.
pub fn checkpoint_indices(dir: &Path) -> Vec<u64> {
    let mut v: Vec<u64> = std::fs::read_dir(dir.join("checkpoints"))
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .filter_map(|e| {
                    let n = e.file_name().to_string_lossy().to_string();
                    n.strip_prefix("ck-").and_then(|s| s.strip_suffix(".gwck")).and_then(|s| s.parse().ok())
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// The checkpoint that index `k` (−1: the last) names among the indices `have` (sorted): `k`
/// itself or, when `k` was not written, the last index before it. Checkpoint k is the state at
/// the first sample with |ε_yy| ≥ k × `checkpoint_strain`; the loading writes at most one
/// checkpoint per sample, under the first index not written yet, so a sample that passes several
/// multiples at once (a `checkpoint_strain` smaller than the strain of one sample) writes index j
/// and skips j + 1 … k: the state of index j is then the first at or beyond k ×
/// `checkpoint_strain`. `check` keeps k × `checkpoint_strain` within the loading's
/// `final_strain`, so k is always passed. None when no index is at or before `k`.
pub fn resolve_index(have: &[u64], k: i64) -> Option<u64> {
    if k < 0 {
        have.last().copied()
    } else {
        have.iter().copied().take_while(|&i| i <= k as u64).last()
    }
}

/// Loads checkpoint `k` (−1: the last) of the run in `source`; a reference checkpoint is
/// regenerated from its full checkpoint ([`regenerate`]).
pub fn load_checkpoint(source: &Path, k: i64) -> Result<StrainCheckpoint> {
    load_checkpoint_with(source, k, &mut |_| {}, &mut || false).map(|c| c.expect("not interrupted"))
}

/// [`load_checkpoint`], telling `log` when it regenerates a state and asking `interrupted`
/// every 1000 steps of the regeneration (None: interrupted).
pub fn load_checkpoint_with(source: &Path, k: i64, log: &mut dyn FnMut(&str), interrupted: &mut dyn FnMut() -> bool) -> Result<Option<StrainCheckpoint>> {
    let have = checkpoint_indices(source);
    let Some(index) = resolve_index(&have, k) else {
        return Err(ExperimentError::Resume {
            path: source.to_path_buf(),
            reason: format!("no checkpoint {k} in {}/checkpoints (present: {:?})", source.display(), have),
        });
    };
    if k >= 0 && index != k as u64 {
        log(&format!(
            "checkpoint {k} was passed within the sample that wrote checkpoint {index} (a sample of the loading spans several multiples of `loading.checkpoint_strain`): replaying that state, the first at or beyond {k} × checkpoint_strain"
        ));
    }
    match read_checkpoint(&checkpoint_path(source, index))? {
        StoredCheckpoint::Full(ck) => Ok(Some(*ck)),
        StoredCheckpoint::Reference(r) => {
            let base = read_full_checkpoint(&checkpoint_path(source, r.base))?;
            log(&format!(
                "checkpoint {index} is a reference: regenerating its state from full checkpoint {} ({} steps of the loading)",
                r.base,
                r.step.saturating_sub(base.sim.step)
            ));
            regenerate(base, &r, interrupted)
        }
    }
}
