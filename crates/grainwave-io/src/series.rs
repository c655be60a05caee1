//! Time series and profiles: named `f64` columns of equal length, saved as `.npz` and `.csv`.

use crate::error::{OutputError, Result};
use crate::npy::NpyArray;
use crate::npz::{check_array_name, Npz, NpzCompression};
use crate::table::{write_csv_atomic, CsvTable};
use std::path::{Path, PathBuf};

/// Named `f64` columns of equal length: a time series (`t`, `kinetic_energy`, …) or a profile
/// (`depth`, `stress_xx`, …), filled row by row or column by column.
///
/// [`Series::write`] saves it as `<stem>.npz` — one 1-D `float64` array of length
/// [`rows`](Series::rows) per column, in column order — and `<stem>.csv` — a header line with
/// the names, then one line per row (numbers in their shortest exact form). Units are not stored
/// in the files: each experiment documents the units of its columns.
///
/// ```
/// use grainwave_io::Series;
///
/// let mut s = Series::new(["t", "kinetic_energy"]).unwrap();
/// s.push_row(&[0.0, 1.5]).unwrap();
/// s.push_row(&[0.1, 0.75]).unwrap();
/// assert_eq!(s.rows(), 2);
/// assert_eq!(s.column("kinetic_energy").unwrap(), [1.5, 0.75]);
/// let dir = std::env::temp_dir().join(format!("grainwave-series-doc-{}", std::process::id()));
/// let files = s.write(&dir, "energy").unwrap();
/// assert_eq!(grainwave_io::Series::read_npz(&files.npz).unwrap(), s);
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
    /// Columns of whole counts (see [`Series::mark_counts`]).
    counts: Vec<bool>,
}

/// The two files written by [`Series::write`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SeriesFiles {
    /// `<dir>/<stem>.npz`.
    pub npz: PathBuf,
    /// `<dir>/<stem>.csv`.
    pub csv: PathBuf,
}

/// A whole number in 0 … 2⁵³ (every such integer is exactly an `f64`).
fn is_count(v: f64) -> bool {
    v >= 0.0 && v <= 9_007_199_254_740_992.0 && v.fract() == 0.0
}

/// Checks that `stem` is a plain file name stem (no directories).
pub(crate) fn check_stem(stem: &str) -> Result<()> {
    if stem.is_empty() || stem.contains(['/', '\\', '\0']) || stem == "." || stem == ".." {
        return Err(OutputError::Name { name: stem.to_string(), reason: "a file stem must be a non-empty name without `/` or `\\`".into() });
    }
    Ok(())
}

impl Series {
    /// A series with the given column names and no rows; refuses empty or repeated names and
    /// names containing `/`, `\`, NUL or starting with `.`.
    pub fn new<S: Into<String>>(names: impl IntoIterator<Item = S>) -> Result<Self> {
        let mut s = Series::default();
        for name in names {
            s.add_column(name.into(), Vec::new())?;
        }
        Ok(s)
    }

    /// A series from whole columns, which must all have the same length.
    pub fn from_columns<S: Into<String>>(columns: impl IntoIterator<Item = (S, Vec<f64>)>) -> Result<Self> {
        let mut s = Series::default();
        for (name, values) in columns {
            s.add_column(name.into(), values)?;
        }
        Ok(s)
    }

    fn add_column(&mut self, name: String, values: Vec<f64>) -> Result<()> {
        check_array_name(&name)?;
        if self.names.contains(&name) {
            return Err(OutputError::DuplicateColumn(name));
        }
        if !self.columns.is_empty() && values.len() != self.rows() {
            return Err(OutputError::ColumnLength { column: name, len: values.len(), expected: self.rows() });
        }
        self.names.push(name);
        self.columns.push(values);
        self.counts.push(false);
        Ok(())
    }

    /// Marks the columns `names` as counts (step numbers, numbers of contacts): written as
    /// integers, `500` rather than `500.0`, in the CSV and as `int64` arrays in the archive, so
    /// that readers get integers back. Refused, naming the column, the row and the value, where
    /// a name is not a column or a value is not a whole number in 0 … 2⁵³ (the range where an
    /// `f64` holds every integer exactly).
    pub fn mark_counts(&mut self, names: &[&str]) -> Result<()> {
        for name in names {
            let k = self.names.iter().position(|n| n == name).ok_or_else(|| OutputError::Name {
                name: name.to_string(),
                reason: format!("not a column of this series (columns: {})", self.names.join(", ")),
            })?;
            if let Some((row, v)) = self.columns[k].iter().enumerate().find(|(_, v)| !is_count(**v)) {
                return Err(OutputError::Name {
                    name: name.to_string(),
                    reason: format!("row {row} holds {v}, but a column of counts holds whole numbers in 0 … 2^53"),
                });
            }
            self.counts[k] = true;
        }
        Ok(())
    }

    /// True when column `name` is a column of counts ([`Series::mark_counts`]).
    pub fn is_counts(&self, name: &str) -> bool {
        self.names.iter().position(|n| n == name).is_some_and(|k| self.counts[k])
    }

    /// Appends a whole column (its length must equal [`rows`](Series::rows) unless the series
    /// has no columns yet).
    pub fn push_column(&mut self, name: impl Into<String>, values: Vec<f64>) -> Result<()> {
        self.add_column(name.into(), values)
    }

    /// Appends one row: one value per column, in column order.
    pub fn push_row(&mut self, row: &[f64]) -> Result<()> {
        if row.len() != self.names.len() {
            return Err(OutputError::Length { what: "row of a series".into(), expected: self.names.len(), len: row.len() });
        }
        if let Some(k) = (0..row.len()).find(|&k| self.counts[k] && !is_count(row[k])) {
            return Err(OutputError::Name {
                name: self.names[k].clone(),
                reason: format!("{} is not a count (a whole number in 0 … 2^53), but the column holds counts", row[k]),
            });
        }
        for (column, &value) in self.columns.iter_mut().zip(row) {
            column.push(value);
        }
        Ok(())
    }

    /// Number of rows (0 without columns).
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }

    /// Column names, in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The column called `name`, if any.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names.iter().position(|n| n == name).map(|k| self.columns[k].as_slice())
    }

    /// `(name, values)` pairs, in column order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &[f64])> {
        self.names.iter().zip(&self.columns).map(|(n, c)| (n.as_str(), c.as_slice()))
    }

    /// The series as an archive: one 1-D array per column, `float64` (`int64` for counts).
    pub fn to_npz(&self) -> Npz {
        let mut npz = Npz::new();
        for ((name, column), &counts) in self.iter().zip(&self.counts) {
            let array = if counts { NpyArray::vector(column.iter().map(|&v| v as i64).collect::<Vec<i64>>()) } else { NpyArray::vector(column.to_vec()) };
            npz.push(name, array).expect("series names are valid, unique archive names");
        }
        npz
    }

    /// The series as a CSV table (header line with the names).
    pub fn to_csv(&self) -> CsvTable {
        let mut t = CsvTable::new();
        for ((name, column), &counts) in self.iter().zip(&self.counts) {
            if counts {
                t.push_u64(name, column.iter().map(|&v| v as u64))
            } else {
                t.push_f64(name, column.iter().copied())
            }
            .expect("series columns are unique and of equal length");
        }
        t
    }

    /// Writes `<dir>/<stem>.npz` (deflated) and `<dir>/<stem>.csv`, each atomically; `dir` is
    /// created if needed.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<SeriesFiles> {
        check_stem(stem)?;
        let files = SeriesFiles { npz: dir.join(format!("{stem}.npz")), csv: dir.join(format!("{stem}.csv")) };
        self.to_npz().write(&files.npz, NpzCompression::Deflated)?;
        write_csv_atomic(&files.csv, &self.to_csv())?;
        Ok(files)
    }

    /// Reads a series back from an `.npz` archive whose arrays are all one-dimensional and of
    /// equal length (any numeric dtype; converted to `f64` as in [`crate::NpyData::to_f64`]).
    pub fn read_npz(path: &Path) -> Result<Self> {
        let npz = Npz::read(path)?;
        let mut s = Series::default();
        for (name, array) in npz.iter() {
            if array.shape().len() != 1 {
                return Err(OutputError::Npy {
                    name: format!("{}/{name}.npy", path.display()),
                    reason: format!("a series column must be one-dimensional, this array has shape {:?}", array.shape()),
                });
            }
            s.add_column(name.to_string(), array.data().to_f64())?;
            // an int64 column reads back as counts, as it was written
            if let Some(ints) = array.as_slice::<i64>() {
                if ints.iter().all(|&v| is_count(v as f64)) {
                    *s.counts.last_mut().expect("the column just added") = true;
                }
            }
        }
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::tests::{parse_csv, scratch_dir};

    #[test]
    fn rows_columns_and_files() {
        let mut s = Series::new(["t", "E", "v"]).unwrap();
        for k in 0..5 {
            let t = 0.1 * k as f64;
            s.push_row(&[t, (-t).exp(), t.sin() / 3.0]).unwrap();
        }
        assert_eq!(s.rows(), 5);
        assert!(s.push_row(&[1.0, 2.0]).is_err());
        assert_eq!(s.rows(), 5, "a refused row leaves the series unchanged");
        let dir = scratch_dir("series");
        let files = s.write(&dir, "signals").unwrap();
        assert_eq!(files.npz, dir.join("signals.npz"));
        let back = Series::read_npz(&files.npz).unwrap();
        assert_eq!(back.names(), ["t", "E", "v"]);
        for (name, column) in s.iter() {
            let b = back.column(name).unwrap();
            assert!(column.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()), "{name}");
        }
        let rows = parse_csv(&std::fs::read_to_string(&files.csv).unwrap());
        assert_eq!(rows[0], ["t", "E", "v"]);
        assert_eq!(rows.len(), 6);
        assert_eq!(rows[3][1].parse::<f64>().unwrap(), s.column("E").unwrap()[2]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn counts_are_written_and_read_back_as_integers() {
        let mut s = Series::from_columns([("step", vec![0.0, 500.0, 1000.0]), ("time", vec![0.0, 1.0, 2.0]), ("contacts", vec![0.0, 7.0, 12.0])]).unwrap();
        s.mark_counts(&["step", "contacts"]).unwrap();
        assert!(s.is_counts("step") && s.is_counts("contacts") && !s.is_counts("time"));
        let dir = scratch_dir("series-counts");
        let files = s.write(&dir, "series").unwrap();
        let rows = parse_csv(&std::fs::read_to_string(&files.csv).unwrap());
        assert_eq!(rows[2], ["500", "1.0", "7"].map(String::from), "counts without a point, floats with one");
        let npz = Npz::read(&files.npz).unwrap();
        assert_eq!(npz.get("step").unwrap().as_slice::<i64>(), Some(&[0i64, 500, 1000][..]));
        assert!(npz.get("time").unwrap().as_slice::<f64>().is_some());
        assert_eq!(Series::read_npz(&files.npz).unwrap(), s, "the archive reads back with its counts");
        std::fs::remove_dir_all(&dir).unwrap();
        // a value that is not a whole number ≥ 0, or a name that is not a column, is refused
        let mut bad = Series::from_columns([("n", vec![1.0, 2.5])]).unwrap();
        let err = bad.mark_counts(&["n"]).unwrap_err().to_string();
        assert!(err.contains("row 1 holds 2.5"), "{err}");
        assert!(bad.mark_counts(&["m"]).unwrap_err().to_string().contains("not a column"));
        assert!(!bad.is_counts("n"));
        let mut s = Series::new(["n"]).unwrap();
        s.mark_counts(&["n"]).unwrap();
        s.push_row(&[3.0]).unwrap();
        assert!(s.push_row(&[-1.0]).is_err() && s.rows() == 1);
    }

    #[test]
    fn inconsistent_input_is_refused() {
        assert!(matches!(Series::new(["a", "a"]).unwrap_err(), OutputError::DuplicateColumn(_)));
        assert!(matches!(Series::new(["a/b"]).unwrap_err(), OutputError::Name { .. }));
        let err = Series::from_columns([("x", vec![1.0, 2.0]), ("y", vec![1.0])]).unwrap_err();
        assert!(matches!(err, OutputError::ColumnLength { len: 1, expected: 2, .. }), "{err}");
        let s = Series::from_columns([("x", vec![1.0])]).unwrap();
        assert!(s.write(Path::new("/tmp"), "../escape").is_err());
        let dir = scratch_dir("series-2d");
        let mut npz = Npz::new();
        npz.push_values("m", &[1, 2], vec![1.0, 2.0]).unwrap();
        npz.write(&dir.join("m.npz"), NpzCompression::Stored).unwrap();
        let err = Series::read_npz(&dir.join("m.npz")).unwrap_err();
        assert!(err.to_string().contains("one-dimensional"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
