//! Units of work and the one scheduler that runs them (for every protocol whose run splits into
//! independent pieces: the samples of `e1`, the reference states, response runs and bisections
//! of `e3`).
//!
//! A protocol describes its plan as a [`Work`]: a list of [`Unit`]s, each with a stable id (the
//! same for the same config, so that a resumed run finds its finished units) and the units whose
//! results it reads (its declared inputs: a response run reads its reference state). The
//! [`Scheduler`] runs the units whose inputs are done, several at once on the rayon pool; each
//! result is persisted atomically as soon as its unit completes ([`store`]: a temporary file
//! renamed into place), so an interrupted or failed run keeps what finished and `grainwave
//! resume` skips it. Progress is reported the same way for every protocol: a stage per round of
//! ready units, `done of total` units through [`crate::protocol::Reporter::samples`] and one log
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
use std::sync::{Arc, Mutex};

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
    forward_progress: bool,
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
    /// `e2` loading, which is the only unit of its round: every replay reads it). Other units
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
    /// the reporter when this is the only unit running).
    pub fn run<D: Dim>(&self, sim: &mut Simulation<D>, stop: &StopCriteria) -> grainwave_core::Result<RunOutcome> {
        let ctx = self.ctx;
        let forward = self.forward_progress;
        let mut observer = |p: &Progress| {
            if forward {
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

    /// Runs every unit that is not done: round after round, the ready units in parallel (at
    /// most [`Scheduler::max_parallel`] at once, started in the plan's order), each recorded as
    /// soon as it completes. Failures take precedence over an interruption: when units failed,
    /// every failure is listed with its unit ([`crate::protocol::failed_units`]; the completed
    /// units are kept, `resume --retry` redoes only the failed ones); after an interruption the
    /// finished units are kept and [`Finished::Interrupted`] is returned.
    pub fn run(&mut self, ctx: &mut RunContext<'_>) -> Result<Finished> {
        let units = self.work.units();
        let total = units.len();
        let already = self.done.iter().filter(|&&d| d).count();
        if already > 0 && already < total {
            ctx.log(&format!("{already} of {total} {} already done (their results are reused)", kinds(units, 0..total)));
        }
        let flag = ctx.interrupt_flag();
        let report_every = ctx.report_every;
        let shared = Mutex::new(ctx);
        loop {
            let ready = self.ready();
            if ready.is_empty() {
                break;
            }
            let workers = self.max_parallel.unwrap_or_else(rayon::current_num_threads).max(1).min(ready.len());
            if let Ok(mut c) = shared.lock() {
                let what = kinds(units, ready.iter().copied());
                c.reporter.stage(&format!("{what} ({} to run)", ready.len()), None);
                c.reporter.samples(self.done.iter().filter(|&&d| d).count(), total);
                c.log(&format!("{} {what} to run, {workers} at a time", ready.len()));
            }
            let env = UnitEnv { ctx: &shared, flag: flag.clone(), forward_progress: ready.len() == 1, report_every, shown: Mutex::new(String::new()) };
            let next = AtomicUsize::new(0);
            let state = Mutex::new((std::mem::take(&mut self.done), Vec::<(usize, UnitStop)>::new()));
            let work = self.work;
            rayon::scope(|s| {
                for _ in 0..workers {
                    s.spawn(|_| loop {
                        if env.interrupted() {
                            return;
                        }
                        let i = next.fetch_add(1, Ordering::SeqCst);
                        let Some(&k) = ready.get(i) else { return };
                        let outcome = work.run(k, &env).and_then(|out| {
                            work.record(k, &out)?;
                            let done = {
                                let mut st = state.lock().map_err(|_| poisoned())?;
                                st.0[k] = true;
                                st.0.clone()
                            };
                            let mut c = shared.lock().map_err(|_| poisoned())?;
                            let count = done.iter().filter(|&&d| d).count();
                            c.reporter.samples(count, total);
                            work.recorded(k, &out, &mut **c, &done)?;
                            Ok(())
                        });
                        if let Err(stop) = outcome {
                            if let Ok(mut st) = state.lock() {
                                st.1.push((k, stop));
                            }
                        }
                    });
                }
            });
            let (done, mut stops) = state.into_inner().map_err(|_| ExperimentError::Core(CoreError::Inconsistent("a worker thread panicked".into())))?;
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
                // failures of one kind are counted among the units of that kind in the round
                let kind = units[failed[0]].kind;
                let e = if failed.iter().all(|&k| units[k].kind == kind) {
                    crate::protocol::failed_units(kind, ready.iter().filter(|&&k| units[k].kind == kind).count(), failures)
                } else {
                    crate::protocol::failed_units("units", ready.len(), failures)
                };
                if let Ok(mut c) = shared.lock() {
                    c.log(&e.to_string());
                }
                return Err(e);
            }
            if interrupted {
                return Ok(Finished::Interrupted);
            }
        }
        Ok(Finished::Complete)
    }
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
        // units 0..4 form the first round (no inputs); unit 2 failed, the others completed, and
        // the units after them (each reads the two before) were not started
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
}
