//! The demo: an embedded `e1` config (`examples/demo.toml`) — about 200 `sphere2d` grains are
//! compressed by a piston at p = 1e-4 until static equilibrium, characterized, their elastic moduli
//! computed, and the pulse emitted by the bottom wall is followed to the top wall (docs/demo.md).

use crate::config::ConfigSource;
use crate::Result;
use crate::protocol::RunContext;
use crate::registry::{self, RunSummary};

/// The demo's config (the text of `examples/demo.toml`).
pub const DEMO_CONFIG: &str = include_str!("../../../examples/demo.toml");

/// The demo's config as a source.
pub fn source() -> ConfigSource {
    ConfigSource::from_text("embedded demo config (examples/demo.toml)", DEMO_CONFIG)
}

/// Runs the demo into `ctx`'s output directory.
pub fn run_demo(ctx: &mut RunContext<'_>) -> Result<RunSummary> {
    registry::run(&source(), ctx)
}
