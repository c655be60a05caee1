//! Special functions needed by the coarse-graining: the error function and its complement, to
//! full double precision (Rust's standard library has neither).
//!
//! `erf` and `erfc` are those of the `libm` crate (the rational approximations of FreeBSD's and
//! musl's libm, error below 1 ulp; erfc keeps full *relative* precision in the tail, where 1 − erf x
//! would not). They replaced a power series (|x| < 2) and a continued fraction (x ≥ 2) of ours
//! that were 3–4 × slower and took a quarter of an E3 study's time in the coarse-graining (its
//! line integrals call erf twice per contact and grid point); the reference values below hold
//! for both.
//!
//! [`erf_difference`] returns erf b − erf a without the cancellation of subtracting two numbers
//! close to ±1.
//!
//! ```
//! use grainwave_analysis::special::{erf, erfc};
//! assert!((erf(1.0) - 0.842_700_792_949_714_9).abs() < 1e-15);
//! assert!((erfc(5.0) / 1.537_459_794_428_034_9e-12 - 1.0).abs() < 1e-13);
//! ```

/// The error function erf x = (2/√π) ∫₀ˣ e^{−t²} dt.
pub fn erf(x: f64) -> f64 {
    libm::erf(x)
}

/// The complementary error function erfc x = 1 − erf x, with full relative precision for large x.
pub fn erfc(x: f64) -> f64 {
    libm::erfc(x)
}

/// erf b − erf a, computed from the complements when both arguments lie far on the same side of
/// zero (where erf ≈ ±1 and the plain difference would lose its digits).
pub fn erf_difference(a: f64, b: f64) -> f64 {
    if a >= 2.0 && b >= 2.0 {
        erfc(a) - erfc(b)
    } else if a <= -2.0 && b <= -2.0 {
        erfc(-b) - erfc(-a)
    } else {
        erf(b) - erf(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference values (mpmath, 30 digits, rounded to double).
    const TABLE: &[(f64, f64, f64)] = &[
        // x, erf x, erfc x
        (0.1, 0.112_462_916_018_284_9, 0.887_537_083_981_715_1),
        (0.5, 0.520_499_877_813_046_5, 0.479_500_122_186_953_5),
        (1.0, 0.842_700_792_949_714_9, 0.157_299_207_050_285_1),
        (1.9, 0.992_790_429_235_257_5, 7.209_570_764_742_5e-3),
        (2.0, 0.995_322_265_018_952_7, 4.677_734_981_047_266e-3),
        (2.5, 0.999_593_047_982_555, 4.069_520_174_449_59e-4),
        (3.0, 0.999_977_909_503_001_4, 2.209_049_699_858_544e-5),
        (5.0, 0.999_999_999_998_462_5, 1.537_459_794_428_034_9e-12),
    ];

    #[test]
    fn matches_reference_values() {
        for &(x, e, c) in TABLE {
            assert!((erf(x) - e).abs() <= 2e-16 * e.abs().max(1e-300) + 1e-16, "erf({x}) = {} vs {e}", erf(x));
            assert!((erf(-x) + e).abs() <= 2e-16 + 1e-16, "erf is odd");
            // x ≥ 2: relative precision of the tail, 1e-14 (a few ulps through the exponential and
            // the continued fraction); below, erfc = 1 − erf is good to an absolute 2 ulps of 1
            if x >= 2.0 {
                assert!((erfc(x) / c - 1.0).abs() < 1e-14, "erfc({x}) = {:e} vs {c:e}", erfc(x));
            } else {
                assert!((erfc(x) - c).abs() < 4.5e-16, "erfc({x}) = {:e} vs {c:e}", erfc(x));
            }
            assert!((erfc(-x) - (2.0 - c)).abs() < 1e-15);
        }
        assert_eq!(erf(0.0), 0.0);
        assert_eq!(erf(40.0), 1.0);
        assert_eq!(erfc(40.0), 0.0);
        assert!(erf(f64::NAN).is_nan());
    }

    #[test]
    fn difference_keeps_precision_in_the_tails() {
        // erf 6 − erf 5 = erfc 5 − erfc 6 ≈ 1.5375e-12, which 1 − 1 would lose entirely
        let d = erf_difference(5.0, 6.0);
        assert!((d / (1.537_459_794_428_034_9e-12 - 2.151_973_671_249_891_3e-17) - 1.0).abs() < 1e-13, "{d:e}");
        let d = erf_difference(-6.0, -5.0);
        assert!((d / (1.537_459_794_428_034_9e-12 - 2.151_973_671_249_891_3e-17) - 1.0).abs() < 1e-13, "{d:e}");
        assert!((erf_difference(-1.0, 1.0) - 2.0 * 0.842_700_792_949_714_9).abs() < 1e-15);
    }
}
