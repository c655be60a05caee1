//! The config reference (docs/config.md) is generated from the key definitions of every study.

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
