//! The simulation domain as a value: which axes are periodic, the periodic cell, and the walls.
//! Nothing else in grainwave does minimum-image arithmetic: ask [`Domain::displacement`].
//!
//! The arithmetic is written once, generic over the floating-point lanes ([`Real`]): one value
//! (`f64`, [`PeriodicImage::displacement_velocity`]) or eight and sixteen at a time (the AVX2 and
//! AVX-512 force passes, neighbor search and displacement checks call
//! [`PeriodicImage::displacement_velocity_lanes`] or, for a cell that is not sheared,
//! [`nearest_image_axis`] with their own lane types). So every path takes the same image with
//! the same bits.

mod time_function;
mod wall;

pub use time_function::TimeFunction;
pub use wall::{Wall, WallMotion};

use crate::dim::{Dim, VectorOps};
use crate::error::{CoreError, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// Periodicity and walls.
///
/// Along a periodic axis k the cell is `[lo_k, hi_k)` and pair vectors follow the minimum-image
/// convention. Along a non-periodic axis `lo`/`hi` are only the initial extent (used for
/// placement and output); grains are confined by walls, if any.
///
/// **Sheared cells.** The periodic cell may be a parallelepiped (LAMMPS's triclinic convention):
/// its edge vectors are a = (L_x, 0, 0), b = (xy, L_y, 0), c = (xz, yz, L_z) with the tilt
/// factors `tilt = [xy, xz, yz]`. The tilt may change at a constant rate, `tilt_rate`: this is
/// Lees–Edwards shear (LAMMPS `fix deform … xy erate … remap v`). The images of a grain then move
/// with the cell: the image of grain j across the y boundary is at x_j − b and moves with
/// v_j − ḃ, and a grain that crosses that boundary has b subtracted from its position and ḃ
/// from its velocity. Grains are not moved affinely: the shear enters through the boundaries.
/// Only the tilt modulo the cell length matters (xy and xy − L_x describe the same lattice):
/// positions are wrapped, and the cell list is built, in the cell whose tilt factors are reduced
/// to [−L/2, L/2].
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
    /// Tilt factors [xy, xz, yz] of a sheared periodic cell (0: rectangular); in 2D only xy.
    pub tilt: [f64; 3],
    /// Rate of change of the tilt factors (Lees–Edwards shear), length/time.
    pub tilt_rate: [f64; 3],
}

/// Axes (tilted edge, component) of the tilt factors xy, xz, yz: `tilt[t]` is component
/// `TILT_AXES[t].1` of the edge vector along axis `TILT_AXES[t].0`.
pub(crate) const TILT_AXES: [(usize, usize); 3] = [(1, 0), (2, 0), (2, 1)];

impl<D: Dim> Domain<D> {
    /// A box `[lo, hi]` with the given periodic axes and no walls.
    pub fn new(lo: D::Vector, hi: D::Vector, periodic: [bool; 3]) -> Self {
        Domain { lo, hi, periodic, walls: Vec::new(), tilt: [0.0; 3], tilt_rate: [0.0; 3] }
    }

    /// Adds a wall (builder style).
    pub fn with_wall(mut self, wall: Wall<D>) -> Self {
        self.walls.push(wall);
        self
    }

    /// Shears the periodic cell in the x–y plane at the engineering shear rate `rate`: the tilt
    /// xy grows as `rate × L_y` per unit time (LAMMPS `fix deform 1 xy erate rate remap v`).
    /// Needs x and y periodic.
    pub fn set_shear_rate(&mut self, rate: f64) -> Result<()> {
        if !(self.periodic[0] && self.periodic[1]) {
            return Err(CoreError::Inconsistent("a sheared cell needs periodic x and y axes".into()));
        }
        if !rate.is_finite() {
            return Err(CoreError::invalid("shear rate", rate, "a finite rate"));
        }
        self.tilt_rate[0] = rate * self.length(1);
        Ok(())
    }

    /// True when the cell is tilted or shearing.
    #[inline]
    pub fn is_sheared(&self) -> bool {
        self.tilt != [0.0; 3] || self.tilt_rate != [0.0; 3]
    }

    /// Advances the tilt by `dt` at its rate.
    #[inline]
    pub fn advance_tilt(&mut self, dt: f64) {
        for t in 0..3 {
            if self.tilt_rate[t] != 0.0 {
                self.tilt[t] += self.tilt_rate[t] * dt;
            }
        }
    }

    /// Tilt factor `t` reduced to [−L/2, L/2] of the edge it shifts (the same lattice).
    #[inline]
    fn reduced_tilt(&self, t: usize) -> f64 {
        let (_, along) = TILT_AXES[t];
        let l = self.length(along);
        self.tilt[t] - l * nearest_integer(self.tilt[t] / l)
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
        let mut tilt = [0.0; 3];
        let mut rate = [0.0; 3];
        let sheared = self.is_sheared();
        if sheared {
            for t in 0..3 {
                let (edge, along) = TILT_AXES[t];
                if edge < D::D && self.periodic[edge] && self.periodic[along] {
                    tilt[t] = self.reduced_tilt(t);
                    rate[t] = self.tilt_rate[t];
                }
            }
        }
        PeriodicImage { length, inverse, tilt, rate, sheared }
    }

    /// Maps `x` back into the periodic cell, counting crossings in `image`.
    #[inline]
    pub fn wrap(&self, x: &mut D::Vector, image: &mut [i32; 3]) {
        let mut v = D::Vector::ZERO;
        self.wrap_moving(x, &mut v, image);
    }

    /// Maps `x` back into the periodic cell, counting crossings in `image`; in a shearing cell
    /// the velocity `v` of a grain that crosses a tilted boundary changes with the images.
    #[inline]
    pub fn wrap_moving(&self, x: &mut D::Vector, v: &mut D::Vector, image: &mut [i32; 3]) {
        self.wrap_in(&self.image(), x, v, image);
    }

    /// Bounds of a quick test for [`Domain::wrap_in`]: a grain needs wrapping only when some
    /// coordinate is at or above `hi` or below `lo` (lo and lo + L along periodic axes, the
    /// comparisons of `wrap_in`; ∓∞ along the others). Not valid in a sheared cell.
    #[inline]
    pub(crate) fn wrap_bounds(&self) -> (D::Vector, D::Vector) {
        let (mut lo, mut hi) = (D::Vector::ZERO, D::Vector::ZERO);
        for k in 0..D::D {
            if self.periodic[k] {
                lo.set(k, self.lo.get(k));
                hi.set(k, self.lo.get(k) + self.length(k));
            } else {
                lo.set(k, f64::NEG_INFINITY);
                hi.set(k, f64::INFINITY);
            }
        }
        (lo, hi)
    }

    /// [`Domain::wrap_moving`] with the cell's [`PeriodicImage`] computed once by the caller.
    #[inline]
    pub fn wrap_in(&self, img: &PeriodicImage<D>, x: &mut D::Vector, v: &mut D::Vector, image: &mut [i32; 3]) {
        if !img.sheared {
            for k in 0..D::D {
                if self.periodic[k] {
                    let l = self.length(k);
                    let lo = self.lo.get(k);
                    let mut xk = x.get(k);
                    // A grain moves far less than a cell length per step: one period at most
                    // (the same bits as before). Further out — a position of 1e30 read from a
                    // file or reached in a blow-up, where x − L may equal x — in one step, so
                    // that no coordinate makes this loop run for ever.
                    if xk >= lo + l {
                        xk -= l;
                        image[k] += 1;
                    } else if xk < lo {
                        xk += l;
                        image[k] -= 1;
                    }
                    if !(xk >= lo && xk < lo + l) && xk.is_finite() {
                        let periods = ((xk - lo) / l).floor();
                        xk = lo + (xk - lo).rem_euclid(l);
                        if !(xk < lo + l) {
                            xk = lo; // rem_euclid can round up to exactly l
                        }
                        image[k] = image[k].saturating_add(periods.clamp(i32::MIN as f64, i32::MAX as f64) as i32);
                    }
                    x.set(k, xk);
                }
            }
            return;
        }
        // From the last axis down: the fractional coordinate along k depends on x_k and on the
        // (already wrapped) fractional coordinates of higher axes; crossing along k shifts by
        // the edge vector e_k, which only changes components ≤ k.
        for k in (0..D::D).rev() {
            if !self.periodic[k] {
                continue;
            }
            for _ in 0..1000 {
                let s = img.fractional(*x, self.lo)[k];
                if s >= 1.0 {
                    img.shift(x, v, k, -1.0);
                    image[k] += 1;
                } else if s < 0.0 {
                    img.shift(x, v, k, 1.0);
                    image[k] -= 1;
                } else {
                    break; // inside (or NaN: reported by the blow-up checks)
                }
            }
        }
    }

    /// Position unwrapped through the periodic images (continuous trajectory in a fixed cell;
    /// in a shearing cell, the images of the cell as it is now).
    pub fn unwrapped(&self, x: D::Vector, image: [i32; 3]) -> D::Vector {
        let img = self.image();
        let mut u = x;
        let mut v = D::Vector::ZERO;
        for k in 0..D::D {
            if self.periodic[k] {
                img.shift(&mut u, &mut v, k, image[k] as f64);
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
        for t in 0..3 {
            let (edge, along) = TILT_AXES[t];
            let name = ["xy", "xz", "yz"][t];
            if !(self.tilt[t].is_finite() && self.tilt_rate[t].is_finite()) {
                return Err(CoreError::invalid(format!("domain.tilt.{name}"), self.tilt[t], "finite tilt factors and rates"));
            }
            if (self.tilt[t] != 0.0 || self.tilt_rate[t] != 0.0) && !(edge < D::D && self.periodic[edge] && self.periodic[along]) {
                return Err(CoreError::Inconsistent(format!(
                    "tilt factor {name} needs periodic axes {} and {} in a {}D domain",
                    ["x", "y", "z"][along],
                    ["x", "y", "z"][edge.min(2)],
                    D::D
                )));
            }
        }
        if self.is_sheared() {
            // widths of the reduced cell across its faces, for the cell list and minimum image
            let h = self.image().face_widths();
            for k in 0..D::D {
                if self.periodic[k] && h[k] <= 2.0 * cutoff {
                    return Err(CoreError::invalid(
                        format!("domain.size[{k}]"),
                        h[k],
                        format!("a sheared cell at least 2 × (largest diameter + skin) = {} wide across every face", 2.0 * cutoff),
                    ));
                }
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
    /// Reduced tilt factors [xy, xz, yz] (0 unless sheared).
    pub(crate) tilt: [f64; 3],
    /// Their rates.
    pub(crate) rate: [f64; 3],
    /// The cell is tilted or shearing: the tilt terms are applied.
    pub(crate) sheared: bool,
}

impl<D: Dim> PeriodicImage<D> {
    /// Cell lengths and their inverses along x, y, z (0 along non-periodic axes and past the
    /// dimension), for the vector paths that take them as plain arrays.
    #[cfg(target_arch = "x86_64")]
    pub(crate) fn lengths_and_inverses(&self) -> ([f64; 3], [f64; 3]) {
        let (mut length, mut inverse) = ([0.0; 3], [0.0; 3]);
        for k in 0..D::D {
            (length[k], inverse[k]) = (self.length.get(k), self.inverse.get(k));
        }
        (length, inverse)
    }

    /// Vector from `from` to `to`, nearest periodic image: from the last axis down,
    /// d − n e_k with n = nint(d_k / L_k) and e_k the cell edge along k; branch-free.
    #[inline(always)]
    pub fn displacement(&self, from: D::Vector, to: D::Vector) -> D::Vector {
        self.displacement_velocity(from, to).0
    }

    /// The nearest-image vector from `from` to `to` and the velocity of that image of `to`
    /// relative to `to` itself (zero unless the cell is shearing).
    #[inline(always)]
    pub fn displacement_velocity(&self, from: D::Vector, to: D::Vector) -> (D::Vector, D::Vector) {
        let r = to - from;
        let mut c = [0.0; 3];
        for k in 0..D::D {
            c[k] = r.get(k);
        }
        let (c, cv) = self.displacement_velocity_lanes(c);
        let (mut d, mut dv) = (D::Vector::ZERO, D::Vector::ZERO);
        for k in 0..D::D {
            d.set(k, c[k]);
            dv.set(k, cv[k]);
        }
        (d, dv)
    }

    /// [`PeriodicImage::displacement_velocity`] lane by lane, on the components of `to − from`
    /// (x, y, z; those past the dimension are ignored and returned as they are): the nearest-image
    /// components and the velocity of the image (zero unless the cell is shearing). The one
    /// implementation of the minimum image: from the last axis down, along axis k
    /// n = nint(d_k / L_k) ([`nearest_image_axis`]), d ← d − n e_k with e_k the cell edge along k
    /// (L_k plus the tilt factors of edge k), and dv ← dv − n ė_k. Branch-free in the lanes; the
    /// tilt terms are applied only in a sheared cell (a test once per call).
    #[inline(always)]
    pub(crate) fn displacement_velocity_lanes<R: Real>(&self, mut d: [R; 3]) -> ([R; 3], [R; 3]) {
        let mut dv = [R::splat(0.0); 3];
        if !self.sheared {
            // the same operations without the tilt terms
            for k in (0..D::D).rev() {
                d[k] = nearest_image_axis(d[k], R::splat(self.length.get(k)), R::splat(self.inverse.get(k))).0;
            }
            return (d, dv);
        }
        for k in (0..D::D).rev() {
            let (dk, n) = nearest_image_axis(d[k], R::splat(self.length.get(k)), R::splat(self.inverse.get(k)));
            d[k] = dk;
            for (t, &(edge, along)) in TILT_AXES.iter().enumerate() {
                if edge == k && self.tilt[t] != 0.0 {
                    d[along] = d[along] - n * R::splat(self.tilt[t]);
                }
                if edge == k && self.rate[t] != 0.0 {
                    dv[along] = dv[along] - n * R::splat(self.rate[t]);
                }
            }
        }
        (d, dv)
    }

    /// Adds `n` edge vectors along axis `k` to `x` and their velocity to `v`.
    #[inline]
    fn shift(&self, x: &mut D::Vector, v: &mut D::Vector, k: usize, n: f64) {
        x.set(k, x.get(k) + n * self.length.get(k));
        for (t, &(edge, along)) in TILT_AXES.iter().enumerate() {
            if edge == k && edge < D::D {
                x.set(along, x.get(along) + n * self.tilt[t]);
                v.set(along, v.get(along) + n * self.rate[t]);
            }
        }
    }

    /// Widths of the cell across its faces: the distance between opposite faces, for each
    /// axis (the volume divided by the area of the face the other two edges span).
    pub(crate) fn face_widths(&self) -> [f64; 3] {
        let l = |k: usize| if k < D::D { self.length.get(k) } else { 1.0 };
        let a = [l(0), 0.0, 0.0];
        let b = [self.tilt[0], l(1), 0.0];
        let c = [self.tilt[1], self.tilt[2], l(2)];
        let cross = |u: [f64; 3], w: [f64; 3]| [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
        let norm = |u: [f64; 3]| (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        let volume = l(0) * l(1) * l(2);
        [volume / norm(cross(b, c)), volume / norm(cross(c, a)), volume / norm(cross(a, b))]
    }

    /// Fractional coordinates of `x` in the cell (periodic axes; others untouched), from the last
    /// axis down: s_k = (x_k − lo_k − Σ_{j>k} s_j e_{j,k}) / L_k.
    pub(crate) fn fractional(&self, x: D::Vector, lo: D::Vector) -> [f64; 3] {
        let mut s = [0.0; 3];
        for k in (0..D::D).rev() {
            let mut xk = x.get(k) - lo.get(k);
            for (t, &(edge, along)) in TILT_AXES.iter().enumerate() {
                if along == k && edge < D::D && edge > k {
                    xk -= s[edge] * self.tilt[t];
                }
            }
            s[k] = xk * self.inverse.get(k);
        }
        s
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
    nearest_integer_lanes(x)
}

/// [`nearest_integer`] lane by lane, the one implementation: clamped to ±2⁵¹ keeping NaN (the
/// constant first: `min`/`max` return their second operand for NaN), then shifted by 1.5 × 2⁵²
/// and back.
#[inline(always)]
pub(crate) fn nearest_integer_lanes<R: Real>(x: R) -> R {
    let (limit, shift) = (R::splat(ROUND_LIMIT), R::splat(ROUND_SHIFT));
    (limit.min((-limit).max(x)) + shift) - shift
}

/// The minimum image along one axis, lane by lane: for a pair-vector component `d`, the cell
/// length `length` along that axis and its inverse `inverse` (both 0 along a non-periodic axis,
/// so that no image is taken), returns `(d − length·n, n)` with `n = nint(d · inverse)`.
/// [`PeriodicImage::displacement_velocity_lanes`] composes it with the tilt terms of a sheared
/// cell; the AVX-512 passes that only run in cells that are not sheared call it directly with
/// per-lane lengths.
#[inline(always)]
pub(crate) fn nearest_image_axis<R: Real>(d: R, length: R, inverse: R) -> (R, R) {
    let n = nearest_integer_lanes(d * inverse);
    (d - length * n, n)
}

/// 1.5 × 2⁵², the shift of [`nearest_integer`].
const ROUND_SHIFT: f64 = 6_755_399_441_055_744.0;
/// 2⁵¹, the clamp of [`nearest_integer`].
const ROUND_LIMIT: f64 = 2_251_799_813_685_248.0;

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
    fn sheared_cell_images_wrap_and_velocities() {
        use crate::dim::D3;
        use glam::DVec3;
        // 2D: L = 10 × 8, tilt xy = 3, shearing at 0.5 per unit time
        let mut d: Domain<D2> = Domain::new(DVec2::ZERO, DVec2::new(10.0, 8.0), [true, true, false]);
        d.tilt = [3.0, 0.0, 0.0];
        d.tilt_rate = [0.5, 0.0, 0.0];
        // j just above the top boundary is, through the image below, near i at the bottom:
        // image of j = x_j − b = (4 − 3, 8.2 − 8) = (1, 0.2)
        let (r, dv) = d.image().displacement_velocity(DVec2::new(1.5, 0.1), DVec2::new(4.0, 8.2));
        assert!((r - DVec2::new(-0.5, 0.1)).length() < 1e-14, "{r:?}");
        assert_eq!(dv, DVec2::new(-0.5, 0.0));
        // crossing the top shifts by −b and slows x by ḃ
        let (mut x, mut v, mut im) = (DVec2::new(4.0, 8.2), DVec2::new(0.1, 1.0), [0; 3]);
        d.wrap_moving(&mut x, &mut v, &mut im);
        assert!((x - DVec2::new(1.0, 0.2)).length() < 1e-14 && im == [0, 1, 0], "{x:?} {im:?}");
        assert!((v - DVec2::new(-0.4, 1.0)).length() < 1e-15);
        assert!((d.unwrapped(x, im) - DVec2::new(4.0, 8.2)).length() < 1e-14);
        // a point left of the tilted face x = xy·y/L_y wraps along x
        let (mut x, mut im) = (DVec2::new(0.5, 4.0), [0; 3]);
        d.wrap(&mut x, &mut im);
        assert!((x - DVec2::new(10.5, 4.0)).length() < 1e-14 && im == [-1, 0, 0], "{x:?}");
        // tilt and tilt − L_x are the same lattice
        let mut e = d.clone();
        e.tilt[0] -= 10.0;
        let a = (DVec2::new(0.3, 7.9), DVec2::new(9.1, 0.2));
        assert!((d.displacement(a.0, a.1) - e.displacement(a.0, a.1)).length() < 1e-12);
        // 3D with all three tilts: every image of a point within the cut-off is found
        let mut d3: Domain<D3> = Domain::new(DVec3::ZERO, DVec3::new(6.0, 7.0, 8.0), [true; 3]);
        d3.tilt = [1.1, -0.7, 0.4];
        let img = d3.image();
        let (a, b) = (DVec3::new(0.2, 6.9, 7.8), DVec3::new(5.9, 0.1, 0.3));
        let r = img.displacement(a, b);
        let mut best = f64::INFINITY;
        for i in -2..=2 {
            for j in -2..=2 {
                for k in -2..=2 {
                    let s = DVec3::new(6.0, 0.0, 0.0) * i as f64 + DVec3::new(1.1, 7.0, 0.0) * j as f64 + DVec3::new(-0.7, 0.4, 8.0) * k as f64;
                    best = best.min((b + s - a).length());
                }
            }
        }
        assert!((r.length() - best).abs() < 1e-12, "{} vs {best}", r.length());
        let h = img.face_widths();
        assert!((h[2] - 8.0).abs() < 1e-12 && h[0] < 6.0 && h[1] < 7.0);
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
        // far outside (a damaged file, a blow-up): one step, inside the cell, the image count
        // moved by the number of periods; before, 1e30 − 10 == 1e30 and the loop never ended
        for (x0, periods) in [(1e30, 1e29), (-1e30, -1e29), (1e300, 1e299), (35.5, 3.0), (-20.5, -3.0)] {
            let mut x = DVec2::new(x0, 1.0);
            let mut im = [0; 3];
            d.wrap(&mut x, &mut im);
            assert!((0.0..10.0).contains(&x.x), "{x0} → {}", x.x);
            let expected = (periods as f64).clamp(i32::MIN as f64, i32::MAX as f64) as i32;
            assert!((im[0] - expected).abs() <= 1, "{x0}: image {} (expected {expected})", im[0]);
        }
        // a period and a half out: the same as two single steps would give (35.5 − 30 = 5.5)
        let mut x = DVec2::new(35.5, 1.0);
        let mut im = [0; 3];
        d.wrap(&mut x, &mut im);
        assert_eq!((x.x, im[0]), (5.5, 3));
        // non-finite positions are left to the blow-up checks, without looping
        let mut x = DVec2::new(f64::INFINITY, 1.0);
        d.wrap(&mut x, &mut [0; 3]);
        assert!(x.x.is_infinite());
    }
}
