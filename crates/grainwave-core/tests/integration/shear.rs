//! Lees–Edwards shear: a periodic cell whose tilt grows at a constant rate (LAMMPS
//! `fix deform 1 xy erate … remap v`). Images across the sheared boundary move with the cell.

use crate::common;
use common::*;
use glam::DVec2;
use grainwave_core::contact::Partner;
use grainwave_core::prelude::*;

fn pool(n: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap()
}

#[test]
fn an_image_across_the_sheared_boundary_collides_like_a_moving_grain() {
    // A at the bottom, B at the top, both at rest; B's image below moves at −ḃ = (−rate, 0) and
    // hits A. Elastic, frictionless: in the frame of the image the collision reverses the normal
    // relative velocity, so |v_image − v_A| stays equal to the rate.
    let rate = 0.2;
    let law = hooke(1.0e4, None, 0.0).build(Partner::Grain, "contact").unwrap();
    let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    grains.push(DVec2::new(5.0, 0.5), 0.5, 1.0, DVec2::ZERO);
    grains.push(DVec2::new(6.2, 7.7), 0.5, 1.0, DVec2::ZERO);
    let mut domain = Domain::new(DVec2::ZERO, DVec2::new(10.0, 8.0), [true, true, false]);
    domain.set_shear_rate(rate / 8.0).unwrap();
    assert_eq!(domain.tilt_rate, [rate, 0.0, 0.0]);
    let mut sim = SimulationBuilder::new(grains, domain, law).dt(1e-4).build().unwrap();
    // image of B: (6.2 − xy, −0.3); contact when |dx| < √(1 − 0.8²) = 0.6, at xy = 0.6
    let mut first = None;
    for _ in 0..200_000 {
        sim.step().unwrap();
        if first.is_none() && sim.counters.contacts > 0 {
            first = Some((sim.time, sim.grains.force[0]));
        }
        if first.is_some() && sim.counters.contacts == 0 {
            break;
        }
    }
    let (t_contact, f) = first.expect("the image reached A");
    assert!((t_contact - 0.6 / rate).abs() < 2e-4, "first contact at t = {t_contact}");
    assert!(f.x < 0.0 && f.y > 0.0, "A is pushed away from the image coming from +x above: {f:?}");
    let v_image = sim.grains.vel[1] - DVec2::new(rate, 0.0);
    let relative = (v_image - sim.grains.vel[0]).length();
    assert!((relative / rate - 1.0).abs() < 1e-3, "|v_rel| after = {relative}");
    assert!((sim.domain.tilt[0] - rate * sim.time).abs() < 1e-9);
}

/// A dense, agitated packing (a compressed triangular lattice of 500 disks, or FCC lattice of
/// 500 spheres) in a shearing cell, its bottom row on the sheared boundary: grains cross it back
/// and forth (positions and velocities remapped), contacts form and break across it.
fn sheared_packing<D: TestDim>(law: ContactLaw) -> Simulation<D> {
    let b = D::dense((20, 25), 5, law, 0.3, 8);
    let mut sim = if D::D == 3 { b.expected_overlap(0.05) } else { b }.build().unwrap();
    sim.domain.set_shear_rate(0.02).unwrap();
    for k in 0..sim.len() {
        let y = sim.grains.pos[k].get(1);
        sim.grains.pos[k].set(1, y - 0.25);
        let (mut x, mut v, mut im) = (sim.grains.pos[k], sim.grains.vel[k], sim.grains.image[k]);
        sim.domain.wrap_moving(&mut x, &mut v, &mut im);
        (sim.grains.pos[k], sim.grains.vel[k], sim.grains.image[k]) = (x, v, im);
    }
    sim.refresh().unwrap();
    sim
}

both_dims! {
    /// The general kernel against the specialised ones (on every vector path the processor has),
    /// threads and blocks, Hooke and Hertz, in a sheared cell: the tilt of the images and their
    /// velocity go through the domain's one minimum image on every path.
    fn sheared_runs_are_bitwise_identical_for_any_threads_blocks_and_kernel<D>() {
        let levels = simd_levels("sheared_runs_are_bitwise_identical_for_any_threads_blocks_and_kernel", &[0, 1, 2, 3]);
        for p in [hooke(1.0e3, Some(0.8), 0.3), hertz(1.0e3, 0.3, 0.4, Some(0.05))] {
            let law = p.build(Partner::Grain, "contact").unwrap();
            let run = |threads: usize, block: Option<usize>, general: bool, simd: u8| {
                pool(threads).install(|| {
                    let mut sim = sheared_packing::<D>(law);
                    sim.set_force_block_len(block);
                    sim.set_general_kernel(general);
                    sim.set_simd_level(simd);
                    sim.steps(D::pick(1500, 600)).unwrap();
                    (sim.state_hash(), sim.nlist.builds, sim.grains.image.iter().map(|i| i[1].abs()).sum::<i32>())
                })
            };
            let reference = run(1, None, true, 0);
            assert!(reference.1 > 5, "the tilt forces rebuilds: {reference:?}");
            assert!(reference.2 > 0, "grains crossed the sheared boundary");
            for &simd in &levels {
                for (threads, block, general) in [(1, None, false), (2, None, false), (3, Some(100), false)] {
                    assert_eq!(run(threads, block, general, simd), reference, "{threads} threads, blocks {block:?}, general {general}, simd {simd}");
                }
            }
            assert_eq!(run(2, Some(77), true, 0), reference, "general kernel, 2 threads, blocks of 77");
        }
    }
}

#[test]
fn shear_develops_a_velocity_profile_and_resumes_bit_for_bit() {
    let law = hooke(1.0e3, Some(0.5), 0.3).build(Partner::Grain, "contact").unwrap();
    let mut sim = sheared_packing::<D2>(law);
    sim.steps(3000).unwrap();
    let mut copy: Simulation<D2> = grainwave_core::checkpoint::decode(&grainwave_core::checkpoint::encode("simulation-2d", &sim).unwrap(), "simulation-2d", "memory").unwrap();
    sim.steps(3000).unwrap();
    copy.steps(3000).unwrap();
    assert_eq!(sim.state_hash(), copy.state_hash());
    // the boundary drags the grains: mean v_x increases with y (least-squares slope > 0)
    let n = sim.len() as f64;
    let (my, mv) = (sim.grains.pos.iter().map(|p| p.y).sum::<f64>() / n, sim.grains.vel.iter().map(|v| v.x).sum::<f64>() / n);
    let cov: f64 = sim.grains.pos.iter().zip(&sim.grains.vel).map(|(p, v)| (p.y - my) * (v.x - mv)).sum();
    let var: f64 = sim.grains.pos.iter().map(|p| (p.y - my) * (p.y - my)).sum();
    let slope = cov / var;
    assert!(slope > 0.002, "shear rate inside the packing {slope} (imposed 0.02)");
}
