//! Helpers shared by the integration tests of several protocols.

use grainwave_experiments::protocol::Reporter;
use grainwave_experiments::Progress;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A silent reporter that raises the interrupt flag at the `after`-th progress report, as
/// Ctrl-C would at that point of the run (`usize::MAX`: never).
pub struct Interrupter {
    flag: Arc<AtomicBool>,
    after: usize,
    seen: usize,
}

impl Interrupter {
    /// Raises `flag` at the `after`-th progress report.
    pub fn new(flag: Arc<AtomicBool>, after: usize) -> Self {
        Interrupter { flag, after, seen: 0 }
    }

    /// Progress reports received so far.
    #[allow(dead_code)] // each test crate compiles this module; not all of them count reports
    pub fn reports(&self) -> usize {
        self.seen
    }
}

impl Reporter for Interrupter {
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
