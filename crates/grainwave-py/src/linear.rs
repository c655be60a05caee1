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
use gl::moduli::{elastic_moduli, ModuliOptions};
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
