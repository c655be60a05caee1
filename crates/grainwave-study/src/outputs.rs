//! The outputs every protocol writes the same way: the resolved config and the summary.
//!
//! * `config.resolved.toml` ([`write_resolved_config`]): the config of the run with every default
//!   filled in, under a comment header naming the protocol and the engine version. `grainwave
//!   resume` compares it with the config a checkpoint carries (`registry::belongs_to`).
//! * `summary.json` ([`write_summary`]): the protocol's typed report, written atomically.

use crate::error::Result;
use serde::Serialize;
use std::path::Path;

/// Name of the resolved config in an output directory.
pub const RESOLVED_CONFIG_FILE: &str = "config.resolved.toml";
/// Name of the summary (the report as JSON) in an output directory.
pub const SUMMARY_FILE: &str = "summary.json";

/// Writes `config.resolved.toml` into `out` (atomically): a header naming the protocol
/// `experiment` and the engine version, then `note` (lines of comment about keys whose values
/// are computed during the run; empty when there is none), then `config` as TOML.
pub fn write_resolved_config<C: Serialize>(out: &Path, experiment: &str, config: &C, note: &str) -> Result<()> {
    let text = resolved_config_text(experiment, config, note);
    grainwave_core::checkpoint::atomic_write(&out.join(RESOLVED_CONFIG_FILE), text.as_bytes())?;
    Ok(())
}

/// The text of `config.resolved.toml` ([`write_resolved_config`]).
pub fn resolved_config_text<C: Serialize>(experiment: &str, config: &C, note: &str) -> String {
    let text = toml::to_string_pretty(config).expect("a config serializes to TOML");
    let mut header = format!("# The config of this {experiment} run with every default filled in (grainwave {}).\n", grainwave_core::VERSION);
    for line in note.lines() {
        header.push_str(&format!("# {line}\n"));
    }
    header.push_str("# Running it again gives the same results, bit for bit.\n\n");
    format!("{header}{text}")
}

/// Writes the report `report` as `summary.json` into `out` (atomically).
pub fn write_summary<R: Serialize>(out: &Path, report: &R) -> Result<()> {
    grainwave_io::write_json_atomic(&out.join(SUMMARY_FILE), report)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize, serde::Deserialize, PartialEq, Debug)]
    struct Example {
        seed: u64,
        friction: f64,
        label: String,
    }

    #[test]
    fn the_resolved_config_reads_back_as_the_config_under_its_header() {
        let c = Example { seed: 7, friction: 0.5, label: "a".into() };
        let text = resolved_config_text("e3", &c, "Keys left out are computed per parameter set.\nSee docs/e3.md.");
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[0].starts_with("# The config of this e3 run") && lines[0].contains(grainwave_core::VERSION), "{text}");
        assert_eq!(lines[1], "# Keys left out are computed per parameter set.");
        assert_eq!(lines[2], "# See docs/e3.md.");
        assert_eq!(lines[3], "# Running it again gives the same results, bit for bit.");
        let back: Example = toml::from_str(&text).unwrap();
        assert_eq!(back, c);
        // no note: the header is two lines
        let plain = resolved_config_text("simulation", &c, "");
        assert_eq!(plain.lines().filter(|l| l.starts_with('#')).count(), 2, "{plain}");
    }
}
