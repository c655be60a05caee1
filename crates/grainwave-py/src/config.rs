//! `grainwave.read_config`: a TOML config file as a dict, on every Python the module supports
//! (the standard library reads TOML only from Python 3.11), and the private
//! `_python_words` that the tests use to check the translation of the library's messages.

use crate::errors::{config_error, python_words};
use crate::study::source;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;

/// A TOML value as a Python object: tables as dicts, arrays as lists, integers as int, floats as
/// float (inf and nan included), dates and times as their TOML text.
fn to_python<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => s.into_pyobject(py)?.into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => f.into_pyobject(py)?.into_any(),
        toml::Value::Boolean(b) => pyo3::types::PyBool::new(py, *b).to_owned().into_any(),
        toml::Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        toml::Value::Array(a) => {
            let list = PyList::empty(py);
            for x in a {
                list.append(to_python(py, x)?)?;
            }
            list.into_any()
        }
        toml::Value::Table(t) => table(py, t)?.into_any(),
    })
}

fn table<'py>(py: Python<'py>, t: &toml::Table) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (k, x) in t {
        d.set_item(k, to_python(py, x)?)?;
    }
    Ok(d)
}

/// Reads a config file (or TOML text) into a dict — to change a few keys and give it to `run`
/// or `Simulation`. A file that does not exist raises `FileNotFoundError` (a `ConfigError`); a
/// syntax error a `ConfigError` at its line and column. The keys are not validated here
/// (`grainwave.check` does that).
#[pyfunction]
#[pyo3(signature = (path, name, text))]
pub fn read_config<'py>(py: Python<'py>, path: Option<PathBuf>, name: &str, text: Option<String>) -> PyResult<Bound<'py, PyDict>> {
    let src = source(py, path, name, text)?;
    let parsed: toml::Table = src.parse().map_err(|e| config_error(py, &e))?;
    table(py, &parsed)
}

/// The message `text` in Python's words (tests only).
#[pyfunction]
pub fn _python_words(text: &str) -> String {
    python_words(text)
}
