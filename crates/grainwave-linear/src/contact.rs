//! One contact of the packing, linearized: the quadratic elastic energy of a contact in terms of
//! the displacements and rotations of its grains, and the generalized forces it produces.
//!
//! # Kinematics
//!
//! Contact c joins grain i to grain j (or to a wall) with unit normal n̂ from i towards j, branch
//! vector b (centre of i → centre of j, nearest periodic image; for a wall, centre of i → contact
//! point) and lever arms a_i, a_j (distances from the centres to the contact point; a_j = 0 for a
//! wall). Give each grain a small displacement u and a small rotation θ (2D: a scalar about ẑ, with
//! θ × r = (−θ r_y, θ r_x)). The contact point of j moves, relative to that of i, by
//!
//! ```text
//! Δ = u_j − u_i − (a_i θ_i + a_j θ_j) × n̂            (walls: u_j = 0, or the wall's own displacement)
//! ```
//!
//! exactly the displacement that the engine's tangential law integrates (grainwave-core
//! `pair_kinematics`: v_c = v_j − v_i − (a_i ω_i + a_j ω_j) × n̂). Its normal part Δ·n̂ = −δξ is the
//! opening of the contact, its tangential part Δ_t = Δ − (Δ·n̂) n̂ the sliding.
//!
//! # Energy
//!
//! ```text
//! E_c = ½ k_n (Δ·n̂)² + ½ k_t |Δ_t|²                       normal and tangential springs
//!     − ½ (F_n/|b|) |d − (d·n̂) n̂|²,  d = u_j − u_i        geometric pre-stress (optional, pairs only)
//!     + ½ k_r |(θ_j − θ_i)_⊥|² + ½ k_tw ((θ_j − θ_i)·n̂)²   rolling and twisting springs (when the law has them)
//! ```
//!
//! with k_n = dF_n/dξ and k_t the differential stiffnesses of the contact record. The generalized
//! forces are −∂E_c/∂q: on i the force f + f_p and torque a_i n̂ × f + M, on j the force −f − f_p and
//! torque a_j n̂ × f − M, where f = k_n (Δ·n̂) n̂ + k_t Δ_t (the spring force on i, as in the engine:
//! the normal force on i is −F_n n̂ and ξ decreases by Δ·n̂), f_p = −(F_n/|b|)(d − (d·n̂) n̂), and M
//! the rolling/twisting torque on i. The dynamical matrix is D = Σ_c ∂²E_c/∂q∂q.
//!
//! The pre-stress term is the second-order change of the energy F_n ξ when the pair's axis turns:
//! a transverse relative displacement d_⊥ rotates n̂ by δn̂ = d_⊥/|b| and turns the normal force
//! with it. A flat wall has no such term (its normal does not turn).
//!
//! # Full linearization of the engine's contact law
//!
//! When the snapshot's contacts carry tangential forces F_t (frictional packings) the engine's
//! forces have further first-order terms, which [`crate::dynamical::PreStress::Full`] adds:
//!
//! * the stored tangential force is kept in the tangent plane as n̂ turns (grainwave-core rotates
//!   the history into the new tangent plane): δF_t = −n̂ (F_t·δn̂) on i;
//! * the lever arms change with the overlap, δa = ½ d·n̂ for grain pairs (a = R − ξ/2) and δa = d·n̂
//!   for walls (a = distance to the wall), and the contact point turns with n̂: the torques gain
//!   δa_i n̂ × F_t + a_i δn̂ × F_t on i and δa_j n̂ × F_t + a_j δn̂ × F_t on j;
//! * (3D) stored rolling and twisting torques M turn with n̂: δM = −n̂ (M_⊥·δn̂) + (M·n̂) δn̂.
//!
//! With these terms D is the exact Jacobian of the engine's (incremental, history-dependent) force
//! law at the snapshot, to first order — but no longer symmetric (friction is not conservative), so
//! it serves direct propagation only; modes, static solves and moduli need a symmetric D.
//!
//! # Affine strain
//!
//! Under a homogeneous displacement gradient e applied to the grain centres and to the walls
//! (SPEC §5.3: "walls and periodic lengths moved affinely") the relative displacements gain e·b
//! (pairs: e·r_ij, which also carries the change of periodic lengths; walls: the wall surface at the
//! contact point moves by e·x_c, the grain centre by e·x_i). [`LinearContact::response`] takes this
//! affine part as an argument.

use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::snapshot::Counterpart;
use serde::{Deserialize, Serialize};

/// The other side of a linearized contact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Partner {
    /// Grain at this storage index of the snapshot.
    Grain(usize),
    /// Wall at this index of the snapshot's domain (fixed in the linear problem).
    Wall(u32),
}

/// One contact with its geometry and stiffnesses, ready for assembly.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct LinearContact<D: Dim> {
    /// Storage index of grain i.
    pub i: usize,
    /// Grain j or wall.
    pub j: Partner,
    /// Unit normal n̂ from i towards j (towards the wall).
    pub normal: D::Vector,
    /// Branch vector b: centre of i → centre of j (nearest image), or → contact point on the wall.
    pub branch: D::Vector,
    /// Lever arm a_i (centre of i → contact point).
    pub lever_i: f64,
    /// Lever arm a_j (0 for walls).
    pub lever_j: f64,
    /// Normal stiffness k_n = dF_n/dξ (force/length).
    pub normal_stiffness: f64,
    /// Tangential stiffness k_t (force/length); 0 when frictionless or (by option) sliding.
    pub tangential_stiffness: f64,
    /// Rolling stiffness k_r (torque/angle), 0 when the law has none or it is excluded.
    pub rolling_stiffness: f64,
    /// Twisting stiffness k_tw (torque/angle, 3D), 0 when absent or excluded.
    pub twisting_stiffness: f64,
    /// Normal force F_n of the snapshot (≥ 0).
    pub normal_force: f64,
    /// Coefficient of the geometric pre-stress term, F_n/|b| (0 when the term is off, and for walls).
    pub prestress: f64,
    /// Tangential force F_t on i in the snapshot (enters only the full linearization).
    pub tangential_force: D::Vector,
    /// Rolling + twisting torque on i in the snapshot (enters only the full linearization).
    pub rolling_torque: D::AngVector,
    /// Include the terms of the full linearization (see the module docs).
    pub full_geometry: bool,
    /// The contact was sliding in the snapshot.
    pub sliding: bool,
}

/// Generalized forces −∂E_c/∂q of one contact on its two grains.
#[derive(Clone, Copy, Debug)]
pub struct ContactResponse<D: Dim> {
    /// Force on i.
    pub force_i: D::Vector,
    /// Torque on i.
    pub torque_i: D::AngVector,
    /// Force on j (meaningless for walls).
    pub force_j: D::Vector,
    /// Torque on j (meaningless for walls).
    pub torque_j: D::AngVector,
    /// Spring force on i, f = k_n (Δ·n̂) n̂ + k_t Δ_t (the change of the contact force on i, without
    /// the pre-stress part).
    pub spring_force: D::Vector,
}

impl<D: Dim> LinearContact<D> {
    /// Grain index of j, if j is a grain.
    #[inline]
    pub fn j_grain(&self) -> Option<usize> {
        match self.j {
            Partner::Grain(j) => Some(j),
            Partner::Wall(_) => None,
        }
    }

    /// Counterpart as written in contact records (stable ids).
    pub fn counterpart(&self, ids: &[u32]) -> Counterpart {
        match self.j {
            Partner::Grain(j) => Counterpart::Grain(ids[j]),
            Partner::Wall(w) => Counterpart::Wall(w),
        }
    }

    /// Relative contact-point displacement Δ and relative centre displacement d for grain
    /// displacements/rotations (u_i, θ_i), (u_j, θ_j) and an extra affine relative displacement
    /// `affine` (e·b; zero when no strain is imposed).
    #[inline]
    pub fn relative(
        &self,
        ui: D::Vector,
        ti: D::AngVector,
        uj: D::Vector,
        tj: D::AngVector,
        affine: D::Vector,
    ) -> (D::Vector, D::Vector) {
        let d = uj - ui + affine;
        let delta = d - D::ang_cross(ti * self.lever_i + tj * self.lever_j, self.normal);
        (delta, d)
    }

    /// Generalized forces −∂E_c/∂q (see the module docs).
    #[inline]
    pub fn response(
        &self,
        ui: D::Vector,
        ti: D::AngVector,
        uj: D::Vector,
        tj: D::AngVector,
        affine: D::Vector,
    ) -> ContactResponse<D> {
        let n = self.normal;
        let (delta, d) = self.relative(ui, ti, uj, tj, affine);
        let dn = delta.dot(n);
        let ft = (delta - n * dn) * self.tangential_stiffness;
        let f = n * (self.normal_stiffness * dn) + ft;
        let fp = (d - n * d.dot(n)) * (-self.prestress);
        // n̂ × f = n̂ × f_t: only the tangential part has a moment (exactly zero when frictionless)
        let tq = D::cross(n, ft);
        let th = tj - ti;
        let m = D::ang_perp(th, n) * self.rolling_stiffness + D::about_normal(self.twisting_stiffness * D::twist(th, n), n);
        let mut r = ContactResponse {
            force_i: f + fp,
            torque_i: tq * self.lever_i + m,
            force_j: -(f + fp),
            torque_j: tq * self.lever_j - m,
            spring_force: f,
        };
        if self.full_geometry {
            let ftan = self.tangential_force;
            let opening = d.dot(n);
            let (dn, da_i, da_j) = match self.j {
                Partner::Grain(_) => ((d - n * opening) / self.branch.norm(), 0.5 * opening, 0.5 * opening),
                Partner::Wall(_) => (D::Vector::ZERO, opening, 0.0),
            };
            let df = n * (-ftan.dot(dn));
            let nxf = D::cross(n, ftan);
            let dnxf = D::cross(dn, ftan);
            let mt = self.rolling_torque;
            let dm = D::about_normal(-D::twist(D::ang_perp(mt, n), dn), n) + D::about_normal(D::twist(mt, n), dn);
            r.force_i += df;
            r.force_j -= df;
            r.torque_i += nxf * da_i + dnxf * self.lever_i + dm;
            r.torque_j += nxf * da_j + dnxf * self.lever_j - dm;
        }
        r
    }

    /// Elastic energy E_c (see the module docs) of the given displacements.
    #[inline]
    pub fn energy(&self, ui: D::Vector, ti: D::AngVector, uj: D::Vector, tj: D::AngVector, affine: D::Vector) -> f64 {
        self.bilinear(ui, ti, uj, tj, affine, ui, ti, uj, tj, affine) * 0.5
    }

    /// The symmetric bilinear form B(x, y) with E_c(x) = ½ B(x, x).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn bilinear(
        &self,
        ui: D::Vector,
        ti: D::AngVector,
        uj: D::Vector,
        tj: D::AngVector,
        affine: D::Vector,
        vi: D::Vector,
        si: D::AngVector,
        vj: D::Vector,
        sj: D::AngVector,
        affine_v: D::Vector,
    ) -> f64 {
        let n = self.normal;
        let (da, ca) = self.relative(ui, ti, uj, tj, affine);
        let (db, cb) = self.relative(vi, si, vj, sj, affine_v);
        let (an, bn) = (da.dot(n), db.dot(n));
        let mut e = self.normal_stiffness * an * bn + self.tangential_stiffness * (da - n * an).dot(db - n * bn);
        e -= self.prestress * (ca - n * ca.dot(n)).dot(cb - n * cb.dot(n));
        let (tha, thb) = (tj - ti, sj - si);
        e += self.rolling_stiffness * D::ang_perp(tha, n).dot(D::ang_perp(thb, n));
        e += self.twisting_stiffness * D::twist(tha, n) * D::twist(thb, n);
        e
    }
}
