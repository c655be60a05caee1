//! The coarse-grained stress of a uniformly compressed lattice equals its virial stress in the
//! bulk (SPEC §4), and fields integrate to the virial sum.

use glam::DVec2;
use grainwave_analysis::coarse_grain::{coarse_grain, CoarseGrainOptions, Grid};
use grainwave_analysis::stress::{contact_stress, contact_stress_filtered};
use grainwave_core::prelude::*;

/// A triangular lattice of `rows` × `columns` Hooke disks of radius 1 with every neighbour
/// overlapping by `overlap` (spacing a = 2 − overlap), periodic along x, free along y. Every
/// contact carries the same force: the stress is uniform away from the top and bottom rows.
fn lattice(rows: usize, columns: usize, overlap: f64) -> (Snapshot<D2>, f64) {
    let mut p = ContactParams::preset("hooke_cundall_strack");
    p.normal_stiffness = Some(1000.0);
    p.friction = Some(0.0);
    let law = p.build(Partner::Grain, "contact").unwrap();
    let a = 2.0 - overlap;
    let h = 3f64.sqrt() / 2.0 * a;
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    for r in 0..rows {
        for c in 0..columns {
            let x = (c as f64 + 0.1 + if r % 2 == 1 { 0.5 } else { 0.0 }) * a;
            g.push(DVec2::new(x, 1.0 + r as f64 * h), 1.0, 1.0, DVec2::ZERO);
        }
    }
    let domain = Domain::new(DVec2::ZERO, DVec2::new(columns as f64 * a, 2.0 + rows as f64 * h), [true, false, false]);
    let sim = SimulationBuilder::new(g, domain, law).max_initial_overlap(0.5).build().unwrap();
    (sim.snapshot(), a)
}

#[test]
fn coarse_grained_stress_equals_the_virial_stress_in_the_bulk() {
    let (snap, a) = lattice(30, 12, 0.01);
    let h = 3f64.sqrt() / 2.0 * a;
    // virial stress of the bulk: grain–grain contacts with contact point in a window of whole
    // periods (8 spacings × 6 rows), over the window's area
    let index: std::collections::HashMap<u32, usize> = snap.id.iter().enumerate().map(|(k, &id)| (id, k)).collect();
    let (x0, z0) = (0.23 * a, 1.0 + 10.37 * h);
    let (x1, z1) = (x0 + 8.0 * a, z0 + 6.0 * h);
    let inside = |c: &ContactRecord<D2>| {
        let p = snap.pos[index[&c.i]] + c.normal * c.lever_i;
        p.x >= x0 && p.x < x1 && p.y >= z0 && p.y < z1
    };
    let virial = contact_stress_filtered(&snap, (x1 - x0) * (z1 - z0), inside);
    // closed form: three bonds of force F = kξ and length a per cell of area a h:
    // σ = (F a / (a h)) Σ n n = (F/h) · (3/2) I
    let f = 1000.0 * 0.01;
    let expected = f / h * 1.5;
    assert!((virial[0] / expected - 1.0).abs() < 1e-12 && (virial[3] / expected - 1.0).abs() < 1e-12, "{virial:?} vs {expected}");
    assert!(virial[1].abs() < 1e-12 * expected);
    // coarse-grained field at points of the bulk (7 widths from the free rows), including points
    // near the periodic edge x = 0 (their contacts come from the image on the other side)
    for (width, tolerance) in [(1.5 * a, 1e-9), (a, 5e-5)] {
        // the field of a Gaussian of width w over a lattice has a ripple ∝ e^{−|G|²w²/4},
        // |G| = 4π/(√3 a) the shortest reciprocal vector: e^{−13.2 (w/a)²} = 2e-6 for w = a, with a
        // prefactor of order the number of shortest G (6) — hence 5e-5; e^{−29.6} ≈ 1e-13 for
        // w = 1.5a, where the cut-off at 6 widths (e^{−36}) and round-off remain: 1e-9
        let grid = Grid::<D2> { origin: DVec2::new(0.05, 1.0 + 13.0 * h), spacing: DVec2::new(0.37 * a, 0.41 * h), counts: [30, 10, 1] };
        let field = coarse_grain(&snap, &grid, &CoarseGrainOptions { width, ..Default::default() });
        for k in 0..grid.len() {
            let (sxx, szz, sxz) = (field.stress_at(k, 0, 0), field.stress_at(k, 1, 1), field.stress_at(k, 0, 1));
            assert!((sxx / expected - 1.0).abs() < tolerance, "w = {width}: σ_xx {sxx} at {:?}", grid.point(k));
            assert!((szz / expected - 1.0).abs() < tolerance, "w = {width}: σ_zz {szz} at {:?}", grid.point(k));
            assert!(sxz.abs() < tolerance * expected, "w = {width}: σ_xz {sxz}");
            assert!((field.stress_at(k, 1, 0) - sxz).abs() < 1e-12 * expected, "σ is symmetric");
        }
    }
}

#[test]
fn the_field_integrates_to_the_virial_sum_and_the_mass() {
    // ∫ σ dA = −Σ_c f ⊗ b and ∫ ρ dA = Σ m over a grid covering the packing and the Gaussians
    let (snap, a) = lattice(4, 5, 0.02);
    let step = 0.1;
    let lo = DVec2::new(-12.0, -12.0);
    let grid = Grid::<D2>::covering(lo, DVec2::new(5.0 * a + 12.0, 20.0), step);
    // a non-periodic copy: every contact counted once, no images
    let mut free = snap.clone();
    free.domain.periodic = [false; 3];
    free.contacts.retain(|c| {
        let pi = free.pos[c.i as usize];
        (pi + c.branch
            - free.pos[match c.j {
                Counterpart::Grain(j) => j as usize,
                Counterpart::Wall(_) => unreachable!(),
            }])
        .length()
            < 1e-9
    });
    let field = coarse_grain(&free, &grid, &CoarseGrainOptions { width: 1.3, ..Default::default() });
    let cell = grid.spacing.x * grid.spacing.y;
    let total_xx: f64 = (0..grid.len()).map(|k| field.stress_at(k, 0, 0)).sum::<f64>() * cell;
    let total_zz: f64 = (0..grid.len()).map(|k| field.stress_at(k, 1, 1)).sum::<f64>() * cell;
    let virial = contact_stress(&free, 1.0);
    // the Riemann sum of smooth Gaussians at step 0.1 ≪ w is exact to ~1e-12
    assert!((total_xx / virial[0] - 1.0).abs() < 1e-9, "{total_xx} vs {}", virial[0]);
    assert!((total_zz / virial[3] - 1.0).abs() < 1e-9, "{total_zz} vs {}", virial[3]);
    let mass: f64 = field.density.iter().sum::<f64>() * cell;
    assert!((mass / free.mass.iter().sum::<f64>() - 1.0).abs() < 1e-9);
}
