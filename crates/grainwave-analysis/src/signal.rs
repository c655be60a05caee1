//! Pulse-signal metrics (SPEC §5.5) and fits over series of heights or pressures.
//!
//! # One signal
//!
//! Given samples F(t_k) of a pulse signal (times strictly increasing), [`pulse_metrics`] finds
//!
//! * the **first (coherent) peak** (SPEC §5.5): the first local maximum F(t_k) that
//!   1. reaches `peak_threshold` × max_j F(t_j) (default 0.1 — a floor for precursor wiggles and
//!      rounding noise, not a competition with later peaks), and
//!   2. is a lobe: after it the signal falls to half its value, F ≤ F(t_k)/2, before it ever
//!      exceeds F(t_k) again (or the record ends first) — a ripple on the rising front is not a
//!      peak.
//!
//!   It is *not* the largest peak: in lattices and chains the first (Airy) lobe of the front is
//!   smaller than the oscillations behind it (≈ 40 % of the record's maximum in the triangular
//!   lattice), and a detector that demands a large fraction of the maximum skips it. Its time and
//!   amplitude A are refined by the parabola through the maximum sample and its two neighbours;
//! * the **leading edge**: the first time F reaches `edge_fraction` × A (default 10 %), by linear
//!   interpolation between the bracketing samples;
//! * the **first zero crossing** after the peak (linear interpolation);
//! * the **width** W = t_zero − t_edge, and the **full width at half maximum**: the last crossing of
//!   A/2 before the peak and the first after it.
//!
//! # Series
//!
//! * [`time_of_flight_velocity`]: c_tof = ΔL/Δt of the leading edge between two heights
//!   (reference: L = 8 and L = 25);
//! * [`linear_fit`]: least squares y = a x + b (arrival times vs height → slowness 1/c);
//! * [`power_law_fit`]: y = C x^p by least squares on (ln x, ln y) (A ∼ L^−γ: γ = −p; W ∼ L^α: α = p;
//!   speeds vs pressure);
//! * [`effective_exponents`]: local slopes d ln y/d ln x between consecutive points, at the
//!   geometric mean of the two abscissae.
//!
//! ```
//! use grainwave_analysis::signal::{pulse_metrics, PulseOptions};
//! // a Gaussian pulse centred at t = 5 with σ = 1, sampled finely
//! let t: Vec<f64> = (0..=1000).map(|k| k as f64 * 0.01).collect();
//! let f: Vec<f64> = t.iter().map(|&t| (-(t - 5.0f64).powi(2) / 2.0).exp()).collect();
//! let m = pulse_metrics(&t, &f, &PulseOptions::default()).unwrap();
//! assert!((m.peak_time - 5.0).abs() < 1e-9 && (m.peak_amplitude - 1.0).abs() < 1e-5);
//! let edge = 5.0 - (2.0 * 10f64.ln()).sqrt(); // F = 0.1 A
//! assert!((m.leading_edge_time - edge).abs() < 1e-4);
//! assert!((m.fwhm.unwrap() - 2.0 * (2.0 * 2f64.ln()).sqrt()).abs() < 1e-4);
//! assert!(m.zero_crossing_time.is_none()); // a Gaussian never crosses zero
//! ```

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of the signal analysis.
#[derive(Debug, Error, PartialEq)]
pub enum SignalError {
    /// Two series that must have the same length do not.
    #[error("`{what}` has {found} samples, expected {expected}")]
    LengthMismatch {
        /// Which series.
        what: String,
        /// Expected length.
        expected: usize,
        /// Actual length.
        found: usize,
    },
    /// Too few samples for the analysis.
    #[error("{what} needs at least {needed} samples, got {found}")]
    TooShort {
        /// What was asked.
        what: String,
        /// Needed.
        needed: usize,
        /// Given.
        found: usize,
    },
    /// Times are not strictly increasing, or a value is not finite.
    #[error("sample {index}: {reason}")]
    BadSample {
        /// Sample index.
        index: usize,
        /// What is wrong.
        reason: String,
    },
    /// No peak satisfies the criteria.
    #[error("no local maximum reaches {threshold} × the largest value {max:e} (a positive pulse is expected)")]
    NoPeak {
        /// Relative threshold.
        threshold: f64,
        /// Largest value of the signal.
        max: f64,
    },
    /// A parameter is out of range.
    #[error("invalid value for `{field}`: {value} (allowed: {allowed})")]
    InvalidParameter {
        /// Parameter.
        field: String,
        /// Value.
        value: String,
        /// Allowed values.
        allowed: String,
    },
}

/// Options of [`pulse_metrics`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PulseOptions {
    /// Fraction of the first peak that defines the leading edge (default 0.1).
    pub edge_fraction: f64,
    /// Floor for the first coherent peak: the first lobe (a local maximum followed by a fall to
    /// half its value) reaching this fraction of the signal's largest value (default 0.1).
    pub peak_threshold: f64,
}

/// Default floor of the first coherent peak, relative to the record's largest value.
pub const DEFAULT_PEAK_THRESHOLD: f64 = 0.1;

impl Default for PulseOptions {
    fn default() -> Self {
        PulseOptions { edge_fraction: 0.1, peak_threshold: DEFAULT_PEAK_THRESHOLD }
    }
}

/// Metrics of the first coherent peak of a signal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PulseMetrics {
    /// Time of the first peak.
    pub peak_time: f64,
    /// Amplitude A of the first peak.
    pub peak_amplitude: f64,
    /// First time the signal reaches `edge_fraction` × A.
    pub leading_edge_time: f64,
    /// First zero crossing after the peak (None if the signal stays positive).
    pub zero_crossing_time: Option<f64>,
    /// W = zero crossing − leading edge.
    pub width: Option<f64>,
    /// Half-maximum crossings before and after the peak.
    pub half_maximum_times: Option<(f64, f64)>,
    /// Full width at half maximum.
    pub fwhm: Option<f64>,
}

fn check(times: &[f64], values: &[f64]) -> Result<(), SignalError> {
    if times.len() != values.len() {
        return Err(SignalError::LengthMismatch { what: "values".into(), expected: times.len(), found: values.len() });
    }
    for k in 0..times.len() {
        if !times[k].is_finite() || !values[k].is_finite() {
            return Err(SignalError::BadSample { index: k, reason: "not a finite number".into() });
        }
        if k > 0 && times[k] <= times[k - 1] {
            return Err(SignalError::BadSample { index: k, reason: "times must increase strictly".into() });
        }
    }
    Ok(())
}

/// Time at which the segment from sample a to sample b crosses `level` (linear interpolation).
fn interpolate(times: &[f64], values: &[f64], a: usize, b: usize, level: f64) -> f64 {
    let (fa, fb) = (values[a], values[b]);
    if fb == fa {
        return times[b];
    }
    times[a] + (level - fa) / (fb - fa) * (times[b] - times[a])
}

/// Whether the local maximum at `k` (its plateau ending before `j`) is a lobe: after it the signal
/// reaches half of it before exceeding it, or the record ends first.
fn is_lobe(values: &[f64], k: usize, j: usize) -> bool {
    let top = values[k];
    for &v in &values[j..] {
        if v > top {
            return false;
        }
        if v <= 0.5 * top {
            return true;
        }
    }
    true
}

/// Metrics of the first coherent peak of F(t) (see the module docs).
pub fn pulse_metrics(times: &[f64], values: &[f64], options: &PulseOptions) -> Result<PulseMetrics, SignalError> {
    check(times, values)?;
    if times.len() < 3 {
        return Err(SignalError::TooShort { what: "pulse_metrics".into(), needed: 3, found: times.len() });
    }
    if !(options.edge_fraction > 0.0 && options.edge_fraction < 1.0) {
        return Err(SignalError::InvalidParameter { field: "edge_fraction".into(), value: options.edge_fraction.to_string(), allowed: "a fraction in (0, 1)".into() });
    }
    if !(options.peak_threshold > 0.0 && options.peak_threshold <= 1.0) {
        return Err(SignalError::InvalidParameter { field: "peak_threshold".into(), value: options.peak_threshold.to_string(), allowed: "a fraction in (0, 1]".into() });
    }
    let n = values.len();
    let max = values.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if !(max > 0.0) {
        return Err(SignalError::NoPeak { threshold: options.peak_threshold, max });
    }
    let level = options.peak_threshold * max;
    // first local maximum above the level (plateaus: the first sample of the plateau) that is a
    // lobe: the signal falls to half of it before exceeding it (or the record ends)
    let mut peak = None;
    for k in 0..n {
        if values[k] < level {
            continue;
        }
        let left_ok = k == 0 || values[k] >= values[k - 1];
        let mut j = k + 1;
        while j < n && values[j] == values[k] {
            j += 1;
        }
        let right_ok = j == n || values[j] < values[k];
        if left_ok && right_ok && is_lobe(values, k, j) {
            peak = Some(k);
            break;
        }
    }
    let k = peak.ok_or(SignalError::NoPeak { threshold: options.peak_threshold, max })?;
    let (mut t_peak, mut amp) = (times[k], values[k]);
    if k > 0 && k + 1 < n && values[k + 1] != values[k] {
        // vertex of the parabola through the three samples
        let (t0, t1, t2) = (times[k - 1], times[k], times[k + 1]);
        let (f0, f1, f2) = (values[k - 1], values[k], values[k + 1]);
        let d01 = (f1 - f0) / (t1 - t0);
        let d12 = (f2 - f1) / (t2 - t1);
        let c2 = (d12 - d01) / (t2 - t0);
        if c2 < 0.0 {
            let c1 = d01 - c2 * (t0 + t1);
            let tv = -c1 / (2.0 * c2);
            if tv > t0 && tv < t2 {
                t_peak = tv;
                amp = f1 + d01 * (tv - t1) + c2 * (tv - t0) * (tv - t1);
            }
        }
    }
    let edge_level = options.edge_fraction * amp;
    let mut t_edge = times[0];
    if values[0] < edge_level {
        for j in 1..=k {
            if values[j] >= edge_level {
                t_edge = interpolate(times, values, j - 1, j, edge_level);
                break;
            }
        }
    }
    let zero = (k + 1..n).find(|&j| values[j] <= 0.0).map(|j| if values[j] == 0.0 { times[j] } else { interpolate(times, values, j - 1, j, 0.0) });
    let half = 0.5 * amp;
    let rise = (1..=k).rev().find(|&j| values[j - 1] < half && values[j] >= half).map(|j| interpolate(times, values, j - 1, j, half));
    let fall = (k + 1..n).find(|&j| values[j] < half).map(|j| interpolate(times, values, j - 1, j, half));
    let half_maximum_times = match (rise, fall) {
        (Some(a), Some(b)) => Some((a, b)),
        _ => None,
    };
    Ok(PulseMetrics {
        peak_time: t_peak,
        peak_amplitude: amp,
        leading_edge_time: t_edge,
        zero_crossing_time: zero,
        width: zero.map(|z| z - t_edge),
        half_maximum_times,
        fwhm: half_maximum_times.map(|(a, b)| b - a),
    })
}

/// c_tof = (L₂ − L₁)/(t₂ − t₁): time-of-flight velocity of the leading edge between two heights.
pub fn time_of_flight_velocity(height_1: f64, edge_time_1: f64, height_2: f64, edge_time_2: f64) -> f64 {
    (height_2 - height_1) / (edge_time_2 - edge_time_1)
}

/// Least-squares line y = slope · x + intercept.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearFit {
    /// Slope.
    pub slope: f64,
    /// Intercept.
    pub intercept: f64,
    /// Coefficient of determination R².
    pub r_squared: f64,
}

/// Least-squares fit of y = a x + b.
pub fn linear_fit(x: &[f64], y: &[f64]) -> Result<LinearFit, SignalError> {
    if x.len() != y.len() {
        return Err(SignalError::LengthMismatch { what: "y".into(), expected: x.len(), found: y.len() });
    }
    if x.len() < 2 {
        return Err(SignalError::TooShort { what: "linear_fit".into(), needed: 2, found: x.len() });
    }
    for (k, (a, b)) in x.iter().zip(y).enumerate() {
        if !a.is_finite() || !b.is_finite() {
            return Err(SignalError::BadSample { index: k, reason: "not a finite number".into() });
        }
    }
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let syy: f64 = y.iter().map(|b| (b - my) * (b - my)).sum();
    if sxx == 0.0 {
        return Err(SignalError::BadSample { index: 0, reason: "all abscissae are equal".into() });
    }
    let slope = sxy / sxx;
    let r_squared = if syy == 0.0 { 1.0 } else { sxy * sxy / (sxx * syy) };
    Ok(LinearFit { slope, intercept: my - slope * mx, r_squared })
}

/// y = prefactor · x^exponent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PowerLawFit {
    /// Exponent p.
    pub exponent: f64,
    /// Prefactor C.
    pub prefactor: f64,
    /// R² of the fit in log–log.
    pub r_squared: f64,
}

fn logs(x: &[f64], y: &[f64]) -> Result<(Vec<f64>, Vec<f64>), SignalError> {
    if x.len() != y.len() {
        return Err(SignalError::LengthMismatch { what: "y".into(), expected: x.len(), found: y.len() });
    }
    for (k, (a, b)) in x.iter().zip(y).enumerate() {
        if !(*a > 0.0 && *b > 0.0 && a.is_finite() && b.is_finite()) {
            return Err(SignalError::BadSample { index: k, reason: format!("power laws need finite positive values, got ({a}, {b})") });
        }
    }
    Ok((x.iter().map(|a| a.ln()).collect(), y.iter().map(|b| b.ln()).collect()))
}

/// Least-squares power law y = C x^p (a line in ln–ln).
pub fn power_law_fit(x: &[f64], y: &[f64]) -> Result<PowerLawFit, SignalError> {
    let (lx, ly) = logs(x, y)?;
    let f = linear_fit(&lx, &ly)?;
    Ok(PowerLawFit { exponent: f.slope, prefactor: f.intercept.exp(), r_squared: f.r_squared })
}

/// Effective exponents d ln y / d ln x between consecutive points, with the geometric mean of the
/// two abscissae: [(√(x_k x_{k+1}), ln(y_{k+1}/y_k)/ln(x_{k+1}/x_k))].
pub fn effective_exponents(x: &[f64], y: &[f64]) -> Result<Vec<(f64, f64)>, SignalError> {
    let (lx, ly) = logs(x, y)?;
    let mut out = Vec::with_capacity(x.len().saturating_sub(1));
    for k in 0..x.len().saturating_sub(1) {
        if lx[k + 1] == lx[k] {
            return Err(SignalError::BadSample { index: k + 1, reason: "two equal abscissae".into() });
        }
        out.push((((lx[k] + lx[k + 1]) / 2.0).exp(), (ly[k + 1] - ly[k]) / (lx[k + 1] - lx[k])));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pulse with known metrics: F(t) = sin(π(t − 1)/2) on [1, 5] (0 outside), sampled every 1e-3.
    /// Peak at t = 2 (A = 1), 10 % edge at 1 + (2/π) asin(0.1), zero crossing at 3, half maximum at
    /// 1 + 1/3 and 2 + 2/3. Linear interpolation on a sine with step 1e-3 errs by ≤ h²|F''|/8 ~ 3e-7
    /// in value, i.e. ≤ 1e-6 in time where the slope is ≥ 0.3.
    #[test]
    fn metrics_of_a_half_sine_pulse() {
        let t: Vec<f64> = (0..=6000).map(|k| k as f64 * 1e-3).collect();
        let f: Vec<f64> = t.iter().map(|&t| if (1.0..=5.0).contains(&t) { (std::f64::consts::PI * (t - 1.0) / 2.0).sin() } else { 0.0 }).collect();
        let m = pulse_metrics(&t, &f, &PulseOptions::default()).unwrap();
        assert!((m.peak_time - 2.0).abs() < 1e-9, "{m:?}");
        assert!((m.peak_amplitude - 1.0).abs() < 1e-9);
        let edge = 1.0 + 2.0 / std::f64::consts::PI * 0.1f64.asin();
        assert!((m.leading_edge_time - edge).abs() < 1e-6, "{} vs {edge}", m.leading_edge_time);
        assert!((m.zero_crossing_time.unwrap() - 3.0).abs() < 1e-9);
        assert!((m.width.unwrap() - (3.0 - edge)).abs() < 1e-6);
        let (a, b) = m.half_maximum_times.unwrap();
        assert!((a - 4.0 / 3.0).abs() < 1e-6 && (b - 8.0 / 3.0).abs() < 1e-6, "{a} {b}");
    }

    /// Precursor wiggles below half the maximum are not the first coherent peak.
    #[test]
    fn precursors_are_skipped() {
        let t: Vec<f64> = (0..=400).map(|k| k as f64 * 0.05).collect();
        let f: Vec<f64> = t.iter().map(|&t| 0.05 * (10.0 * t).sin() * (-t).exp() + (-(t - 12.0f64).powi(2)).exp()).collect();
        let m = pulse_metrics(&t, &f, &PulseOptions::default()).unwrap();
        assert!((m.peak_time - 12.0).abs() < 1e-3, "{m:?}");
        // with no threshold the first wiggle is taken
        let m = pulse_metrics(&t, &f, &PulseOptions { peak_threshold: 1e-3, ..Default::default() }).unwrap();
        assert!(m.peak_time < 1.0);
    }

    /// A front whose first lobe is smaller than the oscillations behind it (as the Airy front of
    /// a lattice: first lobe ≈ 40 % of the maximum): the first lobe is the peak, not the largest
    /// one and not the first one reaching half the maximum. A ripple on the rising front (a local
    /// maximum that does not fall to half before the front climbs higher) is not a peak either.
    #[test]
    fn first_lobe_smaller_than_later_ones_is_the_peak() {
        let t: Vec<f64> = (0..=4000).map(|k| k as f64 * 0.005).collect();
        // lobes at t = 5 (0.4), 8 (1.0), 11 (−0.8 … ), Gaussians of σ = 0.5 — well separated
        let g = |t: f64, c: f64| (-(t - c).powi(2) / (2.0 * 0.25)).exp();
        let f: Vec<f64> = t.iter().map(|&t| 0.4 * g(t, 5.0) + 1.0 * g(t, 8.0) - 0.8 * g(t, 11.0) + 0.9 * g(t, 14.0)).collect();
        let m = pulse_metrics(&t, &f, &PulseOptions::default()).unwrap();
        assert!((m.peak_time - 5.0).abs() < 1e-3 && (m.peak_amplitude - 0.4).abs() < 1e-3, "{m:?}");
        // the leading edge belongs to the first lobe: 0.4 g = 0.04, t = 5 − σ √(2 ln 10)
        assert!((m.leading_edge_time - (5.0 - 0.5 * (2.0 * 10f64.ln()).sqrt())).abs() < 1e-3, "{m:?}");
        // a ripple on the rising front: a narrow bump (0.05, σ = 0.03) at t = 4.5 on the flank of
        // the first lobe (value 0.24, slope 0.49 there; the bump's steepest slope is 1.0, so it
        // makes a local maximum ≈ 0.29, above the 0.1 floor) does not fall to half its height
        // before the lobe climbs past it
        let r: Vec<f64> = t.iter().zip(&f).map(|(&t, &v)| v + 0.05 * (-(t - 4.5f64).powi(2) / (2.0 * 0.03 * 0.03)).exp()).collect();
        let ripple = (1..t.len() - 1).find(|&k| r[k] >= 0.1 && r[k] > r[k - 1] && r[k] >= r[k + 1]).unwrap();
        assert!((t[ripple] - 4.5).abs() < 0.05, "the ripple is a local maximum above the floor: {}", t[ripple]);
        let m = pulse_metrics(&t, &r, &PulseOptions::default()).unwrap();
        assert!((m.peak_time - 5.0).abs() < 1e-2, "{m:?}");
    }

    #[test]
    fn fits_recover_exact_laws() {
        let x = [8.0, 12.0, 16.0, 25.0, 40.0];
        let y: Vec<f64> = x.iter().map(|l| 3.0 * l + 2.0).collect();
        let f = linear_fit(&x, &y).unwrap();
        assert!((f.slope - 3.0).abs() < 1e-13 && (f.intercept - 2.0).abs() < 1e-12 && (f.r_squared - 1.0).abs() < 1e-13);
        let y: Vec<f64> = x.iter().map(|l: &f64| 5.0 * l.powf(-0.75)).collect();
        let p = power_law_fit(&x, &y).unwrap();
        assert!((p.exponent + 0.75).abs() < 1e-13 && (p.prefactor - 5.0).abs() < 1e-12);
        for (_, e) in effective_exponents(&x, &y).unwrap() {
            assert!((e + 0.75).abs() < 1e-13);
        }
        assert!((time_of_flight_velocity(8.0, 10.0, 25.0, 27.0) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn bad_inputs_are_errors() {
        assert!(matches!(pulse_metrics(&[0.0, 1.0, 1.0], &[0.0, 1.0, 0.0], &PulseOptions::default()), Err(SignalError::BadSample { index: 2, .. })));
        assert!(matches!(pulse_metrics(&[0.0, 1.0, 2.0], &[-1.0, -2.0, -1.0], &PulseOptions::default()), Err(SignalError::NoPeak { .. })));
        assert!(power_law_fit(&[1.0, 2.0], &[1.0, -1.0]).is_err());
    }
}
