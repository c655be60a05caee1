//! The single/double-peak classifier on synthetic profiles (SPEC §7.2.8).

use grainwave_analysis::peaks::{classify_profile, PeakOptions, PeakShape};

fn gauss(x: f64, c: f64, w: f64) -> f64 {
    (-((x - c) / w).powi(2)).exp()
}

/// Deterministic pseudo-noise in [−1, 1].
fn noise(k: usize) -> f64 {
    let v = (k as u64).wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    ((v >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

#[test]
fn one_and_two_peaked_profiles_are_recognised() {
    let x: Vec<f64> = (-240..=240).map(|k| k as f64 * 0.25).collect();
    let options = PeakOptions::default();
    // one peak, at the load or slightly off it, with 1 % noise
    for centre in [0.0, 1.5] {
        let y: Vec<f64> = x.iter().enumerate().map(|(k, &x)| gauss(x, centre, 6.0) + 0.01 * noise(k)).collect();
        let c = classify_profile(&x, &y, &options);
        assert_eq!(c.shape, PeakShape::Single, "centre {centre}: {c:?}");
        assert!((c.peaks[0].position - centre).abs() < 1.0);
    }
    // two peaks at ±s, width 4, with 1 % noise: separated enough to dip
    for s in [6.0, 10.0, 15.0] {
        let y: Vec<f64> = x.iter().enumerate().map(|(k, &x)| gauss(x, -s, 4.0) + gauss(x, s, 4.0) + 0.01 * noise(k)).collect();
        let c = classify_profile(&x, &y, &options);
        assert_eq!(c.shape, PeakShape::Double, "s = {s}: {c:?}");
        assert!((c.separation - 2.0 * s).abs() < 1.0, "separation {}", c.separation);
        assert!(c.dip > 0.1);
    }
    // unequal peaks still count, on either side of the load
    let y: Vec<f64> = x.iter().map(|&x| gauss(x, -8.0, 4.0) + 0.6 * gauss(x, 9.0, 4.0)).collect();
    assert_eq!(classify_profile(&x, &y, &options).shape, PeakShape::Double);
    // two Gaussians closer than their width merge into one peak
    let y: Vec<f64> = x.iter().map(|&x| gauss(x, -2.0, 4.0) + gauss(x, 2.0, 4.0)).collect();
    assert_eq!(classify_profile(&x, &y, &options).shape, PeakShape::Single);
    // a shoulder whose prominence is below 5 % of the maximum is ignored
    let y: Vec<f64> = x.iter().map(|&x| gauss(x, 0.0, 5.0) + 0.03 * gauss(x, 20.0, 2.0)).collect();
    assert_eq!(classify_profile(&x, &y, &options).shape, PeakShape::Single);
    // two peaks on the same side of the load are not a double-peaked response
    let y: Vec<f64> = x.iter().map(|&x| gauss(x, 10.0, 3.0) + gauss(x, 25.0, 3.0)).collect();
    assert_eq!(classify_profile(&x, &y, &options).shape, PeakShape::Irregular);
    // a profile without a positive value has no verdict
    let y: Vec<f64> = x.iter().map(|&x| -gauss(x, 0.0, 5.0)).collect();
    assert_eq!(classify_profile(&x, &y, &options).shape, PeakShape::Irregular);
}
