//! Ensemble statistics: means and standard deviations of scalars over samples, and the pointwise
//! ensemble average and r.m.s. deviation of signals sampled on a common time grid (SPEC §5.2, §5.4).
//!
//! ```
//! use grainwave_analysis::ensemble::{mean_std, mean_and_rms};
//! let s = mean_std(&[1.0, 2.0, 3.0]);
//! assert_eq!((s.mean, s.std, s.count), (2.0, 1.0, 3));
//! let (mean, rms) = mean_and_rms(&[vec![0.0, 2.0], vec![2.0, 2.0]]);
//! assert_eq!((mean, rms), (vec![1.0, 2.0], vec![1.0, 0.0]));
//! ```

use serde::{Deserialize, Serialize};

/// Mean and standard deviation of a set of values.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeanStd {
    /// Mean of the finite values (NaN when there is none).
    pub mean: f64,
    /// Sample standard deviation √(Σ(x − x̄)²/(n − 1)) (0 for one value, NaN for none).
    pub std: f64,
    /// Number of finite values used.
    pub count: usize,
}

impl MeanStd {
    /// Standard error of the mean, std/√n.
    pub fn error(&self) -> f64 {
        if self.count == 0 {
            f64::NAN
        } else {
            self.std / (self.count as f64).sqrt()
        }
    }
}

/// Mean and sample standard deviation of the finite entries of `values` (NaN and ±∞ — e.g. a
/// metric a sample could not provide — are left out and not counted).
pub fn mean_std(values: &[f64]) -> MeanStd {
    let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    let n = v.len();
    if n == 0 {
        return MeanStd { mean: f64::NAN, std: f64::NAN, count: 0 };
    }
    let mean = v.iter().sum::<f64>() / n as f64;
    let std = if n > 1 { (v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64).sqrt() } else { 0.0 };
    MeanStd { mean, std, count: n }
}

/// Pointwise ensemble average ⟨F⟩(t_k) and r.m.s. deviation √⟨(F − ⟨F⟩)²⟩(t_k) (population form,
/// divided by the number of signals) of signals on a common grid. Empty input gives empty output;
/// signals shorter than the first are an error of the caller (only the common length is used).
pub fn mean_and_rms(signals: &[Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
    if signals.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let len = signals.iter().map(Vec::len).min().unwrap_or(0);
    let n = signals.len() as f64;
    let mut mean = vec![0.0; len];
    for s in signals {
        for k in 0..len {
            mean[k] += s[k] / n;
        }
    }
    let mut rms = vec![0.0; len];
    for s in signals {
        for k in 0..len {
            rms[k] += (s[k] - mean[k]).powi(2) / n;
        }
    }
    rms.iter_mut().for_each(|x| *x = x.sqrt());
    (mean, rms)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statistics_skip_missing_values() {
        let s = mean_std(&[1.0, f64::NAN, 3.0, f64::INFINITY]);
        assert_eq!((s.mean, s.count), (2.0, 2));
        assert!((s.std - 2f64.sqrt()).abs() < 1e-15 && (s.error() - 1.0).abs() < 1e-15);
        let s = mean_std(&[]);
        assert!(s.mean.is_nan() && s.count == 0);
        assert_eq!(mean_std(&[5.0]).std, 0.0);
        let (m, r) = mean_and_rms(&[vec![1.0, 2.0, 3.0], vec![3.0, 2.0]]);
        assert_eq!((m, r), (vec![2.0, 2.0], vec![1.0, 0.0]));
    }
}
