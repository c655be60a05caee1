//! Contact kinematics: the geometry and relative motion that every contact-law part consumes.

use crate::dim::{Dim, VectorOps};
use crate::real::{dot, from_lanes, to_lanes, Real, Vec3};

/// Geometry and relative motion of one contact (grain i with grain j, or grain i with a wall).
///
/// The contact point sits in the middle of the overlap: its distance from the centre of i is the
/// lever arm `lever_i` = R_i − ξ/2 (wall: R_i − ξ, the distance to the wall plane), so that rigid
/// motions of a pair produce no tangential displacement. Torques use the same lever arms.
#[derive(Clone, Copy, Debug)]
pub struct Kinematics<D: Dim> {
    /// Unit normal n̂ from i towards j (towards the wall for wall contacts).
    pub normal: D::Vector,
    /// Overlap ξ > 0.
    pub overlap: f64,
    /// R* = (1/R_i + 1/R_j)⁻¹ (wall: R_i).
    pub r_eff: f64,
    /// m* = m_i m_j/(m_i + m_j) (wall: m_i).
    pub m_eff: f64,
    /// Distance from the centre of i to the contact point.
    pub lever_i: f64,
    /// Distance from the centre of j to the contact point (0 for walls).
    pub lever_j: f64,
    /// Relative normal velocity (v_j − v_i)·n̂ at the contact point: negative while approaching.
    pub v_n: f64,
    /// Tangential velocity of j relative to i at the contact point.
    pub v_t: D::Vector,
    /// Relative rolling angular velocity (ω_j − ω_i) without its twist component.
    pub w_roll: D::AngVector,
    /// Relative twist rate (ω_j − ω_i)·n̂ (0 in 2D).
    pub w_twist: f64,
}

/// Kinematics of grains i and j whose centre-to-centre vector (nearest image) is `r_ij`, or `None`
/// when they do not overlap.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn pair_kinematics<D: Dim>(
    r_ij: D::Vector,
    radius_i: f64,
    radius_j: f64,
    mass_i: f64,
    mass_j: f64,
    vel_i: D::Vector,
    vel_j: D::Vector,
    omega_i: D::AngVector,
    omega_j: D::AngVector,
) -> Option<Kinematics<D>> {
    let dist2 = r_ij.norm2();
    let sum = radius_i + radius_j;
    if dist2 >= sum * sum {
        return None;
    }
    let (w_i, w_j) = (to_lanes(omega_i), to_lanes(omega_j));
    let (r, v_rel) = (to_lanes(r_ij), to_lanes(vel_j - vel_i));
    let k = match D::D {
        2 => pair_kinematics_lanes::<f64, 2, 1>(r, dist2, radius_i, radius_j, v_rel, w_i, w_j),
        _ => pair_kinematics_lanes::<f64, 3, 3>(r, dist2, radius_i, radius_j, v_rel, w_i, w_j),
    };
    let n: D::Vector = from_lanes(k.normal);
    let (overlap, lever_i, lever_j, v_n, v_t) = (k.overlap, k.lever_i, k.lever_j, k.v_n, from_lanes(k.v_t));
    Some(Kinematics {
        normal: n,
        overlap,
        r_eff: k.r_eff,
        m_eff: mass_i * mass_j / (mass_i + mass_j),
        lever_i,
        lever_j,
        v_n,
        v_t,
        w_roll: D::ang_perp(omega_j - omega_i, n),
        w_twist: D::twist(omega_j - omega_i, n),
    })
}

/// Kinematics of a grain at signed distance `distance` from a wall with inward normal
/// `wall_normal` and velocity `wall_vel`, or `None` when it does not touch the wall.
#[inline]
pub fn wall_kinematics<D: Dim>(
    distance: f64,
    wall_normal: D::Vector,
    wall_vel: D::Vector,
    radius: f64,
    mass: f64,
    vel: D::Vector,
    omega: D::AngVector,
) -> Option<Kinematics<D>> {
    let overlap = radius - distance;
    if overlap <= 0.0 {
        return None;
    }
    let n = -wall_normal;
    let lever_i = distance;
    let v_rel = wall_vel - vel;
    let v_n = v_rel.dot(n);
    let v_c = v_rel - D::ang_cross(omega * lever_i, n);
    let v_t = v_c - n * v_c.dot(n);
    Some(Kinematics {
        normal: n,
        overlap,
        r_eff: radius,
        m_eff: mass,
        lever_i,
        lever_j: 0.0,
        v_n,
        v_t,
        w_roll: D::ang_perp(-omega, n),
        w_twist: D::twist(-omega, n),
    })
}

/// The kinematics of one touching pair per lane (the part of [`Kinematics`] that the force law
/// reads; components past the dimension unused).
#[derive(Clone, Copy)]
pub(crate) struct PairLanes<R> {
    /// Unit normal n̂ from i towards j.
    pub normal: Vec3<R>,
    /// Overlap ξ.
    pub overlap: R,
    /// R* = R_i R_j / (R_i + R_j).
    pub r_eff: R,
    /// Lever arms a_i = R_i − ξ/2, a_j = R_j − ξ/2.
    pub lever_i: R,
    pub lever_j: R,
    /// Relative normal velocity (v_j − v_i)·n̂.
    pub v_n: R,
    /// Tangential velocity of j relative to i at the contact point.
    pub v_t: Vec3<R>,
}

/// The kinematics of a touching pair on every lane, from the centre-to-centre vector `r`
/// (nearest image) and its squared length `dist2`, the radii, v_j − v_i and the angular
/// velocities (`ROT` components: 1 in 2D, 3 in 3D): the one implementation behind
/// [`pair_kinematics`] (`f64`) and the engine's vector paths. The contact point sits in the
/// middle of the overlap; its velocity of j relative to i is
/// v_c = v_j − v_i − (a_i ω_i + a_j ω_j) × n̂, and v_t = v_c − (v_c·n̂) n̂.
#[inline(always)]
pub(crate) fn pair_kinematics_lanes<R: Real, const DIM: usize, const ROT: usize>(
    r: Vec3<R>,
    dist2: R,
    rad_i: R,
    rad_j: R,
    v_rel: Vec3<R>,
    w_i: Vec3<R>,
    w_j: Vec3<R>,
) -> PairLanes<R> {
    let zero = R::splat(0.0);
    let sum = rad_i + rad_j;
    let dist = dist2.sqrt();
    let overlap = sum - dist;
    let mut n = [zero; 3];
    for c in 0..DIM {
        n[c] = r[c] / dist;
    }
    let half = R::splat(0.5);
    let lever_i = rad_i - half * overlap;
    let lever_j = rad_j - half * overlap;
    let v_n = dot::<R, DIM>(v_rel, n);
    let mut wsum = [zero; 3];
    for c in 0..ROT {
        wsum[c] = w_i[c] * lever_i + w_j[c] * lever_j;
    }
    let mut v_c = [zero; 3];
    if DIM == 3 {
        // `Dim::ang_cross` in 3D: glam's DVec3::cross(wsum, n)
        v_c[0] = v_rel[0] - (wsum[1] * n[2] - n[1] * wsum[2]);
        v_c[1] = v_rel[1] - (wsum[2] * n[0] - n[2] * wsum[0]);
        v_c[2] = v_rel[2] - (wsum[0] * n[1] - n[0] * wsum[1]);
    } else {
        // `Dim::ang_cross` in 2D: ω ẑ × n = (−ω n_y, ω n_x)
        v_c[0] = v_rel[0] - -wsum[0] * n[1];
        v_c[1] = v_rel[1] - wsum[0] * n[0];
    }
    let vcn = dot::<R, DIM>(v_c, n);
    let mut v_t = [zero; 3];
    for c in 0..DIM {
        v_t[c] = v_c[c] - n[c] * vcn;
    }
    PairLanes { normal: n, overlap, r_eff: rad_i * rad_j / sum, lever_i, lever_j, v_n, v_t }
}

/// Rotates the vector `v` (`N` components) into the plane perpendicular to the unit vector `n`
/// keeping its length, on every lane: p = v − (v·n̂) n̂, scaled by |v|/|p|; `v` itself when it is
/// zero, zero when it is parallel to n̂. The one implementation behind the stored histories'
/// rotation in the general kernel (`f64`) and the engine's vector paths.
#[inline(always)]
pub(crate) fn into_tangent_plane_lanes<R: Real, const N: usize>(v: Vec3<R>, n: Vec3<R>) -> Vec3<R> {
    let zero = R::splat(0.0);
    let len2 = dot::<R, N>(v, v);
    if R::branch_if(len2.eq(zero)) {
        return v;
    }
    let vdn = dot::<R, N>(v, n);
    let mut p = [zero; 3];
    for c in 0..N {
        p[c] = v[c] - n[c] * vdn;
    }
    let p2 = dot::<R, N>(p, p);
    let (p_zero, p_same, len_zero) = (p2.eq(zero), p2.eq(len2), len2.eq(zero));
    if R::branch_if(p_zero) {
        return [zero; 3];
    }
    if R::branch_if(p_same) {
        return p;
    }
    // on one lane, only reached when the rotation changes the length (f64 branches above)
    let scale = (len2 / p2).sqrt();
    let mut out = [zero; 3];
    for c in 0..N {
        let rotated = R::select(p_zero, zero, R::select(p_same, p[c], p[c] * scale));
        out[c] = R::select(len_zero, v[c], rotated);
    }
    out
}
