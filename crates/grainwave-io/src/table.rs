//! A small column-oriented CSV table and its atomic writer.
//!
//! Format (RFC 4180 subset): a header line with the column names, then one line per row, fields
//! separated by `,`, lines ended by `\n`. Text fields that contain a comma, a double quote, a
//! carriage return or a newline are enclosed in double quotes with inner quotes doubled.
//! Floating-point numbers are written in the shortest form that reads back to the same bits
//! (`0.5`, `1e-7`, `-3.25e20`); non-finite values are written `NaN`, `inf`, `-inf`, which
//! numpy, pandas and spreadsheet programs read. A column of optional numbers ([`Column::OptF64`])
//! writes a missing value as an empty field (`1.5,,2`): "no value", which readers must not
//! confuse with `NaN` (a value that is not a number). Integers are written in decimal, signed
//! ones with a leading `-` where negative.

use crate::error::{OutputError, Result};
use grainwave_core::checkpoint::atomic_write;
use std::fmt::Write as _;
use std::path::Path;

/// The values of one CSV column.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    /// Floating-point numbers.
    F64(Vec<f64>),
    /// Floating-point numbers that may be missing; `None` is written as an empty field.
    OptF64(Vec<Option<f64>>),
    /// Unsigned integers up to 32 bits (ids, counts).
    U32(Vec<u32>),
    /// Unsigned integers up to 64 bits (step counters).
    U64(Vec<u64>),
    /// Signed integers up to 64 bits (wall ids stored as negative numbers, signed differences).
    I64(Vec<i64>),
    /// Text (quoted where needed).
    Text(Vec<String>),
}

impl Column {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            Column::F64(v) => v.len(),
            Column::OptF64(v) => v.len(),
            Column::U32(v) => v.len(),
            Column::U64(v) => v.len(),
            Column::I64(v) => v.len(),
            Column::Text(v) => v.len(),
        }
    }

    /// True when the column has no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn write_field(&self, row: usize, out: &mut String) {
        match self {
            Column::F64(v) => write_f64(v[row], out),
            Column::OptF64(v) => {
                if let Some(x) = v[row] {
                    write_f64(x, out);
                }
            }
            Column::U32(v) => write!(out, "{}", v[row]).expect("writing to a String cannot fail"),
            Column::U64(v) => write!(out, "{}", v[row]).expect("writing to a String cannot fail"),
            Column::I64(v) => write!(out, "{}", v[row]).expect("writing to a String cannot fail"),
            Column::Text(v) => write_text(&v[row], out),
        }
    }
}

/// Shortest round-trip representation (Rust's `Debug` for `f64`, which switches to exponent
/// notation for very small and very large magnitudes).
fn write_f64(x: f64, out: &mut String) {
    if x.is_nan() {
        out.push_str("NaN");
    } else if x.is_infinite() {
        out.push_str(if x > 0.0 { "inf" } else { "-inf" });
    } else {
        write!(out, "{x:?}").expect("writing to a String cannot fail");
    }
}

fn write_text(s: &str, out: &mut String) {
    if s.contains([',', '"', '\n', '\r']) {
        out.push('"');
        out.push_str(&s.replace('"', "\"\""));
        out.push('"');
    } else {
        out.push_str(s);
    }
}

/// A table built column by column; every column must have the same number of rows.
///
/// ```
/// use grainwave_io::CsvTable;
///
/// let mut t = CsvTable::new();
/// t.push_text("wall", ["bottom", "left, lower"]).unwrap();
/// t.push_f64("load", [12.5, 1e-9]).unwrap();
/// assert_eq!(t.to_csv_string(), "wall,load\nbottom,12.5\n\"left, lower\",1e-9\n");
/// assert!(t.push_f64("short", [1.0]).is_err());
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CsvTable {
    names: Vec<String>,
    columns: Vec<Column>,
}

impl CsvTable {
    /// An empty table (no columns, no rows).
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of rows (0 for a table without columns).
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Column::len)
    }

    /// Column names, in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The column called `name`, if any.
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.names.iter().position(|n| n == name).map(|k| &self.columns[k])
    }

    /// Appends a column; refuses a duplicate name or a length different from the existing rows.
    pub fn push(&mut self, name: impl Into<String>, column: Column) -> Result<()> {
        let name = name.into();
        if self.names.contains(&name) {
            return Err(OutputError::DuplicateColumn(name));
        }
        if !self.columns.is_empty() && column.len() != self.rows() {
            return Err(OutputError::ColumnLength { column: name, len: column.len(), expected: self.rows() });
        }
        self.names.push(name);
        self.columns.push(column);
        Ok(())
    }

    /// Appends a column of floating-point numbers.
    pub fn push_f64(&mut self, name: impl Into<String>, values: impl IntoIterator<Item = f64>) -> Result<()> {
        self.push(name, Column::F64(values.into_iter().collect()))
    }

    /// Appends a column of optional floating-point numbers: `None` is written as an empty field
    /// ("no value"), `Some(x)` like [`CsvTable::push_f64`] writes `x`.
    pub fn push_opt_f64(&mut self, name: impl Into<String>, values: impl IntoIterator<Item = Option<f64>>) -> Result<()> {
        self.push(name, Column::OptF64(values.into_iter().collect()))
    }

    /// Appends a column of 32-bit unsigned integers.
    pub fn push_u32(&mut self, name: impl Into<String>, values: impl IntoIterator<Item = u32>) -> Result<()> {
        self.push(name, Column::U32(values.into_iter().collect()))
    }

    /// Appends a column of 64-bit unsigned integers.
    pub fn push_u64(&mut self, name: impl Into<String>, values: impl IntoIterator<Item = u64>) -> Result<()> {
        self.push(name, Column::U64(values.into_iter().collect()))
    }

    /// Appends a column of 64-bit signed integers.
    pub fn push_i64(&mut self, name: impl Into<String>, values: impl IntoIterator<Item = i64>) -> Result<()> {
        self.push(name, Column::I64(values.into_iter().collect()))
    }

    /// Appends a column of text.
    pub fn push_text<S: Into<String>>(&mut self, name: impl Into<String>, values: impl IntoIterator<Item = S>) -> Result<()> {
        self.push(name, Column::Text(values.into_iter().map(Into::into).collect()))
    }

    /// The whole table as CSV text (header line first, every line ends with `\n`).
    pub fn to_csv_string(&self) -> String {
        let mut out = String::with_capacity(16 * (self.rows() + 1) * self.columns.len().max(1));
        for (k, name) in self.names.iter().enumerate() {
            if k > 0 {
                out.push(',');
            }
            write_text(name, &mut out);
        }
        out.push('\n');
        for row in 0..self.rows() {
            for (k, column) in self.columns.iter().enumerate() {
                if k > 0 {
                    out.push(',');
                }
                column.write_field(row, &mut out);
            }
            out.push('\n');
        }
        out
    }
}

/// Writes `table` to `path` as CSV, atomically; parent directories are created.
pub fn write_csv_atomic(path: &Path, table: &CsvTable) -> Result<()> {
    atomic_write(path, table.to_csv_string().as_bytes())?;
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::path::PathBuf;

    /// A fresh, empty directory for one test (removed first if a previous run left it).
    pub(crate) fn scratch_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("grainwave-io-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Minimal RFC 4180 reader, independent of the writer, for checking files.
    pub(crate) fn parse_csv(text: &str) -> Vec<Vec<String>> {
        let mut rows = Vec::new();
        let mut row = Vec::new();
        let mut field = String::new();
        let mut quoted = false;
        let mut chars = text.chars().peekable();
        while let Some(c) = chars.next() {
            match (quoted, c) {
                (true, '"') if chars.peek() == Some(&'"') => {
                    chars.next();
                    field.push('"');
                }
                (true, '"') => quoted = false,
                (true, c) => field.push(c),
                (false, '"') => quoted = true,
                (false, ',') => row.push(std::mem::take(&mut field)),
                (false, '\n') => {
                    row.push(std::mem::take(&mut field));
                    rows.push(std::mem::take(&mut row));
                }
                (false, c) => field.push(c),
            }
        }
        assert!(field.is_empty() && row.is_empty(), "file does not end with a newline");
        rows
    }

    #[test]
    fn numbers_read_back_bit_for_bit() {
        let values = [0.0, -0.0, 1.0, 0.1, 1.0 / 3.0, -2.5e-300, 6.02214076e23, 1e-7, 123456.789, f64::MIN_POSITIVE, f64::MAX];
        let mut t = CsvTable::new();
        t.push_f64("x", values).unwrap();
        t.push_u64("step", (0..values.len() as u64).map(|k| k * (u64::MAX / 16))).unwrap();
        let dir = scratch_dir("numbers");
        let path = dir.join("t.csv");
        write_csv_atomic(&path, &t).unwrap();
        let rows = parse_csv(&std::fs::read_to_string(&path).unwrap());
        assert_eq!(rows[0], vec!["x", "step"]);
        assert_eq!(rows.len(), values.len() + 1);
        for (k, v) in values.iter().enumerate() {
            let back: f64 = rows[k + 1][0].parse().unwrap();
            assert_eq!(back.to_bits(), v.to_bits(), "row {k}: {}", rows[k + 1][0]);
            assert_eq!(rows[k + 1][1].parse::<u64>().unwrap(), k as u64 * (u64::MAX / 16));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn non_finite_numbers_are_named() {
        let mut t = CsvTable::new();
        t.push_f64("x", [f64::NAN, f64::INFINITY, f64::NEG_INFINITY]).unwrap();
        assert_eq!(t.to_csv_string(), "x\nNaN\ninf\n-inf\n");
        for s in ["NaN", "inf", "-inf"] {
            assert!(!s.parse::<f64>().unwrap().is_finite());
        }
    }

    #[test]
    fn text_is_quoted_only_when_needed() {
        let texts = ["plain", "a,b", "say \"hi\"", "two\nlines", ""];
        let mut t = CsvTable::new();
        t.push_text("label", texts).unwrap();
        t.push_u32("n", [1, 2, 3, 4, 5]).unwrap();
        let csv = t.to_csv_string();
        assert!(csv.starts_with("label,n\nplain,1\n\"a,b\",2\n\"say \"\"hi\"\"\",3\n"), "{csv}");
        let rows = parse_csv(&csv);
        assert_eq!(rows.len(), 6);
        for (k, s) in texts.iter().enumerate() {
            assert_eq!(rows[k + 1], vec![s.to_string(), (k + 1).to_string()]);
        }
    }

    #[test]
    fn inconsistent_columns_are_refused() {
        let mut t = CsvTable::new();
        t.push_f64("a", [1.0, 2.0]).unwrap();
        let err = t.push_u32("b", [1]).unwrap_err();
        assert!(matches!(err, OutputError::ColumnLength { len: 1, expected: 2, .. }), "{err}");
        let err = t.push_f64("a", [3.0, 4.0]).unwrap_err();
        assert!(matches!(err, OutputError::DuplicateColumn(ref n) if n == "a"), "{err}");
        assert_eq!(t.names(), ["a"]);
        assert_eq!(t.rows(), 2);
        assert_eq!(t.column("a"), Some(&Column::F64(vec![1.0, 2.0])));
    }

    #[test]
    fn missing_values_are_empty_fields_and_present_ones_read_back() {
        let values = [Some(0.1), None, Some(-2.5e-300), None, Some(f64::NAN), Some(6.02214076e23)];
        let mut t = CsvTable::new();
        t.push_opt_f64("c", values).unwrap();
        t.push_i64("d", [-1, 0, i64::MIN, i64::MAX, 7, -42]).unwrap();
        let csv = t.to_csv_string();
        // None is an empty field, NaN is a value and named
        assert!(csv.starts_with("c,d\n0.1,-1\n,0\n"), "{csv}");
        assert!(csv.contains("\nNaN,7\n"), "{csv}");
        let dir = scratch_dir("optional");
        let path = dir.join("t.csv");
        write_csv_atomic(&path, &t).unwrap();
        let rows = parse_csv(&std::fs::read_to_string(&path).unwrap());
        assert_eq!(rows.len(), values.len() + 1);
        assert_eq!(rows[0], vec!["c", "d"]);
        for (k, v) in values.iter().enumerate() {
            let field = &rows[k + 1][0];
            match v {
                None => assert_eq!(field, "", "row {k}"),
                Some(x) if x.is_nan() => assert_eq!(field, "NaN", "row {k}"),
                Some(x) => assert_eq!(field.parse::<f64>().unwrap().to_bits(), x.to_bits(), "row {k}: {field}"),
            }
        }
        let ints: Vec<i64> = rows[1..].iter().map(|r| r[1].parse().unwrap()).collect();
        assert_eq!(ints, [-1, 0, i64::MIN, i64::MAX, 7, -42]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn optional_columns_are_length_checked() {
        let mut t = CsvTable::new();
        t.push_f64("a", [1.0, 2.0, 3.0]).unwrap();
        let err = t.push_opt_f64("b", [Some(1.0), None]).unwrap_err();
        assert!(matches!(err, OutputError::ColumnLength { len: 2, expected: 3, .. }), "{err}");
        let err = t.push_i64("c", [1, 2, 3, 4]).unwrap_err();
        assert!(matches!(err, OutputError::ColumnLength { len: 4, expected: 3, .. }), "{err}");
        t.push_opt_f64("b", [None, None, None]).unwrap();
        // a column of nothing but missing values still has its rows
        assert_eq!(t.to_csv_string(), "a,b\n1.0,\n2.0,\n3.0,\n");
        assert_eq!(t.column("b"), Some(&Column::OptF64(vec![None; 3])));
    }

    #[test]
    fn empty_table_has_only_a_header() {
        let mut t = CsvTable::new();
        assert_eq!(t.to_csv_string(), "\n");
        t.push_f64("a", []).unwrap();
        t.push_text::<&str>("b", []).unwrap();
        assert_eq!(t.to_csv_string(), "a,b\n");
        assert_eq!(t.rows(), 0);
    }
}
