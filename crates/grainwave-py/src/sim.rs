//! `grainwave.Simulation`: one engine simulation, built from a `simulation` config or loaded from
//! a checkpoint, stepped from Python; its grains as NumPy arrays (copies, in the order of the
//! grains' stable ids), its contact records as a dict of arrays, checkpoints in the engine's own
//! format.

use crate::errors::{config_error, core_error, RunError};
use crate::study::{pool, source};
use grainwave_experiments::engine::core as gc;
use grainwave_experiments::engine::{Dim, Simulation as Engine};
use grainwave_experiments::registry;
use grainwave_experiments::study::Protocol;
use grainwave_experiments::engine::AnySimulation;
use grainwave_experiments::simulation::{self, SimulationState};
use gc::dim::VectorOps;
use gc::sim::{ExternalLoad, RunHooks, StopCriteria};
use gc::snapshot::Counterpart;
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Steps between two looks at Python's signals during `step(n)` (Ctrl-C stops between two
/// steps; the number of steps per call does not change the result).
const STEP_CHUNK: u64 = 1000;

macro_rules! on {
    ($sim:expr, $s:ident => $body:expr) => {
        match $sim {
            AnySimulation::D2($s) => $body,
            AnySimulation::D3($s) => $body,
        }
    };
}

/// Storage slots in the order of the grains' stable ids (the engine re-sorts grains for locality).
fn id_order<D: Dim>(s: &Engine<D>) -> Vec<usize> {
    let mut order: Vec<usize> = (0..s.len()).collect();
    order.sort_by_key(|&k| s.grains.id[k]);
    order
}

/// `values` in id order as a flat row-major buffer and the number of components per grain.
fn flatten<V: VectorOps>(values: &[V], order: &[usize]) -> Vec<f64> {
    let mut out = Vec::with_capacity(order.len() * V::LEN);
    for &k in order {
        for c in 0..V::LEN {
            out.push(values[k].get(c));
        }
    }
    out
}

/// A NumPy array of shape (n,) for one component, (n, len) otherwise.
fn array<'py>(py: Python<'py>, flat: Vec<f64>, len: usize) -> PyResult<Bound<'py, PyAny>> {
    let n = flat.len() / len.max(1);
    let a = PyArray1::from_vec(py, flat);
    if len == 1 {
        Ok(a.into_any())
    } else {
        Ok(a.reshape([n, len])?.into_any())
    }
}

/// Reads `value` as an array of `rows` × `cols` finite float64 (`cols` = 1: shape (rows,) or
/// (rows, 1)); errors name `what`, the shape given and the shape expected, or the first
/// non-finite entry.
fn read_array(py: Python<'_>, value: &Bound<'_, PyAny>, what: &str, rows: usize, cols: usize) -> PyResult<Vec<f64>> {
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", np.getattr("float64")?)?;
    let converted = np
        .call_method("ascontiguousarray", (value,), Some(&kwargs))
        .map_err(|e| PyValueError::new_err(format!("{what}: cannot be read as an array of numbers ({})", e.value(py))))?;
    let arr = converted.cast::<PyArrayDyn<f64>>().map_err(|e| PyValueError::new_err(format!("{what}: not an array of float64 ({e})")))?;
    let shape = arr.shape().to_vec();
    let expected = if cols == 1 { format!("({rows},)") } else { format!("({rows}, {cols})") };
    let ok = match shape.as_slice() {
        [n] => cols == 1 && *n == rows,
        [n, m] => *n == rows && *m == cols,
        _ => false,
    };
    if !ok {
        // as Python writes a shape: (2,), (40, 3)
        let given = match shape.as_slice() {
            [n] => format!("({n},)"),
            _ => format!("({})", shape.iter().map(|s| s.to_string()).collect::<Vec<_>>().join(", ")),
        };
        return Err(PyValueError::new_err(format!("{what}: shape {given} given, {expected} expected (one row per grain, in the order of the grain ids)")));
    }
    let ro = arr.readonly();
    let data = ro.as_slice().map_err(|e| PyValueError::new_err(format!("{what}: {e}")))?.to_vec();
    if let Some(k) = data.iter().position(|v| !v.is_finite()) {
        let (row, col) = (k / cols, k % cols);
        let at = if cols == 1 { format!("[{row}]") } else { format!("[{row}, {col}]") };
        return Err(PyValueError::new_err(format!("{what}: entry {at} is {} (allowed: finite numbers)", data[k])));
    }
    Ok(data)
}

/// One discrete-element simulation (2D or 3D).
#[pyclass(module = "grainwave._native")]
pub struct Simulation {
    sim: AnySimulation,
    /// The stop criteria of the config it was built from (`run_until()` without criteria).
    stop: Option<StopCriteria>,
}

impl Simulation {
    fn from_any(sim: AnySimulation, stop: Option<StopCriteria>) -> Self {
        Simulation { sim, stop }
    }

    /// The engine simulation.
    pub(crate) fn engine(&self) -> &AnySimulation {
        &self.sim
    }
}

/// A per-grain field of `s` in id order, flat, and its number of components.
fn per_grain<D: Dim, V: VectorOps>(s: &Engine<D>, values: &[V]) -> (Vec<f64>, usize) {
    (flatten(values, &id_order(s)), V::LEN)
}

/// Writes `data` (id order, `V::LEN` per grain) into `field` (storage order).
fn scatter<D: Dim, V: VectorOps>(s: &Engine<D>, data: &[f64]) -> Vec<V> {
    let order = id_order(s);
    let mut out = vec![V::ZERO; s.len()];
    for (row, &k) in order.iter().enumerate() {
        out[k] = V::from_slice(&data[row * V::LEN..(row + 1) * V::LEN]);
    }
    out
}

/// Sets positions (wrapped into the periodic cell, image counters restarted) and refreshes the
/// neighbor list and forces; on an error the simulation is left as it was.
fn set_positions<D: Dim>(s: &mut Engine<D>, data: &[f64]) -> PyResult<()> {
    let before = s.clone();
    let mut pos: Vec<D::Vector> = scatter(s, data);
    for (k, x) in pos.iter_mut().enumerate() {
        let mut image = [0i32; 3];
        s.domain.wrap(x, &mut image);
        s.grains.image[k] = image;
    }
    s.grains.pos = pos;
    s.refresh().map_err(|e| {
        *s = before;
        core_error(&e)
    })
}

fn refresh_after<D: Dim>(s: &mut Engine<D>, change: impl FnOnce(&mut Engine<D>)) -> PyResult<()> {
    let before = s.clone();
    change(s);
    s.refresh_forces().map_err(|e| {
        *s = before;
        core_error(&e)
    })
}

fn contacts<'py, D: Dim>(py: Python<'py>, s: &Engine<D>) -> PyResult<Bound<'py, PyDict>> {
    let records = s.contact_records();
    let d = PyDict::new(py);
    let m = records.len();
    let vec = |f: &dyn Fn(&gc::snapshot::ContactRecord<D>) -> D::Vector| {
        let mut out = Vec::with_capacity(m * D::D);
        for r in &records {
            let v = f(r);
            for c in 0..D::D {
                out.push(v.get(c));
            }
        }
        out
    };
    let scalar = |f: &dyn Fn(&gc::snapshot::ContactRecord<D>) -> f64| records.iter().map(f).collect::<Vec<f64>>();
    d.set_item("i", PyArray1::from_vec(py, records.iter().map(|r| i64::from(r.i)).collect::<Vec<i64>>()))?;
    d.set_item("j", PyArray1::from_vec(py, records.iter().map(|r| if let Counterpart::Grain(j) = r.j { i64::from(j) } else { -1 }).collect::<Vec<i64>>()))?;
    d.set_item("wall", PyArray1::from_vec(py, records.iter().map(|r| if let Counterpart::Wall(w) = r.j { i64::from(w) } else { -1 }).collect::<Vec<i64>>()))?;
    d.set_item("normal", array(py, vec(&|r| r.normal), D::D)?.reshape_or(py, m, D::D)?)?;
    d.set_item("branch", array(py, vec(&|r| r.branch), D::D)?.reshape_or(py, m, D::D)?)?;
    d.set_item("overlap", PyArray1::from_vec(py, scalar(&|r| r.overlap)))?;
    d.set_item("normal_force", PyArray1::from_vec(py, scalar(&|r| r.normal_force)))?;
    d.set_item("tangential_force", array(py, vec(&|r| r.tangential_force), D::D)?.reshape_or(py, m, D::D)?)?;
    d.set_item("normal_stiffness", PyArray1::from_vec(py, scalar(&|r| r.normal_stiffness)))?;
    d.set_item("tangential_stiffness", PyArray1::from_vec(py, scalar(&|r| r.tangential_stiffness)))?;
    d.set_item("lever_i", PyArray1::from_vec(py, scalar(&|r| r.lever_i)))?;
    d.set_item("lever_j", PyArray1::from_vec(py, scalar(&|r| r.lever_j)))?;
    d.set_item("sliding", PyArray1::from_vec(py, records.iter().map(|r| r.sliding).collect::<Vec<bool>>()))?;
    Ok(d)
}

/// An empty (0, d) array stays two-dimensional.
trait ReshapeOr<'py> {
    fn reshape_or(self, py: Python<'py>, rows: usize, cols: usize) -> PyResult<Bound<'py, PyAny>>;
}

impl<'py> ReshapeOr<'py> for Bound<'py, PyAny> {
    fn reshape_or(self, py: Python<'py>, rows: usize, cols: usize) -> PyResult<Bound<'py, PyAny>> {
        let _ = py;
        self.call_method1("reshape", ((rows, cols),))
    }
}

/// Loads the engine state of a checkpoint: a simulation saved by `Simulation.save`, the
/// `checkpoint.gwck` of a `simulation` run, or that run's output directory.
fn load_any(path: &std::path::Path) -> grainwave_experiments::Result<AnySimulation> {
    let (file, tag) = grainwave_experiments::protocol::checkpoint_tag(path)?;
    if tag == simulation::TAG {
        let state: SimulationState = grainwave_experiments::protocol::load_state(&file, &tag)?;
        return Ok(state.sim);
    }
    Ok(match gc::checkpoint::load_simulation(&file)? {
        gc::checkpoint::AnySimulation::D2(s) => AnySimulation::D2(s),
        gc::checkpoint::AnySimulation::D3(s) => AnySimulation::D3(s),
    })
}

#[pymethods]
impl Simulation {
    /// Builds a simulation from a `simulation` config (a path, a TOML string or a dict): grains
    /// placed, contacts and forces computed, not stepped.
    #[new]
    fn new(py: Python<'_>, config: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (path, name, text): (Option<PathBuf>, String, Option<String>) = py.import("grainwave._config")?.call_method1("normalize", (config,))?.extract()?;
        let name = name.as_str();
        let src = source(path, name, text).map_err(|e| config_error(py, &e))?;
        let experiment = registry::experiment_name(&src).map_err(|e| config_error(py, &e))?;
        if experiment != <simulation::SimulationProtocol as Protocol>::NAME {
            let e = src.error_at_key("experiment", format!("`{experiment}` is a study: a Simulation is built from `experiment = \"simulation\"` (run a study with grainwave.run)"));
            return Err(config_error(py, &e));
        }
        py.detach(|| registry::check(&src)).map_err(|e| config_error(py, &e))?;
        let prepared = py.detach(|| simulation::prepare(&src)).map_err(|e| config_error(py, &e))?;
        Ok(Self::from_any(prepared.sim, Some(prepared.config.stop)))
    }

    /// Loads a simulation from a checkpoint file written by `save`, from the `checkpoint.gwck` of
    /// a `simulation` run, or from that run's output directory.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let sim = py.detach(|| load_any(&path)).map_err(|e| crate::errors::experiment_error(py, &e))?;
        Ok(Self::from_any(sim, None))
    }

    /// Saves the complete state (atomically) in the engine's checkpoint format; `load` continues
    /// it bit for bit.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| on!(&self.sim, s => s.save_checkpoint(&path))).map_err(|e| core_error(&e))
    }

    /// Advances by `n` steps with the GIL released. Ctrl-C stops between two steps (the state is
    /// then that of a whole number of steps) and raises `KeyboardInterrupt`.
    #[pyo3(signature = (n = 1))]
    fn step(&mut self, py: Python<'_>, n: u64) -> PyResult<()> {
        let mut left = n;
        while left > 0 {
            let chunk = left.min(STEP_CHUNK);
            let sim = &mut self.sim;
            py.detach(|| on!(sim, s => if chunk == 1 { s.step() } else { s.steps(chunk) })).map_err(|e| core_error(&e))?;
            left -= chunk;
            if left > 0 {
                py.check_signals()?;
            }
        }
        Ok(())
    }

    /// Runs until the stop criteria hold (the engine's `[stop]` keys; without any, those of the
    /// config the simulation was built from), with the GIL released; Ctrl-C stops after the
    /// current step and raises `KeyboardInterrupt`. Returns {"reason", "steps"}.
    #[pyo3(signature = (*, step_limit=None, time_limit=None, max_acceleration=None, mean_acceleration=None, kinetic_energy_per_grain=None, network_unchanged_steps=None, no_sliding=false, check_every=0, not_before_time=None, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn run_until<'py>(
        &mut self,
        py: Python<'py>,
        step_limit: Option<u64>,
        time_limit: Option<f64>,
        max_acceleration: Option<f64>,
        mean_acceleration: Option<f64>,
        kinetic_energy_per_grain: Option<f64>,
        network_unchanged_steps: Option<u64>,
        no_sliding: bool,
        check_every: u64,
        not_before_time: Option<f64>,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let given = StopCriteria { step_limit, time_limit, max_acceleration, mean_acceleration, kinetic_energy_per_grain, network_unchanged_steps, no_sliding, check_every, not_before_time };
        let stop = if given == StopCriteria::default() {
            self.stop.clone().ok_or_else(|| PyValueError::new_err("run_until: no stop criteria given, and this simulation was not built from a config that has them (give e.g. step_limit= or time_limit=)"))?
        } else {
            given
        };
        stop.validate().map_err(|e| core_error(&e))?;
        let pool = pool(threads)?;
        let interrupt = AtomicBool::new(false);
        let sim = &mut self.sim;
        let outcome = std::thread::scope(|scope| {
            let flag = &interrupt;
            let worker = scope.spawn(move || {
                let mut go = || {
                    on!(sim, s => {
                        let mut observer = |_: &gc::sim::Progress| gc::sim::Control::Continue;
                        let mut hooks = RunHooks { observer: &mut observer, report_every: 0, interrupt: Some(flag) };
                        s.run_with(&stop, &mut hooks)
                    })
                };
                match &pool {
                    Some(p) => p.install(go),
                    None => go(),
                }
            });
            let mut raised = None;
            while !worker.is_finished() {
                py.detach(|| std::thread::sleep(Duration::from_millis(20)));
                if let Err(e) = py.check_signals() {
                    flag.store(true, Ordering::SeqCst);
                    raised.get_or_insert(e);
                }
            }
            let r = py.detach(|| worker.join());
            (r, raised)
        });
        let (result, raised) = outcome;
        let outcome = result.map_err(|_| RunError::new_err("internal error (a panic in the run)"))?.map_err(|e| core_error(&e))?;
        if let Some(e) = raised {
            if e.is_instance_of::<PyKeyboardInterrupt>(py) {
                return Err(e);
            }
        }
        let d = PyDict::new(py);
        let reason = match outcome.reason {
            gc::sim::StopReason::Converged => "converged",
            gc::sim::StopReason::StepLimit => "step_limit",
            gc::sim::StopReason::TimeLimit => "time_limit",
            gc::sim::StopReason::Interrupted => "interrupted",
        };
        d.set_item("reason", reason)?;
        d.set_item("steps", outcome.steps)?;
        Ok(d)
    }

    /// 2 or 3.
    #[getter]
    fn dimension(&self) -> usize {
        on!(&self.sim, s => dim_of(s))
    }

    fn __len__(&self) -> usize {
        on!(&self.sim, s => s.len())
    }

    /// Steps done.
    #[getter]
    fn step_count(&self) -> u64 {
        on!(&self.sim, s => s.step)
    }

    /// Simulated time.
    #[getter]
    fn time(&self) -> f64 {
        on!(&self.sim, s => s.time)
    }

    /// Time step.
    #[getter]
    fn dt(&self) -> f64 {
        on!(&self.sim, s => s.dt)
    }

    /// Grain kind ("disk", "sphere", …).
    #[getter]
    fn grain_kind(&self) -> &'static str {
        on!(&self.sim, s => s.grains.kind.name())
    }

    /// Hash of the complete dynamical state (equal hashes: same bits).
    #[getter]
    fn state_hash(&self) -> u64 {
        on!(&self.sim, s => s.state_hash())
    }

    /// Kinetic energy (translation and rotation).
    #[getter]
    fn kinetic_energy(&self) -> f64 {
        on!(&self.sim, s => s.kinetic_energy())
    }

    /// Elastic energy stored in the contacts.
    #[getter]
    fn elastic_energy(&self) -> f64 {
        on!(&self.sim, s => s.elastic_energy())
    }

    /// Warnings raised by the engine so far.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        on!(&self.sim, s => s.warnings.clone())
    }

    /// Stable grain ids, in the order of every per-grain array (ascending).
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let ids: Vec<i64> = on!(&self.sim, s => { let o = id_order(s); o.iter().map(|&k| i64::from(s.grains.id[k])).collect() });
        PyArray1::from_vec(py, ids)
    }

    /// Positions, shape (n, d) (wrapped into the periodic cell).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.pos));
        array(py, flat, len)?.reshape_or(py, self.__len__(), len)
    }

    /// Velocities, shape (n, d).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.vel));
        array(py, flat, len)?.reshape_or(py, self.__len__(), len)
    }

    /// Angular velocities: shape (n,) in 2D, (n, 3) in 3D.
    #[getter]
    fn angular_velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.omega));
        array(py, flat, len)
    }

    /// Total forces of the last force evaluation (contacts, gravity, external), shape (n, d).
    #[getter]
    fn forces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.force));
        array(py, flat, len)?.reshape_or(py, self.__len__(), len)
    }

    /// Total torques: shape (n,) in 2D, (n, 3) in 3D.
    #[getter]
    fn torques<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.torque));
        array(py, flat, len)
    }

    /// Radii, shape (n,).
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.radius));
        array(py, flat, len)
    }

    /// Masses, shape (n,).
    #[getter]
    fn masses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.mass));
        array(py, flat, len)
    }

    /// Moments of inertia, shape (n,).
    #[getter]
    fn inertias<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.inertia));
        array(py, flat, len)
    }

    /// Sets the positions (shape (n, d), id order, finite); positions along periodic axes are
    /// wrapped into the cell. The neighbor list and forces are recomputed (time and contact
    /// histories unchanged).
    fn set_positions(&mut self, py: Python<'_>, positions: &Bound<'_, PyAny>) -> PyResult<()> {
        let (n, d) = (self.__len__(), self.dimension());
        let data = read_array(py, positions, "positions", n, d)?;
        on!(&mut self.sim, s => set_positions(s, &data))
    }

    /// Sets the velocities (shape (n, d), id order, finite); forces are recomputed (damping
    /// depends on velocities).
    fn set_velocities(&mut self, py: Python<'_>, velocities: &Bound<'_, PyAny>) -> PyResult<()> {
        let (n, d) = (self.__len__(), self.dimension());
        let data = read_array(py, velocities, "velocities", n, d)?;
        on!(&mut self.sim, s => refresh_after(s, |s| s.grains.vel = scatter(s, &data)))
    }

    /// Sets the angular velocities (shape (n,) in 2D, (n, 3) in 3D; id order, finite).
    fn set_angular_velocities(&mut self, py: Python<'_>, angular_velocities: &Bound<'_, PyAny>) -> PyResult<()> {
        let n = self.__len__();
        let cols = if self.dimension() == 2 { 1 } else { 3 };
        let data = read_array(py, angular_velocities, "angular_velocities", n, cols)?;
        on!(&mut self.sim, s => refresh_after(s, |s| s.grains.omega = scatter(s, &data)))
    }

    /// Replaces every external load by constant forces (shape (n, d)) and, optionally, torques
    /// (shape (n,) in 2D, (n, 3) in 3D) on the grains, in id order; rows of zeros load nothing.
    #[pyo3(signature = (forces, torques=None))]
    fn set_external_forces(&mut self, py: Python<'_>, forces: &Bound<'_, PyAny>, torques: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
        let (n, d) = (self.__len__(), self.dimension());
        let f = read_array(py, forces, "forces", n, d)?;
        let rot = if d == 2 { 1 } else { 3 };
        let t = match torques {
            Some(t) => read_array(py, t, "torques", n, rot)?,
            None => vec![0.0; n * rot],
        };
        on!(&mut self.sim, s => refresh_after(s, |s| s.loads = loads(s, &f, &t)))
    }

    /// The contact records of the current state: a dict of arrays, one entry per contact —
    /// `i` (grain id), `j` (grain id, −1 for a wall), `wall` (wall index, −1 for a grain),
    /// `normal` n̂ from i towards j (m, d), `branch` (m, d), `overlap` ξ, `normal_force` F_n ≥ 0,
    /// `tangential_force` F_t on i (m, d), `normal_stiffness` k_n = dF_n/dξ,
    /// `tangential_stiffness` k_t, `lever_i`, `lever_j` and `sliding` (bool). The force on i is
    /// −F_n n̂ + F_t.
    fn contacts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        on!(&self.sim, s => contacts(py, s))
    }

    /// Writes VTK snapshots of the current state under `dir` — `snapshots/grains_<step>.vtp`
    /// (grains) and `snapshots/contacts_<step>.vtp` (contact network), the files and bytes a
    /// `simulation` run writes for the same state (ParaView reads them) — and returns their
    /// paths.
    fn write_snapshot(&self, py: Python<'_>, dir: PathBuf) -> PyResult<(PathBuf, PathBuf)> {
        let [g, c] = py
            .detach(|| on!(&self.sim, s => simulation::write_snapshot_in(&dir, s)))
            .map_err(|e| crate::errors::experiment_error(py, &e))?;
        Ok((g, c))
    }

    fn __repr__(&self) -> String {
        on!(&self.sim, s => format!("<grainwave.Simulation {}D, {} {} grains, step {}, t = {:e}>", dim_of(s), s.len(), s.grains.kind.name(), s.step, s.time))
    }
}

fn dim_of<D: Dim>(_: &Engine<D>) -> usize {
    D::D
}

/// Constant loads from per-grain forces and torques in id order (zero rows load nothing).
fn loads<D: Dim>(s: &Engine<D>, f: &[f64], t: &[f64]) -> Vec<ExternalLoad<D>> {
    let force: Vec<D::Vector> = scatter(s, f);
    let torque: Vec<D::AngVector> = scatter(s, t);
    let order = id_order(s);
    order
        .iter()
        .filter(|&&k| force[k].norm2() > 0.0 || torque[k].norm2() > 0.0)
        .map(|&k| ExternalLoad { grain: s.grains.id[k], force: force[k], torque: torque[k], profile: gc::domain::TimeFunction::Constant { value: 1.0 } })
        .collect()
}
