//! Linear-algebra kernels of the crate, one file per algorithm family (after faer's
//! `linalg/<family>` layout):
//!
//! * [`eigen`] — dense generalized symmetric eigenproblem D v = ω² M v (all modes);
//! * [`lanczos`] — the largest eigenvalue ω²_max of M⁻¹D by Lanczos iteration, with a Gershgorin cap;
//! * [`cg`] — Jacobi-preconditioned conjugate gradient projected off known null vectors;
//! * [`symplectic`] — symplectic splitting integrators (velocity Verlet, a 4th-order
//!   Runge–Kutta–Nyström method) for M ü = −D u.

pub mod cg;
pub mod eigen;
pub mod lanczos;
pub mod symplectic;
