//! Errors of the output writers and readers.

use grainwave_core::CoreError;
use thiserror::Error;

/// Everything that can go wrong while producing an output file.
#[derive(Debug, Error)]
pub enum OutputError {
    /// Creating, writing or renaming the file failed (the engine's error names the path).
    #[error(transparent)]
    Core(#[from] CoreError),
    /// The value could not be represented as JSON (e.g. a map with non-string keys).
    #[error("cannot serialize the contents of `{path}` as JSON: {source}")]
    Json {
        /// File that was to be written.
        path: String,
        /// Underlying error.
        #[source]
        source: serde_json::Error,
    },
    /// A CSV column does not have as many values as the table has rows.
    #[error("CSV column `{column}` has {len} values, but the table has {expected} rows")]
    ColumnLength {
        /// Name of the offending column.
        column: String,
        /// Number of values given.
        len: usize,
        /// Number of rows of the columns already in the table.
        expected: usize,
    },
    /// Two CSV columns have the same name.
    #[error("CSV column `{0}` appears twice")]
    DuplicateColumn(String),
    /// An array's shape does not match its number of values.
    #[error("array `{name}` has {len} values, but its shape {shape:?} needs {expected}")]
    Shape {
        /// Name of the array (file or archive entry).
        name: String,
        /// Shape given.
        shape: Vec<usize>,
        /// Number of values given.
        len: usize,
        /// Product of the shape.
        expected: usize,
    },
    /// A file could not be read.
    #[error("cannot read `{path}`: {source}")]
    Read {
        /// File that was to be read.
        path: String,
        /// Underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A `.npy` file or `.npz` entry is not in a format this crate reads.
    #[error("`{name}` is not a NumPy array this reader understands: {reason}")]
    Npy {
        /// File or archive entry.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// A `.npz` (zip) archive could not be built or read.
    #[error("zip archive `{name}`: {reason}")]
    Zip {
        /// File or archive being processed.
        name: String,
        /// What went wrong.
        reason: String,
    },
    /// A name (array, column, series, file stem) is empty, repeated or contains characters that
    /// are not allowed in it.
    #[error("invalid name `{name}`: {reason}")]
    Name {
        /// The offending name.
        name: String,
        /// Why it is refused.
        reason: String,
    },
    /// A row or per-grain field has the wrong number of values.
    #[error("{what}: expected {expected} values, got {len}")]
    Length {
        /// What was being given (e.g. "row of series `signals`").
        what: String,
        /// Number of values needed.
        expected: usize,
        /// Number of values given.
        len: usize,
    },
    /// A VTK file name does not end in the extension of its dataset type (`.vtp` for PolyData,
    /// `.vtu` for UnstructuredGrid).
    #[error("VTK file `{path}`: {reason}")]
    VtkExtension {
        /// The file name given.
        path: String,
        /// What the name should end in.
        reason: String,
    },
    /// A contact record names a grain id that is not in the snapshot.
    #[error("a contact refers to grain id {0}, which is not in the snapshot")]
    UnknownGrain(u32),
    /// A `.pvd` collection could not be parsed.
    #[error("`{path}` is not a ParaView collection this reader understands: {reason}")]
    Pvd {
        /// File that was read.
        path: String,
        /// What is wrong.
        reason: String,
    },
    /// A plot could not be drawn (no data, invalid ranges, or a drawing backend error).
    #[error("plot `{stem}`: {reason}")]
    Plot {
        /// File stem of the figure.
        stem: String,
        /// What went wrong.
        reason: String,
    },
}

/// Result alias of the output writers.
pub type Result<T, E = OutputError> = std::result::Result<T, E>;
