//! Units of work and the one scheduler that runs them (for every protocol whose run splits into
//! pieces: the samples of `e1`, the loading and the replays of `e2`, the reference states,
//! response runs and bisections of `e3`; `simulation` is one unit). Every protocol lists its
//! units through [`crate::study::Protocol::plan`].
//!
//! A protocol describes its plan as a [`Work`]: a list of [`Unit`]s, each with a stable id (the
//! same for the same config, so that a resumed run finds its finished units) and the units whose
//! results it reads (its declared inputs: a response run reads its reference state). The
//! [`Scheduler`] runs the units whose inputs are done, several at once on the rayon pool; each
//! result is persisted atomically as soon as its unit completes ([`store`]: a temporary file
//! renamed into place), so an interrupted or failed run keeps what finished and `grainwave
//! resume` skips it. Progress is reported the same way for every protocol: a stage naming the
//! kinds of units to run, `done of total` units through [`crate::protocol::Reporter::samples`] and one log
//! line per unit.
//!
//! Determinism: a unit is a pure function of the config and its inputs' persisted results, and
//! the protocol aggregates results in the order of the units (never in the order they
//! complete), so the outputs are the same bits for any thread count, any number of units run at
//! once and across interruptions.
//!
//! The narrow interface — [`Scheduler::ready`] (the units that can run now), [`Scheduler::run_one`]
//! (run one, anywhere), [`Scheduler::record`] (persist a result and mark its unit done) — is what
//! [`Scheduler::run`] is built from; a Python driver can use the same three calls.
//!
//! ## Other processes (MPI ranks)
//!
//! When the run's context has a [`Link`] to worker processes ([`RunContext::set_remote`]; the
//! command line sets one under `mpirun`, docs/cluster.md), the scheduler of the coordinating
//! process (rank 0) keeps one *slot* per worker beside its own threads: a slot takes the first
//! ready unit that may run elsewhere ([`Work::anywhere`]), sends its index and id to its worker
//! ([`Message::Run`]), waits for the answer — the unit's output, encoded
//! ([`Message::Done`]), its failure or its interruption, with the unit's log lines — and then
//! records the output exactly as a local unit's: [`Work::record`] persists it, [`Work::recorded`]
//! logs it and saves the protocol state, all in the coordinator. The scheduling is dynamic (a
//! worker gets a new unit as soon as it answers), so units of different costs balance.
//!
//! A worker runs [`serve`]: it builds the same [`Work`] from the protocol state the coordinator
//! sent at the start ([`Message::Begin`], see [`crate::registry::serve`]) and runs the units it is
//! sent. Units read their inputs and write their partial states in the output directory, so
//! every process must see that directory (a shared file system: the directory of a cluster
//! job, or one machine). A unit's output is a pure function of the config and its inputs, so a
//! run gives the same bits for any number of processes and threads.

use crate::error::{ExperimentError, Result};
use crate::protocol::RunContext;
use grainwave_core::prelude::*;
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};

/// One unit of work of a plan (serializable: a study's state carries its plan).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Unit {
    /// Stable id, unique in the plan (e.g. `sample p1e-4_N40/s0003`, `run mu0.5_s1/F0.1`):
    /// the same config gives the same ids.
    pub id: String,
    /// What kind of unit it is, in the plural ("samples", "response runs"): progress and
    /// failures are reported by kind.
    pub kind: std::borrow::Cow<'static, str>,
    /// Indices (in the plan) of the units whose results this one reads.
    pub inputs: Vec<usize>,
}

/// Why a unit did not complete.
#[derive(Debug)]
pub enum UnitStop {
    /// The run was interrupted; the unit saved what it needs to continue.
    Interrupted,
    /// The unit failed.
    Failed(ExperimentError),
}

impl From<ExperimentError> for UnitStop {
    fn from(e: ExperimentError) -> Self {
        UnitStop::Failed(e)
    }
}

impl From<CoreError> for UnitStop {
    fn from(e: CoreError) -> Self {
        UnitStop::Failed(e.into())
    }
}

impl From<grainwave_io::OutputError> for UnitStop {
    fn from(e: grainwave_io::OutputError) -> Self {
        UnitStop::Failed(e.into())
    }
}

/// The result of running one unit.
pub type UnitResult<T> = std::result::Result<T, UnitStop>;

/// A plan of units, as a protocol describes it to the scheduler.
pub trait Work: Sync {
    /// What a unit produces (kept in memory only until [`Work::record`] has persisted it;
    /// serializable, to come back from another process).
    type Output: Send + Serialize + DeserializeOwned;
    /// The units, in the plan's order (the order of aggregation).
    fn units(&self) -> &[Unit];
    /// Whether unit `k` is done: its result is persisted (read at the start of a run, so a
    /// resumed run skips it).
    fn is_done(&self, k: usize) -> bool;
    /// Runs unit `k` (its inputs are done). Must be a pure function of the config and the
    /// inputs' results; an interrupted unit saves its own partial state and continues from it.
    fn run(&self, k: usize, env: &UnitEnv<'_, '_, '_>) -> UnitResult<Self::Output>;
    /// Persists the result of unit `k` atomically (with [`store`]).
    fn record(&self, k: usize, output: &Self::Output) -> Result<()>;
    /// Whether unit `k` can run in another process ([`Link`]): true unless it needs the run's
    /// context while it runs (`e2`'s loading writes the protocol checkpoint), which only the
    /// coordinating process has.
    fn anywhere(&self, _k: usize) -> bool {
        true
    }
    /// Called after unit `k` is recorded, with the context (under its lock) and which units are
    /// done: a log line, the protocol state's checkpoint.
    fn recorded(&self, _k: usize, _output: &Self::Output, _ctx: &mut RunContext<'_>, _done: &[bool]) -> Result<()> {
        Ok(())
    }
}

/// Writes a unit's result `value` under content tag `tag` to `path` atomically (creating its
/// directory), then removes the unit's partial state `partial`, if any.
pub fn store<T: Serialize>(path: &Path, tag: &str, value: &T, partial: Option<&Path>) -> Result<()> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| CoreError::Io { action: "cannot create".into(), path: dir.display().to_string(), error: e })?;
    }
    grainwave_core::checkpoint::save(path, tag, value)?;
    if let Some(p) = partial {
        let _ = std::fs::remove_file(p);
    }
    Ok(())
}

/// What a running unit can use: the run's log and reporter (shared, under a lock), the interrupt
/// flag, and the engine with hooks that poll it.
pub struct UnitEnv<'s, 'c, 'r> {
    ctx: &'s Mutex<&'c mut RunContext<'r>>,
    flag: Arc<AtomicBool>,
    /// Units running now: a unit's engine progress is forwarded to the reporter while it runs
    /// alone.
    running: AtomicUsize,
    report_every: u64,
    /// The stage last shown by [`UnitEnv::progress`].
    shown: Mutex<String>,
}

impl UnitEnv<'_, '_, '_> {
    /// Appends a line to `run.log` and shows it.
    pub fn log(&self, text: &str) {
        if let Ok(mut c) = self.ctx.lock() {
            c.log(text);
        }
    }

    /// Appends a line to `run.log` only.
    pub fn log_quiet(&self, text: &str) {
        if let Ok(mut c) = self.ctx.lock() {
            c.log_quiet(text);
        }
    }

    /// The interrupt flag.
    pub fn interrupt_flag(&self) -> &Arc<AtomicBool> {
        &self.flag
    }

    /// True once an interrupt was requested.
    pub fn interrupted(&self) -> bool {
        self.flag.load(Ordering::Relaxed)
    }

    /// The context, under its lock, for a unit that needs the whole of it while it runs (the
    /// `e2` loading, which runs alone: every replay reads it). Other units
    /// wait for the lock to log while `f` runs.
    pub fn with_context<T>(&self, f: impl FnOnce(&mut RunContext<'_>) -> T) -> T {
        let mut c = self.ctx.lock().unwrap_or_else(|e| e.into_inner());
        f(&mut c)
    }

    /// Steps between progress reports and interrupt checks ([`RunContext::report_every`]).
    pub fn report_every(&self) -> u64 {
        self.report_every
    }

    /// Reports the progress `p` of a unit that steps its engine itself, under the stage `stage`
    /// (shown again when another unit reported last).
    pub fn progress(&self, stage: &str, p: &Progress) {
        if let Ok(mut c) = self.ctx.lock() {
            if let Ok(mut shown) = self.shown.lock() {
                if *shown != stage {
                    c.reporter.stage(stage, None);
                    *shown = stage.to_string();
                }
            }
            c.reporter.progress(p);
        }
    }

    /// Runs `sim` until `stop` with hooks that poll the interrupt flag (and forward progress to
    /// the reporter while this is the only unit running).
    pub fn run<D: Dim>(&self, sim: &mut Simulation<D>, stop: &StopCriteria) -> grainwave_core::Result<RunOutcome> {
        let ctx = self.ctx;
        let running = &self.running;
        let mut observer = |p: &Progress| {
            if running.load(Ordering::Relaxed) == 1 {
                if let Ok(mut c) = ctx.lock() {
                    c.reporter.progress(p);
                }
            }
            Control::Continue
        };
        let mut hooks = RunHooks { observer: &mut observer, report_every: self.report_every, interrupt: Some(&self.flag) };
        sim.run_with(stop, &mut hooks)
    }
}

/// How a scheduled run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Finished {
    /// Every unit is done.
    Complete,
    /// Interrupted: the finished units are persisted, the others saved their partial state.
    Interrupted,
}

/// Runs the units of a [`Work`] (see the module documentation).
pub struct Scheduler<'w, W: Work> {
    work: &'w W,
    done: Vec<bool>,
    /// At most this many units at once (default: the rayon pool's thread count).
    pub max_parallel: Option<usize>,
}

impl<'w, W: Work> Scheduler<'w, W> {
    /// A scheduler for `work`, with the units already done marked ([`Work::is_done`]).
    pub fn new(work: &'w W) -> Self {
        let done = (0..work.units().len()).map(|k| work.is_done(k)).collect();
        Scheduler { work, done, max_parallel: None }
    }

    /// Which units are done.
    pub fn done(&self) -> &[bool] {
        &self.done
    }

    /// The units that are not done and whose inputs are all done, in the plan's order.
    pub fn ready(&self) -> Vec<usize> {
        let units = self.work.units();
        (0..units.len()).filter(|&k| !self.done[k] && units[k].inputs.iter().all(|&i| self.done[i])).collect()
    }

    /// Runs unit `k` (which must be ready) without recording it.
    pub fn run_one(&self, k: usize, env: &UnitEnv<'_, '_, '_>) -> UnitResult<W::Output> {
        debug_assert!(self.work.units()[k].inputs.iter().all(|&i| self.done[i]), "unit {k} run before its inputs");
        self.work.run(k, env)
    }

    /// Persists the result of unit `k` and marks it done.
    pub fn record(&mut self, k: usize, output: &W::Output) -> Result<()> {
        self.work.record(k, output)?;
        self.done[k] = true;
        Ok(())
    }

    /// Runs every unit that is not done: each worker (at most [`Scheduler::max_parallel`], by
    /// default the rayon pool's thread count) takes the first unit in the plan's order whose
    /// inputs are done, as soon as it is free, so a unit starts when its inputs are recorded,
    /// not when every unit started before it has finished. Each result is recorded as soon as
    /// its unit completes. When a unit fails, the units that do not read it (directly or through
    /// others) still run; then every failure is listed with its unit
    /// ([`crate::protocol::failed_units`]; the completed units are kept, `resume --retry` redoes
    /// only the others). After an interruption no unit is started, the running ones save their
    /// partial state, the finished ones are kept and [`Finished::Interrupted`] is returned.
    /// Failures take precedence over an interruption.
    pub fn run(&mut self, ctx: &mut RunContext<'_>) -> Result<Finished> {
        let units = self.work.units();
        let total = units.len();
        let already = self.done.iter().filter(|&&d| d).count();
        if already > 0 && already < total {
            ctx.log(&format!("{already} of {total} {} already done (their results are reused)", kinds(units, 0..total)));
        }
        let to_run: Vec<usize> = (0..total).filter(|&k| !self.done[k]).collect();
        if to_run.is_empty() {
            return Ok(Finished::Complete);
        }
        let flag = ctx.interrupt_flag();
        let report_every = ctx.report_every;
        let workers = self.max_parallel.unwrap_or_else(rayon::current_num_threads).max(1).min(to_run.len());
        let link = ctx.remote();
        let ranks = link.as_ref().map_or(0, |l| l.workers());
        let what = kinds(units, to_run.iter().copied());
        ctx.reporter.stage(&format!("{what} ({} to run)", to_run.len()), None);
        ctx.reporter.samples(already, total);
        if ranks > 0 {
            ctx.log(&format!("{} {what} to run, {workers} at a time here and one at a time on each of {ranks} other rank(s)", to_run.len()));
        } else {
            ctx.log(&format!("{} {what} to run, {workers} at a time", to_run.len()));
        }
        let shared = Mutex::new(ctx);
        let env = UnitEnv { ctx: &shared, flag: flag.clone(), running: AtomicUsize::new(0), report_every, shown: Mutex::new(String::new()) };
        let done = std::mem::take(&mut self.done);
        let queue = Mutex::new(Queue { started: done.clone(), done, stops: Vec::new(), local: workers });
        let wake = Condvar::new();
        let work = self.work;
        // per process (0: this one, r: rank r): units run and seconds spent running them
        let busy: Vec<Mutex<(usize, f64)>> = (0..=ranks).map(|_| Mutex::new((0, 0.0))).collect();
        let started_at = std::time::Instant::now();
        // Runs unit `k` (already marked started and counted running) on this process (`rank`
        // None) or on rank r, records its result and wakes the waiting slots; true when rank r
        // cannot be reached (its slot then takes no more units).
        let run_unit = |k: usize, rank: Option<usize>| -> bool {
            let mut broken = false;
            let unit_started = std::time::Instant::now();
            let result = match (rank, link.as_deref()) {
                (Some(r), Some(l)) => {
                    let (result, ok) = run_remote(work, l, r, k, &env);
                    broken = !ok;
                    result
                }
                _ => work.run(k, &env),
            };
            if let Ok(mut b) = busy[rank.unwrap_or(0)].lock() {
                b.0 += 1;
                b.1 += unit_started.elapsed().as_secs_f64();
            }
            let outcome = result.and_then(|out| {
                work.record(k, &out)?;
                queue.lock().map_err(|_| poisoned())?.done[k] = true;
                wake.notify_all();
                let mut c = shared.lock().map_err(|_| poisoned())?;
                // the done flags read under the context's lock: the states `recorded` saves, in
                // the order it saves them, never lose a unit (a snapshot taken before the lock
                // could be saved after a later, larger one)
                let done = queue.lock().map_err(|_| poisoned())?.done.clone();
                let count = done.iter().filter(|&&d| d).count();
                c.reporter.samples(count, total);
                work.recorded(k, &out, &mut **c, &done)?;
                Ok(())
            });
            if let Err(stop) = outcome {
                if let Ok(mut q) = queue.lock() {
                    q.stops.push((k, stop));
                }
            }
            // decremented under the lock, so that a slot deciding to wait sees it
            if let Ok(_q) = queue.lock() {
                env.running.fetch_sub(1, Ordering::SeqCst);
            }
            wake.notify_all();
            broken
        };
        // The slot of another process (rank r ≥ 1): the first unit in the plan's order whose
        // inputs are done and that may run elsewhere; none: wait while units run or another
        // slot can take a ready unit (their results may make one ready), else this slot is done.
        // It waits on a thread of its own, not on one of the pool's workers.
        let remote = |r: usize| loop {
            let k = {
                let Ok(mut q) = queue.lock() else { return };
                loop {
                    if env.interrupted() {
                        return;
                    }
                    if let Some(k) = (0..total).find(|&k| q.ready(units, k) && work.anywhere(k)) {
                        q.started[k] = true;
                        // counted under the lock, so that a slot deciding to stop sees it
                        env.running.fetch_add(1, Ordering::SeqCst);
                        break k;
                    }
                    if env.running.load(Ordering::SeqCst) == 0 && !(0..total).any(|k| q.ready(units, k)) {
                        return;
                    }
                    match wake.wait(q) {
                        Ok(g) => q = g,
                        Err(_) => return,
                    }
                }
            };
            if run_unit(k, Some(r)) {
                return;
            }
        };
        let interrupted = || env.interrupted();
        let local = LocalSlots { queue: &queue, wake: &wake, units, running: &env.running, interrupted: &interrupted, workers, run_unit: &run_unit };
        std::thread::scope(|threads| {
            // a slot of another process waits on messages most of the time: a thread of its own
            for r in 1..=ranks {
                let remote = &remote;
                threads.spawn(move || remote(r));
            }
            rayon::scope(|s| {
                for _ in 0..workers {
                    s.spawn(|s| local.slot(s));
                }
            });
        });
        if ranks > 0 {
            // how well the units were spread: a rank is idle while it waits for a ready unit
            // (or for the last units of others to end)
            let wall = started_at.elapsed().as_secs_f64();
            if let Ok(mut c) = shared.lock() {
                for (r, b) in busy.iter().enumerate() {
                    let (n, seconds) = b.lock().map(|b| *b).unwrap_or((0, 0.0));
                    let slots = if r == 0 { workers } else { 1 };
                    let idle = 100.0 * (1.0 - seconds / (slots as f64 * wall).max(1e-12)).max(0.0);
                    let on = if r == 0 { format!(" on {workers} thread(s)") } else { String::new() };
                    let of = if slots > 1 { format!("{slots} × {wall:.1}") } else { format!("{wall:.1}") };
                    c.log(&format!("rank {r}: {n} unit(s){on}, busy {seconds:.1} s of {of} s, idle {idle:.0} %"));
                }
            }
        }
        let Queue { done, started, mut stops, .. } = queue.into_inner().map_err(|_| ExperimentError::Core(CoreError::Inconsistent("a worker thread panicked".into())))?;
        self.done = done;
        stops.sort_by_key(|(k, _)| *k);
        let mut failures = Vec::new();
        let mut failed = Vec::new();
        let mut interrupted = flag.load(Ordering::Relaxed);
        for (k, stop) in stops {
            match stop {
                UnitStop::Interrupted => interrupted = true,
                UnitStop::Failed(e) => {
                    failures.push(format!("{}: {}", units[k].id, crate::protocol::failure_line(&e)));
                    failed.push(k);
                }
            }
        }
        if !failures.is_empty() {
            // failures of one kind are counted among the units of that kind that were started
            let ran: Vec<usize> = to_run.iter().copied().filter(|&k| started[k]).collect();
            let kind = &units[failed[0]].kind;
            let e = if failed.iter().all(|&k| units[k].kind == *kind) {
                crate::protocol::failed_units(kind, ran.iter().filter(|&&k| units[k].kind == *kind).count(), failures)
            } else {
                crate::protocol::failed_units("units", ran.len(), failures)
            };
            if let Ok(mut c) = shared.lock() {
                c.log(&e.to_string());
            }
            return Err(e);
        }
        if interrupted {
            return Ok(Finished::Interrupted);
        }
        Ok(Finished::Complete)
    }
}

/// Runs unit `k` on worker `rank` of `link` and waits for its answer; the flag is false when the
/// worker cannot be reached (its slot then stops). An interrupted unit there interrupts the whole
/// run (the other ranks got the same signal, or the worker is shutting down).
fn run_remote<W: Work>(work: &W, link: &dyn Link, rank: usize, k: usize, env: &UnitEnv<'_, '_, '_>) -> (UnitResult<W::Output>, bool) {
    let lost = |what: String| (Err(UnitStop::Failed(ExperimentError::Rank { rank, message: what })), false);
    let request = match (Message::Run { unit: k, id: work.units()[k].id.clone() }).encode() {
        Ok(b) => b,
        Err(e) => return (Err(e.into()), true),
    };
    if let Err(e) = link.send(rank, &request) {
        return lost(format!("cannot send unit `{}`: {e}", work.units()[k].id));
    }
    let bytes = match poll(|| link.try_receive(rank)) {
        Ok(b) => b,
        Err(e) => return lost(format!("no answer for unit `{}`: {e}", work.units()[k].id)),
    };
    let message = match Message::decode(&bytes) {
        Ok(m) => m,
        Err(e) => return lost(format!("unreadable answer for unit `{}`: {}", work.units()[k].id, crate::protocol::failure_line(&e))),
    };
    let log = |lines: &[String]| {
        for l in lines {
            env.log(l);
        }
    };
    match message {
        Message::Done { unit, output, log: lines } if unit == k => {
            log(&lines);
            match grainwave_core::checkpoint::decode::<W::Output>(&output, OUTPUT_TAG, "a unit's output") {
                Ok(out) => (Ok(out), true),
                Err(e) => lost(format!("unreadable output of unit `{}`: {e}", work.units()[k].id)),
            }
        }
        Message::Failed { unit, error, log: lines } if unit == k => {
            log(&lines);
            (Err(UnitStop::Failed(ExperimentError::Rank { rank, message: error })), true)
        }
        Message::Interrupted { unit, log: lines } if unit == k => {
            log(&lines);
            env.flag.store(true, Ordering::SeqCst);
            (Err(UnitStop::Interrupted), true)
        }
        other => lost(format!("answered {} to unit {k} (`{}`)", other.name(), work.units()[k].id)),
    }
}

/// Waits for `try_once` to return something, sleeping between tries with pauses that double from
/// 0.2 ms up to 20 ms: units take milliseconds to hours, and a blocking wait inside most MPI
/// libraries spins a core (a worker waiting for `e2`'s loading must not take rank 0's core).
pub fn poll<T, E>(mut try_once: impl FnMut() -> std::result::Result<Option<T>, E>) -> std::result::Result<T, E> {
    let mut pause = std::time::Duration::from_micros(200);
    loop {
        if let Some(v) = try_once()? {
            return Ok(v);
        }
        std::thread::sleep(pause);
        pause = (pause * 2).min(std::time::Duration::from_millis(20));
    }
}

/// The error of a worker that lost its connection to the coordinator.
pub(crate) fn lost_coordinator(rank: usize, e: String) -> ExperimentError {
    ExperimentError::Rank { rank, message: format!("lost the coordinator (rank 0): {e}") }
}

/// Content tag of the messages between processes.
const MESSAGE_TAG: &str = "grainwave-message";
/// Content tag of a unit's output inside [`Message::Done`].
const OUTPUT_TAG: &str = "grainwave-unit-output";

/// A message between the coordinator of a run (rank 0) and a worker process.
#[derive(Debug, Serialize, Deserialize)]
pub enum Message {
    /// Coordinator → worker, once, before any unit: the protocol state of the run (checkpoint
    /// bytes under the protocol's content tag `tag`) and the output directory.
    Begin {
        /// Content tag of the state (which protocol).
        tag: String,
        /// The state, as [`grainwave_core::checkpoint::encode`] writes it.
        state: Vec<u8>,
        /// The output directory (absolute).
        out: PathBuf,
    },
    /// Coordinator → worker: run unit `unit` of the plan (its id, checked by the worker).
    Run {
        /// Index of the unit in the plan.
        unit: usize,
        /// Its id.
        id: String,
    },
    /// Worker → coordinator: the unit completed.
    Done {
        /// Index of the unit.
        unit: usize,
        /// Its output, encoded.
        output: Vec<u8>,
        /// The lines it logged.
        log: Vec<String>,
    },
    /// Worker → coordinator: the unit failed.
    Failed {
        /// Index of the unit.
        unit: usize,
        /// The error and its causes, on one line.
        error: String,
        /// The lines it logged.
        log: Vec<String>,
    },
    /// Worker → coordinator: the unit was interrupted (it saved its partial state).
    Interrupted {
        /// Index of the unit.
        unit: usize,
        /// The lines it logged.
        log: Vec<String>,
    },
    /// Coordinator → worker: the run is over; exit.
    Quit,
}

impl Message {
    /// The message as bytes (with a checksum).
    pub fn encode(&self) -> Result<Vec<u8>> {
        Ok(grainwave_core::checkpoint::encode(MESSAGE_TAG, self)?)
    }

    /// Reads a message.
    pub fn decode(bytes: &[u8]) -> Result<Message> {
        Ok(grainwave_core::checkpoint::decode(bytes, MESSAGE_TAG, "a message from another process")?)
    }

    fn name(&self) -> &'static str {
        match self {
            Message::Begin { .. } => "begin",
            Message::Run { .. } => "run",
            Message::Done { .. } => "done",
            Message::Failed { .. } => "failed",
            Message::Interrupted { .. } => "interrupted",
            Message::Quit => "quit",
        }
    }
}

pub use crate::link::{Link, WorkerLink};

/// Sends [`Message::Quit`] to every worker of `link` (the coordinator, once, at the end of its
/// command, whatever the outcome); a worker that cannot be reached is skipped.
pub fn quit_all(link: &dyn Link) {
    if let Ok(bytes) = Message::Quit.encode() {
        for r in 1..=link.workers() {
            let _ = link.send(r, &bytes);
        }
    }
}

/// A worker's loop: runs the units of `work` that the coordinator sends, in the output directory
/// `out`, and answers each with its output (encoded), failure or interruption and the lines it
/// logged, until [`Message::Quit`]. `interrupt` is the worker's interrupt flag (its own Ctrl-C
/// or SIGTERM: the running unit saves its partial state and answers "interrupted").
pub fn serve<W: Work>(work: &W, link: &dyn WorkerLink, out: &Path, interrupt: Arc<AtomicBool>) -> Result<()> {
    let mut reporter = crate::protocol::SilentReporter;
    let mut ctx = RunContext::detached(out, &mut reporter, interrupt.clone());
    let report_every = ctx.report_every;
    let shared = Mutex::new(&mut ctx);
    let env = UnitEnv { ctx: &shared, flag: interrupt, running: AtomicUsize::new(0), report_every, shown: Mutex::new(String::new()) };
    let rank = link.rank();
    let transport = |e: String| lost_coordinator(rank, e);
    loop {
        let message = Message::decode(&link.receive().map_err(transport)?)?;
        let answer = match message {
            Message::Run { unit, id } => {
                let log = || shared.lock().map(|mut c| c.take_log()).unwrap_or_default();
                match work.units().get(unit) {
                    Some(u) if u.id == id => {
                        env.running.store(1, Ordering::SeqCst);
                        let result = work.run(unit, &env);
                        env.running.store(0, Ordering::SeqCst);
                        match result {
                            Ok(output) => Message::Done { unit, output: grainwave_core::checkpoint::encode(OUTPUT_TAG, &output)?, log: log() },
                            Err(UnitStop::Interrupted) => Message::Interrupted { unit, log: log() },
                            Err(UnitStop::Failed(e)) => Message::Failed { unit, error: crate::protocol::failure_line(&e), log: log() },
                        }
                    }
                    other => Message::Failed {
                        unit,
                        error: format!(
                            "the plans differ: unit {unit} is `{id}` on rank 0 but {} here (are all ranks running the same grainwave?)",
                            other.map_or("absent".to_string(), |u| format!("`{}`", u.id))
                        ),
                        log: Vec::new(),
                    },
                }
            }
            Message::Quit => return Ok(()),
            other => return Err(ExperimentError::Rank { rank, message: format!("unexpected `{}` message from rank 0", other.name()) }),
        };
        link.send(&answer.encode()?).map_err(transport)?;
    }
}

/// A plan without units (a protocol whose run is one simulation, on one process's threads): a
/// worker serving it only waits for [`Message::Quit`].
pub struct NoUnits;

impl Work for NoUnits {
    type Output = ();
    fn units(&self) -> &[Unit] {
        &[]
    }
    fn is_done(&self, _: usize) -> bool {
        true
    }
    fn run(&self, k: usize, _: &UnitEnv<'_, '_, '_>) -> UnitResult<()> {
        Err(UnitStop::Failed(ExperimentError::Core(CoreError::Inconsistent(format!("unit {k} of a plan without units")))))
    }
    fn record(&self, _: usize, _: &()) -> Result<()> {
        Ok(())
    }
}

/// The scheduler's shared record of a run: which units are done and started, and how the units
/// that did not complete stopped.
struct Queue {
    done: Vec<bool>,
    started: Vec<bool>,
    stops: Vec<(usize, UnitStop)>,
    /// Local slots alive ([`LocalSlots`]).
    local: usize,
}

impl Queue {
    /// Unit `k` is not started and its inputs are done.
    fn ready(&self, units: &[Unit], k: usize) -> bool {
        !self.started[k] && units[k].inputs.iter().all(|&i| self.done[i])
    }
}

/// The slots of [`Scheduler::run`] on this process's worker pool. A slot takes the first
/// ready unit in the plan's order, runs it, and takes the next. A slot that finds no ready
/// unit gives its worker back to the pool instead of waiting on it, so that the units running
/// can use it (the engine of a unit runs its passes on the same pool: the `e2` loading, alone
/// for hours, runs on every worker); a slot that takes a unit while another is ready and fewer
/// than `workers` slots are alive starts one more. The last slot alive waits while units run on
/// other ranks (their results may make one ready).
struct LocalSlots<'a> {
    queue: &'a Mutex<Queue>,
    wake: &'a Condvar,
    units: &'a [Unit],
    running: &'a AtomicUsize,
    interrupted: &'a (dyn Fn() -> bool + Sync),
    workers: usize,
    run_unit: &'a (dyn Fn(usize, Option<usize>) -> bool + Sync),
}

impl<'a> LocalSlots<'a> {
    fn slot(&'a self, s: &rayon::Scope<'a>) {
        let total = self.units.len();
        loop {
            let k = {
                let Ok(mut q) = self.queue.lock() else { return };
                loop {
                    if (self.interrupted)() {
                        q.local -= 1;
                        return;
                    }
                    if let Some(k) = (0..total).find(|&k| q.ready(self.units, k)) {
                        q.started[k] = true;
                        // counted under the lock, so that a slot deciding to stop sees it
                        self.running.fetch_add(1, Ordering::SeqCst);
                        if q.local < self.workers && (0..total).any(|j| q.ready(self.units, j)) {
                            q.local += 1;
                            s.spawn(move |s| self.slot(s));
                        }
                        break k;
                    }
                    // nothing ready: done when nothing runs; otherwise give the worker back,
                    // unless this is the last slot (then units run only on other ranks)
                    if q.local > 1 || self.running.load(Ordering::SeqCst) == 0 {
                        q.local -= 1;
                        return;
                    }
                    match self.wake.wait(q) {
                        Ok(g) => q = g,
                        Err(_) => return,
                    }
                }
            };
            (self.run_unit)(k, None);
        }
    }
}

/// The kinds of `units[ks]`, in the plan's order, joined ("reference states, response runs").
fn kinds(units: &[Unit], ks: impl Iterator<Item = usize>) -> String {
    let mut v: Vec<&str> = Vec::new();
    for k in ks {
        if !v.contains(&&*units[k].kind) {
            v.push(&units[k].kind);
        }
    }
    v.join(", ")
}

fn poisoned() -> UnitStop {
    UnitStop::Failed(ExperimentError::Core(CoreError::Inconsistent("a worker thread panicked".into())))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::SilentReporter;

    /// Units k = 0..n: unit k computes k² + (sum of its inputs' values), persisted as a file.
    struct Squares {
        dir: std::path::PathBuf,
        units: Vec<Unit>,
        fail: Option<usize>,
        interrupt_at: Option<usize>,
        runs: AtomicUsize,
        /// A unit that may only run in the coordinating process.
        local_only: Option<usize>,
        /// The units this instance ran.
        ran: Mutex<Vec<usize>>,
        /// How long each unit takes here.
        pause: std::time::Duration,
    }

    impl Squares {
        fn new(dir: &Path, n: usize) -> Self {
            // units 0..n/2 have no inputs; each later unit reads the two before it
            let units = (0..n).map(|k| Unit { id: format!("u{k:02}"), kind: "units".into(), inputs: if k < n / 2 { vec![] } else { vec![k - 2, k - 1] } }).collect();
            Squares { dir: dir.to_path_buf(), units, fail: None, interrupt_at: None, runs: AtomicUsize::new(0), local_only: None, ran: Mutex::new(Vec::new()), pause: std::time::Duration::ZERO }
        }
        fn file(&self, k: usize) -> std::path::PathBuf {
            self.dir.join("units").join(format!("{}.gwck", self.units[k].id))
        }
        fn value(&self, k: usize) -> u64 {
            grainwave_core::checkpoint::load(&self.file(k), "test-unit").unwrap()
        }
    }

    impl Work for Squares {
        type Output = u64;
        fn units(&self) -> &[Unit] {
            &self.units
        }
        fn is_done(&self, k: usize) -> bool {
            self.file(k).exists()
        }
        fn run(&self, k: usize, env: &UnitEnv<'_, '_, '_>) -> UnitResult<u64> {
            self.runs.fetch_add(1, Ordering::SeqCst);
            self.ran.lock().unwrap().push(k);
            env.log(&format!("unit {k} ran"));
            std::thread::sleep(self.pause);
            if self.interrupt_at == Some(k) {
                env.interrupt_flag().store(true, Ordering::SeqCst);
                return Err(UnitStop::Interrupted);
            }
            if self.fail == Some(k) {
                return Err(UnitStop::Failed(ExperimentError::Core(CoreError::Inconsistent(format!("unit {k} cannot")))));
            }
            Ok((k * k) as u64 + self.units[k].inputs.iter().map(|&i| self.value(i)).sum::<u64>())
        }
        fn record(&self, k: usize, v: &u64) -> Result<()> {
            store(&self.file(k), "test-unit", v, None)
        }
        fn anywhere(&self, k: usize) -> bool {
            self.local_only != Some(k)
        }
    }

    fn expected(n: usize) -> Vec<u64> {
        let mut v: Vec<u64> = Vec::new();
        for k in 0..n {
            let inputs = if k < n / 2 { 0 } else { v[k - 2] + v[k - 1] };
            v.push((k * k) as u64 + inputs);
        }
        v
    }

    fn run(work: &Squares, threads: usize, max_parallel: Option<usize>) -> Result<Finished> {
        let mut rep = SilentReporter;
        let mut ctx = RunContext::new(&work.dir, &mut rep, Arc::new(AtomicBool::new(false)))?;
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut s = Scheduler::new(work);
        s.max_parallel = max_parallel;
        pool.install(|| s.run(&mut ctx))
    }

    fn temp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("grainwave-work-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn units_run_after_their_inputs_with_the_same_results_for_any_thread_count() {
        for (threads, max) in [(1, None), (3, None), (4, Some(2))] {
            let dir = temp(&format!("threads{threads}"));
            let w = Squares::new(&dir, 10);
            assert_eq!(run(&w, threads, max).unwrap(), Finished::Complete);
            // a unit reading an input that was not yet persisted would have panicked in `value`
            assert_eq!((0..10).map(|k| w.value(k)).collect::<Vec<_>>(), expected(10), "threads {threads}");
            assert_eq!(w.runs.load(Ordering::SeqCst), 10);
            let _ = std::fs::remove_dir_all(&dir);
        }
    }

    #[test]
    fn a_resumed_run_skips_finished_units_and_failures_are_listed_by_unit() {
        let dir = temp("resume");
        let mut w = Squares::new(&dir, 8);
        w.fail = Some(2);
        let e = run(&w, 2, None).unwrap_err();
        let text = e.to_string();
        // units 0..4 have no inputs; unit 2 failed, the others completed, and the units after
        // them (each reads the two before, so every one reads unit 2 directly or through
        // others) were not started
        assert!(text.contains("u02: ") && text.contains("unit 2 cannot") && text.starts_with("1 of the 4 units failed"), "{text}");
        let done: Vec<bool> = (0..8).map(|k| w.file(k).exists()).collect();
        assert_eq!(done, [true, true, false, true, false, false, false, false]);
        // retry: only the units not done run
        w.fail = None;
        w.runs.store(0, Ordering::SeqCst);
        assert_eq!(run(&w, 2, None).unwrap(), Finished::Complete);
        assert_eq!(w.runs.load(Ordering::SeqCst), 5);
        assert_eq!((0..8).map(|k| w.value(k)).collect::<Vec<_>>(), expected(8));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn an_interrupted_run_keeps_what_finished_and_continues_to_the_same_results() {
        let dir = temp("interrupt");
        let mut w = Squares::new(&dir, 8);
        w.interrupt_at = Some(4);
        assert_eq!(run(&w, 1, None).unwrap(), Finished::Interrupted);
        assert!((0..4).all(|k| w.file(k).exists()) && !w.file(4).exists());
        w.interrupt_at = None;
        w.runs.store(0, Ordering::SeqCst);
        assert_eq!(run(&w, 2, None).unwrap(), Finished::Complete);
        assert_eq!(w.runs.load(Ordering::SeqCst), 4);
        assert_eq!((0..8).map(|k| w.value(k)).collect::<Vec<_>>(), expected(8));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Waits up to 20 s for `flag`; false when it never came.
    fn wait_for(flag: &AtomicBool) -> bool {
        let t = std::time::Instant::now();
        while !flag.load(Ordering::SeqCst) {
            if t.elapsed().as_secs() > 20 {
                return false;
            }
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        true
    }

    /// Runs `w` to completion with its outputs in `dir`, on a pool of two workers.
    fn run_on_two_workers<W: Work>(w: &W, dir: &Path) {
        let mut rep = SilentReporter;
        let mut ctx = RunContext::new(dir, &mut rep, Arc::new(AtomicBool::new(false))).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let mut s = Scheduler::new(w);
        assert_eq!(pool.install(|| s.run(&mut ctx)).unwrap(), Finished::Complete);
    }

    /// The value unit `k` of [`Overtake`] or [`Alone`] recorded in `dir`.
    fn recorded(dir: &Path, k: usize) -> bool {
        grainwave_core::checkpoint::load(&dir.join(format!("u{k}.gwck")), "test-unit").unwrap()
    }

    /// Unit 0 (no inputs) waits until unit 2 has started; unit 2 reads unit 1 (no inputs, quick).
    struct Overtake {
        units: Vec<Unit>,
        dir: std::path::PathBuf,
        started2: AtomicBool,
    }

    impl Work for Overtake {
        type Output = bool;
        fn units(&self) -> &[Unit] {
            &self.units
        }
        fn is_done(&self, _: usize) -> bool {
            false
        }
        fn run(&self, k: usize, _: &UnitEnv<'_, '_, '_>) -> UnitResult<bool> {
            match k {
                0 => Ok(wait_for(&self.started2)),
                2 => {
                    self.started2.store(true, Ordering::SeqCst);
                    Ok(true)
                }
                _ => Ok(true),
            }
        }
        fn record(&self, k: usize, v: &bool) -> Result<()> {
            store(&self.dir.join(format!("u{k}.gwck")), "test-unit", v, None)
        }
    }

    #[test]
    fn a_unit_starts_as_soon_as_its_inputs_are_done_and_a_worker_is_free() {
        // with two workers, unit 2 (input: unit 1) must start while unit 0 still runs: a
        // scheduler that ran in rounds would wait for unit 0, which waits for unit 2 (it gives
        // up after 20 s and records false)
        let dir = temp("overtake");
        let w = Overtake {
            units: vec![
                Unit { id: "slow".into(), kind: "units".into(), inputs: vec![] },
                Unit { id: "quick".into(), kind: "units".into(), inputs: vec![] },
                Unit { id: "after-quick".into(), kind: "units".into(), inputs: vec![1] },
            ],
            dir: dir.clone(),
            started2: AtomicBool::new(false),
        };
        run_on_two_workers(&w, &dir);
        assert!(recorded(&dir, 0), "unit 2 did not start before unit 0 ended");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Unit 0 runs alone (units 1 and 2 read it) and splits its work in two with
    /// `rayon::join`; units 1 and 2 each wait for the other to start.
    struct Alone {
        units: Vec<Unit>,
        dir: std::path::PathBuf,
        second_half: AtomicBool,
        started: [AtomicBool; 3],
    }

    impl Work for Alone {
        type Output = bool;
        fn units(&self) -> &[Unit] {
            &self.units
        }
        fn is_done(&self, _: usize) -> bool {
            false
        }
        fn run(&self, k: usize, _: &UnitEnv<'_, '_, '_>) -> UnitResult<bool> {
            self.started[k].store(true, Ordering::SeqCst);
            Ok(match k {
                // the first half waits for the second: they overlap only when another worker
                // takes the second half while the first waits
                0 => rayon::join(|| wait_for(&self.second_half), || self.second_half.store(true, Ordering::SeqCst)).0,
                1 => wait_for(&self.started[2]),
                _ => wait_for(&self.started[1]),
            })
        }
        fn record(&self, k: usize, v: &bool) -> Result<()> {
            store(&self.dir.join(format!("u{k}.gwck")), "test-unit", v, None)
        }
    }

    #[test]
    fn a_unit_running_alone_has_every_worker_and_units_made_ready_together_run_together() {
        // With two workers and one ready unit, a slot that waited on its worker for a unit to
        // become ready would leave the running unit one worker: the two halves of unit 0 would
        // run one after the other (the first gives up after 20 s and records false). Then
        // units 1 and 2, made ready together, must run at the same time.
        let dir = temp("alone");
        let w = Alone {
            units: vec![
                Unit { id: "alone".into(), kind: "units".into(), inputs: vec![] },
                Unit { id: "one".into(), kind: "units".into(), inputs: vec![0] },
                Unit { id: "two".into(), kind: "units".into(), inputs: vec![0] },
            ],
            dir: dir.clone(),
            second_half: AtomicBool::new(false),
            started: Default::default(),
        };
        run_on_two_workers(&w, &dir);
        for (k, what) in [(0, "the two halves of the unit running alone did not overlap"), (1, "units 1 and 2 did not run together"), (2, "units 2 and 1 did not run together")] {
            assert!(recorded(&dir, k), "{what}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Worker "processes" as threads, linked by channels: the coordinator's side.
    struct Channels {
        to: Vec<Mutex<std::sync::mpsc::Sender<Vec<u8>>>>,
        from: Vec<Mutex<std::sync::mpsc::Receiver<Vec<u8>>>>,
    }

    impl Link for Channels {
        fn workers(&self) -> usize {
            self.to.len()
        }
        fn send(&self, rank: usize, bytes: &[u8]) -> std::result::Result<(), String> {
            self.to[rank - 1].lock().unwrap().send(bytes.to_vec()).map_err(|e| e.to_string())
        }
        fn try_receive(&self, rank: usize) -> std::result::Result<Option<Vec<u8>>, String> {
            match self.from[rank - 1].lock().unwrap().try_recv() {
                Ok(b) => Ok(Some(b)),
                Err(std::sync::mpsc::TryRecvError::Empty) => Ok(None),
                Err(e) => Err(e.to_string()),
            }
        }
    }

    /// A worker thread's side.
    struct WorkerEnd {
        rank: usize,
        from: std::sync::mpsc::Receiver<Vec<u8>>,
        to: std::sync::mpsc::Sender<Vec<u8>>,
    }

    impl WorkerLink for WorkerEnd {
        fn rank(&self) -> usize {
            self.rank
        }
        fn receive(&self) -> std::result::Result<Vec<u8>, String> {
            self.from.recv().map_err(|e| e.to_string())
        }
        fn send(&self, bytes: &[u8]) -> std::result::Result<(), String> {
            self.to.send(bytes.to_vec()).map_err(|e| e.to_string())
        }
    }

    /// Runs `coordinator` with `ranks` worker threads, each serving its own `Squares` built by
    /// `make` (as a worker process builds its own plan); returns the outcome, the log and the
    /// units each worker ran.
    fn distributed(coordinator: &Squares, ranks: usize, make: impl Fn() -> Squares + Sync) -> (Result<Finished>, String, Vec<Vec<usize>>) {
        let (mut to, mut from, mut ends) = (Vec::new(), Vec::new(), Vec::new());
        for rank in 1..=ranks {
            let (tx, rx) = std::sync::mpsc::channel();
            let (tx2, rx2) = std::sync::mpsc::channel();
            to.push(Mutex::new(tx));
            from.push(Mutex::new(rx2));
            ends.push(WorkerEnd { rank, from: rx, to: tx2 });
        }
        let link: Arc<dyn Link> = Arc::new(Channels { to, from });
        std::thread::scope(|s| {
            let workers: Vec<_> = ends
                .into_iter()
                .map(|end| {
                    let make = &make;
                    s.spawn(move || {
                        let w = make();
                        serve(&w, &end, &w.dir, Arc::new(AtomicBool::new(false))).unwrap();
                        let ran = w.ran.lock().unwrap().clone();
                        ran
                    })
                })
                .collect();
            let outcome = {
                let mut rep = SilentReporter;
                let mut ctx = RunContext::new(&coordinator.dir, &mut rep, Arc::new(AtomicBool::new(false))).unwrap();
                ctx.set_remote(link.clone());
                let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
                let mut s = Scheduler::new(coordinator);
                let outcome = pool.install(|| s.run(&mut ctx));
                quit_all(&*link);
                outcome
            };
            let ran = workers.into_iter().map(|h| h.join().unwrap()).collect();
            let log = std::fs::read_to_string(coordinator.dir.join(crate::protocol::LOG_FILE)).unwrap_or_default();
            (outcome, log, ran)
        })
    }

    #[test]
    fn units_run_in_other_processes_give_the_same_results_and_are_recorded_here() {
        let n = 12;
        let dir = temp("ranks");
        let mut coordinator = Squares::new(&dir, n);
        coordinator.local_only = Some(1);
        // the coordinator's units take 200 ms, the workers' none: the workers' slots start long
        // before it could run every unit itself (units of no duration let one thread run them all
        // before the workers' threads were scheduled on a loaded machine)
        coordinator.pause = std::time::Duration::from_millis(200);
        // and the workers' 50 ms: with units of no duration, one worker could run them all
        // before the other's slot thread was scheduled (1 run in 35 on a loaded machine)
        let worker = || {
            let mut w = Squares::new(&dir, n);
            w.pause = std::time::Duration::from_millis(50);
            w
        };
        let (outcome, log, ran) = distributed(&coordinator, 2, worker);
        assert_eq!(outcome.unwrap(), Finished::Complete);
        assert_eq!((0..n).map(|k| coordinator.value(k)).collect::<Vec<_>>(), expected(n));
        // every unit ran exactly once, somewhere; the workers ran some of them (each takes a unit
        // as soon as it is free, and the coordinator runs one at a time), never the local-only one
        let here = coordinator.ran.lock().unwrap().clone();
        let mut all: Vec<usize> = here.iter().chain(ran.iter().flatten()).copied().collect();
        all.sort();
        assert_eq!(all, (0..n).collect::<Vec<_>>(), "here {here:?}, workers {ran:?}");
        assert!(ran.iter().all(|r| !r.is_empty()) && ran.iter().flatten().all(|&k| k != 1), "here {here:?}, workers {ran:?}");
        assert!(here.contains(&1));
        // the workers' log lines reach the coordinator's run.log
        for k in 0..n {
            assert!(log.contains(&format!("unit {k} ran")), "{log}");
        }
        assert!(log.contains("one at a time on each of 2 other rank(s)"), "{log}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_unit_failing_in_another_process_is_listed_with_its_rank_and_resumes_anywhere() {
        let n = 8;
        let dir = temp("rank-failure");
        let mut coordinator = Squares::new(&dir, n);
        // unit 3 fails wherever it runs: here (only if the coordinator takes it) or on rank 1
        coordinator.fail = Some(3);
        let make = || {
            let mut w = Squares::new(&dir, n);
            w.fail = Some(3);
            w
        };
        let (outcome, _, ran) = distributed(&coordinator, 1, make);
        let text = outcome.unwrap_err().to_string();
        assert!(text.contains("u03: ") && text.contains("unit 3 cannot"), "{text}");
        if ran[0].contains(&3) {
            assert!(text.contains("(on rank 1)"), "{text}");
        }
        // resumed without workers: only the units not done run, to the same results
        coordinator.fail = None;
        coordinator.runs.store(0, Ordering::SeqCst);
        assert_eq!(run(&coordinator, 2, None).unwrap(), Finished::Complete);
        assert_eq!((0..n).map(|k| coordinator.value(k)).collect::<Vec<_>>(), expected(n));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_worker_with_another_plan_refuses_its_units() {
        let dir = temp("rank-plan");
        let mut coordinator = Squares::new(&dir, 6);
        // the coordinator's units take 200 ms: the worker is sent some before the coordinator could
        // run all six itself (without a pause, on a loaded machine, it sometimes did, and the run
        // completed without asking the worker: 3 failures in 8 runs)
        coordinator.pause = std::time::Duration::from_millis(200);
        // the worker's plan has other ids: every unit it is sent comes back failed, naming both
        let make = || {
            let mut w = Squares::new(&dir, 6);
            for u in &mut w.units {
                u.id = format!("other-{}", u.id);
            }
            w
        };
        let (outcome, _, ran) = distributed(&coordinator, 1, make);
        assert!(ran[0].is_empty());
        let text = outcome.unwrap_err().to_string();
        assert!(text.contains("the plans differ") && text.contains("`other-u0"), "{text}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

