//! Lattice elasticity (SPEC §7.3): affine (long-wavelength) moduli of a periodic spring network
//! and the anisotropic half-plane criterion.
//!
//! A periodic 2D network is described by its unit cell: the cell area A and every bond once, with
//! bond vector r, normal stiffness kⁿ and tangential stiffness kᵗ. Under a homogeneous strain
//! (u_ij = e·r_ij) the energy per cell is
//!
//! ```text
//! E = ½ Σ_bonds kⁿ (r̂·u_ij)² + kᵗ |u_ij − (r̂·u_ij) r̂|²,      E/A = ½ εᵀ C ε   (Voigt)
//! ```
//!
//! With x horizontal and z vertical (the direction of the point force) the four moduli of an
//! orthotropic medium, in the convention of the half-plane criterion (SPEC §7.3), are
//! a = C_xxxx, b = C_zzzz, c = C_xxzz and **d = 2 C_xzxz** (so that σ_xz = d ε_xz; d is twice the
//! shear modulus, not the shear modulus). An anisotropic elastic half-plane loaded by a point force
//! responds with a double-peaked stress profile when
//!
//! ```text
//! r = [ab − c(d + c)] / (bd) < 0.
//! ```
//!
//! Isotropic media (a = b = λ + 2μ, c = λ, d = 2μ) give r = [(λ + 2μ)² − λ(λ + 2μ)]/[2μ(λ + 2μ)] = 1
//! exactly, whatever λ and μ. For the triangular lattice with horizontal bonds (k₁ⁿ, k₁ᵗ) and oblique
//! ones (k₂ⁿ, k₂ᵗ), in units of ℓ²/(8A) = R²/(2A) (ℓ = 2R the spacing):
//! a = 8k₁ⁿ + k₂ⁿ + 3k₂ᵗ, b = 9k₂ⁿ + 3k₂ᵗ, c = 3(k₂ⁿ − k₂ᵗ), d = 6k₂ⁿ + 4k₁ᵗ + 2k₂ᵗ; with the horizontal
//! contacts open and β = k₂ᵗ/k₂ⁿ, r = (β² + 10β − 3)/(β² + 6β + 9), negative for β < √28 − 5 ≈ 0.2915.
//! For any packing
//! the same moduli follow from the affine energy of its contact network:
//! [`crate::moduli::ElasticModuli::affine`] and [`AnisotropicModuli::from_voigt`].
//!
//! ```
//! use grainwave_linear::lattice::SpringNetwork;
//! // central springs k on a triangular lattice: Lamé λ = μ = √3 k/4, d = 2μ, isotropic: r = 1
//! let net = SpringNetwork::triangular(1.0, (1.0, 0.0), (1.0, 0.0));
//! let m = net.moduli();
//! let mu = 3f64.sqrt() / 4.0;
//! assert!((m.a - 3.0 * mu).abs() < 1e-14 && (m.c - mu).abs() < 1e-14 && (m.d - 2.0 * mu).abs() < 1e-14);
//! assert!((m.r() - 1.0).abs() < 1e-14);
//! // without horizontal springs the response becomes double-peaked
//! assert!(SpringNetwork::triangular(1.0, (0.0, 0.0), (1.0, 0.0)).moduli().r() < 0.0);
//! ```

use crate::moduli::voigt_strain;
use serde::{Deserialize, Serialize};

/// One bond of a periodic spring network.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpringBond {
    /// Bond vector r (length units).
    pub vector: [f64; 2],
    /// Normal stiffness kⁿ.
    pub normal_stiffness: f64,
    /// Tangential stiffness kᵗ.
    pub tangential_stiffness: f64,
}

/// A periodic 2D spring network given by its unit cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpringNetwork {
    /// Area of the unit cell.
    pub cell_area: f64,
    /// Every bond of the cell once.
    pub bonds: Vec<SpringBond>,
}

/// The four moduli of an orthotropic 2D medium (x horizontal, z vertical), in the convention of
/// the half-plane criterion (SPEC §7.3): d is **twice** C_xzxz.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AnisotropicModuli {
    /// a = C_xxxx.
    pub a: f64,
    /// b = C_zzzz.
    pub b: f64,
    /// c = C_xxzz.
    pub c: f64,
    /// d = 2 C_xzxz (σ_xz = d ε_xz).
    pub d: f64,
}

impl AnisotropicModuli {
    /// r = [ab − c(d + c)]/(bd).
    pub fn r(&self) -> f64 {
        (self.a * self.b - self.c * (self.d + self.c)) / (self.b * self.d)
    }

    /// True when the half-plane response to a point force is double-peaked (r < 0).
    pub fn double_peaked(&self) -> bool {
        self.r() < 0.0
    }

    /// From a Voigt matrix with engineering shear strains (its shear diagonal entry is C_xzxz):
    /// 3 × 3 (2D: [xx, zz, xz], z = y) or 6 × 6 (3D: x and z = axes 0 and 2, xz = entry 4).
    /// d = 2 × the shear entry.
    pub fn from_voigt(c: &[Vec<f64>]) -> Self {
        if c.len() == 3 {
            AnisotropicModuli { a: c[0][0], b: c[1][1], c: c[0][1], d: 2.0 * c[2][2] }
        } else {
            AnisotropicModuli { a: c[0][0], b: c[2][2], c: c[0][2], d: 2.0 * c[4][4] }
        }
    }
}

impl SpringNetwork {
    /// Triangular lattice of spacing `spacing` with one lattice direction along x: horizontal bonds
    /// (kⁿ, kᵗ) = `horizontal`, the two oblique bonds (±60°) `oblique`. Cell area √3/2 · spacing².
    pub fn triangular(spacing: f64, horizontal: (f64, f64), oblique: (f64, f64)) -> Self {
        let s = spacing;
        let h = 3f64.sqrt() / 2.0 * s;
        let bond = |v: [f64; 2], k: (f64, f64)| SpringBond { vector: v, normal_stiffness: k.0, tangential_stiffness: k.1 };
        SpringNetwork {
            cell_area: h * s,
            bonds: vec![bond([s, 0.0], horizontal), bond([0.5 * s, h], oblique), bond([-0.5 * s, h], oblique)],
        }
    }

    /// Affine Voigt stiffness [xx, zz, xz] (engineering shear).
    pub fn affine_voigt(&self) -> Vec<Vec<f64>> {
        let strains: Vec<Vec<f64>> = (0..3).map(|k| voigt_strain(2, k)).collect();
        let mut c = vec![vec![0.0; 3]; 3];
        for b in &self.bonds {
            let r = b.vector;
            let len = (r[0] * r[0] + r[1] * r[1]).sqrt();
            let n = [r[0] / len, r[1] / len];
            let u: Vec<[f64; 2]> = strains.iter().map(|e| [e[0] * r[0] + e[1] * r[1], e[2] * r[0] + e[3] * r[1]]).collect();
            for k in 0..3 {
                for l in 0..3 {
                    let (uk, ul) = (u[k], u[l]);
                    let (nk, nl) = (uk[0] * n[0] + uk[1] * n[1], ul[0] * n[0] + ul[1] * n[1]);
                    let tk = [uk[0] - nk * n[0], uk[1] - nk * n[1]];
                    let tl = [ul[0] - nl * n[0], ul[1] - nl * n[1]];
                    c[k][l] += b.normal_stiffness * nk * nl + b.tangential_stiffness * (tk[0] * tl[0] + tk[1] * tl[1]);
                }
            }
        }
        for row in c.iter_mut() {
            for x in row.iter_mut() {
                *x /= self.cell_area;
            }
        }
        c
    }

    /// The moduli (a, b, c, d = 2 C_xzxz) of the affine stiffness.
    pub fn moduli(&self) -> AnisotropicModuli {
        AnisotropicModuli::from_voigt(&self.affine_voigt())
    }
}
