//! # grainwave-io
//!
//! Output writers shared by every grainwave experiment (formats and units: `docs/formats.md`):
//!
//! * [`write_json_atomic`]: any `Serialize` value as pretty-printed JSON;
//! * [`CsvTable`] and [`write_csv_atomic`]: a small column-oriented CSV table (numbers and text);
//! * [`grains_csv`] / [`write_grains_csv`]: one row per grain of a [`Snapshot`](grainwave_core::snapshot::Snapshot),
//!   with dimension-dependent columns;
//! * [`npy`] and [`npz`]: NumPy `.npy` arrays and `.npz` archives, written and read back;
//! * [`Series`]: named `f64` columns (time series, profiles) saved as `.npz` + `.csv`;
//! * [`vtk`]: VTK XML files for ParaView — grains as points, contacts as lines, `.pvd` time series;
//! * [`plot`]: line plots, histograms and pictures of 2D packings as PNG + SVG, text from an
//!   embedded font.
//!
//! Every file is written through [`grainwave_core::checkpoint::atomic_write`] (a temporary file in
//! the same directory, synced, then renamed), so a reader never sees a half-written output even if
//! the run is killed while writing.
//!
//! ```
//! use grainwave_io::{write_csv_atomic, CsvTable};
//!
//! let mut table = CsvTable::new();
//! table.push_u32("id", [0, 1]).unwrap();
//! table.push_f64("radius", [0.5, 0.45]).unwrap();
//! assert_eq!(table.to_csv_string(), "id,radius\n0,0.5\n1,0.45\n");
//!
//! let dir = std::env::temp_dir().join(format!("grainwave-io-doc-{}", std::process::id()));
//! write_csv_atomic(&dir.join("radii.csv"), &table).unwrap();
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```
#![warn(missing_docs)]

mod error;
mod grains_table;
mod json;
pub mod lammps;
pub mod npy;
pub mod npz;
pub mod plot;
mod series;
mod table;
pub mod vtk;

pub use error::{OutputError, Result};
pub use grains_table::{grains_csv, write_grains_csv};
pub use json::write_json_atomic;
pub use npy::{npy_bytes, read_npy, write_npy, NpyArray, NpyData, NpyElement};
pub use npz::{read_npz, write_npz, Npz, NpzCompression};
pub use series::{Series, SeriesFiles};
pub use table::{write_csv_atomic, Column, CsvTable};
