//! Shared fixtures of the physics tests.
#![allow(dead_code)]

use glam::{DVec2, DVec3};
use grainwave_core::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Hooke law with the given stiffness, restitution (None: elastic) and friction.
pub fn hooke(k_n: f64, restitution: Option<f64>, friction: f64) -> ContactParams {
    let mut p = ContactParams::preset("hooke_cundall_strack");
    p.normal_stiffness = Some(k_n);
    p.restitution = restitution;
    p.friction = Some(friction);
    p
}

/// Hertz–Mindlin law.
pub fn hertz(young: f64, poisson: f64, friction: f64, zeta: Option<f64>) -> ContactParams {
    let mut p = ContactParams::preset("hertz_mindlin");
    p.young = Some(young);
    p.poisson = Some(poisson);
    p.friction = Some(friction);
    p.damping_fraction = zeta;
    p
}

/// Dense, polydisperse 2D periodic packing: a triangular lattice compressed so that neighbours
/// overlap by a few per cent, radii ±10 %, random velocities of scale `v`.
pub fn dense_2d(rows: usize, cols: usize, law: ContactLaw, v: f64, seed: u64) -> SimulationBuilder<D2> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a = 1.0;
    let lx = cols as f64 * a;
    let ly = rows as f64 * a * 3f64.sqrt() / 2.0;
    let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    for p in grainwave_core::placement::triangular_lattice(rows, cols, a, [0.25, 0.25]) {
        let r = 0.5 * 1.02 * (1.0 + 0.08 * (2.0 * rng.random::<f64>() - 1.0));
        let vel = DVec2::new(v * (2.0 * rng.random::<f64>() - 1.0), v * (2.0 * rng.random::<f64>() - 1.0));
        grains.push(DVec2::new(p[0], p[1]), r, 1.0, vel);
    }
    for w in grains.omega.iter_mut() {
        *w = v * (2.0 * rng.random::<f64>() - 1.0);
    }
    let domain = Domain::new(DVec2::ZERO, DVec2::new(lx, ly), [true, true, false]);
    SimulationBuilder::new(grains, domain, law).max_initial_overlap(0.3).seed(seed)
}

/// Dense, polydisperse 3D periodic packing on a compressed FCC lattice (n³ cubic cells).
pub fn dense_3d(n: usize, law: ContactLaw, v: f64, seed: u64) -> SimulationBuilder<D3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let a = 2f64.sqrt(); // nearest-neighbour distance 1
    let l = n as f64 * a;
    let mut grains = Grains::<D3>::new(GrainKind::Sphere);
    let basis = [[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]];
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                for b in basis {
                    let p = DVec3::new((i as f64 + b[0]) * a + 0.1, (j as f64 + b[1]) * a + 0.1, (k as f64 + b[2]) * a + 0.1);
                    let r = 0.5 * 1.02 * (1.0 + 0.08 * (2.0 * rng.random::<f64>() - 1.0));
                    let vel = DVec3::new(
                        v * (2.0 * rng.random::<f64>() - 1.0),
                        v * (2.0 * rng.random::<f64>() - 1.0),
                        v * (2.0 * rng.random::<f64>() - 1.0),
                    );
                    grains.push(p, r, 1.0, vel);
                }
            }
        }
    }
    let domain = Domain::new(DVec3::ZERO, DVec3::splat(l), [true, true, true]);
    SimulationBuilder::new(grains, domain, law).max_initial_overlap(0.3).seed(seed)
}

/// Total mechanical energy (kinetic + elastic + gravitational).
pub fn total_energy<D: Dim>(sim: &Simulation<D>) -> f64 {
    sim.kinetic_energy() + sim.elastic_energy() + sim.gravitational_energy()
}

/// Relative difference |a − b| / |b|.
pub fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Relaxes a damped dense packing to a jammed state (KE per grain below `ke_tol`), then switches
/// to the elastic law `elastic` and gives every grain a random velocity of scale `v`.
pub fn jam_then_heat<D: Dim>(mut sim: Simulation<D>, elastic: ContactLaw, ke_tol: f64, v: f64, seed: u64) -> Simulation<D> {
    let stop = StopCriteria { kinetic_energy_per_grain: Some(ke_tol), step_limit: Some(200_000), check_every: 50, ..Default::default() };
    let out = sim.run(&stop, &mut |_| Control::Continue).unwrap();
    assert_eq!(out.reason, StopReason::Converged, "packing did not relax: {:?}", out.last);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    sim.law = elastic;
    for k in 0..sim.len() {
        let mut vel = D::Vector::ZERO;
        for c in 0..D::D {
            vel.set(c, v * (2.0 * rng.random::<f64>() - 1.0));
        }
        sim.grains.vel[k] = vel;
    }
    sim.refresh_forces().unwrap();
    sim
}

/// The vector paths of the force pass (`Simulation::set_simd_level`) among `wanted` that this
/// processor has: 0 (portable) always; 1 (the fused AVX2 pass) with AVX2; 2 (the AVX-512 windows)
/// and 3 (the fused pass on 512-bit lanes) with AVX-512 F and VL. A level the processor lacks
/// would silently run the next lower one, so it is left out and
/// `skipped: CPU lacks …` is written to stderr, past the test harness's output capture (so that
/// `cargo test` shows it even when the test passes).
pub fn simd_levels(test: &str, wanted: &[u8]) -> Vec<u8> {
    #[cfg(target_arch = "x86_64")]
    let (avx2, avx512) = (
        std::arch::is_x86_feature_detected!("avx2"),
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl"),
    );
    #[cfg(not(target_arch = "x86_64"))]
    let (avx2, avx512) = (false, false);
    let mut lacking = Vec::new();
    let levels = wanted
        .iter()
        .copied()
        .filter(|&l| {
            let (has, lacks) = match l {
                0 => (true, ""),
                1 => (avx2, "AVX2"),
                _ => (avx512, "AVX-512 F and VL"),
            };
            if !has {
                lacking.push((l, lacks));
            }
            has
        })
        .collect();
    for (l, lacks) in lacking {
        skipped(lacks, &format!("{test}: SIMD level {l} not run"));
    }
    levels
}

/// Writes `skipped: CPU lacks {lacks}: {what}` to stderr past the test harness's capture.
pub fn skipped(lacks: &str, what: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr().lock(), "skipped: CPU lacks {lacks}: {what}");
}

/// What a physics test written once for both dimensions needs to know of its dimension: the
/// grain kind, the dense packing fixture, and a way to pick per-dimension parameters. Run such a
/// test with [`both_dims!`].
pub trait TestDim: Dim {
    /// Disks of unit thickness in 2D, spheres in 3D.
    fn kind() -> GrainKind;
    /// The dense periodic packing: [`dense_2d`]`(rows, cols, …)` with `two = (rows, cols)` in
    /// 2D, [`dense_3d`]`(three, …)` (4 three³ spheres) in 3D.
    fn dense(two: (usize, usize), three: usize, law: ContactLaw, v: f64, seed: u64) -> SimulationBuilder<Self>;
    /// `two` in 2D, `three` in 3D.
    fn pick<T>(two: T, three: T) -> T {
        if Self::D == 2 {
            two
        } else {
            three
        }
    }
}

impl TestDim for D2 {
    fn kind() -> GrainKind {
        GrainKind::Disk { thickness: 1.0 }
    }
    fn dense(two: (usize, usize), _three: usize, law: ContactLaw, v: f64, seed: u64) -> SimulationBuilder<D2> {
        dense_2d(two.0, two.1, law, v, seed)
    }
}

impl TestDim for D3 {
    fn kind() -> GrainKind {
        GrainKind::Sphere
    }
    fn dense(_two: (usize, usize), three: usize, law: ContactLaw, v: f64, seed: u64) -> SimulationBuilder<D3> {
        dense_3d(three, law, v, seed)
    }
}

/// The vector of the first `D` components of `c`.
pub fn vector<D: Dim>(c: [f64; 3]) -> D::Vector {
    let mut v = D::Vector::ZERO;
    for (k, &x) in c.iter().enumerate().take(D::D) {
        v.set(k, x);
    }
    v
}

/// An angular velocity: `c` in 3D, its z component (the rotation in the plane) in 2D.
pub fn spin<D: Dim>(c: [f64; 3]) -> D::AngVector {
    let mut w = D::AngVector::ZERO;
    let len = <D::AngVector as VectorOps>::LEN;
    for k in 0..len {
        w.set(k, c[3 - len + k]);
    }
    w
}

/// A physics test written once, generic over the dimension, run in 2D and in 3D:
///
/// ```ignore
/// both_dims! {
///     /// What the test shows.
///     fn grains_settle_under_gravity<D>() { … D::kind() … D::pick(150, 150) … }
/// }
/// ```
///
/// defines the tests `grains_settle_under_gravity::d2` and `grains_settle_under_gravity::d3`,
/// which run the body with `D = D2` and `D = D3` (`D: TestDim`).
#[allow(unused_macros)]
macro_rules! both_dims {
    ($(#[$meta:meta])* fn $name:ident<$d:ident>() $body:block) => {
        $(#[$meta])*
        mod $name {
            #[allow(unused_imports)]
            use super::*;
            fn body<$d: TestDim>() $body
            #[test]
            fn d2() {
                body::<grainwave_core::dim::D2>()
            }
            #[test]
            fn d3() {
                body::<grainwave_core::dim::D3>()
            }
        }
    };
}
#[allow(unused_imports)]
pub(crate) use both_dims;
