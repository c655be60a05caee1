//! The integration tests of grainwave-cli (the program run as a user would), in one test binary (one link of the whole stack instead of
//! one per file): each module is a file of tests of one subject.

mod adversarial;
mod interrupt;

use std::path::Path;
use std::time::{Duration, Instant};

/// Waits until `path` exists; fails the test after `limit`.
fn wait_for(path: &Path, limit: Duration) {
    let t = Instant::now();
    while !path.exists() {
        assert!(t.elapsed() < limit, "{} did not appear", path.display());
        std::thread::sleep(Duration::from_millis(20));
    }
}
