//! Moduli of lattices (SPEC §5.3, §7.3) against textbook values.
//!
//! A triangular lattice of spacing a with normal springs k_n and tangential springs k_t on every
//! bond is isotropic, with Lamé constants (per unit thickness)
//!
//! ```text
//! λ = √3 (k_n − k_t)/4,     μ = √3 (k_n + k_t)/4       (central springs: λ = μ = √3 k/4)
//! ```
//!
//! (from E/A = ½ Σ_bonds [k_n (n̂·e n̂)² + k_t (|e n̂|² − (n̂·e n̂)²)] a²/A with Σ n̂⁴ over the three bond
//! directions = (3/8)(δδ + δδ + δδ) and A = √3a²/2). In Voigt form C₁₁ = C₂₂ = λ + 2μ, C₁₂ = λ,
//! C₃₃ = μ. A perfect Bravais lattice with equal lever arms has no non-affine relaxation (every grain
//! is a centre of inversion), so the imposed-strain moduli equal the affine ones; tolerance 1e-9
//! relative (the static solver's residual 1e-11 times the condition of the small systems).

use crate::common;
use common::*;
use glam::DVec2;
use grainwave_core::prelude::*;
use grainwave_linear::lattice::{AnisotropicModuli, SpringNetwork};
use grainwave_linear::prelude::*;
use grainwave_linear::reference::TriangularLatticeSpec;

fn lame(k_n: f64, k_t: f64) -> (f64, f64) {
    let s = 3f64.sqrt() / 4.0;
    (s * (k_n - k_t), s * (k_n + k_t))
}

#[test]
fn triangular_spring_network_has_textbook_lame_constants() {
    for (k_n, k_t) in [(1.0, 0.0), (2.0, 0.7), (1.0, 1.0)] {
        let net = SpringNetwork::triangular(1.3, (k_n, k_t), (k_n, k_t));
        let c = net.affine_voigt();
        let (lambda, mu) = lame(k_n, k_t);
        let expected = [[lambda + 2.0 * mu, lambda, 0.0], [lambda, lambda + 2.0 * mu, 0.0], [0.0, 0.0, mu]];
        for i in 0..3 {
            for j in 0..3 {
                assert!((c[i][j] - expected[i][j]).abs() < 1e-14, "k = ({k_n}, {k_t}): C[{i}][{j}] = {} vs {}", c[i][j], expected[i][j]);
            }
        }
        // isotropic half-plane: d = 2μ, r = 1, single-peaked response
        let m = net.moduli();
        assert!((m.d - 2.0 * mu).abs() < 1e-14);
        assert!((m.r() - 1.0).abs() < 1e-13);
        assert!(!m.double_peaked());
    }
}

/// Opening the horizontal contacts (k₁ = 0) of a central-force lattice gives, from the two oblique
/// bonds alone, a = k/(4√3), b = 9k/(4√3), c = 3k/(4√3), d = 2 C_xzxz = 6k/(4√3), hence
/// r = (9 − 3·9)/54 = −1/3: a double-peaked response (SPEC §7.3).
#[test]
fn open_horizontal_contacts_give_a_double_peaked_response() {
    let m = SpringNetwork::triangular(1.0, (0.0, 0.0), (1.0, 0.0)).moduli();
    let u = 1.0 / (4.0 * 3f64.sqrt());
    for (got, want) in [(m.a, u), (m.b, 9.0 * u), (m.c, 3.0 * u), (m.d, 6.0 * u)] {
        assert!((got - want).abs() < 1e-15, "{m:?}");
    }
    assert!((m.r() + 1.0 / 3.0).abs() < 1e-14 && m.double_peaked());
    // r as a function of the horizontal stiffness changes sign in between
    let r_of = |k1: f64| SpringNetwork::triangular(1.0, (k1, 0.0), (1.0, 0.0)).moduli().r();
    assert!(r_of(0.0) < 0.0 && r_of(1.0) > 0.0);
    // d is twice the Voigt shear entry
    let m = AnisotropicModuli::from_voigt(&[vec![1.0, 0.0, 0.0], vec![0.0, 1.0, 0.0], vec![0.0, 0.0, 1.0]]);
    assert_eq!(m.d, 2.0);
}

/// A perfect, periodic triangular packing of equal disks (Hooke contacts, spacing 1): moduli from
/// imposed strain and relaxation = affine moduli = Lamé constants of the network.
fn perfect_lattice(rows: usize, cols: usize, k_n: f64, ratio: f64) -> Snapshot<D2> {
    let params = hooke_params(k_n, ratio.max(1e-300), if ratio > 0.0 { 1e3 } else { 0.0 });
    let law = params.build(Partner::Grain, "contact").unwrap();
    let dy = 3f64.sqrt() / 2.0;
    let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    for p in grainwave_core::placement::triangular_lattice(rows, cols, 1.0, [0.25, 0.5]) {
        grains.push(DVec2::new(p[0], p[1]), 0.51, 1.0, DVec2::ZERO);
    }
    let domain = Domain::new(DVec2::new(0.0, 0.5 - 0.5 * dy), DVec2::new(cols as f64, 0.5 - 0.5 * dy + rows as f64 * dy), [true, true, false]);
    SimulationBuilder::new(grains, domain, law).max_initial_overlap(0.1).build().unwrap().snapshot()
}

#[test]
fn imposed_strain_moduli_equal_affine_moduli_on_a_perfect_lattice() {
    for (k_n, ratio) in [(1.0, 0.0), (1.0, 0.5)] {
        let snap = perfect_lattice(8, 8, k_n, ratio);
        assert_eq!(snap.contacts.len(), 3 * 64, "three bonds per grain");
        let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
        let m = elastic_moduli(&dm, &ModuliOptions::default()).unwrap();
        let (lambda, mu) = lame(k_n, ratio * k_n);
        let expected = [[lambda + 2.0 * mu, lambda, 0.0], [lambda, lambda + 2.0 * mu, 0.0], [0.0, 0.0, mu]];
        let scale = lambda + 2.0 * mu;
        for i in 0..3 {
            for j in 0..3 {
                assert!((m.voigt[i][j] - expected[i][j]).abs() < 1e-9 * scale, "k_t/k_n = {ratio}: relaxed C[{i}][{j}] = {} vs {}", m.voigt[i][j], expected[i][j]);
                assert!((m.affine[i][j] - expected[i][j]).abs() < 1e-12 * scale, "affine C[{i}][{j}]");
            }
        }
        // continuum speeds of the lattice: ρ = m/A per grain
        let rho = std::f64::consts::PI * 0.51 * 0.51 / (3f64.sqrt() / 2.0);
        assert!((m.density - rho).abs() < 1e-12 * rho);
        assert!((m.longitudinal_speed - ((lambda + 2.0 * mu) / rho).sqrt()).abs() < 1e-9);
        assert!((m.transverse_speed - (mu / rho).sqrt()).abs() < 1e-9);
    }
}

/// Local moduli (SPEC §5.3) of a triangular lattice between two walls, periodic in x (Hooke,
/// k_t = k_n/2, walls with the same springs, 12 columns): the body-force and imposed-line moduli
/// approach the bulk values λ + 2μ (vertical loading) and μ (horizontal) as 1/L₂. The lattice is not
/// homogeneous at its boundaries — the wall springs form a soft layer (one spring k_n per grain
/// over half a row spacing: modulus ≈ 0.43 k_n vs λ + 2μ ≈ 1.5 k_n), and each line of imposed
/// displacements is a stiff layer one grain thick — which shifts the stored energy by O(a/L₂)
/// (measured at 40 rows: −11 % … +13 %). The test checks that the deviation halves from 40 to 80
/// rows (ratio within [1.7, 2.3]: a pure boundary effect) and that the Richardson extrapolation
/// 2 C(80) − C(40) recovers the bulk modulus within 1.5 % (measured ≤ 1.2 %; deterministic input) — which checks the
/// modulus formulas of SPEC §5.3 with their factors n², π² and (n + 1)².
#[test]
fn local_moduli_of_a_lattice_between_walls_approach_the_bulk_moduli() {
    let (cols, k_n, ratio) = (12, 1.0, 0.5);
    let params = hooke_params(k_n, ratio, 1e3);
    let law = params.build(Partner::Grain, "contact").unwrap();
    let wall = params.build(Partner::Wall, "contact.wall").unwrap();
    let dy = 3f64.sqrt() / 2.0;
    let packing = |rows: usize| {
        let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        for p in grainwave_core::placement::triangular_lattice(rows, cols, 1.0, [0.25, 0.5]) {
            grains.push(DVec2::new(p[0], p[1]), 0.51, 1.0, DVec2::ZERO);
        }
        // walls half a row spacing beyond the outer rows: every outer-row grain touches its wall
        let (bottom, top) = (0.5 - 0.5 * dy, 0.5 + (rows as f64 - 0.5) * dy);
        let domain = Domain::new(DVec2::new(0.0, bottom), DVec2::new(cols as f64, top), [true, false, false])
            .with_wall(Wall::axis_aligned("bottom", 1, bottom, true, wall))
            .with_wall(Wall::axis_aligned("top", 1, top, false, wall));
        let snap = SimulationBuilder::new(grains, domain, law).max_initial_overlap(0.2).build().unwrap().snapshot();
        DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap()
    };
    let (short, tall) = (packing(40), packing(80));
    let (lambda, mu) = lame(k_n, ratio * k_n);
    let opts = ModuliOptions::default();
    for (axis, bulk) in [(1, lambda + 2.0 * mu), (0, mu)] {
        for loading in [LocalLoading::BodyForce { n: 1 }, LocalLoading::BodyForce { n: 2 }, LocalLoading::ImposedLines { n: 1, fix_transverse: true }, LocalLoading::ImposedLines { n: 3, fix_transverse: true }] {
            let c40 = local_modulus(&short, axis, &loading, &opts).unwrap().modulus;
            let c80 = local_modulus(&tall, axis, &loading, &opts).unwrap().modulus;
            let (d40, d80) = (c40 / bulk - 1.0, c80 / bulk - 1.0);
            let extrapolated = (2.0 * c80 - c40) / bulk - 1.0;
            eprintln!("axis {axis}, {loading:?}: C/bulk − 1 = {d40:+.4} (40 rows), {d80:+.4} (80 rows), extrapolated {extrapolated:+.4}");
            assert!((1.7..2.3).contains(&(d40 / d80)), "axis {axis}, {loading:?}: deviation does not scale as 1/L₂: {d40} vs {d80}");
            assert!(extrapolated.abs() < 0.015, "axis {axis}, {loading:?}: extrapolated modulus off by {extrapolated}");
        }
    }
}

/// 3D: a perfect periodic FCC packing of equal spheres (nearest-neighbour distance 1, cube side
/// a = √2) with central springs k has the textbook cubic moduli C₁₁ = 2k/a, C₁₂ = C₄₄ = k/a; with
/// tangential springs too, imposed-strain and affine moduli still coincide (cubic symmetry leaves
/// no axial vector linear in a symmetric strain, so the grains do not rotate). Tolerance 1e-9.
#[test]
fn fcc_lattice_has_textbook_cubic_moduli() {
    use glam::DVec3;
    for ratio in [0.0_f64, 0.4] {
        let k = 3.0;
        let params = hooke_params(k, ratio.max(1e-300), if ratio > 0.0 { 1e3 } else { 0.0 });
        let law = params.build(Partner::Grain, "contact").unwrap();
        let a = 2f64.sqrt();
        let n = 2;
        let mut grains = Grains::<D3>::new(GrainKind::Sphere);
        for i in 0..n {
            for j in 0..n {
                for l in 0..n {
                    for b in [[0.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [0.0, 0.5, 0.5]] {
                        grains.push(DVec3::new((i as f64 + b[0]) * a + 0.1, (j as f64 + b[1]) * a + 0.1, (l as f64 + b[2]) * a + 0.1), 0.51, 1.0, DVec3::ZERO);
                    }
                }
            }
        }
        let side = n as f64 * a;
        let domain = Domain::new(DVec3::ZERO, DVec3::splat(side), [true, true, true]);
        let snap = SimulationBuilder::new(grains, domain, law).max_initial_overlap(0.1).build().unwrap().snapshot();
        assert_eq!(snap.contacts.len(), 6 * 32, "12 neighbours per sphere");
        let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
        let m = elastic_moduli(&dm, &ModuliOptions::default()).unwrap();
        let scale = 2.0 * k / a;
        for i in 0..6 {
            for j in 0..6 {
                assert!((m.voigt[i][j] - m.affine[i][j]).abs() < 1e-9 * scale, "k_t/k_n = {ratio}: C[{i}][{j}] relaxed {} vs affine {}", m.voigt[i][j], m.affine[i][j]);
            }
        }
        if ratio == 0.0 {
            for i in 0..6 {
                for j in 0..6 {
                    let expected = match (i, j) {
                        (i, j) if i == j && i < 3 => 2.0 * k / a,
                        (i, j) if i < 3 && j < 3 => k / a,
                        (i, j) if i == j => k / a,
                        _ => 0.0,
                    };
                    assert!((m.voigt[i][j] - expected).abs() < 1e-9 * scale, "C[{i}][{j}] = {} vs {expected}", m.voigt[i][j]);
                }
            }
        }
    }
}

/// The triangular reference lattice of SPEC §5.6 is built in exact equilibrium under its pressure.
#[test]
fn triangular_reference_lattice_is_in_equilibrium() {
    for friction in [0.0, 0.5] {
        let spec = TriangularLatticeSpec { rows: 12, columns: 10, pressure: 1e-4, friction, ..Default::default() };
        let sim = spec.build().unwrap();
        let g = spec.geometry();
        let snap = sim.snapshot();
        let worst = sim.grains.force.iter().map(|f| f.length()).fold(0.0, f64::max);
        eprintln!("friction {friction}: overlap {:.4e}, wall overlap {:.4e}, contact force {:.4e}, max net force {worst:.1e}", g.overlap, g.wall_overlap, g.contact_force);
        assert!(worst < 1e-10 * g.contact_force, "net force {worst:e}");
        let lx = spec.columns as f64 * g.spacing;
        for w in [0, 1] {
            let load = snap.wall_load(w);
            assert!((load / (spec.pressure * lx * spec.diameter) - 1.0).abs() < 1e-12, "wall {w}: load {load}");
        }
        assert_eq!(snap.contacts.len(), 3 * spec.columns * spec.rows, "c·r horizontal + 2c(r − 1) oblique bonds + 2c wall contacts");
    }
    // polydisperse: placed without overlap, the top wall a piston under p L_x d̄
    let spec = TriangularLatticeSpec { rows: 6, columns: 8, polydispersity: 0.2, piston: true, seed: 4, ..Default::default() };
    let sim = spec.build().unwrap();
    assert!(sim.snapshot().contacts.is_empty());
    let d: Vec<f64> = sim.grains.radius.iter().map(|r| 2.0 * r).collect();
    assert!(d.iter().all(|&x| (0.8..=1.2).contains(&x)) && d.iter().any(|&x| x < 0.95) && d.iter().any(|&x| x > 1.05));
    match &sim.domain.walls[1].motion {
        WallMotion::Piston { force, .. } => {
            let lx = sim.domain.length(0);
            assert!((force.eval(0.0) - spec.pressure * lx * spec.diameter).abs() < 1e-15);
        }
        other => panic!("top wall should be a piston, not {other:?}"),
    }
}

/// Static solves with imposed displacements: the free equations D_ff u_f = f_f − D_fc u_c hold on
/// the full dof vector (constrained dofs at their values), for a chain and a lattice.
#[test]
fn static_solves_honour_imposed_displacements() {
    let snap = perfect_lattice(8, 8, 1.0, 0.5);
    let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
    let layout = *dm.layout();
    let mut c = Constraints::new();
    c.fix_translation(&layout, 0, &[0.01, -0.02]);
    c.fix_grain(&layout, 17);
    c.fix(layout.rotation(30, 0), 0.03);
    let system = dm.free_system(&c, ZeroRows::Keep).unwrap();
    assert_eq!(system.dofs(), layout.total() - 6);
    let f: Vec<f64> = (0..system.dofs()).map(|k| ((k * 31) % 7) as f64 * 1e-3).collect();
    let sol = solve_static(&system, &f, &StaticOptions::default()).unwrap();
    assert_eq!(sol.rigid_modes, 0, "fixed grains pin the translations");
    let u = system.expand(&sol.displacement).unwrap();
    assert_eq!((u[layout.translation(0, 0)], u[layout.translation(0, 1)], u[layout.rotation(30, 0)]), (0.01, -0.02, 0.03));
    let mut du = vec![0.0; layout.total()];
    dm.apply(&u, &mut du);
    let r = system.restrict(&du).unwrap();
    let err = r.iter().zip(&f).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let scale = f.iter().fold(0.0_f64, |a, b| a.max(b.abs()));
    assert!(err < 1e-9 * scale, "{err:e}");
}

/// SPEC §5.6 closed forms of the lattice speed against the lattice's own stiffnesses: the
/// equilibrium geometry (spacing a, bond force F, Hertz overlap ξ) gives k_n = (3/2)F/ξ and, with
/// friction, the Mindlin k_t = k_n (ν = 0); the continuum speed of the triangular spring network,
/// c² = (λ + 2μ)/ρ₂ with ρ₂ = m/(√3a²/2), must approach the closed form as p → 0: the closed form
/// sets a = d̄ and neglects the overlap, a relative error O(ξ) ~ (√3 p)^(2/3) (≈ 1.4e-4 at
/// p = 1e-6, 3e-3 at 1e-4), so the tolerance is 2 ξ. The frictional/frictionless ratio is √(4/3)
/// exactly.
#[test]
fn lattice_speed_closed_forms_match_the_spring_network() {
    for p in [1e-7, 1e-6, 1e-5, 1e-4] {
        for friction in [0.0, 0.5] {
            let spec = TriangularLatticeSpec { pressure: p, friction, ..Default::default() };
            let g = spec.geometry();
            let k_n = 1.5 * g.contact_force / g.overlap;
            let k_t = if friction > 0.0 { k_n } else { 0.0 };
            let net = SpringNetwork::triangular(g.spacing, (k_n, k_t), (k_n, k_t));
            let c22 = net.affine_voigt()[1][1];
            let m = std::f64::consts::PI / 6.0;
            let rho = m / (3f64.sqrt() / 2.0 * g.spacing * g.spacing);
            let c = (c22 / rho).sqrt();
            let closed = spec.closed_form_speed();
            assert!((c / closed - 1.0).abs() < 2.0 * g.overlap, "p = {p}, μ = {friction}: network {c} vs closed form {closed}");
        }
        let ratio = TriangularLatticeSpec { pressure: p, friction: 0.5, ..Default::default() }.closed_form_speed() / TriangularLatticeSpec { pressure: p, friction: 0.0, ..Default::default() }.closed_form_speed();
        assert!((ratio - (4.0f64 / 3.0).sqrt()).abs() < 1e-14);
    }
}
