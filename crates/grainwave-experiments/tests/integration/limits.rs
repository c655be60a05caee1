//! The resource limits checked at validation time: hard, soft, and the message naming the flag
//! that lifts the soft ones.

use grainwave_experiments::config::ConfigSource;
use grainwave_experiments::limits::{available_memory, check, BYTES_PER_GRAIN, HARD_MAX_GRAINS, MAX_GRAINS};

#[test]
fn hard_soft_and_lifted() {
    let src = ConfigSource::from_text("t.toml", "[grains]\ncount = 4000000000\n");
    let e = check(&src, "grains.count", "grains", 5.0e9, MAX_GRAINS, HARD_MAX_GRAINS, 0.0).unwrap_err();
    assert_eq!(e.key.as_deref(), Some("grains.count"));
    assert!(e.message.contains("not representable"), "{}", e.message);
    // soft limit: refused and the message names the flag that lifts it
    let e = check(&src, "grains.count", "grains", 2.0e7, MAX_GRAINS, HARD_MAX_GRAINS, 0.0).unwrap_err();
    assert!(e.message.contains("--allow-large"), "{}", e.message);
    // memory: 1e18 bytes exceed any machine, even with the soft limits lifted
    if available_memory().is_some() {
        let e = check(&src, "grains.count", "grains", 1.0e6, MAX_GRAINS, HARD_MAX_GRAINS, 1.0e12).unwrap_err();
        assert!(e.message.contains("of memory"), "{}", e.message);
    }
    assert!(check(&src, "grains.count", "grains", 1.0e6, MAX_GRAINS, HARD_MAX_GRAINS, BYTES_PER_GRAIN).is_ok());
}
