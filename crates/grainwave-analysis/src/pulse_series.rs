//! Pulse metrics over a series of heights (SPEC §5.5): arrival times vs L with linear fits, the
//! time-of-flight velocity c_tof, and the amplitude and width exponents — plain (a power-law fit over
//! the whole series) and effective (local slopes d ln y/d ln L between consecutive heights).
//!
//! * **Arrival times**: the leading edge (10 % of the first peak) and the first-peak time, each
//!   fitted linearly against L; the inverse slopes are speeds.
//! * **c_tof** = ΔL/Δt of the leading edge between two heights of the series, those closest to the
//!   reference heights (SPEC: L = 8 and L = 25).
//! * **Exponents**: A ∼ L^−γ (γ = −slope of ln A vs ln L), W ∼ L^α with W the width from the leading
//!   edge to the first zero crossing, and the FWHM exponent likewise.
//!
//! ```
//! use grainwave_analysis::pulse_series::{analyze_heights, SeriesOptions};
//! use grainwave_analysis::signal::PulseMetrics;
//! // a front moving at c = 2 whose amplitude falls as L^-1/2 and width grows as L^1/3
//! let points: Vec<(f64, PulseMetrics)> = [8.0f64, 16.0, 25.0].iter().map(|&l| {
//!     let w = l.powf(1.0 / 3.0);
//!     (l, PulseMetrics { peak_time: l / 2.0 + 0.3 * w, peak_amplitude: l.powf(-0.5), leading_edge_time: l / 2.0,
//!         zero_crossing_time: Some(l / 2.0 + w), width: Some(w), half_maximum_times: None, fwhm: None })
//! }).collect();
//! let s = analyze_heights(&points, &SeriesOptions::default()).unwrap();
//! assert!((s.time_of_flight.unwrap().velocity - 2.0).abs() < 1e-12);
//! assert!((s.amplitude_exponent.as_ref().unwrap().gamma - 0.5).abs() < 1e-12);
//! assert!((s.width_exponent.as_ref().unwrap().exponent - 1.0 / 3.0).abs() < 1e-12);
//! ```

use crate::signal::{effective_exponents, linear_fit, power_law_fit, LinearFit, PulseMetrics, SignalError};
use serde::{Deserialize, Serialize};

/// Options of [`analyze_heights`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SeriesOptions {
    /// Reference heights of c_tof: the two heights of the series closest to these are used
    /// (default [8, 25], SPEC §5.5) [length].
    pub tof_heights: [f64; 2],
}

impl Default for SeriesOptions {
    fn default() -> Self {
        SeriesOptions { tof_heights: [8.0, 25.0] }
    }
}

/// c_tof between two heights.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimeOfFlight {
    /// Lower height L₁ [length].
    pub height_1: f64,
    /// Upper height L₂ [length].
    pub height_2: f64,
    /// Leading-edge times t₁, t₂ [time].
    pub edge_times: (f64, f64),
    /// c_tof = (L₂ − L₁)/(t₂ − t₁) [length/time].
    pub velocity: f64,
}

/// A power law y ∼ L^exponent.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Exponent {
    /// Fitted exponent (slope in ln–ln).
    pub exponent: f64,
    /// −exponent (γ of A ∼ L^−γ).
    pub gamma: f64,
    /// Prefactor.
    pub prefactor: f64,
    /// R² in ln–ln.
    pub r_squared: f64,
    /// Effective exponents between consecutive heights: (geometric-mean height, local slope).
    pub effective: Vec<(f64, f64)>,
}

/// Everything [`analyze_heights`] derives.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeightSeries {
    /// Heights L, increasing [length].
    pub heights: Vec<f64>,
    /// Leading-edge times [time].
    pub edge_times: Vec<f64>,
    /// First-peak times [time].
    pub peak_times: Vec<f64>,
    /// First-peak amplitudes A.
    pub amplitudes: Vec<f64>,
    /// Widths W (leading edge → first zero crossing; NaN when absent) [time].
    pub widths: Vec<f64>,
    /// FWHM (NaN when absent) [time].
    pub fwhm: Vec<f64>,
    /// Linear fit of the leading-edge time vs L.
    pub edge_fit: Option<LinearFit>,
    /// Linear fit of the peak time vs L.
    pub peak_fit: Option<LinearFit>,
    /// 1/slope of the leading-edge fit [length/time].
    pub edge_speed: Option<f64>,
    /// 1/slope of the peak-time fit [length/time].
    pub peak_speed: Option<f64>,
    /// c_tof between the heights closest to the reference heights.
    pub time_of_flight: Option<TimeOfFlight>,
    /// A ∼ L^−γ.
    pub amplitude_exponent: Option<Exponent>,
    /// W ∼ L^α.
    pub width_exponent: Option<Exponent>,
    /// FWHM ∼ L^α'.
    pub fwhm_exponent: Option<Exponent>,
}

fn exponent(x: &[f64], y: &[f64]) -> Option<Exponent> {
    let keep: Vec<(f64, f64)> = x.iter().zip(y).filter(|(a, b)| a.is_finite() && b.is_finite() && **a > 0.0 && **b > 0.0).map(|(a, b)| (*a, *b)).collect();
    if keep.len() < 2 {
        return None;
    }
    let (x, y): (Vec<f64>, Vec<f64>) = keep.into_iter().unzip();
    let fit = power_law_fit(&x, &y).ok()?;
    let effective = effective_exponents(&x, &y).ok()?;
    Some(Exponent { exponent: fit.exponent, gamma: -fit.exponent, prefactor: fit.prefactor, r_squared: fit.r_squared, effective })
}

/// Fits over a series of (height, metrics) points (see the module docs). Heights must be positive
/// and distinct; points are sorted by height. One point gives the tables without fits.
pub fn analyze_heights(points: &[(f64, PulseMetrics)], options: &SeriesOptions) -> Result<HeightSeries, SignalError> {
    let mut pts: Vec<&(f64, PulseMetrics)> = points.iter().collect();
    for (k, (l, _)) in pts.iter().enumerate() {
        if !(l.is_finite() && *l > 0.0) {
            return Err(SignalError::BadSample { index: k, reason: format!("height {l} is not a positive length") });
        }
    }
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    for k in 1..pts.len() {
        if pts[k].0 == pts[k - 1].0 {
            return Err(SignalError::BadSample { index: k, reason: format!("height {} appears twice", pts[k].0) });
        }
    }
    let heights: Vec<f64> = pts.iter().map(|p| p.0).collect();
    let edge_times: Vec<f64> = pts.iter().map(|p| p.1.leading_edge_time).collect();
    let peak_times: Vec<f64> = pts.iter().map(|p| p.1.peak_time).collect();
    let amplitudes: Vec<f64> = pts.iter().map(|p| p.1.peak_amplitude).collect();
    let widths: Vec<f64> = pts.iter().map(|p| p.1.width.unwrap_or(f64::NAN)).collect();
    let fwhm: Vec<f64> = pts.iter().map(|p| p.1.fwhm.unwrap_or(f64::NAN)).collect();
    let (edge_fit, peak_fit) = if heights.len() >= 2 { (linear_fit(&heights, &edge_times).ok(), linear_fit(&heights, &peak_times).ok()) } else { (None, None) };
    let time_of_flight = if heights.len() >= 2 {
        let nearest = |target: f64, exclude: Option<usize>| {
            (0..heights.len()).filter(|&k| Some(k) != exclude).min_by(|&a, &b| (heights[a] - target).abs().total_cmp(&(heights[b] - target).abs()))
        };
        let k1 = nearest(options.tof_heights[0], None);
        let k2 = k1.and_then(|k1| nearest(options.tof_heights[1], Some(k1)));
        match (k1, k2) {
            (Some(a), Some(b)) => {
                let (a, b) = if heights[a] < heights[b] { (a, b) } else { (b, a) };
                Some(TimeOfFlight {
                    height_1: heights[a],
                    height_2: heights[b],
                    edge_times: (edge_times[a], edge_times[b]),
                    velocity: crate::signal::time_of_flight_velocity(heights[a], edge_times[a], heights[b], edge_times[b]),
                })
            }
            _ => None,
        }
    } else {
        None
    };
    Ok(HeightSeries {
        edge_speed: edge_fit.map(|f| 1.0 / f.slope),
        peak_speed: peak_fit.map(|f| 1.0 / f.slope),
        amplitude_exponent: exponent(&heights, &amplitudes),
        width_exponent: exponent(&heights, &widths),
        fwhm_exponent: exponent(&heights, &fwhm),
        heights,
        edge_times,
        peak_times,
        amplitudes,
        widths,
        fwhm,
        edge_fit,
        peak_fit,
        time_of_flight,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::{pulse_metrics, PulseOptions};
    use std::f64::consts::PI;

    /// A synthetic pulse: 0 before t_a, then A sin(π(t − t_a)/W) (first lobe positive, then
    /// negative), sampled every `dt`. Its metrics are known in closed form: leading edge
    /// t_a + W asin(0.1)/π, peak t_a + W/2 with amplitude A, zero crossing t_a + W, FWHM 2W/3.
    fn pulse(t_a: f64, amplitude: f64, w: f64, dt: f64, end: f64) -> (Vec<f64>, Vec<f64>) {
        let n = (end / dt).round() as usize;
        let t: Vec<f64> = (0..=n).map(|k| k as f64 * dt).collect();
        let f = t.iter().map(|&t| if t > t_a && t < t_a + 1.5 * w { amplitude * (PI * (t - t_a) / w).sin() } else { 0.0 }).collect();
        (t, f)
    }

    /// Arrival t_a = L/c + t₀, A = A₀ L^−γ, W = W₀ L^α, through `pulse_metrics` and
    /// `analyze_heights`: every quantity is recovered. Tolerances: linear interpolation on a sine
    /// sampled every 1e-3 (≥ 2000 samples per lobe) errs by ≤ h²|F''|/8 ≈ 1e-7 A in value, so edge
    /// and zero-crossing times by ~1e-6 W and the parabolic peak amplitude by ~1e-9 A; exponents
    /// from log ratios of such values are good to ~1e-6, and c to ~1e-6 relative.
    #[test]
    fn c_tof_and_exponents_of_synthetic_signals() {
        let (c, t0, a0, gamma, w0, alpha) = (0.3, 2.0, 0.7, 0.8, 1.5, 0.4);
        let heights = [8.0, 12.0, 16.0, 25.0, 40.0];
        let kappa = (0.1f64).asin() / PI; // edge offset in units of W
        let points: Vec<(f64, PulseMetrics)> = heights
            .iter()
            .map(|&l: &f64| {
                let w = w0 * l.powf(alpha);
                let (t, f) = pulse(l / c + t0, a0 * l.powf(-gamma), w, 1e-3, l / c + t0 + 2.0 * w);
                (l, pulse_metrics(&t, &f, &PulseOptions::default()).unwrap())
            })
            .collect();
        let s = analyze_heights(&points, &SeriesOptions::default()).unwrap();
        let a = s.amplitude_exponent.as_ref().unwrap();
        assert!((a.gamma - gamma).abs() < 1e-6, "γ = {}", a.gamma);
        assert!((a.prefactor - a0).abs() < 1e-6 * a0);
        for (_, e) in &a.effective {
            assert!((e + gamma).abs() < 1e-6);
        }
        let w = s.width_exponent.as_ref().unwrap();
        assert!((w.exponent - alpha).abs() < 1e-6, "α = {}", w.exponent);
        assert!((w.prefactor - w0 * (1.0 - kappa)).abs() < 1e-5, "{}", w.prefactor);
        let f = s.fwhm_exponent.as_ref().unwrap();
        assert!((f.exponent - alpha).abs() < 1e-6 && (f.prefactor - 2.0 * w0 / 3.0).abs() < 1e-5);
        // c_tof between L = 8 and 25: ΔL / Δ(L/c + κ W(L)) exactly
        let tof = s.time_of_flight.unwrap();
        assert_eq!((tof.height_1, tof.height_2), (8.0, 25.0));
        let edge = |l: f64| l / c + t0 + kappa * w0 * l.powf(alpha);
        let expected = 17.0 / (edge(25.0) - edge(8.0));
        assert!((tof.velocity - expected).abs() < 1e-6 * expected, "c_tof = {} vs {expected}", tof.velocity);
        for (k, &l) in heights.iter().enumerate() {
            assert!((s.edge_times[k] - edge(l)).abs() < 1e-5, "edge at L = {l}: {} vs {}", s.edge_times[k], edge(l));
            assert!((s.peak_times[k] - (l / c + t0 + w0 * l.powf(alpha) / 2.0)).abs() < 1e-6);
        }
        // with a constant width the arrival times are exactly linear: every speed is c
        let points: Vec<(f64, PulseMetrics)> = heights
            .iter()
            .map(|&l| {
                let (t, f) = pulse(l / c + t0, a0 * l.powf(-gamma), w0, 1e-3, l / c + t0 + 2.0 * w0);
                (l, pulse_metrics(&t, &f, &PulseOptions::default()).unwrap())
            })
            .collect();
        let s = analyze_heights(&points, &SeriesOptions::default()).unwrap();
        for v in [s.time_of_flight.unwrap().velocity, s.edge_speed.unwrap(), s.peak_speed.unwrap()] {
            assert!((v - c).abs() < 1e-6 * c, "{v}");
        }
        assert!(s.edge_fit.unwrap().r_squared > 1.0 - 1e-12);
        assert!(s.width_exponent.unwrap().exponent.abs() < 1e-6);
    }

    #[test]
    fn series_refuse_bad_heights_and_handle_short_ones() {
        let m = PulseMetrics { peak_time: 2.0, peak_amplitude: 1.0, leading_edge_time: 1.0, zero_crossing_time: None, width: None, half_maximum_times: None, fwhm: None };
        assert!(analyze_heights(&[(8.0, m.clone()), (8.0, m.clone())], &SeriesOptions::default()).is_err());
        assert!(analyze_heights(&[(-1.0, m.clone())], &SeriesOptions::default()).is_err());
        let s = analyze_heights(&[(8.0, m.clone())], &SeriesOptions::default()).unwrap();
        assert!(s.time_of_flight.is_none() && s.edge_fit.is_none() && s.amplitude_exponent.is_none());
        // widths missing: no width exponent, the rest is there
        let s = analyze_heights(&[(8.0, m.clone()), (16.0, PulseMetrics { leading_edge_time: 2.0, peak_amplitude: 0.5, ..m })], &SeriesOptions::default()).unwrap();
        assert!(s.width_exponent.is_none() && (s.amplitude_exponent.unwrap().gamma - 1.0).abs() < 1e-12);
        assert!((s.time_of_flight.unwrap().velocity - 8.0).abs() < 1e-12);
    }
}
