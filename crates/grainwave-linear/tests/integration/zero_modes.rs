//! D is symmetric and positive semi-definite, and its null space is exactly the expected one on
//! constructed packings; the static solver handles those zero modes (and fails cleanly, without
//! panicking, on a loaded floppy mode).
//!
//! Packings: compressed triangular (2D) and FCC (3D) lattices, periodic in every direction (free:
//! no walls) or between two walls, with a few grains shrunk to radius 0.3 so that they touch
//! nothing (rattlers). Expected zero modes:
//!
//! | packing | zero modes |
//! |---|---|
//! | free periodic, frictional | d rigid translations + (d + r) per rattler |
//! | free periodic, frictionless | d + every grain's r rotations + d per rattler translation |
//! | frictional, between frictional walls | (d + r) per rattler only |
//! | free periodic, frictional, rattlers removed | d |
//!
//! The zero space splits into motions of the rattlers and the rest (`Modes::zero_space_split`):
//! every rattler mode above is carried by the rattlers alone (weight 1 of P = Zᵀ M_rattlers Z),
//! the rigid translations and, without friction, the rotations of the other grains and the sliding
//! of the backbone along frictionless walls by the rest (weight 0); a grain resting on one frictional contact has exactly one zero mode, rolling about
//! the contact point.
//!
//! A mode counts as zero when |ω²| ≤ 1e-10 max ω²; the test also requires a clean gap (the next
//! eigenvalue above 1e-5 max ω²; measured gaps are printed) so that the count cannot be an
//! accident of the threshold. Symmetry: the blocks are assembled from one bilinear form, so
//! asymmetry is rounding only (≤ 1e-15 of the largest entry).

use crate::common;
use common::*;
use glam::DVec2;
use grainwave_core::prelude::*;
use grainwave_linear::prelude::*;

fn spectrum_check<D: Dim>(name: &str, snap: &Snapshot<D>, options: &AssemblyOptions, expected: usize) -> DynamicalMatrix<D> {
    let dm = DynamicalMatrix::assemble(snap, options).unwrap();
    let dense = dm.stiffness().to_dense();
    let n = dense.nrows();
    let scale = (0..n).flat_map(|r| (0..n).map(move |c| (r, c))).map(|(r, c)| dense[(r, c)].abs()).fold(0.0, f64::max);
    let asym = (0..n).flat_map(|r| (0..n).map(move |c| (r, c))).map(|(r, c)| (dense[(r, c)] - dense[(c, r)]).abs()).fold(0.0, f64::max);
    assert!(asym <= 1e-15 * scale, "{name}: asymmetry {:e}", asym / scale);
    let system = dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap();
    let modes = Modes::compute(&system, &EigenOptions::default()).unwrap();
    let w2 = modes.omega_squared();
    let max = w2.iter().fold(0.0_f64, |a, &b| a.max(b.abs()));
    let min = w2[0];
    let zeros = modes.zero_modes(1e-10);
    let gap = w2.get(zeros).copied().unwrap_or(f64::INFINITY) / max;
    let largest_zero = if zeros > 0 { w2[..zeros].iter().fold(0.0_f64, |a, &b| a.max(b.abs())) / max } else { 0.0 };
    eprintln!("{name}: {zeros} zero modes (expected {expected}), |ω²| ≤ {largest_zero:.1e} of max, next {gap:.2e}, min ω² {:.1e}, asymmetry {:.1e}", min / max, asym / scale);
    assert!(min >= -1e-12 * max, "{name}: D is not positive semi-definite: {min:e}");
    assert_eq!(zeros, expected, "{name}: number of zero modes");
    assert!(gap > 1e-5, "{name}: no clean gap above the zero modes: {gap:e}");
    // mass-normalization: Vᵀ M V = I
    let v = modes.vectors();
    for a in [0, zeros, modes.len() - 1] {
        for b in [0, zeros, modes.len() - 1] {
            let s: f64 = (0..modes.len()).map(|r| v[(r, a)] * modes.mass()[r] * v[(r, b)]).sum();
            assert!((s - if a == b { 1.0 } else { 0.0 }).abs() < 1e-12, "{name}: vᵀMv = {s}");
        }
    }
    dm
}

const RATTLERS_2D: [usize; 3] = [9, 27, 44];
const RATTLERS_3D: [usize; 2] = [5, 20];

#[test]
fn free_periodic_packings_have_rigid_and_rattler_zero_modes_2d() {
    let nr = RATTLERS_2D.len();
    let frictional = lattice_2d(8, 8, GrainKind::Sphere2d, &hertz_params(0.5, 0.0), false, None, 1, &RATTLERS_2D).build().unwrap().snapshot();
    let n = frictional.len();
    spectrum_check("2D periodic frictional", &frictional, &AssemblyOptions::default(), 2 + 3 * nr);
    let removed = spectrum_check("2D periodic frictional, rattlers removed", &frictional, &AssemblyOptions { rattlers: Rattlers::Remove, ..Default::default() }, 2);
    assert_eq!(removed.removed().iter().filter(|&&r| r).count(), nr);
    let frictionless = lattice_2d(8, 8, GrainKind::Sphere2d, &hertz_params(0.0, 0.0), false, None, 1, &RATTLERS_2D).build().unwrap().snapshot();
    spectrum_check("2D periodic frictionless", &frictionless, &AssemblyOptions::default(), 2 + n + 2 * nr);
    let walls = lattice_2d(8, 8, GrainKind::Sphere2d, &hertz_params(0.5, 0.0), true, None, 1, &RATTLERS_2D).build().unwrap().snapshot();
    spectrum_check("2D frictional between walls", &walls, &AssemblyOptions::default(), 3 * nr);
}

#[test]
fn free_periodic_packings_have_rigid_and_rattler_zero_modes_3d() {
    let nr = RATTLERS_3D.len();
    let frictional = lattice_3d(2, 2, &hertz_params(0.5, 0.0), false, None, 2, &RATTLERS_3D).build().unwrap().snapshot();
    let n = frictional.len();
    spectrum_check("3D periodic frictional", &frictional, &AssemblyOptions::default(), 3 + 6 * nr);
    spectrum_check("3D periodic frictional, rattlers removed", &frictional, &AssemblyOptions { rattlers: Rattlers::Remove, ..Default::default() }, 3);
    let frictionless = lattice_3d(2, 2, &hertz_params(0.0, 0.0), false, None, 2, &RATTLERS_3D).build().unwrap().snapshot();
    spectrum_check("3D periodic frictionless", &frictionless, &AssemblyOptions::default(), 3 + 3 * n + 3 * nr);
    let walls = lattice_3d(2, 2, &hertz_params(0.5, 0.0), true, None, 2, &RATTLERS_3D).build().unwrap().snapshot();
    spectrum_check("3D frictional between walls", &walls, &AssemblyOptions::default(), 6 * nr);
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Static solves on packings with zero modes: the rigid translations are projected out, the rattler
/// dofs dropped, and D u equals the balanced part of the load to the solver tolerance.
#[test]
fn static_solver_handles_rigid_modes_and_rattlers() {
    for frictional in [true, false] {
        let params = hertz_params(if frictional { 0.5 } else { 0.0 }, 0.0);
        let snap = lattice_2d(8, 8, GrainKind::Sphere2d, &params, false, None, 3, &RATTLERS_2D).build().unwrap().snapshot();
        let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
        let system = dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap();
        // a load with a net force along x and y, on every dof
        let f: Vec<f64> = (0..system.dofs()).map(|k| ((k * 7919) % 13) as f64 / 13.0 - 0.3).collect();
        let sol = solve_static(&system, &f, &StaticOptions::default()).unwrap();
        let n = snap.len();
        let nr = RATTLERS_2D.len();
        assert_eq!(sol.rigid_modes, 2);
        assert_eq!(sol.zero_rows.len(), if frictional { 3 * nr } else { n + 2 * nr });
        // residual of the balanced load: f minus its zero-row part minus its mean translation
        let mut y = vec![0.0; system.dofs()];
        system.apply(&sol.displacement, &mut y);
        let layout = system.layout();
        let kept: Vec<usize> = (0..system.dofs()).filter(|k| !sol.zero_rows.contains(k)).collect();
        let mut balanced = f.clone();
        for &k in &sol.zero_rows {
            balanced[k] = 0.0;
        }
        for axis in 0..2 {
            let members: Vec<usize> = kept.iter().copied().filter(|&k| layout.component_of(system.free_dofs()[k]) == axis).collect();
            let mean = members.iter().map(|&k| balanced[k]).sum::<f64>() / members.len() as f64;
            for &k in &members {
                balanced[k] -= mean;
            }
        }
        let r: Vec<f64> = balanced.iter().zip(&y).map(|(a, b)| a - b).collect();
        let rel = norm(&r) / norm(&balanced);
        eprintln!("frictional = {frictional}: {} CG iterations, ‖P f − D u‖/‖P f‖ = {rel:.1e}, unbalanced load {:.3}", sol.iterations, sol.unbalanced_load);
        assert!(rel < 1e-10, "{rel:e}");
        assert!(sol.unbalanced_load > 0.0);
    }
}

/// One disk (R = 0.5, centre 0.49 above the floor) resting on a frictional floor of a box periodic
/// along x: Hooke contacts k_n = 100, k_t/k_n = 0.5, μ = 0.5.
fn grain_on_frictional_floor() -> Snapshot<D2> {
    let params = hooke_params(100.0, 0.5, 0.5);
    let law = params.build(Partner::Grain, "contact").unwrap();
    let wall = params.build(Partner::Wall, "contact.wall").unwrap();
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    g.push(DVec2::new(5.0, 0.49), 0.5, 1.0, DVec2::ZERO);
    let domain = Domain::new(DVec2::ZERO, DVec2::new(10.0, 5.0), [true, false, false]).with_wall(Wall::axis_aligned("floor", 1, 0.0, true, wall));
    SimulationBuilder::new(g, domain, law).max_initial_overlap(0.1).build().unwrap().snapshot()
}

/// One frictional grain resting on a wall: the normal load is carried (u = f/k_n), a tangential
/// load excites the rolling mode (a floppy mode with non-zero rows) and is refused with an error —
/// or, with a Tikhonov regularization, answered with a large finite displacement.
#[test]
fn floppy_modes_give_errors_not_panics() {
    let snap = grain_on_frictional_floor();
    let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
    let system = dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap();
    let sol = solve_static(&system, &[0.0, 1.0, 0.0], &StaticOptions::default()).unwrap();
    assert!((sol.displacement[1] - 0.01).abs() < 1e-14, "{:?}", sol.displacement);
    let err = solve_static(&system, &[1.0, 0.0, 0.0], &StaticOptions::default()).unwrap_err();
    eprintln!("tangential load on a rolling grain: {err}");
    assert!(matches!(err, LinearError::NotPositiveDefinite { .. } | LinearError::NoConvergence { .. }));
    // (D + η diag D) has condition number ~1/η: its attainable residual is ~ε/η, hence the tolerance
    let sol = solve_static(&system, &[1.0, 0.0, 0.0], &StaticOptions { regularization: 1e-6, tolerance: 1e-8, ..Default::default() }).unwrap();
    assert!(sol.displacement.iter().all(|x| x.is_finite()) && sol.displacement[0].abs() > 1e2, "{:?}", sol.displacement);
    // a compressed chain with pre-stress and free transverse dofs is unstable: an error, not a panic
    let chain = grainwave_linear::reference::ChainSpec { grains: 5, ..Default::default() };
    let snap = chain.build().unwrap().snapshot();
    let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions { prestress: PreStress::Normal, ..Default::default() }).unwrap();
    let system = dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap();
    let mut f = vec![0.0; system.dofs()];
    f[system.free_index(dm.layout().translation(2, 1)).unwrap()] = 1.0;
    let err = solve_static(&system, &f, &StaticOptions::default()).unwrap_err();
    assert!(matches!(err, LinearError::NotPositiveDefinite { .. }), "{err}");
    let modes = Modes::compute(&system, &EigenOptions::default()).unwrap();
    assert!(modes.omega_squared()[0] < 0.0, "the pre-stressed chain has buckling modes");
}

/// The grain-block storage used for products when the free dofs are whole grains gives the same
/// product as the scalar CSR matrix (to rounding: the sums are associated per block), in 2D and 3D;
/// systems with partial grains fall back to the CSR.
#[test]
fn block_products_equal_csr_products() {
    fn check(system: &LinearSystem, expect_blocks: bool) {
        assert_eq!(system.has_block_storage(), expect_blocks);
        let n = system.dofs();
        let x: Vec<f64> = (0..n).map(|k| ((k * 7919) % 101) as f64 / 101.0 - 0.5).collect();
        let mut y = vec![0.0; n];
        system.apply(&x, &mut y);
        let d = system.stiffness();
        let s = d.symbolic();
        let mut worst: f64 = 0.0;
        let mut scale: f64 = 0.0;
        for r in 0..n {
            let z: f64 = (s.row_ptr()[r]..s.row_ptr()[r + 1]).map(|e| d.val()[e] * x[s.col_idx()[e]]).sum();
            worst = worst.max((z - y[r]).abs());
            scale = scale.max(z.abs());
        }
        assert!(worst <= 1e-14 * scale, "{worst:e} vs {scale:e}");
    }
    let snap2 = lattice_2d(8, 8, GrainKind::Sphere2d, &hertz_params(0.5, 0.0), true, None, 5, &RATTLERS_2D).build().unwrap().snapshot();
    let dm2 = DynamicalMatrix::assemble(&snap2, &AssemblyOptions::default()).unwrap();
    check(&dm2.free_system(&Constraints::new(), ZeroRows::Keep).unwrap(), true);
    let removed = DynamicalMatrix::assemble(&snap2, &AssemblyOptions { rattlers: Rattlers::Remove, ..Default::default() }).unwrap();
    check(&removed.free_system(&Constraints::new(), ZeroRows::Keep).unwrap(), true);
    let mut c = Constraints::new();
    c.fix_grain(dm2.layout(), 3);
    check(&dm2.free_system(&c, ZeroRows::Keep).unwrap(), true);
    c.fix(dm2.layout().rotation(5, 0), 0.0);
    check(&dm2.free_system(&c, ZeroRows::Keep).unwrap(), false);
    check(&dm2.free_system(&Constraints::new(), ZeroRows::Drop).unwrap(), true); // whole rattlers dropped
    let frictionless = lattice_2d(8, 8, GrainKind::Sphere2d, &hertz_params(0.0, 0.0), true, None, 5, &[]).build().unwrap().snapshot();
    let dmf = DynamicalMatrix::assemble(&frictionless, &AssemblyOptions::default()).unwrap();
    check(&dmf.free_system(&Constraints::new(), ZeroRows::Drop).unwrap(), false); // rotations dropped
    let snap3 = lattice_3d(2, 2, &hertz_params(0.5, 0.0), true, None, 6, &[]).build().unwrap().snapshot();
    let dm3 = DynamicalMatrix::assemble(&snap3, &AssemblyOptions::default()).unwrap();
    check(&dm3.free_system(&Constraints::new(), ZeroRows::Keep).unwrap(), true);
}

/// The rattler part of the zero space of `snap` (rattlers = the grains in `rattlers`), with the
/// check that the split is clean: every eigenvalue of P = Zᵀ M_R Z is 0 or 1 to rounding (the
/// constructed packings' zero motions are either on the rattlers or off them), so that the count
/// cannot depend on the 0.99 threshold.
fn split<D: Dim>(name: &str, snap: &Snapshot<D>, rattlers: &[usize]) -> ZeroSpaceSplit {
    let dm = DynamicalMatrix::assemble(snap, &AssemblyOptions::default()).unwrap();
    let system = dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap();
    let modes = Modes::compute(&system, &EigenOptions::default()).unwrap();
    let layout = *dm.layout();
    let selected: Vec<bool> = modes.free_dofs().iter().map(|&f| rattlers.contains(&layout.grain_of(f))).collect();
    let s = modes.zero_space_split(1e-10, &selected, 0.99).unwrap();
    assert_eq!(s.zero_modes, modes.zero_modes(1e-10));
    let (counted, rest) = s.weights.split_at(s.localized);
    eprintln!(
        "{name}: {} zero modes, {} on the rattlers; smallest counted weight {:?}, largest other {:?}",
        s.zero_modes,
        s.localized,
        counted.last(),
        rest.first()
    );
    // exact-arithmetic weights are 1 and 0; the eigenvectors of a degenerate zero space carry
    // rounding of order ε‖D‖/gap (gap ≥ 1e-5 of ‖D‖ above): 1e-9 leaves a wide margin
    assert!(counted.iter().all(|&w| (w - 1.0).abs() < 1e-9), "{name}: {counted:?}");
    assert!(rest.iter().all(|&w| w.abs() < 1e-9), "{name}: {rest:?}");
    s
}

#[test]
fn zero_space_splits_into_rattler_and_backbone_motions() {
    let nr = RATTLERS_2D.len();
    let walls = lattice_2d(8, 8, GrainKind::Sphere2d, &hertz_params(0.5, 0.0), true, None, 1, &RATTLERS_2D).build().unwrap().snapshot();
    let n = walls.len();
    // between walls, frictional: 3 per contactless rattler, all of them the rattlers'
    let s = split("2D frictional between walls", &walls, &RATTLERS_2D);
    assert_eq!((s.zero_modes, s.localized), (3 * nr, 3 * nr));
    // the same packing, asking about grains that are held: none of the zero space is theirs
    let s = split("2D frictional between walls, held grains selected", &walls, &[0, 10, 20]);
    assert_eq!((s.zero_modes, s.localized), (3 * nr, 0));
    // one grain more shrunk: 3 zero modes more, all of them the rattlers'
    let more = [RATTLERS_2D[0], RATTLERS_2D[1], RATTLERS_2D[2], 36];
    let walls4 = lattice_2d(8, 8, GrainKind::Sphere2d, &hertz_params(0.5, 0.0), true, None, 1, &more).build().unwrap().snapshot();
    let s = split("2D frictional between walls, 4 rattlers", &walls4, &more);
    assert_eq!((s.zero_modes, s.localized), (3 * nr + 3, 3 * nr + 3));
    // free periodic: the 2 rigid translations belong to the backbone
    let periodic = lattice_2d(8, 8, GrainKind::Sphere2d, &hertz_params(0.5, 0.0), false, None, 1, &RATTLERS_2D).build().unwrap().snapshot();
    let s = split("2D periodic frictional", &periodic, &RATTLERS_2D);
    assert_eq!((s.zero_modes, s.localized), (2 + 3 * nr, 3 * nr));
    // frictionless between walls: every grain's rotation is free, and the frictionless walls let
    // the whole backbone slide along the periodic axis; the rattlers' rotations and translations
    // are theirs, the other n − nr rotations and the sliding the backbone's
    let frictionless = lattice_2d(8, 8, GrainKind::Sphere2d, &hertz_params(0.0, 0.0), true, None, 1, &RATTLERS_2D).build().unwrap().snapshot();
    let s = split("2D frictionless between walls", &frictionless, &RATTLERS_2D);
    assert_eq!((s.zero_modes, s.localized), (n + 2 * nr + 1, 3 * nr));
    // 3D, between walls: 6 per rattler
    let nr3 = RATTLERS_3D.len();
    let walls3 = lattice_3d(2, 2, &hertz_params(0.5, 0.0), true, None, 2, &RATTLERS_3D).build().unwrap().snapshot();
    let s = split("3D frictional between walls", &walls3, &RATTLERS_3D);
    assert_eq!((s.zero_modes, s.localized), (6 * nr3, 6 * nr3));
}

/// A frictional grain on one contact (a rattler by the default threshold of 2) has one zero mode,
/// rolling without slipping about the contact point (u = −θ × R n̂ for a rotation θ), and it is the
/// grain's; the normal and tangential springs hold the other two dofs.
#[test]
fn a_grain_on_one_frictional_contact_has_one_rolling_zero_mode() {
    let snap = grain_on_frictional_floor();
    assert_eq!(grainwave_linear::rattlers::find_rattlers(&snap, 2), vec![true]);
    let s = split("one grain on a frictional floor", &snap, &[0]);
    assert_eq!((s.zero_modes, s.localized), (1, 1));
    // the zero mode is the rolling motion: u_x = −R θ (centre 0.49 above the contact point, R = 0.5
    // minus the overlap: the lever arm), u_y = 0
    let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
    let modes = Modes::compute(&dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap(), &EigenOptions::default()).unwrap();
    let v = modes.mode(0);
    let at = |full: usize| v[modes.free_dofs().iter().position(|&f| f == full).unwrap()];
    let layout = dm.layout();
    let (ux, uy, theta) = (at(layout.translation(0, 0)), at(layout.translation(0, 1)), at(layout.rotation(0, 0)));
    let lever = dm.contacts()[0].lever_i;
    assert!(uy.abs() < 1e-12 * theta.abs(), "{v:?}");
    assert!((ux / theta + lever).abs() < 1e-9 * lever, "u_x/θ = {} vs −{lever}", ux / theta);
}
