//! The inputs of the libFuzzer targets of `fuzz/` (docs/fuzzing.md), shared with the ordinary
//! tests that replay the regression inputs (`tests/fuzz_regressions.rs`), so that a replayed
//! input goes through exactly the code that the fuzzer ran.
//!
//! Each function takes the raw bytes of one input and checks the property of its loader: it
//! returns normally (the input was loaded or refused with a message of at most
//! [`MAX_MESSAGE_BYTES`]), or `Err` with a description when the property fails. A panic, an
//! abort or an allocation beyond the fuzzer's memory limit is a failure too; the fuzzer reports
//! those itself, the replay tests catch the panics.

use crate::config::ConfigSource;

/// Longest error message accepted [bytes]: a message quotes at most 200 characters of the input
/// (`grainwave_io::lammps::MAX_ECHO_CHARS`, the config excerpt), plus its own words.
pub const MAX_MESSAGE_BYTES: usize = 2000;

/// The protocols whose config loaders are fuzzed, one target each (`config_<protocol>`): every
/// protocol of the registry.
pub const PROTOCOLS: &[&str] = crate::registry::EXPERIMENTS;

fn message_ok(what: &str, message: &str) -> Result<(), String> {
    if message.is_empty() || message.len() >= MAX_MESSAGE_BYTES {
        return Err(format!("{what}: a message of {} bytes (allowed: 1 to {MAX_MESSAGE_BYTES})", message.len()));
    }
    Ok(())
}

/// TOML text → validated spec of `protocol`: the shape check against the protocol's schema, then
/// its validation (what `grainwave check` runs, sizes and cross-field rules included); for
/// `simulation`, whose validation places the grains, under the tighter soft limit of
/// [`crate::limits::fuzz_limits`] (at most 500 grains: a larger config is refused by the size
/// check, before any placement). Returns whether the config was accepted. Bytes that are not UTF-8 are refused by the file reader
/// before any loader sees them, and are accepted here as refused.
pub fn config(protocol: &str, data: &[u8]) -> Result<bool, String> {
    if protocol == "simulation" {
        crate::limits::fuzz_limits::with(|| config_checked(protocol, data))
    } else {
        config_checked(protocol, data)
    }
}

fn config_checked(protocol: &str, data: &[u8]) -> Result<bool, String> {
    let Ok(text) = std::str::from_utf8(data) else { return Ok(false) };
    let src = ConfigSource::from_text("fuzz.toml", text);
    let Some(entry) = crate::registry::protocol(protocol) else { return Err(format!("no config target for protocol `{protocol}`")) };
    match (entry.check)(&src) {
        Ok(_) => Ok(true),
        Err(e) => message_ok("shape check or validation", &e.message).map(|_| false),
    }
}

/// Checkpoint bytes → the state of every protocol. Each input is decoded as it is, then with its
/// checksum recomputed ([`refresh_crc`]), so that mutations reach the payload decoder instead of
/// stopping at the checksum.
pub fn checkpoint(data: &[u8]) -> Result<(), String> {
    decode_all(data)?;
    let mut bytes = data.to_vec();
    if refresh_crc(&mut bytes) {
        decode_all(&bytes)?;
    }
    Ok(())
}

fn decode_all(bytes: &[u8]) -> Result<(), String> {
    if let Err(e) = grainwave_core::checkpoint::verify(bytes, "fuzz") {
        message_ok("checkpoint header", &e.to_string())?;
    }
    for p in &crate::registry::PROTOCOLS {
        if let Some(m) = (p.decode)(bytes) {
            message_ok("checkpoint", &m)?;
        }
    }
    Ok(())
}

/// Recomputes the checksum of a mutated checkpoint (the engine's function, re-exported here
/// for the fuzz targets).
pub use grainwave_core::checkpoint::refresh_crc;

/// LAMMPS data file bytes → grains, by both the 3D and the 2D import. Bytes that are not UTF-8
/// are refused by the file reader first ([`grainwave_io::lammps::bounded_text`]).
pub fn lammps(data: &[u8]) -> Result<(), String> {
    use grainwave_io::lammps::{parse_data, ImportOptions};
    let Ok(text) = std::str::from_utf8(data) else { return Ok(()) };
    match parse_data(text, "fuzz.data") {
        Ok(d) => {
            for e in [d.to_packing_3d(&ImportOptions::default()).err(), d.to_packing_2d(&ImportOptions::default()).err()].into_iter().flatten() {
                message_ok("LAMMPS import", &e.to_string())?;
            }
            Ok(())
        }
        Err(e) => message_ok("LAMMPS data file", &e.to_string()),
    }
}
