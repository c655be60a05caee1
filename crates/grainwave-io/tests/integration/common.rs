//! Helpers shared by the integration tests: scratch directories and calling Python readers.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A fresh, empty directory for one test (removed first if a previous run left it).
pub fn scratch_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("grainwave-io-it-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The Python interpreter (`$PYTHON`, default `python3`) if it can import every module in
/// `modules`; otherwise prints why the calling test is skipped and returns `None`.
///
/// The message goes straight to the process's standard error, which the test harness does not
/// capture, so `cargo test` shows it even when the test passes.
pub fn python_with(modules: &[&str]) -> Option<String> {
    let exe = std::env::var("PYTHON").unwrap_or_else(|_| "python3".to_string());
    let ok = Command::new(&exe).arg("-c").arg(format!("import {}", modules.join(", "))).output().map(|o| o.status.success()).unwrap_or(false);
    if ok {
        Some(exe)
    } else {
        // The PyPI package of an import: `vtkmodules.vtkIOXML` comes with `vtk`.
        fn package<'a>(m: &&'a str) -> &'a str {
            match m.split('.').next().unwrap_or(m) {
                "vtkmodules" => "vtk",
                top => top,
            }
        }
        let names = modules.iter().map(package).collect::<Vec<_>>().join(" ");
        let _ = writeln!(
            std::io::stderr().lock(),
            "skipped: {} not available (install with pip install {names})",
            modules.iter().map(package).collect::<Vec<_>>().join("/")
        );
        None
    }
}

/// Runs `script` with `args`, panicking with Python's error output if it fails; returns stdout.
pub fn run_python(exe: &str, script: &str, args: &[&Path]) -> String {
    let out = Command::new(exe).arg("-c").arg(script).args(args).output().expect("python runs");
    assert!(
        out.status.success(),
        "python failed ({}):\n--- stdout\n{}\n--- stderr\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("python prints UTF-8")
}

/// Lower-case hex of `bytes`.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

use glam::DVec2;
use grainwave_core::placement::triangular_lattice;
use grainwave_core::prelude::*;

fn hooke(partner: Partner, stiffness: f64) -> ContactLaw {
    let mut p = ContactParams::preset("hooke_cundall_strack");
    p.normal_stiffness = Some(stiffness);
    p.restitution = Some(0.3);
    p.build(partner, "contact").unwrap()
}

/// Three disks of radius 0.5 in a cell periodic along x ([0, 4)) above a floor at y = 0:
/// grain 0 at x = 0.2 touches grain 1 at x = 3.205 through the periodic boundary, both press on
/// the floor, and grain 2 sits on grain 0 — four contacts, two of them with the wall.
pub fn periodic_pile() -> Snapshot<D2> {
    let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    grains.push(DVec2::new(0.2, 0.495), 0.5, 1.0, DVec2::ZERO);
    grains.push(DVec2::new(3.205, 0.495), 0.5, 1.0, DVec2::new(0.1, 0.0));
    grains.push(DVec2::new(0.2, 1.49), 0.5, 1.0, DVec2::ZERO);
    grains.omega[2] = 0.25;
    let floor = Wall::axis_aligned("floor", 1, 0.0, true, hooke(Partner::Wall, 1e4));
    let domain = Domain::new(DVec2::new(0.0, 0.0), DVec2::new(4.0, 4.0), [true, false, false]).with_wall(floor);
    SimulationBuilder::new(grains, domain, hooke(Partner::Grain, 1e4)).build().unwrap().snapshot()
}

fn hertz(partner: Partner) -> ContactLaw {
    let mut p = ContactParams::preset("hertz_mindlin");
    p.young = Some(5000.0);
    p.poisson = Some(0.2);
    p.damping_fraction = Some(0.3);
    p.build(partner, "contact").unwrap()
}

/// A small pile settled under gravity: 96 disks (radii 0.4–0.5 from a fixed sequence) dropped
/// from a triangular lattice into a cell periodic along x (width 9.6) onto a floor at y = 0,
/// Hertz–Mindlin contacts (E = 5000, ν = 0.2, 30 % of critical damping), g = 1, integrated for
/// 25 time units — close to static equilibrium, with force chains, stiffnesses that vary with
/// the load, and contacts through the periodic boundary.
pub fn settled_pile() -> Snapshot<D2> {
    let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    let mut state = 12345u64;
    for [x, y] in triangular_lattice(12, 8, 1.2, [0.6, 0.6]) {
        // Weyl-sequence radii: deterministic, no RNG dependency.
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let u = (state >> 11) as f64 / (1u64 << 53) as f64;
        grains.push(DVec2::new(x, y), 0.4 + 0.1 * u, 1.0, DVec2::ZERO);
    }
    let floor = Wall::axis_aligned("floor", 1, 0.0, true, hertz(Partner::Wall));
    let domain = Domain::new(DVec2::new(0.0, 0.0), DVec2::new(9.6, 16.0), [true, false, false]).with_wall(floor);
    let mut sim = SimulationBuilder::new(grains, domain, hertz(Partner::Grain)).gravity(DVec2::new(0.0, -1.0)).build().unwrap();
    let stop = StopCriteria { time_limit: Some(25.0), ..Default::default() };
    sim.run(&stop, &mut |_| Control::Continue).unwrap();
    sim.snapshot()
}
