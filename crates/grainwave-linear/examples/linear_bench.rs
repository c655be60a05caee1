//! Timings of the linear analysis, recorded in BENCHMARKS.md ("Linear analysis").
//!
//! ```text
//! cargo run -p grainwave-linear --release --example linear_bench -- modes 600
//! cargo run -p grainwave-linear --release --example linear_bench -- modes 2000
//! cargo run -p grainwave-linear --release --example linear_bench -- transit 100000
//! cargo run -p grainwave-linear --release --example linear_bench -- lattice 100000
//! ```
//!
//! `modes N`: an E1 packing of N `sphere2d` Hertz–Mindlin grains (p = 1e-4, μ = 0.5, square box,
//! prepared with grainwave-core as in the tests), then assembly of D, all modes, the modal signal
//! on 2 000 times over two transits, and, for comparison, direct propagation over the same window.
//!
//! `transit N`: the same kind of packing (gas at area fraction 0.45 compressed by 6000 time units
//! of damped MD under 10 × the piston force, then quenched under p = 1e-4 for at most 20 000 steps
//! or to max acceleration < 1e-7: the contact network is what matters for the cost, not the last
//! digits of the force balance), then direct propagation of pulse A from the bottom wall until the
//! first zero crossing after the first peak of the top-wall signal — one transit.
//!
//! `lattice N`: the same propagation across the triangular reference lattice of √N × √N balls
//! (built in exact equilibrium, nothing to prepare).
//!
//! Prepared packings are cached as grainwave-core checkpoints in `target/linear-bench/`.

#[path = "../tests/integration/common.rs"]
mod common;

use common::*;
use grainwave_analysis::signal::{pulse_metrics, PulseOptions};
use grainwave_core::prelude::*;
use grainwave_linear::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// An E1 packing of `n` grains in a square box relaxed to max acceleration < `tol`. With
/// `settle`, the gas (area fraction `gas`) is first compressed by plain damped MD for that long
/// (quenching from the start would stop the falling piston at every collision), then quenched.
fn packing(n: usize, tol: f64, gas: f64, settle: Option<f64>) -> Simulation<D2> {
    let width = (n as f64).sqrt().round();
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/linear-bench");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("packing_{n}_{tol:e}.ckpt"));
    if let Ok(sim) = Simulation::<D2>::load_checkpoint(&path) {
        eprintln!("packing: loaded {}", path.display());
        return sim;
    }
    let spec = PackingSpec { max_acceleration: tol, gas_fraction: gas, ..PackingSpec::e1(n, width, 1) };
    let t = Instant::now();
    let mut last = Instant::now();
    let mut sim = common::gas(&spec);
    let set_piston_force = |sim: &mut Simulation<D2>, f: f64| {
        if let WallMotion::Piston { force, .. } = &mut sim.domain.walls[1].motion {
            *force = TimeFunction::constant(f);
        }
    };
    if let Some(t_settle) = settle {
        // A piston under p = 1e-4 sweeps a dense gas slowly (v ≈ √(F/mass per unit height), ≈ 0.02
        // diameters per time unit here): compress under 10 p, then relax under p.
        let target = spec.pressure * spec.width;
        set_piston_force(&mut sim, 10.0 * target);
        let stop = StopCriteria { time_limit: Some(t_settle), check_every: 500, ..Default::default() };
        sim.run(&stop, &mut |p| {
            if last.elapsed().as_secs_f64() > 30.0 {
                eprintln!("  compression: step {:>8}, t = {:9.1}, KE/grain {:.2e}, max acceleration {:.2e}", p.step, p.time, p.kinetic_energy_per_grain, p.max_acceleration);
                last = Instant::now();
            }
            Control::Continue
        })
        .unwrap();
        eprintln!("  compressed to height {:.2} in {:.1} s", sim.domain.walls[1].position.y, t.elapsed().as_secs_f64());
        set_piston_force(&mut sim, target);
        sim.refresh_forces().unwrap();
    }
    // large packings creep for a long time under quenching: stop after `cap` steps and say so
    let cap = if settle.is_some() { 20_000 } else { 20_000_000 };
    let mut reached = f64::INFINITY;
    let outcome = relax(&mut sim, tol, cap, &mut |sim, acc| {
        reached = acc;
        if last.elapsed().as_secs_f64() > 30.0 {
            eprintln!("  relaxation: step {:>8}, t = {:9.1}, max acceleration {acc:.2e}, top wall at {:.2}", sim.step, sim.time, sim.domain.walls[1].position.y);
            last = Instant::now();
        }
    });
    if outcome.is_err() {
        eprintln!("  relaxation stopped after {cap} steps at max acceleration {reached:.2e} (tolerance {tol:e})");
    }
    eprintln!("packing: {n} grains, width {width}, prepared in {:.1} s ({} steps)", t.elapsed().as_secs_f64(), sim.step);
    sim.save_checkpoint(&path).unwrap();
    sim
}

fn modes(n: usize) {
    let sim = packing(n, 1e-10, 0.3, None);
    let t = Instant::now();
    let snap = sim.snapshot();
    let t_snap = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let dm = DynamicalMatrix::assemble(&snap, &AssemblyOptions::default()).unwrap();
    let system = dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap();
    let t_assembly = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let modes = Modes::compute(&system, &EigenOptions::default()).unwrap();
    let t_modes = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let source = source_vector(&dm, &system, 0).unwrap();
    let detector = detector_vector(&dm, &system, 1).unwrap();
    let state = InitialCondition::Impulse { strength: 1.0 }.state(&system, &source).unwrap();
    let modal = ModalSignal::new(&modes, &state, &detector.vector).unwrap();
    let height = snap.domain.walls[1].position.y - snap.domain.walls[0].position.y;
    // two transits at the speed of a chain of mean grains (upper bound of the pulse speed)
    let window = 2.0 * height / 0.25;
    let times: Vec<f64> = (0..2000).map(|k| window * k as f64 / 1999.0).collect();
    let f = modal.eval_many(&times);
    let t_signal = t.elapsed().as_secs_f64();
    let m = pulse_metrics(&times, &f, &PulseOptions::default()).unwrap();
    let t = Instant::now();
    let direct = propagate_signal(&system, system.mass(), &state, &detector.vector, &times, &PropagationOptions::default()).unwrap();
    let t_direct = t.elapsed().as_secs_f64();
    let diff = f.iter().zip(&direct.values).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt() / f.iter().map(|a| a * a).sum::<f64>().sqrt();
    println!("modes {n}: {} grains, {} contacts, {} dofs, nnz(D) = {}, threads {}", snap.len(), snap.contacts.len(), system.dofs(), system.stiffness().val().len(), rayon::current_num_threads());
    println!("  snapshot {t_snap:.3} s | assembly (CSR + free system) {t_assembly:.3} s | all modes {t_modes:.2} s | modal signal, 2000 times {t_signal:.3} s | total {:.2} s", t_snap + t_assembly + t_modes + t_signal);
    println!("  first peak t = {:.1}, leading edge {:.1}; direct propagation of the same window: {:.2} s ({} steps), relative L2 difference {diff:.1e}", m.peak_time, m.leading_edge_time, t_direct, direct.steps);
}

fn transit(n: usize) {
    let sim = packing(n, 1e-7, 0.45, Some(6000.0));
    transit_of(&format!("transit {n}"), &sim.snapshot());
}

/// The triangular reference lattice (SPEC §5.6) of ≈ n Hertz–Mindlin `sphere2d` balls (√n rows of
/// √n), p = 1e-4, μ = 0.5: built in exact equilibrium, no preparation.
fn lattice(n: usize) {
    let side = (n as f64).sqrt().round() as usize;
    let spec = grainwave_linear::reference::TriangularLatticeSpec { rows: side, columns: side, ..Default::default() };
    let t = Instant::now();
    let sim = spec.build().unwrap();
    eprintln!("lattice {side} × {side} built in {:.1} s", t.elapsed().as_secs_f64());
    transit_of(&format!("lattice {}", side * side), &sim.snapshot());
}

fn transit_of(name: &str, snap: &Snapshot<D2>) {
    let t = Instant::now();
    let dm = DynamicalMatrix::assemble(snap, &AssemblyOptions::default()).unwrap();
    let system = dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap();
    let t_assembly = t.elapsed().as_secs_f64();
    let source = source_vector(&dm, &system, 0).unwrap();
    let detector = detector_vector(&dm, &system, 1).unwrap();
    let state = InitialCondition::Impulse { strength: 1.0 }.state(&system, &source).unwrap();
    let height = snap.domain.walls[1].position.y - snap.domain.walls[0].position.y;
    for (label, scheme, spp) in [("4th-order Blanes–Moan, 20 steps/period", Scheme::BlanesMoan4, 20.0), ("velocity Verlet, 60 steps/period", Scheme::VelocityVerlet, 60.0)] {
        let t = Instant::now();
        let opts = PropagationOptions { scheme, steps_per_period: spp, ..Default::default() };
        let mut p = Propagator::new(&system, system.mass(), &state, None, &opts).unwrap();
        let t_setup = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let (mut times, mut values) = (Vec::new(), Vec::new());
        let dt_out = 1.0;
        let t_max = 4.0 * height / 0.25;
        let mut peak: f64 = 0.0;
        let mut end = None;
        let mut k = 0;
        while end.is_none() && (k as f64) * dt_out < t_max {
            k += 1;
            let tk = k as f64 * dt_out;
            p.advance_to(tk).unwrap();
            let f: f64 = p.displacement().iter().zip(&detector.vector).map(|(a, b)| a * b).sum();
            peak = peak.max(f);
            // no pulse outruns 0.4 diameters per time unit (a chain of mean grains: 0.25; measured
            // leading edges: ≈ 0.29), so earlier sign changes are precursor noise
            if tk > height / 0.4 && peak > 0.0 && f <= 0.0 && values.iter().any(|&v| v > 0.5 * peak) {
                end = Some(tk);
            }
            times.push(tk);
            values.push(f);
        }
        let wall = t.elapsed().as_secs_f64();
        let m = pulse_metrics(&times, &values, &PulseOptions::default()).unwrap();
        let steps = p.steps();
        let products = steps * scheme.stages() as u64;
        println!("{name} ({label}): {} grains, {} contacts, {} dofs, nnz(D) = {}, height {height:.1}, threads {}", snap.len(), snap.contacts.len(), system.dofs(), system.stiffness().val().len(), rayon::current_num_threads());
        println!(
            "  assembly {t_assembly:.2} s, ω_max estimate {t_setup:.2} s (ω_max ≈ {:.4}); transit to t = {:.1} (first zero crossing after the peak; peak t = {:.1}, edge {:.1}): {wall:.1} s, {steps} steps, {products} products with D, {:.2} ms per product",
            p.spectral_bound().estimate.sqrt(),
            times.last().unwrap(),
            m.peak_time,
            m.leading_edge_time,
            1e3 * wall / products as f64
        );
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let what = args.get(1).map(String::as_str).unwrap_or("modes");
    let n: usize = args.get(2).map_or(600, |s| s.parse().expect("grain count"));
    match what {
        "modes" => modes(n),
        "transit" => transit(n),
        "lattice" => lattice(n),
        "prepare" => {
            packing(n, 1e-7, 0.45, Some(6000.0));
        }
        _ => eprintln!("usage: linear_bench modes|transit|lattice|prepare N"),
    }
}
