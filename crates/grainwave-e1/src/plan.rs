//! Validation of an `e1` config into a plan: the study, its groups (one per size and pressure, each
//! with its time grid) and the sample tasks.

use super::config::*;
use grainwave_study::config::{positive, ConfigError, ConfigSource};
use grainwave_core::util::Fnv64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// What is studied.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum StudyKind {
    /// Disordered packings by piston compression.
    Packing,
    /// Triangular lattices.
    Lattice,
    /// The 1D chain.
    Chain,
}

impl StudyKind {
    /// Name used in outputs.
    pub fn name(self) -> &'static str {
        match self {
            StudyKind::Packing => "packing",
            StudyKind::Lattice => "lattice",
            StudyKind::Chain => "chain",
        }
    }
}

/// One size at one pressure: a set of samples analysed together.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Group {
    /// Index in the plan.
    pub index: usize,
    /// Directory-safe name, e.g. `p1e-4_L25`, `p1e-4_N600`, `p1e-4_r20`, `N50`.
    pub name: String,
    /// Pressure p (none for chains) [force/area].
    pub pressure: Option<f64>,
    /// Index of the pressure in the config's list.
    pub pressure_index: usize,
    /// Index of the size in the config's list.
    pub size_index: usize,
    /// The size as given: target height, grain count, rows or chain length.
    pub size_label: String,
    /// Grains of each sample.
    pub grains: usize,
    /// Lattice rows (lattices only).
    pub rows: usize,
    /// Height estimated before preparation (sets the default time grid) [length].
    pub estimated_height: f64,
    /// Times of the signal grid [time].
    pub times: Vec<f64>,
}

/// A sample of a group.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Task {
    /// Group index.
    pub group: usize,
    /// Sample index k (0 … N − 1).
    pub sample: usize,
    /// Seed s₀ + k.
    pub seed: u64,
}

/// A validated `e1` config: what a run does, carried by its state ([`crate::E1State`]).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Plan {
    /// The config with computed defaults filled in (stored as its TOML text in checkpoints).
    #[serde(with = "grainwave_study::config::toml_text")]
    pub config: E1Config,
    /// What is studied.
    pub kind: StudyKind,
    /// Dimension of the grains' centres (2 or 3).
    pub dimension: usize,
    /// Periodic width L_x (packings) [length].
    pub width: f64,
    /// Diameter spread a (packings) or polydispersity (lattices, chains).
    pub spread: f64,
    /// Friction μ.
    pub friction: f64,
    /// Poisson's ratio ν.
    pub poisson: f64,
    /// Groups, pressure-major within each size: sizes × pressures.
    pub groups: Vec<Group>,
    /// Tasks, sample-major (all groups of sample 0 first), so that a partial run holds complete
    /// samples.
    pub tasks: Vec<Task>,
}

/// Speed of a chain of mean grains whose contacts carry the force p d̄² (E1 units, E* = 1, ρ = 1):
/// Hertz between two mean spheres (E*_ij = ½, R* = ¼) gives F = ξ^{3/2}/3, k = ½(3p)^{1/3}, and
/// c_H = d̄ √(k/m̄) = √(3/π) (3p)^{1/6}. Sets the default time grid.
pub fn hertz_chain_speed(pressure: f64) -> f64 {
    (3.0 / PI).sqrt() * (3.0 * pressure).powf(1.0 / 6.0)
}

fn err(src: &ConfigSource, key: &str, msg: impl Into<String>) -> ConfigError {
    src.error_at_key(key, msg)
}

/// Refuses a `preparation.max_acceleration` that the gas meets before it is compressed.
///
/// The preparation stops at the first check (every `check_every` steps, step 0 included) where
/// the largest grain acceleration and the piston's are below the tolerance. At step 0 the grains
/// of the gas do not touch (zero force) and the piston is pushed by F alone: its acceleration is
/// a₀ = F/M. A tolerance above a₀ is met at step 0, so the "packing" is the loose gas with no
/// contact network, and every sample of the group fails afterwards. a₀ depends on the sampled
/// diameters (mean d̄ₛ, each in [1 − a, 1 + a]); its upper bound, for the smallest pressure p:
///
/// * default piston (one layer of mean grains: F = p L d̄ₛ and M = (L/d̄ₛ) m̄ in 2D, F = p L² and
///   M = (L²/d̄ₛ²) m̄ in 3D; `sphere2d` grains are spheres too, so m̄ = π⟨d³⟩ₛ/6 ≥ π d̄ₛ³/6 by
///   Jensen in both): a₀ = p d̄ₛ²/m̄ ≤ 6p/(π d̄ₛ) ≤ 6p/(π(1 − a));
/// * given `piston_mass` M: a₀ = p L d̄ₛ/M ≤ p L (1 + a)/M (2D), = p L²/M (3D).
///
/// A tolerance above this bound certainly stops the preparation at step 0 for the groups at
/// pressure p, and is refused; a tolerance just below it may still work for some samples and is
/// left to the run. Published protocols use tolerances many orders of magnitude smaller (default
/// 10⁻¹⁰ against p ≥ 10⁻⁶).
fn max_acceleration_bound(src: &ConfigSource, cfg: &E1Config, dimension: usize, width: f64, spread: f64, pressures: &[f64]) -> Result<(), ConfigError> {
    let pc = &cfg.preparation;
    let p = pressures.iter().cloned().fold(f64::INFINITY, f64::min);
    if !(p.is_finite() && p > 0.0) || !pc.max_acceleration.is_finite() {
        return Ok(());
    }
    let bound = match (pc.piston_mass, dimension) {
        (None, _) => 6.0 * p / (PI * (1.0 - spread)),
        (Some(m), 2) => p * width * (1.0 + spread) / m,
        (Some(m), _) => p * width * width / m,
    };
    // (the bound is exact for equal grains: allow for its rounding)
    if pc.max_acceleration > bound * (1.0 + 1e-12) {
        return Err(err(
            src,
            "preparation.max_acceleration",
            format!(
                "{} (allowed: below {bound:.4e}, the acceleration of the piston under the smallest pressure {p:.4e} before any contact; a larger tolerance is met by the uncompressed gas at step 0, and every sample would fail)",
                pc.max_acceleration
            ),
        ));
    }
    Ok(())
}

fn pressures(src: &ConfigSource, key: &str, p: &[f64]) -> Result<(), ConfigError> {
    if p.is_empty() {
        return Err(err(src, key, "empty (allowed: at least one pressure)"));
    }
    for (k, &x) in p.iter().enumerate() {
        positive(src, &format!("{key}[{k}]"), x)?;
        // pressures are in units of the contact modulus E*: a Hertz contact needs p ≪ E*, and
        // p ≥ E* would overlap grains by more than their size (every sample would fail)
        if x >= 1.0 {
            return Err(err(src, &format!("{key}[{k}]"), format!("{x} (allowed: 0 < p < 1 in units of E*; Hertz contacts need p ≪ E*)")));
        }
        if p[..k].contains(&x) {
            return Err(err(src, &format!("{key}[{k}]"), format!("{x} appears twice")));
        }
    }
    Ok(())
}

/// `1e-4` → `1e-4`, `2.5e-5` → `2.5e-5`.
pub fn pressure_label(p: f64) -> String {
    format!("{p:e}")
}

fn number_label(x: f64) -> String {
    if x.fract() == 0.0 && x.abs() < 1e9 {
        format!("{}", x as i64)
    } else {
        format!("{x}")
    }
}

/// Validates `cfg` into a plan.
pub fn plan(src: &ConfigSource, cfg: &E1Config) -> Result<Plan, ConfigError> {
    if cfg.experiment != "e1" {
        return Err(err(src, "experiment", format!("this protocol is `e1`, not `{}`", cfg.experiment)));
    }
    if cfg.samples == 0 {
        return Err(err(src, "samples", "0 (allowed: at least 1)"));
    }
    if cfg.parallel_samples == Some(0) {
        return Err(err(src, "parallel_samples", "0 (allowed: at least 1)"));
    }
    let given = [cfg.packing.is_some(), cfg.lattice.is_some(), cfg.chain.is_some()].iter().filter(|&&b| b).count();
    if given != 1 {
        return Err(err(
            src,
            "experiment",
            format!("give exactly one of `[packing]`, `[lattice]` and `[chain]` (the file has {given})"),
        ));
    }
    let mut config = cfg.clone();
    let pc = &cfg.preparation;
    // below 1e-3 the gas box is a thousand times the packing's height (and at 5e-324 infinite):
    // the piston would take longer to close it than any preparation limit allows
    if !(pc.gas_fraction >= 1e-3 && pc.gas_fraction < 0.6) {
        return Err(err(src, "preparation.gas_fraction", format!("{} (allowed: a fraction in [0.001, 0.6))", pc.gas_fraction)));
    }
    if let Some(v) = pc.initial_speed {
        if !(v.is_finite() && v >= 0.0) {
            return Err(err(src, "preparation.initial_speed", format!("{v} (allowed: a finite speed ≥ 0)")));
        }
    }
    if !(0.0..=1.0).contains(&pc.damping) {
        return Err(err(src, "preparation.damping", format!("{} (allowed: a fraction of critical in [0, 1])", pc.damping)));
    }
    if let Some(m) = pc.piston_mass {
        positive(src, "preparation.piston_mass", m)?;
    }
    positive(src, "preparation.max_acceleration", pc.max_acceleration)?;
    if pc.check_every == 0 {
        return Err(err(src, "preparation.check_every", "0 (allowed: at least 1)"));
    }
    if !(pc.dt_fraction > 0.0 && pc.dt_fraction <= 0.2) {
        return Err(err(src, "preparation.dt_fraction", format!("{} (allowed: a fraction in (0, 0.2])", pc.dt_fraction)));
    }
    // measured: a tail at 0.2 of the contact period (factor 4) left 1 packing of 20 at p = 1e-6
    // in a slow cycle that never converged; 0.15 (factor 3) converged for all
    if !(pc.tail_dt_factor >= 1.0 && pc.dt_fraction * pc.tail_dt_factor <= 0.15 + 1e-12) {
        return Err(err(
            src,
            "preparation.tail_dt_factor",
            format!("{} (allowed: a factor ≥ 1 with dt_fraction × factor ≤ 0.15, i.e. at most {} with dt_fraction = {})", pc.tail_dt_factor, (0.15 / pc.dt_fraction * 1e9).round() / 1e9, pc.dt_fraction),
        ));
    }
    if !(pc.tail_kinetic_energy.is_finite() && pc.tail_kinetic_energy >= 0.0) {
        return Err(err(src, "preparation.tail_kinetic_energy", format!("{} (allowed: a finite energy ≥ 0, in units of p d̄³)", pc.tail_kinetic_energy)));
    }
    if !(0.0..=1.0).contains(&pc.tail_sliding_fraction) {
        return Err(err(src, "preparation.tail_sliding_fraction", format!("{} (allowed: a fraction in [0, 1])", pc.tail_sliding_fraction)));
    }
    if let Some(x) = pc.expected_overlap {
        if !(x > 0.0 && x < 0.5) {
            return Err(err(src, "preparation.expected_overlap", format!("{x} (allowed: a fraction in (0, 0.5))")));
        }
    }
    let ch = &cfg.characterization;
    if !(ch.boundary_layer.is_finite() && ch.boundary_layer >= 0.0) {
        return Err(err(src, "characterization.boundary_layer", format!("{} (allowed: a length ≥ 0)", ch.boundary_layer)));
    }
    if ch.histogram_bins == 0 {
        return Err(err(src, "characterization.histogram_bins", "0 (allowed: at least 1)"));
    }
    // the output stage allocates one count per bin (several histograms per group)
    grainwave_study::limits::check(src, "characterization.histogram_bins", "histogram bins", ch.histogram_bins as f64, grainwave_study::limits::MAX_POINTS, f64::INFINITY, 64.0)?;
    let pu = &cfg.pulse;
    if pu.prestress == PreStressName::Full && pu.method == PulseMethod::Modal {
        return Err(err(src, "pulse.prestress", "`full` makes D non-symmetric, which the modal sum cannot use: set `pulse.method = \"direct\"`"));
    }
    if let Some(t) = pu.end_time {
        positive(src, "pulse.end_time", t)?;
    }
    positive(src, "pulse.transits", pu.transits)?;
    if pu.time_samples < 3 {
        return Err(err(src, "pulse.time_samples", format!("{} (allowed: at least 3)", pu.time_samples)));
    }
    if !(pu.edge_fraction > 0.0 && pu.edge_fraction < 1.0) {
        return Err(err(src, "pulse.edge_fraction", format!("{} (allowed: a fraction in (0, 1))", pu.edge_fraction)));
    }
    let threshold = pu.peak_threshold.unwrap_or(grainwave_analysis::signal::DEFAULT_PEAK_THRESHOLD);
    if !(threshold > 0.0 && threshold <= 1.0) {
        return Err(err(src, "pulse.peak_threshold", format!("{threshold} (allowed: a fraction in (0, 1])")));
    }
    config.pulse.peak_threshold = Some(threshold);
    if pu.bootstrap == 1 {
        return Err(err(src, "pulse.bootstrap", "1 (allowed: 0 for no intervals, or at least 2 replicates)"));
    }
    if !(pu.exponent_resolution > 0.0 && pu.exponent_resolution.is_finite()) {
        return Err(err(src, "pulse.exponent_resolution", format!("{} (allowed: a positive fraction)", pu.exponent_resolution)));
    }
    for (k, &f) in pu.field_times.iter().enumerate() {
        if !(f.is_finite() && f >= 0.0) {
            return Err(err(src, &format!("pulse.field_times[{k}]"), format!("{f} (allowed: a fraction ≥ 0 of the first-peak time)")));
        }
    }
    if let Some(d) = &cfg.damped {
        if d.damping_fractions.is_empty() {
            return Err(err(src, "damped.damping_fractions", "empty (allowed: at least one ζ)"));
        }
        for (k, &z) in d.damping_fractions.iter().enumerate() {
            if !(0.0..=1.0).contains(&z) {
                return Err(err(src, &format!("damped.damping_fractions[{k}]"), format!("{z} (allowed: ζ in [0, 1])")));
            }
        }
        positive(src, "damped.amplitude", d.amplitude)?;
        if cfg.chain.is_some() {
            return Err(err(src, "damped", "damped MD runs need Hertz–Mindlin packings or lattices, not the spring chain"));
        }
        if !pu.enabled {
            return Err(err(src, "damped", "damped MD runs are compared with the linear pulse: keep `pulse.enabled = true`"));
        }
    }
    if !(cfg.output.save_every_seconds.is_finite() && cfg.output.save_every_seconds > 0.0) {
        return Err(err(src, "output.save_every_seconds", format!("{} (allowed: a number of seconds > 0)", cfg.output.save_every_seconds)));
    }

    let grid = |end: f64| -> Vec<f64> {
        let n = pu.time_samples;
        (0..n).map(|k| end * k as f64 / (n - 1) as f64).collect()
    };
    let mut groups = Vec::new();
    let (kind, dimension, width, spread, friction, poisson);
    if let Some(p) = &cfg.packing {
        kind = StudyKind::Packing;
        pressures(src, "packing.pressures", &p.pressures)?;
        dimension = match p.kind {
            PackingKind::Sphere2d => 2,
            PackingKind::Sphere => 3,
        };
        width = p.width.unwrap_or(if dimension == 2 { 24.0 } else { 8.0 });
        positive(src, "packing.width", width)?;
        spread = p.spread.unwrap_or(if dimension == 2 { 0.2 } else { 0.0 });
        if !(0.0..0.5).contains(&spread) {
            return Err(err(src, "packing.spread", format!("{spread} (allowed: a relative half-width in [0, 0.5))")));
        }
        if width < 2.0 * (1.0 + spread) + 0.5 {
            return Err(err(src, "packing.width", format!("{width} (allowed: more than twice the largest diameter plus the neighbour-list skin)")));
        }
        friction = p.friction;
        poisson = p.poisson;
        let fraction = p.estimated_fraction.unwrap_or(if dimension == 2 { 0.82 } else { 0.62 });
        if !(fraction > 0.0 && fraction < 1.0) {
            return Err(err(src, "packing.estimated_fraction", format!("{fraction} (allowed: a fraction in (0, 1))")));
        }
        max_acceleration_bound(src, cfg, dimension, width, spread, &p.pressures)?;
        // mean grain measure for diameters uniform in [1 − a, 1 + a]: ⟨d²⟩ = 1 + a²/3, ⟨d³⟩ = 1 + a²
        let cross = if dimension == 2 { width } else { width * width };
        let grain_measure = if dimension == 2 { PI / 4.0 * (1.0 + spread * spread / 3.0) } else { PI / 6.0 * (1.0 + spread * spread) };
        let sizes: Vec<(String, usize, f64)> = match (&p.heights, &p.grains) {
            (Some(h), None) => {
                if h.is_empty() {
                    return Err(err(src, "packing.heights", "empty (allowed: at least one height)"));
                }
                let mut v = Vec::new();
                for (k, &l) in h.iter().enumerate() {
                    if !(l.is_finite() && l >= 2.0) {
                        return Err(err(src, &format!("packing.heights[{k}]"), format!("{l} (allowed: a height ≥ 2 diameters)")));
                    }
                    if h[..k].contains(&l) {
                        return Err(err(src, &format!("packing.heights[{k}]"), format!("{l} appears twice")));
                    }
                    let n = (fraction * cross * l / grain_measure).round() as usize;
                    v.push((format!("L{}", number_label(l)), n.max(1), l));
                }
                v
            }
            (None, Some(g)) => {
                if g.is_empty() {
                    return Err(err(src, "packing.grains", "empty (allowed: at least one grain count)"));
                }
                let mut v = Vec::new();
                for (k, &n) in g.iter().enumerate() {
                    if n < 2 {
                        return Err(err(src, &format!("packing.grains[{k}]"), format!("{n} (allowed: at least 2)")));
                    }
                    if g[..k].contains(&n) {
                        return Err(err(src, &format!("packing.grains[{k}]"), format!("{n} appears twice")));
                    }
                    v.push((format!("N{n}"), n, n as f64 * grain_measure / (fraction * cross)));
                }
                v
            }
            _ => return Err(err(src, "packing", "give either `heights` or `grains` (one packing size each)")),
        };
        if let Some(pk) = config.packing.as_mut() {
            pk.width = Some(width);
            pk.spread = Some(spread);
            pk.estimated_fraction = Some(fraction);
        }
        for (si, (label, n, l)) in sizes.iter().enumerate() {
            for (pi, &pr) in p.pressures.iter().enumerate() {
                let end = pu.end_time.unwrap_or(pu.transits * l / hertz_chain_speed(pr));
                groups.push(Group {
                    index: groups.len(),
                    name: format!("p{}_{label}", pressure_label(pr)),
                    pressure: Some(pr),
                    pressure_index: pi,
                    size_index: si,
                    size_label: label.clone(),
                    grains: *n,
                    rows: 0,
                    estimated_height: *l,
                    times: grid(end),
                });
            }
        }
    } else if let Some(lc) = &cfg.lattice {
        kind = StudyKind::Lattice;
        dimension = 2;
        pressures(src, "lattice.pressures", &lc.pressures)?;
        if lc.rows.is_empty() {
            return Err(err(src, "lattice.rows", "empty (allowed: at least one number of rows)"));
        }
        if lc.columns < 3 {
            return Err(err(src, "lattice.columns", format!("{} (allowed: at least 3)", lc.columns)));
        }
        if !(0.0..0.5).contains(&lc.polydispersity) {
            return Err(err(src, "lattice.polydispersity", format!("{} (allowed: a relative half-width in [0, 0.5))", lc.polydispersity)));
        }
        width = lc.columns as f64;
        spread = lc.polydispersity;
        friction = lc.friction;
        poisson = lc.poisson;
        for (si, &rows) in lc.rows.iter().enumerate() {
            if rows < 2 {
                return Err(err(src, &format!("lattice.rows[{si}]"), format!("{rows} (allowed: at least 2)")));
            }
            if lc.rows[..si].contains(&rows) {
                return Err(err(src, &format!("lattice.rows[{si}]"), format!("{rows} appears twice")));
            }
            let l = (rows - 1) as f64 * 3f64.sqrt() / 2.0 + 1.0;
            for (pi, &pr) in lc.pressures.iter().enumerate() {
                let end = pu.end_time.unwrap_or(pu.transits * l / hertz_chain_speed(pr));
                groups.push(Group {
                    index: groups.len(),
                    name: format!("p{}_r{rows}", pressure_label(pr)),
                    pressure: Some(pr),
                    pressure_index: pi,
                    size_index: si,
                    size_label: format!("r{rows}"),
                    grains: rows * lc.columns,
                    rows,
                    estimated_height: l,
                    times: grid(end),
                });
            }
        }
    } else {
        let c = cfg.chain.as_ref().expect("one study is given");
        kind = StudyKind::Chain;
        dimension = 2;
        width = 0.0;
        friction = 0.0;
        poisson = 0.0;
        spread = c.polydispersity;
        for (key, v) in [("chain.stiffness", c.stiffness), ("chain.mass", c.mass), ("chain.spacing", c.spacing)] {
            positive(src, key, v)?;
        }
        if !(0.0..0.5).contains(&c.polydispersity) {
            return Err(err(src, "chain.polydispersity", format!("{} (allowed: a relative half-width in [0, 0.5))", c.polydispersity)));
        }
        if c.grains.is_empty() {
            return Err(err(src, "chain.grains", "empty (allowed: at least one chain length)"));
        }
        // the ranges of the engine: a stiffness is a modulus in [1e-100, 1e100] (the time step and
        // every derived stiffness follow from it), the balls' radius 0.505 ℓ and mass within
        // 1e±60 and 1e±100 (their ratios stay representable); beyond them every sample failed at
        // its start, naming the engine's keys (`contact.normal_stiffness`, `grains.position`)
        for (key, v, lo, hi, what) in [
            ("chain.stiffness", c.stiffness, 1e-100, 1e100, "a stiffness"),
            ("chain.mass", c.mass, 1e-100, 1e100, "a mass"),
            ("chain.spacing", c.spacing, 1e-60, 1e60, "a spacing"),
        ] {
            if !(lo..=hi).contains(&v) {
                return Err(err(src, key, format!("{v} (allowed: {what} in [{lo:e}, {hi:e}], within which the chain's derived values stay representable)")));
            }
        }
        let speed = c.spacing * (c.stiffness / c.mass).sqrt();
        for (si, &n) in c.grains.iter().enumerate() {
            if n < 2 {
                return Err(err(src, &format!("chain.grains[{si}]"), format!("{n} (allowed: at least 2)")));
            }
            if c.grains[..si].contains(&n) {
                return Err(err(src, &format!("chain.grains[{si}]"), format!("{n} appears twice")));
            }
            let l = n as f64 * c.spacing;
            let end = pu.end_time.unwrap_or(pu.transits * l / speed);
            groups.push(Group {
                index: groups.len(),
                name: format!("N{n}"),
                pressure: None,
                pressure_index: 0,
                size_index: si,
                size_label: format!("N{n}"),
                grains: n,
                rows: 0,
                estimated_height: l,
                times: grid(end),
            });
        }
    }
    if !(friction.is_finite() && friction >= 0.0) {
        return Err(err(src, &format!("{}.friction", kind.name()), format!("{friction} (allowed: μ ≥ 0)")));
    }
    if !(-1.0 < poisson && poisson < 0.5) {
        return Err(err(src, &format!("{}.poisson", kind.name()), format!("{poisson} (allowed: ν in (−1, 0.5))")));
    }
    // the time grid of each group ends at `end_time`, or `transits` × the height over the
    // estimated speed: an infinite end (transits = 1e308) makes every time inf or NaN, and the
    // run failed after computing, plotting signals with no finite point
    for g in &groups {
        let end = g.times.last().copied().unwrap_or(0.0);
        if !(end.is_finite() && g.times.get(1).is_some_and(|&t| t > 0.0)) {
            let (key, value) = match pu.end_time {
                Some(t) => ("pulse.end_time", t),
                None => ("pulse.transits", pu.transits),
            };
            return Err(err(
                src,
                key,
                format!(
                    "{value} makes the time grid of {} end at {end} (allowed: a value for which the {} times from 0 to the end are finite and increasing)",
                    g.name, pu.time_samples
                ),
            ));
        }
    }
    // groups ordered size-major, pressures inside; tasks sample-major
    let mut tasks = Vec::new();
    for k in 0..cfg.samples {
        for g in &groups {
            tasks.push(Task { group: g.index, sample: k, seed: cfg.seed + k as u64 });
        }
    }
    Ok(Plan { config, kind, dimension, width, spread, friction, poisson, groups, tasks })
}

impl Plan {
    /// Checks the structure of a plan read from a checkpoint (a crafted or damaged file must be
    /// refused before anything indexes or allocates by it): group indices in order, every task's
    /// group and sample in range, grain and time counts within the kernel's hard bounds, time
    /// grids finite and non-decreasing, dimension 2 or 3. Returns what is wrong.
    pub fn check_carried(&self) -> Result<(), String> {
        use grainwave_study::limits::{HARD_MAX_GRAINS, MAX_POINTS, MAX_UNITS};
        if !matches!(self.dimension, 2 | 3) {
            return Err(format!("dimension {} (allowed: 2, 3)", self.dimension));
        }
        if self.tasks.len() as f64 > MAX_UNITS {
            return Err(format!("{} tasks (allowed: at most {MAX_UNITS})", self.tasks.len()));
        }
        for (k, g) in self.groups.iter().enumerate() {
            if g.index != k {
                return Err(format!("group {k} says it is group {}", g.index));
            }
            if g.grains as f64 > HARD_MAX_GRAINS || g.rows > g.grains.max(1) {
                return Err(format!("group {k}: {} grains in {} rows (allowed: at most {HARD_MAX_GRAINS} grains)", g.grains, g.rows));
            }
            if g.times.len() as f64 > MAX_POINTS || g.times.iter().any(|t| !t.is_finite()) || g.times.windows(2).any(|w| w[1] < w[0]) {
                return Err(format!("group {k}: a time grid of {} values that is not finite and non-decreasing (or longer than {MAX_POINTS})", g.times.len()));
            }
        }
        for (k, t) in self.tasks.iter().enumerate() {
            if t.group >= self.groups.len() || t.sample >= self.config.samples {
                return Err(format!("task {k}: group {} of {}, sample {} of {}", t.group, self.groups.len(), t.sample, self.config.samples));
            }
        }
        Ok(())
    }

    /// Pressures of the study, in config order (empty for chains).
    pub fn pressures(&self) -> Vec<f64> {
        let mut v: Vec<(usize, f64)> = self.groups.iter().filter_map(|g| g.pressure.map(|p| (g.pressure_index, p))).collect();
        v.sort_by_key(|x| x.0);
        v.dedup_by_key(|x| x.0);
        v.into_iter().map(|x| x.1).collect()
    }

    /// Number of sizes.
    pub fn sizes(&self) -> usize {
        self.groups.iter().map(|g| g.size_index + 1).max().unwrap_or(0)
    }

    /// Fingerprint of what determines the prepared packing of `task`: the study and preparation
    /// keys, the group's size and pressure, and the seed.
    pub fn packing_fingerprint(&self, task: &Task) -> u64 {
        let g = &self.groups[task.group];
        let mut h = Fnv64::default();
        let c = &self.config;
        let text = |v: &dyn erased::Toml| v.toml();
        h.write(text(&c.packing).as_bytes());
        h.write(text(&c.lattice).as_bytes());
        h.write(text(&c.chain).as_bytes());
        h.write(text(&c.preparation).as_bytes());
        h.write(g.name.as_bytes());
        h.write(&(g.grains as u64).to_le_bytes());
        h.write(&task.seed.to_le_bytes());
        h.write(grainwave_core::VERSION.as_bytes());
        h.finish()
    }

    /// Fingerprint of everything that determines the result of `task`.
    pub fn result_fingerprint(&self, task: &Task) -> u64 {
        let g = &self.groups[task.group];
        let c = &self.config;
        let mut h = Fnv64::default();
        h.write(&self.packing_fingerprint(task).to_le_bytes());
        let text = |v: &dyn erased::Toml| v.toml();
        h.write(text(&c.characterization).as_bytes());
        h.write(text(&c.moduli).as_bytes());
        h.write(text(&c.pulse).as_bytes());
        h.write(text(&c.damped).as_bytes());
        h.write(&(task.sample as u64).to_le_bytes());
        for t in &g.times {
            h.write_f64(*t);
        }
        h.finish()
    }
}

/// TOML text of config parts, for fingerprints.
mod erased {
    pub trait Toml {
        fn toml(&self) -> String;
    }
    impl<T: serde::Serialize> Toml for T {
        fn toml(&self) -> String {
            #[derive(serde::Serialize)]
            struct Wrap<'a, T: serde::Serialize> {
                v: &'a T,
            }
            toml::to_string(&Wrap { v: self }).unwrap_or_default()
        }
    }
}
