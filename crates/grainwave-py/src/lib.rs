//! # grainwave-py
//!
//! The native part of the Python package `grainwave` (built by maturin, see `docs/python.md`):
//! the studies of the registry (`check`, `run`, `resume`), the engine's `Simulation` and the
//! linear analysis of its state (`grainwave.linear`), over
//! `grainwave-experiments` only. The Python package in `python/grainwave` turns configs given as
//! paths, TOML strings or dicts into what these functions take, reads the outputs of a run into
//! NumPy arrays and draws progress bars.
//!
//! The GIL is released while the engine computes; runs are the same bits as the command line's
//! for the same config (the same library calls, the same thread-count-independent engine).
#![warn(missing_docs)]

mod config;
mod errors;
mod linear;
mod sim;
mod study;

use pyo3::prelude::*;

/// The extension module `grainwave._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("ConfigError", py.get_type::<errors::ConfigError>())?;
    m.add("Interrupted", py.get_type::<errors::Interrupted>())?;
    m.add("RunError", py.get_type::<errors::RunError>())?;
    m.add("VERSION", grainwave_experiments::VERSION)?;
    m.add_function(wrap_pyfunction!(study::check, m)?)?;
    m.add_function(wrap_pyfunction!(study::run, m)?)?;
    m.add_function(wrap_pyfunction!(study::resume, m)?)?;
    m.add_function(wrap_pyfunction!(config::read_config, m)?)?;
    m.add_function(wrap_pyfunction!(config::_python_words, m)?)?;
    m.add_class::<sim::Simulation>()?;
    m.add_function(wrap_pyfunction!(linear::dynamical_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(linear::modes, m)?)?;
    m.add_function(wrap_pyfunction!(linear::moduli, m)?)?;
    m.add_function(wrap_pyfunction!(linear::modal_pulse, m)?)?;
    m.add_function(wrap_pyfunction!(linear::direct_pulse, m)?)?;
    m.add_function(wrap_pyfunction!(linear::incremental_pulse, m)?)?;
    Ok(())
}
