//! Peaks of a sampled profile and the single/double-peak classifier of the floor response
//! (SPEC §7.2.8).
//!
//! # Peaks
//!
//! A **peak** is a local maximum of the samples y_k (a plateau counts once, at its middle; the two
//! end samples are never peaks). Its **prominence** is its height above the higher of its two
//! bases, a base being the lowest sample between the peak and the nearest sample higher than the
//! peak on that side (or the end of the profile).
//!
//! # Classification
//!
//! With y_max the largest sample (the profile must have one > 0), the peaks whose prominence is at
//! least `prominence` × y_max are **significant**:
//!
//! * one significant peak → [`PeakShape::Single`];
//! * two or more, the two highest lying on either side of the centre x_c (the position of the
//!   load) with the profile between them dipping below both → [`PeakShape::Double`]; the **dip**
//!   1 − y_min/min(y₁, y₂) (y_min the lowest sample between them) and the **separation** x₂ − x₁ are
//!   reported;
//! * anything else (no peak, the two highest on the same side) → [`PeakShape::Irregular`].
//!
//! The default prominence threshold, 5 % of the maximum, ignores the ripple left by smoothing the
//! discrete floor forces and the noise of a single disordered sample, and is well below the dip of
//! the two-peaked responses of frictionless lattices (tens of per cent).
//!
//! ```
//! use grainwave_analysis::peaks::{classify_profile, PeakOptions, PeakShape};
//! let x: Vec<f64> = (-200..=200).map(|k| k as f64 * 0.1).collect();
//! let one: Vec<f64> = x.iter().map(|x| (-(x / 4.0f64).powi(2)).exp()).collect();
//! let two: Vec<f64> = x.iter().map(|x| (-((x - 7.0) / 3.0f64).powi(2)).exp() + (-((x + 7.0) / 3.0f64).powi(2)).exp()).collect();
//! assert_eq!(classify_profile(&x, &one, &PeakOptions::default()).shape, PeakShape::Single);
//! assert_eq!(classify_profile(&x, &two, &PeakOptions::default()).shape, PeakShape::Double);
//! ```

use serde::{Deserialize, Serialize};

/// A local maximum of a profile.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Peak {
    /// Sample index.
    pub index: usize,
    /// Position x.
    pub position: f64,
    /// Value y.
    pub height: f64,
    /// Prominence (height above the higher base).
    pub prominence: f64,
}

/// All peaks of (x, y) with their prominences, in order of position.
pub fn find_peaks(x: &[f64], y: &[f64]) -> Vec<Peak> {
    assert_eq!(x.len(), y.len(), "x and y must have the same length");
    let n = y.len();
    let mut peaks = Vec::new();
    let mut k = 1;
    while k + 1 < n {
        if y[k] > y[k - 1] {
            // walk along a plateau
            let mut e = k;
            while e + 1 < n && y[e + 1] == y[k] {
                e += 1;
            }
            if e + 1 < n && y[e + 1] < y[k] {
                let mid = (k + e) / 2;
                let h = y[k];
                let mut left = h;
                let mut j = k;
                while j > 0 {
                    j -= 1;
                    if y[j] > h {
                        break;
                    }
                    left = left.min(y[j]);
                }
                let mut right = h;
                let mut j = e;
                while j + 1 < n {
                    j += 1;
                    if y[j] > h {
                        break;
                    }
                    right = right.min(y[j]);
                }
                peaks.push(Peak { index: mid, position: x[mid], height: h, prominence: h - left.max(right) });
            }
            k = e + 1;
        } else {
            k += 1;
        }
    }
    peaks
}

/// Options of [`classify_profile`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PeakOptions {
    /// Least prominence of a significant peak, as a fraction of the profile's maximum (default 0.05).
    pub prominence: f64,
    /// Position of the load: the two peaks of a double-peaked profile lie on either side (default 0).
    pub centre: f64,
}

impl Default for PeakOptions {
    fn default() -> Self {
        PeakOptions { prominence: 0.05, centre: 0.0 }
    }
}

/// Verdict of the classifier.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PeakShape {
    /// One significant peak (elastic-like response).
    Single,
    /// Two significant peaks on either side of the load.
    Double,
    /// No significant peak, or peaks not arranged as one of the above.
    Irregular,
}

impl PeakShape {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            PeakShape::Single => "single",
            PeakShape::Double => "double",
            PeakShape::Irregular => "irregular",
        }
    }
}

/// Result of [`classify_profile`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PeakClassification {
    /// The verdict.
    pub shape: PeakShape,
    /// The significant peaks, in order of position.
    pub peaks: Vec<Peak>,
    /// Double: 1 − y_min/min(y₁, y₂) between the two peaks; otherwise 0.
    pub dip: f64,
    /// Double: distance between the two peaks; otherwise 0.
    pub separation: f64,
    /// Position of the highest sample.
    pub max_position: f64,
}

/// Classifies the profile (x, y) as single- or double-peaked (see the module docs).
pub fn classify_profile(x: &[f64], y: &[f64], options: &PeakOptions) -> PeakClassification {
    let (mut k_max, mut y_max) = (0, f64::NEG_INFINITY);
    for (k, &v) in y.iter().enumerate() {
        if v > y_max {
            y_max = v;
            k_max = k;
        }
    }
    let max_position = x.get(k_max).copied().unwrap_or(f64::NAN);
    let irregular = |peaks: Vec<Peak>| PeakClassification { shape: PeakShape::Irregular, peaks, dip: 0.0, separation: 0.0, max_position };
    if !(y_max > 0.0) {
        return irregular(Vec::new());
    }
    let significant: Vec<Peak> = find_peaks(x, y).into_iter().filter(|p| p.prominence >= options.prominence * y_max).collect();
    match significant.len() {
        0 => irregular(significant),
        1 => PeakClassification { shape: PeakShape::Single, peaks: significant, dip: 0.0, separation: 0.0, max_position },
        _ => {
            let mut by_height = significant.clone();
            by_height.sort_by(|a, b| b.height.total_cmp(&a.height));
            let (p, q) = (by_height[0], by_height[1]);
            let (a, b) = if p.position < q.position { (p, q) } else { (q, p) };
            let between = y[a.index..=b.index].iter().cloned().fold(f64::INFINITY, f64::min);
            let lower = a.height.min(b.height);
            if a.position < options.centre && b.position > options.centre && between < lower {
                PeakClassification {
                    shape: PeakShape::Double,
                    peaks: significant,
                    dip: 1.0 - between / lower,
                    separation: b.position - a.position,
                    max_position,
                }
            } else {
                irregular(significant)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prominences_of_a_simple_profile() {
        let x: Vec<f64> = (0..9).map(|k| k as f64).collect();
        let y = [0.0, 2.0, 1.0, 3.0, 3.0, 3.0, 0.5, 1.0, 0.0];
        let p = find_peaks(&x, &y);
        assert_eq!(p.len(), 3);
        assert_eq!((p[0].index, p[0].prominence), (1, 1.0)); // base 1.0 towards the higher plateau
        assert_eq!((p[1].index, p[1].prominence), (4, 3.0)); // plateau 3..5, middle 4
        assert_eq!((p[2].index, p[2].prominence), (7, 0.5));
    }
}
