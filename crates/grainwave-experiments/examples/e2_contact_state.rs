//! Where the contacts at the Coulomb limit of an E2 state sit, and which way a homogeneous strain
//! increment would push them (SPEC §6.2, §6.6): why compressive pulses release so little sliding
//! in compression, and where in the packing the pulses disturb the sliding contacts.
//!
//! For a state file (a replay's `final.gwck`, e.g. `replays/stop500_g3/final.gwck`, the static
//! state before its pulses; or a strain checkpoint `checkpoints/ck-*.gwck` holding a full state) it
//! prints, over the grain–grain contacts:
//!
//! * the margin 1 − |F_t|/(μ F_n) from the Coulomb limit, as counts below 1e-12 … 1e-2
//!   (the static-state count of SPEC §6.2 is the margin ≤ 1e-6);
//! * for the mobilised contacts (margin ≤ 1e-6), the affine test of `e2::model::sliding_drive`:
//!   under a small homogeneous strain increment E a contact at the limit keeps sliding when
//!   F̂_t·δF_t > μ δF_n for the affine increments δF_n = −k_n n·E b, δF_t = k_t (t·E b) t. Counted for E =
//!   ∓ e_x e_x (a compressive / rarefying pulse from the right wall, p_a > 0 / < 0), ∓ e_y e_y (the
//!   same from the top wall) and the loading's own increment, E ∝ −(ε_xx, ε_yy) (the state's
//!   strain, counted positive in compression), which must push most mobilised contacts on if
//!   the sign conventions are right;
//! * the mobilised contacts' positions: counts per fifth of the box along x (the right wall
//!   emits the pulses) and along y, and the mean |cos θ| of their normals against all contacts'.
//!
//! With amplitudes after the state (`p_a` in t*, e.g. `1e-9 -1e-9`), it also replays a δ pulse
//! from the state's pulsing wall for `E2_PULSE_TA` acoustic times (default 2, as the static-limit
//! replays), next to the same replay without the pulse, and counts, among the mobilised contacts
//! that the affine test says the pulse pushes on and among those it says the pulse releases, how
//! many the pulse made slide (the engine's cap flag set in some step of the pulsed copy and in no
//! step of the unpulsed one): how far the grains' response is from the affine one. With
//! `E2_ARRIVALS` = the replay's `aK_arrivals.csv` files (comma-separated, one per amplitude), the
//! contacts that slid are split into those whose first sliding step comes no later than the
//! pulse's arrival at grain i (they can slow the front) and those after it (the pulse's tail).
//!
//! With `E2_SPLIT_CSV` = a file name, the same counts are written split by distance from the
//! pulsing wall (fifths of the box, 0 = next to the wall) and by the orientation of the contact
//! normal (|θ| from the pulse's axis in six 15° bins, 0° = along the pulse): per bin the
//! grain–grain contacts, the mobilised ones, those pushed on by p_a > 0 and by p_a < 0, and, per
//! replayed amplitude, the contacts (mobilised or not) the pulse made slide (`slid_<p_a>`) — where
//! in the packing the sliding that slows a pulse sits, comparable between packing sizes.
//!
//! ```text
//! cargo run --release -p grainwave-experiments --example e2_contact_state -- STATE.gwck [p_a ...]
//! ```
//! A pulse is not homogeneous and the grains' response is not affine, so the test says only where
//! the mean increment pushes; that it predicts almost no sliding for compressive pulses in a
//! compressed packing while the replays show some is the point of printing it.
use grainwave_core::prelude::*;
use grainwave_experiments::e2::biaxial::read_full_checkpoint;
use grainwave_experiments::e2::model::{is_mobilised, sliding_drive};
use grainwave_experiments::e2::config::PulseShape;
use grainwave_experiments::e2::replay::{pulse_strain, Perturbation};
use std::collections::HashMap;
use std::path::PathBuf;

/// Grain–grain contacts (i, j) whose cap flag is set in some step of `steps`, with the first such
/// step (counted from 1).
fn flagged_over(sim: &mut Simulation<D2>, drive: &grainwave_experiments::e2::model::Drive, steps: u64) -> Result<HashMap<(u32, u32), u64>, Box<dyn std::error::Error>> {
    let mut seen = HashMap::new();
    for s in 1..=steps {
        drive.step(sim)?;
        for c in sim.contact_records() {
            if let (true, Counterpart::Grain(j)) = (c.sliding, c.j) {
                seen.entry((c.i, j)).or_insert(s);
            }
        }
    }
    Ok(seen)
}

/// Arrival time [t_a] by grain id from a replay's `aK_arrivals.csv` (`id,x,y,distance,arrival`).
fn read_arrivals(path: &str) -> Result<HashMap<u32, f64>, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(path)?;
    let mut out = HashMap::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if let (Some(id), Some(t)) = (f.first(), f.get(4)) {
            if let (Ok(id), Ok(t)) = (id.parse::<u32>(), t.parse::<f64>()) {
                out.insert(id, t);
            }
        }
    }
    Ok(out)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path: PathBuf = std::env::args().nth(1).ok_or("usage: e2_contact_state STATE.gwck")?.into();
    let ck = read_full_checkpoint(&path)?;
    let sim = &ck.sim;
    let snap = sim.snapshot();
    let mu = snap.law.friction;
    let records: Vec<_> = snap.contacts.iter().filter(|c| matches!(c.j, Counterpart::Grain(_))).collect();
    let index: std::collections::HashMap<u32, usize> = snap.id.iter().enumerate().map(|(k, &id)| (id, k)).collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for p in &snap.pos {
        x0 = x0.min(p.x);
        x1 = x1.max(p.x);
        y0 = y0.min(p.y);
        y1 = y1.max(p.y);
    }
    println!("state {}: {} grains, {} grain–grain contacts, μ = {mu}, strain (ε_xx, ε_yy) = ({:.4e}, {:.4e})", path.display(), snap.id.len(), records.len(), ck.strain.0, ck.strain.1);

    let margin = |c: &&ContactRecord<D2>| 1.0 - c.tangential_force.norm() / (mu * c.normal_force);
    let bounds = [1e-12, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2];
    let flagged = records.iter().filter(|c| c.sliding).count();
    print!("margin 1 − |F_t|/(μ F_n) ≤");
    for b in bounds {
        print!("  {b:.0e}: {}", records.iter().filter(|c| margin(c) <= b).count());
    }
    println!("  (cap flag: {flagged})");

    let mobilised: Vec<_> = records.iter().filter(|c| is_mobilised(c, mu)).collect();
    let drive = |c: &ContactRecord<D2>, e: [[f64; 2]; 2]| sliding_drive(c, mu, e);
    let (ex, ey) = ck.strain;
    let scale = ex.abs().max(ey.abs()).max(f64::MIN_POSITIVE);
    let cases: [(&str, [[f64; 2]; 2]); 5] = [
        ("right-wall pulse p_a > 0 (E = −e_x e_x)", [[-1.0, 0.0], [0.0, 0.0]]),
        ("right-wall pulse p_a < 0 (E = +e_x e_x)", [[1.0, 0.0], [0.0, 0.0]]),
        ("top-wall pulse p_a > 0 (E = −e_y e_y)", [[0.0, 0.0], [0.0, -1.0]]),
        ("top-wall pulse p_a < 0 (E = +e_y e_y)", [[0.0, 0.0], [0.0, 1.0]]),
        ("the loading's increment (E ∝ −the strain)", [[-ex / scale, 0.0], [0.0, -ey / scale]]),
    ];
    println!("mobilised (margin ≤ 1e-6): {}; pushed on (drive > 0) by", mobilised.len());
    for (name, e) in cases {
        let on = mobilised.iter().filter(|c| drive(c, e) > 0.0).count();
        println!("  {name}: {on} ({:.1} %)", 100.0 * on as f64 / mobilised.len().max(1) as f64);
    }

    let bins = 5;
    let at = |c: &ContactRecord<D2>| {
        let p = snap.pos[index[&c.i]] + c.normal * c.lever_i;
        (p.x, p.y)
    };
    let mut along_x = vec![0usize; bins];
    let mut along_y = vec![0usize; bins];
    let mut all_x = vec![0usize; bins];
    for c in &records {
        let (x, _) = at(c);
        all_x[(((x - x0) / (x1 - x0) * bins as f64) as usize).min(bins - 1)] += 1;
    }
    for c in &mobilised {
        let (x, y) = at(c);
        along_x[(((x - x0) / (x1 - x0) * bins as f64) as usize).min(bins - 1)] += 1;
        along_y[(((y - y0) / (y1 - y0) * bins as f64) as usize).min(bins - 1)] += 1;
    }
    println!("mobilised per fifth along x (left → right wall): {along_x:?} of all contacts {all_x:?}");
    println!("mobilised per fifth along y (bottom → top): {along_y:?}");
    let mean_cos = |v: &[&&ContactRecord<D2>]| v.iter().map(|c| c.normal.x.abs()).sum::<f64>() / v.len().max(1) as f64;
    let all: Vec<_> = records.iter().collect();
    println!("mean |n_x|: mobilised {:.3}, all contacts {:.3}", mean_cos(&mobilised), mean_cos(&all));

    // the split by distance from the pulsing wall and by orientation against the pulse's axis
    let along_pulse = ck.drive.pulse_wall == grainwave_experiments::e2::model::RIGHT;
    let distance_bin = |c: &ContactRecord<D2>| {
        let (x, y) = at(c);
        let d = if along_pulse { (x1 - x) / (x1 - x0) } else { (y1 - y) / (y1 - y0) };
        ((d * bins as f64) as usize).min(bins - 1)
    };
    let angles = 6;
    let angle_bin = |c: &ContactRecord<D2>| {
        let (a, b) = if along_pulse { (c.normal.x.abs(), c.normal.y.abs()) } else { (c.normal.y.abs(), c.normal.x.abs()) };
        ((b.atan2(a).to_degrees() / 15.0) as usize).min(angles - 1)
    };
    // rows: (kind, bin, from, to, [contacts, mobilised, pushed on by p_a > 0, by p_a < 0], slid per amplitude)
    let mut split: Vec<(&str, usize, f64, f64, [usize; 4], Vec<usize>)> = (0..bins)
        .map(|b| ("distance", b, b as f64 / bins as f64, (b + 1) as f64 / bins as f64, [0; 4], Vec::new()))
        .chain((0..angles).map(|b| ("orientation", b, 15.0 * b as f64, 15.0 * (b + 1) as f64, [0; 4], Vec::new())))
        .collect();
    let (e_plus, e_minus) = (pulse_strain(ck.drive.pulse_wall, 1.0), pulse_strain(ck.drive.pulse_wall, -1.0));
    for c in &records {
        let mob = is_mobilised(c, mu);
        for s in [distance_bin(c), bins + angle_bin(c)] {
            let n = &mut split[s].4;
            n[0] += 1;
            if mob {
                n[1] += 1;
                n[2] += usize::from(drive(c, e_plus) > 0.0);
                n[3] += usize::from(drive(c, e_minus) > 0.0);
            }
        }
    }

    let amplitudes: Vec<f64> = std::env::args().skip(2).map(|a| a.parse::<f64>()).collect::<Result<_, _>>()?;
    let span: f64 = std::env::var("E2_PULSE_TA").ok().map(|v| v.parse()).transpose()?.unwrap_or(2.0);
    let steps = (span * ck.units.acoustic_time / sim.dt).ceil() as u64;
    let arrival_files: Vec<String> = std::env::var("E2_ARRIVALS").map(|v| v.split(',').map(String::from).collect()).unwrap_or_default();
    let mut without: Option<HashMap<(u32, u32), u64>> = None;
    for (k, a) in amplitudes.into_iter().enumerate() {
        let e = pulse_strain(ck.drive.pulse_wall, a);
        let (on, off): (Vec<_>, Vec<_>) = mobilised.iter().partition(|c| drive(c, e) > 0.0);
        let key = |c: &&&&ContactRecord<D2>| match c.j {
            Counterpart::Grain(j) => (c.i, j),
            _ => unreachable!("grain–grain contacts only"),
        };
        if without.is_none() {
            let mut sim0 = sim.clone();
            without = Some(flagged_over(&mut sim0, &ck.drive, steps)?);
        }
        let mut sim1 = sim.clone();
        let mut drive1 = ck.drive.clone();
        // delivered in the first step, as the replays do (delay one step)
        let pulse = Perturbation::WallPulse { shape: PulseShape::Delta, time_unit: ck.units.time, delay: sim.dt, width: 0.0 };
        pulse.apply(&mut sim1, &mut drive1, a)?;
        let with = flagged_over(&mut sim1, &drive1, steps)?;
        let reference = without.as_ref().expect("set above");
        let arrivals = match arrival_files.get(k) {
            Some(path) => Some(read_arrivals(path)?),
            None => None,
        };
        // (slid, of which no later than the front's arrival at grain i, of which with an arrival,
        // contacts of the class with an arrival at grain i)
        let slid = |v: &[&&&ContactRecord<D2>]| {
            let mut n = [0usize; 4];
            for c in v {
                if arrivals.as_ref().is_some_and(|m| m.contains_key(&c.i)) {
                    n[3] += 1;
                }
                let Some(&first) = with.get(&key(c)) else { continue };
                if reference.contains_key(&key(c)) {
                    continue;
                }
                n[0] += 1;
                if let Some(t) = arrivals.as_ref().and_then(|m| m.get(&c.i)) {
                    n[2] += 1;
                    if first as f64 * sim.dt / ck.units.acoustic_time <= *t {
                        n[1] += 1;
                    }
                }
            }
            n
        };
        let (s_on, s_off) = (slid(&on), slid(&off));
        for row in split.iter_mut() {
            row.5.push(0);
        }
        for c in &records {
            let Counterpart::Grain(j) = c.j else { continue };
            if with.contains_key(&(c.i, j)) && !reference.contains_key(&(c.i, j)) {
                for s in [distance_bin(c), bins + angle_bin(c)] {
                    *split[s].5.last_mut().expect("pushed above") += 1;
                }
            }
        }
        let others = with.keys().filter(|q| !reference.contains_key(q)).count() - s_on[0] - s_off[0];
        println!(
            "pulse p_a = {a:e} t* over {span} t_a ({steps} steps): slid (cap flag in the pulsed copy only) {} of the {} pushed on, {} of the {} released, and {} contacts that were not mobilised",
            s_on[0],
            on.len(),
            s_off[0],
            off.len(),
            others
        );
        if arrivals.is_some() {
            println!(
                "  where the pulse arrived (grain i has an arrival): {} pushed on, {} released; slid no later than the front: {} and {}; slid later: {} and {}",
                s_on[3],
                s_off[3],
                s_on[1],
                s_off[1],
                s_on[2] - s_on[1],
                s_off[2] - s_off[1]
            );
        }
    }
    if let Ok(file) = std::env::var("E2_SPLIT_CSV") {
        let mut text = String::from("split,bin,from,to,contacts,mobilised,pushed_on_compression,pushed_on_rarefaction");
        for a in std::env::args().skip(2) {
            text.push_str(&format!(",slid_{a}"));
        }
        text.push('\n');
        for (kind, b, lo, hi, n, slid) in &split {
            text.push_str(&format!("{kind},{b},{lo},{hi},{},{},{},{}", n[0], n[1], n[2], n[3]));
            for s in slid {
                text.push_str(&format!(",{s}"));
            }
            text.push('\n');
        }
        std::fs::write(&file, text)?;
        println!("split by distance from the pulsing wall and by orientation: {file}");
    }
    Ok(())
}
