//! Periodic boundaries (SPEC §1.3): a pair straddling the boundary interacts exactly as the same
//! pair in the interior.

use crate::common;
use common::*;
use grainwave_core::contact::Partner;
use grainwave_core::prelude::*;

both_dims! {
    /// Two frictional, spinning grains colliding obliquely, once in the middle of the cell and
    /// once across the corner (every axis periodic): Hooke with restitution 0.7 (2D disks) and
    /// Hertz–Mindlin with 10 % damping (3D spheres). Relative positions, velocities, spins and
    /// contact forces must agree. The only difference is the rounding of the absolute
    /// coordinates (positions ~5 vs ~0.5: ulps of 1e-15 vs 1e-16), which accumulates over the
    /// 4000 steps to ~1e-11; the tolerance 1e-9 is far below any boundary error, which would be
    /// O(1).
    fn pair_across_the_boundary_matches_interior_pair<D>() {
        let params = D::pick(hooke(1.0e4, Some(0.7), 0.5), hertz(1.0e4, 0.3, 0.5, Some(0.1)));
        let law = params.build(Partner::Grain, "contact").unwrap();
        let run = |offset: D::Vector| {
            let mut g = Grains::<D>::new(D::kind());
            g.push(offset + vector::<D>([-0.52, -0.1, 0.05]), 0.5, 1.0, vector::<D>([0.8, 0.3, -0.1]));
            g.push(offset + vector::<D>([0.52, 0.1, -0.05]), 0.45, 1.0, vector::<D>([-0.6, -0.2, 0.1]));
            g.omega[0] = spin::<D>([0.5, -1.0, 3.0]);
            g.omega[1] = spin::<D>([0.0, 0.0, -1.0]);
            let d = Domain::new(D::Vector::ZERO, vector::<D>([10.0, 8.0, 6.0]), [true, true, D::D == 3]);
            let mut sim = SimulationBuilder::new(g, d, law).build().unwrap();
            let mut forces = Vec::new();
            for _ in 0..4000 {
                sim.step().unwrap();
                forces.push(sim.grains.force[0]);
            }
            let dx = sim.domain.displacement(sim.grains.pos[0], sim.grains.pos[1]);
            (dx, sim.grains.vel.clone(), sim.grains.omega.clone(), forces, sim.grains.image.clone())
        };
        let inside = run(vector::<D>([5.0, 4.0, 3.0]));
        let across = run(D::Vector::ZERO); // grain 0 starts at negative coordinates: wrapped
        assert!(across.4.iter().any(|im| im.iter().any(|&c| c != 0)), "the pair straddles the boundary");
        let peak = inside.3.iter().map(|f| f.norm()).fold(0.0, f64::max);
        assert!(peak > 1.0, "the grains collided");
        assert!((inside.0 - across.0).norm() < 1e-9, "relative position {:?} vs {:?}", inside.0, across.0);
        for k in 0..2 {
            assert!((inside.1[k] - across.1[k]).norm() < 1e-9);
            assert!((inside.2[k] - across.2[k]).norm() < 1e-9);
        }
        assert!((inside.1[0] - vector::<D>([0.8, 0.3, -0.1])).norm() > 0.1, "the grains collided");
        for (a, b) in inside.3.iter().zip(&across.3) {
            assert!((*a - *b).norm() < 1e-7 * peak);
        }
    }
}
