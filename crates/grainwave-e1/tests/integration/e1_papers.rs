//! The E1 configs of `examples/papers/` (full-size studies, not run by the suite) are valid and
//! follow the published protocol (SPEC §5.1): no velocity quenching in any preparation (except the
//! `-quench-on` twin of the preparation-cost comparison, identical to its `-quench-off` twin but
//! for `quench`); the
//! lattices measure c_tof between L ≈ 8 and 25 and come frictional and frictionless; the exponent
//! series spans at least a factor 5 in height.

use grainwave_study::config::ConfigSource;
use grainwave_e1 as e1;
use std::path::Path;

#[test]
fn e1_paper_configs_follow_the_published_protocol() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/papers");
    let mut checked = 0;
    let mut lattices = Vec::new();
    let mut quench_twins = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let path = e.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if !(name.starts_with("e1-") && name.ends_with(".toml")) {
            continue;
        }
        let src = ConfigSource::from_file(&path).unwrap();
        let plan = e1::prepare(&src).unwrap_or_else(|e| panic!("{name}: {e}"));
        if plan.config.preparation.quench {
            // the one allowed use: the cost comparison, a `-quench-on` twin of a published-protocol
            // config that differs from it in `quench` alone
            let twin_name = name.strip_suffix("-quench-on.toml").map(|stem| format!("{stem}-quench-off.toml"));
            let twin_name = twin_name.unwrap_or_else(|| panic!("{name}: the published protocol has no quenching (SPEC §5.1)"));
            let twin = e1::prepare(&ConfigSource::from_file(&dir.join(&twin_name)).unwrap()).unwrap_or_else(|e| panic!("{twin_name}: {e}"));
            assert!(!twin.config.preparation.quench, "{twin_name}: the twin of {name} must not quench");
            let mut flipped = twin.config.clone();
            flipped.preparation.quench = true;
            assert_eq!(toml::to_string(&flipped).unwrap(), toml::to_string(&plan.config).unwrap(), "{name} and {twin_name} must differ in `quench` only");
            quench_twins += 1;
        }
        if let Some(l) = &plan.config.lattice {
            lattices.push(l.friction);
            // c_tof between the heights closest to 8 and 25: the groups must contain them
            let heights: Vec<f64> = plan.groups.iter().map(|g| g.estimated_height).collect();
            for target in [8.0, 25.0] {
                assert!(heights.iter().any(|h| (h - target).abs() < 1.0), "{name}: no lattice height near {target}: {heights:?}");
            }
        }
        if name == "e1-exponents.toml" {
            let h = plan.config.packing.as_ref().unwrap().heights.clone().unwrap();
            let span = h.iter().cloned().fold(0.0, f64::max) / h.iter().cloned().fold(f64::INFINITY, f64::min);
            assert!(span >= 5.0 && plan.config.samples >= 20 && plan.config.pulse.bootstrap > 0, "{name}: span {span}");
        }
        checked += 1;
    }
    assert!(checked >= 5, "only {checked} E1 paper configs");
    assert!(quench_twins <= 1, "{quench_twins} quenching configs");
    assert!(lattices.contains(&0.0) && lattices.contains(&0.5), "lattices: frictionless and frictional (μ = 0.5) wanted, got {lattices:?}");
}
