//! Resource bounds, checked when a config is validated (by `grainwave check` and before `run`
//! computes anything): the sizes a config asks for — grains per simulation, samples and runs,
//! points per signal or profile — and an estimate of the memory they need.
//!
//! Two kinds of limit:
//!
//! * **hard**: a size that cannot be represented (grain ids are 32-bit), or a memory estimate
//!   larger than the memory this machine has available (`MemAvailable` of `/proc/meminfo`; no
//!   memory check where that is unknown). Always refused.
//! * **soft**: the documented limits below ([`MAX_GRAINS`], [`MAX_UNITS`], [`MAX_POINTS`]),
//!   far above every published study but below sizes that are almost always typing mistakes.
//!   `grainwave run --allow-large` / `check --allow-large` lift them ([`set_allow_large`]).
//!
//! A refusal is a [`ConfigError`] at the key that asks for the size (exit code 2). Each study
//! checks its own sizes with [`check`] when it validates a config (its `limits` function).

use crate::config::{ConfigError, ConfigSource};
use std::sync::atomic::{AtomicBool, Ordering};

/// Soft limit on the grains of one simulation.
pub const MAX_GRAINS: f64 = 1.0e7;
/// Soft limit on the units of work of one study (samples, groups × samples, runs).
pub const MAX_UNITS: f64 = 1.0e5;
/// Soft limit on the points of one signal, profile or time grid.
pub const MAX_POINTS: f64 = 1.0e7;
/// Hard limit on the grains of one simulation: grain ids are 32-bit.
pub const HARD_MAX_GRAINS: f64 = u32::MAX as f64;
/// Estimated memory per grain of a running simulation, neighbor lists, contacts and (E1) the
/// linear-response matrices included [bytes]. An upper estimate: the 3D Hertz–Mindlin runs of
/// the benchmarks use about half of it.
pub const BYTES_PER_GRAIN: f64 = 2048.0;

static ALLOW_LARGE: AtomicBool = AtomicBool::new(false);

/// Lifts (true) or restores (false) the soft limits for this process.
pub fn set_allow_large(on: bool) {
    ALLOW_LARGE.store(on, Ordering::SeqCst);
}

/// True when the soft limits are lifted.
pub fn allow_large() -> bool {
    ALLOW_LARGE.load(Ordering::SeqCst)
}

/// Memory available to a new process [bytes], when the system says (Linux `MemAvailable`).
pub fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0)
}

/// [`available_memory`], read again when the last reading is older than a second: a `check`
/// compares several sizes with it, and the fuzzer validates thousands of configs a second.
fn available_memory_recent() -> Option<f64> {
    use std::sync::Mutex;
    use std::time::{Duration, Instant};
    static LAST: Mutex<Option<(Instant, Option<f64>)>> = Mutex::new(None);
    let mut last = LAST.lock().unwrap_or_else(|e| e.into_inner());
    match *last {
        Some((at, value)) if at.elapsed() < Duration::from_secs(1) => value,
        _ => {
            let value = available_memory();
            *last = Some((Instant::now(), value));
            value
        }
    }
}

/// The tighter soft limit on grains of the `config_simulation` fuzz target (docs/fuzzing.md).
///
/// Validating a `simulation` config builds it, as `grainwave check` does: the grains are placed
/// and a first force evaluation runs, a cost proportional to the grains asked for. While fuzzing,
/// a config that asks for more than [`fuzz_limits::GRAINS`] is refused by [`check`] like any
/// oversized config (before anything is placed or allocated); smaller ones go through all of
/// their validation, placement included. The other protocols validate without building anything
/// sized by the config, and are fuzzed under the documented limits.
pub mod fuzz_limits {
    use std::cell::Cell;
    /// Grains of one simulation while fuzzing (instead of [`super::MAX_GRAINS`]): above every
    /// seed config of the target (at most 400 grains), so that the seeds reach the placement.
    pub const GRAINS: f64 = 500.0;
    thread_local! {
        static ON: Cell<bool> = const { Cell::new(false) };
    }
    /// True while [`with`] runs on this thread.
    pub fn on() -> bool {
        ON.with(Cell::get)
    }
    /// Runs `f` with the fuzzing limit in force on this thread (restored afterwards, panic or not).
    pub fn with<T>(f: impl FnOnce() -> T) -> T {
        struct Restore(bool);
        impl Drop for Restore {
            fn drop(&mut self) {
                ON.with(|c| c.set(self.0));
            }
        }
        let _restore = Restore(ON.with(|c| c.replace(true)));
        f()
    }
}

fn gib(bytes: f64) -> String {
    format!("{:.3} GiB", bytes / (1u64 << 30) as f64)
}

/// Checks one size: `n` items (of `what`) asked for by `key`, soft limit `soft`, hard limit
/// `hard`, `bytes_each` bytes each (0: not counted in the memory estimate).
pub fn check(src: &ConfigSource, key: &str, what: &str, n: f64, soft: f64, hard: f64, bytes_each: f64) -> Result<(), ConfigError> {
    if n.is_nan() || n > hard {
        return Err(src.error_at_key(key, format!("{n:.4e} {what} (allowed: at most {hard:.4e}; not representable)")));
    }
    let bytes = n * bytes_each;
    if let Some(avail) = if bytes > 0.0 { available_memory_recent() } else { None } {
        if bytes > avail {
            return Err(src.error_at_key(
                key,
                format!("{n:.4e} {what} need about {} of memory; this machine has {} available (allowed: what fits)", gib(bytes), gib(avail)),
            ));
        }
    }
    if soft == MAX_GRAINS && fuzz_limits::on() && n > fuzz_limits::GRAINS {
        let tight = fuzz_limits::GRAINS;
        return Err(src.error_at_key(key, format!("{n:.4e} {what} exceed the fuzzing limit of {tight} (allowed: at most {tight} while fuzzing; documented limit {soft:.0e})")));
    }
    if n > soft && !allow_large() {
        return Err(src.error_at_key(
            key,
            format!("{n:.4e} {what} exceed the limit of {soft:.0e} (allowed: at most {soft:.0e}; `--allow-large` lifts this limit, see docs/config.md)"),
        ));
    }
    Ok(())
}
