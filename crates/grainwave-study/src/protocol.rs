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
pub const CHECKPOINT_FILE: &str = crate::outputs::CHECKPOINT.pattern;
/// Name of the log file in an output directory.
pub const LOG_FILE: &str = crate::outputs::LOG.pattern;
/// Name of the lock file in an output directory: held (an advisory `flock`-style lock) by the
/// process running in the directory, released by the system when that process ends in any way,
/// so a lock is never stale.
pub const LOCK_FILE: &str = crate::outputs::LOCK.pattern;
/// Name of the marker of a failed run (a numerical blow-up, every sample failed…): it holds the
/// diagnosis. `grainwave inspect` reports it; `grainwave resume` refuses the directory unless
/// told `--retry`.
pub const FAILED_FILE: &str = crate::outputs::FAILED.pattern;
/// Files whose presence marks a directory as a grainwave output directory.
pub const OUTPUT_MARKERS: &[&str] = &[CHECKPOINT_FILE, LOG_FILE, FAILED_FILE, crate::outputs::RESOLVED_CONFIG_FILE, crate::outputs::SUMMARY_FILE];

/// The diagnosis recorded in `dir`'s failure marker, if the run there failed.
pub fn failure_of(dir: &Path) -> Option<String> {
    // a regular file only, and only its first 64 KiB (the text is clipped to 2 000 characters):
    // a FIFO or an endless file in the directory must not hang `inspect` or `resume`
    let path = dir.join(FAILED_FILE);
    if !std::fs::metadata(&path).ok()?.is_file() {
        return Some(format!("{FAILED_FILE} is not a regular file (remove it to use the directory)"));
    }
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut std::io::Read::take(std::fs::File::open(&path).ok()?, 64 << 10), &mut bytes).ok()?;
    Some(crate::config::clip(String::from_utf8_lossy(&bytes).trim(), 2000))
}

/// What a new run does with a directory that holds the outputs of an earlier run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UsedDirectory {
    /// Use it as it is: files of the same name are replaced (the demo; a resume).
    Keep,
    /// Refuse (exit code 2), naming `--overwrite` and `resume`.
    Refuse,
    /// Remove its contents first.
    Overwrite,
}

/// Takes the lock of output directory `out` (which exists): refused with
/// [`ExperimentError::Busy`] while another process holds it.
fn lock_directory(out: &Path) -> Result<std::fs::File> {
    let path = out.join(LOCK_FILE);
    let io = |action: &str, e| grainwave_core::CoreError::Io { action: action.into(), path: path.display().to_string(), error: e };
    let mut f = std::fs::OpenOptions::new().create(true).truncate(false).read(true).write(true).open(&path).map_err(|e| io("cannot create the lock file", e))?;
    match f.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            let mut holder = String::new();
            let _ = std::io::Read::read_to_string(&mut f, &mut holder);
            let holder = holder.trim().chars().take(40).collect::<String>();
            return Err(ExperimentError::Busy { dir: out.to_path_buf(), holder });
        }
        // a file system without locks: run unguarded rather than not at all
        Err(std::fs::TryLockError::Error(_)) => return Ok(f),
    }
    let _ = f.set_len(0);
    let _ = write!(f, "pid {}", std::process::id());
    Ok(f)
}

/// Applies `mode` to the locked directory `out`.
fn prepare_directory(out: &Path, mode: UsedDirectory) -> Result<()> {
    if mode == UsedDirectory::Keep {
        return Ok(());
    }
    let io = |e| grainwave_core::CoreError::Io { action: "cannot list".into(), path: out.display().to_string(), error: e };
    let entries: Vec<std::fs::DirEntry> = std::fs::read_dir(out).map_err(io)?.collect::<std::io::Result<_>>().map_err(io)?;
    let others: Vec<&std::fs::DirEntry> = entries.iter().filter(|e| e.file_name() != LOCK_FILE).collect();
    if others.is_empty() {
        return Ok(());
    }
    let ours = OUTPUT_MARKERS.iter().any(|m| out.join(m).exists());
    if !ours {
        return Err(ExperimentError::UsedDirectory {
            dir: out.to_path_buf(),
            reason: format!("it holds {} file(s) that are not grainwave outputs; give a new or empty directory (`--overwrite` clears only grainwave output directories)", others.len()),
        });
    }
    if mode == UsedDirectory::Refuse && !out.join(CHECKPOINT_FILE).exists() && !out.join(crate::outputs::SUMMARY_FILE).exists() {
        return Err(ExperimentError::UsedDirectory {
            dir: out.to_path_buf(),
            reason: "it holds the start of an earlier run that stopped before it saved anything (no `checkpoint.gwck`: nothing to resume); start it again with `--overwrite`, or give another `--out`".into(),
        });
    }
    if mode == UsedDirectory::Refuse {
        return Err(ExperimentError::UsedDirectory {
            dir: out.to_path_buf(),
            reason: format!(
                "it holds the outputs of an earlier run; continue that run with `grainwave resume {0}`, replace it with `--overwrite`, or give another `--out`",
                out.display()
            ),
        });
    }
    for e in others {
        let p = e.path();
        let removed = if e.file_type().map(|t| t.is_dir()).unwrap_or(false) { std::fs::remove_dir_all(&p) } else { std::fs::remove_file(&p) };
        removed.map_err(|e| grainwave_core::CoreError::Io { action: "cannot remove (for --overwrite)".into(), path: p.display().to_string(), error: e })?;
    }
    Ok(())
}

/// Receives progress; the CLI draws bars, a library user can do anything (or nothing).
pub trait Reporter: Send {
    /// A stage starts (e.g. "relaxation"); `total_steps` is its step budget when known.
    fn stage(&mut self, name: &str, total_steps: Option<u64>);
    /// Progress of the current stage.
    fn progress(&mut self, p: &Progress);
    /// Progress of the units of work of a run (samples, reference states, response runs…):
    /// `done` of `total` ([`crate::work::Scheduler`]).
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

/// A silent reporter that raises an interrupt flag at the `after`-th progress report, as Ctrl-C
/// would at that point of the run (`usize::MAX`: never): what the tests of interruption and
/// bit-identical resume run a study with.
pub struct InterruptAfter {
    flag: Arc<AtomicBool>,
    after: usize,
    seen: usize,
}

impl InterruptAfter {
    /// Raises `flag` at the `after`-th progress report.
    pub fn new(flag: Arc<AtomicBool>, after: usize) -> Self {
        InterruptAfter { flag, after, seen: 0 }
    }

    /// Progress reports received so far.
    pub fn reports(&self) -> usize {
        self.seen
    }
}

impl Reporter for InterruptAfter {
    fn stage(&mut self, _: &str, _: Option<u64>) {}
    fn progress(&mut self, _: &Progress) {
        self.seen += 1;
        if self.seen == self.after {
            self.flag.store(true, Ordering::SeqCst);
        }
    }
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
    /// The directory's lock, held while the context lives (none for a worker process's
    /// context: the coordinator holds it).
    _lock: Option<std::fs::File>,
    /// Other processes that run units of the plan (MPI ranks), if any
    /// ([`crate::link::Link`]).
    remote: Option<Arc<dyn crate::link::Link>>,
    /// A worker process's context: its log lines, kept for the coordinator (which writes
    /// `run.log`).
    captured: Option<Vec<String>>,
}

impl<'a> RunContext<'a> {
    /// A context writing into `out` (created if needed), reporting to `reporter`, stopping when
    /// `interrupt` becomes true.
    /// `interrupt` becomes true. Files of the same name in `out` are replaced
    /// ([`UsedDirectory::Keep`]); the directory is locked while the context lives.
    pub fn new(out: &Path, reporter: &'a mut dyn Reporter, interrupt: Arc<AtomicBool>) -> Result<Self> {
        Self::open(out, reporter, interrupt, UsedDirectory::Keep)
    }

    /// A context for a new run into `out`: the directory is created if needed and locked (a
    /// second process is refused with [`ExperimentError::Busy`]), then `mode` says what happens
    /// to the outputs of an earlier run found there.
    pub fn open(out: &Path, reporter: &'a mut dyn Reporter, interrupt: Arc<AtomicBool>, mode: UsedDirectory) -> Result<Self> {
        std::fs::create_dir_all(out).map_err(|e| grainwave_core::CoreError::Io {
            action: "cannot create the output directory".into(),
            path: out.display().to_string(),
            error: e,
        })?;
        let lock = lock_directory(out)?;
        prepare_directory(out, mode)?;
        let log_path = out.join(LOG_FILE);
        // a FIFO (or a device) named run.log would block the open for ever: refused
        grainwave_core::files::refuse_special(&log_path, "the run's log").map_err(|e| ExperimentError::UsedDirectory { dir: out.to_path_buf(), reason: e.to_string() })?;
        let log = std::fs::OpenOptions::new().create(true).append(true).open(&log_path).ok();
        Ok(RunContext {
            out: out.to_path_buf(),
            reporter,
            interrupt,
            report_every: 1000,
            log,
            started: std::time::Instant::now(),
            _lock: Some(lock),
            remote: None,
            captured: None,
        })
    }

    /// The context of a worker process (an MPI rank ≠ 0) running units of the run in `out` for
    /// a coordinator: it neither creates nor locks the directory (the coordinator holds it),
    /// writes no `run.log` (its lines are kept for the coordinator: [`RunContext::take_log`])
    /// and refuses to write the run's checkpoint (the coordinator's).
    pub fn detached(out: &Path, reporter: &'a mut dyn Reporter, interrupt: Arc<AtomicBool>) -> Self {
        RunContext {
            out: out.to_path_buf(),
            reporter,
            interrupt,
            report_every: 1000,
            log: None,
            started: std::time::Instant::now(),
            _lock: None,
            remote: None,
            captured: Some(Vec::new()),
        }
    }

    /// The log lines a worker process's context kept since the last call.
    pub fn take_log(&mut self) -> Vec<String> {
        self.captured.as_mut().map(std::mem::take).unwrap_or_default()
    }

    /// Lets the scheduler hand units to other processes through `link` (the coordinator of an
    /// MPI run).
    pub fn set_remote(&mut self, link: Arc<dyn crate::link::Link>) {
        self.remote = Some(link);
    }

    /// The link to other processes that run units, if any.
    pub fn remote(&self) -> Option<Arc<dyn crate::link::Link>> {
        self.remote.clone()
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
        if let Some(c) = self.captured.as_mut() {
            c.push(text.to_string());
        }
        if let Some(f) = self.log.as_mut() {
            let _ = writeln!(f, "[{:9.2} s] {text}", self.started.elapsed().as_secs_f64());
        }
        self.reporter.message(text);
    }

    /// Records that the run failed with `error`: the diagnosis goes to `run.log` and into the
    /// failure marker [`FAILED_FILE`] (written atomically). Interruptions and bad input are not
    /// failures of the run and leave no marker.
    pub fn mark_failed(&mut self, error: &ExperimentError) {
        if matches!(error, ExperimentError::Interrupted { .. }) || error.is_input_error() || self.captured.is_some() {
            return;
        }
        let text = crate::error::error_chain(error, "\n  caused by: ");
        self.log_quiet(&format!("failed: {text}"));
        let _ = grainwave_core::checkpoint::atomic_write(&self.path(FAILED_FILE), format!("{text}\n").as_bytes());
    }

    /// Removes the failure marker (a retried run).
    pub fn clear_failed(&mut self) {
        if std::fs::remove_file(self.path(FAILED_FILE)).is_ok() {
            self.log_quiet("retrying a failed run: failure marker removed");
        }
    }

    /// Appends a line to `run.log` only.
    pub fn log_quiet(&mut self, text: &str) {
        if let Some(c) = self.captured.as_mut() {
            c.push(text.to_string());
        }
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
        if self.captured.is_some() {
            return Err(ExperimentError::Core(grainwave_core::CoreError::Inconsistent(format!(
                "a worker process cannot write the run's checkpoint {} (the coordinator, rank 0, does)",
                path.display()
            ))));
        }
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

/// When every unit of a study failed (`failures` yields one entry per unit: `Some(reason)` for a
/// failure), logs them and returns [`ExperimentError::AllFailed`]: the run then ends with exit
/// code 1 and the list, instead of failing in the output stage on empty data.
pub fn refuse_all_failed(ctx: &mut RunContext<'_>, what: &str, failures: impl Iterator<Item = Option<String>>) -> Result<()> {
    let mut list = Vec::new();
    for f in failures {
        match f {
            Some(reason) => list.push(crate::config::clip(&crate::config::compact_numbers(&reason), 2 * crate::config::MAX_ECHO_CHARS)),
            None => return Ok(()),
        }
    }
    if list.is_empty() {
        return Ok(());
    }
    let e = ExperimentError::AllFailed { what: what.to_string(), failures: list };
    ctx.log(&e.to_string());
    Err(e)
}

/// The error of a stage in which `failures` (one line each) of `total` units failed: every one
/// ([`ExperimentError::AllFailed`]) or some ([`ExperimentError::UnitsFailed`]); both end the
/// run with exit code 1.
pub fn failed_units(what: &str, total: usize, failures: Vec<String>) -> ExperimentError {
    if failures.len() == total {
        ExperimentError::AllFailed { what: what.to_string(), failures }
    } else {
        ExperimentError::UnitsFailed { what: what.to_string(), total, failures }
    }
}

/// One line describing a unit's failure: the error and its causes ("a: b"), clipped to
/// 3 × [`crate::config::MAX_ECHO_CHARS`] characters.
pub fn failure_line(e: &ExperimentError) -> String {
    let text = crate::error::error_chain(e, ": ");
    crate::config::clip(&crate::config::compact_numbers(&text.replace('\n', " ")), 3 * crate::config::MAX_ECHO_CHARS)
}

/// Reads the content tag of the checkpoint of output directory `dir` (or of a checkpoint file).
pub fn checkpoint_tag(path: &Path) -> Result<(PathBuf, String)> {
    let file = if path.is_dir() { path.join(CHECKPOINT_FILE) } else { path.to_path_buf() };
    if !file.exists() {
        return Err(ExperimentError::Resume {
            path: path.to_path_buf(),
            reason: if path.join(crate::outputs::RESOLVED_CONFIG_FILE).exists() {
                format!(
                    "no `{CHECKPOINT_FILE}` there: the run stopped before it saved anything, so there is nothing to resume; start it again with `grainwave run CONFIG --out {} --overwrite`",
                    path.display()
                )
            } else {
                format!("no `{CHECKPOINT_FILE}` there (was the run started with `grainwave run … --out {}`?)", path.display())
            },
        });
    }
    let bytes = grainwave_core::checkpoint::read_bytes(&file)?;
    let (tag, _) = grainwave_core::checkpoint::verify(&bytes, &file.display().to_string())?;
    Ok((file, tag))
}

/// Loads a protocol state with content tag `tag`.
pub fn load_state<T: DeserializeOwned>(file: &Path, tag: &str) -> Result<T> {
    Ok(grainwave_core::checkpoint::load(file, tag)?)
}
