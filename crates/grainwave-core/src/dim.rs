//! Dimension abstraction: one engine for 2D and 3D.
//!
//! [`Dim`] carries the translational vector type ([`Dim::Vector`], `DVec2`/`DVec3`), the angular
//! vector type ([`Dim::AngVector`], a scalar `f64` about ẑ in 2D, a `DVec3` in 3D), and the
//! orientation type. Engine code is generic over `D: Dim`; the binary dispatches once at the top.

use glam::{DQuat, DVec2, DVec3};
use serde::{de::DeserializeOwned, Serialize};
use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// Operations shared by translational and angular vectors.
pub trait VectorOps:
    Copy
    + Clone
    + Debug
    + Default
    + PartialEq
    + Send
    + Sync
    + Serialize
    + DeserializeOwned
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign<f64>
    + 'static
{
    /// The zero vector.
    const ZERO: Self;
    /// Number of components.
    const LEN: usize;
    /// Euclidean dot product.
    fn dot(self, other: Self) -> f64;
    /// Component `k` (0-based).
    fn get(self, k: usize) -> f64;
    /// Sets component `k`.
    fn set(&mut self, k: usize, value: f64);
    /// Squared Euclidean norm.
    #[inline]
    fn norm2(self) -> f64 {
        self.dot(self)
    }
    /// Euclidean norm.
    #[inline]
    fn norm(self) -> f64 {
        self.norm2().sqrt()
    }
    /// True when every component is finite.
    fn is_finite_vec(self) -> bool {
        (0..Self::LEN).all(|k| self.get(k).is_finite())
    }
    /// Components as a 3-array, padded with zeros (for output).
    fn to_array3(self) -> [f64; 3] {
        let mut a = [0.0; 3];
        for (k, slot) in a.iter_mut().enumerate().take(Self::LEN) {
            *slot = self.get(k);
        }
        a
    }
    /// Builds a vector from the first `LEN` entries of `a`.
    fn from_slice(a: &[f64]) -> Self {
        let mut v = Self::ZERO;
        for k in 0..Self::LEN {
            v.set(k, a[k]);
        }
        v
    }
}

impl VectorOps for f64 {
    const ZERO: Self = 0.0;
    const LEN: usize = 1;
    #[inline]
    fn dot(self, other: Self) -> f64 {
        self * other
    }
    #[inline]
    fn get(self, _k: usize) -> f64 {
        self
    }
    #[inline]
    fn set(&mut self, _k: usize, value: f64) {
        *self = value;
    }
}

impl VectorOps for DVec2 {
    const ZERO: Self = DVec2::ZERO;
    const LEN: usize = 2;
    #[inline]
    fn dot(self, other: Self) -> f64 {
        self.x * other.x + self.y * other.y
    }
    #[inline]
    fn get(self, k: usize) -> f64 {
        self[k]
    }
    #[inline]
    fn set(&mut self, k: usize, value: f64) {
        self[k] = value;
    }
}

impl VectorOps for DVec3 {
    const ZERO: Self = DVec3::ZERO;
    const LEN: usize = 3;
    #[inline]
    fn dot(self, other: Self) -> f64 {
        self.x * other.x + self.y * other.y + self.z * other.z
    }
    #[inline]
    fn get(self, k: usize) -> f64 {
        self[k]
    }
    #[inline]
    fn set(&mut self, k: usize, value: f64) {
        self[k] = value;
    }
}

/// A spatial dimension (2 or 3) and its vector algebra.
pub trait Dim: Copy + Clone + Debug + Default + Send + Sync + PartialEq + 'static {
    /// Number of translational degrees of freedom per grain.
    const D: usize;
    /// Number of rotational degrees of freedom per grain (1 in 2D, 3 in 3D).
    const ROT: usize;
    /// Short name ("2d" / "3d").
    const NAME: &'static str;
    /// Position, velocity and force vectors.
    type Vector: VectorOps;
    /// Angular velocities, torques and small rotations: `f64` about ẑ in 2D, a vector in 3D.
    type AngVector: VectorOps;
    /// Orientation of a grain: an angle about ẑ in 2D, a unit quaternion in 3D.
    type Orientation: Copy + Clone + Debug + PartialEq + Send + Sync + Serialize + DeserializeOwned + 'static;

    /// ω × r: the velocity of a point at offset `r` on a body spinning with `w`.
    fn ang_cross(w: Self::AngVector, r: Self::Vector) -> Self::Vector;
    /// a × b: the torque of force `b` applied at lever `a`.
    fn cross(a: Self::Vector, b: Self::Vector) -> Self::AngVector;
    /// Component of an angular vector perpendicular to the contact normal `n`
    /// (in 2D every angular vector is perpendicular to the plane and returned unchanged).
    fn ang_perp(w: Self::AngVector, n: Self::Vector) -> Self::AngVector;
    /// Component of an angular vector along the contact normal `n` (twist rate); 0 in 2D,
    /// where rotations are about ẑ and normals lie in the plane.
    fn twist(w: Self::AngVector, n: Self::Vector) -> f64;
    /// The angular vector `m n̂` (a torque about the normal); zero in 2D.
    fn about_normal(m: f64, n: Self::Vector) -> Self::AngVector;
    /// The identity orientation.
    fn identity_orientation() -> Self::Orientation;
    /// Advances an orientation by the rotation `w dt` (exact exponential map in 3D).
    fn rotate_orientation(o: Self::Orientation, w: Self::AngVector, dt: f64) -> Self::Orientation;
    /// [`Dim::rotate_orientation`] of every `o[k]` by `w[k] dt` (the shorter length), bitwise the
    /// same; in 3D several grains at a time.
    #[inline]
    fn rotate_orientations(o: &mut [Self::Orientation], w: &[Self::AngVector], dt: f64) {
        for (o, w) in o.iter_mut().zip(w) {
            *o = Self::rotate_orientation(*o, *w, dt);
        }
    }
    /// The orientation as a rotation vector (axis × angle; 2D: angle about ẑ in `[2]`).
    fn orientation_rotation_vector(o: Self::Orientation) -> [f64; 3];
    /// Unit vector along axis `k`.
    fn unit(k: usize) -> Self::Vector {
        let mut v = Self::Vector::ZERO;
        v.set(k, 1.0);
        v
    }

    /// One time step of `sim` ([`crate::sim::Simulation::step`]). With
    /// [`Dim::engine_refresh_forces`], the entry points of the engine's heavy code — the force
    /// pass and its vector kernels, the neighbor list, the integration passes — are functions of
    /// the implementations for [`D2`] and [`D3`], which are not generic: they are compiled once,
    /// in this crate, instead of again in every crate that steps a simulation (a generic
    /// function is compiled in each crate that instantiates it). Call `Simulation::step`.
    #[doc(hidden)]
    fn engine_step(sim: &mut crate::sim::Simulation<Self>) -> crate::Result<()>;
    /// The force evaluation of [`crate::sim::Simulation::refresh_forces`]
    /// ([`Dim::engine_step`] says why it is here). Call `Simulation::refresh_forces`.
    #[doc(hidden)]
    fn engine_refresh_forces(sim: &mut crate::sim::Simulation<Self>) -> crate::Result<()>;
}

/// Two dimensions: grains move in the x–y plane and rotate about ẑ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct D2;

/// Three dimensions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct D3;

impl Dim for D2 {
    const D: usize = 2;
    const ROT: usize = 1;
    const NAME: &'static str = "2d";
    type Vector = DVec2;
    type AngVector = f64;
    type Orientation = f64;

    #[inline]
    fn ang_cross(w: f64, r: DVec2) -> DVec2 {
        DVec2::new(-w * r.y, w * r.x)
    }
    #[inline]
    fn cross(a: DVec2, b: DVec2) -> f64 {
        a.x * b.y - a.y * b.x
    }
    #[inline]
    fn ang_perp(w: f64, _n: DVec2) -> f64 {
        w
    }
    #[inline]
    fn twist(_w: f64, _n: DVec2) -> f64 {
        0.0
    }
    #[inline]
    fn about_normal(_m: f64, _n: DVec2) -> f64 {
        0.0
    }
    fn identity_orientation() -> f64 {
        0.0
    }
    #[inline]
    fn rotate_orientation(o: f64, w: f64, dt: f64) -> f64 {
        o + w * dt
    }
    fn orientation_rotation_vector(o: f64) -> [f64; 3] {
        [0.0, 0.0, o]
    }
    #[inline(never)]
    fn engine_step(sim: &mut crate::sim::Simulation<Self>) -> crate::Result<()> {
        sim.step_here()
    }
    #[inline(never)]
    fn engine_refresh_forces(sim: &mut crate::sim::Simulation<Self>) -> crate::Result<()> {
        sim.refresh_forces_here()
    }
}

impl Dim for D3 {
    const D: usize = 3;
    const ROT: usize = 3;
    const NAME: &'static str = "3d";
    type Vector = DVec3;
    type AngVector = DVec3;
    type Orientation = DQuat;

    #[inline]
    fn ang_cross(w: DVec3, r: DVec3) -> DVec3 {
        w.cross(r)
    }
    #[inline]
    fn cross(a: DVec3, b: DVec3) -> DVec3 {
        a.cross(b)
    }
    #[inline]
    fn ang_perp(w: DVec3, n: DVec3) -> DVec3 {
        w - n * w.dot(n)
    }
    #[inline]
    fn twist(w: DVec3, n: DVec3) -> f64 {
        w.dot(n)
    }
    #[inline]
    fn about_normal(m: f64, n: DVec3) -> DVec3 {
        n * m
    }
    fn identity_orientation() -> DQuat {
        DQuat::IDENTITY
    }
    fn rotate_orientation(o: DQuat, w: DVec3, dt: f64) -> DQuat {
        let v = w * dt;
        let theta2 = v.length_squared();
        if theta2 == 0.0 {
            return o;
        }
        // The rotation by the vector v = ω dt is the quaternion (sin(θ/2) v/θ, cos(θ/2)), θ = |v|.
        // For the small angles of a time step, series in x² = θ²/4 (Horner form, multiplications
        // only: no square root, division or library call) are exact to rounding: for x² < 1e-2
        // the first omitted terms, x¹²/12! and x¹⁰/11!, are below 1e-20.
        let x2 = 0.25 * theta2;
        let r = if x2 < 1e-2 {
            const S: [f64; 6] = [1.0, 1.0 / 6.0, 1.0 / 120.0, 1.0 / 5040.0, 1.0 / 362_880.0, 1.0 / 39_916_800.0];
            const C: [f64; 6] = [1.0, 1.0 / 2.0, 1.0 / 24.0, 1.0 / 720.0, 1.0 / 40_320.0, 1.0 / 3_628_800.0];
            let sinc = S[0] - x2 * (S[1] - x2 * (S[2] - x2 * (S[3] - x2 * (S[4] - x2 * S[5]))));
            let cos = C[0] - x2 * (C[1] - x2 * (C[2] - x2 * (C[3] - x2 * (C[4] - x2 * C[5]))));
            let a = v * (0.5 * sinc);
            DQuat::from_xyzw(a.x, a.y, a.z, cos)
        } else {
            DQuat::from_scaled_axis(v)
        };
        // Renormalise with one Newton step for 1/|q| (|q| differs from 1 by rounding only).
        let q = r * o;
        q * (1.5 - 0.5 * q.length_squared())
    }

    fn orientation_rotation_vector(o: DQuat) -> [f64; 3] {
        o.to_scaled_axis().to_array()
    }

    fn rotate_orientations(o: &mut [DQuat], w: &[DVec3], dt: f64) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl") {
                // SAFETY: the processor supports AVX-512 F and VL.
                unsafe { rotate_lanes_avx512(o, w, dt) };
                return;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the processor supports AVX2.
                unsafe { rotate_lanes_avx2(o, w, dt) };
                return;
            }
        }
        rotate_lanes(o, w, dt);
    }
    #[inline(never)]
    fn engine_step(sim: &mut crate::sim::Simulation<Self>) -> crate::Result<()> {
        sim.step_here()
    }
    #[inline(never)]
    fn engine_refresh_forces(sim: &mut crate::sim::Simulation<Self>) -> crate::Result<()> {
        sim.refresh_forces_here()
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn rotate_lanes_avx2(o: &mut [DQuat], w: &[DVec3], dt: f64) {
    rotate_lanes(o, w, dt);
}

/// [`rotate_lanes`] with AVX-512 intrinsics: eight grains at a time, their quaternions and spins
/// loaded as whole rows and transposed in registers (the compiler's version of [`rotate_lanes`]
/// goes through stack arrays whose element-wise stores cannot be forwarded to the vector loads
/// that follow). Exactly the operations of [`rotate_lanes`] in the same order (so the same bits);
/// lanes outside the series' range (or not finite) are redone by the scalar function.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl")]
unsafe fn rotate_lanes_avx512(o: &mut [DQuat], w: &[DVec3], dt: f64) {
    use crate::simd512::{deinterleave3, idx};
    use std::arch::x86_64::*;
    const S: [f64; 6] = [1.0, 1.0 / 6.0, 1.0 / 120.0, 1.0 / 5040.0, 1.0 / 362_880.0, 1.0 / 39_916_800.0];
    const C: [f64; 6] = [1.0, 1.0 / 2.0, 1.0 / 24.0, 1.0 / 720.0, 1.0 / 40_320.0, 1.0 / 3_628_800.0];
    let n = o.len().min(w.len());
    let split = n - n % 8;
    // SAFETY: AVX-512 F and VL are enabled here; every load and store stays inside o[k..k + 8]
    // and w[k..k + 8] (DQuat is four f64, DVec3 three).
    unsafe {
        // (x, y, z, w) of two rows each ⇄ one component of four rows, and halves joined
        let (even, odd) = (idx([0, 4, 8, 12, 1, 5, 9, 13]), idx([2, 6, 10, 14, 3, 7, 11, 15]));
        let (lo, hi) = (idx([0, 1, 2, 3, 8, 9, 10, 11]), idx([4, 5, 6, 7, 12, 13, 14, 15]));
        let c = _mm512_set1_pd;
        let (add, sub, mul) = (|a, b| _mm512_add_pd(a, b), |a, b| _mm512_sub_pd(a, b), |a, b| _mm512_mul_pd(a, b));
        for k in (0..split).step_by(8) {
            let op = o.as_mut_ptr().add(k) as *mut f64;
            let wp = w.as_ptr().add(k) as *const f64;
            let rows = [_mm512_loadu_pd(op), _mm512_loadu_pd(op.add(8)), _mm512_loadu_pd(op.add(16)), _mm512_loadu_pd(op.add(24))];
            // [x0..x3 y0..y3], [z0..z3 w0..w3], the same for grains 4..7
            let (e0, e1) = (_mm512_permutex2var_pd(rows[0], even, rows[1]), _mm512_permutex2var_pd(rows[0], odd, rows[1]));
            let (f0, f1) = (_mm512_permutex2var_pd(rows[2], even, rows[3]), _mm512_permutex2var_pd(rows[2], odd, rows[3]));
            let (x1, y1) = (_mm512_permutex2var_pd(e0, lo, f0), _mm512_permutex2var_pd(e0, hi, f0));
            let (z1, w1) = (_mm512_permutex2var_pd(e1, lo, f1), _mm512_permutex2var_pd(e1, hi, f1));
            // spins: 24 consecutive f64 de-interleaved
            let (a, b, cc) = (_mm512_loadu_pd(wp), _mm512_loadu_pd(wp.add(8)), _mm512_loadu_pd(wp.add(16)));
            let [wx, wy, wz] = deinterleave3(a, b, cc);
            let (vx, vy, vz) = (mul(wx, c(dt)), mul(wy, c(dt)), mul(wz, c(dt)));
            let theta2 = add(add(mul(vx, vx), mul(vy, vy)), mul(vz, vz));
            let x2 = mul(c(0.25), theta2);
            let series = |k: [f64; 6]| sub(c(k[0]), mul(x2, sub(c(k[1]), mul(x2, sub(c(k[2]), mul(x2, sub(c(k[3]), mul(x2, sub(c(k[4]), mul(x2, c(k[5])))))))))));
            let (sinc, cos) = (series(S), series(C));
            let half = mul(c(0.5), sinc);
            let (x0, y0, z0, w0) = (mul(vx, half), mul(vy, half), mul(vz, half), cos);
            let rx = sub(add(add(mul(w0, x1), mul(x0, w1)), mul(y0, z1)), mul(z0, y1));
            let ry = add(add(sub(mul(w0, y1), mul(x0, z1)), mul(y0, w1)), mul(z0, x1));
            let rz = add(sub(add(mul(w0, z1), mul(x0, y1)), mul(y0, x1)), mul(z0, w1));
            let rw = sub(sub(sub(mul(w0, w1), mul(x0, x1)), mul(y0, y1)), mul(z0, z1));
            let s = sub(c(1.5), mul(c(0.5), add(add(add(mul(rx, rx), mul(ry, ry)), mul(rz, rz)), mul(rw, rw))));
            let keep = _mm512_cmp_pd_mask::<_CMP_EQ_OQ>(theta2, _mm512_setzero_pd());
            let pick = |r, q| _mm512_mask_blend_pd(keep, mul(r, s), q);
            let (ox, oy, oz, ow) = (pick(rx, x1), pick(ry, y1), pick(rz, z1), pick(rw, w1));
            // lanes for the scalar function: !(x² < 1e-2), NaN included
            let scalar = _mm512_cmp_pd_mask::<_CMP_NLT_UQ>(x2, c(1e-2));
            let orig: [DQuat; 8] = if scalar != 0 { std::array::from_fn(|l| o[k + l]) } else { [DQuat::IDENTITY; 8] };
            let (e0, f0) = (_mm512_permutex2var_pd(ox, lo, oy), _mm512_permutex2var_pd(ox, hi, oy));
            let (e1, f1) = (_mm512_permutex2var_pd(oz, lo, ow), _mm512_permutex2var_pd(oz, hi, ow));
            _mm512_storeu_pd(op, _mm512_permutex2var_pd(e0, even, e1));
            _mm512_storeu_pd(op.add(8), _mm512_permutex2var_pd(e0, odd, e1));
            _mm512_storeu_pd(op.add(16), _mm512_permutex2var_pd(f0, even, f1));
            _mm512_storeu_pd(op.add(24), _mm512_permutex2var_pd(f0, odd, f1));
            let mut bits = scalar;
            while bits != 0 {
                let l = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                o[k + l] = D3::rotate_orientation(orig[l], w[k + l], dt);
            }
        }
    }
    for k in split..n {
        o[k] = D3::rotate_orientation(o[k], w[k], dt);
    }
}

/// [`D3::rotate_orientation`] for [`ROT_LANES`] grains at a time: the series branch as one
/// branch-free loop over the lanes (the compiler vectorizes it), exactly the operations of the
/// scalar function in the same order (so the same bits); lanes outside the series' range (or not
/// finite) are redone by the scalar function.
#[inline(always)]
fn rotate_lanes(o: &mut [DQuat], w: &[DVec3], dt: f64) {
    const L: usize = ROT_LANES;
    const S: [f64; 6] = [1.0, 1.0 / 6.0, 1.0 / 120.0, 1.0 / 5040.0, 1.0 / 362_880.0, 1.0 / 39_916_800.0];
    const C: [f64; 6] = [1.0, 1.0 / 2.0, 1.0 / 24.0, 1.0 / 720.0, 1.0 / 40_320.0, 1.0 / 3_628_800.0];
    let n = o.len().min(w.len());
    let (o, w) = (&mut o[..n], &w[..n]);
    let split = n - n % L;
    let (o_lanes, o_rest) = o.split_at_mut(split);
    let (w_lanes, w_rest) = w.split_at(split);
    for (oq, wq) in o_lanes.chunks_exact_mut(L).zip(w_lanes.chunks_exact(L)) {
        let (mut v, mut q) = ([[0.0; L]; 3], [[0.0; L]; 4]);
        for l in 0..L {
            let vl = wq[l] * dt;
            (v[0][l], v[1][l], v[2][l]) = (vl.x, vl.y, vl.z);
            (q[0][l], q[1][l], q[2][l], q[3][l]) = (oq[l].x, oq[l].y, oq[l].z, oq[l].w);
        }
        let mut out = [[0.0; L]; 4];
        let mut scalar = [false; L];
        for l in 0..L {
            let (vx, vy, vz) = (v[0][l], v[1][l], v[2][l]);
            let theta2 = vx * vx + vy * vy + vz * vz;
            let x2 = 0.25 * theta2;
            let sinc = S[0] - x2 * (S[1] - x2 * (S[2] - x2 * (S[3] - x2 * (S[4] - x2 * S[5]))));
            let cos = C[0] - x2 * (C[1] - x2 * (C[2] - x2 * (C[3] - x2 * (C[4] - x2 * C[5]))));
            let half = 0.5 * sinc;
            let (x0, y0, z0, w0) = (vx * half, vy * half, vz * half, cos);
            let (x1, y1, z1, w1) = (q[0][l], q[1][l], q[2][l], q[3][l]);
            // glam's DQuat product r * o
            let rx = w0 * x1 + x0 * w1 + y0 * z1 - z0 * y1;
            let ry = w0 * y1 - x0 * z1 + y0 * w1 + z0 * x1;
            let rz = w0 * z1 + x0 * y1 - y0 * x1 + z0 * w1;
            let rw = w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1;
            let s = 1.5 - 0.5 * (rx * rx + ry * ry + rz * rz + rw * rw);
            let keep = theta2 == 0.0;
            out[0][l] = if keep { x1 } else { rx * s };
            out[1][l] = if keep { y1 } else { ry * s };
            out[2][l] = if keep { z1 } else { rz * s };
            out[3][l] = if keep { w1 } else { rw * s };
            scalar[l] = !(x2 < 1e-2);
        }
        for l in 0..L {
            oq[l] = if scalar[l] { D3::rotate_orientation(oq[l], wq[l], dt) } else { DQuat::from_xyzw(out[0][l], out[1][l], out[2][l], out[3][l]) };
        }
    }
    for (oq, wq) in o_rest.iter_mut().zip(w_rest) {
        *oq = D3::rotate_orientation(*oq, *wq, dt);
    }
}

/// Grains per batch of [`D3::rotate_orientations`].
const ROT_LANES: usize = 8;

/// The dimension of a run, known at run time.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
pub enum Dimension {
    /// Two dimensions.
    Two,
    /// Three dimensions.
    Three,
}

impl Dimension {
    /// 2 or 3.
    pub fn value(self) -> usize {
        match self {
            Dimension::Two => 2,
            Dimension::Three => 3,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_products_are_consistent_between_dimensions() {
        // In 2D, ω ẑ × r must equal the 3D cross product restricted to the plane.
        let w = 0.7;
        let r = DVec2::new(0.3, -1.2);
        let v2 = D2::ang_cross(w, r);
        let v3 = D3::ang_cross(DVec3::new(0.0, 0.0, w), DVec3::new(r.x, r.y, 0.0));
        assert_eq!(v2, DVec2::new(v3.x, v3.y));
        let f = DVec2::new(2.0, 0.5);
        let t3 = D3::cross(DVec3::new(r.x, r.y, 0.0), DVec3::new(f.x, f.y, 0.0));
        assert_eq!(D2::cross(r, f), t3.z);
    }

    #[test]
    fn small_rotations_match_the_exponential_map() {
        // the series branch against glam's sin/cos, for angles across its range and just beyond
        for &angle in &[1e-9, 1e-5, 1e-3, 0.05, 0.15, 0.199, 0.2001, 0.5] {
            for axis in [DVec3::X, DVec3::new(0.3, -0.5, 0.8).normalize()] {
                let o = DQuat::from_scaled_axis(DVec3::new(0.1, 0.2, -0.3));
                let series = D3::rotate_orientation(o, axis * angle / 0.01, 0.01);
                let exact = (DQuat::from_scaled_axis(axis * angle) * o).normalize();
                let diff = (series - exact).length();
                assert!(diff < 4e-16, "angle {angle}: {diff:e}");
            }
        }
    }

    #[test]
    fn batched_rotations_are_bitwise_the_scalar_ones() {
        // zero, tiny, typical, series limit, beyond it, huge and non-finite rates; lengths that
        // leave a remainder
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let mut w: Vec<DVec3> = (0..203).map(|k| DVec3::new(rnd(), rnd(), rnd()) * [1e-3, 1.0, 30.0, 400.0][k % 4]).collect();
        w[5] = DVec3::ZERO;
        w[17] = DVec3::new(0.0, -0.0, 0.0);
        w[33] = DVec3::new(f64::NAN, 0.0, 1.0);
        w[40] = DVec3::new(1e300, 0.0, 0.0);
        w[41] = DVec3::new(199.99, 0.0, 0.0);
        w[42] = DVec3::new(200.0, 0.0, 0.0);
        let o: Vec<DQuat> = (0..203).map(|_| DQuat::from_scaled_axis(DVec3::new(rnd(), rnd(), rnd()) * 2.0)).collect();
        for len in [0, 3, 8, 9, 64, 203] {
            let mut batch = o[..len].to_vec();
            D3::rotate_orientations(&mut batch, &w[..len], 1e-3);
            let mut plain = o[..len].to_vec();
            rotate_lanes(&mut plain, &w[..len], 1e-3);
            for k in 0..len {
                let scalar = D3::rotate_orientation(o[k], w[k], 1e-3);
                for (a, b) in [(batch[k], scalar), (plain[k], scalar)] {
                    assert_eq!(a.to_array().map(f64::to_bits), b.to_array().map(f64::to_bits), "grain {k}: {a:?} {b:?}");
                }
            }
        }
    }

    #[test]
    fn quaternion_rotation_matches_rotation_vector() {
        let w = DVec3::new(0.0, 0.0, 2.0);
        let o = D3::rotate_orientation(D3::identity_orientation(), w, 0.25);
        let rv = D3::orientation_rotation_vector(o);
        assert!((rv[2] - 0.5).abs() < 1e-14 && rv[0].abs() < 1e-14);
    }
}
