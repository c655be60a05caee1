//! Errors of the output writers.

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
}

/// Result alias of the output writers.
pub type Result<T, E = OutputError> = std::result::Result<T, E>;
