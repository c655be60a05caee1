//! Runs under `mpirun` (built only with the feature `mpi`; `.ci/run` installs Open MPI and runs
//! these): a study's outputs are the same for 1, 2 and 3 ranks as for one process without MPI,
//! and a run whose rank dies stops (no hang) and resumes on another number of ranks to the same
//! outputs. docs/cluster.md.
#![cfg(feature = "mpi")]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_grainwave");

/// A small E1 ensemble: 2 heights × 4 samples of tiny 2D packings (≈ 2 s on one core).
const E1: &str = r#"
experiment = "e1"
seed = 11
samples = 4
parallel_samples = 1

[packing]
kind = "sphere2d"
width = 6.0
grains = [24, 40]
pressures = [1e-4]

[pulse]
field_times = [1.0]
time_samples = 801
"#;

/// A larger one for the kill test: 2 heights × 12 samples (≈ 15 s on one core).
const E1_LONG: &str = r#"
experiment = "e1"
seed = 11
samples = 12
parallel_samples = 1

[packing]
kind = "sphere2d"
width = 6.0
grains = [60, 90]
pressures = [1e-4]

[pulse]
time_samples = 801
"#;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("grainwave-mpi-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn config(d: &Path, text: &str) -> PathBuf {
    let f = d.join("study.toml");
    std::fs::write(&f, text).unwrap();
    f
}

/// `mpirun -np N` (Open MPI: may put more ranks than cores, and as root in containers).
fn mpirun(n: usize) -> Command {
    let version = Command::new("mpirun").arg("--version").output().expect("mpirun is installed (the `mpi` feature was built against an MPI library)");
    let mut c = Command::new("mpirun");
    if String::from_utf8_lossy(&version.stdout).contains("Open MPI") {
        c.arg("--oversubscribe").env("OMPI_ALLOW_RUN_AS_ROOT", "1").env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
    }
    c.args(["-np", &n.to_string(), BIN]);
    c
}

fn single() -> Command {
    Command::new(BIN)
}

/// Runs `args` after `cmd` with one thread per process; panics on failure.
fn ok(mut cmd: Command, args: &[&str], what: &str) {
    let o = cmd.args(["--threads", "1", "--quiet"]).args(args).output().unwrap();
    assert!(o.status.success(), "{what}: {}\n{}", o.status, String::from_utf8_lossy(&o.stderr));
}

fn run(cmd: Command, config: &Path, out: &Path, what: &str) {
    ok(cmd, &["run", config.to_str().unwrap(), "--out", out.to_str().unwrap()], what);
}

/// The outputs of a run, with what legitimately differs between two runs removed: `run.log`, the
/// lock, `timing.json`, the unit files (`*.gwck`, which carry wall-clock times; every output
/// made from them is compared), JSON keys and CSV columns named `…seconds…`.
fn outputs(d: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    for path in walk(d) {
        let name = path.strip_prefix(d).unwrap().display().to_string();
        assert!(!name.contains(".tmp"), "a temporary file was left behind: {name}");
        if ["run.log", ".grainwave.lock", "timing.json", "study.toml"].contains(&name.as_str()) || name.ends_with(".gwck") {
            continue;
        }
        let bytes = std::fs::read(&path).unwrap();
        let bytes = if name.ends_with(".json") {
            let mut v: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
            drop_timings(&mut v);
            serde_json::to_vec(&v).unwrap()
        } else if name.ends_with(".csv") {
            without_timing_columns(&String::from_utf8(bytes).unwrap()).into_bytes()
        } else {
            bytes
        };
        files.push((name, bytes));
    }
    files.sort();
    files
}

fn drop_timings(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.retain(|k, _| !k.contains("seconds"));
            m.values_mut().for_each(drop_timings);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(drop_timings),
        _ => {}
    }
}

fn without_timing_columns(text: &str) -> String {
    let mut lines = text.lines();
    let Some(header) = lines.next() else { return String::new() };
    let keep: Vec<bool> = header.split(',').map(|h| !h.contains("seconds")).collect();
    let pick = |l: &str| l.split(',').zip(&keep).filter(|(_, k)| **k).map(|(f, _)| f).collect::<Vec<_>>().join(",");
    std::iter::once(pick(header)).chain(lines.map(pick)).collect::<Vec<_>>().join("\n")
}

fn assert_same(a: &[(String, Vec<u8>)], b: &[(String, Vec<u8>)], what: &str) {
    let names = |f: &[(String, Vec<u8>)]| f.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(a), names(b), "{what}: other files");
    for ((n, x), (_, y)) in a.iter().zip(b) {
        assert!(x == y, "{what}: {n} differs");
    }
}

#[test]
fn e1_ensembles_and_e3_sweeps_give_the_same_outputs_on_1_2_and_3_ranks() {
    let e3 = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/e3-sweep.toml")).unwrap();
    for (name, text) in [("e1", E1), ("e3", e3.as_str())] {
        let d = dir(name);
        let cfg = config(&d, text);
        let alone = d.join("alone");
        run(single(), &cfg, &alone, &format!("{name} without mpirun"));
        let expected = outputs(&alone);
        assert!(expected.iter().any(|(n, _)| n == "summary.json") && expected.len() > 10, "{name}: {:?}", expected.iter().map(|f| &f.0).collect::<Vec<_>>());
        for n in [1, 2, 3] {
            let out = d.join(format!("np{n}"));
            run(mpirun(n), &cfg, &out, &format!("{name} on {n} rank(s)"));
            assert_same(&expected, &outputs(&out), &format!("{name}, {n} rank(s) vs one process"));
            if n > 1 {
                // the units did go to the other ranks
                let log = std::fs::read_to_string(out.join("run.log")).unwrap();
                assert!(log.contains(&format!("one at a time on each of {} other rank(s)", n - 1)), "{name}: {log}");
            }
        }
        let _ = std::fs::remove_dir_all(&d);
    }
}

/// Pids of the processes running rank `rank` of a command that names `marker`.
fn rank_pid(marker: &str, rank: usize) -> Option<u32> {
    for e in std::fs::read_dir("/proc").ok()?.flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else { continue };
        let cmdline = std::fs::read(e.path().join("cmdline")).unwrap_or_default();
        let environ = std::fs::read(e.path().join("environ")).unwrap_or_default();
        let has = |hay: &[u8], needle: &str| hay.windows(needle.len()).any(|w| w == needle.as_bytes());
        if has(&cmdline, marker) && has(&cmdline, "grainwave") && environ.split(|&b| b == 0).any(|v| v == format!("OMPI_COMM_WORLD_RANK={rank}").as_bytes()) {
            return Some(pid);
        }
    }
    None
}

#[test]
fn a_run_whose_rank_dies_stops_and_resumes_on_another_rank_count_to_the_same_outputs() {
    let d = dir("kill");
    let cfg = config(&d, E1_LONG);
    let out = d.join("killed");
    let mut cmd = mpirun(3);
    let mut child = cmd
        .args(["--threads", "1", "--quiet", "run", cfg.to_str().unwrap(), "--out", out.to_str().unwrap()])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // wait for three finished samples, then kill rank 2 (SIGKILL: no chance to clean up)
    let t = Instant::now();
    let finished = || walk(&out).into_iter().filter(|p| p.ends_with("result.gwck")).count();
    while finished() < 3 {
        assert!(t.elapsed() < Duration::from_secs(120), "no sample finished");
        assert!(child.try_wait().unwrap().is_none(), "the run ended before the kill");
        std::thread::sleep(Duration::from_millis(50));
    }
    let pid = rank_pid(out.to_str().unwrap(), 2).expect("rank 2 is running");
    assert!(Command::new("kill").args(["-KILL", &pid.to_string()]).status().unwrap().success());
    // the job stops (mpirun ends every rank: rank 0 checkpoints on the SIGTERM it gets), no hang
    let t = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(t.elapsed() < Duration::from_secs(60), "the run hangs after rank 2 died");
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    assert!(!status.success(), "{stderr}");
    assert!(stderr.contains("rank 2"), "the launcher names the rank that died: {stderr}");
    assert!(!out.join("summary.json").exists() && out.join("checkpoint.gwck").exists());
    let done = finished();
    // resumed on 2 ranks: the finished samples are kept, the others run, same outputs as one
    // process without MPI
    ok(mpirun(2), &["resume", out.to_str().unwrap()], "resume on 2 ranks");
    let log = std::fs::read_to_string(out.join("run.log")).unwrap();
    assert!(log.contains(&format!("{done} of 24 samples already done")), "{log}");
    let alone = d.join("alone");
    run(single(), &cfg, &alone, "without mpirun");
    assert_same(&outputs(&alone), &outputs(&out), "killed on 3 ranks and resumed on 2 vs one process");
    let _ = std::fs::remove_dir_all(&d);
}

fn walk(d: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut stack = vec![d.to_path_buf()];
    while let Some(p) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&p) else { continue };
        for e in entries.flatten() {
            let path = e.path();
            if path.is_dir() {
                stack.push(path);
            } else {
                files.push(path);
            }
        }
    }
    files
}

#[test]
fn version_says_mpi_is_in_and_a_bad_config_under_mpirun_exits_2_on_every_rank() {
    let o = single().arg("--version").output().unwrap();
    assert!(String::from_utf8_lossy(&o.stdout).contains("with MPI"));
    // rank 0 refuses the config; the other ranks are told to quit: no hang, exit code 2
    let d = dir("bad");
    let cfg = config(&d, &E1.replace("samples = 4", "samples = -4"));
    let o = mpirun(3).args(["--threads", "1", "run", cfg.to_str().unwrap(), "--out", d.join("out").to_str().unwrap()]).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("samples"), "{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&d);
}
