//! `grainwave`: the command-line program. It parses arguments, calls an experiment protocol,
//! shows progress and prints a short summary; the work happens in `grainwave-experiments`.
//!
//! Exit codes: 0 success; 1 runtime failure (numerical blow-up, output not writable…); 2 bad
//! input (unknown flag, invalid config, invalid thread count); 130 interrupted by Ctrl-C or
//! SIGTERM (the state is saved: `grainwave resume DIR` continues).

/// `println!` that never panics. When stdout is a pipe whose reader has gone (`grainwave … | head`)
/// the line is lost but the program carries on: a long run must not die, or exit 101, because
/// whoever watched it stopped reading.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

/// `eprintln!` that never panics (see `say!`): progress and error lines on a closed stderr are
/// dropped, the run and its exit code are unchanged.
macro_rules! tell {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr().lock(), $($arg)*);
    }};
}

mod bench;
mod inspect;
#[cfg(feature = "mpi")]
mod mpi;
mod progress;

use anyhow::{Context, Result};
use clap::{Args, CommandFactory, Parser, Subcommand};
use grainwave_experiments::config::ConfigSource;
use grainwave_experiments::protocol::{RunContext, UsedDirectory};
use grainwave_experiments::registry::{self, RunSummary};
use grainwave_experiments::ExperimentError;
use progress::CliReporter;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// The version line (`grainwave --version`): says whether the program can run under MPI.
const VERSION: &str = if cfg!(feature = "mpi") {
    concat!(env!("CARGO_PKG_VERSION"), " (with MPI: `mpirun -np N grainwave run …` spreads a study's units over N ranks)")
} else {
    concat!(env!("CARGO_PKG_VERSION"), " (without MPI; build with `--features mpi` to run under mpirun)")
};

/// Where the units of a run go (docs/cluster.md).
enum Ranks {
    /// This process runs them all (no MPI launcher, or a single rank).
    Alone,
    /// Rank 0 of an MPI run: units also go to the other ranks.
    #[cfg_attr(not(feature = "mpi"), allow(dead_code))]
    Coordinator(Arc<dyn grainwave_experiments::work::Link>),
    /// Another rank of an MPI run: runs the units rank 0 sends.
    #[cfg(feature = "mpi")]
    Worker(Arc<mpi::Comm>),
}

/// Tells the other ranks to quit when rank 0's command ends, however it ends.
struct QuitOnDrop(Option<Arc<dyn grainwave_experiments::work::Link>>);

impl Drop for QuitOnDrop {
    fn drop(&mut self) {
        if let Some(link) = &self.0 {
            grainwave_experiments::work::quit_all(&**link);
        }
    }
}

/// The MPI environment and this process's part, for `run` and `resume` under an MPI launcher.
#[cfg(feature = "mpi")]
fn ranks() -> Result<(Option<mpi::Mpi>, Ranks)> {
    Ok(match mpi::start()? {
        None => (None, Ranks::Alone),
        Some((env, ranks)) => (Some(env), ranks),
    })
}

/// Without MPI: a run started by `mpirun -np N` (N > 1) would start N copies of the same run;
/// refused, naming the build that can.
#[cfg(not(feature = "mpi"))]
fn ranks() -> Result<(Option<()>, Ranks)> {
    for var in ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "MPI_LOCALNRANKS"] {
        if let Some(n) = std::env::var(var).ok().and_then(|v| v.parse::<usize>().ok()) {
            if n > 1 {
                return Err(BadInput(format!(
                    "started by an MPI launcher with {n} ranks ({var} = {n}), but this grainwave was built without MPI: \
                     build it with `cargo build --release --features mpi` (docs/cluster.md), or run one process"
                ))
                .into());
            }
        }
    }
    Ok((None, Ranks::Alone))
}

/// A worker rank's whole command: runs the units rank 0 sends until it says to quit.
#[cfg(feature = "mpi")]
fn serve_as_worker(comm: &mpi::Comm) -> Result<()> {
    let interrupt = Arc::new(AtomicBool::new(false));
    {
        let flag = interrupt.clone();
        // the running unit saves its partial state and answers "interrupted"; a second signal
        // exits at once (every file is written atomically)
        let _ = ctrlc::set_handler(move || {
            if flag.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    rayon::scope(|_| registry::serve(comm, interrupt))?;
    Ok(())
}

/// Discrete-element simulations of granular materials: stress transmission and acoustics.
#[derive(Debug, Parser)]
#[command(name = "grainwave", version = VERSION, propagate_version = true)]
struct Cli {
    /// Number of worker threads (default: one per core). Results are bitwise identical for any
    /// number of threads.
    #[arg(long, global = true, value_name = "N", value_parser = parse_threads)]
    threads: Option<usize>,

    /// Print no progress and no summary (warnings and errors still go to stderr).
    #[arg(long, short, global = true)]
    quiet: bool,

    /// Lift the soft limits on sizes (grains, samples, points; see docs/config.md). Sizes that
    /// need more memory than the machine has available stay refused.
    #[arg(long, global = true)]
    allow_large: bool,

    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the experiment described by a config file
    Run(RunArgs),
    /// Run the embedded demo: a 200-grain E1 packing at p = 1e-4, its characterization, moduli and pulse
    Demo(OutArgs),
    /// Validate a config file without running it
    Check {
        /// The config file.
        config: PathBuf,
    },
    /// Continue an interrupted run from the checkpoint in its output directory
    Resume {
        /// The output directory of the run.
        dir: PathBuf,
        /// Resume a run that failed (its directory holds `run.failed`), after changing what made
        /// it fail.
        #[arg(long)]
        retry: bool,
    },
    /// Say what a checkpoint, config or output directory holds
    Inspect {
        /// A file or an output directory.
        path: PathBuf,
    },
    /// Re-make the plots of a run from its saved data
    Plot {
        /// The output directory of the run.
        dir: PathBuf,
    },
    /// Print the config reference (Markdown; the source of docs/config.md)
    Reference {
        /// Print the output reference instead: the files each study writes (the source of
        /// docs/outputs.md).
        #[arg(long)]
        outputs: bool,
    },
    /// Print shell completions
    Completions {
        /// Shell: bash, zsh, fish, elvish or powershell.
        shell: clap_complete::Shell,
    },
    /// Throughput on the LAMMPS benchmark packings (particle-steps per second), optionally with
    /// LAMMPS run back to back; see BENCHMARKS.md
    Bench(bench::BenchArgs),
}

#[derive(Debug, Args)]
struct RunArgs {
    /// The config file (TOML).
    config: PathBuf,
    /// Output directory (default: grainwave-out/<config file name>). A directory holding the
    /// outputs of an earlier run is refused unless `--overwrite` is given.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Remove the outputs of an earlier run from the output directory before running.
    #[arg(long)]
    overwrite: bool,
}

#[derive(Debug, Args)]
struct OutArgs {
    /// Output directory (created if needed; files of the same name are replaced).
    #[arg(long, value_name = "DIR", default_value = "grainwave-out/demo")]
    out: PathBuf,
}

/// Accepts a whole number of threads ≥ 1.
fn parse_threads(s: &str) -> std::result::Result<usize, String> {
    let max = max_threads();
    match s.parse::<usize>() {
        Ok(n) if (1..=max).contains(&n) => Ok(n),
        Ok(n) if n > max => Err(format!(
            "{n} threads is more than this machine can use (allowed: 1 to {max}, 4 × its {} cores, at least 64; results are the same for any thread count)",
            cores()
        )),
        _ => Err(format!("`{s}` is not a thread count: give a whole number ≥ 1")),
    }
}

/// Cores this process may use.
fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, usize::from)
}

/// Largest `--threads`: more threads than cores only add switching (the results do not depend
/// on the count), and each thread reserves a stack: `--threads 100000` took minutes to start.
fn max_threads() -> usize {
    (4 * cores()).max(64)
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
    // Config errors: source excerpt with the offending key underlined; never wrap lines (a file
    // path or key must stay on one line for editors and scripts to pick it up).
    let _ = miette::set_hook(Box::new(|_| Box::new(miette::MietteHandlerOpts::new().wrap_lines(false).build())));
    let cli = Cli::parse(); // exits with code 2 on bad arguments, 0 for --help/--version
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => report_error(&err),
    }
}

/// Prints an error and chooses the exit code.
fn report_error(err: &anyhow::Error) -> ExitCode {
    if let Some(e) = err.chain().find_map(|e| e.downcast_ref::<ExperimentError>()) {
        match e {
            ExperimentError::Config(c) => {
                let report = miette::Report::new((**c).clone());
                tell!("{report:?}");
                return ExitCode::from(2);
            }
            ExperimentError::Interrupted { .. } => {
                tell!("{e}");
                return ExitCode::from(130);
            }
            _ => {}
        }
    }
    tell!("{}", error_chain(err));
    // a checkpoint refused by the engine itself (damaged, crafted, inconsistent: `inspect`
    // decodes without the experiments' error type) is bad input too, as in `resume`
    let refused_checkpoint = |e: &(dyn std::error::Error + 'static)| matches!(e.downcast_ref::<grainwave_experiments::engine::core::CoreError>(), Some(grainwave_experiments::engine::core::CoreError::Checkpoint { .. }));
    let input = err
        .chain()
        .any(|e| e.is::<BadInput>() || refused_checkpoint(e) || e.downcast_ref::<ExperimentError>().is_some_and(ExperimentError::is_input_error));
    ExitCode::from(if input { 2 } else { 1 })
}

/// "error: outer\n  caused by: inner…", skipping causes whose text the previous message
/// already ends with.
fn error_chain(err: &anyhow::Error) -> String {
    let out = format!("error: {}", grainwave_experiments::error_chain(err.as_ref(), "\n  caused by: "));
    // extreme values (1e308 is 309 digits in `{}`) in exponent form
    grainwave_experiments::config::compact_numbers(&out)
}

fn run(cli: &Cli) -> Result<()> {
    grainwave_experiments::limits::set_allow_large(cli.allow_large);
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .with_context(|| format!("cannot start a pool of {n} worker threads"))?;
    }
    // under an MPI launcher, `run` and `resume` spread their units over the ranks
    let (_mpi, ranks) = if matches!(cli.command, Command::Run(_) | Command::Resume { .. }) { ranks()? } else { (None, Ranks::Alone) };
    let remote = match ranks {
        Ranks::Alone => None,
        Ranks::Coordinator(link) => Some(link),
        #[cfg(feature = "mpi")]
        Ranks::Worker(comm) => return serve_as_worker(&comm),
    };
    let _quit = QuitOnDrop(remote.clone());
    match &cli.command {
        Command::Run(args) => {
            let src = ConfigSource::from_file(&args.config).map_err(ExperimentError::from)?;
            let out = args.out.clone().unwrap_or_else(|| default_out(&args.config));
            // validate before touching the output directory: a refused config changes nothing there
            registry::check(&src).map_err(ExperimentError::from)?;
            registry::check_inputs(&src).map_err(ExperimentError::from)?;
            let mode = if args.overwrite { UsedDirectory::Overwrite } else { UsedDirectory::Refuse };
            execute(cli.quiet, &out, mode, remote, |ctx| registry::run(&src, ctx))
        }
        Command::Demo(args) => execute(cli.quiet, &args.out, UsedDirectory::Keep, None, |ctx| grainwave_experiments::demo::run_demo(ctx)),
        Command::Resume { dir, retry } => {
            if !dir.is_dir() {
                return Err(BadInput(format!("`{}` is not a directory (give the output directory of the run)", dir.display())).into());
            }
            if let Some(why) = grainwave_experiments::protocol::failure_of(dir) {
                if !retry {
                    let first = why.lines().next().unwrap_or("").to_string();
                    return Err(ExperimentError::Resume {
                        path: dir.clone(),
                        reason: format!("the run failed: {first} (see run.log; `grainwave resume --retry {}` tries again)", dir.display()),
                    }
                    .into());
                }
            }
            execute(cli.quiet, dir, UsedDirectory::Keep, remote, |ctx| {
                ctx.clear_failed();
                registry::resume(dir, ctx)
            })
        }
        Command::Check { config } => {
            let src = ConfigSource::from_file(config).map_err(ExperimentError::from)?;
            let lines = registry::check(&src).map_err(ExperimentError::from)?;
            registry::check_inputs(&src).map_err(ExperimentError::from)?;
            if !cli.quiet {
                say!("{}: valid", config.display());
                for l in lines {
                    say!("  {l}");
                }
            }
            Ok(())
        }
        Command::Inspect { path } => {
            if !path.exists() {
                return Err(BadInput(format!("`{}` does not exist", path.display())).into());
            }
            for l in inspect::describe(path)? {
                say!("{l}");
            }
            Ok(())
        }
        Command::Plot { dir } => {
            for f in registry::plot(dir)? {
                if !cli.quiet {
                    say!("{}", dir.join(f).display());
                }
            }
            Ok(())
        }
        Command::Reference { outputs } => {
            {
                use std::io::Write as _;
                let text = if *outputs { registry::outputs_markdown() } else { registry::reference_markdown() };
                let _ = write!(std::io::stdout().lock(), "{text}");
            }
            Ok(())
        }
        Command::Completions { shell } => {
            // generated into memory first: writing it to a closed stdout must not panic
            let mut script = Vec::new();
            clap_complete::generate(*shell, &mut Cli::command(), "grainwave", &mut script);
            {
                use std::io::Write as _;
                let _ = std::io::stdout().lock().write_all(&script);
            }
            Ok(())
        }
        Command::Bench(args) => bench::run(args, cli.quiet),
    }
}

/// `grainwave-out/<stem of the config file>`.
fn default_out(config: &Path) -> PathBuf {
    let stem = config.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "run".into());
    PathBuf::from("grainwave-out").join(stem)
}

/// Runs a protocol with progress display and Ctrl-C handling, then prints its summary.
fn execute(
    quiet: bool,
    out: &Path,
    mode: UsedDirectory,
    remote: Option<Arc<dyn grainwave_experiments::work::Link>>,
    work: impl FnOnce(&mut RunContext<'_>) -> grainwave_experiments::Result<RunSummary> + Send) -> Result<()> {
    let interrupt = Arc::new(AtomicBool::new(false));
    {
        let flag = interrupt.clone();
        // First Ctrl-C/SIGTERM: finish the current step, checkpoint, exit. Second: exit at once
        // (every file, checkpoints included, is written atomically, so nothing is half-written).
        let _ = ctrlc::set_handler(move || {
            if flag.swap(true, Ordering::SeqCst) {
                tell!("\ninterrupted again: exiting now");
                std::process::exit(130);
            }
            tell!("\ninterrupt: finishing the current step and saving a checkpoint (Ctrl-C again to quit at once)");
        });
    }
    let mut reporter = CliReporter::new(quiet);
    let started = std::time::Instant::now();
    let result = {
        let mut ctx = match RunContext::open(out, &mut reporter, interrupt, mode) {
            Ok(ctx) => ctx,
            Err(e) if e.is_input_error() => return Err(e.into()),
            // an output directory that cannot be created or written is the user's to fix: exit 2
            Err(e) => return Err(BadInput(format!("cannot use `{}`: {}", out.display(), error_chain(&anyhow::Error::new(e)).trim_start_matches("error: "))).into()),
        };
        if let Some(link) = remote {
            ctx.set_remote(link);
        }
        // Enter the thread pool once for the whole run (parallel loops then start in place).
        let result = rayon::scope(|_| work(&mut ctx));
        if let Err(e) = &result {
            ctx.mark_failed(e);
        }
        result
    };
    reporter.finish();
    let summary = result?;
    if !quiet {
        say!("grainwave: done in {:.1} s", started.elapsed().as_secs_f64());
        for l in &summary.lines {
            say!("  {l}");
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
        // bounded: `--threads 100000` spent minutes creating threads before this check
        let max = max_threads();
        assert!(max >= 64 && max >= cores());
        assert_eq!(parse_threads(&max.to_string()), Ok(max));
        let err = parse_threads(&(max + 1).to_string()).unwrap_err();
        assert!(err.contains(&format!("allowed: 1 to {max}")), "{err}");
        assert!(parse_threads("100000").is_err());
        let err = Cli::try_parse_from(["grainwave", "demo", "--threads", "100000"]).unwrap_err();
        assert_eq!(err.exit_code(), 2);
    }

    #[test]
    fn defaults_and_global_flags() {
        let cli = Cli::try_parse_from(["grainwave", "--quiet", "demo", "--threads", "2"]).unwrap();
        assert!(cli.quiet);
        assert_eq!(cli.threads, Some(2));
        let Command::Demo(args) = cli.command else { panic!("demo") };
        assert_eq!(args.out, PathBuf::from("grainwave-out/demo"));
        assert_eq!(default_out(Path::new("examples/pile.toml")), PathBuf::from("grainwave-out/pile"));
    }

    #[test]
    fn repeated_causes_are_printed_once() {
        let io = std::io::Error::new(std::io::ErrorKind::PermissionDenied, "denied");
        let err = anyhow::Error::new(io).context("cannot create `x`: denied").context("the run failed");
        assert_eq!(error_chain(&err), "error: the run failed\n  caused by: cannot create `x`: denied");
    }
}
