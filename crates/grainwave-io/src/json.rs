//! Pretty-printed JSON files, written atomically.

use crate::error::{OutputError, Result};
use grainwave_core::checkpoint::atomic_write;
use serde::Serialize;
use std::path::Path;

/// Writes `value` to `path` as pretty-printed JSON (two-space indent, trailing newline),
/// atomically; parent directories are created.
///
/// Numbers are written in the shortest form that reads back to the same bits; readers built with
/// this crate parse them exactly (serde_json's `float_roundtrip` feature is enabled here — its
/// default parser may be off by one unit in the last place). Non-finite floating-point numbers
/// have no JSON representation: serde_json writes them as `null`.
pub fn write_json_atomic<T: Serialize + ?Sized>(path: &Path, value: &T) -> Result<()> {
    let mut bytes = serde_json::to_vec_pretty(value)
        .map_err(|source| OutputError::Json { path: path.display().to_string(), source })?;
    bytes.push(b'\n');
    atomic_write(path, &bytes)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Summary {
        grains: u32,
        ratio: f64,
        reason: String,
        tiny: f64,
    }

    #[test]
    fn round_trip_through_file() {
        let dir = crate::table::tests::scratch_dir("json-round-trip");
        let path = dir.join("nested/summary.json");
        // 48.442799571001956 is a value the fast (inexact) parser reads one ulp off.
        let value = Summary { grains: 300, ratio: 48.442799571001956, reason: "converged".into(), tiny: 1.25e-13 };
        write_json_atomic(&path, &value).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.ends_with("}\n"), "{text}");
        assert!(text.contains("\n  \"grains\": 300,"), "pretty-printed with two spaces: {text}");
        let back: Summary = serde_json::from_str(&text).unwrap();
        // serde_json prints the shortest representation that reads back to the same bits.
        assert_eq!(back, value);
        // No temporary file is left behind.
        let names: Vec<_> = std::fs::read_dir(path.parent().unwrap()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("summary.json")]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn overwrites_existing_file() {
        let dir = crate::table::tests::scratch_dir("json-overwrite");
        let path = dir.join("a.json");
        write_json_atomic(&path, &vec![1, 2, 3]).unwrap();
        write_json_atomic(&path, &vec![4]).unwrap();
        let back: Vec<i32> = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(back, vec![4]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn unserializable_value_names_the_file() {
        let dir = crate::table::tests::scratch_dir("json-error");
        let path = dir.join("bad.json");
        let mut map = std::collections::BTreeMap::new();
        map.insert(vec![1u8], 1.0);
        let err = write_json_atomic(&path, &map).unwrap_err();
        assert!(matches!(err, OutputError::Json { .. }), "{err}");
        assert!(err.to_string().contains("bad.json"), "{err}");
        assert!(!path.exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
