//! ParaView collections (`.pvd`): a list of (time, file) pairs that ParaView opens as one time series.

use crate::error::{OutputError, Result};
use crate::npy::read_file;
use grainwave_core::checkpoint::atomic_write;
use std::fmt::Write as _;
use std::path::Path;

/// One file of a collection.
#[derive(Clone, Debug, PartialEq)]
pub struct PvdEntry {
    /// Simulated time of the file (ParaView's `timestep`).
    pub time: f64,
    /// Part number: files with the same time and different parts are shown together.
    pub part: u32,
    /// File name relative to the directory of the `.pvd` file.
    pub file: String,
}

/// A time series of VTK files, written as a `.pvd` collection:
///
/// ```xml
/// <?xml version="1.0"?>
/// <VTKFile type="Collection" version="0.1" byte_order="LittleEndian">
///   <Collection>
///     <DataSet timestep="0.5" group="" part="0" file="grains_000001.vtp"/>
///   </Collection>
/// </VTKFile>
/// ```
///
/// Opening the `.pvd` in ParaView loads every file and puts them on its time axis. File names
/// are relative to the `.pvd` file, so an output directory can be moved as a whole. Times are
/// written in the shortest form that reads back to the same `f64`.
///
/// ```
/// use grainwave_io::vtk::PvdCollection;
///
/// let mut pvd = PvdCollection::new();
/// pvd.push(0.0, "grains_000000.vtp").unwrap();
/// pvd.push(0.5, "grains_000001.vtp").unwrap();
/// assert!(pvd.to_xml().contains("<DataSet timestep=\"0.5\" group=\"\" part=\"0\" file=\"grains_000001.vtp\"/>"));
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PvdCollection {
    entries: Vec<PvdEntry>,
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&apos;")
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"").replace("&apos;", "'").replace("&amp;", "&")
}

impl PvdCollection {
    /// An empty collection.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `relative_file` (relative to the `.pvd` file) at simulated time `time`, part 0.
    pub fn push(&mut self, time: f64, relative_file: impl Into<String>) -> Result<()> {
        self.push_part(time, 0, relative_file)
    }

    /// Adds `relative_file` at `time` as part `part` (several parts at one time are shown
    /// together, e.g. grains and contacts in one collection). Refuses a non-finite time and an
    /// empty or absolute file name.
    pub fn push_part(&mut self, time: f64, part: u32, relative_file: impl Into<String>) -> Result<()> {
        let file = relative_file.into();
        if !time.is_finite() {
            return Err(OutputError::Name { name: file, reason: format!("the time of a collection entry must be finite, got {time}") });
        }
        if file.is_empty() || Path::new(&file).is_absolute() {
            return Err(OutputError::Name { name: file, reason: "collection entries must be non-empty paths relative to the .pvd file".into() });
        }
        self.entries.push(PvdEntry { time, part, file });
        Ok(())
    }

    /// The entries, in the order they were added.
    pub fn entries(&self) -> &[PvdEntry] {
        &self.entries
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when the collection has no entries.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The complete `.pvd` file.
    pub fn to_xml(&self) -> String {
        let mut x = String::from("<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n");
        for e in &self.entries {
            let _ = writeln!(x, "    <DataSet timestep=\"{:?}\" group=\"\" part=\"{}\" file=\"{}\"/>", e.time, e.part, escape(&e.file));
        }
        x.push_str("  </Collection>\n</VTKFile>\n");
        x
    }

    /// Writes the collection to `path`, atomically (rewritten whole each time, so a collection
    /// grown during a run is always a complete file); parent directories are created.
    pub fn write(&self, path: &Path) -> Result<()> {
        atomic_write(path, self.to_xml().as_bytes())?;
        Ok(())
    }

    /// Reads a collection written by [`PvdCollection::write`] (or any `.pvd` whose `DataSet`
    /// elements carry `timestep` and `file`), e.g. to continue it when a run is resumed.
    pub fn read(path: &Path) -> Result<Self> {
        let bytes = read_file(path)?;
        let err = |reason: String| OutputError::Pvd { path: path.display().to_string(), reason };
        let text = String::from_utf8(bytes).map_err(|_| err("the file is not UTF-8 text".into()))?;
        if !text.contains("type=\"Collection\"") {
            return Err(err("it is not a VTKFile of type Collection".into()));
        }
        let mut out = PvdCollection::new();
        let mut rest = text.as_str();
        while let Some(start) = rest.find("<DataSet") {
            let end = start + rest[start..].find('>').ok_or_else(|| err("unterminated DataSet element".into()))?;
            let tag = &rest[start..end];
            let time = attribute(tag, "timestep").ok_or_else(|| err(format!("DataSet without timestep: {tag}>")))?;
            let time: f64 = time.parse().map_err(|_| err(format!("timestep `{time}` is not a number")))?;
            let part = match attribute(tag, "part") {
                Some(p) => p.parse().map_err(|_| err(format!("part `{p}` is not a non-negative integer")))?,
                None => 0,
            };
            let file = attribute(tag, "file").ok_or_else(|| err(format!("DataSet without file: {tag}>")))?;
            out.push_part(time, part, unescape(file)).map_err(|e| err(e.to_string()))?;
            rest = &rest[end..];
        }
        Ok(out)
    }
}

/// The value of attribute `name` in the text of one XML start tag.
fn attribute<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let mut search = tag;
    loop {
        let k = search.find(name)?;
        let preceded = search[..k].chars().next_back().is_some_and(char::is_whitespace);
        let after = search[k + name.len()..].trim_start();
        if preceded {
            if let Some(value) = after.strip_prefix('=') {
                let value = value.trim_start();
                let quote = value.chars().next()?;
                if quote == '"' || quote == '\'' {
                    return value[1..].split(quote).next();
                }
            }
        }
        search = &search[k + name.len()..];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::tests::scratch_dir;

    #[test]
    fn write_and_read_back() {
        let dir = scratch_dir("pvd");
        let mut pvd = PvdCollection::new();
        for k in 0..4 {
            pvd.push(k as f64 / 3.0, format!("snapshots/grains_{k:06}.vtp")).unwrap();
        }
        pvd.push_part(1.0, 1, "odd & \"quoted\".vtu").unwrap();
        let path = dir.join("grains.pvd");
        pvd.write(&path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("timestep=\"0.3333333333333333\""), "{text}");
        assert!(text.contains("file=\"odd &amp; &quot;quoted&quot;.vtu\""), "{text}");
        let back = PvdCollection::read(&path).unwrap();
        assert_eq!(back, pvd);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_entries_and_files_are_refused() {
        let mut pvd = PvdCollection::new();
        assert!(pvd.push(f64::NAN, "a.vtp").is_err());
        assert!(pvd.push(0.0, "").is_err());
        assert!(pvd.push(0.0, "/abs/a.vtp").is_err());
        assert!(pvd.is_empty());
        let dir = scratch_dir("pvd-bad");
        let path = dir.join("x.pvd");
        std::fs::write(&path, "<VTKFile type=\"Collection\"><Collection><DataSet timestep=\"x\" file=\"a.vtp\"/></Collection></VTKFile>").unwrap();
        let err = PvdCollection::read(&path).unwrap_err();
        assert!(err.to_string().contains("timestep `x`"), "{err}");
        std::fs::write(&path, "<VTKFile type=\"UnstructuredGrid\"></VTKFile>").unwrap();
        assert!(PvdCollection::read(&path).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
