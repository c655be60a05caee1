//! `grainwave`: the command-line program. It parses arguments, calls an experiment protocol,
//! shows progress and prints a short summary; the work happens in `grainwave-experiments`.
//!
//! Exit codes: 0 success, 1 runtime failure (numerical blow-up, output files not writable…),
//! 2 bad input (unknown flag, invalid thread count, invalid parameters).

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use grainwave_experiments::demo::{run_demo, DemoConfig, DemoReport};
use grainwave_experiments::{Control, ExperimentError, Progress, StopReason};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Discrete-element simulations of granular materials: stress transmission and acoustics.
#[derive(Debug, Parser)]
#[command(name = "grainwave", version, propagate_version = true)]
struct Cli {
    /// Number of worker threads (default: one per core). Results are bitwise identical for any
    /// number of threads.
    #[arg(long, global = true, value_name = "N", value_parser = parse_threads)]
    threads: Option<usize>,

    /// Print no progress and no summary (warnings and errors still go to stderr).
    #[arg(long, short, global = true)]
    quiet: bool,

    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Settle 300 polydisperse disks under gravity in a box and check that the floor carries the
    /// whole weight; writes summary.json and grains.csv
    ///
    /// The disks start as a loose gas in the upper part of a box 20 wide with frictionless side
    /// walls, fall, and settle until every grain's acceleration is below 1e-7 g and the kinetic
    /// energy per grain below 1e-12. See docs/demo.md.
    Demo(DemoArgs),
}

#[derive(Debug, Args)]
struct DemoArgs {
    /// Output directory (created if needed; existing files of the same name are replaced).
    #[arg(long, value_name = "DIR", default_value = "grainwave-out/demo")]
    out: PathBuf,
}

/// Accepts a whole number of threads ≥ 1.
fn parse_threads(s: &str) -> std::result::Result<usize, String> {
    match s.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("`{s}` is not a thread count: give a whole number ≥ 1")),
    }
}

/// An error caused by the user's input (exit code 2) rather than by the run (exit code 1).
#[derive(Debug)]
struct BadInput(String);

impl std::fmt::Display for BadInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

fn main() -> ExitCode {
    let cli = Cli::parse(); // exits with code 2 on bad arguments, 0 for --help/--version
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("{}", error_chain(&err));
            let input = err.chain().any(|e| {
                e.is::<BadInput>() || e.downcast_ref::<ExperimentError>().is_some_and(ExperimentError::is_input_error)
            });
            ExitCode::from(if input { 2 } else { 1 })
        }
    }
}

/// "error: outer\n  caused by: inner…", skipping causes whose text the previous message
/// already ends with (some errors repeat their source in their own message).
fn error_chain(err: &anyhow::Error) -> String {
    let mut out = format!("error: {err}");
    let mut previous = err.to_string();
    for cause in err.chain().skip(1) {
        let text = cause.to_string();
        if previous.ends_with(&text) {
            continue;
        }
        out.push_str(&format!("\n  caused by: {text}"));
        previous = text;
    }
    out
}

fn run(cli: &Cli) -> Result<()> {
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .with_context(|| format!("cannot start a pool of {n} worker threads"))?;
    }
    match &cli.command {
        Command::Demo(args) => demo(args, cli.quiet),
    }
}

/// Runs `work` on a worker thread of the global thread pool and waits for it.
///
/// The engine's parallel loops, when called from a worker, split their work in place; called from
/// the main thread, every loop of every step is sent to the pool and waited for, which costs two
/// futex system calls per loop. Measured on the demo (300 grains, 133,300 steps, 2 cores):
/// 6.7 s from the main thread, 4.8 s on a worker with one thread, same results bit for bit.
fn on_worker<R: Send>(work: impl FnOnce() -> R + Send) -> R {
    rayon::scope(|_| work())
}

fn demo(args: &DemoArgs, quiet: bool) -> Result<()> {
    std::fs::create_dir_all(&args.out)
        .map_err(|e| BadInput(format!("cannot create the output directory `{}`: {e}", args.out.display())))?;
    let cfg = DemoConfig::default();
    let mut reporter = Reporter::new(quiet, &cfg);
    let start = Instant::now();
    let result = on_worker(|| run_demo(&cfg, &args.out, &mut |p| reporter.update(p, start.elapsed())).map_err(anyhow::Error::from));
    reporter.finish();
    let report = result.with_context(|| format!("the demo failed (outputs in `{}` are incomplete)", args.out.display()))?;
    let elapsed = start.elapsed();
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    if report.stop_reason != StopReason::Converged {
        eprintln!(
            "warning: the run stopped ({}) before reaching equilibrium; the floor force is not expected to equal the weight",
            reason_text(report.stop_reason)
        );
    }
    if !quiet {
        print_summary(&report, &args.out, elapsed);
    }
    Ok(())
}

fn reason_text(reason: StopReason) -> &'static str {
    match reason {
        StopReason::Converged => "converged",
        StopReason::StepLimit => "step limit reached",
        StopReason::TimeLimit => "time limit reached",
        StopReason::Interrupted => "interrupted",
    }
}

fn print_summary(r: &DemoReport, out: &Path, elapsed: Duration) {
    println!(
        "grainwave demo: {} after {} steps (simulated time {:.2}, wall clock {:.1} s)",
        reason_text(r.stop_reason),
        r.steps,
        r.simulated_time,
        elapsed.as_secs_f64()
    );
    println!("  grains          {} disks ({}), seed {}, pile height {:.2}", r.grains, r.dimension, r.seed, r.pile_height);
    println!(
        "  floor force     {:.6} = {:.9} × total weight {:.6}",
        r.floor_force, r.floor_force_over_weight, r.total_weight
    );
    println!("  kinetic energy  {:.3e} per grain", r.kinetic_energy_per_grain);
    println!(
        "  contacts        {} grain–grain, {} grain–wall, {} sliding",
        r.contacts.grain_grain, r.contacts.grain_wall, r.contacts.sliding
    );
    let mut label = "  outputs         ";
    for f in &r.files {
        println!("{label}{}", out.join(f).display());
        label = "                  ";
    }
}

/// Shows progress: a live line on a terminal, plain throttled lines otherwise, nothing if quiet.
enum Reporter {
    Silent,
    Bar(ProgressBar, StopTargets),
    Plain {
        /// When the last line was printed.
        last: Option<Duration>,
        /// The latest report and its time, if it has not been printed.
        pending: Option<(Progress, Duration)>,
        targets: StopTargets,
    },
}

/// Seconds between two plain progress lines when stderr is not a terminal.
const PLAIN_INTERVAL: Duration = Duration::from_secs(5);

impl Reporter {
    fn new(quiet: bool, cfg: &DemoConfig) -> Self {
        if quiet {
            return Reporter::Silent;
        }
        let targets = StopTargets { kinetic_energy_per_grain: cfg.stop.kinetic_energy_per_grain, max_acceleration: cfg.stop.max_acceleration };
        if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new_spinner();
            // `wide_msg` cuts the message to the terminal width, so the line never wraps.
            bar.set_style(ProgressStyle::with_template("{spinner} {elapsed:>4} {wide_msg}").expect("the template is valid"));
            bar.enable_steady_tick(Duration::from_millis(120));
            bar.set_message("placing grains");
            Reporter::Bar(bar, targets)
        } else {
            Reporter::Plain { last: None, pending: None, targets }
        }
    }

    fn update(&mut self, p: &Progress, elapsed: Duration) -> Control {
        match self {
            Reporter::Silent => {}
            Reporter::Bar(bar, targets) => bar.set_message(targets.describe(p)),
            Reporter::Plain { last, pending, targets } => {
                if last.is_none_or(|t| elapsed >= t + PLAIN_INTERVAL) {
                    print_plain(p, elapsed, targets);
                    *last = Some(elapsed);
                    *pending = None;
                } else {
                    *pending = Some((*p, elapsed));
                }
            }
        }
        Control::Continue
    }

    /// Clears the live line, or prints the final state if its line was skipped.
    fn finish(&mut self) {
        match self {
            Reporter::Silent => {}
            Reporter::Bar(bar, _) => bar.finish_and_clear(),
            Reporter::Plain { pending, targets, .. } => {
                if let Some((p, elapsed)) = pending.take() {
                    print_plain(&p, elapsed, targets);
                }
            }
        }
    }
}

fn print_plain(p: &Progress, elapsed: Duration, targets: &StopTargets) {
    eprintln!("[{:6.1} s] {}", elapsed.as_secs_f64(), targets.describe(p));
}

/// The equilibrium criteria the run stops at, shown next to the current values.
struct StopTargets {
    kinetic_energy_per_grain: Option<f64>,
    max_acceleration: Option<f64>,
}

impl StopTargets {
    /// "step 133200  t 84.25  KE/grain 1.9e-14 (<1e-12)  max accel 2.1e-6 (<1e-7)".
    fn describe(&self, p: &Progress) -> String {
        let target = |t: Option<f64>| t.map(|t| format!(" (<{t:.0e})")).unwrap_or_default();
        format!(
            "step {}  t {:.2}  KE/grain {:.1e}{}  max accel {:.1e}{}",
            p.step,
            p.time,
            p.kinetic_energy_per_grain,
            target(self.kinetic_energy_per_grain),
            p.max_acceleration,
            target(self.max_acceleration)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn arguments_are_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn thread_count_must_be_positive() {
        assert_eq!(parse_threads("3"), Ok(3));
        for bad in ["0", "-1", "two", "1.5", ""] {
            assert!(parse_threads(bad).is_err(), "{bad}");
        }
        let err = Cli::try_parse_from(["grainwave", "demo", "--threads", "0"]).unwrap_err();
        assert_eq!(err.exit_code(), 2);
    }

    #[test]
    fn demo_defaults_and_global_flags() {
        let cli = Cli::try_parse_from(["grainwave", "--quiet", "demo", "--threads", "2"]).unwrap();
        assert!(cli.quiet);
        assert_eq!(cli.threads, Some(2));
        let Command::Demo(args) = cli.command;
        assert_eq!(args.out, PathBuf::from("grainwave-out/demo"));
    }

    #[test]
    fn repeated_causes_are_printed_once() {
        let io = std::io::Error::new(std::io::ErrorKind::PermissionDenied, "denied");
        let err = anyhow::Error::new(io).context("cannot create `x`: denied").context("the demo failed");
        assert_eq!(error_chain(&err), "error: the demo failed\n  caused by: cannot create `x`: denied");
    }
}
