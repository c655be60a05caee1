//! Studies: `check`, `run` and `resume` of any protocol of the registry, as the command line does
//! them, with the GIL released during the run, progress sent to a Python callback and Ctrl-C
//! turned into the run's interrupt flag (the run finishes its current step, saves its state and
//! raises `grainwave.Interrupted`).

use crate::errors::{chain, config_error, config_file_not_found, experiment_error, not_found, RunError};
use grainwave_experiments::config::ConfigSource;
use grainwave_experiments::protocol::{failure_of, Reporter, RunContext, UsedDirectory};
use grainwave_experiments::registry::{self, RunSummary};
use grainwave_experiments::{ExperimentError, Progress};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, RecvTimeoutError, Sender};
use std::sync::Arc;
use std::time::Duration;

/// How often the waiting thread looks at Python's signals (Ctrl-C) while a run goes on.
const SIGNAL_POLL: Duration = Duration::from_millis(100);

/// The config as the module receives it: a file (named in errors by its path) or TOML text
/// (named `name`, e.g. "<dict>" or "<string>"). A file that does not exist raises a
/// `ConfigError` that is also a `FileNotFoundError`; other errors a `ConfigError`.
pub fn source(py: Python<'_>, path: Option<PathBuf>, name: &str, text: Option<String>) -> PyResult<ConfigSource> {
    match path {
        Some(p) => ConfigSource::from_file(&p).map_err(|e| {
            if !p.exists() && p.symlink_metadata().is_err() {
                config_file_not_found(py, &e, &p)
            } else {
                config_error(py, &e)
            }
        }),
        None => Ok(ConfigSource::from_text(name, text.unwrap_or_default())),
    }
}

/// While alive, the soft size limits are lifted (`allow_large=True`, the command line's
/// `--allow-large`). The limits are a setting of the process: a count of the calls that lift
/// them keeps them lifted until the last of those calls returns.
pub struct AllowLarge(bool);

static LIFTED: std::sync::Mutex<usize> = std::sync::Mutex::new(0);

impl AllowLarge {
    /// Lifts the limits when `on` (else does nothing).
    pub fn new(on: bool) -> Self {
        if on {
            let mut n = LIFTED.lock().unwrap_or_else(|e| e.into_inner());
            *n += 1;
            grainwave_experiments::limits::set_allow_large(true);
        }
        AllowLarge(on)
    }
}

impl Drop for AllowLarge {
    fn drop(&mut self) {
        if self.0 {
            let mut n = LIFTED.lock().unwrap_or_else(|e| e.into_inner());
            *n -= 1;
            if *n == 0 {
                grainwave_experiments::limits::set_allow_large(false);
            }
        }
    }
}

/// Validates a config; returns what `grainwave check` prints about it.
#[pyfunction]
#[pyo3(signature = (path, name, text, allow_large=false))]
pub fn check(py: Python<'_>, path: Option<PathBuf>, name: &str, text: Option<String>, allow_large: bool) -> PyResult<Vec<String>> {
    let src = source(py, path, name, text)?;
    let _lifted = AllowLarge::new(allow_large);
    py.detach(|| registry::check(&src)).map_err(|e| config_error(py, &e))
}

/// Validates and runs a config into `out`. Returns (report as JSON text, summary lines, output
/// directory).
#[pyfunction]
#[pyo3(signature = (path, name, text, out, overwrite, threads, progress, allow_large=false))]
#[allow(clippy::too_many_arguments)]
pub fn run(
    py: Python<'_>,
    path: Option<PathBuf>,
    name: &str,
    text: Option<String>,
    out: PathBuf,
    overwrite: bool,
    threads: Option<usize>,
    progress: Option<Bound<'_, PyAny>>,
    allow_large: bool,
) -> PyResult<(String, Vec<String>, PathBuf)> {
    let src = source(py, path, name, text)?;
    let _lifted = AllowLarge::new(allow_large);
    // validate before touching the output directory: a refused config changes nothing there
    py.detach(|| registry::check(&src)).map_err(|e| config_error(py, &e))?;
    let mode = if overwrite { UsedDirectory::Overwrite } else { UsedDirectory::Refuse };
    let summary = drive(py, &out, mode, threads, progress.as_ref(), |ctx| registry::run(&src, ctx))?;
    Ok((summary.report.to_string(), summary.lines, out))
}

/// Continues the run of output directory `dir` from its checkpoint (`retry`: also a run that
/// failed, after its cause was fixed).
#[pyfunction]
#[pyo3(signature = (dir, threads, progress, retry, allow_large=false))]
pub fn resume(py: Python<'_>, dir: PathBuf, threads: Option<usize>, progress: Option<Bound<'_, PyAny>>, retry: bool, allow_large: bool) -> PyResult<(String, Vec<String>, PathBuf)> {
    let text = format!("`{}` is not a directory (give the output directory of the run)", dir.display());
    if !dir.exists() {
        return Err(not_found(py, "PathNotFoundError", &dir, &text));
    }
    if !dir.is_dir() {
        return Err(PyValueError::new_err(text));
    }
    let _lifted = AllowLarge::new(allow_large);
    if let Some(why) = failure_of(&dir) {
        if !retry {
            let first = why.lines().next().unwrap_or("").to_string();
            let e = ExperimentError::Resume {
                path: dir.clone(),
                reason: format!("the run failed: {first} (see run.log; `grainwave.resume(dir, retry=True)` tries again)"),
            };
            return Err(experiment_error(py, &e));
        }
    }
    let summary = drive(py, &dir, UsedDirectory::Keep, threads, progress.as_ref(), |ctx| {
        ctx.clear_failed();
        registry::resume(&dir, ctx)
    })?;
    Ok((summary.report.to_string(), summary.lines, dir))
}

/// What the run's reporter sends to the thread that holds the GIL.
pub(crate) enum Event {
    Stage(String, Option<u64>),
    Progress(Progress),
    Units(usize, usize),
    Message(String),
}

/// A reporter that sends everything down a channel (the run's thread never touches Python).
struct ChannelReporter(Sender<Event>);

impl Reporter for ChannelReporter {
    fn stage(&mut self, name: &str, total_steps: Option<u64>) {
        let _ = self.0.send(Event::Stage(name.to_string(), total_steps));
    }
    fn progress(&mut self, p: &Progress) {
        let _ = self.0.send(Event::Progress(*p));
    }
    fn samples(&mut self, done: usize, total: usize) {
        let _ = self.0.send(Event::Units(done, total));
    }
    fn message(&mut self, text: &str) {
        let _ = self.0.send(Event::Message(text.to_string()));
    }
}

/// The dict the progress callback receives for an event.
pub(crate) fn event_dict<'py>(py: Python<'py>, e: &Event) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    match e {
        Event::Stage(name, total) => {
            d.set_item("kind", "stage")?;
            d.set_item("name", name)?;
            d.set_item("total_steps", *total)?;
        }
        Event::Progress(p) => {
            d.set_item("kind", "progress")?;
            d.set_item("step", p.step)?;
            d.set_item("time", p.time)?;
            d.set_item("kinetic_energy_per_grain", p.kinetic_energy_per_grain)?;
            d.set_item("max_acceleration", p.max_acceleration)?;
            d.set_item("mean_acceleration", p.mean_acceleration)?;
            d.set_item("contacts", p.contacts)?;
            d.set_item("sliding", p.sliding)?;
            d.set_item("fraction", p.fraction_of_limit)?;
        }
        Event::Units(done, total) => {
            d.set_item("kind", "units")?;
            d.set_item("done", *done)?;
            d.set_item("total", *total)?;
        }
        Event::Message(text) => {
            d.set_item("kind", "message")?;
            d.set_item("text", text)?;
        }
    }
    Ok(d)
}

/// A pool of `threads` workers, or none (the global pool: one worker per core).
pub fn pool(threads: Option<usize>) -> PyResult<Option<rayon::ThreadPool>> {
    match threads {
        None => Ok(None),
        Some(0) => Err(PyValueError::new_err("threads = 0: give a whole number ≥ 1 (or None: one per core); results are the same for any thread count")),
        Some(n) if n > 4 * std::thread::available_parallelism().map_or(1, usize::from).max(16) => Err(PyValueError::new_err(format!(
            "threads = {n} is more than this machine can use (allowed: 1 to {}); results are the same for any thread count",
            4 * std::thread::available_parallelism().map_or(1, usize::from).max(16)
        ))),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map(Some)
            .map_err(|e| RunError::new_err(format!("cannot start a pool of {n} worker threads: {e}"))),
    }
}

/// Runs `work` in a context on `out` on a thread of its own, with the GIL released. This thread
/// waits, delivering the progress events to `progress` (coalesced: of consecutive step reports
/// only the last) and polling Python's signals: a `KeyboardInterrupt` (Ctrl-C) or an exception of
/// the callback sets the run's interrupt flag; the run then saves its state and ends, and the
/// exception is raised (`grainwave.Interrupted` for Ctrl-C).
fn drive<F>(py: Python<'_>, out: &Path, mode: UsedDirectory, threads: Option<usize>, progress: Option<&Bound<'_, PyAny>>, work: F) -> PyResult<RunSummary>
where
    F: FnOnce(&mut RunContext<'_>) -> grainwave_experiments::Result<RunSummary> + Send,
{
    let pool = pool(threads)?;
    let interrupt = Arc::new(AtomicBool::new(false));
    let (tx, mut rx) = channel::<Event>();
    let flag = interrupt.clone();
    let out_owned = out.to_path_buf();
    std::thread::scope(|scope| {
        let worker = scope.spawn(move || -> grainwave_experiments::Result<RunSummary> {
            let mut reporter = ChannelReporter(tx);
            let mut ctx = RunContext::open(&out_owned, &mut reporter, flag, mode)?;
            let result = match &pool {
                Some(p) => p.install(|| work(&mut ctx)),
                // enter the global pool once for the whole run, as the command line does
                None => rayon::scope(|_| work(&mut ctx)),
            };
            if let Err(e) = &result {
                ctx.mark_failed(e);
            }
            result
        });
        // the first exception seen while waiting (Ctrl-C or the callback's)
        let mut raised: Option<PyErr> = None;
        let stop = |raised: &mut Option<PyErr>, e: PyErr| {
            interrupt.store(true, Ordering::SeqCst);
            if raised.is_none() {
                *raised = Some(e);
            }
        };
        loop {
            let (back, first) = py.detach(move || {
                let r = rx.recv_timeout(SIGNAL_POLL);
                (rx, r)
            });
            rx = back;
            let done = match first {
                Ok(e) => {
                    let mut batch = vec![e];
                    batch.extend(rx.try_iter());
                    if let (Some(cb), true) = (progress, raised.is_none()) {
                        for (k, e) in batch.iter().enumerate() {
                            // of consecutive step reports only the last
                            if matches!(e, Event::Progress(_)) && matches!(batch.get(k + 1), Some(Event::Progress(_))) {
                                continue;
                            }
                            if let Err(err) = event_dict(py, e).and_then(|d| cb.call1((d,))) {
                                stop(&mut raised, err);
                                break;
                            }
                        }
                    }
                    false
                }
                Err(RecvTimeoutError::Timeout) => false,
                Err(RecvTimeoutError::Disconnected) => true,
            };
            if let Err(e) = py.check_signals() {
                stop(&mut raised, e);
            }
            if done {
                break;
            }
        }
        let result = py.detach(|| worker.join());
        let result = match result {
            Ok(r) => r,
            Err(panic) => {
                let what = panic.downcast_ref::<String>().cloned().or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_default();
                return Err(RunError::new_err(format!("internal error (a panic in the run): {what}")));
            }
        };
        match (result, raised) {
            (Ok(summary), None) => Ok(summary),
            // Ctrl-C: the run saved its state; raise the library's Interrupted (a KeyboardInterrupt)
            (Err(e @ ExperimentError::Interrupted { .. }), Some(err)) if err.is_instance_of::<pyo3::exceptions::PyKeyboardInterrupt>(py) => Err(experiment_error(py, &e)),
            // the callback raised: its exception, with the saved state named in a note
            (Err(e @ ExperimentError::Interrupted { .. }), Some(err)) => {
                let note = format!("grainwave: the run stopped; {}", chain(&e));
                let _ = err.value(py).call_method1("add_note", (note,));
                Err(err)
            }
            (Err(e), _) => Err(experiment_error(py, &e)),
            // finished before the interrupt took effect: still raise what was raised
            (Ok(_), Some(err)) => Err(err),
        }
    })
}
