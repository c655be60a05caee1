//! What every protocol shares: where outputs go, how progress is reported, how a run is
//! interrupted and checkpointed, and how it resumes.
//!
//! A protocol's whole state is one serializable value. It is written to `checkpoint.gwck` in the
//! output directory periodically, when the run is interrupted (Ctrl-C / SIGTERM: the current step
//! is completed first) and at the end. `grainwave resume DIR` reads it back and continues; since
//! the engine is deterministic and every protocol event happens at fixed step numbers, the
//! resumed run produces the same bits as an uninterrupted one.

use crate::error::{ExperimentError, Result};
use grainwave_core::sim::{Control, Progress, RunHooks};
use serde::{de::DeserializeOwned, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Name of the checkpoint file in an output directory.
pub const CHECKPOINT_FILE: &str = "checkpoint.gwck";
/// Name of the log file in an output directory.
pub const LOG_FILE: &str = "run.log";

/// Receives progress; the CLI draws bars, a library user can do anything (or nothing).
pub trait Reporter: Send {
    /// A stage starts (e.g. "relaxation"); `total_steps` is its step budget when known.
    fn stage(&mut self, name: &str, total_steps: Option<u64>);
    /// Progress of the current stage.
    fn progress(&mut self, p: &Progress);
    /// Progress of an ensemble: `done` samples of `total`.
    fn samples(&mut self, done: usize, total: usize);
    /// A line of information for the user.
    fn message(&mut self, text: &str);
}

/// A reporter that shows nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct SilentReporter;

impl Reporter for SilentReporter {
    fn stage(&mut self, _: &str, _: Option<u64>) {}
    fn progress(&mut self, _: &Progress) {}
    fn samples(&mut self, _: usize, _: usize) {}
    fn message(&mut self, _: &str) {}
}

/// The environment of a running protocol.
pub struct RunContext<'a> {
    out: PathBuf,
    /// Where progress goes.
    pub reporter: &'a mut dyn Reporter,
    interrupt: Arc<AtomicBool>,
    /// Report progress at least every this many steps (0: only at stop-criterion checks). Has no
    /// influence on results.
    pub report_every: u64,
    log: Option<std::fs::File>,
    started: std::time::Instant,
}

impl<'a> RunContext<'a> {
    /// A context writing into `out` (created if needed), reporting to `reporter`, stopping when
    /// `interrupt` becomes true.
    pub fn new(out: &Path, reporter: &'a mut dyn Reporter, interrupt: Arc<AtomicBool>) -> Result<Self> {
        std::fs::create_dir_all(out).map_err(|e| grainwave_core::CoreError::Io {
            action: "cannot create the output directory".into(),
            path: out.display().to_string(),
            error: e,
        })?;
        let log_path = out.join(LOG_FILE);
        let log = std::fs::OpenOptions::new().create(true).append(true).open(&log_path).ok();
        Ok(RunContext { out: out.to_path_buf(), reporter, interrupt, report_every: 1000, log, started: std::time::Instant::now() })
    }

    /// The output directory.
    pub fn out_dir(&self) -> &Path {
        &self.out
    }

    /// Path of a file in the output directory.
    pub fn path(&self, name: &str) -> PathBuf {
        self.out.join(name)
    }

    /// True once an interrupt was requested.
    pub fn interrupted(&self) -> bool {
        self.interrupt.load(Ordering::Relaxed)
    }

    /// Appends a line to `run.log` (wall-clock seconds since the start of this process) and
    /// shows it through the reporter.
    pub fn log(&mut self, text: &str) {
        if let Some(f) = self.log.as_mut() {
            let _ = writeln!(f, "[{:9.2} s] {text}", self.started.elapsed().as_secs_f64());
        }
        self.reporter.message(text);
    }

    /// Appends a line to `run.log` only.
    pub fn log_quiet(&mut self, text: &str) {
        if let Some(f) = self.log.as_mut() {
            let _ = writeln!(f, "[{:9.2} s] {text}", self.started.elapsed().as_secs_f64());
        }
    }

    /// Seconds since the context was created.
    pub fn elapsed(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// The interrupt flag, for protocols that run several simulations at once and poll it from
    /// each of them.
    pub fn interrupt_flag(&self) -> Arc<AtomicBool> {
        self.interrupt.clone()
    }

    /// Runs `f` with engine hooks that forward progress to the reporter and poll the interrupt
    /// flag.
    pub fn with_hooks<R>(&mut self, f: impl FnOnce(&mut RunHooks<'_>) -> R) -> R {
        let flag = self.interrupt.clone();
        let reporter = &mut *self.reporter;
        let mut observer = |p: &Progress| {
            reporter.progress(p);
            Control::Continue
        };
        let mut hooks = RunHooks { observer: &mut observer, report_every: self.report_every, interrupt: Some(&flag) };
        f(&mut hooks)
    }

    /// Writes the protocol state `state` under content tag `tag` to the checkpoint file
    /// (atomically).
    pub fn save_checkpoint<T: Serialize>(&mut self, tag: &str, state: &T) -> Result<PathBuf> {
        let path = self.path(CHECKPOINT_FILE);
        grainwave_core::checkpoint::save(&path, tag, state)?;
        Ok(path)
    }

    /// Saves the state and returns the "interrupted" error.
    pub fn interrupted_error<T: Serialize>(&mut self, tag: &str, state: &T) -> ExperimentError {
        match self.save_checkpoint(tag, state) {
            Ok(checkpoint) => {
                self.log(&format!("interrupted: state saved in {}", checkpoint.display()));
                ExperimentError::Interrupted { checkpoint, dir: self.out.clone() }
            }
            Err(e) => e,
        }
    }
}

/// Reads the content tag of the checkpoint of output directory `dir` (or of a checkpoint file).
pub fn checkpoint_tag(path: &Path) -> Result<(PathBuf, String)> {
    let file = if path.is_dir() { path.join(CHECKPOINT_FILE) } else { path.to_path_buf() };
    if !file.exists() {
        return Err(ExperimentError::Resume {
            path: path.to_path_buf(),
            reason: format!("no `{CHECKPOINT_FILE}` there (was the run started with `grainwave run … --out {}`?)", path.display()),
        });
    }
    let bytes = std::fs::read(&file).map_err(|e| grainwave_core::CoreError::Io {
        action: "cannot read".into(),
        path: file.display().to_string(),
        error: e,
    })?;
    let (tag, _) = grainwave_core::checkpoint::verify(&bytes, &file.display().to_string())?;
    Ok((file, tag))
}

/// Loads a protocol state with content tag `tag`.
pub fn load_state<T: DeserializeOwned>(file: &Path, tag: &str) -> Result<T> {
    Ok(grainwave_core::checkpoint::load(file, tag)?)
}
