//! Linear analysis of a simulation's current state (`grainwave-linear`): the dynamical matrix D
//! and masses M (SPEC §5.4), its eigenmodes D v = ω² M v and the elastic moduli (SPEC §5.3).
//!
//! Degrees of freedom: grain by grain in the order of `grain_ids` (the snapshot's order), each
//! grain its d translations then its rotations (1 in 2D, 3 in 3D).

use crate::errors::RunError;
use crate::sim::Simulation;
use grainwave_experiments::engine::linear as gl;
use grainwave_experiments::engine::Dim;
use grainwave_experiments::engine::AnySimulation;
use gl::dynamical::{AssemblyOptions, DynamicalMatrix, PreStress, Rattlers, SlidingContacts, ZeroRows};
use gl::linalg::eigen::{EigenOptions, Modes};
use gl::incremental::{BranchHistory, BranchRule, IncrementalOptions, IncrementalPropagator, Piston, StateCounts, DEFAULT_MOBILISATION_TOLERANCE};
use gl::moduli::{elastic_moduli, ModuliOptions};
use grainwave_experiments::e2 as gw_e2;
use gw_e2::arrival::StripFit;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

fn options(prestress: &str, rattlers: &str, sliding: &str, rolling: bool) -> PyResult<AssemblyOptions> {
    let prestress = match prestress {
        "none" => PreStress::None,
        "normal" => PreStress::Normal,
        "full" => PreStress::Full,
        other => return Err(PyValueError::new_err(format!("prestress = {other:?} (allowed: \"none\", \"normal\", \"full\")"))),
    };
    let rattlers = match rattlers {
        "keep" => Rattlers::Keep,
        "remove" => Rattlers::Remove,
        other => return Err(PyValueError::new_err(format!("rattlers = {other:?} (allowed: \"keep\", \"remove\")"))),
    };
    let sliding = match sliding {
        "stick" => SlidingContacts::Stick,
        "free" => SlidingContacts::Free,
        other => return Err(PyValueError::new_err(format!("sliding = {other:?} (allowed: \"stick\", \"free\")"))),
    };
    Ok(AssemblyOptions { prestress, rattlers, sliding, rolling, ..AssemblyOptions::default() })
}

fn linear_error(e: gl::LinearError) -> PyErr {
    let text = crate::errors::chain(&e);
    match e {
        gl::LinearError::InvalidParameter { .. } | gl::LinearError::LengthMismatch { .. } | gl::LinearError::Inconsistent(_) | gl::LinearError::UnknownWall { .. } => PyValueError::new_err(text),
        _ => RunError::new_err(text),
    }
}

fn assemble<D: Dim>(s: &grainwave_experiments::engine::Simulation<D>, o: &AssemblyOptions) -> PyResult<(DynamicalMatrix<D>, Vec<i64>)> {
    let snap = s.snapshot();
    let ids = snap.id.iter().map(|&i| i64::from(i)).collect();
    Ok((DynamicalMatrix::assemble(&snap, o).map_err(linear_error)?, ids))
}

fn matrix_dict<'py, D: Dim>(py: Python<'py>, dm: &DynamicalMatrix<D>, ids: Vec<i64>) -> PyResult<Bound<'py, PyDict>> {
    let k = dm.stiffness();
    let n = dm.dofs();
    let (mut rows, mut cols, mut values) = (Vec::new(), Vec::new(), Vec::new());
    let symbolic = k.symbolic();
    let (ptr, idx, val) = (symbolic.row_ptr(), symbolic.col_idx(), k.val());
    for r in 0..n {
        for p in ptr[r]..ptr[r + 1] {
            rows.push(r as i64);
            cols.push(idx[p] as i64);
            values.push(val[p]);
        }
    }
    let d = PyDict::new(py);
    d.set_item("rows", PyArray1::from_vec(py, rows))?;
    d.set_item("cols", PyArray1::from_vec(py, cols))?;
    d.set_item("values", PyArray1::from_vec(py, values))?;
    d.set_item("shape", (n, n))?;
    d.set_item("mass", PyArray1::from_vec(py, dm.mass().to_vec()))?;
    d.set_item("removed", PyArray1::from_vec(py, dm.removed().to_vec()))?;
    d.set_item("grain_ids", PyArray1::from_vec(py, ids))?;
    d.set_item("dofs_per_grain", dm.layout().per_grain())?;
    d.set_item("symmetric", dm.is_symmetric())?;
    Ok(d)
}

/// D (COO triplets, summed duplicates none) and M of the current state.
#[pyfunction]
#[pyo3(signature = (sim, prestress="none", rattlers="keep", sliding="stick", rolling=true))]
pub fn dynamical_matrix<'py>(py: Python<'py>, sim: PyRef<'py, Simulation>, prestress: &str, rattlers: &str, sliding: &str, rolling: bool) -> PyResult<Bound<'py, PyDict>> {
    let o = options(prestress, rattlers, sliding, rolling)?;
    match sim.engine() {
        AnySimulation::D2(s) => {
            let (dm, ids) = py.detach(|| assemble(s, &o))?;
            matrix_dict(py, &dm, ids)
        }
        AnySimulation::D3(s) => {
            let (dm, ids) = py.detach(|| assemble(s, &o))?;
            matrix_dict(py, &dm, ids)
        }
    }
}

fn modes_of<D: Dim>(s: &grainwave_experiments::engine::Simulation<D>, o: &AssemblyOptions, threads: Option<usize>) -> PyResult<(Modes, Vec<i64>, usize)> {
    let (dm, ids) = assemble(s, o)?;
    let system = dm.free_system(&Default::default(), ZeroRows::Keep).map_err(linear_error)?;
    let modes = Modes::compute(&system, &EigenOptions { threads, ..EigenOptions::default() }).map_err(linear_error)?;
    Ok((modes, ids, dm.layout().per_grain()))
}

/// Every eigenmode D v = ω² M v of the current state (dense; M-orthonormal vectors).
#[pyfunction]
#[pyo3(signature = (sim, prestress="none", rattlers="keep", sliding="stick", rolling=true, threads=1))]
pub fn modes<'py>(py: Python<'py>, sim: PyRef<'py, Simulation>, prestress: &str, rattlers: &str, sliding: &str, rolling: bool, threads: Option<usize>) -> PyResult<Bound<'py, PyDict>> {
    let o = options(prestress, rattlers, sliding, rolling)?;
    let (modes, ids, per) = match sim.engine() {
        AnySimulation::D2(s) => py.detach(|| modes_of(s, &o, threads))?,
        AnySimulation::D3(s) => py.detach(|| modes_of(s, &o, threads))?,
    };
    let v = modes.vectors();
    let (rows, cols) = (v.nrows(), v.ncols());
    let mut flat = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            flat.push(v[(r, c)]);
        }
    }
    let d = PyDict::new(py);
    d.set_item("omega_squared", PyArray1::from_vec(py, modes.omega_squared().to_vec()))?;
    d.set_item("frequencies", PyArray1::from_vec(py, modes.frequencies()))?;
    d.set_item("vectors", PyArray1::from_vec(py, flat).reshape([rows, cols])?)?;
    d.set_item("participation", PyArray1::from_vec(py, modes.participation().to_vec()))?;
    d.set_item("free_dofs", PyArray1::from_vec(py, modes.free_dofs().iter().map(|&k| k as i64).collect::<Vec<i64>>()))?;
    d.set_item("mass", PyArray1::from_vec(py, modes.mass().to_vec()))?;
    d.set_item("grain_ids", PyArray1::from_vec(py, ids))?;
    d.set_item("dofs_per_grain", per)?;
    Ok(d)
}

/// Elastic moduli by imposed strain and linear relaxation (Voigt C, affine C, volume, density,
/// speeds).
#[pyfunction]
#[pyo3(signature = (sim, prestress="none", rattlers="keep", sliding="stick", rolling=true))]
pub fn moduli<'py>(py: Python<'py>, sim: PyRef<'py, Simulation>, prestress: &str, rattlers: &str, sliding: &str, rolling: bool) -> PyResult<Bound<'py, PyDict>> {
    let o = options(prestress, rattlers, sliding, rolling)?;
    let m = match sim.engine() {
        AnySimulation::D2(s) => py.detach(|| assemble(s, &o).and_then(|(dm, _)| elastic_moduli(&dm, &ModuliOptions::default()).map_err(linear_error)))?,
        AnySimulation::D3(s) => py.detach(|| assemble(s, &o).and_then(|(dm, _)| elastic_moduli(&dm, &ModuliOptions::default()).map_err(linear_error)))?,
    };
    let d = PyDict::new(py);
    d.set_item("voigt", m.voigt.clone())?;
    d.set_item("affine", m.affine.clone())?;
    d.set_item("volume", m.volume)?;
    d.set_item("density", m.density)?;
    d.set_item("longitudinal_speed", m.longitudinal_speed)?;
    d.set_item("transverse_speed", m.transverse_speed)?;
    d.set_item("asymmetry", m.asymmetry)?;
    Ok(d)
}

fn pulse_setup(source_wall: u32, detector_wall: u32, initial_condition: &str, strength: f64) -> PyResult<gl::pulse::PulseSetup> {
    if !strength.is_finite() {
        return Err(PyValueError::new_err(format!("strength = {strength} (allowed: a finite number)")));
    }
    let initial_condition = match initial_condition {
        "impulse" => gl::pulse::InitialCondition::Impulse { strength },
        "displacement" => gl::pulse::InitialCondition::Displacement { amplitude: strength },
        other => return Err(PyValueError::new_err(format!("initial_condition = {other:?} (allowed: \"impulse\" (A), \"displacement\" (B))"))),
    };
    Ok(gl::pulse::PulseSetup { source_wall, detector_wall, initial_condition })
}

fn read_times(py: Python<'_>, times: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let np = py.import("numpy")?;
    let a = np.call_method1("asarray", (times, "float64"))?.call_method0("ravel")?;
    let t: Vec<f64> = a.call_method0("tolist")?.extract()?;
    if let Some(k) = t.iter().position(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!("times: entry [{k}] is {} (allowed: finite numbers)", t[k])));
    }
    if let Some(k) = t.windows(2).position(|w| w[1] < w[0]) {
        return Err(PyValueError::new_err(format!("times: entry [{}] = {} is before entry [{k}] = {} (allowed: increasing times)", k + 1, t[k + 1], t[k])));
    }
    Ok(t)
}

/// The pulse of SPEC §5.5 as a sum over all modes: the force F_sig(t) on the detector wall after
/// the source wall's kick (A) or displacement (B), all grains free, walls fixed.
#[pyfunction]
#[pyo3(signature = (sim, source_wall, detector_wall, times, initial_condition="impulse", strength=1.0, prestress="none", rattlers="keep", sliding="stick", rolling=true, threads=1))]
#[allow(clippy::too_many_arguments)]
pub fn modal_pulse<'py>(
    py: Python<'py>,
    sim: PyRef<'py, Simulation>,
    source_wall: u32,
    detector_wall: u32,
    times: &Bound<'py, PyAny>,
    initial_condition: &str,
    strength: f64,
    prestress: &str,
    rattlers: &str,
    sliding: &str,
    rolling: bool,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let o = options(prestress, rattlers, sliding, rolling)?;
    let setup = pulse_setup(source_wall, detector_wall, initial_condition, strength)?;
    let t = read_times(py, times)?;
    let eigen = EigenOptions { threads, ..EigenOptions::default() };
    let p = match sim.engine() {
        AnySimulation::D2(s) => py.detach(|| gl::pulse::modal_pulse(&s.snapshot(), &o, &eigen, &setup, &t)),
        AnySimulation::D3(s) => py.detach(|| gl::pulse::modal_pulse(&s.snapshot(), &o, &eigen, &setup, &t)),
    }
    .map_err(linear_error)?;
    let d = PyDict::new(py);
    d.set_item("times", PyArray1::from_vec(py, p.times))?;
    d.set_item("signal", PyArray1::from_vec(py, p.signal))?;
    d.set_item("omega_squared", PyArray1::from_vec(py, p.omega_squared))?;
    d.set_item("participation", PyArray1::from_vec(py, p.participation))?;
    d.set_item("contributions", PyArray1::from_vec(py, p.contributions))?;
    d.set_item("coupling", PyArray1::from_vec(py, p.coupling))?;
    d.set_item("dofs", p.dofs)?;
    Ok(d)
}

/// The same pulse by direct integration of M ü = −D u (sparse D, 4th-order symplectic scheme).
#[pyfunction]
#[pyo3(signature = (sim, source_wall, detector_wall, times, initial_condition="impulse", strength=1.0, prestress="none", rattlers="keep", sliding="stick", rolling=true, steps_per_period=20.0))]
#[allow(clippy::too_many_arguments)]
pub fn direct_pulse<'py>(
    py: Python<'py>,
    sim: PyRef<'py, Simulation>,
    source_wall: u32,
    detector_wall: u32,
    times: &Bound<'py, PyAny>,
    initial_condition: &str,
    strength: f64,
    prestress: &str,
    rattlers: &str,
    sliding: &str,
    rolling: bool,
    steps_per_period: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let o = options(prestress, rattlers, sliding, rolling)?;
    let setup = pulse_setup(source_wall, detector_wall, initial_condition, strength)?;
    let t = read_times(py, times)?;
    let prop = gl::propagation::PropagationOptions { steps_per_period, ..Default::default() };
    let p = match sim.engine() {
        AnySimulation::D2(s) => py.detach(|| gl::pulse::direct_pulse(&s.snapshot(), &o, &prop, &setup, &t)),
        AnySimulation::D3(s) => py.detach(|| gl::pulse::direct_pulse(&s.snapshot(), &o, &prop, &setup, &t)),
    }
    .map_err(linear_error)?;
    let d = PyDict::new(py);
    d.set_item("times", PyArray1::from_vec(py, p.times))?;
    d.set_item("signal", PyArray1::from_vec(py, p.values))?;
    d.set_item("steps", p.steps)?;
    d.set_item("max_step", p.max_step)?;
    Ok(d)
}

/// How the pulsing wall is set in motion.
#[derive(Clone, Copy)]
enum Kick {
    /// Walls fixed; the grains touching the wall get the impulse amplitude × s_i (condition A).
    Grains,
    /// The wall is a piston of this mass and gets the velocity amplitude / mass.
    Piston(f64),
    /// The wall is a piston of the mass its motion has in the simulation.
    StatePiston,
}

fn kick_of(piston_mass: Option<&Bound<'_, PyAny>>) -> PyResult<Kick> {
    let Some(m) = piston_mass else { return Ok(Kick::Grains) };
    if m.is_none() {
        return Ok(Kick::Grains);
    }
    if let Ok(s) = m.extract::<String>() {
        return if s == "state" { Ok(Kick::StatePiston) } else { Err(PyValueError::new_err(format!("piston_mass = {s:?} (allowed: None, \"state\" or a finite mass > 0)"))) };
    }
    let mass: f64 = m.extract().map_err(|_| PyValueError::new_err(format!("piston_mass = {} (allowed: None, \"state\" or a finite mass > 0)", m.repr().map(|r| r.to_string()).unwrap_or_default())))?;
    if !(mass.is_finite() && mass > 0.0) {
        return Err(PyValueError::new_err(format!("piston_mass = {mass} (allowed: None, \"state\" or a finite mass > 0)")));
    }
    Ok(Kick::Piston(mass))
}

fn branch_rule(branches: &str) -> PyResult<BranchRule> {
    [BranchRule::Incremental, BranchRule::Stick, BranchRule::Free, BranchRule::Slip]
        .into_iter()
        .find(|r| r.name() == branches)
        .ok_or_else(|| PyValueError::new_err(format!("branches = {branches:?} (allowed: \"incremental\", \"stick\", \"free\", \"slip\")")))
}

/// Settings of one incremental pulse (checked).
struct IncrementalSetup {
    wall: usize,
    detector: Option<usize>,
    kick: Kick,
    amplitude: f64,
    options: IncrementalOptions,
    strips: usize,
    fit_range: [f64; 2],
}

/// What an incremental pulse computed (grains in snapshot order).
struct IncrementalRun {
    ids: Vec<i64>,
    dim: usize,
    positions: Vec<f64>,
    distance: Vec<f64>,
    velocity: Vec<f64>,
    signal: Option<Vec<f64>>,
    piston: Option<(Vec<f64>, Vec<f64>)>,
    slipping: Vec<u64>,
    counts: StateCounts,
    history: Vec<BranchHistory>,
    pairs: Vec<(i64, i64)>,
    arrival: Vec<f64>,
    fit: Option<StripFit>,
    steps: u64,
    max_step: f64,
    seconds: f64,
}

fn incremental_run<D: Dim>(s: &grainwave_experiments::engine::Simulation<D>, setup: &IncrementalSetup, times: &[f64]) -> PyResult<IncrementalRun> {
    use grainwave_experiments::engine::core::dim::VectorOps;
    use grainwave_experiments::engine::core::domain::WallMotion;
    let snapshot = s.snapshot();
    let walls = &snapshot.domain.walls;
    let wall = &walls[setup.wall];
    let inward = wall.normal / wall.normal.norm();
    let piston = match setup.kick {
        Kick::Grains => None,
        Kick::Piston(mass) => Some(Piston { wall: setup.wall as u32, mass }),
        Kick::StatePiston => match s.domain.walls[setup.wall].motion {
            WallMotion::Piston { mass, .. } => Some(Piston { wall: setup.wall as u32, mass }),
            _ => return Err(PyValueError::new_err(format!("piston_mass = \"state\": the wall {} (`{}`) is not a piston in the simulation (allowed there: None or a mass)", setup.wall, wall.name))),
        },
    };
    let mut p = IncrementalPropagator::<D>::new(&snapshot, piston, &setup.options).map_err(linear_error)?;
    // the source and detector vectors of the pulse module, on the network with every contact
    // sticking (the normal springs, which are all they use, do not depend on the branches)
    let assembly = AssemblyOptions { prestress: PreStress::None, rattlers: Rattlers::Keep, rattler_min_contacts: None, sliding: SlidingContacts::Stick, rolling: true };
    let dm = DynamicalMatrix::assemble(&snapshot, &assembly).map_err(linear_error)?;
    let system = dm.free_system(&gl::Constraints::new(), ZeroRows::Keep).map_err(linear_error)?;
    let free = system.free_dofs();
    let dofs = dm.dofs();
    if piston.is_some() {
        p.set_piston_velocity(setup.amplitude / piston.map_or(1.0, |pc| pc.mass)).map_err(linear_error)?;
    } else {
        let source = gl::pulse::source_vector(&dm, &system, setup.wall as u32).map_err(linear_error)?;
        let mut v = vec![0.0; dofs];
        for ((&k, s), m) in free.iter().zip(&source.vector).zip(system.mass()) {
            v[k] = setup.amplitude * s / m;
        }
        p.set_velocity(&v).map_err(linear_error)?;
    }
    let detector = match setup.detector {
        None => None,
        Some(w) => {
            let c = gl::pulse::detector_vector(&dm, &system, w as u32).map_err(linear_error)?;
            // a moving detector wall compresses its springs by its own displacement q
            let q_gain = if piston.is_some_and(|pc| pc.wall as usize == w) { c.stiffness_sum } else { 0.0 };
            Some((c.vector, q_gain))
        }
    };
    let n = snapshot.len();
    let dim = D::D;
    let per = dofs / n.max(1);
    let started = std::time::Instant::now();
    let mut velocity = Vec::with_capacity(times.len() * n * dim);
    let mut field = Vec::with_capacity(times.len() * n * 2);
    let mut signal = detector.as_ref().map(|_| Vec::with_capacity(times.len()));
    let mut piston_out = piston.map(|_| (Vec::with_capacity(times.len()), Vec::with_capacity(times.len())));
    let mut slipping = Vec::with_capacity(times.len());
    for &t in times {
        p.advance_to(t).map_err(linear_error)?;
        let v = p.velocity();
        for g in 0..n {
            let vg = D::Vector::from_slice(&v[g * per..g * per + dim]);
            velocity.extend_from_slice(&v[g * per..g * per + dim]);
            field.push(vg.dot(inward) as f32);
            field.push(0.0f32);
        }
        if let (Some(sig), Some((c, q_gain))) = (signal.as_mut(), detector.as_ref()) {
            let u = p.displacement();
            sig.push(free.iter().zip(c).map(|(&k, ck)| ck * u[k]).sum::<f64>() + q_gain * p.piston_state().0);
        }
        if let Some((q, qdot)) = piston_out.as_mut() {
            let (a, b) = p.piston_state();
            q.push(a);
            qdot.push(b);
        }
        slipping.push(p.slipping() as u64);
    }
    let seconds = started.elapsed().as_secs_f64();
    let distance: Vec<f64> = snapshot.pos.iter().map(|&x| wall.distance(x)).collect();
    let arrival = gw_e2::arrival::arrival_of_maximum(&field, n, times, 0);
    let fit = gw_e2::arrival::strip_speed(&distance, &arrival, setup.strips, setup.fit_range);
    let pairs = p
        .history()
        .iter()
        .map(|h| {
            let c = &snapshot.contacts[h.contact];
            (i64::from(c.i), c.j.signed_id())
        })
        .collect();
    Ok(IncrementalRun {
        ids: snapshot.id.iter().map(|&i| i64::from(i)).collect(),
        dim,
        positions: snapshot.pos.iter().flat_map(|x| (0..dim).map(move |k| x.get(k))).collect(),
        distance,
        velocity,
        signal,
        piston: piston_out,
        slipping,
        counts: p.counts(),
        history: p.history().to_vec(),
        pairs,
        arrival: arrival.iter().map(|a| a.unwrap_or(f64::NAN)).collect(),
        fit,
        steps: p.steps(),
        max_step: p.max_step(),
        seconds,
    })
}

/// The incremental (piecewise-linear) pulse of `grainwave_linear::incremental`: the δ pulse of
/// wall `wall` through the linearized network whose contacts at the Coulomb limit follow
/// `branches`, sampled at `times` (the pulse at t = 0).
#[pyfunction]
#[pyo3(signature = (sim, wall, times, amplitude=1.0, branches="incremental", piston_mass=None, detector_wall=None, rolling_cap=true, wall_damping=true, mobilisation_tolerance=DEFAULT_MOBILISATION_TOLERANCE, steps_per_period=50.0, strips=128, fit_range=(0.1, 0.9)))]
#[allow(clippy::too_many_arguments)]
pub fn incremental_pulse<'py>(
    py: Python<'py>,
    sim: PyRef<'py, Simulation>,
    wall: i64,
    times: &Bound<'py, PyAny>,
    amplitude: f64,
    branches: &str,
    piston_mass: Option<&Bound<'py, PyAny>>,
    detector_wall: Option<i64>,
    rolling_cap: bool,
    wall_damping: bool,
    mobilisation_tolerance: f64,
    steps_per_period: f64,
    strips: i64,
    fit_range: (f64, f64),
) -> PyResult<Bound<'py, PyDict>> {
    let walls = match sim.engine() {
        AnySimulation::D2(s) => s.domain.walls.len(),
        AnySimulation::D3(s) => s.domain.walls.len(),
    };
    let wall_index = |name: &str, w: i64| -> PyResult<usize> {
        if w >= 0 && (w as usize) < walls {
            Ok(w as usize)
        } else {
            Err(PyValueError::new_err(format!("{name} = {w} (allowed: a wall index 0 to {}, the order of the config's [[walls]])", walls as i64 - 1)))
        }
    };
    let wall = wall_index("wall", wall)?;
    let detector = detector_wall.map(|w| wall_index("detector_wall", w)).transpose()?;
    if !amplitude.is_finite() {
        return Err(PyValueError::new_err(format!("amplitude = {amplitude} (allowed: a finite number)")));
    }
    let rule = branch_rule(branches)?;
    let kick = kick_of(piston_mass)?;
    if strips < 1 {
        return Err(PyValueError::new_err(format!("strips = {strips} (allowed: an integer ≥ 1)")));
    }
    let (a, b) = fit_range;
    if !(0.0 <= a && a < b && b <= 1.0) {
        return Err(PyValueError::new_err(format!("fit_range = ({a}, {b}) (allowed: fractions 0 ≤ a < b ≤ 1)")));
    }
    // the ranges of IncrementalOptions::validate, named as this function's arguments
    if !(mobilisation_tolerance.is_finite() && (0.0..1.0).contains(&mobilisation_tolerance)) {
        return Err(PyValueError::new_err(format!("mobilisation_tolerance = {mobilisation_tolerance} (allowed: a number in [0, 1))")));
    }
    if !(steps_per_period.is_finite() && steps_per_period > std::f64::consts::PI) {
        return Err(PyValueError::new_err(format!("steps_per_period = {steps_per_period} (allowed: a number > π; velocity Verlet is stable for ω dt < 2)")));
    }
    let options = IncrementalOptions { branches: rule, mobilisation_tolerance, rolling_cap, wall_damping, steps_per_period };
    let t = read_times(py, times)?;
    if let Some(&t0) = t.first() {
        if t0 < 0.0 {
            return Err(PyValueError::new_err(format!("times: entry [0] = {t0} is before the pulse (allowed: times ≥ 0)")));
        }
    }
    let setup = IncrementalSetup { wall, detector, kick, amplitude, options, strips: strips as usize, fit_range: [a, b] };
    let r = match sim.engine() {
        AnySimulation::D2(s) => py.detach(|| incremental_run(s, &setup, &t))?,
        AnySimulation::D3(s) => py.detach(|| incremental_run(s, &setup, &t))?,
    };
    let n = r.ids.len();
    let d = PyDict::new(py);
    d.set_item("times", PyArray1::from_vec(py, t.clone()))?;
    d.set_item("velocity", PyArray1::from_vec(py, r.velocity).reshape([t.len(), n, r.dim])?)?;
    d.set_item("grain_ids", PyArray1::from_vec(py, r.ids))?;
    d.set_item("positions", PyArray1::from_vec(py, r.positions).reshape([n, r.dim])?)?;
    d.set_item("distance", PyArray1::from_vec(py, r.distance))?;
    d.set_item("arrival", PyArray1::from_vec(py, r.arrival))?;
    match &r.fit {
        Some(f) => {
            let fit = PyDict::new(py);
            fit.set_item("speed", f.speed)?;
            fit.set_item("intercept", f.intercept)?;
            fit.set_item("strips_used", f.strips_used)?;
            fit.set_item("distance", PyArray1::from_vec(py, f.distance.clone()))?;
            fit.set_item("time", PyArray1::from_vec(py, f.time.clone()))?;
            d.set_item("fit", fit)?;
        }
        None => d.set_item("fit", py.None())?,
    }
    match r.signal {
        Some(sig) => d.set_item("signal", PyArray1::from_vec(py, sig))?,
        None => d.set_item("signal", py.None())?,
    }
    match r.piston {
        Some((q, qdot)) => {
            d.set_item("piston_displacement", PyArray1::from_vec(py, q))?;
            d.set_item("piston_velocity", PyArray1::from_vec(py, qdot))?;
        }
        None => {
            d.set_item("piston_displacement", py.None())?;
            d.set_item("piston_velocity", py.None())?;
        }
    }
    d.set_item("slipping", PyArray1::from_vec(py, r.slipping))?;
    let c = PyDict::new(py);
    c.set_item("contacts", r.counts.contacts)?;
    c.set_item("at_limit", r.counts.at_limit)?;
    c.set_item("at_rolling_cap", r.counts.at_rolling_cap)?;
    c.set_item("nearly_open_1e6", r.counts.nearly_open_1e6)?;
    c.set_item("nearly_open_1e3", r.counts.nearly_open_1e3)?;
    c.set_item("mean_normal_force", r.counts.mean_normal_force)?;
    c.set_item("unloaded", r.counts.unloaded)?;
    c.set_item("slipped", r.history.iter().filter(|h| h.first_slip.is_some()).count())?;
    d.set_item("counts", c)?;
    let h = PyDict::new(py);
    let hs = &r.history;
    h.set_item("contact", PyArray1::from_vec(py, hs.iter().map(|x| x.contact as i64).collect::<Vec<_>>()))?;
    h.set_item("i", PyArray1::from_vec(py, r.pairs.iter().map(|x| x.0).collect::<Vec<_>>()))?;
    h.set_item("j", PyArray1::from_vec(py, r.pairs.iter().map(|x| x.1).collect::<Vec<_>>()))?;
    h.set_item("slip_steps", PyArray1::from_vec(py, hs.iter().map(|x| x.slip_steps).collect::<Vec<_>>()))?;
    h.set_item("switches", PyArray1::from_vec(py, hs.iter().map(|x| x.switches).collect::<Vec<_>>()))?;
    h.set_item("first_slip", PyArray1::from_vec(py, hs.iter().map(|x| x.first_slip.unwrap_or(f64::NAN)).collect::<Vec<_>>()))?;
    h.set_item("last_switch", PyArray1::from_vec(py, hs.iter().map(|x| x.last_switch.unwrap_or(f64::NAN)).collect::<Vec<_>>()))?;
    h.set_item("slipping", PyArray1::from_vec(py, hs.iter().map(|x| x.slipping).collect::<Vec<_>>()))?;
    d.set_item("history", h)?;
    d.set_item("branches", rule.name())?;
    d.set_item("steps", r.steps)?;
    d.set_item("max_step", r.max_step)?;
    d.set_item("wall_seconds", r.seconds)?;
    Ok(d)
}
