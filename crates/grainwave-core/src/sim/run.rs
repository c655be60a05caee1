//! Running until a stop criterion (SPEC §3): equilibrium criteria and step/time limits.

use super::Simulation;
use crate::dim::{Dim, VectorOps};
use crate::error::{CoreError, Result};
use crate::util::{det_max, det_sum};
use serde::{Deserialize, Serialize};

/// When to stop. The run converges when **all** equilibrium criteria that are set hold at a
/// check; it stops anyway at the step or time limit (absolute values, so that a resumed run stops
/// where the uninterrupted one would). At least one limit is required.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct StopCriteria {
    /// Stop when the step counter reaches this value.
    pub step_limit: Option<u64>,
    /// Stop when simulated time reaches this value.
    pub time_limit: Option<f64>,
    /// Converged when max_i max(|F_i|/m_i, |τ_i| R_i/I_i) is below this (acceleration units).
    pub max_acceleration: Option<f64>,
    /// Converged when the mean of the same per-grain acceleration is below this.
    pub mean_acceleration: Option<f64>,
    /// Converged when the kinetic energy per grain is below this.
    pub kinetic_energy_per_grain: Option<f64>,
    /// Converged when no contact formed or broke during this many consecutive steps.
    pub network_unchanged_steps: Option<u64>,
    /// Converged only when no contact is sliding.
    #[serde(default)]
    pub no_sliding: bool,
    /// Evaluate the criteria (and report progress) every this many steps (0 or 1: every step).
    #[serde(default)]
    pub check_every: u64,
    /// Do not declare convergence before this simulated time (e.g. the end of a load ramp).
    pub not_before_time: Option<f64>,
}

impl StopCriteria {
    /// True when at least one equilibrium criterion is set.
    pub fn has_equilibrium_criterion(&self) -> bool {
        self.max_acceleration.is_some()
            || self.mean_acceleration.is_some()
            || self.kinetic_energy_per_grain.is_some()
            || self.network_unchanged_steps.is_some()
            || self.no_sliding
    }

    /// The step at which the run certainly stops, where nothing can stop it earlier: the step
    /// limit when no equilibrium criterion and no time limit is set, `None` otherwise. A
    /// progress bar's total (a bar drawn to the step limit of a run that converges at 7 % of it
    /// would show a meaningless ETA).
    pub fn certain_end(&self) -> Option<u64> {
        if self.has_equilibrium_criterion() || self.time_limit.is_some() {
            None
        } else {
            self.step_limit
        }
    }

    /// Checks the values.
    pub fn validate(&self) -> Result<()> {
        if self.step_limit.is_none() && self.time_limit.is_none() {
            return Err(CoreError::invalid("stop.step_limit", "(missing)", "a step limit or a time limit (`stop.time_limit`)"));
        }
        if let Some(t) = self.time_limit {
            if !(t.is_finite() && t >= 0.0) {
                return Err(CoreError::invalid("stop.time_limit", t, "a finite time ≥ 0"));
            }
        }
        for (key, v) in [
            ("stop.max_acceleration", self.max_acceleration),
            ("stop.mean_acceleration", self.mean_acceleration),
            ("stop.kinetic_energy_per_grain", self.kinetic_energy_per_grain),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return Err(CoreError::invalid(key, v, "a finite tolerance > 0"));
                }
            }
        }
        Ok(())
    }
}

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// All equilibrium criteria held.
    Converged,
    /// The step limit was reached first.
    StepLimit,
    /// The time limit was reached first.
    TimeLimit,
    /// The observer asked to stop (e.g. Ctrl-C); the current step was completed.
    Interrupted,
}

/// State reported to the observer at every check.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct Progress {
    /// Step counter.
    pub step: u64,
    /// Simulated time.
    pub time: f64,
    /// Kinetic energy per grain.
    pub kinetic_energy_per_grain: f64,
    /// max_i max(|F_i|/m_i, |τ_i| R_i/I_i).
    pub max_acceleration: f64,
    /// Mean of the same.
    pub mean_acceleration: f64,
    /// Contacts (grain–grain + grain–wall).
    pub contacts: u64,
    /// Sliding contacts.
    pub sliding: u64,
    /// Consecutive steps without a contact forming or breaking.
    pub steps_network_unchanged: u64,
    /// Fraction of the step/time limit done, in [0, 1].
    pub fraction_of_limit: f64,
}

/// What the observer tells the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    /// Keep going.
    Continue,
    /// Stop after this step.
    Stop,
}

/// Optional hooks of [`Simulation::run_with`]; none of them changes the result of a run.
pub struct RunHooks<'a> {
    /// Called at every check, every `report_every` steps and at the end. Returning
    /// [`Control::Stop`] interrupts the run after the current step.
    pub observer: &'a mut dyn FnMut(&Progress) -> Control,
    /// Also report every this many steps (0: only at checks).
    pub report_every: u64,
    /// Polled after every step; when set, the run stops (e.g. on Ctrl-C).
    pub interrupt: Option<&'a std::sync::atomic::AtomicBool>,
}

enum Event {
    Limit(StopReason),
    Check,
    Report,
    Interrupt,
}

/// Result of [`Simulation::run`].
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct RunOutcome {
    /// Why it stopped.
    pub reason: StopReason,
    /// Steps done by this call.
    pub steps: u64,
    /// State at the end.
    pub last: Progress,
}

impl<D: Dim> Simulation<D> {
    /// Current values of every stop quantity.
    pub fn progress(&self, stop: &StopCriteria) -> Progress {
        let g = &self.grains;
        let n = g.len();
        let acc = |k: usize| {
            let a = g.force[k].norm() / g.mass[k];
            let b = g.torque[k].norm() * g.radius[k] / g.inertia[k];
            a.max(b)
        };
        let ke = self.kinetic_energy();
        let mut fraction: f64 = 0.0;
        if let Some(s) = stop.step_limit {
            fraction = fraction.max(if s == 0 { 1.0 } else { self.step as f64 / s as f64 });
        }
        if let Some(t) = stop.time_limit {
            fraction = fraction.max(if t == 0.0 { 1.0 } else { self.time / t });
        }
        Progress {
            step: self.step,
            time: self.time,
            kinetic_energy_per_grain: ke / n as f64,
            max_acceleration: det_max(n, acc),
            mean_acceleration: det_sum(n, acc) / n as f64,
            contacts: self.counters.contacts,
            sliding: self.counters.sliding,
            steps_network_unchanged: self.counters.steps_network_unchanged,
            fraction_of_limit: fraction.min(1.0),
        }
    }

    fn converged(&self, stop: &StopCriteria, p: &Progress) -> bool {
        if !stop.has_equilibrium_criterion() {
            return false;
        }
        if let Some(t) = stop.not_before_time {
            // half a step of slack, as for the time limit: accumulated time may fall short of t
            if self.time < t - 0.5 * self.dt {
                return false;
            }
        }
        stop.max_acceleration.is_none_or(|tol| p.max_acceleration < tol)
            && stop.mean_acceleration.is_none_or(|tol| p.mean_acceleration < tol)
            && stop.kinetic_energy_per_grain.is_none_or(|tol| p.kinetic_energy_per_grain < tol)
            && stop.network_unchanged_steps.is_none_or(|k| p.steps_network_unchanged >= k)
            && (!stop.no_sliding || p.sliding == 0)
    }

    fn limit_reached(&self, stop: &StopCriteria) -> Option<super::StopReason> {
        if stop.step_limit.is_some_and(|s| self.step >= s) {
            return Some(StopReason::StepLimit);
        }
        // half a step of slack so that t_limit = k·dt stops after exactly k steps
        if stop.time_limit.is_some_and(|t| self.time >= t - 0.5 * self.dt) {
            return Some(StopReason::TimeLimit);
        }
        None
    }

    /// Steps until `stop` is met, calling `observer` at every check. Convergence and limits are
    /// checked at absolute step numbers that are multiples of `check_every`, so a resumed run stops
    /// at the same step as the uninterrupted one.
    pub fn run(&mut self, stop: &StopCriteria, observer: &mut dyn FnMut(&Progress) -> Control) -> Result<RunOutcome> {
        self.run_with(stop, &mut RunHooks { observer, report_every: 0, interrupt: None })
    }

    /// Like [`Simulation::run`], with hooks that never change the result: the observer is also
    /// called every `report_every` steps, and `interrupt` is polled after every step (the run
    /// then returns [`StopReason::Interrupted`] having completed that step).
    pub fn run_with(&mut self, stop: &StopCriteria, hooks: &mut RunHooks<'_>) -> Result<RunOutcome> {
        stop.validate()?;
        let every = stop.check_every.max(1);
        let report = hooks.report_every;
        let start = self.step;
        let interrupt = hooks.interrupt;
        let interrupted = || interrupt.is_some_and(|f| f.load(std::sync::atomic::Ordering::Relaxed));
        loop {
            // Advance to the next check (a multiple of `every`), report, limit or interrupt,
            // inside the thread pool.
            let event = crate::util::in_pool(|| -> Result<Event> {
                loop {
                    if let Some(reason) = self.limit_reached(stop) {
                        return Ok(Event::Limit(reason));
                    }
                    self.step()?;
                    if self.step % every == 0 {
                        return Ok(Event::Check);
                    }
                    if interrupted() {
                        return Ok(Event::Interrupt);
                    }
                    if report > 0 && self.step % report == 0 {
                        return Ok(Event::Report);
                    }
                }
            })?;
            match event {
                Event::Limit(reason) => {
                    self.check_timestep_warning();
                    let last = self.progress(stop);
                    (hooks.observer)(&last);
                    return Ok(RunOutcome { reason, steps: self.step - start, last });
                }
                Event::Check => {
                    let p = self.progress(stop);
                    if self.converged(stop, &p) {
                        self.check_timestep_warning();
                        (hooks.observer)(&p);
                        return Ok(RunOutcome { reason: StopReason::Converged, steps: self.step - start, last: p });
                    }
                    if (hooks.observer)(&p) == Control::Stop || interrupted() {
                        return Ok(RunOutcome { reason: StopReason::Interrupted, steps: self.step - start, last: p });
                    }
                }
                Event::Report => {
                    let p = self.progress(stop);
                    if (hooks.observer)(&p) == Control::Stop {
                        return Ok(RunOutcome { reason: StopReason::Interrupted, steps: self.step - start, last: p });
                    }
                }
                Event::Interrupt => {
                    let p = self.progress(stop);
                    (hooks.observer)(&p);
                    return Ok(RunOutcome { reason: StopReason::Interrupted, steps: self.step - start, last: p });
                }
            }
        }
    }

    /// Warns when, at the deepest overlap seen so far, the time step exceeds the suggested
    /// fraction of the shortest contact period (matters for Hertz contacts, which stiffen).
    pub fn check_timestep_warning(&mut self) {
        let (r_min, r_max) = self.grains.radius_range();
        let seen = self.counters.max_overlap_ratio_seen * r_min / r_max;
        let overlap = self.expected_overlap.max(seen);
        let suggested = crate::timestep::suggest_timestep(&self.grains, &self.law, &self.domain.walls, self.dt_fraction, overlap);
        if self.dt > suggested * (1.0 + 1e-12) {
            self.warn(format!(
                "time step {:.4e} exceeds {} of the shortest contact period at the deepest overlap seen ({:.3e} of the largest radius): suggested {:.4e}",
                self.dt, self.dt_fraction, overlap, suggested
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::StopCriteria;

    #[test]
    fn a_bar_total_only_where_nothing_ends_the_run_earlier() {
        let steps = StopCriteria { step_limit: Some(5000), ..Default::default() };
        assert_eq!(steps.certain_end(), Some(5000));
        // an equilibrium criterion or a time limit can end the run before the step limit
        let settle = StopCriteria { max_acceleration: Some(1e-7), ..steps.clone() };
        assert_eq!(settle.certain_end(), None);
        let sliding = StopCriteria { no_sliding: true, ..steps.clone() };
        assert_eq!(sliding.certain_end(), None);
        let timed = StopCriteria { time_limit: Some(2.0), ..steps };
        assert_eq!(timed.certain_end(), None);
        assert_eq!(StopCriteria { time_limit: Some(2.0), ..Default::default() }.certain_end(), None);
    }
}
