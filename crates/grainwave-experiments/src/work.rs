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
//! [`Scheduler::run`] is built from; a distributor that puts units on other processes (MPI ranks)
//! or a Python driver can use the same three calls.

use crate::error::{ExperimentError, Result};
use crate::protocol::RunContext;
use grainwave_core::prelude::*;
use serde::Serialize;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};

/// One unit of work of a plan.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unit {
    /// Stable id, unique in the plan (e.g. `sample p1e-4_N40/s0003`, `run mu0.5_s1/F0.1`):
    /// the same config gives the same ids.
    pub id: String,
    /// What kind of unit it is, in the plural ("samples", "response runs"): progress and
    /// failures are reported by kind.
    pub kind: &'static str,
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
    /// What a unit produces (kept in memory only until [`Work::record`] has persisted it).
    type Output: Send;
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
        let what = kinds(units, to_run.iter().copied());
        ctx.reporter.stage(&format!("{what} ({} to run)", to_run.len()), None);
        ctx.reporter.samples(already, total);
        ctx.log(&format!("{} {what} to run, {workers} at a time", to_run.len()));
        let shared = Mutex::new(ctx);
        let env = UnitEnv { ctx: &shared, flag: flag.clone(), running: AtomicUsize::new(0), report_every, shown: Mutex::new(String::new()) };
        let done = std::mem::take(&mut self.done);
        let queue = Mutex::new(Queue { started: done.clone(), done, stops: Vec::new() });
        let wake = Condvar::new();
        let work = self.work;
        rayon::scope(|s| {
            for _ in 0..workers {
                s.spawn(|_| loop {
                    // the first unit in the plan's order whose inputs are done; none: wait while
                    // units run (their results may make one ready), else this worker is done
                    let k = {
                        let Ok(mut q) = queue.lock() else { return };
                        loop {
                            if env.interrupted() {
                                return;
                            }
                            if let Some(k) = (0..total).find(|&k| !q.started[k] && units[k].inputs.iter().all(|&i| q.done[i])) {
                                q.started[k] = true;
                                // counted under the lock, so that a worker deciding to stop sees it
                                env.running.fetch_add(1, Ordering::SeqCst);
                                break k;
                            }
                            if env.running.load(Ordering::SeqCst) == 0 {
                                return;
                            }
                            match wake.wait(q) {
                                Ok(g) => q = g,
                                Err(_) => return,
                            }
                        }
                    };
                    let outcome = work.run(k, &env).and_then(|out| {
                        work.record(k, &out)?;
                        queue.lock().map_err(|_| poisoned())?.done[k] = true;
                        wake.notify_all();
                        let mut c = shared.lock().map_err(|_| poisoned())?;
                        // the done flags read under the context's lock: the states `recorded`
                        // saves, in the order it saves them, never lose a unit (a snapshot taken
                        // before the lock could be saved after a later, larger one)
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
                    // decremented under the lock, so that a worker deciding to wait sees it
                    if let Ok(_q) = queue.lock() {
                        env.running.fetch_sub(1, Ordering::SeqCst);
                    }
                    wake.notify_all();
                });
            }
        });
        let Queue { done, started, mut stops } = queue.into_inner().map_err(|_| ExperimentError::Core(CoreError::Inconsistent("a worker thread panicked".into())))?;
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
            let kind = units[failed[0]].kind;
            let e = if failed.iter().all(|&k| units[k].kind == kind) {
                crate::protocol::failed_units(kind, ran.iter().filter(|&&k| units[k].kind == kind).count(), failures)
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

/// The scheduler's shared record of a run: which units are done and started, and how the units
/// that did not complete stopped.
struct Queue {
    done: Vec<bool>,
    started: Vec<bool>,
    stops: Vec<(usize, UnitStop)>,
}

/// The kinds of `units[ks]`, in the plan's order, joined ("reference states, response runs").
fn kinds(units: &[Unit], ks: impl Iterator<Item = usize>) -> String {
    let mut v: Vec<&str> = Vec::new();
    for k in ks {
        if !v.contains(&units[k].kind) {
            v.push(units[k].kind);
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
    }

    impl Squares {
        fn new(dir: &Path, n: usize) -> Self {
            // units 0..n/2 have no inputs; each later unit reads the two before it
            let units = (0..n).map(|k| Unit { id: format!("u{k:02}"), kind: "units", inputs: if k < n / 2 { vec![] } else { vec![k - 2, k - 1] } }).collect();
            Squares { dir: dir.to_path_buf(), units, fail: None, interrupt_at: None, runs: AtomicUsize::new(0) }
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
                0 => {
                    let t = std::time::Instant::now();
                    while !self.started2.load(Ordering::SeqCst) {
                        if t.elapsed().as_secs() > 20 {
                            return Ok(false);
                        }
                        std::thread::sleep(std::time::Duration::from_millis(1));
                    }
                    Ok(true)
                }
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
                Unit { id: "slow".into(), kind: "units", inputs: vec![] },
                Unit { id: "quick".into(), kind: "units", inputs: vec![] },
                Unit { id: "after-quick".into(), kind: "units", inputs: vec![1] },
            ],
            dir: dir.clone(),
            started2: AtomicBool::new(false),
        };
        let mut rep = SilentReporter;
        let mut ctx = RunContext::new(&dir, &mut rep, Arc::new(AtomicBool::new(false))).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let mut s = Scheduler::new(&w);
        assert_eq!(pool.install(|| s.run(&mut ctx)).unwrap(), Finished::Complete);
        let v: bool = grainwave_core::checkpoint::load(&dir.join("u0.gwck"), "test-unit").unwrap();
        assert!(v, "unit 2 did not start before unit 0 ended");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
