//! Helpers shared by the integration tests: scratch directories and calling Python readers.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty directory for one test (removed first if a previous run left it).
pub fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("grainwave-io-it-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The Python interpreter (`$PYTHON`, default `python3`) if it can import every module in
/// `modules`; otherwise prints why the calling test is skipped and returns `None`.
///
/// The message goes straight to the process's standard error, which the test harness does not
/// capture, so `cargo test` shows it even when the test passes.
pub fn python_with(modules: &[&str]) -> Option<String> {
    let exe = std::env::var("PYTHON").unwrap_or_else(|_| "python3".to_string());
    let ok = Command::new(&exe).arg("-c").arg(format!("import {}", modules.join(", "))).output().map(|o| o.status.success()).unwrap_or(false);
    if ok {
        Some(exe)
    } else {
        let names = modules.join(" ");
        let _ = writeln!(
            std::io::stderr().lock(),
            "skipped: {} not available (install with pip install {names})",
            modules.join("/")
        );
        None
    }
}

/// Runs `script` with `args`, panicking with Python's error output if it fails; returns stdout.
pub fn run_python(exe: &str, script: &str, args: &[&Path]) -> String {
    let out = Command::new(exe).arg("-c").arg(script).args(args).output().expect("python runs");
    assert!(
        out.status.success(),
        "python failed ({}):\n--- stdout\n{}\n--- stderr\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("python prints UTF-8")
}

/// Lower-case hex of `bytes`.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}
