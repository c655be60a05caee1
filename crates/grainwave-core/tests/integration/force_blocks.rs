//! The force pass cuts the grains into blocks (one per piece of parallel work) and sums every
//! grain's force over its partners in increasing index whatever the cut: the bits of a run do not
//! depend on the block length nor on the number of threads (see `sim::forces`).

use crate::common;
use common::*;
use grainwave_core::contact::Partner;
use grainwave_core::prelude::*;

fn pool(n: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap()
}

fn hashes<D: Dim>(make: impl Fn() -> Simulation<D> + Sync, steps: u64) -> Vec<u64> {
    let mut out = Vec::new();
    for threads in [1, 2, 3] {
        for len in [None, Some(1), Some(7), Some(64), Some(250), Some(100_000)] {
            out.push(pool(threads).install(|| {
                let mut sim = make();
                sim.set_force_block_len(len);
                sim.steps(steps).unwrap();
                assert!(sim.nlist.builds > 1 && sim.counters.contacts > 0);
                sim.state_hash()
            }));
        }
    }
    out
}

#[test]
fn block_length_and_thread_count_do_not_change_a_bit_2d() {
    // frictional, damped, with rolling resistance and without (both specialised)
    for rolling in [false, true] {
        let mut p = hooke(1.0e3, Some(0.8), 0.3);
        if rolling {
            p.rolling_stiffness = Some(0.5);
            p.rolling_friction = Some(0.05);
        }
        let law = p.build(Partner::Grain, "contact").unwrap();
        let h = hashes(|| dense_2d(12, 15, law, 0.5, 21).build().unwrap(), 400);
        assert!(h.iter().all(|&x| x == h[0]), "rolling {rolling}: {h:x?}");
    }
}

#[test]
fn block_length_and_thread_count_do_not_change_a_bit_3d_with_walls_and_gravity() {
    use glam::DVec3;
    let p = hertz(1.0e3, 0.3, 0.4, Some(0.05));
    let law = p.build(Partner::Grain, "contact").unwrap();
    let wall_law = p.build(Partner::Wall, "contact.wall").unwrap();
    let make = || {
        let mut sim = dense_3d(3, law, 0.2, 5).gravity(DVec3::new(0.0, 0.0, -0.5)).expected_overlap(0.05).build().unwrap();
        // a floor below the lattice, and a load on one grain
        let lo = sim.grains.pos.iter().map(|x| x.z).fold(f64::INFINITY, f64::min) - 0.6;
        sim.domain.periodic[2] = false;
        sim.domain.walls.push(Wall::axis_aligned("floor", 2, lo, true, wall_law));
        sim.loads.push(ExternalLoad { grain: 3, force: DVec3::new(0.1, 0.0, 0.0), torque: DVec3::ZERO, profile: TimeFunction::Constant { value: 1.0 } });
        sim.refresh().unwrap();
        sim
    };
    let h = hashes(make, 300);
    assert!(h.iter().all(|&x| x == h[0]), "{h:x?}");
}

#[test]
fn specialised_window_kernels_give_the_bits_of_the_general_kernel() {
    // Hertz–Mindlin (Tsuji and critical damping) and Hooke–Cundall–Strack (mass-proportional
    // and restitution damping), each also with rolling resistance, 2D and 3D, still and shearing cells, 1 and 2 threads with
    // several blocks, and one block.
    // (general, simd, one block): the general kernel, or a specialised one on the portable path
    // (simd 0), the fused AVX2 pass (1), the AVX-512 windows (2) or the fused pass on 512-bit
    // lanes (3) — the levels the processor has; the others are reported as skipped)
    let levels = simd_levels("specialised_window_kernels_give_the_bits_of_the_general_kernel", &[0, 1, 2, 3]);
    type Make = dyn Fn() -> Box<dyn FnMut((bool, u8, bool)) -> u64> + Sync;
    let run = |mode: (bool, u8, bool), threads: usize, make: &Make| {
        pool(threads).install(|| (make())(mode))
    };
    let laws = {
        let mut tsuji = hertz(1.0e3, 0.3, 0.4, None);
        tsuji.tsuji_restitution = Some(0.5);
        let mut rate = hooke(1.0e3, None, 0.3);
        rate.normal_damping_rate = Some(5.0);
        // rolling resistance (E2's law: restitution damping, weak rolling stiffness and cap;
        // and a stiff, damped one on Hertz–Mindlin, whose cap is reached often)
        let mut e2 = hooke(1.0e3, Some(0.8), 0.3);
        e2.rolling_stiffness = Some(0.5);
        e2.rolling_friction = Some(0.01);
        let mut hertz_rolling = hertz(1.0e3, 0.3, 0.4, Some(0.05));
        hertz_rolling.rolling_stiffness = Some(5.0);
        hertz_rolling.rolling_damping = Some(0.01);
        hertz_rolling.rolling_friction = Some(0.05);
        vec![tsuji, hertz(1.0e3, 0.3, 0.4, Some(0.05)), rate, hooke(1.0e3, Some(0.8), 0.3), e2, hertz_rolling]
    };
    for p in laws {
        let law = p.build(Partner::Grain, "contact").unwrap();
        assert!(!matches!(law.specialize(), grainwave_core::contact::Specialized::General(_)));
        // a shearing cell too: the tilt of the images and their velocity
        for shear in [0.0, 0.02] {
            let make2 = move || -> Box<dyn FnMut((bool, u8, bool)) -> u64> {
                Box::new(move |(general, simd, one)| {
                    let mut sim = dense_2d(30, 40, law, 0.5, 21).expected_overlap(0.05).build().unwrap();
                    sim.set_general_kernel(general);
                    sim.set_simd_level(simd);
                    if shear != 0.0 {
                        sim.domain.set_shear_rate(shear).unwrap();
                    }
                    sim.set_force_block_len(if one { None } else { Some(300) });
                    sim.steps(300).unwrap();
                    assert!(sim.counters.contacts > 0 && sim.nlist.builds > 1);
                    sim.state_hash()
                })
            };
            let make3 = move || -> Box<dyn FnMut((bool, u8, bool)) -> u64> {
                Box::new(move |(general, simd, one)| {
                    let mut sim = dense_3d(4, law, 0.3, 22).expected_overlap(0.05).build().unwrap();
                    sim.set_general_kernel(general);
                    sim.set_simd_level(simd);
                    if shear != 0.0 {
                        sim.domain.set_shear_rate(shear).unwrap();
                    }
                    sim.set_force_block_len(if one { None } else { Some(50) });
                    sim.steps(300).unwrap();
                    assert!(sim.counters.contacts > 0);
                    sim.state_hash()
                })
            };
            for make in [&make2 as &Make, &make3] {
                let reference = run((true, 0, false), 1, make);
                for threads in [1, 2] {
                    for &simd in &levels {
                        assert_eq!(run((false, simd, false), threads, make), reference, "{law:?}, shear {shear}, {threads} threads, simd {simd}");
                    }
                }
                for &simd in &levels {
                    assert_eq!(run((false, simd, true), 1, make), reference, "{law:?}, shear {shear}, one block, simd {simd}");
                }
            }
        }
    }
}

#[test]
fn the_close_list_of_the_fused_pass_misses_no_contact() {
    // 3D (the close list is kept in 3D only). Fast grains (v = 2 per unit time against a close margin of 0.03): the fused pass's close
    // list is rebuilt many times between neighbor-list builds. A list that missed a pair which
    // came into contact, or forgot a contact that opened, would change the bits against the
    // general kernel.
    let p = hooke(1.0e3, Some(0.8), 0.3);
    let law = p.build(Partner::Grain, "contact").unwrap();
    let run = |general: bool, simd: u8| {
        let mut sim = dense_3d(4, law, 2.0, 7).expected_overlap(0.05).build().unwrap();
        sim.set_general_kernel(general);
        sim.set_simd_level(simd);
        sim.steps(400).unwrap();
        (sim.state_hash(), sim.close_list_builds(), sim.nlist.builds, sim.close_list_fingerprint())
    };
    let (general, _, builds, _) = run(true, 0);
    // the fused pass on 256-bit (1) and 512-bit lanes (3), whose close lists are filtered
    // element by element (1) or eight pairs at a time (3): the same list (the levels the
    // processor has; the others are reported as skipped)
    let levels = simd_levels("the_close_list_of_the_fused_pass_misses_no_contact", &[1, 3]);
    let fingerprints: Vec<u64> = levels.iter().map(|&simd| run(false, simd).3).collect();
    assert!(fingerprints.iter().all(|&f| f == fingerprints[0]), "{fingerprints:x?}");
    for &simd in &levels {
        let (fused, close_builds, _, _) = run(false, simd);
        assert_eq!(fused, general, "simd {simd}");
        assert!(close_builds > 2 * builds, "simd {simd}: close list built {close_builds} times, neighbor list {builds}");
    }
}

#[test]
fn a_nan_spin_is_caught_through_the_close_list() {
    // A NaN angular velocity leaves positions finite (no neighbor-list rebuild), so only the
    // force pass can see it: through the close list (3D, fused pass), the grain's contacts still
    // carry it into a non-finite force.
    let law = hooke(1.0e3, Some(0.8), 0.3).build(Partner::Grain, "contact").unwrap();
    let levels = simd_levels("a_nan_spin_is_caught_through_the_close_list", &[1, 3]);
    for (general, simd) in levels.iter().map(|&l| (false, l)).chain([(true, 0)]) {
        let mut sim = dense_3d(4, law, 0.3, 22).expected_overlap(0.05).build().unwrap();
        sim.set_general_kernel(general);
        sim.set_simd_level(simd);
        sim.steps(50).unwrap();
        assert!(general || sim.close_list_builds() > 0);
        sim.grains.omega[7] = glam::DVec3::new(f64::NAN, 0.0, 0.0);
        let e = sim.steps(5).unwrap_err().to_string();
        assert!(e.contains("non-finite"), "general {general}, simd {simd}: {e}");
    }
}

#[test]
fn masses_changed_by_hand_reach_the_close_list() {
    // The close list keeps the radii and reduced masses of its pairs. After masses are changed
    // by hand and `refresh_forces` is called (as documented), the fused pass damps with the new
    // ones: the bits of the general kernel, which reads the masses at every step. (Without the
    // rebuild, the old reduced masses would stay until the grains have moved by the margin.)
    let law = hooke(1.0e3, Some(0.8), 0.3).build(Partner::Grain, "contact").unwrap();
    let run = |general: bool, simd: u8| {
        let mut sim = dense_3d(4, law, 0.3, 22).expected_overlap(0.05).build().unwrap();
        sim.set_general_kernel(general);
        sim.set_simd_level(simd);
        sim.steps(50).unwrap();
        for k in (0..sim.grains.len()).step_by(3) {
            sim.grains.mass[k] *= 2.5;
            sim.grains.inertia[k] *= 2.5;
        }
        sim.refresh_forces().unwrap();
        sim.steps(100).unwrap();
        assert!(sim.counters.contacts > 0);
        sim.state_hash()
    };
    let reference = run(true, 0);
    for simd in simd_levels("masses_changed_by_hand_reach_the_close_list", &[1, 3]) {
        assert_eq!(run(false, simd), reference, "simd {simd}");
    }
}

/// A packing stepped 300 times (its lists also rebuilt every 37 steps), on the general kernel
/// or the window kernels at vector level `simd` in blocks of `len` pairs (`None`: one block):
/// its state hash.
fn run_300<D: Dim>(mut sim: Simulation<D>, general: bool, simd: u8, len: Option<usize>) -> u64 {
    sim.set_general_kernel(general);
    sim.set_simd_level(simd);
    sim.set_force_block_len(len);
    for s in 0..300 {
        if s % 37 == 0 {
            sim.nlist.stale = true;
        }
        sim.step().unwrap();
    }
    assert!(sim.counters.contacts > 0 && sim.nlist.builds > 8);
    sim.state_hash()
}

/// `law` on a dense 2D and a dense 3D packing gives the bits of the general kernel on every
/// path: 1 and 2 threads with several blocks, and one block, at each vector level of `levels`.
fn every_path_gives_the_bits_of_the_general_kernel(law: ContactLaw, levels: &[u8]) {
    let make2 = || dense_2d(30, 40, law, 0.5, 21).expected_overlap(0.05).build().unwrap();
    let make3 = || dense_3d(4, law, 0.3, 22).expected_overlap(0.05).build().unwrap();
    let reference = (pool(1).install(|| run_300(make2(), true, 0, Some(300))), pool(1).install(|| run_300(make3(), true, 0, Some(50))));
    for threads in [1, 2] {
        for &simd in levels {
            let got = pool(threads).install(|| (run_300(make2(), false, simd, Some(300)), run_300(make3(), false, simd, Some(50))));
            assert_eq!(got, reference, "{law:?}, {threads} threads, simd {simd}");
        }
    }
    for &simd in levels {
        let got = pool(1).install(|| (run_300(make2(), false, simd, None), run_300(make3(), false, simd, None)));
        assert_eq!(got, reference, "{law:?}, one block, simd {simd}");
    }
}

#[test]
fn a_normal_law_with_history_gives_the_bits_of_the_general_kernel_on_every_path() {
    // The hysteretic normal law (history ξ_max per contact) through its specialised composition
    // (`Specialized::NormalHistory`: the history gathered and scattered beside the tangential
    // spring) against the general kernel: the linear spring and the slip-activation spring,
    // with and without rolling resistance, three dampers; 2D and 3D, neighbor lists rebuilt
    // every 37 steps besides their own rebuilds, 1 and 2 threads with several blocks, and one
    // block; every vector path the processor has (the others are reported as skipped).
    use grainwave_core::contact::{Hysteretic, NormalTable, Specialized};
    let levels = simd_levels("a_normal_law_with_history_gives_the_bits_of_the_general_kernel_on_every_path", &[0, 1, 2, 3]);
    let law = |k2: f64, damping: u8, slip: Option<f64>, rolling: bool| {
        let mut p = ContactParams { normal: Some(NormalTable::Hysteretic(Hysteretic { loading_stiffness: 1.0e3, unloading_stiffness: k2 })), ..Default::default() };
        p.friction = Some(0.3);
        match damping {
            0 => p.normal_damping_rate = Some(5.0),
            1 => p.damping_fraction = Some(0.1),
            _ => p.normal_damping = Some(0.5),
        }
        p.slip_activation_time = slip;
        if rolling {
            (p.rolling_stiffness, p.rolling_friction) = (Some(0.5), Some(0.05));
        }
        p.build(Partner::Grain, "contact").unwrap()
    };
    let laws = [law(3.0e3, 0, None, false), law(3.0e3, 1, None, true), law(2.0e3, 2, Some(0.05), false), law(4.0e3, 0, Some(0.05), true)];
    for law in laws {
        assert!(matches!(law.specialize(), Specialized::NormalHistory(..)), "{law:?}");
        every_path_gives_the_bits_of_the_general_kernel(law, &levels);
    }
    // the history acts: with k₂ = k₁ (no hysteresis) the same packing at the same time step
    // ends elsewhere
    let (a, b) = (law(3.0e3, 0, None, false), law(1.0e3, 0, None, false));
    let end = |law: ContactLaw| pool(1).install(|| run_300(dense_2d(30, 40, law, 0.5, 21).dt(5e-4).build().unwrap(), false, 3, Some(300)));
    assert_ne!(end(a), end(b));
}

#[test]
fn a_tangential_law_with_history_gives_the_bits_of_the_general_kernel_on_every_path() {
    // Slip-weakening friction (history: the slip δ per contact) through its specialised
    // composition (`Specialized::TangentialHistory`: the history gathered and scattered beside
    // the tangential spring) against the general kernel, with and without rolling resistance,
    // two dampers; 2D and 3D, neighbor lists rebuilt every 37 steps besides their own rebuilds,
    // 1 and 2 threads with several blocks, and one block; every vector path the processor has.
    use grainwave_core::contact::tangential::SlipWeakening;
    use grainwave_core::contact::Specialized;
    let levels = simd_levels("a_tangential_law_with_history_gives_the_bits_of_the_general_kernel_on_every_path", &[0, 1, 2, 3]);
    let law = |residual_ratio: f64, damping: u8, rolling: bool| {
        let mut p = hooke(1.0e3, None, 0.3);
        match damping {
            0 => p.normal_damping_rate = Some(5.0),
            _ => p.damping_fraction = Some(0.1),
        }
        if rolling {
            (p.rolling_stiffness, p.rolling_friction) = (Some(0.5), Some(0.05));
        }
        let law = p.build(Partner::Grain, "contact").unwrap();
        ContactLaw { tangential: SlipWeakening { stiffness: 300.0, residual_ratio, weakening_distance: 1e-3 }.into(), ..law }
    };
    for law in [law(0.2, 0, false), law(0.5, 1, true)] {
        assert!(matches!(law.specialize(), Specialized::TangentialHistory(..)), "{law:?}");
        every_path_gives_the_bits_of_the_general_kernel(law, &levels);
    }
    // the history acts: without weakening (r = 1) the same packing ends elsewhere
    let end = |law: ContactLaw| pool(1).install(|| run_300(dense_2d(30, 40, law, 0.5, 21).dt(5e-4).build().unwrap(), false, 3, Some(300)));
    assert_ne!(end(law(0.2, 0, false)), end(law(1.0, 0, false)));
}
