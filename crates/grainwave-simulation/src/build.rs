//! Validation of a `simulation` config into a ready-to-run engine simulation.

use super::config::*;
use grainwave_study::config::{values::to_vector, ConfigError, ConfigSource};
use grainwave_core::contact::{ContactParams, Partner};
use grainwave_core::prelude::*;
use grainwave_core::checkpoint::AnySimulation;
use grainwave_core::sim::Safety;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Overlays the keys given in `over` onto `base` (keys absent from `over` keep `base`'s value).
pub fn overlay(base: &ContactParams, over: &ContactParams) -> ContactParams {
    let mut b = toml::Table::try_from(base).expect("contact params serialize");
    let o = toml::Table::try_from(over).expect("contact params serialize");
    for (k, v) in o {
        b.insert(k, v);
    }
    b.try_into().expect("overlaid contact params deserialize")
}

fn err(src: &ConfigSource, key: &str, msg: impl Into<String>) -> ConfigError {
    src.error_at_key(key, msg)
}

/// Validates `cfg` and builds the simulation (placing the grains, checking overlaps, computing
/// the initial forces) — everything short of stepping.
pub fn build(src: &ConfigSource, cfg: &SimulationConfig) -> Result<AnySimulation, ConfigError> {
    if cfg.experiment != "simulation" {
        return Err(err(src, "experiment", format!("this protocol is `simulation`, not `{}`", cfg.experiment)));
    }
    match cfg.grains.kind {
        KindName::Disk | KindName::Sphere2d => Ok(AnySimulation::D2(build_dim::<D2>(src, cfg)?)),
        KindName::Sphere => Ok(AnySimulation::D3(build_dim::<D3>(src, cfg)?)),
    }
}

fn vector<D: Dim>(src: &ConfigSource, key: &str, v: &[f64]) -> Result<D::Vector, ConfigError> {
    to_vector::<D>(v).map_err(|m| err(src, key, m))
}

fn build_dim<D: Dim>(src: &ConfigSource, cfg: &SimulationConfig) -> Result<Simulation<D>, ConfigError> {
    let core = |e: CoreError| src.error_from_core(&e);
    let g = &cfg.grains;
    let kind = match g.kind {
        KindName::Disk => GrainKind::Disk { thickness: g.thickness },
        KindName::Sphere2d => GrainKind::Sphere2d,
        KindName::Sphere => GrainKind::Sphere,
    };
    if g.count == 0 {
        return Err(err(src, "grains.count", "0 grains (allowed: at least 1)"));
    }
    if !(g.density.is_finite() && g.density > 0.0) {
        return Err(err(src, "grains.density", format!("{} (allowed: a finite density > 0)", g.density)));
    }
    if !(g.thickness.is_finite() && g.thickness > 0.0) {
        return Err(err(src, "grains.thickness", format!("{} (allowed: a finite thickness > 0)", g.thickness)));
    }
    let sizes = match &g.size {
        SizeConfig::Monodisperse { radius } => SizeDistribution::Monodisperse { radius: *radius },
        SizeConfig::UniformDiameter { mean_diameter, spread } => {
            SizeDistribution::UniformDiameter { mean_diameter: *mean_diameter, spread: *spread }
        }
        SizeConfig::UniformRadius { max_radius, delta } => SizeDistribution::UniformRadius { max_radius: *max_radius, delta: *delta },
        SizeConfig::Explicit { radii } => SizeDistribution::Explicit { radii: radii.clone() },
    };
    sizes.validate().map_err(|e| match e {
        CoreError::InvalidParameter { field, value, allowed } => {
            err(src, &format!("grains.size.{}", field.split('[').next().unwrap_or(&field)), format!("{value} (allowed: {allowed})"))
        }
        other => core(other),
    })?;

    // domain
    let size = vector::<D>(src, "domain.size", &cfg.domain.size)?;
    for k in 0..D::D {
        if !(size.get(k) > 0.0) {
            return Err(err(src, "domain.size", format!("{:?} (allowed: lengths > 0)", cfg.domain.size)));
        }
    }
    let origin = match &cfg.domain.origin {
        Some(o) => vector::<D>(src, "domain.origin", o)?,
        None => D::Vector::ZERO,
    };
    let mut periodic = [false; 3];
    for a in &cfg.domain.periodic {
        if a.index() >= D::D {
            return Err(err(src, "domain.periodic", format!("axis `{a:?}` does not exist in {}D", D::D)));
        }
        periodic[a.index()] = true;
    }
    let hi = origin + size;
    // the box must keep its size where it is placed: at origin 1e17 a size of 8 is lost to
    // rounding (hi − origin = 0), which was then blamed on `domain.size`
    for k in 0..D::D {
        let kept = hi.get(k) - origin.get(k);
        if !origin.get(k).is_finite() || (kept - size.get(k)).abs() > 1e-9 * size.get(k) {
            return Err(err(
                src,
                "domain.origin",
                format!(
                    "{:?} (allowed: an origin at which the box keeps its size: here size[{k}] = {} becomes {kept} after rounding)",
                    cfg.domain.origin.as_deref().unwrap_or(&[]),
                    size.get(k)
                ),
            ));
        }
    }
    let mut domain = Domain::new(origin, hi, periodic);

    // contact laws
    if cfg.contact.preset.is_empty() && !cfg.contact.has_families() {
        return Err(err(
            src,
            "contact.preset",
            format!(
                "missing (allowed: {}; or the law by family, a table `[contact.normal]` with `law` one of {})",
                grainwave_core::contact::PRESETS.join(", "),
                grainwave_core::contact::NormalElastic::NAMES.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ")
            ),
        ));
    }
    let law = cfg.contact.build(Partner::Grain, "contact").map_err(core)?;
    let wall_base = overlay(&cfg.contact, &cfg.wall_contact);
    wall_base.build(Partner::Wall, "wall_contact").map_err(core)?;

    // radii (needed for piston areas)
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    let radii = sizes.sample(g.count, &mut rng).map_err(core)?;
    let mean_diameter = 2.0 * radii.iter().sum::<f64>() / radii.len() as f64;

    // wall names so far → index: one lookup per wall (50 000 walls were checked in n², 9 s)
    let mut wall_names: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for (w, wc) in cfg.walls.iter().enumerate() {
        let key = |k: &str| format!("walls[{w}].{k}");
        // names label the wall's output columns and files: they must be unique and non-empty
        if wc.name.trim().is_empty() {
            return Err(err(src, &key("name"), "empty (allowed: a name, unique among the walls)"));
        }
        // they become file and archive member names (`load_<name>`): refused here, before the run,
        // rather than when the outputs are written after it
        if wc.name.chars().count() > 64 || wc.name.chars().any(|c| c == '/' || c == '\\' || c.is_control()) {
            return Err(err(
                src,
                &key("name"),
                format!(
                    "{:?} (allowed: at most 64 characters, without `/`, `\\` or control characters: the name becomes part of file names)",
                    grainwave_study::config::clip(&wc.name, grainwave_study::config::MAX_ECHO_CHARS)
                ),
            ));
        }
        if let Some(&first) = wall_names.get(wc.name.as_str()) {
            return Err(err(src, &key("name"), format!("`{}` is already the name of walls[{first}] (allowed: a name unique among the walls)", grainwave_study::config::clip(&wc.name, grainwave_study::config::MAX_ECHO_CHARS))));
        }
        wall_names.insert(&wc.name, w);
        let axis = wc.axis.index();
        if axis >= D::D {
            return Err(err(src, &key("axis"), format!("`{:?}` does not exist in {}D", wc.axis, D::D)));
        }
        if periodic[axis] {
            return Err(err(src, &key("axis"), format!("axis `{:?}` is periodic; a wall cannot close it", wc.axis)));
        }
        let low = wc.side == Side::Low;
        let coordinate = wc.position.unwrap_or(if low { origin.get(axis) } else { hi.get(axis) });
        let params = match &wc.contact {
            Some(over) => overlay(&wall_base, over),
            None => wall_base.clone(),
        };
        let wall_law = params.build(Partner::Wall, &key("contact")).map_err(core)?;
        let mut wall = Wall::<D>::axis_aligned(wc.name.clone(), axis, coordinate, low, wall_law);
        let forbid = |name: &str, given: bool, motion: &str| -> Result<(), ConfigError> {
            if given {
                Err(err(src, &key(name), format!("does not apply to a `{motion}` wall")))
            } else {
                Ok(())
            }
        };
        match wc.motion {
            MotionKind::Fixed => {
                forbid("speed", wc.speed.is_some(), "fixed")?;
                forbid("mass", wc.mass.is_some(), "fixed")?;
                forbid("force", wc.force.is_some(), "fixed")?;
                forbid("pressure", wc.pressure.is_some(), "fixed")?;
            }
            MotionKind::Velocity => {
                forbid("mass", wc.mass.is_some(), "velocity")?;
                forbid("force", wc.force.is_some(), "velocity")?;
                forbid("pressure", wc.pressure.is_some(), "velocity")?;
                let speed = wc.speed.as_ref().ok_or_else(|| err(src, &key("speed"), "missing: a `velocity` wall needs a speed"))?;
                wall = wall.with_motion(WallMotion::Velocity { speed: speed.to_core() });
            }
            MotionKind::Piston => {
                forbid("speed", wc.speed.is_some(), "piston")?;
                let mass = wc.mass.ok_or_else(|| err(src, &key("mass"), "missing: a piston needs a mass"))?;
                let force = match (&wc.force, &wc.pressure) {
                    (Some(f), None) => f.to_core(),
                    (None, Some(p)) => {
                        let mut area = 1.0;
                        for k in 0..D::D {
                            if k != axis {
                                area *= size.get(k);
                            }
                        }
                        if D::D == 2 {
                            area *= match kind {
                                GrainKind::Disk { thickness } => thickness,
                                _ => mean_diameter,
                            };
                        }
                        scale(p.to_core(), area)
                    }
                    (Some(_), Some(_)) => return Err(err(src, &key("pressure"), "give either `force` or `pressure`, not both")),
                    (None, None) => return Err(err(src, &key("force"), "missing: a piston needs a `force` or a `pressure`")),
                };
                wall = wall.with_motion(WallMotion::Piston { mass, force });
            }
        }
        wall.validate(w).map_err(|e| match e {
            CoreError::InvalidParameter { field, value, allowed } => {
                // the whole path below the wall (`speed.times`, not `times`); a piston given by
                // `pressure` has its force computed from it: name the key the file has
                let mut sub = field.strip_prefix(&format!("walls[{w}].")).unwrap_or_else(|| field.rsplit('.').next().unwrap_or("")).to_string();
                if sub.starts_with("force") && wc.force.is_none() && wc.pressure.is_some() {
                    sub = "pressure".into();
                }
                err(src, &key(&sub), format!("{value} (allowed: {allowed})"))
            }
            other => core(other),
        })?;
        // a function the engine interpolates must stay finite between its values (a speed table
        // from 1e308 to −1e308 has an infinite slope: the wall went to NaN and the run ended
        // "normally", failing only when it drew the grains), and a piston's acceleration
        // |force| / mass must be finite (mass 1e-300 under 1e300)
        let (function, sub) = match &wall.motion {
            WallMotion::Velocity { speed } => (Some(speed), "speed"),
            WallMotion::Piston { force, .. } => (Some(force), if wc.force.is_none() && wc.pressure.is_some() { "pressure" } else { "force" }),
            _ => (None, ""),
        };
        if let Some(f) = function {
            let (largest, steepest) = extent(f);
            if !steepest.is_finite() {
                return Err(err(src, &key(sub), format!("values whose differences overflow ({steepest}) (allowed: a function whose values and the differences between them are finite)")));
            }
            if let WallMotion::Piston { mass, .. } = wall.motion {
                if !(largest / mass).is_finite() {
                    return Err(err(
                        src,
                        &key("mass"),
                        format!("{mass}: the piston's acceleration |{sub}| / mass reaches {} (allowed: a mass for which it is finite)", largest / mass),
                    ));
                }
            }
        }
        domain = domain.with_wall(wall);
    }

    // placement
    let pc = &cfg.placement;
    let rmin = match &pc.region_min {
        Some(v) => vector::<D>(src, "placement.region_min", v)?,
        None => origin,
    };
    let rmax = match &pc.region_max {
        Some(v) => vector::<D>(src, "placement.region_max", v)?,
        None => hi,
    };
    for k in 0..D::D {
        if !(rmax.get(k) > rmin.get(k)) {
            return Err(err(src, "placement.region_max", format!("{:?} must exceed region_min {:?} on every axis", rmax, rmin)));
        }
    }
    // a region reaching behind a wall may place grains there, which the engine refuses (naming
    // the grain and the wall): the key to blame is the bound that crosses the wall
    let crosses = |low: bool| {
        domain.walls.iter().any(|w| {
            (0..D::D).any(|k| {
                let n = w.normal.get(k);
                if low {
                    n > 0.0 && rmin.get(k) < w.position.get(k)
                } else {
                    n < 0.0 && rmax.get(k) > w.position.get(k)
                }
            })
        })
    };
    let behind_key = if pc.region_min.is_some() && crosses(true) {
        "placement.region_min"
    } else if pc.region_max.is_some() && crosses(false) {
        "placement.region_max"
    } else {
        "placement"
    };
    if !(pc.speed.is_finite() && pc.speed >= 0.0) {
        return Err(err(src, "placement.speed", format!("{} (allowed: a finite speed ≥ 0)", pc.speed)));
    }
    let r_max = radii.iter().cloned().fold(0.0, f64::max);
    let positions: Vec<D::Vector> = match pc.method {
        PlacementMethod::Gas => {
            if pc.attempts == 0 {
                return Err(err(src, "placement.attempts", "0 (allowed: at least 1)"));
            }
            grainwave_core::placement::random_gas::<D>(&radii, rmin, rmax, periodic, &mut rng, pc.attempts)
                .map_err(|e| err(src, "placement", e.to_string()))?
        }
        PlacementMethod::Lattice => {
            let a = pc.spacing.unwrap_or(2.0 * r_max);
            if !(a.is_finite() && a > 0.0) {
                return Err(err(src, "placement.spacing", format!("{a} (allowed: a finite spacing > 0)")));
            }
            lattice::<D>(g.count, a, rmin, rmax, r_max).ok_or_else(|| {
                err(src, "placement", format!("{} grains do not fit on a lattice of spacing {a} in the region {:?}–{:?}", g.count, rmin, rmax))
            })?
        }
    };
    let mut grains = Grains::<D>::new(kind);
    for (p, r) in positions.iter().zip(&radii) {
        let mut v = D::Vector::ZERO;
        if pc.speed > 0.0 {
            for k in 0..D::D {
                v.set(k, pc.speed * (2.0 * rng.random::<f64>() - 1.0));
            }
        }
        grains.push(*p, *r, g.density, v);
    }

    // body forces, loads, integration
    let gravity = match &cfg.gravity {
        Some(v) => vector::<D>(src, "gravity", v)?,
        None => D::Vector::ZERO,
    };
    let ic = &cfg.integration;
    let mut b = SimulationBuilder::new(grains, domain, law)
        .gravity(gravity)
        .integrator(match ic.integrator {
            IntegratorName::VelocityVerlet => Integrator::VelocityVerlet,
            IntegratorName::Beeman => Integrator::Beeman,
        })
        .dt_fraction(ic.dt_fraction)
        .expected_overlap(ic.expected_overlap)
        .max_initial_overlap(ic.max_initial_overlap)
        .safety(Safety { max_overlap_fraction: ic.max_overlap_fraction })
        .seed(cfg.seed);
    if let Some(dt) = ic.dt {
        b = b.dt(dt);
    }
    if let Some(s) = ic.skin {
        b = b.skin(s);
    }
    for (k, l) in cfg.loads.iter().enumerate() {
        let key = |f: &str| format!("loads[{k}].{f}");
        let force = match &l.force {
            Some(f) => vector::<D>(src, &key("force"), f)?,
            None => D::Vector::ZERO,
        };
        let torque = match &l.torque {
            None => D::AngVector::ZERO,
            Some(t) if t.len() == D::ROT && t.iter().all(|x| x.is_finite()) => D::AngVector::from_slice(t),
            Some(t) => return Err(err(src, &key("torque"), format!("{t:?} (allowed: {} finite number(s) in {}D)", D::ROT, D::D))),
        };
        b = b.load(ExternalLoad {
            grain: l.grain,
            force,
            torque,
            profile: l.profile.as_ref().map(|p| p.to_core()).unwrap_or(TimeFunction::Constant { value: 1.0 }),
        });
    }
    cfg.stop.validate().map_err(core)?;
    let sim = b.build().map_err(|e| match &e {
        CoreError::InvalidParameter { field, .. } if field.starts_with("loads[") => core(e),
        CoreError::InvalidParameter { field, value, allowed }
            if ["dt", "dt_fraction", "expected_overlap", "skin", "max_initial_overlap", "max_overlap_fraction"].contains(&field.as_str()) =>
        {
            err(src, &format!("integration.{field}"), format!("{value} (allowed: {allowed})"))
        }
        CoreError::InitialOverlap { .. } => err(src, "integration.max_initial_overlap", e.to_string()),
        CoreError::Inconsistent(m) if m.contains("is behind wall") => {
            err(src, behind_key, format!("{m} (allowed: a placement region in front of every wall, within the domain's walls)"))
        }
        _ => core(e),
    })?;
    Ok(sim)
}

/// Multiplies a time function by a constant.
/// The largest |value| of `f` and the largest difference between two of its values that the
/// engine interpolates between (inf when that difference overflows).
fn extent(f: &TimeFunction) -> (f64, f64) {
    match f {
        TimeFunction::Constant { value } => (value.abs(), 0.0),
        TimeFunction::Ramp { from, to, .. } => (from.abs().max(to.abs()), (to - from).abs()),
        TimeFunction::CosineStop { value, .. } => (value.abs(), value.abs()),
        TimeFunction::Table { values, .. } => (
            values.iter().fold(0.0, |m, v| m.max(v.abs())),
            values.windows(2).fold(0.0, |m, w| m.max((w[1] - w[0]).abs())),
        ),
    }
}

fn scale(f: TimeFunction, c: f64) -> TimeFunction {
    match f {
        TimeFunction::Constant { value } => TimeFunction::Constant { value: value * c },
        TimeFunction::Ramp { from, to, start, end } => TimeFunction::Ramp { from: from * c, to: to * c, start, end },
        TimeFunction::CosineStop { value, start, duration } => TimeFunction::CosineStop { value: value * c, start, duration },
        TimeFunction::Table { times, values } => TimeFunction::Table { times, values: values.into_iter().map(|v| v * c).collect() },
    }
}

/// `n` lattice sites filling the region row by row (triangular in 2D, simple cubic in 3D), at
/// least `margin` from the region's faces; `None` when they do not fit.
fn lattice<D: Dim>(n: usize, a: f64, lo: D::Vector, hi: D::Vector, margin: f64) -> Option<Vec<D::Vector>> {
    let mut out = Vec::with_capacity(n);
    if D::D == 2 {
        let dy = a * 3f64.sqrt() / 2.0;
        let mut row = 0;
        loop {
            let y = lo.get(1) + margin + row as f64 * dy;
            if y > hi.get(1) - margin + 1e-12 {
                return None;
            }
            let shift = if row % 2 == 1 { 0.5 * a } else { 0.0 };
            let mut x = lo.get(0) + margin + shift;
            while x <= hi.get(0) - margin + 1e-12 {
                let mut p = D::Vector::ZERO;
                p.set(0, x);
                p.set(1, y);
                out.push(p);
                if out.len() == n {
                    return Some(out);
                }
                x += a;
            }
            row += 1;
        }
    } else {
        let count = |k: usize| (((hi.get(k) - lo.get(k) - 2.0 * margin) / a).floor() as usize) + 1;
        let (nx, ny) = (count(0), count(1));
        let mut k = 0;
        while out.len() < n {
            let z = lo.get(2) + margin + k as f64 * a;
            if z > hi.get(2) - margin + 1e-12 {
                return None;
            }
            for j in 0..ny {
                for i in 0..nx {
                    let mut p = D::Vector::ZERO;
                    p.set(0, lo.get(0) + margin + i as f64 * a);
                    p.set(1, lo.get(1) + margin + j as f64 * a);
                    p.set(2, z);
                    out.push(p);
                    if out.len() == n {
                        return Some(out);
                    }
                }
            }
            k += 1;
        }
        Some(out)
    }
}
