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
//! * A path that does not exist raises an exception that is both a `FileNotFoundError` and what
//!   it was before (a `ConfigError` for a config file, a `ValueError` for a checkpoint or an
//!   output directory): the classes of `grainwave/_errors.py`.
//!
//! The library's messages name the command line's flags and commands (`--overwrite`,
//! `grainwave resume DIR`); [`python_words`] turns them into the Python calls and keyword
//! arguments that do the same, so that every message reaching Python names something Python has.

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
/// ends with, in Python's words ([`python_words`]).
pub fn chain(e: &dyn std::error::Error) -> String {
    python_words(&grainwave_experiments::config::compact_numbers(&grainwave_experiments::error_chain(e, ": ")))
}

/// `text` with the command line's commands and flags, written in backquotes, replaced by the
/// Python calls and keyword arguments that do the same: `` `grainwave resume out/x` `` →
/// `` `grainwave.resume("out/x")` ``, `` `--overwrite` `` → `` `overwrite=True` ``,
/// `` `--allow-large` `` → `` `allow_large=True` ``, `` `--out` `` → `` `out` ``,
/// `` `grainwave run CONFIG --out d --overwrite` `` → `` `grainwave.run(config, out="d", overwrite=True)` ``.
/// Other code spans (keys, file names) are left as they are.
pub fn python_words(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for (k, part) in text.split('`').enumerate() {
        if k > 0 {
            out.push('`');
        }
        // odd parts are inside backquotes
        if k % 2 == 1 {
            out.push_str(&python_span(part));
        } else {
            out.push_str(part);
        }
    }
    out
}

/// One code span of [`python_words`].
fn python_span(span: &str) -> String {
    let quoted = |s: &str| format!("{s:?}");
    // a placeholder of the command line's usage line, or a path (which may hold spaces)
    let positional = |s: &str, command: &str| match s {
        "CONFIG" | "config" => "config".to_string(),
        "DIR" | "dir" => "dir".to_string(),
        "…" | "..." => if command == "resume" { "dir".to_string() } else { "config".to_string() },
        path => quoted(path),
    };
    let argument = |flag: &str, value: &str, command: &str| {
        let name = flag.trim_start_matches("--").replace('-', "_");
        if value.is_empty() {
            format!("{name}=True")
        } else {
            format!("{name}={}", positional(value, command))
        }
    };
    if let Some(rest) = span.strip_prefix("grainwave ") {
        let (command, rest) = rest.split_once(' ').unwrap_or((rest, ""));
        if matches!(command, "run" | "resume" | "check") {
            // "PATH --flag VALUE --switch": the parts between the flags
            let mut parts = rest.split(" --");
            let first = parts.next().unwrap_or("").trim();
            let mut args = Vec::new();
            let mut flags: Vec<&str> = parts.collect();
            if let Some(f) = first.strip_prefix("--") {
                flags.insert(0, f);
            } else if !first.is_empty() {
                args.push(positional(first, command));
            }
            for f in flags {
                let (flag, value) = f.split_once(' ').unwrap_or((f, ""));
                args.push(argument(flag, value.trim(), command));
            }
            return format!("grainwave.{command}({})", args.join(", "));
        }
    }
    match span.strip_prefix("--") {
        // an option that takes a value is an argument's name; a switch is `name=True`
        Some(flag) if !flag.is_empty() && !flag.contains(' ') => {
            let name = flag.replace('-', "_");
            if name == "out" || name == "threads" {
                name
            } else {
                format!("{name}=True")
            }
        }
        _ => span.to_string(),
    }
}

/// The key path `walls[1].mass` as the Python expression that reaches it in a dict config:
/// `config["walls"][1]["mass"]`.
fn dict_path(key: &str) -> String {
    let mut out = String::from("config");
    for part in key.split('.') {
        let (name, indices) = match part.find('[') {
            Some(at) => (&part[..at], &part[at..]),
            None => (part, ""),
        };
        if !name.is_empty() {
            out.push_str(&format!("[{:?}]", name.trim_matches('"')));
        }
        out.push_str(indices);
    }
    out
}

/// The command line's rendering of a config error — the lines of the file around the error and
/// a mark under the value, labelled with the key — without colours and without the header that
/// repeats the message; None when there is no position to show.
fn snippet(e: &LibConfigError) -> Option<String> {
    use miette::{GraphicalReportHandler, GraphicalTheme};
    miette::Diagnostic::source_code(e)?;
    let mut out = String::new();
    let handler = GraphicalReportHandler::new_themed(GraphicalTheme::unicode_nocolor()).with_width(100).with_links(false);
    handler.render_report(&mut out, e).ok()?;
    // the excerpt only: the exception's own line already says what the report's header says
    let lines: Vec<&str> = out.trim_end().lines().collect();
    let from = lines.iter().position(|l| l.contains("╭─["))?;
    Some(lines[from..].join("\n"))
}

/// `grainwave.ConfigError` with its fields set. A config given as a dict (`file` "<dict>") is
/// named by its key path (`line` and `column`, positions in the TOML text written from the dict,
/// are 0); for a file or a string, the command line's excerpt with a caret is the exception's
/// note (shown under the traceback) and its `snippet`.
pub fn config_error(py: Python<'_>, e: &LibConfigError) -> PyErr {
    let mut e = e.clone();
    e.message = python_words(&e.message);
    let from_dict = e.file == "<dict>" && e.key.is_some();
    let note = if from_dict { e.key.as_deref().map(|k| format!("in the dict: {}", dict_path(k))) } else { snippet(&e) };
    if from_dict {
        e.line = 0;
        e.column = 0;
    }
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
    set("snippet", note.clone().into_pyobject(py).expect("str or None").into_any());
    if let Some(n) = note {
        add_note(py, &err, &n);
    }
    err
}

/// Adds a note to an exception (`add_note` from Python 3.11, the `__notes__` list before).
pub fn add_note(py: Python<'_>, err: &PyErr, note: &str) {
    let value = err.value(py);
    if value.call_method1("add_note", (note,)).is_err() {
        let notes = value.getattr("__notes__").ok().and_then(|n| n.extract::<Vec<String>>().ok()).unwrap_or_default();
        let mut notes = notes;
        notes.push(note.to_string());
        let _ = value.setattr("__notes__", notes);
    }
}

/// An exception for `path`, which does not exist: an instance of the class `class_name` of
/// `grainwave._errors` (a `FileNotFoundError` that is also what the call raised before for it),
/// with `text` as its message.
pub fn not_found(py: Python<'_>, class_name: &str, path: &std::path::Path, text: &str) -> PyErr {
    let made = py.import("grainwave._errors").and_then(|m| m.getattr(class_name)).and_then(|cls| {
        let e = cls.call1((2i32, "No such file or directory", path.display().to_string()))?;
        e.setattr("text", text)?;
        Ok(PyErr::from_value(e))
    });
    made.unwrap_or_else(|e| e)
}

/// A config file that does not exist: a `ConfigError` (fields as for any other) that is also a
/// `FileNotFoundError`.
pub fn config_file_not_found(py: Python<'_>, e: &LibConfigError, path: &std::path::Path) -> PyErr {
    let err = not_found(py, "ConfigFileNotFoundError", path, &e.to_string());
    let value = err.value(py);
    let _ = value.setattr("file", e.file.clone());
    let _ = value.setattr("line", 0usize);
    let _ = value.setattr("column", 0usize);
    let _ = value.setattr("key", py.None());
    let _ = value.setattr("message", e.message.clone());
    let _ = value.setattr("snippet", py.None());
    err
}

/// The Python exception for an error of a run or of its input.
pub fn experiment_error(py: Python<'_>, e: &ExperimentError) -> PyErr {
    match e {
        ExperimentError::Config(c) => config_error(py, c),
        ExperimentError::Interrupted { checkpoint, dir } => {
            let err = Interrupted::new_err(python_words(&e.to_string()));
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
