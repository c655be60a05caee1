//! The demo: an embedded `simulation` config (`examples/demo.toml`) — a gas of 300 polydisperse
//! disks settles under gravity in a box until static equilibrium, and the walls then carry the
//! whole weight.

use crate::config::ConfigSource;
use crate::error::Result;
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
