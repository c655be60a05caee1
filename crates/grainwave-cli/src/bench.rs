//! `grainwave bench`: throughput on the LAMMPS benchmark packings, optionally with LAMMPS run
//! back to back on the same case (see BENCHMARKS.md and docs/bench.md).

use anyhow::Result;
use clap::Args;
use grainwave_experiments::bench::{median, run_grainwave, run_lammps, write_results, BenchCase, BenchConfig, BenchResult, GrainOrder, LammpsCommand};
use std::path::PathBuf;

/// Arguments of `grainwave bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Cases to run: hertz3d, hooke3d, hooke2d, walled2d, piston2d, slab2d (default: the three
    /// LAMMPS cases).
    #[arg(value_name = "CASE", value_parser = parse_case)]
    pub cases: Vec<BenchCase>,

    /// Directory holding the packings (pack3d_062.data.gz, pack2d_084.data.gz) and the LAMMPS
    /// decks (bench3d.lmp, bench2d.lmp).
    #[arg(long, value_name = "DIR")]
    pub dir: PathBuf,

    /// Number of steps (default: 2000 for the 3D cases, 5000 for the 2D ones, as the decks).
    #[arg(long, value_name = "N")]
    pub steps: Option<u64>,

    /// Engineering shear rate of the periodic cell (LAMMPS `fix deform xy erate`), 0 = static.
    #[arg(long, value_name = "RATE", default_value_t = 0.0)]
    pub shear: f64,

    /// Storage order of grainwave's grains: `file` (as LAMMPS wrote them, binned in space),
    /// `sorted` (re-binned by grainwave) or `shuffled` (random, no locality).
    #[arg(long, value_name = "ORDER", default_value = "file", value_parser = parse_order)]
    pub order: GrainOrder,

    /// Vector path of grainwave's force pass: 0 portable, 1 the fused AVX2 pass, 2 the AVX-512
    /// windows, 3 the fused pass on 512-bit lanes (default; each where the processor has it).
    /// Results are the same bits on every path; this compares their speed.
    #[arg(long, value_name = "LEVEL", value_parser = clap::value_parser!(u8).range(0..=3))]
    pub simd: Option<u8>,

    /// Tile the periodic cases' packing NX × NY × NZ times (e.g. `4x4x2`: 1 024 000 spheres from
    /// the 32 000 of hertz3d and hooke3d); the same local structure at a larger size.
    #[arg(long, value_name = "NXxNYxNZ", default_value = "1x1x1", value_parser = parse_replicate)]
    pub replicate: [u32; 3],

    /// Runs per case (each from the file); medians are printed when more than one.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub repeat: u32,

    /// Also run LAMMPS (this executable, e.g. `lmp`) on the same case, alternating with grainwave.
    #[arg(long, value_name = "LMP")]
    pub lammps: Option<String>,

    /// MPI processes for LAMMPS (through `mpirun` when more than 1).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub lammps_procs: u32,

    /// Write every measurement to this JSON file.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

fn parse_order(s: &str) -> std::result::Result<GrainOrder, String> {
    GrainOrder::from_name(s).ok_or_else(|| format!("unknown order `{s}` (available: file, sorted, shuffled)"))
}

fn parse_replicate(s: &str) -> std::result::Result<[u32; 3], String> {
    let parts: Vec<&str> = s.split('x').collect();
    let bad = || format!("`{s}` is not NXxNYxNZ (three factors of at least 1, e.g. 4x4x2; 2D: NXxNYx1)");
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut n = [1u32; 3];
    for (k, p) in parts.iter().enumerate() {
        n[k] = p.trim().parse::<u32>().ok().filter(|&f| f >= 1).ok_or_else(bad)?;
    }
    Ok(n)
}

fn parse_case(s: &str) -> std::result::Result<BenchCase, String> {
    BenchCase::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = BenchCase::ALL.iter().map(|c| c.name()).collect();
        format!("unknown case `{s}` (available: {})", names.join(", "))
    })
}

/// Runs the benchmarks and prints one line per run, then the medians.
pub fn run(args: &BenchArgs, quiet: bool) -> Result<()> {
    if !args.shear.is_finite() {
        // a bad argument, like a bad config: exit code 2
        return Err(crate::BadInput(format!("invalid value '{}' for '--shear <RATE>': not a finite rate (allowed: a finite engineering shear rate, 0 = static)", args.shear)).into());
    }
    let cases = if args.cases.is_empty() { vec![BenchCase::Hertz3d, BenchCase::Hooke3d, BenchCase::Hooke2d] } else { args.cases.clone() };
    let lammps = args.lammps.as_ref().map(|exe| LammpsCommand { executable: exe.clone(), processes: args.lammps_procs as usize });
    let mut all: Vec<BenchResult> = Vec::new();
    let say = |r: &BenchResult| {
        if !quiet {
            say!(
                "{:<9} {:<8} shear {:<5} N {:>6} steps {:>5} workers {} | {:>8.3} s  {:>10.4e} particle-steps/s  {:>10.4e} contact-steps/s  contacts/grain {:.4}  rebuilds {:>4}  peak mem {:>6.1} MiB  KE {:.6e} {}",
                r.code,
                r.case,
                r.shear,
                r.grains,
                r.steps,
                r.workers,
                r.loop_seconds,
                r.particle_steps_per_second,
                r.contact_steps_per_second,
                r.contacts_per_grain,
                r.neighbor_rebuilds,
                r.peak_memory_bytes as f64 / (1024.0 * 1024.0),
                r.kinetic_energy,
                r.state_hash
            );
        }
    };
    for &case in &cases {
        let cfg = BenchConfig { case, dir: args.dir.clone(), steps: args.steps, shear: args.shear, order: args.order, simd: args.simd, replicate: args.replicate };
        for _ in 0..args.repeat {
            let r = rayon::scope(|_| run_grainwave(&cfg))?;
            say(&r);
            all.push(r);
            if let Some(lmp) = &lammps {
                let r = run_lammps(&cfg, lmp)?;
                say(&r);
                all.push(r);
            }
        }
    }
    if !quiet && args.repeat > 1 {
        say!("medians over {} runs:", args.repeat);
        for &case in &cases {
            let rate = |code: &str, per: fn(&BenchResult) -> f64| {
                let v: Vec<f64> = all.iter().filter(|r| r.code == code && r.case == case.name()).map(per).collect();
                median(&v)
            };
            let gw = rate("grainwave", |r| r.particle_steps_per_second);
            let gw_c = rate("grainwave", |r| r.contact_steps_per_second);
            if lammps.is_some() {
                let lmp = rate("lammps", |r| r.particle_steps_per_second);
                say!("  {:<8} grainwave {gw:.4e}  lammps {lmp:.4e}  ratio {:.3}  (grainwave {gw_c:.4e} contact-steps/s)", case.name(), gw / lmp);
            } else {
                say!("  {:<8} grainwave {gw:.4e}  ({gw_c:.4e} contact-steps/s)", case.name());
            }
        }
    }
    if let Some(path) = &args.json {
        write_results(path, &all)?;
    }
    Ok(())
}
