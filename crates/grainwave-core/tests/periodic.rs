//! Periodic boundaries (SPEC §1.3): a pair straddling the boundary interacts exactly as the same
//! pair in the interior.

mod common;
use common::*;
use glam::{DVec2, DVec3};
use grainwave_core::contact::Partner;
use grainwave_core::prelude::*;

/// Two frictional, spinning disks colliding obliquely, once in the middle of the cell and once
/// across the corner (both axes periodic). Relative positions, velocities, spins and contact
/// forces must agree. The only difference is the rounding of the absolute coordinates
/// (positions ~5 vs ~0.5: ulps of 1e-15 vs 1e-16), which accumulates over the 4000 steps to
/// ~1e-11; the tolerance 1e-9 is far below any boundary error, which would be O(1).
#[test]
fn pair_across_the_boundary_matches_interior_pair_2d() {
    let law = hooke(1.0e4, Some(0.7), 0.5).build(Partner::Grain, "contact").unwrap();
    let run = |offset: DVec2| {
        let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        g.push(offset + DVec2::new(-0.52, -0.1), 0.5, 1.0, DVec2::new(0.8, 0.3));
        g.push(offset + DVec2::new(0.52, 0.1), 0.45, 1.0, DVec2::new(-0.6, -0.2));
        g.omega[0] = 3.0;
        g.omega[1] = -1.0;
        let d = Domain::new(DVec2::ZERO, DVec2::new(10.0, 8.0), [true, true, false]);
        let mut sim = SimulationBuilder::new(g, d, law).build().unwrap();
        let mut forces = Vec::new();
        for _ in 0..4000 {
            sim.step().unwrap();
            forces.push(sim.grains.force[0]);
        }
        let dx = sim.domain.displacement(sim.grains.pos[0], sim.grains.pos[1]);
        (dx, sim.grains.vel.clone(), sim.grains.omega.clone(), forces, sim.grains.image.clone())
    };
    let inside = run(DVec2::new(5.0, 4.0));
    let across = run(DVec2::new(0.0, 0.0)); // grain 0 starts at negative x and y: wrapped
    assert!(across.4.iter().any(|im| im[0] != 0 || im[1] != 0), "the pair straddles the boundary");
    let peak = inside.3.iter().map(|f| f.length()).fold(0.0, f64::max);
    assert!(peak > 1.0, "the grains collided");
    assert!((inside.0 - across.0).length() < 1e-9, "relative position {:?} vs {:?}", inside.0, across.0);
    for k in 0..2 {
        assert!((inside.1[k] - across.1[k]).length() < 1e-9);
        assert!((inside.2[k] - across.2[k]).abs() < 1e-9);
    }
    for (a, b) in inside.3.iter().zip(&across.3) {
        assert!((*a - *b).length() < 1e-7 * peak);
    }
}

#[test]
fn pair_across_the_boundary_matches_interior_pair_3d() {
    let law = hertz(1.0e4, 0.3, 0.5, Some(0.1)).build(Partner::Grain, "contact").unwrap();
    let run = |offset: DVec3| {
        let mut g = Grains::<D3>::new(GrainKind::Sphere);
        g.push(offset + DVec3::new(-0.52, -0.1, 0.05), 0.5, 1.0, DVec3::new(0.8, 0.3, -0.1));
        g.push(offset + DVec3::new(0.52, 0.1, -0.05), 0.45, 1.0, DVec3::new(-0.6, -0.2, 0.1));
        g.omega[0] = DVec3::new(0.5, -1.0, 3.0);
        let d = Domain::new(DVec3::ZERO, DVec3::new(10.0, 8.0, 6.0), [true, true, true]);
        let mut sim = SimulationBuilder::new(g, d, law).build().unwrap();
        sim.steps(4000).unwrap();
        (sim.domain.displacement(sim.grains.pos[0], sim.grains.pos[1]), sim.grains.vel.clone(), sim.grains.omega.clone())
    };
    let inside = run(DVec3::new(5.0, 4.0, 3.0));
    let across = run(DVec3::ZERO);
    assert!((inside.0 - across.0).length() < 1e-9, "relative position {:?} vs {:?}", inside.0, across.0);
    for k in 0..2 {
        assert!((inside.1[k] - across.1[k]).length() < 1e-9);
        assert!((inside.2[k] - across.2[k]).length() < 1e-9);
    }
    assert!((inside.1[0] - DVec3::new(0.8, 0.3, -0.1)).length() > 0.1, "the grains collided");
}
