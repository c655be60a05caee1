//! Contact kinematics: the geometry and relative motion that every contact-law part consumes.

use crate::dim::{Dim, VectorOps};

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
    let dist = dist2.sqrt();
    let overlap = sum - dist;
    let n = r_ij / dist;
    let lever_i = radius_i - 0.5 * overlap;
    let lever_j = radius_j - 0.5 * overlap;
    let v_rel = vel_j - vel_i;
    let v_n = v_rel.dot(n);
    // velocity of j's contact point relative to i's: v_j + ω_j × (−a_j n̂) − v_i − ω_i × (a_i n̂)
    let v_c = v_rel - D::ang_cross(omega_i * lever_i + omega_j * lever_j, n);
    let v_t = v_c - n * v_c.dot(n);
    Some(Kinematics {
        normal: n,
        overlap,
        r_eff: radius_i * radius_j / sum,
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
