//! Adversarial inputs through the real program: each config in `tests/adversarial/` reproduces a
//! failure found by probing (an abort on a size, a check that passed what the run rejected, an
//! unguarded output directory…). Each must now be refused cleanly: the expected exit code, a
//! first line naming the key, a short message, and no allocation sized from the input first.

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_grainwave");

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/adversarial").join(name)
}

fn out(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("grainwave-adv-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Runs the program with `args` (one worker thread, quiet) and returns (exit code, stderr).
fn gw(args: &[&str]) -> (i32, String) {
    let o = Command::new(BIN).args(["--threads", "1", "--quiet"]).args(args).output().expect("the program starts");
    (o.status.code().unwrap_or(-1), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// `check` (and `run`, which validates the same way before computing) refuses `name` with exit
/// code 2 and a message naming `key`, of bounded length.
fn refused(name: &str, key: &str, words: &str) {
    let cfg = fixture(name);
    let cfg = cfg.to_str().unwrap();
    let dir = out(name);
    for args in [vec!["check", cfg], vec!["run", cfg, "--out", dir.to_str().unwrap()]] {
        let (code, err) = gw(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(&format!("`{key}`")), "{args:?}: the message does not name `{key}`: {err}");
        assert!(err.contains(words), "{args:?}: the message does not say `{words}`: {err}");
        assert!(err.len() < 4000, "{args:?}: {} bytes of message", err.len());
        assert!(!err.contains("memory allocation"), "{err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_grain_count_beyond_32_bit_ids_and_memory_is_refused() {
    // before: SIGABRT (exit 134) "memory allocation of 32000000000 bytes failed"
    refused("sim-grains-4e9.toml", "grains.count", "grains");
}

#[test]
fn a_huge_box_does_not_size_the_placement_grid() {
    // before: SIGABRT "memory allocation of 1375899741312 bytes failed" (the placement grid
    // had one cell per diameter of the box). Now the grid is bounded by the grain count and the
    // 300 grains are placed: check passes.
    let (code, err) = gw(&["check", fixture("sim-domain-2e32.toml").to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn a_billion_samples_are_refused_before_planning() {
    // before: check grew without bound (killed by a 30 s timeout under a 4 GB memory limit)
    refused("e1-samples-1e9.toml", "samples", "--allow-large");
}

#[test]
fn a_height_of_1e9_is_refused_by_check() {
    // before: check passed (1.03e10 grains) and run aborted
    refused("e1-heights-1e9.toml", "packing.heights[0]", "grains");
}

#[test]
fn a_tiny_profile_step_is_refused_by_check() {
    // before: check passed; run aborted in the output stage, after the computation
    refused("e3-profile-step-1e-12.toml", "response.profile_step", "profile points");
}

#[test]
fn an_e2_strip_count_beyond_memory_is_refused_by_check() {
    // found by the allocation audit: `vec![…; strips]` after the loading stage (capacity overflow)
    refused("e2-strips-huge.toml", "replays[0].strips", "strips");
}

#[test]
fn an_e3_sweep_whose_lists_multiply_beyond_the_limit_is_refused_before_planning() {
    // found by the allocation audit: 100 frictions × 100 stiffness ratios × 100 samples × 100
    // forces = 1e8 response runs, each list short; `check` built the whole plan
    refused("e3-runs-product.toml", "samples", "cases (sets × samples)");
}

#[test]
fn an_e1_histogram_bin_count_beyond_memory_is_refused_by_check() {
    // found by the allocation audit: one count per bin in the output stage (capacity overflow)
    refused("e1-histogram-bins.toml", "characterization.histogram_bins", "histogram bins");
}

#[test]
fn allow_large_lifts_only_the_soft_limits() {
    let cfg = fixture("e1-samples-1e9.toml");
    // 1e9 samples: the soft limit is lifted, but the plan's tasks still need more memory than any
    // machine of today has (1e9 tasks × 2 sizes × 2 pressures × 32 kB of signals)
    let (code, err) = gw(&["--allow-large", "check", cfg.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("of memory"), "{err}");
    let (code, err) = gw(&["--allow-large", "check", fixture("sim-grains-4e9.toml").to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
}

// ---- `check` catches what `run` would reject (issue list 2) ----

#[test]
fn a_duplicate_wall_name_is_refused_by_check() {
    // before: check passed, the run went to convergence and failed writing a CSV (exit 1)
    refused("sim-duplicate-wall.toml", "walls[1].name", "already the name of walls[0]");
}

#[test]
fn an_absurd_pressure_is_refused_by_check() {
    // before: check passed, every sample failed, exit 0, the message named `walls[1].force.value`
    refused("e1-pressure-1e308.toml", "packing.pressures[0]", "units of E*");
}

#[test]
fn a_subnormal_stiffness_is_blamed_on_the_key_the_file_has() {
    // before: `contact.tangential_stiffness` (a derived key) was blamed
    refused("sim-normal-stiffness-5e-324.toml", "contact.normal_stiffness", "[1e-100, 1e100]");
}

#[test]
fn an_array_for_a_table_is_refused() {
    // before: `pulse = []` was accepted silently (all defaults)
    refused("e1-pulse-array.toml", "pulse", "is a table");
}

#[test]
fn a_table_for_a_number_names_the_key() {
    // before: "invalid type: map, expected usize" (no key)
    refused("e1-samples-table.toml", "samples", "is a value");
}

#[test]
fn a_repeated_table_header_is_quoted() {
    // before: "duplicate key" (no name)
    let (code, err) = gw(&["check", fixture("e1-repeated-table.toml").to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("duplicate key: `[pulse]`"), "{err}");
}

#[test]
fn a_huge_bad_value_is_not_echoed_in_full() {
    // before: a 1 MB bad enum value gave 3.5 MB of error
    let dir = out("huge-value");
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("c.toml");
    let text = std::fs::read_to_string(fixture("e1-pressure-1e308.toml")).unwrap().replace("kind = \"sphere2d\"", &format!("kind = \"{}\"", "q".repeat(1 << 20)));
    std::fs::write(&cfg, text).unwrap();
    let (code, err) = gw(&["check", cfg.to_str().unwrap()]);
    assert_eq!(code, 2, "{}", &err[..err.len().min(2000)]);
    assert!(err.contains("packing.kind"), "{}", &err[..err.len().min(2000)]);
    assert!(err.len() < 3000, "{} bytes of message", err.len());
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- one run per directory (issue list 3) ----

const QUICK: &str = "tests/adversarial/quick.toml";

fn quick() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(QUICK)
}

#[test]
fn a_used_directory_is_refused_unless_overwrite_which_clears_it() {
    let dir = out("used");
    let d = dir.to_str().unwrap();
    let cfg = quick();
    let (code, err) = gw(&["run", cfg.to_str().unwrap(), "--out", d]);
    assert_eq!(code, 0, "{err}");
    // before: a second run into the directory exited 0 and left the first run's files beside its own
    let (code, err) = gw(&["run", cfg.to_str().unwrap(), "--out", d]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--overwrite") && err.contains("resume"), "{err}");
    let stale = dir.join("snapshot-from-an-earlier-run.vtp");
    std::fs::write(&stale, b"x").unwrap();
    let (code, err) = gw(&["run", cfg.to_str().unwrap(), "--out", d, "--overwrite"]);
    assert_eq!(code, 0, "{err}");
    assert!(!stale.exists(), "--overwrite leaves the earlier run's files");
    // a directory of other files is never cleared
    let other = out("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("notes.txt"), b"mine").unwrap();
    let (code, err) = gw(&["run", cfg.to_str().unwrap(), "--out", other.to_str().unwrap(), "--overwrite"]);
    assert_eq!(code, 2, "{err}");
    assert!(other.join("notes.txt").exists());
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&other);
}

#[test]
fn a_busy_directory_is_refused() {
    // before: two runs into one directory both exited 0 and interleaved their files. Here this
    // test process holds the directory's lock, as a running grainwave does (an advisory lock
    // on `.grainwave.lock`, released by the system when its holder ends).
    let dir = out("busy");
    std::fs::create_dir_all(&dir).unwrap();
    let d = dir.to_str().unwrap();
    let cfg = quick();
    let lock = std::fs::OpenOptions::new().create(true).truncate(false).write(true).open(dir.join(".grainwave.lock")).unwrap();
    lock.try_lock().unwrap();
    for args in [vec!["run", cfg.to_str().unwrap(), "--out", d], vec!["resume", d], vec!["demo", "--out", d]] {
        let (code, err) = gw(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains("in use by another grainwave process"), "{args:?}: {err}");
    }
    drop(lock);
    // released: the run proceeds
    let (code, err) = gw(&["run", cfg.to_str().unwrap(), "--out", d]);
    assert_eq!(code, 0, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_checkpoint_of_another_run_is_refused_by_resume() {
    let (a, b) = (out("seed-a"), out("seed-b"));
    let cfg = quick();
    let text = std::fs::read_to_string(&cfg).unwrap();
    let other = out("seed-b-config");
    std::fs::create_dir_all(&other).unwrap();
    let cfg_b = other.join("b.toml");
    std::fs::write(&cfg_b, text.replacen("seed = ", "seed = 1000", 1)).unwrap();
    assert_eq!(gw(&["run", cfg.to_str().unwrap(), "--out", a.to_str().unwrap()]).0, 0);
    assert_eq!(gw(&["run", cfg_b.to_str().unwrap(), "--out", b.to_str().unwrap()]).0, 0);
    std::fs::copy(b.join("checkpoint.gwck"), a.join("checkpoint.gwck")).unwrap();
    // before: resumed without complaint
    let (code, err) = gw(&["resume", a.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("belongs to another run") && err.contains("config.resolved.toml"), "{err}");
    for d in [a, b, other] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn a_damaged_checkpoint_is_an_input_error_that_says_what_is_wrong() {
    // before: bytes appended exited 1 (and were called "truncated"), while a checkpoint of
    // another run exited 2; both are a checkpoint that does not fit the directory: exit 2
    let dir = out("damaged");
    let d = dir.to_str().unwrap();
    assert_eq!(gw(&["run", quick().to_str().unwrap(), "--out", d]).0, 0);
    let ck = dir.join("checkpoint.gwck");
    let good = std::fs::read(&ck).unwrap();
    let mut longer = good.clone();
    longer.extend_from_slice(b"xxxxxxxx");
    std::fs::write(&ck, &longer).unwrap();
    let (code, err) = gw(&["resume", d]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("8 unexpected bytes after the end of the checkpoint"), "{err}");
    std::fs::write(&ck, &good[..good.len() - 5]).unwrap();
    let (code, err) = gw(&["resume", d]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("truncated") && err.contains("5 bytes missing"), "{err}");
    let mut flipped = good.clone();
    let k = flipped.len() - 3;
    flipped[k] ^= 0x40;
    std::fs::write(&ck, &flipped).unwrap();
    let (code, err) = gw(&["resume", d]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("checksum mismatch"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_wall_time_function_error_names_the_whole_key() {
    // before: `walls[3].times` for `walls[3].speed.times`
    refused("sim-wall-speed-times.toml", "walls[3].speed.times", "strictly increasing");
}

// ---- blow-ups mark the directory as failed (issue list 4) ----

#[test]
fn a_blow_up_is_logged_marked_and_not_resumed_without_retry() {
    let dir = out("blow-up");
    let d = dir.to_str().unwrap();
    let (code, err) = gw(&["run", fixture("sim-blow-up.toml").to_str().unwrap(), "--out", d]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("numerical blow-up"), "{err}");
    let log = std::fs::read_to_string(dir.join("run.log")).unwrap();
    assert!(log.contains("failed: numerical blow-up"), "{log}");
    assert!(std::fs::read_to_string(dir.join("run.failed")).unwrap().starts_with("numerical blow-up"));
    // before: inspect called the directory "in progress or interrupted"
    let o = Command::new(BIN).args(["inspect", d]).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("FAILED: numerical blow-up") && !text.contains("in progress"), "{text}");
    // before: resume blew up again
    let (code, err) = gw(&["resume", d]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("the run failed: numerical blow-up") && err.contains("--retry"), "{err}");
    // --retry gets past the marker (here it resumes from the starting state, saved before the
    // first step, and blows up again)
    let (code, err) = gw(&["resume", "--retry", d]);
    assert_ne!(code, 0, "{err}");
    assert!(!err.contains("the run failed"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- a run whose units fail at run time (issue list 2: never exit 0, never a crash in the output stage) ----

/// Runs `fixture` into a fresh directory; returns (exit code, stderr, directory).
fn run_fixture(name: &str) -> (i32, String, PathBuf) {
    let dir = out(name);
    let (code, err) = gw(&["run", fixture(name).to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    (code, err, dir)
}

/// The directory is marked as failed with `first` as the diagnosis, `inspect` says so, the log
/// has it, and no summary was written.
fn marked_failed(dir: &Path, first: &str) {
    let failed = std::fs::read_to_string(dir.join("run.failed")).unwrap();
    assert!(failed.starts_with(first), "run.failed: {failed}");
    let log = std::fs::read_to_string(dir.join("run.log")).unwrap();
    assert!(log.contains(&format!("failed: {first}")), "{log}");
    assert!(!dir.join("summary.json").exists(), "a summary was written for a failed run");
    let o = Command::new(BIN).args(["inspect", dir.to_str().unwrap()]).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains(&format!("FAILED: {first}")), "{text}");
}

#[test]
fn e1_every_sample_failing_exits_1_with_the_list() {
    // before (with `max_acceleration = 1.5`, now refused by `check`): every sample failed, then
    // the plot step failed ("no data series", exit 1, no summary). A step limit far too small is
    // a failure that only the run can find.
    let (code, err, dir) = run_fixture("e1-step-limit.toml");
    assert_eq!(code, 1, "{err}");
    assert!(err.starts_with("error: every one of the 8 samples failed"), "{err}");
    // one line per sample (2 heights × 2 pressures × 2 seeds), each naming its group and seed
    for group in ["p1e-5_L6", "p1e-4_L6", "p1e-5_L10", "p1e-4_L10"] {
        for seed in [1, 2] {
            assert!(err.contains(&format!("\n    {group} seed {seed}: ")), "{group} seed {seed} not listed: {err}");
        }
    }
    assert!(!err.contains("no data series") && !err.contains("panicked"), "{err}");
    assert!(err.contains("reached no equilibrium within") && !err.contains("inconsistent set-up"), "{err}");
    marked_failed(&dir, "every one of the 8 samples failed");
    // before: `plot` of that directory failed in the plot stage ("the plot has no data series")
    let (code, err) = gw(&["plot", dir.to_str().unwrap()]);
    assert_eq!(code, 1, "{err}");
    assert!(err.starts_with("error: every one of the 8 finished samples failed"), "{err}");
    assert!(!err.contains("no data series"), "{err}");
    // and `plot` of a directory that is not a run says `plot`, not `resume`
    let empty = out("not-a-run");
    std::fs::create_dir_all(&empty).unwrap();
    let (code, err) = gw(&["plot", empty.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.starts_with("error: cannot plot"), "{err}");
    let _ = std::fs::remove_dir_all(&empty);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_e1_tolerance_met_by_the_uncompressed_gas_is_refused_by_check() {
    // before: `check` passed it, then `run` made every sample fail ("no free grain is in contact
    // with wall `bottom`": the preparation stopped at step 0, before compressing the gas)
    refused("e1-max-acceleration-1.5.toml", "preparation.max_acceleration", "met by the uncompressed gas at step 0");
}

#[test]
fn e3_every_response_run_failing_exits_1_with_the_list() {
    // before: the first failure only (the other runs' failures were dropped)
    let (code, err, dir) = run_fixture("e3-forces-1e12.toml");
    assert_eq!(code, 1, "{err}");
    assert!(err.starts_with("error: every one of the 2 response runs failed"), "{err}");
    for f in ["F1000000000000: numerical blow-up", "F2000000000000: numerical blow-up"] {
        assert!(err.contains(f), "`{f}` not listed: {err}");
    }
    // the reference state was done and is kept
    assert!(dir.join("units/L8xM20_d0_mu0.5_kt0.8_s1/reference.gwck").exists());
    marked_failed(&dir, "every one of the 2 response runs failed");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn e3_some_runs_failing_exits_1_naming_them_and_keeps_the_others() {
    let (code, err, dir) = run_fixture("e3-one-force-1e12.toml");
    assert_eq!(code, 1, "{err}");
    assert!(err.starts_with("error: 1 of the 2 response runs failed"), "{err}");
    assert!(err.contains("F1000000000000: numerical blow-up") && !err.contains("F0.5:"), "{err}");
    assert!(dir.join("units/L8xM20_d0_mu0.5_kt0.8_s1/F0.5.gwck").exists(), "the completed run was not kept");
    marked_failed(&dir, "1 of the 2 response runs failed");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn e2_failing_replays_exit_1_naming_each_and_are_not_resumed_without_retry() {
    // the two replays read only the loading: both run, both fail, and each is listed by its id
    let (code, err, dir) = run_fixture("e2-replay-blow-up.toml");
    assert_eq!(code, 1, "{err}");
    assert!(err.starts_with("error: every one of the 2 replays failed"), "{err}");
    assert!(err.contains("replay/fast: numerical blow-up") && err.contains("replay/faster: numerical blow-up"), "{err}");
    // the loading before them is kept
    assert!(dir.join("loading.csv").exists() && dir.join("checkpoints/index.csv").exists());
    marked_failed(&dir, "every one of the 2 replays failed");
    let (code, err) = gw(&["resume", dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--retry"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- closed output streams ----

/// Runs the program with stdout and stderr piped and both read ends closed before it writes
/// anything, as `grainwave run … 2>&1 | head -1` does once `head` has its line; returns the exit
/// code.
fn with_closed_pipes(args: &[&str]) -> i32 {
    use std::process::Stdio;
    let mut child = Command::new(BIN)
        .args(["--threads", "1"])
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the program starts");
    drop(child.stdout.take());
    drop(child.stderr.take());
    child.wait().expect("the program ends").code().unwrap_or(-1)
}

#[test]
fn closed_output_pipes_neither_panic_nor_stop_a_run() {
    // before: the first progress line written to the closed pipe panicked ("failed printing to
    // stderr"), exit 101, the run lost. Now the lines are dropped and the run finishes.
    let dir = out("closed-pipes");
    let code = with_closed_pipes(&["run", quick().to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(dir.join("summary.json").exists(), "the run did not finish");
    // an error still gets its exit code
    let code = with_closed_pipes(&["check", fixture("sim-duplicate-wall.toml").to_str().unwrap()]);
    assert_eq!(code, 2);
    // the outputs of the other commands
    assert_eq!(with_closed_pipes(&["reference"]), 0);
    assert_eq!(with_closed_pipes(&["completions", "bash"]), 0);
    assert_eq!(with_closed_pipes(&["inspect", dir.to_str().unwrap()]), 0);
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- endless inputs ----

#[test]
fn an_endless_config_or_checkpoint_is_refused_without_filling_the_memory() {
    // before: `check /dev/zero` and `inspect /dev/zero` read until the memory ran out
    if !Path::new("/dev/zero").exists() {
        eprintln!("skipped: no /dev/zero on this system");
        return;
    }
    let (code, err) = gw(&["check", "/dev/zero"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("longer than 16 MiB"), "{err}");
    let (code, err) = gw(&["inspect", "/dev/zero"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("not a regular file"), "{err}");
    // a resume whose checkpoint is not a regular file
    let dir = out("endless");
    std::fs::create_dir_all(dir.join("checkpoint.gwck")).unwrap();
    let (code, err) = gw(&["resume", dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("a directory"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_config_from_a_pipe_is_still_read() {
    use std::io::Write;
    use std::process::Stdio;
    let text = std::fs::read(quick()).unwrap();
    let mut child = Command::new(BIN)
        .args(["check", "/dev/stdin"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the program starts");
    child.stdin.take().unwrap().write_all(&text).unwrap();
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("valid"));
}

/// Starts the program with `args` (one worker thread, quiet), stderr captured.
fn spawn(args: &[&str]) -> std::process::Child {
    Command::new(BIN)
        .args(["--threads", "1", "--quiet"])
        .args(args)
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .expect("the program starts")
}

/// Waits up to `limit` for `child`; kills it and fails the test if it is still running.
fn wait_at_most(child: &mut std::process::Child, limit: std::time::Duration, what: &str) -> (i32, String) {
    let start = std::time::Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            let _ = std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err);
            return (status.code().unwrap_or(-1), err);
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what}: still running after {limit:?}");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

fn signal(child: &std::process::Child, sig: &str) {
    let ok = Command::new("kill").args([sig, &child.id().to_string()]).status().unwrap().success();
    assert!(ok, "kill {sig}");
}

#[test]
fn a_radius_that_rounds_to_zero_is_refused_by_check() {
    // before: check and run never answered (the placement grid's cell grew from 0 by × 1.26)
    refused("sim-zero-radius.toml", "grains.size.mean_diameter", "between 1e-60 and 1e60");
}

#[test]
fn a_gas_fraction_of_5e_324_is_refused_by_check() {
    // before: check passed, run looped for ever sizing the placement grid of an infinite gas box
    refused("e1-gas-fraction-5e-324.toml", "preparation.gas_fraction", "[0.001, 0.6)");
    refused("e2-gas-fraction-5e-324.toml", "packing.gas_fraction", "[0.001, 0.5]");
}

#[test]
fn a_speed_of_1e30_in_a_periodic_box_ends_with_a_diagnosis() {
    // before: the periodic wrap subtracted one box length at a time from 1e30 × dt, for ever
    let dir = out("speed-1e30");
    let cfg = fixture("sim-speed-1e30-periodic.toml");
    let mut child = spawn(&["run", cfg.to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    // generous for a loaded machine: the run takes milliseconds
    let (code, err) = wait_at_most(&mut child, std::time::Duration::from_secs(60), "a run at 1e30");
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("blow-up"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ctrl_c_is_honoured_whatever_the_preparation_chunk() {
    // before: with check_every = 2^32 the preparation looked at the interrupt flag only between
    // chunks; a Ctrl-C printed its message and the run went on for minutes
    let dir = out("check-every");
    let cfg = fixture("e1-check-every-2e32.toml");
    let mut child = spawn(&["run", cfg.to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    // once the sample's preparation has begun (its directory exists), interrupt
    crate::wait_for(&dir.join("samples"), std::time::Duration::from_secs(60));
    std::thread::sleep(std::time::Duration::from_millis(500));
    signal(&child, "-INT");
    let (code, err) = wait_at_most(&mut child, std::time::Duration::from_secs(30), "an interrupted preparation");
    assert_eq!(code, 130, "{err}");
    assert!(dir.join("checkpoint.gwck").exists(), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_run_killed_at_once_resumes_and_a_directory_without_a_checkpoint_says_so() {
    // before: e2 first saved after `output.save_every` = 300 s; a run killed earlier left only
    // config.resolved.toml and run.log, which `run` refused (pointing to `resume`) and `resume`
    // refused (no checkpoint). Now every run saves its starting state first.
    let dir = out("killed");
    let d = dir.to_str().unwrap();
    let cfg = fixture("e2-small.toml");
    let mut child = spawn(&["run", cfg.to_str().unwrap(), "--out", d]);
    crate::wait_for(&dir.join("checkpoint.gwck"), std::time::Duration::from_secs(60));
    signal(&child, "-KILL");
    let _ = child.wait();
    let (code, err) = gw(&["resume", d]);
    assert_eq!(code, 0, "{err}");
    assert!(dir.join("summary.json").exists());
    // a directory left by an earlier version, which saved nothing before it was killed
    let dead = out("dead-end");
    std::fs::create_dir_all(&dead).unwrap();
    std::fs::copy(dir.join("config.resolved.toml"), dead.join("config.resolved.toml")).unwrap();
    std::fs::write(dead.join("run.log"), b"[     0.0 s] e2: preparing 400 disks\n").unwrap();
    let dd = dead.to_str().unwrap();
    let (code, err) = gw(&["resume", dd]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("nothing to resume") && err.contains("--overwrite"), "{err}");
    let (code, err) = gw(&["run", cfg.to_str().unwrap(), "--out", dd]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("stopped before it saved anything") && err.contains("--overwrite") && !err.contains("grainwave resume"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&dead);
}

/// An e2 config with `n` replays, each (after the first) `from` the one before.
fn e2_chain(n: usize) -> String {
    let mut s = String::from("experiment = \"e2\"\n[packing]\ncolumns = 10\nrows = 10\n[loading]\nfinal_strain = 2e-4\ncheckpoint_strain = 2e-5\n");
    for k in 0..n {
        s.push_str(&format!("[[replays]]\nname = \"r{k}\"\ncheckpoint = -1\nmodification = \"velocity_scale\"\n"));
        if k > 0 {
            s.push_str(&format!("from = \"r{}\"\n", k - 1));
        }
    }
    s
}

#[test]
fn a_long_chain_of_e2_replays_is_checked_without_a_quadratic_cost_and_the_count_is_bounded() {
    // before: `check` compared each `from` with every earlier replay's name: 30 000 chained
    // replays took 80 s, 180 000 (within the 16 MiB config limit) about 40 minutes; nothing
    // bounded the count (100 001 replays were accepted)
    let dir = out("chain");
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("chain.toml");
    std::fs::write(&cfg, e2_chain(30_000)).unwrap();
    let mut child = spawn(&["check", cfg.to_str().unwrap()]);
    // a hang guard, not a timing: the check takes well under a second now
    let (code, err) = wait_at_most(&mut child, std::time::Duration::from_secs(30), "check of 30 000 chained replays");
    assert_eq!(code, 0, "{err}");
    std::fs::write(&cfg, e2_chain(100_001)).unwrap();
    let (code, err) = gw(&["check", cfg.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("`replays`") && err.contains("exceed the limit"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn errors_name_the_key_the_file_has() {
    // before, each of these was refused naming no key (serde's "invalid type: map, expected f64"
    // at the section header), a key no file has, or another key
    refused("e1-packing-width-table.toml", "packing.width", "a table, but `packing.width` is a value");
    refused("settle-pile-mean-diameter-string.toml", "grains.size.mean_diameter", "text \"x\", but `grains.size.mean_diameter` takes a number");
    refused("e1-parallel_samples-2e31.toml", "parallel_samples", "GiB");
    refused("sim-kt-ratio-1e308.toml", "contact.tangential_stiffness_ratio", "k_t = ratio × normal_stiffness a finite, normal number");
    refused("sim-origin-1e17.toml", "domain.origin", "keeps its size");
    refused("sim-radius-1e-300.toml", "grains.size.radius", "between 1e-60 and 1e60");
}

// ---- check = run: what a run would refuse or fail on, known from the config, is refused by
// `check` (exit 2, at the key the file has) — reproducers 17, 19–27, 30–32 of the second probe ----

#[test]
fn nan_is_refused_at_its_key_wherever_it_is() {
    // before: `check` passed; a NaN slips through every range check (all comparisons are false)
    refused("sim-not-before-nan.toml", "stop.not_before_time", "nan (allowed: a number");
    refused("e1-chain-tof-nan.toml", "pulse.tof_heights[1]", "nan (allowed: a number");
}

#[test]
fn a_fixed_length_list_of_another_length_is_refused() {
    // before: [k_n, k_t, 7.0] was read as [k_n, k_t] without a word (a list of 1 was refused)
    refused("e3-lattice-horizontal-3.toml", "lattice.horizontal", "a list of 3 values (allowed: exactly 2 values)");
    refused("e3-bracket-3.toml", "first_opening.bracket", "a list of 3 values (allowed: exactly 2 values)");
}

#[test]
fn e2_values_the_engine_would_refuse_are_refused_at_the_e2_key() {
    // before: `check` 0, `run` 2 at start naming engine keys the file does not have
    // (`contact.rolling_stiffness`, `walls[2].mass`, `gravity[0]`)
    refused("e2-normal_stiffness-5e-324.toml", "material.normal_stiffness", "[1e-100, 1e100]");
    refused("e2-rolling_stiffness-1e308.toml", "material.rolling_stiffness", "rolling stiffness");
    refused("e2-wall_mass-1e308.toml", "preparation.wall_mass", "pistons' mass");
    refused("e2-gravity-1e308.toml", "preparation.gravity", "gravity inf");
}

#[test]
fn an_e2_source_directory_that_is_not_there_is_refused_by_check() {
    // before: `check` 0; `run` failed every replay at its start (exit 1: "no checkpoint -1 in …")
    refused("e2-source-dir-missing.toml", "source.dir", "is not a directory");
    // a directory without strain checkpoints
    let dir = out("empty-source");
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("c.toml");
    let text = std::fs::read_to_string(fixture("e2-source-dir-missing.toml")).unwrap().replace("no-such-e2-run", dir.to_str().unwrap());
    std::fs::write(&cfg, text).unwrap();
    let (code, err) = gw(&["check", cfg.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("`source.dir`") && err.contains("holds no strain checkpoint"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn e2_replays_that_fail_after_the_loading_are_refused_by_check() {
    // before: the packing was prepared and loaded, then the replay failed (exit 1)
    refused("e2-replay-name-300.toml", "replays[0].name", "300 characters (allowed: at most 200");
    refused("e2-top-pulse-without-piston.toml", "replays[0].pulse_wall", "is not a piston");
    // before: the loading ran, then both replays failed on the checkpoints' bookkeeping
    refused("e2-checkpoint-strain-5e-324.toml", "loading.checkpoint_strain", "finite number of checkpoints");
}

#[test]
fn an_e2_preparation_without_equilibrium_is_a_run_failure_exit_1() {
    // before: exit 2 ("inconsistent set-up"), as if the config were invalid; it is valid, and
    // only the run finds that the preparation reaches no equilibrium in `preparation.max_time`
    let (code, err, dir) = run_fixture("e2-no-equilibrium.toml");
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("no equilibrium") && err.contains("`preparation.max_time`"), "{err}");
    assert!(!err.contains("inconsistent set-up"), "{err}");
    marked_failed(&dir, "the preparation reached no equilibrium");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn e3_values_that_fail_the_units_are_refused_by_check() {
    // before: the reference states and runs were computed, then every run failed writing its
    // table ("CSV column `dsigma_w2` appears twice")
    refused("e3-duplicate-widths.toml", "response.widths[1]", "appears twice");
    // before: every unit failed at its start ("File name too long": 5e-324 written out in full)
    refused("e3-friction-5e-324.toml", "material.friction", "within 255 bytes");
    // before: every response run failed at its start with `stop.max_acceleration` (no e3 key)
    refused("e3-forces-5e-324.toml", "load.forces", "stopping tolerances");
    refused("e3-response-max-acceleration-1e308.toml", "relaxation.response_max_acceleration", "finite");
}

#[test]
fn an_e1_chain_the_engine_cannot_build_is_refused_by_check() {
    // before: every sample failed at its start naming `contact.normal_stiffness`, `grains.position`
    refused("e1-chain-stiffness-1e308.toml", "chain.stiffness", "[1e-100, 1e100]");
    refused("e1-chain-spacing-1e308.toml", "chain.spacing", "[1e-60, 1e60]");
}

#[test]
fn values_that_failed_the_output_stage_are_refused_by_check() {
    // before: the computation ran, then the plots failed (exit 1, the work lost)
    refused("e1-transits-1e308.toml", "pulse.transits", "time grid");
    refused("e3-lattice-tangential_ratios-1e308.toml", "lattice.tangential_ratios[0]", "criterion r");
    refused("sim-piston-tiny-mass-huge-force.toml", "walls[3].mass", "acceleration");
    refused("sim-velocity-table-1e308.toml", "walls[3].speed", "differences overflow");
}

#[test]
fn a_placement_region_behind_a_wall_names_its_key() {
    // before: "inconsistent set-up: grain id 1 … is behind wall `left`", no key
    refused("sim-origin-outside-region.toml", "placement.region_min", "is behind wall `left`");
}

#[test]
fn lammps_non_finite_tilt_and_spin_are_refused_naming_them() {
    // before: a NaN tilt xy was dropped (the state hash of the untilted box, exit 0); a NaN
    // angular velocity was refused quoting the finite position and velocity
    for (dir, words) in [("lmp-tilt-nan", "tilt factor xy = NaN"), ("lmp-omega-nan", "atom 1 has wx = NaN")] {
        let (code, err) = gw(&["bench", "--dir", fixture(dir).to_str().unwrap(), "hooke3d", "--steps", "2"]);
        assert_eq!(code, 2, "{dir}: {err}");
        assert!(err.contains(words), "{dir}: {err}");
    }
}

// ---- one exit code per fault class (docs/hardening.md, "Exit codes") ----

#[test]
fn bad_arguments_and_unfinished_runs_are_input_errors_exit_2() {
    // before: `bench --shear nan` exit 1
    let (code, err) = gw(&["bench", "--dir", "/nonexistent", "hooke3d", "--shear", "nan"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--shear"), "{err}");
    // before: `plot` of an unfinished run exit 1, "cannot write the outputs … series.npz: No such file"
    let dir = out("unfinished-plot");
    let (code, err) = gw(&["run", quick().to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    std::fs::remove_file(dir.join("summary.json")).unwrap();
    std::fs::remove_file(dir.join("series.npz")).unwrap();
    let (code, err) = gw(&["plot", dir.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("has not finished") && err.contains("grainwave resume"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

// ---- messages: bounded, harmless for the terminal ----

#[test]
fn a_huge_unknown_key_or_a_huge_neighbouring_line_is_not_quoted_in_full() {
    // before: 1 000 385 bytes (the unknown key quoted in full) and 4 000 422 bytes (the 4 MB line
    // next to the error shown in the source excerpt)
    let dir = out("huge-key");
    std::fs::create_dir_all(&dir).unwrap();
    let base = std::fs::read_to_string(quick()).unwrap();
    let key = dir.join("key.toml");
    // the last table of the file is `[output]`: the key is unknown there
    std::fs::write(&key, format!("{base}\n{} = 1\n", "k".repeat(1 << 20))).unwrap();
    let line = dir.join("line.toml");
    std::fs::write(&line, format!("units = \"{}\"\nzz_bad = 1\n{base}", "u".repeat(4 << 20))).unwrap();
    for cfg in [&key, &line] {
        let (code, err) = gw(&["check", cfg.to_str().unwrap()]);
        assert_eq!(code, 2, "{}", &err[..err.len().min(2000)]);
        assert!(err.contains("unknown key"), "{}", &err[..err.len().min(2000)]);
        assert!(err.len() < 2000, "{}: {} bytes of message", cfg.display(), err.len());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn control_characters_of_the_input_are_escaped_in_messages() {
    // before: the ESC and BEL of a quoted key went raw to the terminal (recolouring it, setting its title)
    let dir = out("control");
    std::fs::create_dir_all(&dir).unwrap();
    let cfg = dir.join("c.toml");
    std::fs::write(&cfg, format!("{}\n\"\\u001b[31mRED\\u001b]0;title\\u0007\" = 1\n", std::fs::read_to_string(quick()).unwrap())).unwrap();
    // (in `[output]`, the file's last table: an unknown key, quoted in the message)
    let (code, err) = gw(&["check", cfg.to_str().unwrap()]);
    assert_eq!(code, 2, "{err}");
    assert!(!err.contains('\u{1b}') && !err.contains('\u{7}'), "raw control characters in {err:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
