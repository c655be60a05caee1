//! Lattice elasticity (SPEC §7.3) against moduli derived by hand.
//!
//! A centred rectangular lattice (horizontal period ℓ₁, row spacing h; a triangular lattice when
//! h = √3 ℓ₁/2) has per cell (area A = ℓ₁ h) one horizontal bond (length ℓ₁, stiffnesses k₁ⁿ, k₁ᵗ)
//! and two oblique bonds (length ℓ₂, angles ±θ from the horizontal, k₂ⁿ, k₂ᵗ). Under an affine
//! strain ε a bond along n̂ = (c, s) stretches by ℓ n̂·ε·n̂ = ℓ(c² ε_xx + s² ε_zz + cs γ) and slides
//! by ℓ t̂·ε·n̂ = ℓ(sc(ε_zz − ε_xx) + (c² − s²)γ/2), t̂ = (−s, c), γ = 2ε_xz. Collecting the energy
//! ½ Σ kⁿ(stretch)² + kᵗ(slide)² = A (½ a ε_xx² + ½ b ε_zz² + c ε_xx ε_zz + ½ C_xzxz γ²), and the
//! half-plane criterion's d is 2 C_xzxz (SPEC §7.3):
//!
//! ```text
//! a = [k₁ⁿ ℓ₁² + 2ℓ₂² c²(k₂ⁿ c² + k₂ᵗ s²)] / A
//! b = 2ℓ₂² s²(k₂ⁿ s² + k₂ᵗ c²) / A
//! c = 2ℓ₂² c² s²(k₂ⁿ − k₂ᵗ) / A
//! d = 2 [k₁ᵗ ℓ₁²/4 + 2ℓ₂²(k₂ⁿ c² s² + k₂ᵗ (c² − s²)²/4)] / A
//! ```
//!
//! (the oblique bonds' cross terms in γ cancel between +θ and −θ). For the triangular lattice
//! (c = ½, s = √3/2, ℓ₁ = ℓ₂ = ℓ) this is, in units of ℓ²/(8A), the paper's a = 8k₁ⁿ + k₂ⁿ + 3k₂ᵗ,
//! b = 9k₂ⁿ + 3k₂ᵗ, c = 3(k₂ⁿ − k₂ᵗ), d = 6k₂ⁿ + 4k₁ᵗ + 2k₂ᵗ. With the horizontal contacts open and
//! β = k₂ᵗ/k₂ⁿ: ab − c(d + c) = 6(β² + 10β − 3), bd = 6(β² + 6β + 9), so
//! r = (β² + 10β − 3)/(β² + 6β + 9), which changes sign at β* = √28 − 5 = 0.29150; with every bond
//! equal the network is isotropic and r = 1.

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
        d: 2.0 * (k1.1 * l1 * l1 / 4.0 + 2.0 * l2 * l2 * (k2.0 * c * c * s * s + k2.1 * (c * c - s * s).powi(2) / 4.0)) / area,
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
    // the same bonds everywhere: isotropic, r = 1 for any kᵗ/kⁿ (with d = C_xzxz it would be
    // (3λ + 4μ)/(λ + 2μ), 7/3 for central springs)
    for x in [0.0, 0.3, 0.8, 1.0] {
        let m = SpringNetwork::triangular(l, (1.0, x), (1.0, x)).moduli();
        assert!((m.r() - 1.0).abs() < 1e-12, "x = {x}: r = {}", m.r());
    }
    // open horizontal contacts: r(β) in closed form
    for beta in [0.0, 0.05, 0.1, 0.2, 0.29, 0.3, 0.5, 0.8, 1.0] {
        let m = SpringNetwork::triangular(l, (0.0, 0.0), (1.0, beta)).moduli();
        let expected = open_horizontal_r(beta);
        assert!((m.r() - expected).abs() < 1e-12, "β = {beta}: r = {} vs {expected}", m.r());
    }
    let root = sign_change(|beta| SpringNetwork::triangular(l, (0.0, 0.0), (3000.0, 3000.0 * beta)).moduli().r());
    assert!((root - BETA_STAR).abs() < 1e-4, "r changes sign at β = {root}, not {BETA_STAR}");
}

/// r = (β² + 10β − 3)/(β² + 6β + 9) of the triangular lattice with open horizontal contacts.
fn open_horizontal_r(beta: f64) -> f64 {
    (beta * beta + 10.0 * beta - 3.0) / (beta * beta + 6.0 * beta + 9.0)
}

/// Root of β² + 10β − 3: √28 − 5.
const BETA_STAR: f64 = 0.291_502_622_129_181_2;

/// The β in (0, 1) where `r` changes sign from negative to positive, by bisection to 1e-9.
fn sign_change(r: impl Fn(f64) -> f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1.0);
    assert!(r(lo) < 0.0 && r(hi) > 0.0, "no sign change in (0, 1): r(0) = {}, r(1) = {}", r(lo), r(hi));
    while hi - lo > 1e-9 {
        let mid = 0.5 * (lo + hi);
        if r(mid) < 0.0 {
            lo = mid
        } else {
            hi = mid
        }
    }
    0.5 * (lo + hi)
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
    // 0.01, soft tangential springs (kᵗ/kⁿ = 0.1, below the crossover 0.2915)
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

/// The two checks of SPEC §7.3 on moduli *measured* from the contact network of lattices built in
/// the engine (every record's kⁿ, kᵗ and branch vector as the engine has them):
///
/// * all contacts closed (every neighbour overlapped by 1e-5 R): isotropic, r = 1;
/// * horizontal contacts open: horizontal period 2R + 1e-6 (a gap of 1e-6), oblique neighbours
///   overlapped by 1e-5, so the oblique bonds are 60° to within ~1e-5 rad; r(β) follows
///   (β² + 10β − 3)/(β² + 6β + 9) and changes sign at 0.2915.
///
/// Tolerances: the geometry departs from the perfect triangle by relative ~1e-5, which moves r by
/// O(1e-5) (measured ≤ 1e-5) and the root by less; r within 1e-4, the root within 1e-4 (the SPEC's
/// precision).
#[test]
fn measured_lattice_network_gives_r_one_when_isotropic_and_the_closed_form_when_horizontals_open() {
    let radius = 1.0;
    let window = |l1: f64, h: f64| NetworkWindow { min: [0.37 * l1, radius + 1.77 * h], max: [8.37 * l1, radius + 7.77 * h] };
    for ratio in [0.2, 0.8, 1.0] {
        let l = 2.0 * radius - 1e-5;
        let h = 3f64.sqrt() / 2.0 * l;
        let net = spring_network(&engine_lattice(10, 12, radius, l, h, ratio).snapshot(), &window(l, h), false);
        assert_eq!(net.bonds.len(), 3 * 8 * 6);
        let r = net.moduli().r();
        assert!((r - 1.0).abs() < 1e-4, "k_t/k_n = {ratio}: measured r = {r}, isotropic network must give 1");
    }
    let l1 = 2.0 * radius + 1e-6;
    let l2: f64 = 2.0 * radius - 1e-5;
    let h = (l2 * l2 - 0.25 * l1 * l1).sqrt();
    let measured_r = |beta: f64| {
        let net = spring_network(&engine_lattice(10, 12, radius, l1, h, beta).snapshot(), &window(l1, h), false);
        assert_eq!(net.bonds.len(), 2 * 8 * 6, "no horizontal bond");
        net.moduli().r()
    };
    for beta in [0.1, 0.25, 0.29, 0.3, 0.5, 0.8] {
        let r = measured_r(beta);
        assert!((r - open_horizontal_r(beta)).abs() < 1e-4, "β = {beta}: measured r = {r} vs {}", open_horizontal_r(beta));
        assert_eq!(r < 0.0, beta < BETA_STAR, "β = {beta}: r = {r}");
    }
    // the engine lattice needs kᵗ > 0: bisect on (0.01, 1)
    let (mut lo, mut hi) = (0.01, 1.0);
    while hi - lo > 1e-6 {
        let mid = 0.5 * (lo + hi);
        if measured_r(mid) < 0.0 {
            lo = mid
        } else {
            hi = mid
        }
    }
    let root = 0.5 * (lo + hi);
    assert!((root - BETA_STAR).abs() < 1e-4, "measured r changes sign at β = {root}, not {BETA_STAR}");
}
