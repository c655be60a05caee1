//! Spatial sorting reorders the grains without changing the physics: ids, contact histories and
//! forces follow their grains.

mod common;
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
