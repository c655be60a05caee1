//! The demo end to end on a small pile: equilibrium, force balance, and the files it writes.

use grainwave_experiments::demo::{run_demo, DemoConfig, DemoReport, GRAINS_FILE, SUMMARY_FILE};
use grainwave_experiments::{Control, StopReason};
use std::path::PathBuf;

/// 60 disks in a box 8 wide: about five layers, settles in a few thousand time units of the
/// contact period (well under a second in release mode).
fn small() -> DemoConfig {
    DemoConfig { grains: 60, box_width: 8.0, box_height: 25.0, gas_bottom: 4.0, ..Default::default() }
}

fn out_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("demo-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Reads grains.csv back as (header, rows of numbers).
fn read_grains(dir: &std::path::Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(dir.join(GRAINS_FILE)).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(str::to_string).collect();
    let rows = lines.map(|l| l.split(',').map(|x| x.parse::<f64>().unwrap()).collect::<Vec<f64>>()).collect();
    (header, rows)
}

#[test]
fn small_pile_settles_and_the_floor_carries_its_weight() {
    let cfg = small();
    let dir = out_dir("settles");
    let mut checks = 0u64;
    let report = run_demo(&cfg, &dir, &mut |_| {
        checks += 1;
        Control::Continue
    })
    .unwrap();

    assert_eq!(report.stop_reason, StopReason::Converged, "{report:#?}");
    assert_eq!(report.grains, 60);
    assert_eq!(report.steps, checks * cfg.stop.check_every, "the observer sees every check");
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
    // The run stops when KE/grain < 1e-12 and every |a_i| < 1e-7 g.
    assert!(report.kinetic_energy_per_grain < 1e-12, "{}", report.kinetic_energy_per_grain);
    assert!((report.kinetic_energy / 60.0 - report.kinetic_energy_per_grain).abs() <= 1e-15 * report.kinetic_energy_per_grain.max(1e-300));
    // |F_floor/W − 1| ≤ Σ m|a_y| / (Σ m g) ≤ max|a| / g < 1e-7 (see the module docs); 1e-6 leaves
    // room for the difference between the last force evaluation and the final state.
    assert!((report.floor_force_over_weight - 1.0).abs() < 1e-6, "floor/weight = {}", report.floor_force_over_weight);
    // Horizontal balance: the side walls differ by the shear force on the floor.
    let w = &report.wall_loads;
    assert!((w.left - w.right - report.floor_shear_force).abs() < 1e-6 * report.total_weight, "{w:?} {}", report.floor_shear_force);
    assert!(w.left > 0.0 && w.right > 0.0, "the pile pushes the side walls apart: {w:?}");
    assert_eq!(w.top, 0.0, "nothing touches the top wall");
    // A pile of 60 disks (area ≈ 47.6) at a packing fraction between 0.7 and 0.9 on a floor 8
    // wide is 6.6 to 8.5 high.
    assert!((6.6..8.5).contains(&report.pile_height), "pile height {}", report.pile_height);
    assert!(report.contacts.grain_grain > 60, "{:?}", report.contacts);

    // summary.json is the report.
    let text = std::fs::read_to_string(dir.join(SUMMARY_FILE)).unwrap();
    let back: DemoReport = serde_json::from_str(&text).unwrap();
    assert_eq!(back, report);
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json["stop_reason"], "converged");
    assert_eq!(json["dimension"], "2d");
    assert_eq!(json["grainwave_version"], grainwave_experiments::VERSION);
    assert_eq!(json["config"]["grains"], 60);

    // grains.csv: one row per grain; its numbers give the same weight and floor force.
    let (header, rows) = read_grains(&dir);
    assert_eq!(header, ["id", "x", "y", "vx", "vy", "omega", "radius", "mass", "fx", "fy"]);
    assert_eq!(rows.len(), 60);
    let mut ids: Vec<u32> = rows.iter().map(|r| r[0] as u32).collect();
    ids.sort_unstable();
    assert_eq!(ids, (0..60).collect::<Vec<u32>>());
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let weight: f64 = rows.iter().map(|r| r[col("mass")] * cfg.gravity).sum();
    assert!((weight - report.total_weight).abs() <= 1e-12 * weight);
    // Σ f_y = F_floor − W: the floor force seen through the grains' total forces.
    let sum_fy: f64 = rows.iter().map(|r| r[col("fy")]).sum();
    assert!((weight + sum_fy - report.floor_force).abs() <= 1e-9 * weight, "Σfy = {sum_fy}");
    for r in &rows {
        let (x, y, radius) = (r[col("x")], r[col("y")], r[col("radius")]);
        assert!((0.4..=0.6).contains(&radius));
        // Inside the box, up to the small overlap with the walls.
        assert!(x > radius * 0.99 && x < cfg.box_width - radius * 0.99 && y > radius * 0.99, "{r:?}");
    }
}

#[test]
fn stopping_early_still_writes_the_outputs() {
    let cfg = small();
    let dir = out_dir("interrupted");
    let report = run_demo(&cfg, &dir, &mut |p| if p.step >= 1000 { Control::Stop } else { Control::Continue }).unwrap();
    assert_eq!(report.stop_reason, StopReason::Interrupted);
    assert_eq!(report.steps, 1000);
    let back: DemoReport = serde_json::from_str(&std::fs::read_to_string(dir.join(SUMMARY_FILE)).unwrap()).unwrap();
    assert_eq!(back.stop_reason, StopReason::Interrupted);
    assert_eq!(read_grains(&dir).1.len(), 60);
    // Still falling: far from equilibrium.
    assert!(report.kinetic_energy_per_grain > 1e-3, "{}", report.kinetic_energy_per_grain);
}

#[test]
fn same_seed_same_result_other_seed_other_result() {
    let mut cfg = small();
    cfg.stop.step_limit = Some(3000);
    let run = |cfg: &DemoConfig, name: &str| {
        let dir = out_dir(name);
        run_demo(cfg, &dir, &mut |_| Control::Continue).unwrap();
        std::fs::read_to_string(dir.join(GRAINS_FILE)).unwrap()
    };
    let a = run(&cfg, "seed-a");
    let b = run(&cfg, "seed-b");
    assert_eq!(a, b, "two runs with the same seed must agree bit for bit");
    cfg.seed += 1;
    assert_ne!(run(&cfg, "seed-c"), a);
}
