//! Spatial sorting reorders the grains without changing the physics: ids, contact histories and
//! forces follow their grains.

use crate::common;
use common::*;
use grainwave_core::contact::Partner;
use grainwave_core::prelude::*;
use std::collections::HashMap;

fn by_id<D: Dim>(sim: &Simulation<D>) -> HashMap<u32, (D::Vector, D::Vector, D::AngVector)> {
    (0..sim.len()).map(|k| (sim.grains.id[k], (sim.grains.pos[k], sim.grains.force[k], sim.grains.torque[k]))).collect()
}

fn records<D: Dim>(sim: &Simulation<D>) -> HashMap<(u32, u32), (f64, f64)> {
    sim.contact_records()
        .iter()
        .filter_map(|c| match c.j {
            Counterpart::Grain(j) => Some(((c.i.min(j), c.i.max(j)), (c.normal_force, c.tangential_force.norm()))),
            Counterpart::Wall(_) => None,
        })
        .collect()
}

#[test]
fn sorting_keeps_grains_histories_and_forces() {
    let mut p = hooke(1.0e3, Some(0.8), 0.3);
    p.rolling_stiffness = Some(0.5);
    let law = p.build(Partner::Grain, "contact").unwrap();
    let mut sim = dense_2d(20, 25, law, 0.5, 21).build().unwrap();
    let mut sorted = sim.clone();
    sim.steps(300).unwrap();
    sorted.steps(300).unwrap();
    sorted.sort_spatially();
    assert_ne!(sorted.grains.id, sim.grains.id, "the order changed");
    sim.refresh_forces().unwrap();
    sorted.refresh_forces().unwrap();
    let (a, b) = (by_id(&sim), by_id(&sorted));
    let f_max = sim.grains.force.iter().map(|f| f.norm()).fold(0.0, f64::max);
    for (id, (x, f, t)) in &a {
        let (y, g, u) = b[id];
        assert_eq!(*x, y, "grain {id} moved");
        // same contacts summed in another order: rounding only
        assert!((*f - g).norm() <= 1e-13 * f_max, "grain {id}: {f:?} vs {g:?}");
        assert!((t - u).abs() <= 1e-13 * f_max, "grain {id}: torque {t} vs {u}");
    }
    let (ra, rb) = (records(&sim), records(&sorted));
    assert_eq!(ra.len(), rb.len());
    assert!(ra.len() > 500 && ra.values().any(|r| r.1 > 0.0), "frictional contacts with stored history");
    for (k, v) in &ra {
        let w = rb[k];
        assert!((v.0 - w.0).abs() <= 1e-12 * f_max && (v.1 - w.1).abs() <= 1e-12 * f_max, "contact {k:?}: {v:?} vs {w:?}");
    }
    // and it runs on deterministically
    let hashes: Vec<u64> = [1, 2, 3]
        .iter()
        .map(|&n| {
            let mut s = sorted.clone();
            rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap().install(|| s.steps(200).unwrap());
            s.state_hash()
        })
        .collect();
    assert!(hashes.iter().all(|&h| h == hashes[0]));
}

/// Mean |i − j| of the storage indices over grain–grain contacts.
fn mean_index_gap<D: Dim>(sim: &Simulation<D>) -> f64 {
    let at: HashMap<u32, usize> = (0..sim.len()).map(|k| (sim.grains.id[k], k)).collect();
    let gaps: Vec<f64> = sim
        .contact_records()
        .iter()
        .filter_map(|c| match c.j {
            Counterpart::Grain(j) => Some((at[&c.i] as f64 - at[&j] as f64).abs()),
            Counterpart::Wall(_) => None,
        })
        .collect();
    gaps.iter().sum::<f64>() / gaps.len() as f64
}

#[test]
fn blocks_keep_partners_close_in_memory_and_change_no_physics() {
    // a long strip, 10 rows of 200 disks: in plain bin order a grain's partners in the next row
    // are a whole row (≈ 100–200 grains) away; in blocks of about 100 grains — the strip's
    // whole height (≈ 17 bins of one radius) by ≈ 10 disks — a block row. (Much smaller blocks
    // would cut the strip's height in two, and the pairs across that cut would be a whole
    // block row apart.)
    let law = hooke(1.0e3, Some(0.8), 0.3).build(Partner::Grain, "contact").unwrap();
    let mut sim = dense_2d(10, 200, law, 0.2, 5).build().unwrap();
    sim.steps(100).unwrap();
    let (mut plain, mut blocked) = (sim.clone(), sim.clone());
    plain.sort_spatially();
    blocked.sort_spatially_in_blocks(100);
    for s in [&mut sim, &mut plain, &mut blocked] {
        s.refresh_forces().unwrap();
    }
    let (g_plain, g_blocked) = (mean_index_gap(&plain), mean_index_gap(&blocked));
    assert!(g_plain > 40.0, "plain bin order: partners a row apart ({g_plain})");
    assert!(g_blocked < 0.3 * g_plain, "blocks: {g_blocked} against {g_plain}");
    // the whole strip is fewer grains than the default block: plain bin order
    assert_eq!(plain.grains.id, {
        let mut one = sim.clone();
        one.sort_spatially_in_blocks(2000);
        one.grains.id
    });
    // same grains, same forces (another summation order: rounding only)
    let (a, b) = (by_id(&sim), by_id(&blocked));
    let f_max = sim.grains.force.iter().map(|f| f.norm()).fold(0.0, f64::max);
    assert_eq!(a.len(), b.len());
    for (id, (x, f, _)) in &a {
        let (y, g, _) = b[id];
        assert_eq!(*x, y, "grain {id} moved");
        assert!((*f - g).norm() <= 1e-13 * f_max, "grain {id}: {f:?} vs {g:?}");
    }
}
