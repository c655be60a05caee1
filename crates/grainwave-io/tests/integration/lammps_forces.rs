//! Same physics as LAMMPS: the force on every grain of a small pre-jammed packing, at the start
//! and after the first step, under the 3D Hertz–Mindlin benchmark law (`pair_style granular`,
//! `hertz/material 1e5 0.5 0.3 tangential mindlin NULL 1.0 0.5 damping tsuji`), against
//! LAMMPS's own dump.
//!
//! Fixtures (`tests/fixtures/lammps/`, see the README there): `pack3d_300.data`, 300 spheres
//! prepared by LAMMPS with `prep3d.lmp`; `forces3d.dump`, written by LAMMPS running
//! `forces3d.lmp` on it (positions, velocities and forces at steps 0 and 1, 17 digits).

use glam::DVec3;
use grainwave_core::contact::{ContactParams, Partner};
use grainwave_core::prelude::*;
use grainwave_io::lammps::{read_data, ImportOptions};
use std::collections::HashMap;
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/lammps").join(name)
}

/// One dumped atom: position, velocity, force, contact count.
#[derive(Clone, Copy, Debug)]
struct Dumped {
    x: DVec3,
    v: DVec3,
    f: DVec3,
    contacts: f64,
}

/// The snapshots of a `dump custom … id x y z vx vy vz fx fy fz c_z`, by step, by atom id.
fn read_dump() -> HashMap<u64, HashMap<u32, Dumped>> {
    let text = std::fs::read_to_string(fixture("forces3d.dump")).unwrap();
    let mut out = HashMap::new();
    let mut lines = text.lines();
    while let Some(l) = lines.next() {
        assert_eq!(l, "ITEM: TIMESTEP");
        let step: u64 = lines.next().unwrap().trim().parse().unwrap();
        assert_eq!(lines.next().unwrap(), "ITEM: NUMBER OF ATOMS");
        let n: usize = lines.next().unwrap().trim().parse().unwrap();
        for _ in 0..4 {
            lines.next(); // box bounds
        }
        assert!(lines.next().unwrap().starts_with("ITEM: ATOMS id x y z vx vy vz fx fy fz"));
        let mut atoms = HashMap::new();
        for _ in 0..n {
            let w: Vec<f64> = lines.next().unwrap().split_whitespace().map(|s| s.parse().unwrap()).collect();
            let v3 = |k: usize| DVec3::new(w[k], w[k + 1], w[k + 2]);
            atoms.insert(w[0] as u32, Dumped { x: v3(1), v: v3(4), f: v3(7), contacts: w[10] });
        }
        out.insert(step, atoms);
    }
    out
}

/// The benchmark's 3D Hertz–Mindlin law (as `grainwave bench hertz3d`).
fn hertz_tsuji() -> ContactParams {
    ContactParams {
        young: Some(1.0e5),
        poisson: Some(0.3),
        tsuji_restitution: Some(0.5),
        tangential_damping_ratio: Some(1.0),
        friction: Some(0.5),
        ..ContactParams::preset("hertz_mindlin")
    }
}

/// (max over grains of |F_grainwave − F_LAMMPS| / the largest force in the packing, max of
/// |ΔF|/|F| over grains whose force is not a near-cancellation, |F| > 1 % of the largest).
fn compare(sim: &Simulation<D3>, dumped: &HashMap<u32, Dumped>) -> (f64, f64) {
    let f_max = dumped.values().map(|d| d.f.length()).fold(0.0, f64::max);
    let (mut abs, mut rel) = (0.0_f64, 0.0_f64);
    for k in 0..sim.len() {
        let d = dumped[&sim.grains.id[k]];
        let diff = (sim.grains.force[k] - d.f).length();
        abs = abs.max(diff / f_max);
        if d.f.length() > 0.01 * f_max {
            rel = rel.max(diff / d.f.length());
        }
    }
    (abs, rel)
}

#[test]
fn hertz_tsuji_forces_match_lammps_at_start_and_after_the_first_step() {
    let data = read_data(&fixture("pack3d_300.data")).unwrap();
    assert_eq!(data.len(), 300);
    let (mut grains, domain) = data.to_packing_3d(&ImportOptions::default()).unwrap();
    for v in grains.vel.iter_mut() {
        *v = DVec3::ZERO; // velocity all set 0 0 0
    }
    let law = hertz_tsuji().build(Partner::Grain, "contact").unwrap();
    let mut sim = SimulationBuilder::new(grains, domain, law).dt(1e-3).skin(0.1).max_initial_overlap(0.3).build().unwrap();
    let dump = read_dump();

    // Step 0: elastic Hertz forces only (no relative motion).
    let (abs0, rel0) = compare(&sim, &dump[&0]);
    // same contacts: LAMMPS's contact/atom counts
    let mut contacts = vec![0.0; sim.len()];
    for c in sim.contact_records() {
        contacts[sim.grains.index_of(c.i).unwrap()] += 1.0;
        if let Counterpart::Grain(j) = c.j {
            contacts[sim.grains.index_of(j).unwrap()] += 1.0;
        }
    }
    for k in 0..sim.len() {
        assert_eq!(contacts[k], dump[&0][&sim.grains.id[k]].contacts, "contacts of grain {}", sim.grains.id[k]);
    }

    // Step 1: positions from the half kick, Tsuji normal damping and the first Mindlin increment.
    sim.step().unwrap();
    let mut dx = 0.0_f64;
    let mut dv = 0.0_f64;
    for k in 0..sim.len() {
        let d = dump[&1][&sim.grains.id[k]];
        dx = dx.max(sim.domain.displacement(d.x, sim.grains.pos[k]).length());
        dv = dv.max((sim.grains.vel[k] - d.v).length() / d.v.length().max(1e-300));
    }
    let (abs1, rel1) = compare(&sim, &dump[&1]);
    eprintln!("step 0: max |ΔF|/F_max {abs0:.2e}, max |ΔF|/|F| {rel0:.2e}");
    eprintln!("step 1: max |ΔF|/F_max {abs1:.2e}, max |ΔF|/|F| {rel1:.2e}; positions {dx:.2e}, velocities (rel.) {dv:.2e}");
    // Both codes evaluate the same expressions in a different order: the differences are
    // rounding (measured 3e-14 of the largest force, 2.5e-13 per grain), far inside 1e-9. A
    // change of the tangential damping ratio from 1 to 0.9 gives 1e-2 at step 1.
    for (what, e) in [("step 0 abs", abs0), ("step 0 rel", rel0), ("step 1 abs", abs1), ("step 1 rel", rel1)] {
        assert!(e < 1e-9, "{what}: {e:e}");
    }
    assert!(dx < 1e-12, "positions after the first step differ by {dx:e}");
    // velocities after the second half kick: they include the step-1 forces
    assert!(dv < 1e-9, "velocities after the first step differ by {dv:e} (relative)");
}
