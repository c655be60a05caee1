//! Trace of an E1 preparation (SPEC §5.1, the reference size: 618 `sphere2d` grains, 24 wide,
//! μ = 0.5): every `every` steps, the kinetic energy per grain, the largest and mean grain
//! acceleration, contacts, sliding contacts, the piston's height and acceleration, the contact
//! count of the grain with the largest acceleration, and the share of the kinetic energy in the
//! most energetic grain with its contact count (0: a rattler in flight). It runs the preparation
//! itself (`e1::prepare::relax`, tail time step included), so it shows where its steps go.
//!
//! ```text
//! cargo run --release -p grainwave-experiments --example e1_relax_trace -- [pressure] [seed] [every] [tail_dt_factor]
//! ```
//! Defaults: 1e-4, 1, 10000, the default factor (1 gives the plain preparation).
use grainwave_core::prelude::*;
use grainwave_experiments::e1::config::PreparationConfig;
use grainwave_experiments::e1::prepare::{build_gas, relax, PackingSpec, PreparationInfo};
use std::collections::HashMap;
use std::sync::atomic::AtomicBool;

fn trace_line(sim: &Simulation<D2>) -> String {
    let stop = StopCriteria { step_limit: Some(u64::MAX), ..Default::default() };
    let p = sim.progress(&stop);
    let piston = &sim.domain.walls[1];
    let snap = sim.snapshot();
    let n = snap.id.len();
    let mut degree = HashMap::<u32, usize>::new();
    for c in &snap.contacts {
        *degree.entry(c.i).or_default() += 1;
        if let Counterpart::Grain(j) = c.j {
            *degree.entry(j).or_default() += 1;
        }
    }
    let deg = |k: usize| degree.get(&snap.id[k]).copied().unwrap_or(0);
    let acc = |k: usize| (snap.force[k].norm() / snap.mass[k]).max(snap.torque[k].norm() * snap.radius[k] / snap.inertia[k]);
    let ke = |k: usize| 0.5 * snap.mass[k] * snap.vel[k].dot(snap.vel[k]);
    let k_acc = (0..n).max_by(|&a, &b| acc(a).total_cmp(&acc(b))).unwrap_or(0);
    let k_ke = (0..n).max_by(|&a, &b| ke(a).total_cmp(&ke(b))).unwrap_or(0);
    let ke_total: f64 = (0..n).map(ke).sum();
    format!(
        "{},{:.6e},{:.4e},{:.3e},{:.3e},{:.3e},{},{},{:.7},{:.3e},{},{:.3},{}",
        p.step,
        p.time,
        sim.dt,
        p.kinetic_energy_per_grain,
        p.max_acceleration,
        p.mean_acceleration,
        p.contacts,
        p.sliding,
        piston.position.y,
        piston.accel.abs(),
        deg(k_acc),
        ke(k_ke) / ke_total.max(f64::MIN_POSITIVE),
        deg(k_ke)
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let arg = |i: usize| args.get(i).map(String::as_str);
    let pressure: f64 = arg(1).map_or(Ok(1e-4), str::parse)?;
    let seed: u64 = arg(2).map_or(Ok(1), str::parse)?;
    let every: u64 = arg(3).map_or(Ok(10_000), str::parse)?;
    let mut preparation = PreparationConfig::default();
    if let Some(f) = arg(4) {
        preparation.tail_dt_factor = f.parse()?;
    }
    if every == 0 || every % preparation.check_every != 0 {
        return Err(format!("every = {every} (allowed: a positive multiple of check_every = {})", preparation.check_every).into());
    }
    let spec = PackingSpec { grains: 618, width: 24.0, spread: 0.2, friction: 0.5, poisson: 0.0, pressure, seed, preparation };
    let mut sim = build_gas::<D2>(&spec)?;
    println!("step,time,dt,ke_per_grain,max_acc,mean_acc,contacts,sliding,piston_height,piston_acc,max_acc_grain_contacts,top_ke_share,top_ke_grain_contacts");
    let mut info = PreparationInfo::default();
    // `save` is called at every chunk boundary (save_every = 0): the trace's hook
    let mut trace = |s: &Simulation<D2>, _: &PreparationInfo| {
        if s.step % every == 0 {
            println!("{}", trace_line(s));
        }
        Ok(())
    };
    relax(&mut sim, &mut info, &spec.preparation, pressure, &AtomicBool::new(false), 0.0, &mut trace)?;
    println!("{}", trace_line(&sim));
    eprintln!("converged at step {} (tail time step from step {:?})", info.steps, info.tail_step);
    Ok(())
}
