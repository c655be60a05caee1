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
}

/// The two files written by [`Series::write`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SeriesFiles {
    /// `<dir>/<stem>.npz`.
    pub npz: PathBuf,
    /// `<dir>/<stem>.csv`.
    pub csv: PathBuf,
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
        Ok(())
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

    /// The series as an archive: one 1-D `float64` array per column.
    pub fn to_npz(&self) -> Npz {
        let mut npz = Npz::new();
        for (name, column) in self.iter() {
            npz.push(name, NpyArray::vector(column.to_vec())).expect("series names are valid, unique archive names");
        }
        npz
    }

    /// The series as a CSV table (header line with the names).
    pub fn to_csv(&self) -> CsvTable {
        let mut t = CsvTable::new();
        for (name, column) in self.iter() {
            t.push_f64(name, column.iter().copied()).expect("series columns are unique and of equal length");
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
