//! NumPy `.npz` archives: a zip file with one `.npy` entry per named array.
//!
//! An array called `speed` is stored as the zip entry `speed.npy` (see [`crate::npy`] for the
//! entry format); `numpy.load("file.npz")["speed"]` returns it. Entries are either stored
//! (like `numpy.savez`) or deflated (like `numpy.savez_compressed`); both load the same way.
//! Entry times are fixed at 1980-01-01 00:00, so the same arrays always give the same bytes.

use crate::error::{OutputError, Result};
use crate::npy::{read_file, NpyArray, NpyElement};
use grainwave_core::checkpoint::atomic_write;
use std::io::{Cursor, Read, Write};
use std::path::Path;
use zip::write::SimpleFileOptions;
use zip::{CompressionMethod, DateTime, ZipArchive, ZipWriter};

/// How the entries of an `.npz` archive are stored.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NpzCompression {
    /// No compression (as `numpy.savez`): fastest.
    Stored,
    /// Deflate (as `numpy.savez_compressed`): smaller; the values are unchanged.
    #[default]
    Deflated,
}

/// Checks that `name` can be an array name in an archive (and a column name of a series).
pub(crate) fn check_array_name(name: &str) -> Result<()> {
    let refuse = |reason: &str| Err(OutputError::Name { name: name.to_string(), reason: reason.to_string() });
    if name.is_empty() {
        return refuse("names must not be empty");
    }
    if name.contains(['/', '\\', '\0']) {
        return refuse("names must not contain `/`, `\\` or NUL (they become file names in the archive)");
    }
    if name.starts_with('.') {
        return refuse("names must not start with `.`");
    }
    Ok(())
}

/// Named arrays, in insertion order, that make up an `.npz` archive.
///
/// ```
/// use grainwave_io::{Npz, NpzCompression, NpyArray};
///
/// let mut npz = Npz::new();
/// npz.push("time", NpyArray::vector(vec![0.0, 0.1, 0.2])).unwrap();
/// npz.push("ids", NpyArray::new(&[2], vec![4i64, 9]).unwrap()).unwrap();
/// let bytes = npz.to_bytes(NpzCompression::Deflated).unwrap();
/// let back = Npz::from_bytes("demo.npz", &bytes).unwrap();
/// assert_eq!(back.names().collect::<Vec<_>>(), ["time", "ids"]);
/// assert_eq!(back.get("ids").unwrap().as_i64().unwrap(), [4, 9]);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Npz {
    arrays: Vec<(String, NpyArray)>,
}

impl Npz {
    /// An empty archive.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `array` as `name`; refuses an empty or repeated name, or one containing `/`, `\`,
    /// NUL or starting with `.`.
    pub fn push(&mut self, name: impl Into<String>, array: NpyArray) -> Result<()> {
        let name = name.into();
        check_array_name(&name)?;
        if self.get(&name).is_some() {
            return Err(OutputError::Name { name, reason: "the archive already has an array of that name".into() });
        }
        self.arrays.push((name, array));
        Ok(())
    }

    /// Adds `values` (C order) with `shape` as `name` (see [`NpyArray::new`] and [`Npz::push`]).
    pub fn push_values<T: NpyElement>(&mut self, name: impl Into<String>, shape: &[usize], values: Vec<T>) -> Result<()> {
        let name = name.into();
        let array = NpyArray::new(shape, values).map_err(|e| match e {
            OutputError::Shape { shape, len, expected, .. } => OutputError::Shape { name: name.clone(), shape, len, expected },
            other => other,
        })?;
        self.push(name, array)
    }

    /// The array called `name`, if any.
    pub fn get(&self, name: &str) -> Option<&NpyArray> {
        self.arrays.iter().find(|(n, _)| n == name).map(|(_, a)| a)
    }

    /// Array names, in order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.arrays.iter().map(|(n, _)| n.as_str())
    }

    /// `(name, array)` pairs, in order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &NpyArray)> {
        self.arrays.iter().map(|(n, a)| (n.as_str(), a))
    }

    /// Number of arrays.
    pub fn len(&self) -> usize {
        self.arrays.len()
    }

    /// True when the archive has no arrays.
    pub fn is_empty(&self) -> bool {
        self.arrays.is_empty()
    }

    /// The complete `.npz` file.
    pub fn to_bytes(&self, compression: NpzCompression) -> Result<Vec<u8>> {
        let zip_error = |e: &dyn std::fmt::Display| OutputError::Zip { name: "npz archive".into(), reason: e.to_string() };
        let method = match compression {
            NpzCompression::Stored => CompressionMethod::Stored,
            NpzCompression::Deflated => CompressionMethod::Deflated,
        };
        let mut writer = ZipWriter::new(Cursor::new(Vec::new()));
        for (name, array) in &self.arrays {
            let bytes = array.to_npy_bytes();
            let options = SimpleFileOptions::default()
                .compression_method(method)
                .last_modified_time(DateTime::DEFAULT)
                .unix_permissions(0o644)
                .large_file(bytes.len() as u64 >= u64::from(u32::MAX));
            writer.start_file(format!("{name}.npy"), options).map_err(|e| zip_error(&e))?;
            writer.write_all(&bytes).map_err(|e| zip_error(&e))?;
        }
        Ok(writer.finish().map_err(|e| zip_error(&e))?.into_inner())
    }

    /// Parses a complete `.npz` file; `name` only labels errors. Every entry must be a `.npy`
    /// file; its name without `.npy` becomes the array name.
    /// Every size read from the archive is checked against `bytes` before anything is reserved:
    /// an entry may declare at most [`MAX_EXPANSION`] times its compressed size (itself at most
    /// the length of `bytes`), and may hold no more than it declares.
    pub fn from_bytes(name: &str, bytes: &[u8]) -> Result<Self> {
        let zip_error = |reason: String| OutputError::Zip { name: name.to_string(), reason };
        let mut archive = ZipArchive::new(Cursor::new(bytes)).map_err(|e| zip_error(e.to_string()))?;
        let mut out = Npz::new();
        for k in 0..archive.len() {
            let mut entry = archive.by_index(k).map_err(|e| zip_error(e.to_string()))?;
            let entry_name = entry.name().to_string();
            let Some(array_name) = entry_name.strip_suffix(".npy") else {
                return Err(zip_error(format!("entry `{entry_name}` is not a .npy file")));
            };
            // the sizes in the zip directory are the file's word: bound them by the bytes at hand
            // before reserving anything. An entry's data lies within the file, and deflate expands
            // at most 1032-fold (a stored entry not at all), so no honest entry is larger.
            let compressed = entry.compressed_size().min(bytes.len() as u64);
            let most = compressed.saturating_mul(MAX_EXPANSION);
            if entry.size() > most {
                return Err(zip_error(format!(
                    "entry `{entry_name}` declares {} bytes, more than its {} compressed bytes can hold (at most {MAX_EXPANSION} times as many): the archive is corrupted",
                    entry.size(),
                    entry.compressed_size()
                )));
            }
            let declared = entry.size();
            let mut data = Vec::with_capacity(declared as usize);
            // and read no more than declared, whatever the compressed stream holds
            (&mut entry).take(declared.saturating_add(1)).read_to_end(&mut data).map_err(|e| zip_error(format!("entry `{entry_name}`: {e}")))?;
            if data.len() as u64 != declared {
                return Err(zip_error(format!("entry `{entry_name}` holds {} bytes or more, but declares {declared}: the archive is corrupted", data.len())));
            }
            let array = NpyArray::from_npy_bytes(&format!("{name}/{entry_name}"), &data)?;
            out.push(array_name, array)?;
        }
        Ok(out)
    }

    /// Writes the archive to `path`, atomically; parent directories are created.
    pub fn write(&self, path: &Path, compression: NpzCompression) -> Result<()> {
        let bytes = self.to_bytes(compression).map_err(|e| match e {
            OutputError::Zip { reason, .. } => OutputError::Zip { name: path.display().to_string(), reason },
            other => other,
        })?;
        atomic_write(path, &bytes)?;
        Ok(())
    }

    /// Reads an `.npz` file (written here or by `numpy.savez` / `numpy.savez_compressed`).
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = read_file(path)?;
        Self::from_bytes(&path.display().to_string(), &bytes)
    }
}

/// Largest ratio of an `.npz` entry's size to its compressed size accepted by [`Npz::from_bytes`]:
/// deflate expands at most 1032-fold (a stored entry is its own size).
pub const MAX_EXPANSION: u64 = 1100;

/// Writes the named arrays to `path` as an `.npz` archive, atomically (see [`Npz`]).
pub fn write_npz(path: &Path, npz: &Npz, compression: NpzCompression) -> Result<()> {
    npz.write(path, compression)
}

/// Reads an `.npz` archive (see [`Npz::read`]).
pub fn read_npz(path: &Path) -> Result<Npz> {
    Npz::read(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::npy::NpyData;
    use crate::table::tests::scratch_dir;

    fn sample() -> Npz {
        let mut npz = Npz::new();
        npz.push_values("time", &[4], vec![0.0, 0.25, 0.5, 1.0 / 3.0]).unwrap();
        npz.push_values("positions", &[2, 3], vec![1.0, 2.0, 3.0, -4.0, 5.5, f64::NAN]).unwrap();
        npz.push_values("ids", &[3], vec![0i64, 7, i64::MAX]).unwrap();
        npz.push_values("sliding", &[2], vec![true, false]).unwrap();
        npz.push_values("counts", &[2, 2], vec![1u32, 2, 3, 4]).unwrap();
        npz
    }

    #[test]
    fn round_trip_stored_and_deflated() {
        let dir = scratch_dir("npz-round-trip");
        let npz = sample();
        for compression in [NpzCompression::Stored, NpzCompression::Deflated] {
            let path = dir.join(format!("{compression:?}.npz"));
            write_npz(&path, &npz, compression).unwrap();
            let back = read_npz(&path).unwrap();
            assert_eq!(back.names().collect::<Vec<_>>(), ["time", "positions", "ids", "sliding", "counts"]);
            for (name, a) in npz.iter() {
                let b = back.get(name).unwrap();
                assert_eq!(a.shape(), b.shape(), "{name}");
                match (a.data(), b.data()) {
                    (NpyData::F64(x), NpyData::F64(y)) => {
                        assert!(x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits()), "{name}")
                    }
                    (x, y) => assert_eq!(x, y, "{name}"),
                }
            }
        }
        // Deterministic bytes: no time stamps from the clock.
        assert_eq!(npz.to_bytes(NpzCompression::Deflated).unwrap(), sample().to_bytes(NpzCompression::Deflated).unwrap());
        let stored = std::fs::metadata(dir.join("Stored.npz")).unwrap().len();
        assert!(stored > 5 * 128, "five entries with 128-byte headers: {stored} bytes");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn names_are_checked() {
        let mut npz = Npz::new();
        npz.push_values("a", &[1], vec![1.0]).unwrap();
        for bad in ["", "a", "x/y", ".hidden"] {
            let err = npz.push_values(bad, &[1], vec![1.0]).unwrap_err();
            assert!(matches!(err, OutputError::Name { .. }), "{bad}: {err}");
        }
        let err = npz.push_values("short", &[3], vec![1.0]).unwrap_err();
        assert!(err.to_string().contains("`short`"), "{err}");
    }

    #[test]
    fn malformed_archives_are_errors() {
        let err = Npz::from_bytes("junk.npz", b"PK not really").unwrap_err();
        assert!(matches!(err, OutputError::Zip { .. }) && err.to_string().contains("junk.npz"), "{err}");
        // A zip with an entry that is not a .npy file.
        let mut writer = ZipWriter::new(Cursor::new(Vec::new()));
        writer.start_file("notes.txt", SimpleFileOptions::default()).unwrap();
        writer.write_all(b"hello").unwrap();
        let bytes = writer.finish().unwrap().into_inner();
        let err = Npz::from_bytes("other.npz", &bytes).unwrap_err();
        assert!(err.to_string().contains("notes.txt"), "{err}");
        let err = read_npz(Path::new("/nonexistent/grainwave.npz")).unwrap_err();
        assert!(matches!(err, OutputError::Read { .. }), "{err}");
    }

    /// `bytes` with the uncompressed size of the first entry set to `size` in the central
    /// directory (which the reader trusts) and in the local header.
    fn with_declared_size(bytes: &[u8], size: u32) -> Vec<u8> {
        let mut b = bytes.to_vec();
        let find = |b: &[u8], sig: [u8; 4]| b.windows(4).position(|w| w == sig).unwrap();
        let local = find(&b, [0x50, 0x4b, 0x03, 0x04]);
        b[local + 22..local + 26].copy_from_slice(&size.to_le_bytes());
        let central = find(&b, [0x50, 0x4b, 0x01, 0x02]);
        b[central + 24..central + 28].copy_from_slice(&size.to_le_bytes());
        b
    }

    #[test]
    fn declared_sizes_are_bounded_by_the_archive_before_allocating() {
        let bytes = sample().to_bytes(NpzCompression::Stored).unwrap();
        assert!(Npz::from_bytes("ok.npz", &bytes).is_ok());
        // before: `Vec::with_capacity(entry.size())` reserved what the directory said, here 4 GiB
        // for a file of under a kilobyte
        let huge = with_declared_size(&bytes, 0xFFFF_FFF0);
        let err = Npz::from_bytes("huge.npz", &huge).unwrap_err().to_string();
        assert!(err.contains("entry `time.npy` declares 4294967280 bytes, more than its"), "{err}");
        // an entry holding more than it declares is refused, not read on
        let small = with_declared_size(&bytes, 16);
        let err = Npz::from_bytes("small.npz", &small).unwrap_err().to_string();
        assert!(err.contains("time.npy") && err.contains("declares 16"), "{err}");
        // deflated: a size within 1100 × the compressed size is read as usual
        let deflated = sample().to_bytes(NpzCompression::Deflated).unwrap();
        assert!(Npz::from_bytes("d.npz", &deflated).is_ok());
    }
}
