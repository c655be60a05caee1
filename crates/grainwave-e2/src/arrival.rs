//! Arrival times and pulse speed (SPEC §6.5).
//!
//! * Wall pulse: the arrival at grain i is the sample time of the maximum of |δv_x,i| (|δv_y,i| for
//!   a pulse from the top wall).
//! * Wall pulse, first lobe (an extension for deforming packings, `arrival = "first_lobe"`): with
//!   u_i = ±δv_x,i signed so that the incident pulse's motion is positive, the arrival is the time
//!   of the peak of the first interval where u_i > 0 (a "lobe") that starts by u_i reaching
//!   `lobe_threshold` × A_inc, A_inc being the incident amplitude, the largest |δv_x| among the
//!   grains of the strip next to the pulsing wall while the pulse enters ([`incident_amplitude`]).
//!   A lobe still open at the end of the record gives no arrival.
//! * Central source: the first sample time at which |δv_i| reaches 10 % of its maximum.
//! * Pulse speed: the grains are binned by their distance s from the source into strips of equal
//!   width (128 by default) perpendicular to the propagation; in each strip the grain with the
//!   third-smallest arrival time is kept; s against t of those grains is fitted by a straight line,
//!   s = c t + b, and c is the speed.

use serde::{Deserialize, Serialize};

/// Arrival by the maximum of |δv_c|, c = `component` (0: x, 1: y; a wall pulse uses the component
/// along the wall normal, SPEC's |v_x| for the right wall). `field` is [samples][grains][2]
/// (row-major), `times` the sample times. Grains that never move get `None`, and so do those whose
/// maximum is at the last sample (the pulse may not have passed yet).
pub fn arrival_of_maximum(field: &[f32], grains: usize, times: &[f64], component: usize) -> Vec<Option<f64>> {
    let samples = times.len();
    (0..grains)
        .map(|i| {
            let mut best = 0.0f32;
            let mut at = None;
            for s in 0..samples {
                let v = field[(s * grains + i) * 2 + component].abs();
                if v > best {
                    best = v;
                    at = Some(s);
                }
            }
            match at {
                Some(s) if s + 1 < samples => Some(times[s]),
                _ => None,
            }
        })
        .collect()
}

/// Arrival by the peak of the first lobe of u_i = `sign` × δv_c,i that reaches `threshold`
/// (absolute, in the field's units): from the first sample where u_i ≥ `threshold` to the next
/// sample where u_i ≤ 0, the time of the largest u_i. `None` for grains that never reach the
/// threshold and for lobes still open at the last sample.
pub fn arrival_of_first_lobe(field: &[f32], grains: usize, times: &[f64], component: usize, sign: f64, threshold: f64) -> Vec<Option<f64>> {
    let samples = times.len();
    let u = |s: usize, i: usize| sign * field[(s * grains + i) * 2 + component] as f64;
    (0..grains)
        .map(|i| {
            let start = (0..samples).find(|&s| u(s, i) >= threshold)?;
            let mut best = start;
            for s in start + 1..samples {
                let v = u(s, i);
                if v <= 0.0 {
                    return Some(times[best]);
                }
                if v > u(best, i) {
                    best = s;
                }
            }
            None
        })
        .collect()
}

/// The incident amplitude A_inc of a wall pulse: the largest |δv_c| among the grains whose
/// distance from the pulsing wall is below `near` (the first strip) at samples up to time
/// `until` (the pulse has entered; later the near-wall grains also carry reflections and, in a
/// deforming packing, the growth of the perturbation). Zero when nothing moved.
pub fn incident_amplitude(field: &[f32], grains: usize, times: &[f64], component: usize, distance: &[f64], near: f64, until: f64) -> f64 {
    let mut a = 0.0f64;
    for (s, &t) in times.iter().enumerate() {
        if t > until {
            break;
        }
        for (i, &d) in distance.iter().enumerate().take(grains) {
            if d < near {
                a = a.max((field[(s * grains + i) * 2 + component] as f64).abs());
            }
        }
    }
    a
}

/// Arrival by the first time |δv| reaches `fraction` (SPEC: 10 %) of its maximum (central source).
pub fn arrival_of_threshold(field: &[f32], grains: usize, times: &[f64], fraction: f64) -> Vec<Option<f64>> {
    let samples = times.len();
    let speed = |s: usize, i: usize| {
        let k = (s * grains + i) * 2;
        (field[k] as f64).hypot(field[k + 1] as f64)
    };
    (0..grains)
        .map(|i| {
            let max = (0..samples).map(|s| speed(s, i)).fold(0.0, f64::max);
            if max <= 0.0 {
                return None;
            }
            (0..samples).find(|&s| speed(s, i) >= fraction * max).map(|s| times[s])
        })
        .collect()
}

/// The result of the strip method.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StripFit {
    /// Per used strip: distance s of its third-earliest grain from the source [length].
    pub distance: Vec<f64>,
    /// Per used strip: that grain's arrival time [time].
    pub time: Vec<f64>,
    /// Slope c of s = c t + b [length/time].
    pub speed: f64,
    /// Intercept b [length].
    pub intercept: f64,
    /// Strips used in the fit.
    pub strips_used: usize,
}

/// The strip method: `distance[i]` is grain i's distance from the source, `arrival[i]` its arrival
/// time. Strips of equal width cover [0, max distance]; strips with fewer than three arrived grains
/// are skipped; only strips whose centre lies between `fit_range` fractions of the largest distance
/// enter the fit. Returns `None` when fewer than two strips remain, and when the fitted slope is
/// not positive: arrival times that do not increase with distance are no front (by the maximum of
/// |δv_x| in a deforming packing whose two replays drift apart by more than the pulse, the maxima
/// sit at the end of the record), and a negative "speed" would pass into the decomposition as a
/// number.
pub fn strip_speed(distance: &[f64], arrival: &[Option<f64>], strips: usize, fit_range: [f64; 2]) -> Option<StripFit> {
    let s_max = distance.iter().cloned().fold(0.0, f64::max);
    if !(s_max > 0.0) || strips == 0 {
        return None;
    }
    let width = s_max / strips as f64;
    let mut bins: Vec<Vec<(f64, f64)>> = vec![Vec::new(); strips];
    for (s, t) in distance.iter().zip(arrival) {
        if let Some(t) = t {
            let b = ((s / width) as usize).min(strips - 1);
            bins[b].push((*t, *s));
        }
    }
    let mut fit = StripFit::default();
    for (b, bin) in bins.iter_mut().enumerate() {
        let centre = (b as f64 + 0.5) * width;
        if bin.len() < 3 || centre < fit_range[0] * s_max || centre > fit_range[1] * s_max {
            continue;
        }
        bin.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
        fit.time.push(bin[2].0);
        fit.distance.push(bin[2].1);
    }
    if fit.time.len() < 2 {
        return None;
    }
    let c = super::strain::regression_slope(&fit.time, &fit.distance);
    if !(c > 0.0 && c.is_finite()) {
        return None;
    }
    let n = fit.time.len() as f64;
    fit.intercept = fit.distance.iter().sum::<f64>() / n - c * fit.time.iter().sum::<f64>() / n;
    fit.speed = c;
    fit.strips_used = fit.time.len();
    Some(fit)
}
