//! Files of a run directory that `run` and `resume` read or open (issue 41, reproducers 13 and
//! 14): a FIFO, a device or an oversized file in place of `config.resolved.toml` or `run.log` is
//! refused with an error naming the file, never read until memory runs out nor waited on for
//! ever.
#![cfg(unix)]

use grainwave_experiments::config::MAX_CONFIG_BYTES;
use grainwave_experiments::protocol::{RunContext, SilentReporter, UsedDirectory};
use grainwave_experiments::registry::belongs_to;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

fn fresh(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("grainwave-rundir-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Makes a FIFO at `path`; false where `mkfifo` is missing.
fn mkfifo(path: &Path) -> bool {
    std::process::Command::new("mkfifo").arg(path).status().map(|s| s.success()).unwrap_or(false)
}

fn config() -> toml::Table {
    toml::from_str("experiment = \"simulation\"\nseed = 1\n").unwrap()
}

#[test]
fn resolved_config_that_is_a_fifo_a_device_or_too_long_is_refused_by_name() {
    let dir = fresh("resolved");
    let path = dir.join("config.resolved.toml");
    // absent: nothing to compare; the same config: accepted
    belongs_to(&dir, &config()).unwrap();
    std::fs::write(&path, "experiment = \"simulation\"\nseed = 1\n").unwrap();
    belongs_to(&dir, &config()).unwrap();
    // longer than MAX_CONFIG_BYTES (before: read whole, accepted)
    std::fs::write(&path, vec![b'#'; MAX_CONFIG_BYTES as usize + 1]).unwrap();
    let e = belongs_to(&dir, &config()).unwrap_err().to_string();
    assert!(e.contains("config.resolved.toml") && e.contains(&format!("longer than the {MAX_CONFIG_BYTES} bytes allowed")), "{e}");
    // /dev/zero (before: read until the OOM killer came)
    std::fs::remove_file(&path).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &path).unwrap();
    let e = belongs_to(&dir, &config()).unwrap_err().to_string();
    assert!(e.contains("config.resolved.toml") && e.contains("not a regular file"), "{e}");
    // a FIFO (before: blocked for ever)
    std::fs::remove_file(&path).unwrap();
    if mkfifo(&path) {
        let e = belongs_to(&dir, &config()).unwrap_err().to_string();
        assert!(e.contains("config.resolved.toml") && e.contains("not a regular file"), "{e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A config with a key added after a run started (`order`, with a default).
#[derive(serde::Serialize, serde::Deserialize)]
struct Later {
    experiment: String,
    seed: u64,
    #[serde(default)]
    order: String,
}

/// A run whose `config.resolved.toml` predates a key resumes when its checkpoint holds the key's
/// default, and is refused naming the key when it holds another value; a key that differs is
/// still named.
#[test]
fn a_key_added_since_the_run_started_compares_with_its_default() {
    let dir = fresh("later");
    std::fs::write(dir.join("config.resolved.toml"), "experiment = \"simulation\"\nseed = 1\n").unwrap();
    let at = |order: &str, seed: u64| Later { experiment: "simulation".into(), seed, order: order.into() };
    belongs_to(&dir, &at("", 1)).unwrap();
    let e = belongs_to(&dir, &at("sorted", 1)).unwrap_err().to_string();
    assert!(e.contains("key `order`") && e.contains("sorted"), "{e}");
    let e = belongs_to(&dir, &at("", 2)).unwrap_err().to_string();
    assert!(e.contains("key `seed`") && e.contains('2') && e.contains('1'), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn run_log_that_is_a_fifo_is_refused_by_name() {
    let dir = fresh("log");
    if !mkfifo(&dir.join("run.log")) {
        return;
    }
    let mut rep = SilentReporter;
    // before: the open for appending blocked for ever
    let e = RunContext::open(&dir, &mut rep, Arc::new(AtomicBool::new(false)), UsedDirectory::Keep).err().expect("refused").to_string();
    assert!(e.contains("run.log") && e.contains("not a regular file"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
