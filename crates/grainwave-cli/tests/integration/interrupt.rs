//! Interrupt and resume through the real program: SIGINT mid-run (the program finishes the
//! current step, checkpoints and exits with 130) and SIGKILL between periodic checkpoints (no
//! chance to clean up). In both cases `grainwave resume DIR` must produce the same files, bit for
//! bit, as an uninterrupted run, and no output may be left half-written.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use crate::wait_for;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_grainwave");

fn config() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/interrupt.toml")
}

fn out(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("grainwave-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn start(dir: &Path) -> Child {
    Command::new(BIN)
        .args(["--quiet", "run"])
        .arg(config())
        .arg("--out")
        .arg(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the program starts")
}

fn resume(dir: &Path) {
    let st = Command::new(BIN).args(["--quiet", "resume"]).arg(dir).status().unwrap();
    assert!(st.success(), "resume failed: {st}");
}

/// The result files of a run, by name (the log and the lock file are excluded).
fn results(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let name = p.strip_prefix(dir).unwrap().display().to_string();
                assert!(!name.contains(".tmp"), "a temporary file was left behind: {name}");
                // the log records wall-clock times, the lock file the pid of its last holder
                if name != "run.log" && name != ".grainwave.lock" {
                    files.push((name, std::fs::read(&p).unwrap()));
                }
            }
        }
    }
    files.sort();
    files
}

fn reference() -> Vec<(String, Vec<u8>)> {
    let dir = out("reference");
    let st = Command::new(BIN).args(["--quiet", "run"]).arg(config()).arg("--out").arg(&dir).status().unwrap();
    assert!(st.success());
    results(&dir)
}

fn names(files: &[(String, Vec<u8>)]) -> Vec<&str> {
    files.iter().map(|(n, _)| n.as_str()).collect()
}

#[test]
fn sigint_then_resume_gives_the_same_bits_and_sigkill_too() {
    let expected = reference();
    assert!(names(&expected).contains(&"summary.json") && names(&expected).contains(&"series.csv"));

    // SIGINT once the run has started.
    let dir = out("sigint");
    let mut child = start(&dir);
    wait_for(&dir.join("config.resolved.toml"), Duration::from_secs(60));
    std::thread::sleep(Duration::from_millis(700));
    let pid = child.id().to_string();
    assert!(Command::new("kill").args(["-INT", &pid]).status().unwrap().success());
    let status = child.wait().unwrap();
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    assert_eq!(status.code(), Some(130), "an interrupted run exits with 130; stderr: {stderr}");
    assert!(stderr.contains("grainwave resume"), "tells how to continue: {stderr}");
    assert!(dir.join("checkpoint.gwck").exists() && !dir.join("summary.json").exists());
    resume(&dir);
    assert_eq!(names(&results(&dir)), names(&expected));
    assert!(results(&dir) == expected, "SIGINT + resume differs from the uninterrupted run");

    // SIGKILL between two periodic checkpoints: resume from the last one.
    let dir = out("sigkill");
    let mut child = start(&dir);
    // the first checkpoint is the starting state, saved before any step; wait for the first
    // periodic one, which replaces it
    let ck = dir.join("checkpoint.gwck");
    wait_for(&ck, Duration::from_secs(60));
    let first = std::fs::metadata(&ck).unwrap().modified().unwrap();
    let t = Instant::now();
    while std::fs::metadata(&ck).and_then(|m| m.modified()).map_or(true, |m| m == first) {
        assert!(t.elapsed() < Duration::from_secs(60), "no periodic checkpoint within 60 s");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    child.kill().unwrap(); // SIGKILL
    let status = child.wait().unwrap();
    assert!(!status.success());
    assert!(!dir.join("summary.json").exists(), "killed before the end");
    // a kill landing inside a checkpoint write leaves `.checkpoint.gwck.PID.tmp`; make sure that
    // case is covered every time (pid 4e9 is above any pid_max, so not running): resume removes it
    std::fs::write(dir.join(".checkpoint.gwck.4000000000.tmp"), b"half").unwrap();
    resume(&dir);
    assert!(results(&dir) == expected, "SIGKILL + resume differs from the uninterrupted run");
}

#[test]
fn bad_config_exits_with_2_and_points_at_the_line() {
    let dir = out("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    let text = std::fs::read_to_string(config()).unwrap().replace("restitution = 0.7", "restitution = -0.7");
    std::fs::write(&bad, text).unwrap();
    for args in [vec!["check"], vec!["run"]] {
        let o = Command::new(BIN).args(&args).arg(&bad).output().unwrap();
        assert_eq!(o.status.code(), Some(2));
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("bad.toml:20:15") && err.contains("contact.restitution") && err.contains("-0.7"), "{err}");
    }
    let o = Command::new(BIN).args(["resume"]).arg(&dir).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "nothing to resume is bad input");
    assert!(String::from_utf8_lossy(&o.stderr).contains("no `checkpoint.gwck`"));
}

#[test]
fn inspect_describes_checkpoints_and_directories() {
    let dir = out("inspect");
    let pile = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/settle-pile.toml");
    let st = Command::new(BIN).args(["--quiet", "run", pile, "--out"]).arg(&dir).status().unwrap();
    assert!(st.success());
    let o = Command::new(BIN).args(["inspect"]).arg(dir.join("checkpoint.gwck")).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("checksum ok") && text.contains("300 disk (2D)") && text.contains("finished (Converged)"), "{text}");
    let o = Command::new(BIN).args(["inspect"]).arg(&dir).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("simulation run, stopped: converged") && text.contains("summary.json"), "{text}");
    // the files by the study's declarations (docs/outputs.md): each named with its description
    assert!(text.contains("files, by the outputs `simulation` declares"), "{text}");
    assert!(text.lines().any(|l| l.trim_start().starts_with("grains.csv") && l.contains("CSV: the final grains")), "{text}");
    assert!(text.contains("matches a declaration") && !text.contains("match no declaration"), "{text}");
    // a file the study does not write is named as such
    std::fs::write(dir.join("notes.txt"), b"mine").unwrap();
    let o = Command::new(BIN).args(["inspect"]).arg(&dir).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("1 file(s) match no declaration of `simulation`") && text.lines().any(|l| l.trim() == "notes.txt"), "{text}");
    std::fs::remove_file(dir.join("notes.txt")).unwrap();
    // a corrupted checkpoint is refused with a clear message
    let mut bytes = std::fs::read(dir.join("checkpoint.gwck")).unwrap();
    let k = bytes.len() / 2;
    bytes[k] ^= 1;
    std::fs::write(dir.join("checkpoint.gwck"), bytes).unwrap();
    let o = Command::new(BIN).args(["inspect"]).arg(dir.join("checkpoint.gwck")).output().unwrap();
    // bad input, as `resume` of the same file: exit 2 (docs/hardening.md)
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("checksum mismatch"));
    // a summary.json and a failure marker that are FIFOs (no writer: reading them would block
    // for ever) are reported, not read
    std::fs::remove_file(dir.join("summary.json")).unwrap();
    std::fs::remove_file(dir.join("checkpoint.gwck")).unwrap(); // the corrupted one: inspect would stop on it
    let fifo = |name: &str| Command::new("mkfifo").arg(dir.join(name)).status().is_ok_and(|s| s.success());
    if !(fifo("summary.json") && fifo("run.failed")) {
        eprintln!("skipped: mkfifo not available: the FIFO part of inspect_describes_checkpoints_and_directories");
        return;
    }
    let mut child = Command::new(BIN).args(["inspect"]).arg(&dir).stdout(std::process::Stdio::piped()).spawn().unwrap();
    let start = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed().as_secs() > 30 {
            let _ = child.kill();
            panic!("inspect blocked on a FIFO summary.json or run.failed");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let o = child.wait_with_output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("summary.json not read: not a regular file") && text.contains("run.failed is not a regular file"), "{text}");
}
