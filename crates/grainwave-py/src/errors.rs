//! The exceptions of the module and the mapping of the library's errors onto them.
//!
//! * `ConfigError(ValueError)`: an invalid config; carries `file`, `line`, `column` (1-based, 0
//!   when unknown), `key` (the key path, or `None`) and `message` (what is wrong and what is
//!   allowed), the same fields the command line prints.
//! * `Interrupted(KeyboardInterrupt)`: a run stopped by Ctrl-C (or by an exception of the progress
//!   callback) after saving its state; carries `checkpoint` and `dir` (`grainwave.resume(dir)`
//!   continues bit for bit).
//! * `RunError(RuntimeError)`: the run failed (numerical blow-up, every sample failed, an output
//!   not writable…).
//! * `ValueError`: other bad input (a directory that cannot be resumed or used, a checkpoint that
//!   cannot be read, an array of the wrong shape, a non-finite value).

use grainwave_experiments::config::ConfigError as LibConfigError;
use grainwave_experiments::engine::core::CoreError;
use grainwave_experiments::ExperimentError;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(grainwave, ConfigError, PyValueError, "An invalid config: `key`, `line`, `column`, `file` and `message` say where and what.");
pyo3::create_exception!(
    grainwave,
    Interrupted,
    PyKeyboardInterrupt,
    "A run interrupted (Ctrl-C) after saving its state: `dir` and `checkpoint`; `grainwave.resume(dir)` continues it."
);
pyo3::create_exception!(grainwave, RunError, PyRuntimeError, "A run that failed (numerical blow-up, every unit failed, outputs not writable).");

/// The message of an error followed by its causes ("a: b"), skipping causes the text already
/// ends with.
pub fn chain(e: &dyn std::error::Error) -> String {
    grainwave_experiments::config::compact_numbers(&grainwave_experiments::error_chain(e, ": "))
}

/// `grainwave.ConfigError` with its fields set.
pub fn config_error(py: Python<'_>, e: &LibConfigError) -> PyErr {
    let err = ConfigError::new_err(e.to_string());
    let value = err.value(py);
    let set = |name: &str, v: Bound<'_, PyAny>| {
        let _ = value.setattr(name, v);
    };
    set("file", e.file.clone().into_pyobject(py).expect("str").into_any());
    set("line", e.line.into_pyobject(py).expect("int").into_any());
    set("column", e.column.into_pyobject(py).expect("int").into_any());
    set("key", e.key.clone().into_pyobject(py).expect("str or None").into_any());
    set("message", e.message.clone().into_pyobject(py).expect("str").into_any());
    err
}

/// The Python exception for an error of a run or of its input.
pub fn experiment_error(py: Python<'_>, e: &ExperimentError) -> PyErr {
    match e {
        ExperimentError::Config(c) => config_error(py, c),
        ExperimentError::Interrupted { checkpoint, dir } => {
            let err = Interrupted::new_err(e.to_string());
            let value = err.value(py);
            let _ = value.setattr("checkpoint", checkpoint.clone());
            let _ = value.setattr("dir", dir.clone());
            err
        }
        e if e.is_input_error() => PyValueError::new_err(chain(e)),
        e => RunError::new_err(chain(e)),
    }
}

/// The Python exception for an engine error: bad input as `ValueError`, the rest as `RunError`.
pub fn core_error(e: &CoreError) -> PyErr {
    match e {
        CoreError::InvalidParameter { .. } | CoreError::UnknownName { .. } | CoreError::Inconsistent(_) | CoreError::InitialOverlap { .. } | CoreError::Checkpoint { .. } => {
            PyValueError::new_err(chain(e))
        }
        e => RunError::new_err(chain(e)),
    }
}
