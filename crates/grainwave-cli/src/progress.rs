//! Progress display: indicatif bars on a terminal, plain throttled lines otherwise, nothing when
//! quiet. Implements the protocols' `Reporter`.

use grainwave_experiments::protocol::Reporter;
use grainwave_experiments::Progress;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// Seconds between two plain progress lines when stderr is not a terminal.
const PLAIN_INTERVAL: Duration = Duration::from_secs(5);

/// The CLI's reporter.
pub struct CliReporter {
    mode: Mode,
    started: Instant,
    stage: String,
    last_plain: Option<Instant>,
    pending: Option<String>,
}

enum Mode {
    Quiet,
    Bars { multi: MultiProgress, steps: Option<ProgressBar>, samples: Option<ProgressBar> },
    Plain,
}

impl CliReporter {
    /// A reporter for the current terminal.
    pub fn new(quiet: bool) -> Self {
        let mode = if quiet {
            Mode::Quiet
        } else if std::io::stderr().is_terminal() {
            Mode::Bars { multi: MultiProgress::with_draw_target(ProgressDrawTarget::stderr()), steps: None, samples: None }
        } else {
            Mode::Plain
        };
        CliReporter { mode, started: Instant::now(), stage: String::new(), last_plain: None, pending: None }
    }

    /// Removes the bars, printing the last plain line if it was held back.
    pub fn finish(&mut self) {
        match &mut self.mode {
            Mode::Bars { steps, samples, .. } => {
                if let Some(b) = steps.take() {
                    b.finish_and_clear();
                }
                if let Some(b) = samples.take() {
                    b.finish_and_clear();
                }
            }
            Mode::Plain => {
                if let Some(line) = self.pending.take() {
                    tell!("{line}");
                }
            }
            Mode::Quiet => {}
        }
    }

    fn describe(p: &Progress) -> String {
        format!(
            "step {}  t {:.4e}  KE/grain {:.2e}  max accel {:.2e}  contacts {}  sliding {}",
            p.step, p.time, p.kinetic_energy_per_grain, p.max_acceleration, p.contacts, p.sliding
        )
    }
}

impl Reporter for CliReporter {
    fn stage(&mut self, name: &str, total_steps: Option<u64>) {
        self.stage = name.to_string();
        if let Mode::Bars { multi, steps, .. } = &mut self.mode {
            if let Some(b) = steps.take() {
                b.finish_and_clear();
            }
            let bar = match total_steps {
                Some(n) => {
                    let b = multi.add(ProgressBar::new(n));
                    b.set_style(
                        ProgressStyle::with_template("{prefix:.bold} [{bar:25}] {percent:>3}% {elapsed_precise} (ETA {eta}) {wide_msg}")
                            .expect("valid template")
                            .progress_chars("=> "),
                    );
                    b
                }
                None => {
                    let b = multi.add(ProgressBar::new_spinner());
                    b.set_style(ProgressStyle::with_template("{prefix:.bold} {spinner} {elapsed_precise} {wide_msg}").expect("valid template"));
                    b
                }
            };
            bar.set_prefix(name.to_string());
            bar.enable_steady_tick(Duration::from_millis(200));
            *steps = Some(bar);
        }
    }

    fn progress(&mut self, p: &Progress) {
        match &mut self.mode {
            Mode::Quiet => {}
            Mode::Bars { steps, .. } => {
                if let Some(b) = steps {
                    b.set_position(p.step);
                    b.set_message(Self::describe(p));
                }
            }
            Mode::Plain => {
                let line = format!("[{:8.1} s] {} {}", self.started.elapsed().as_secs_f64(), self.stage, Self::describe(p));
                if self.last_plain.is_none_or(|t| t.elapsed() >= PLAIN_INTERVAL) {
                    tell!("{line}");
                    self.last_plain = Some(Instant::now());
                    self.pending = None;
                } else {
                    self.pending = Some(line);
                }
            }
        }
    }

    fn samples(&mut self, done: usize, total: usize) {
        match &mut self.mode {
            Mode::Quiet => {}
            Mode::Bars { multi, samples, .. } => {
                let bar = samples.get_or_insert_with(|| {
                    let b = multi.insert(0, ProgressBar::new(total as u64));
                    b.set_style(ProgressStyle::with_template("samples [{bar:25}] {pos}/{len} (ETA {eta})").expect("valid template").progress_chars("=> "));
                    b
                });
                bar.set_length(total as u64);
                bar.set_position(done as u64);
            }
            Mode::Plain => tell!("[{:8.1} s] samples {done}/{total}", self.started.elapsed().as_secs_f64()),
        }
    }

    fn message(&mut self, text: &str) {
        match &self.mode {
            Mode::Quiet => {}
            Mode::Bars { multi, .. } => {
                let _ = multi.println(text);
            }
            Mode::Plain => tell!("[{:8.1} s] {text}", self.started.elapsed().as_secs_f64()),
        }
    }
}
