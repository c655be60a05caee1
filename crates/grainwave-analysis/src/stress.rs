//! The contact (virial) stress of a packing (SPEC §4):
//!
//! ```text
//! σ_αβ = −(1/V) Σ_c f_α b_β
//! ```
//!
//! over contacts c (each once), f the force on grain i of the contact and b its branch vector
//! (centre of i → centre of j, nearest periodic image; wall contacts: centre of i → contact point).
//! This is the SPEC's (1/V) Σ F_ij r_ij with the sign turned so that **compressive stresses are
//! positive**. V is the caller's choice (area in 2D, or area × mean diameter for a "3D pressure").
//!
//! ```
//! use grainwave_analysis::stress::principal_2d;
//! let (s1, s2, angle) = principal_2d([[3.0, 1.0], [1.0, 3.0]]);
//! assert!((s1 - 4.0).abs() < 1e-12 && (s2 - 2.0).abs() < 1e-12);
//! assert!((angle - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
//! ```

use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::snapshot::{ContactRecord, Counterpart, Snapshot};

/// σ (d × d, row-major), compression positive, of the contacts of `snapshot` accepted by `keep`,
/// over the volume `volume`.
pub fn contact_stress_filtered<D: Dim>(snapshot: &Snapshot<D>, volume: f64, keep: impl Fn(&ContactRecord<D>) -> bool) -> Vec<f64> {
    let d = D::D;
    let mut s = vec![0.0; d * d];
    for c in snapshot.contacts.iter().filter(|c| keep(c)) {
        let f = c.force_on_i();
        for a in 0..d {
            for b in 0..d {
                s[a * d + b] -= f.get(a) * c.branch.get(b);
            }
        }
    }
    s.iter_mut().for_each(|x| *x /= volume);
    s
}

/// σ of all contacts (grain–grain and grain–wall) over `volume`.
pub fn contact_stress<D: Dim>(snapshot: &Snapshot<D>, volume: f64) -> Vec<f64> {
    contact_stress_filtered(snapshot, volume, |_| true)
}

/// σ of the grain–grain contacts only.
pub fn grain_contact_stress<D: Dim>(snapshot: &Snapshot<D>, volume: f64) -> Vec<f64> {
    contact_stress_filtered(snapshot, volume, |c| matches!(c.j, Counterpart::Grain(_)))
}

/// Principal values (σ₁ ≥ σ₂) of a symmetric 2 × 2 tensor and the angle of the σ₁ direction from
/// the x axis, in (−π/2, π/2].
pub fn principal_2d(s: [[f64; 2]; 2]) -> (f64, f64, f64) {
    let mean = 0.5 * (s[0][0] + s[1][1]);
    let half = 0.5 * (s[0][0] - s[1][1]);
    let shear = 0.5 * (s[0][1] + s[1][0]);
    let radius = (half * half + shear * shear).sqrt();
    let angle = 0.5 * shear.atan2(half);
    (mean + radius, mean - radius, angle)
}
