//! The config reference (docs/config.md) is generated from the key definitions of every study,
//! the output reference (docs/outputs.md) from their output declarations.

use std::path::Path;

#[test]
fn config_reference_is_up_to_date() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/config.md");
    let fresh = grainwave_experiments::registry::reference_markdown();
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    if std::env::var("GRAINWAVE_BLESS").is_ok() {
        std::fs::write(&path, &fresh).unwrap();
        return;
    }
    assert!(
        on_disk == fresh,
        "docs/config.md is stale: regenerate it with `cargo run --release -- reference > docs/config.md` \
         (or GRAINWAVE_BLESS=1 cargo test -p grainwave-experiments --release config_reference)"
    );
    for key in ["normal_stiffness", "restitution", "check_every", "series_every", "pressure", "distribution"] {
        assert!(fresh.contains(key), "reference mentions `{key}`");
    }
}

#[test]
fn output_reference_is_up_to_date() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/outputs.md");
    let fresh = grainwave_experiments::registry::outputs_markdown();
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    if std::env::var("GRAINWAVE_BLESS").is_ok() {
        std::fs::write(&path, &fresh).unwrap();
        return;
    }
    assert!(
        on_disk == fresh,
        "docs/outputs.md is stale: regenerate it with `cargo run --release -- reference --outputs > docs/outputs.md` \
         (or GRAINWAVE_BLESS=1 cargo test -p grainwave-experiments --release output_reference)"
    );
    // a section per study, each with the common files and its own
    for p in grainwave_experiments::registry::PROTOCOLS.iter() {
        let section = fresh.split(&format!("## `experiment = \"{}\"`", p.name)).nth(1).unwrap_or_else(|| panic!("no section for {}", p.name));
        let section = section.split("\n## ").next().unwrap();
        assert!(section.contains("`summary.json`") && section.contains("`config.resolved.toml`"), "{}: {section}", p.name);
        assert_eq!(section.lines().filter(|l| l.starts_with("| `")).count(), p.outputs.len(), "{}", p.name);
    }
    assert!(fresh.contains("`replays/<name>/a<k>_arrivals.csv`") && fresh.contains("`series.csv`"));
}

/// Every study's output declarations are well-formed and distinct.
#[test]
fn output_declarations_are_well_formed() {
    for p in grainwave_experiments::registry::PROTOCOLS.iter() {
        assert!(!p.outputs.is_empty(), "{} declares no outputs", p.name);
        for (k, o) in p.outputs.iter().enumerate() {
            assert_eq!(grainwave_experiments::outputs::pattern_problem(o.pattern), None, "{}", p.name);
            assert!(!o.description.is_empty(), "{}: {} has no description", p.name, o.pattern);
            assert!(p.outputs[..k].iter().all(|q| q.pattern != o.pattern), "{}: {} declared twice", p.name, o.pattern);
        }
        for common in grainwave_experiments::outputs::COMMON {
            assert!(p.outputs.contains(&common), "{} does not declare {}", p.name, common.pattern);
        }
    }
}

/// `grainwave inspect` finds a run directory's protocol by its `config.resolved.toml` (or its
/// checkpoint): a directory that names none has no protocol.
#[test]
fn a_run_directory_is_attributed_by_its_resolved_config() {
    let dir = std::env::temp_dir().join(format!("grainwave-of-directory-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let registry = &grainwave_experiments::registry::REGISTRY;
    assert!(registry.of_directory(&dir).is_none(), "an empty directory");
    let config = dir.join("config.resolved.toml");
    std::fs::write(&config, "# header\nexperiment = \"e2\"\nseed = 5\n").unwrap();
    assert_eq!(registry.of_directory(&dir).map(|e| e.name), Some("e2"));
    std::fs::write(&config, "experiment = \"e9\"\n").unwrap();
    assert!(registry.of_directory(&dir).is_none(), "an unknown experiment");
    std::fs::write(&config, "experiment = [\n").unwrap();
    assert!(registry.of_directory(&dir).is_none(), "a config that is not TOML");
    std::fs::remove_dir_all(&dir).unwrap();
}
