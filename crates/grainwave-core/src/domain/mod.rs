//! The simulation domain as a value: which axes are periodic, the periodic cell, and the walls.
//! Nothing else in grainwave does minimum-image arithmetic: ask [`Domain::displacement`].

mod time_function;
mod wall;

pub use time_function::TimeFunction;
pub use wall::{Wall, WallMotion};

use crate::dim::{Dim, VectorOps};
use crate::error::{CoreError, Result};
use serde::{Deserialize, Serialize};

/// Periodicity and walls.
///
/// Along a periodic axis k the cell is `[lo_k, hi_k)` and pair vectors follow the minimum-image
/// convention. Along a non-periodic axis `lo`/`hi` are only the initial extent (used for
/// placement and output); grains are confined by walls, if any.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Domain<D: Dim> {
    /// Lower corner.
    pub lo: D::Vector,
    /// Upper corner.
    pub hi: D::Vector,
    /// Periodicity per axis (entries beyond the dimension are ignored).
    pub periodic: [bool; 3],
    /// Walls.
    pub walls: Vec<Wall<D>>,
}

impl<D: Dim> Domain<D> {
    /// A box `[lo, hi]` with the given periodic axes and no walls.
    pub fn new(lo: D::Vector, hi: D::Vector, periodic: [bool; 3]) -> Self {
        Domain { lo, hi, periodic, walls: Vec::new() }
    }

    /// Adds a wall (builder style).
    pub fn with_wall(mut self, wall: Wall<D>) -> Self {
        self.walls.push(wall);
        self
    }

    /// Edge length along axis `k`.
    #[inline]
    pub fn length(&self, k: usize) -> f64 {
        self.hi.get(k) - self.lo.get(k)
    }

    /// True when axis `k` is periodic.
    #[inline]
    pub fn is_periodic(&self, k: usize) -> bool {
        self.periodic[k]
    }

    /// Vector from `from` to `to`, nearest periodic image.
    #[inline]
    pub fn displacement(&self, from: D::Vector, to: D::Vector) -> D::Vector {
        self.image().displacement(from, to)
    }

    /// The periodic cell in the form the force loop uses (inverse lengths precomputed); its
    /// [`PeriodicImage::displacement`] is bitwise equal to [`Domain::displacement`].
    #[inline]
    pub fn image(&self) -> PeriodicImage<D> {
        let mut length = D::Vector::ZERO;
        let mut inverse = D::Vector::ZERO;
        for k in 0..D::D {
            if self.periodic[k] {
                let l = self.length(k);
                length.set(k, l);
                inverse.set(k, 1.0 / l);
            }
        }
        PeriodicImage { length, inverse }
    }

    /// Maps `x` back into the periodic cell, counting crossings in `image`.
    #[inline]
    pub fn wrap(&self, x: &mut D::Vector, image: &mut [i32; 3]) {
        for k in 0..D::D {
            if self.periodic[k] {
                let l = self.length(k);
                let lo = self.lo.get(k);
                let mut xk = x.get(k);
                // A grain moves far less than a cell length per step; loop for robustness.
                while xk >= lo + l {
                    xk -= l;
                    image[k] += 1;
                }
                while xk < lo {
                    xk += l;
                    image[k] -= 1;
                }
                x.set(k, xk);
            }
        }
    }

    /// Position unwrapped through the periodic images (continuous trajectory).
    pub fn unwrapped(&self, x: D::Vector, image: [i32; 3]) -> D::Vector {
        let mut u = x;
        for k in 0..D::D {
            if self.periodic[k] {
                u.set(k, x.get(k) + image[k] as f64 * self.length(k));
            }
        }
        u
    }

    /// Checks extents, walls and that periodic cells are wide enough for pair cut-off `cutoff`
    /// (the minimum-image convention needs every periodic length > 2 × cutoff).
    pub fn validate(&self, cutoff: f64) -> Result<()> {
        for k in 0..D::D {
            let l = self.length(k);
            if !(l.is_finite() && l > 0.0) {
                return Err(CoreError::invalid(format!("domain.size[{k}]"), l, "a finite length > 0"));
            }
            if self.periodic[k] && l <= 2.0 * cutoff {
                return Err(CoreError::invalid(
                    format!("domain.size[{k}]"),
                    l,
                    format!("a periodic length > 2 × (largest diameter + skin) = {}", 2.0 * cutoff),
                ));
            }
        }
        for (w, wall) in self.walls.iter().enumerate() {
            wall.validate(w)?;
            for k in 0..D::D {
                if self.periodic[k] && wall.normal.get(k).abs() > 1e-12 {
                    return Err(CoreError::Inconsistent(format!(
                        "wall `{}` has a normal with a component along periodic axis {k}",
                        wall.name
                    )));
                }
            }
        }
        Ok(())
    }
}

/// Minimum-image arithmetic of a [`Domain`] with the inverse cell lengths precomputed.
#[derive(Clone, Copy, Debug)]
pub struct PeriodicImage<D: Dim> {
    /// Cell length along periodic axes, 0 along the others.
    pub(crate) length: D::Vector,
    /// 1 / length along periodic axes, 0 along the others (so that no image is ever taken).
    pub(crate) inverse: D::Vector,
}

impl<D: Dim> PeriodicImage<D> {
    /// Vector from `from` to `to`, nearest periodic image: per axis d − L·nint(d/L), branch-free.
    #[inline(always)]
    pub fn displacement(&self, from: D::Vector, to: D::Vector) -> D::Vector {
        let mut d = to - from;
        for k in 0..D::D {
            let dk = d.get(k);
            d.set(k, dk - self.length.get(k) * nearest_integer(dk * self.inverse.get(k)));
        }
        d
    }
}

/// The integer nearest to `x` (ties to even), as a float, for |x| < 2⁵¹ (beyond, ±2⁵¹: pair
/// vectors are at most a few box lengths, larger values only come from a blow-up).
///
/// `f64::round` is a library call on the baseline x86-64 target (no SSE4.1 `roundsd`); adding and
/// subtracting 1.5 × 2⁵² rounds exactly in two instructions, and the whole function is branch-free
/// so that the force kernels vectorize. NaN stays NaN.
#[inline(always)]
pub fn nearest_integer(x: f64) -> f64 {
    const SHIFT: f64 = 6_755_399_441_055_744.0; // 1.5 × 2⁵²
    const LIMIT: f64 = 2_251_799_813_685_248.0; // 2⁵¹
    (x.clamp(-LIMIT, LIMIT) + SHIFT) - SHIFT
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::D2;
    use glam::DVec2;

    #[test]
    fn nearest_integer_rounds_exactly() {
        for (x, n) in [(0.0, 0.0), (0.49999999999999994, 0.0), (0.5, 0.0), (1.5, 2.0), (-2.5, -2.0), (-0.7, -1.0), (3.2e9 + 0.6, 3.2e9 + 1.0)] {
            assert_eq!(nearest_integer(x), n, "{x}");
        }
        assert_eq!(nearest_integer(1e300), 2_251_799_813_685_248.0);
        assert!(nearest_integer(f64::NAN).is_nan());
    }

    #[test]
    fn minimum_image_and_wrap() {
        let d: Domain<D2> = Domain::new(DVec2::ZERO, DVec2::new(10.0, 5.0), [true, false, false]);
        let v = d.displacement(DVec2::new(9.5, 1.0), DVec2::new(0.5, 2.0));
        assert!((v - DVec2::new(1.0, 1.0)).length() < 1e-14);
        let v = d.displacement(DVec2::new(0.5, 1.0), DVec2::new(9.5, 4.0));
        assert!((v - DVec2::new(-1.0, 3.0)).length() < 1e-14, "non-periodic y must not wrap: {v:?}");
        let mut x = DVec2::new(10.25, 7.0);
        let mut im = [0; 3];
        d.wrap(&mut x, &mut im);
        assert_eq!(im[0], 1);
        assert!((x.x - 0.25).abs() < 1e-14 && x.y == 7.0);
        assert!((d.unwrapped(x, im).x - 10.25).abs() < 1e-14);
    }
}
