//! VTK XML output for ParaView (and meshio): grains as points, contacts as lines, `.pvd` time series.
//!
//! * [`grains_dataset`] / [`write_grains_vtp`] / [`write_grains_vtu`]: one point per grain with
//!   radius, mass, velocity, angular velocity, force, torque and rotation;
//! * [`contacts_dataset`] / [`write_contacts_vtp`] / [`write_contacts_vtu`]: one line per contact
//!   with normal and tangential force, stiffnesses, overlap, sliding flag and wall index;
//! * [`PvdCollection`]: a `.pvd` file listing snapshot files with their times;
//! * [`VtkDataSet`]: the dataset behind both, to which experiments add their own fields.
//!
//! `.vtp` (PolyData) and `.vtu` (UnstructuredGrid) files hold the same points, cells and arrays;
//! ParaView reads both, `meshio` reads `.vtu` only.

mod dataset;
mod pvd;
mod snapshot;

pub use dataset::{VtkArray, VtkCells, VtkDataSet, VtkFormat, VtkValues};
pub use pvd::{PvdCollection, PvdEntry};
pub use snapshot::{contacts_dataset, grains_dataset, write_contacts_vtp, write_contacts_vtu, write_grains_vtp, write_grains_vtu};
