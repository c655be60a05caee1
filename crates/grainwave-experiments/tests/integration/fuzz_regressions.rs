//! Replays every input kept in `tests/fuzz-regressions/` through the code the libFuzzer targets
//! of `fuzz/` run (`grainwave_experiments::fuzzing`), as an ordinary test: CI runs it on a stable
//! toolchain, where the fuzzer itself cannot be built (docs/fuzzing.md).
//!
//! * `config/*.toml`: through the config loader of every protocol (`config_simulation`,
//!   `config_e1`, `config_e2`, `config_e3`) and through `grainwave check`'s dispatcher;
//! * `checkpoint/*`: through the checkpoint decoder of every protocol;
//! * `lammps/*`: through the LAMMPS data reader.
//!
//! Each file is an input that made a target fail (panic, abort, an allocation beyond the
//! fuzzer's limit, an over-long message) before its fix; its name says what it was. Property:
//! the loader returns (loaded, or refused with a message of bounded length) without a panic.

use grainwave_experiments::config::ConfigSource;
use grainwave_experiments::fuzzing;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

fn inputs(kind: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions").join(kind);
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| p.is_file() && p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n != "README.md" && !n.starts_with('.')))
        .collect();
    v.sort();
    v
}

/// Runs `f` on the bytes of every input of `kind`; a panic or a failed property names the file.
fn replay(kind: &str, f: impl Fn(&[u8]) -> Result<(), String>) -> usize {
    let files = inputs(kind);
    for p in &files {
        let bytes = std::fs::read(p).unwrap();
        match catch_unwind(AssertUnwindSafe(|| f(&bytes))) {
            Ok(Ok(())) => {}
            Ok(Err(e)) => panic!("{}: {e}", p.display()),
            Err(_) => panic!("{}: the loader panicked", p.display()),
        }
    }
    files.len()
}

#[test]
fn config_regressions_load_or_are_refused_with_a_message() {
    let n = replay("config", |bytes| {
        for protocol in fuzzing::PROTOCOLS {
            fuzzing::config(protocol, bytes).map_err(|e| format!("config_{protocol}: {e}"))?;
        }
        // and through the dispatcher of `grainwave check` (the protocol named by the file)
        if let Ok(text) = std::str::from_utf8(bytes) {
            if let Err(e) = grainwave_experiments::registry::check(&ConfigSource::from_text("regression.toml", text)) {
                if e.message.is_empty() || e.message.len() >= fuzzing::MAX_MESSAGE_BYTES {
                    return Err(format!("check: a message of {} bytes", e.message.len()));
                }
            }
        }
        Ok(())
    });
    eprintln!("{n} config regression input(s) replayed");
}

#[test]
fn checkpoint_regressions_are_refused_with_a_message() {
    let n = replay("checkpoint", fuzzing::checkpoint);
    eprintln!("{n} checkpoint regression input(s) replayed");
}

#[test]
fn lammps_regressions_load_or_are_refused_with_a_message() {
    let n = replay("lammps", fuzzing::lammps);
    eprintln!("{n} LAMMPS regression input(s) replayed");
}
