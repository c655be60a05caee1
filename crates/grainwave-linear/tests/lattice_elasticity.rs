//! Lattice elasticity (SPEC §7.3) against moduli derived by hand.
//!
//! A centred rectangular lattice (horizontal period ℓ₁, row spacing h; a triangular lattice when
//! h = √3 ℓ₁/2) has per cell (area A = ℓ₁ h) one horizontal bond (length ℓ₁, stiffnesses k₁ⁿ, k₁ᵗ)
//! and two oblique bonds (length ℓ₂, angles ±θ from the horizontal, k₂ⁿ, k₂ᵗ). Under an affine
//! strain ε a bond along n̂ = (c, s) stretches by ℓ n̂·ε·n̂ = ℓ(c² ε_xx + s² ε_zz + cs γ) and slides
//! by ℓ t̂·ε·n̂ = ℓ(sc(ε_zz − ε_xx) + (c² − s²)γ/2), t̂ = (−s, c), γ = 2ε_xz. Collecting the energy
//! ½ Σ kⁿ(stretch)² + kᵗ(slide)² = A (½ a ε_xx² + ½ b ε_zz² + c ε_xx ε_zz + ½ d γ²):
//!
//! ```text
//! a = [k₁ⁿ ℓ₁² + 2ℓ₂² c²(k₂ⁿ c² + k₂ᵗ s²)] / A
//! b = 2ℓ₂² s²(k₂ⁿ s² + k₂ᵗ c²) / A
//! c = 2ℓ₂² c² s²(k₂ⁿ − k₂ᵗ) / A
//! d = [k₁ᵗ ℓ₁²/4 + 2ℓ₂²(k₂ⁿ c² s² + k₂ᵗ (c² − s²)²/4)] / A
//! ```
//!
//! (the oblique bonds' cross terms in γ cancel between +θ and −θ).

use glam::DVec2;
use grainwave_core::prelude::*;
use grainwave_linear::lattice::{AnisotropicModuli, SpringNetwork};
use grainwave_linear::measured_network::{spring_network, NetworkWindow};

fn hand_moduli(l1: f64, h: f64, k1: (f64, f64), k2: (f64, f64)) -> AnisotropicModuli {
    let l2 = ((0.5 * l1).powi(2) + h * h).sqrt();
    let (c, s) = (0.5 * l1 / l2, h / l2);
    let area = l1 * h;
    AnisotropicModuli {
        a: (k1.0 * l1 * l1 + 2.0 * l2 * l2 * c * c * (k2.0 * c * c + k2.1 * s * s)) / area,
        b: 2.0 * l2 * l2 * s * s * (k2.0 * s * s + k2.1 * c * c) / area,
        c: 2.0 * l2 * l2 * c * c * s * s * (k2.0 - k2.1) / area,
        d: (k1.1 * l1 * l1 / 4.0 + 2.0 * l2 * l2 * (k2.0 * c * c * s * s + k2.1 * (c * c - s * s).powi(2) / 4.0)) / area,
    }
}

fn r_of(m: &AnisotropicModuli) -> f64 {
    (m.a * m.b - m.c * (m.d + m.c)) / (m.b * m.d)
}

fn close(a: &AnisotropicModuli, b: &AnisotropicModuli) {
    // the code sums the same few products in another order: 1e-12 relative is round-off
    let scale = b.a.abs().max(b.b.abs()).max(b.d.abs());
    for (x, y, n) in [(a.a, b.a, "a"), (a.b, b.b, "b"), (a.c, b.c, "c"), (a.d, b.d, "d")] {
        assert!((x - y).abs() <= 1e-12 * scale, "{n}: {x} vs {y}");
    }
}

#[test]
fn triangular_network_moduli_and_r_match_the_hand_derivation() {
    let l = 2.0;
    let h = 3f64.sqrt() / 2.0 * l;
    for (k1, k2) in [((1.0, 0.0), (1.0, 0.0)), ((1.0, 0.8), (1.0, 0.8)), ((0.0, 0.0), (1.0, 0.8)), ((0.3, 0.1), (2.0, 0.5)), ((0.0, 0.0), (1.0, 0.1))] {
        let net = SpringNetwork::triangular(l, k1, k2);
        let m = net.moduli();
        let hand = hand_moduli(l, h, k1, k2);
        close(&m, &hand);
        assert!((m.r() - r_of(&hand)).abs() < 1e-12 * r_of(&hand).abs().max(1.0));
    }
    // central springs everywhere: isotropic, r = (3λ + 4μ)/(λ + 2μ) = 7/3 with λ = μ
    let m = SpringNetwork::triangular(l, (1.0, 0.0), (1.0, 0.0)).moduli();
    assert!((m.r() - 7.0 / 3.0).abs() < 1e-12);
    // without horizontal springs, in units of ℓ²kⁿ/(8A) with x = kᵗ/kⁿ: a = 1 + 3x, b = 9 + 3x,
    // c = 3(1 − x), d = 3 + x, so r ∝ ab − c(d + c) = 3(x² + 18x − 3) changes sign at
    // x = √84 − 9 = 0.1652: stiff tangential springs keep one peak, soft ones give two
    for (x, sign) in [(0.0, -1.0), (0.1, -1.0), (0.16, -1.0), (0.17, 1.0), (0.8, 1.0)] {
        let m = SpringNetwork::triangular(l, (0.0, 0.0), (1.0, x)).moduli();
        let expected = 3.0 * (x * x + 18.0 * x - 3.0) / ((9.0 + 3.0 * x) * (3.0 + x));
        assert!((m.r() - expected).abs() < 1e-12, "x = {x}: r = {} vs {expected}", m.r());
        assert_eq!(m.r().signum(), sign, "x = {x}");
    }
}

/// A Hooke lattice of disks built in the engine: rows `rows` of `columns` disks of radius R,
/// horizontal period `l1` (periodic along x), row spacing `h`, between two walls.
fn engine_lattice(rows: usize, columns: usize, radius: f64, l1: f64, h: f64, ratio: f64) -> Simulation<D2> {
    let mut p = ContactParams::preset("hooke_cundall_strack");
    p.normal_stiffness = Some(1000.0);
    p.tangential_stiffness_ratio = Some(ratio);
    p.friction = Some(1.0);
    let law = p.build(Partner::Grain, "contact").unwrap();
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    for r in 0..rows {
        for c in 0..columns {
            let x = (c as f64 + 0.3 + if r % 2 == 1 { 0.5 } else { 0.0 }) * l1;
            g.push(DVec2::new(x, radius + r as f64 * h), radius, 1.0, DVec2::ZERO);
        }
    }
    let top = 2.0 * radius + (rows - 1) as f64 * h;
    let domain = Domain::new(DVec2::ZERO, DVec2::new(columns as f64 * l1, top), [true, false, false])
        .with_wall(Wall::axis_aligned("bottom", 1, 0.0, true, law))
        .with_wall(Wall::axis_aligned("top", 1, top, false, law));
    SimulationBuilder::new(g, domain, law).max_initial_overlap(0.5).build().unwrap()
}

#[test]
fn measured_network_of_an_engine_lattice_matches_the_hand_derivation() {
    let radius = 1.0;
    // compressed triangular lattice: every neighbour overlaps by 0.01
    let l = 2.0 * radius - 0.01;
    let h = 3f64.sqrt() / 2.0 * l;
    let sim = engine_lattice(10, 12, radius, l, h, 0.8);
    // 8 periods wide, 6 rows high (whole periods of every bond family), away from the walls
    let window = NetworkWindow { min: [0.37 * l, radius + 1.77 * h], max: [8.37 * l, radius + 7.77 * h] };
    let net = spring_network(&sim.snapshot(), &window, false);
    assert_eq!(net.bonds.len(), 3 * 8 * 6, "three bonds per grain");
    let hand = hand_moduli(l, h, (1000.0, 800.0), (1000.0, 800.0));
    close(&net.moduli(), &hand);
    assert!(net.moduli().r() > 0.0);

    // horizontal contacts open: horizontal period 2R + 0.02, oblique bonds still overlapped by
    // 0.01, soft tangential springs (kᵗ/kⁿ = 0.1, below the crossover 0.165)
    let l1 = 2.0 * radius + 0.02;
    let l2: f64 = 2.0 * radius - 0.01;
    let h = (l2 * l2 - 0.25 * l1 * l1).sqrt();
    let sim = engine_lattice(10, 12, radius, l1, h, 0.1);
    let window = NetworkWindow { min: [0.37 * l1, radius + 1.77 * h], max: [8.37 * l1, radius + 7.77 * h] };
    let net = spring_network(&sim.snapshot(), &window, false);
    assert_eq!(net.bonds.len(), 2 * 8 * 6, "no horizontal bond");
    let hand = hand_moduli(l1, h, (0.0, 0.0), (1000.0, 100.0));
    close(&net.moduli(), &hand);
    assert!(net.moduli().r() < 0.0, "opened horizontal contacts make the response double-peaked");
    assert!((net.moduli().r() - r_of(&hand)).abs() < 1e-10);
}
