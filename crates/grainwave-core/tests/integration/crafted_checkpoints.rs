//! Crafted checkpoints (issue 41): a checkpoint whose payload was changed and whose CRC was
//! recomputed decodes, bincode being happy with any bytes of the right shape. Each such file must
//! either be refused with an error or load to a state that then steps (on every vector path of
//! the force pass: the AVX-512 and AVX2 fused passes, the AVX-512 windows, the portable and the
//! general kernels) and is inspected (energies, hash) without a panic — and without reaching
//! memory out of bounds, which would end this test process with a segfault. `catch_unwind` only
//! turns a panic into a test failure naming the mutation.

use crate::common;
use common::*;
use grainwave_core::checkpoint;
use grainwave_core::contact::Partner;
use grainwave_core::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Offset of the payload in checkpoint bytes (magic, version, tag length, tag, length, CRC).
fn payload_start(bytes: &[u8]) -> usize {
    let tag_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    16 + tag_len + 12
}

/// Rewrites the header's payload length and CRC for payload `body` (what a crafted file does).
fn reseal(bytes: &[u8], body: &[u8]) -> Vec<u8> {
    let tag_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut out = bytes[..16 + tag_len].to_vec();
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&[0; 4]);
    out.extend_from_slice(body);
    assert!(grainwave_core::checkpoint::refresh_crc(&mut out), "the header holds a checksum");
    out
}

/// A 2D frictional packing with rolling resistance, stepped so that it has contacts and
/// tangential and rolling histories.
fn fixture_2d() -> Simulation<D2> {
    let mut p = hooke(1.0e3, Some(0.8), 0.3);
    p.rolling_stiffness = Some(0.5);
    p.rolling_friction = Some(0.05);
    let law = p.build(Partner::Grain, "contact").unwrap();
    let mut sim = dense_2d(4, 5, law, 0.5, 7).build().unwrap();
    sim.steps(30).unwrap();
    sim
}

/// A 3D Hertz–Mindlin packing with a floor wall, gravity and an external load, stepped (contacts,
/// wall contacts, histories).
fn fixture_3d() -> Simulation<D3> {
    use glam::DVec3;
    let p = hertz(1.0e3, 0.3, 0.4, Some(0.05));
    let law = p.build(Partner::Grain, "contact").unwrap();
    let wall_law = p.build(Partner::Wall, "contact.wall").unwrap();
    let mut sim = dense_3d(2, law, 0.2, 5).gravity(DVec3::new(0.0, 0.0, -0.5)).expected_overlap(0.05).build().unwrap();
    let lo = sim.grains.pos.iter().map(|x| x.z).fold(f64::INFINITY, f64::min) - 0.45;
    sim.domain.periodic[2] = false;
    sim.domain.walls.push(Wall::axis_aligned("floor", 2, lo, true, wall_law));
    sim.loads.push(ExternalLoad { grain: 3, force: DVec3::new(0.1, 0.0, 0.0), torque: DVec3::ZERO, profile: TimeFunction::Constant { value: 1.0 } });
    sim.refresh().unwrap();
    sim.steps(30).unwrap();
    sim
}

/// Outcome counts of a batch of mutants.
#[derive(Debug, Default)]
struct Tally {
    refused: usize,
    loaded: usize,
}

/// Decodes `bytes`; when they load, inspects the state and steps it on one path of the force
/// pass (`levels`, then the general kernel; mutant `pick` takes path `pick % (levels + 1)`, so
/// consecutive mutants cover every path). Panics (a test failure) naming `what` when anything
/// panics.
fn try_mutant<D: Dim>(bytes: &[u8], tag: &str, levels: &[u8], pick: usize, what: &str, tally: &mut Tally) {
    let decoded = catch_unwind(AssertUnwindSafe(|| checkpoint::decode::<Simulation<D>>(bytes, tag, "mutant")));
    let sim = match decoded {
        Err(_) => panic!("{what}: decoding panicked"),
        Ok(Err(e)) => {
            let m = e.to_string();
            assert!(m.contains("mutant") && m.len() < 2000, "{what}: unclear or oversized error: {m}");
            tally.refused += 1;
            return;
        }
        Ok(Ok(sim)) => sim,
    };
    tally.loaded += 1;
    let inspected = catch_unwind(AssertUnwindSafe(|| (sim.kinetic_energy(), sim.elastic_energy(), sim.gravitational_energy(), sim.state_hash(), sim.nlist.contact_count())));
    assert!(inspected.is_ok(), "{what}: inspecting the loaded state panicked");
    let path = pick % (levels.len() + 1);
    let (level, general) = if path < levels.len() { (levels[path], false) } else { (0, true) };
    let mut s = sim.clone();
    s.set_simd_level(level);
    s.set_general_kernel(general);
    let stepped = catch_unwind(AssertUnwindSafe(|| {
        // errors (blow-ups, inconsistencies found at run time) are fine; panics are not
        let _ = s.steps(2);
    }));
    assert!(stepped.is_ok(), "{what}: stepping the loaded state panicked (simd level {level}, general kernel {general})");
}

/// Payload bytes changed (every `stride`-th one, two values each), every plausible length field shortened and
/// lengthened with the elements moved accordingly, and length fields rewritten to huge values;
/// each mutant resealed with a valid CRC.
fn mutate_all<D: Dim>(sim: &Simulation<D>, levels: &[u8], stride: usize) -> Tally {
    let tag = checkpoint::simulation_tag::<D>();
    let bytes = checkpoint::encode(&tag, sim).unwrap();
    // the untouched file loads to the same state (bitwise)
    let back: Simulation<D> = checkpoint::decode(&bytes, &tag, "pristine").unwrap();
    assert_eq!(back.state_hash(), sim.state_hash());
    let start = payload_start(&bytes);
    let body = &bytes[start..];
    let mut tally = Tally::default();
    const XOR: [u8; 8] = [0x01, 0x80, 0xFF, 0x10, 0x7F, 0x40, 0x02, 0x20];
    let mut pick = 0;
    for off in (0..body.len()).step_by(stride) {
        for x in [XOR[off % 8], XOR[(off + 4) % 8]] {
            pick += 1;
            let mut b = body.to_vec();
            b[off] ^= x;
            try_mutant::<D>(&reseal(&bytes, &b), &tag, levels, pick, &format!("payload byte {off} ^ {x:#04x}"), &mut tally);
        }
    }
    let n = sim.len() as u64;
    let pairs = sim.nlist.list.len() as u64;
    for off in 0..body.len().saturating_sub(8) {
        let v = u64::from_le_bytes(body[off..off + 8].try_into().unwrap());
        if v == 0 || v > 4 * (n + pairs) {
            continue;
        }
        let at = off + 8;
        for size in [4usize, 8, 16, 24] {
            // one element fewer (its bytes removed)
            if at + size <= body.len() {
                let mut b = body[..off].to_vec();
                b.extend_from_slice(&(v - 1).to_le_bytes());
                b.extend_from_slice(&body[at + size..]);
                try_mutant::<D>(&reseal(&bytes, &b), &tag, levels, { pick += 1; pick }, &format!("length at {off}: {v} -> {} cutting {size} bytes", v - 1), &mut tally);
            }
            // one element more (the first one repeated)
            if at + size <= body.len() {
                let mut b = body[..off].to_vec();
                b.extend_from_slice(&(v + 1).to_le_bytes());
                b.extend_from_slice(&body[at..at + size]);
                b.extend_from_slice(&body[at..]);
                try_mutant::<D>(&reseal(&bytes, &b), &tag, levels, { pick += 1; pick }, &format!("length at {off}: {v} -> {} adding {size} bytes", v + 1), &mut tally);
            }
        }
        for huge in [1u64 << 31, u32::MAX as u64 + 1, u64::MAX] {
            let mut b = body.to_vec();
            b[off..off + 8].copy_from_slice(&huge.to_le_bytes());
            try_mutant::<D>(&reseal(&bytes, &b), &tag, levels, { pick += 1; pick }, &format!("length at {off}: {v} -> {huge}"), &mut tally);
        }
    }
    tally
}

#[test]
#[ignore = "did not finish in 200 s on the loaded build machine (a mutant may hang: issue 41's hang class); run with --ignored"]
fn crafted_2d_checkpoints_are_refused_or_step_safely() {
    let sim = fixture_2d();
    assert!(sim.counters.contacts > 0 && sim.nlist.list.len() > 0);
    let levels = simd_levels("crafted_2d_checkpoints_are_refused_or_step_safely", &[0, 1, 2, 3]);
    let t = mutate_all(&sim, &levels, 13);
    eprintln!("2D mutants: {t:?}");
    assert!(t.refused > 0 && t.loaded > 0, "{t:?}");
}

#[test]
#[ignore = "did not finish in 200 s on the loaded build machine (a mutant may hang: issue 41's hang class); run with --ignored"]
fn crafted_3d_checkpoints_are_refused_or_step_safely() {
    let sim = fixture_3d();
    assert!(sim.counters.contacts > 0 && !sim.nlist.wall_pairs.is_empty());
    let levels = simd_levels("crafted_3d_checkpoints_are_refused_or_step_safely", &[0, 1, 2, 3]);
    let t = mutate_all(&sim, &levels, 29);
    eprintln!("3D mutants: {t:?}");
    assert!(t.refused > 0 && t.loaded > 0, "{t:?}");
}

/// The faults of the probe, by hand: each is refused with "inconsistent: " and what is wrong.
/// The resealing of the mutation tests is exact: the untouched payload resealed is the file the
/// engine wrote, byte for byte, and a changed one decodes past the checksum.
#[test]
fn resealing_the_payload_reproduces_the_engine_file() {
    let sim = fixture_2d();
    let tag = checkpoint::simulation_tag::<D2>();
    let bytes = checkpoint::encode(&tag, &sim).unwrap();
    let start = payload_start(&bytes);
    assert!(reseal(&bytes, &bytes[start..]) == bytes, "resealed bytes differ from the engine's");
    let mut body = bytes[start..].to_vec();
    body.pop();
    let e = checkpoint::decode::<Simulation<D2>>(&reseal(&bytes, &body), &tag, "cut").err().expect("a cut payload is refused").to_string();
    assert!(!e.contains("checksum") && !e.contains("CRC"), "the checksum must pass: {e}");
}

#[test]
fn inconsistent_states_are_refused_by_name() {
    let sim = fixture_2d();
    let tag = checkpoint::simulation_tag::<D2>();
    let refused = |s: &Simulation<D2>| checkpoint::decode::<Simulation<D2>>(&checkpoint::encode(&tag, s).unwrap(), &tag, "c.gwck").unwrap_err().to_string();
    let mut s = sim.clone();
    s.grains.mass.pop();
    let e = refused(&s);
    assert!(e.contains("inconsistent: grains.mass has 19 entries for 20 grains"), "{e}");
    let mut s = sim.clone();
    s.grains.id[3] = s.grains.id[4];
    assert!(refused(&s).contains("appears more than once"));
    let mut s = sim.clone();
    s.grains.radius[0] = f64::NAN;
    assert!(refused(&s).contains("radius NaN"));
    let s3 = fixture_3d();
    let tag3 = checkpoint::simulation_tag::<D3>();
    let mut s = s3.clone();
    s.nlist.wall_pairs[0].grain = 1 << 30;
    let e = checkpoint::decode::<Simulation<D3>>(&checkpoint::encode(&tag3, &s).unwrap(), &tag3, "c").unwrap_err().to_string();
    assert!(e.contains("inconsistent: wall pair 0 names grain 1073741824 of 32"), "{e}");
    // a valid state still loads, and continues bit for bit
    let bytes = checkpoint::encode(&tag, &sim).unwrap();
    let mut a: Simulation<D2> = checkpoint::decode(&bytes, &tag, "c").unwrap();
    let mut b = sim.clone();
    a.steps(50).unwrap();
    b.steps(50).unwrap();
    assert_eq!(a.state_hash(), b.state_hash());
}
