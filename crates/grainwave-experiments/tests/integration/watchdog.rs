//! A time budget for one run of a generated case: raises the run's interrupt flag (as Ctrl-C
//! would) when the budget is spent before the run ends, so that a case that runs for long is
//! stopped at a checkpoint and counted, not waited for.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::Duration;

/// Raises [`Watchdog::flag`] `budget` after [`Watchdog::start`] unless dropped first.
pub struct Watchdog {
    flag: Arc<AtomicBool>,
    done: Option<mpsc::Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl Watchdog {
    /// Starts the clock.
    pub fn start(budget: Duration) -> Self {
        let flag = Arc::new(AtomicBool::new(false));
        let (done, wait) = mpsc::channel::<()>();
        let thread = {
            let flag = flag.clone();
            std::thread::spawn(move || {
                // a dropped sender (the run ended) wakes this at once, without raising the flag
                if wait.recv_timeout(budget) == Err(mpsc::RecvTimeoutError::Timeout) {
                    flag.store(true, Ordering::SeqCst);
                }
            })
        };
        Watchdog { flag, done: Some(done), thread: Some(thread) }
    }

    /// The interrupt flag to give the run.
    pub fn flag(&self) -> Arc<AtomicBool> {
        self.flag.clone()
    }
}

impl Drop for Watchdog {
    /// Stops the clock and waits for its thread.
    fn drop(&mut self) {
        drop(self.done.take());
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn the_flag_is_raised_only_when_the_budget_is_spent() {
    let quick = Watchdog::start(Duration::from_secs(60));
    let flag = quick.flag();
    drop(quick); // returns at once: the thread wakes on the dropped sender
    assert!(!flag.load(Ordering::SeqCst));
    let slow = Watchdog::start(Duration::from_millis(20));
    let flag = slow.flag();
    std::thread::sleep(Duration::from_millis(500));
    assert!(flag.load(Ordering::SeqCst), "raised after its budget");
}
