//! `grainwave.Simulation`: one engine simulation, built from a `simulation` config or loaded from
//! a checkpoint (a simulation's, or a state a study stored: an E1 packing, an E2 strain
//! checkpoint, an E3 reference state), stepped from Python; its grains as read-only NumPy arrays
//! (copies, in the order of the grains' stable ids), its contact records as a dict of arrays
//! (`grainwave._tables.Columns`), checkpoints in the engine's own format.

use crate::errors::{config_error, core_error, not_found, RunError};
use crate::study::{event_dict, pool, source, AllowLarge, Event};
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
use pyo3::exceptions::PyValueError;
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

/// `a` made read-only (`flags.writeable = False`): a property such as `sim.positions` is a copy
/// of the state, and an assignment into it (`sim.positions[0] = …`) would change nothing, so it
/// raises NumPy's "assignment destination is read-only" instead of doing nothing.
fn frozen(a: Bound<'_, PyAny>) -> PyResult<Bound<'_, PyAny>> {
    a.getattr("flags")?.setattr("writeable", false)?;
    Ok(a)
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
/// `checkpoint.gwck` of a `simulation` run, or that run's output directory; or a state a study
/// stored: an E1 packing (`samples/<group>/s<seed>/packing.gwck`, also `preparing.gwck`), an E2
/// strain checkpoint stored in full (`checkpoints/ck-<k>.gwck`, a replay's `final.gwck`), an E3
/// reference state.
fn load_any(path: &std::path::Path) -> grainwave_experiments::Result<AnySimulation> {
    use grainwave_experiments::{e1, e2, e3};
    let (file, tag) = grainwave_experiments::protocol::checkpoint_tag(path)?;
    use grainwave_experiments::protocol::load_state as load;
    match tag.as_str() {
        t if t == simulation::TAG => {
            let state: SimulationState = load(&file, &tag)?;
            Ok(state.sim)
        }
        e1::ensemble::PACKING_TAG | e1::ensemble::PREPARING_TAG => {
            let packing: e1::prepare::PackingFile = load(&file, &tag)?;
            Ok(packing.sim)
        }
        e2::biaxial::CHECKPOINT_TAG | e2::biaxial::COMPRESSED_TAG | e2::biaxial::REFERENCE_TAG => match e2::biaxial::read_checkpoint(&file)? {
            e2::biaxial::StoredCheckpoint::Full(ck) => Ok(AnySimulation::D2(ck.sim)),
            e2::biaxial::StoredCheckpoint::Reference(r) => Err(gc::CoreError::Checkpoint {
                path: file.display().to_string(),
                reason: format!(
                    "an E2 strain checkpoint kept as a reference (the state at step {} is regenerated from full checkpoint {} by the loading, which only the study runs); load that full checkpoint (`ck-{:06}.gwck`) instead",
                    r.step, r.base, r.base
                ),
            }
            .into()),
        },
        e3::work::REFERENCE_TAG => {
            let reference: e3::work::ReferenceResult = load(&file, &tag)?;
            Ok(AnySimulation::D2(reference.sim))
        }
        _ => Ok(gc::checkpoint::load_simulation(&file).map_err(|e| match e {
            gc::CoreError::Checkpoint { path, reason } => gc::CoreError::Checkpoint {
                path,
                reason: format!(
                    "{reason} (allowed: a simulation saved by Simulation.save, a `simulation` run's checkpoint or directory, an E1 packing.gwck, an E2 strain checkpoint, an E3 reference state)"
                ),
            },
            e => e,
        })?),
    }
}

/// The checkpoint tag of a simulation in dimension `D`.
fn tag_of<D: Dim>(_: &Engine<D>) -> String {
    gc::checkpoint::simulation_tag::<D>()
}

/// The engine state in the checkpoint format (what `save` writes; for pickling).
fn to_bytes(sim: &AnySimulation) -> Result<Vec<u8>, gc::CoreError> {
    on!(sim, s => gc::checkpoint::encode(&tag_of(s), s))
}

/// The engine state of checkpoint bytes written by [`to_bytes`].
fn from_bytes(bytes: &[u8]) -> Result<AnySimulation, gc::CoreError> {
    use grainwave_experiments::engine::{D2, D3};
    let what = "<pickled Simulation>";
    let (tag, _) = gc::checkpoint::verify(bytes, what)?;
    if tag == gc::checkpoint::simulation_tag::<D2>() {
        Ok(AnySimulation::D2(gc::checkpoint::decode(bytes, &tag, what)?))
    } else if tag == gc::checkpoint::simulation_tag::<D3>() {
        Ok(AnySimulation::D3(gc::checkpoint::decode(bytes, &tag, what)?))
    } else {
        Err(gc::CoreError::Checkpoint { path: what.into(), reason: format!("holds `{tag}`, not a simulation") })
    }
}

#[pymethods]
impl Simulation {
    /// Builds a simulation from a `simulation` config (a path, a TOML string or a dict): grains
    /// placed, contacts and forces computed, not stepped. `allow_large=True` lifts the soft
    /// limits on sizes (the command line's `--allow-large`).
    #[new]
    #[pyo3(signature = (config, *, allow_large=false))]
    fn new(py: Python<'_>, config: &Bound<'_, PyAny>, allow_large: bool) -> PyResult<Self> {
        let (path, name, text): (Option<PathBuf>, String, Option<String>) = py.import("grainwave._config")?.call_method1("normalize", (config,))?.extract()?;
        let name = name.as_str();
        let src = source(py, path, name, text)?;
        let _lifted = AllowLarge::new(allow_large);
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
    /// a `simulation` run, or from that run's output directory; or a state a study stored: an E1
    /// packing (`samples/<group>/s<seed>/packing.gwck`), an E2 strain checkpoint stored in full
    /// (`checkpoints/ck-<k>.gwck`), an E3 reference state. A path that does not exist raises
    /// `FileNotFoundError` (also a `ValueError`).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        if !path.exists() {
            return Err(not_found(py, "PathNotFoundError", &path, &format!("cannot load `{}`: no such file or directory", path.display())));
        }
        let sim = py.detach(|| load_any(&path)).map_err(|e| crate::errors::experiment_error(py, &e))?;
        Ok(Self::from_any(sim, None))
    }

    /// A deep copy: the same state, bit for bit, evolving on its own (both continue to the same
    /// bits); the stop criteria of the config come along.
    fn copy(&self) -> Self {
        Self::from_any(self.sim.clone(), self.stop.clone())
    }

    fn __copy__(&self) -> Self {
        self.copy()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.copy()
    }

    /// Pickling: the state in the engine's checkpoint format (as `save` writes it; the stop
    /// criteria of the config are not kept).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyAny>,))> {
        let bytes = py.detach(|| to_bytes(&self.sim)).map_err(|e| core_error(&e))?;
        let cls = py.import("grainwave._native")?.getattr("Simulation")?.getattr("_from_checkpoint_bytes")?;
        Ok((cls, (pyo3::types::PyBytes::new(py, &bytes).into_any(),)))
    }

    /// A simulation from the bytes of a checkpoint (the inverse of pickling).
    #[staticmethod]
    fn _from_checkpoint_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Self> {
        let sim = py.detach(|| from_bytes(data)).map_err(|e| core_error(&e))?;
        Ok(Self::from_any(sim, None))
    }

    /// Saves the complete state (atomically) in the engine's checkpoint format; `load` continues
    /// it bit for bit.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| on!(&self.sim, s => s.save_checkpoint(&path))).map_err(|e| core_error(&e))
    }

    /// Advances by `n` steps (a whole number ≥ 0) with the GIL released. Ctrl-C stops between
    /// two steps (the state is then that of a whole number of steps) and raises
    /// `KeyboardInterrupt`. `progress`: None, True (a tqdm bar, or lines on stderr) or a callable
    /// receiving the event dicts of `grainwave.run` (a "stage" named "step", then "progress"
    /// every 1000 steps); it changes no bit of the result.
    #[pyo3(signature = (n = None, *, progress = None))]
    fn step(&mut self, py: Python<'_>, n: Option<&Bound<'_, PyAny>>, progress: Option<Bound<'_, PyAny>>) -> PyResult<()> {
        // n = None (the default): one step
        let n = n.map_or(Ok(1), |n| whole_steps(py, "n", n))?;
        let shown = Shown::open(py, progress.as_ref())?;
        let first = self.step_count();
        shown.stage(py, "step", first, Some(first.saturating_add(n)))?;
        let mut left = n;
        let result = (|| {
            while left > 0 {
                let chunk = left.min(STEP_CHUNK);
                let sim = &mut self.sim;
                py.detach(|| on!(sim, s => if chunk == 1 { s.step() } else { s.steps(chunk) })).map_err(|e| core_error(&e))?;
                left -= chunk;
                if shown.on() {
                    let stop = StopCriteria { step_limit: Some(first.saturating_add(n)), ..StopCriteria::default() };
                    let p = on!(&self.sim, s => s.progress(&stop));
                    shown.progress(py, &p)?;
                }
                if left > 0 {
                    py.check_signals()?;
                }
            }
            Ok(())
        })();
        shown.close(py)?;
        result
    }

    /// Runs until the stop criteria hold (the engine's `[stop]` keys; without any, those of the
    /// config the simulation was built from), with the GIL released; Ctrl-C stops after the
    /// current step and raises `KeyboardInterrupt`. Returns {"reason", "steps"} ("steps": the
    /// steps this call made).
    ///
    /// `step_limit` and `time_limit` are the simulation's step count and time at which the run
    /// stops, counted from its start (step 0, t = 0) like the config's `[stop]` keys — not from
    /// this call: on a simulation at step 700, `run_until(step_limit=1000)` makes 300 steps, and
    /// one already past the limit makes none. The equilibrium criteria (`max_acceleration`,
    /// `mean_acceleration`, `kinetic_energy_per_grain`, `network_unchanged_steps`,
    /// `no_sliding`) are checked every `check_every` steps, not before `not_before_time`.
    /// `progress`: None, True or a callable, as for `grainwave.run` (a "stage" named
    /// "run_until" whose `total_steps` is the step limit when the run can only end there, None
    /// when an equilibrium criterion may end it sooner; "progress" every 1000 steps and at each
    /// check); it changes no bit of the result.
    #[pyo3(signature = (*, step_limit=None, time_limit=None, max_acceleration=None, mean_acceleration=None, kinetic_energy_per_grain=None, network_unchanged_steps=None, no_sliding=false, check_every=0, not_before_time=None, threads=None, progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn run_until<'py>(
        &mut self,
        py: Python<'py>,
        step_limit: Option<&Bound<'py, PyAny>>,
        time_limit: Option<f64>,
        max_acceleration: Option<f64>,
        mean_acceleration: Option<f64>,
        kinetic_energy_per_grain: Option<f64>,
        network_unchanged_steps: Option<u64>,
        no_sliding: bool,
        check_every: u64,
        not_before_time: Option<f64>,
        threads: Option<usize>,
        progress: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let step_limit = step_limit.map(|v| whole_steps(py, "step_limit", v)).transpose()?;
        let given = StopCriteria { step_limit, time_limit, max_acceleration, mean_acceleration, kinetic_energy_per_grain, network_unchanged_steps, no_sliding, check_every, not_before_time };
        let stop = if given == StopCriteria::default() {
            self.stop.clone().ok_or_else(|| PyValueError::new_err("run_until: no stop criteria given, and this simulation was not built from a config that has them (give e.g. step_limit= or time_limit=)"))?
        } else {
            given
        };
        stop.validate().map_err(|e| core_error(&e))?;
        let pool = pool(threads)?;
        let shown = Shown::open(py, progress.as_ref())?;
        let first = self.step_count();
        // a bar's total only where the run cannot end before it
        let total = stop.certain_end();
        if let Err(e) = shown.stage(py, "run_until", first, total) {
            shown.close(py)?;
            return Err(e);
        }
        let report_every = if shown.on() { STEP_CHUNK } else { 0 };
        let interrupt = AtomicBool::new(false);
        let (tx, rx) = std::sync::mpsc::channel::<gc::sim::Progress>();
        let sim = &mut self.sim;
        let outcome = std::thread::scope(|scope| {
            let flag = &interrupt;
            let worker = scope.spawn(move || {
                let mut go = || {
                    on!(sim, s => {
                        let mut observer = |p: &gc::sim::Progress| {
                            if report_every > 0 {
                                let _ = tx.send(*p);
                            }
                            gc::sim::Control::Continue
                        };
                        let mut hooks = RunHooks { observer: &mut observer, report_every, interrupt: Some(flag) };
                        s.run_with(&stop, &mut hooks)
                    })
                };
                match &pool {
                    Some(p) => p.install(go),
                    None => go(),
                }
            });
            let mut raised: Option<PyErr> = None;
            let deliver = |raised: &mut Option<PyErr>| {
                // of the reports since the last look only the latest
                if let (Some(p), None) = (rx.try_iter().last(), raised.as_ref()) {
                    if let Err(e) = shown.progress(py, &p) {
                        flag.store(true, Ordering::SeqCst);
                        *raised = Some(e);
                    }
                }
            };
            while !worker.is_finished() {
                py.detach(|| std::thread::sleep(Duration::from_millis(20)));
                deliver(&mut raised);
                if let Err(e) = py.check_signals() {
                    flag.store(true, Ordering::SeqCst);
                    raised.get_or_insert(e);
                }
            }
            let r = py.detach(|| worker.join());
            deliver(&mut raised);
            (r, raised)
        });
        let closed = shown.close(py);
        let (result, raised) = outcome;
        let outcome = result.map_err(|_| RunError::new_err("internal error (a panic in the run)"))?.map_err(|e| core_error(&e))?;
        if let Some(e) = raised {
            // Ctrl-C, or an exception of the progress callback (the run stopped after a whole step)
            return Err(e);
        }
        closed?;
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
    fn ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let ids: Vec<i64> = on!(&self.sim, s => { let o = id_order(s); o.iter().map(|&k| i64::from(s.grains.id[k])).collect() });
        frozen(PyArray1::from_vec(py, ids).into_any())
    }

    /// Positions, shape (n, d) (wrapped into the periodic cell).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.pos));
        frozen(array(py, flat, len)?.reshape_or(py, self.__len__(), len)?)
    }

    /// Velocities, shape (n, d).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.vel));
        frozen(array(py, flat, len)?.reshape_or(py, self.__len__(), len)?)
    }

    /// Angular velocities: shape (n,) in 2D, (n, 3) in 3D.
    #[getter]
    fn angular_velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.omega));
        frozen(array(py, flat, len)?)
    }

    /// Total forces of the last force evaluation (contacts, gravity, external), shape (n, d).
    /// Velocity Verlet evaluates the forces of a step at the half-step velocities, so under
    /// damping (dashpots at the contacts or walls) they differ slightly from the sum of the
    /// contact records of `contacts()`, which use the current velocities; after
    /// `set_velocities(sim.velocities)` the two agree.
    #[getter]
    fn forces<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.force));
        frozen(array(py, flat, len)?.reshape_or(py, self.__len__(), len)?)
    }

    /// Total torques: shape (n,) in 2D, (n, 3) in 3D.
    #[getter]
    fn torques<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.torque));
        frozen(array(py, flat, len)?)
    }

    /// Radii, shape (n,).
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.radius));
        frozen(array(py, flat, len)?)
    }

    /// Masses, shape (n,).
    #[getter]
    fn masses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.mass));
        frozen(array(py, flat, len)?)
    }

    /// Moments of inertia, shape (n,).
    #[getter]
    fn inertias<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (flat, len) = on!(&self.sim, s => per_grain(s, &s.grains.inertia));
        frozen(array(py, flat, len)?)
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
    /// −F_n n̂ + F_t. The dict (a `dict` with `to_pandas()` and `records()`, the columns split
    /// into `normal_x`, `normal_y`…) is a new copy at each call, its arrays writable.
    fn contacts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let d = on!(&self.sim, s => contacts(py, s))?;
        py.import("grainwave._tables")?.getattr("Columns")?.call1((d,))
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

/// A number of steps given to `step` or `run_until`: a whole number ≥ 0 (a negative one is a
/// `ValueError` naming the argument, not the `OverflowError` of an unsigned conversion).
fn whole_steps(py: Python<'_>, what: &str, value: &Bound<'_, PyAny>) -> PyResult<u64> {
    let refuse = || {
        let shown = value.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".into());
        PyValueError::new_err(format!("{what} = {shown} (allowed: a whole number of steps ≥ 0, at most {})", u64::MAX))
    };
    if value.is_instance_of::<pyo3::types::PyBool>() {
        return Err(refuse());
    }
    let index = py.import("operator")?.call_method1("index", (value,)).map_err(|_| refuse())?;
    index.extract::<u64>().map_err(|_| refuse())
}

/// The progress display of `step`/`run_until`: the callable that `grainwave._progress.make`
/// returns for `progress` (None: nothing shown) and its `close`.
struct Shown<'py> {
    callback: Option<Bound<'py, PyAny>>,
    close: Option<Bound<'py, PyAny>>,
}

impl<'py> Shown<'py> {
    fn open(py: Python<'py>, progress: Option<&Bound<'py, PyAny>>) -> PyResult<Self> {
        let Some(p) = progress.filter(|p| !p.is_none()) else { return Ok(Shown { callback: None, close: None }) };
        let (callback, close): (Option<Bound<'py, PyAny>>, Bound<'py, PyAny>) = py.import("grainwave._progress")?.call_method1("make", (p,))?.extract()?;
        Ok(Shown { callback, close: Some(close) })
    }

    fn on(&self) -> bool {
        self.callback.is_some()
    }

    /// The "stage" event: `name`, `total_steps` (the step count at which it ends, None when
    /// unknown) and `first_step` (the step count it starts from).
    fn stage(&self, py: Python<'py>, name: &str, first: u64, total: Option<u64>) -> PyResult<()> {
        if let Some(cb) = &self.callback {
            let d = event_dict(py, &Event::Stage(name.to_string(), total))?;
            d.set_item("first_step", first)?;
            cb.call1((d,))?;
        }
        Ok(())
    }

    fn progress(&self, py: Python<'py>, p: &gc::sim::Progress) -> PyResult<()> {
        if let Some(cb) = &self.callback {
            cb.call1((event_dict(py, &Event::Progress(*p))?,))?;
        }
        Ok(())
    }

    fn close(&self, _py: Python<'py>) -> PyResult<()> {
        if let Some(c) = &self.close {
            c.call0()?;
        }
        Ok(())
    }
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
