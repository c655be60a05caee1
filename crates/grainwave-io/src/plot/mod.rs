//! Figures in one house style, saved as PNG and SVG with an embedded font.
//!
//! * [`LinePlot`]: series, dashed guides, markers and error bands (mean ± r.m.s.) on linear or
//!   logarithmic axes, with a legend;
//! * [`Histogram`]: counts or probability densities of samples over shared bins;
//! * [`PackingPicture`]: a 2D packing — grains as disks, the force or stiffness network (line
//!   width ∝ normal force or normal stiffness), per-grain arrows, or an arrival-time map;
//! * [`FieldMap`]: a scalar field on a 2D grid as a colour map with a colour bar (e.g. a
//!   coarse-grained stress component);
//! * [`ContactChangePicture`]: the contact-force difference between two states of a 2D packing,
//!   with opened and created contacts marked and applied forces as arrows.
//!
//! Every figure is written as `<stem>.png` (8-bit RGB) and `<stem>.svg` of the same pixel size,
//! each atomically. Text uses DejaVu Sans compiled into the library (licence in
//! `crates/grainwave-io/fonts/`), so no system font library is needed; the SVG names the font
//! list `DejaVu Sans, sans-serif` and is rendered with the viewer's fonts.

mod chart;
mod contact_changes;
mod field_map;
mod frame;
mod geometry;
mod histogram;
mod line;
mod packing;
mod style;

pub use chart::LegendPosition;
pub use contact_changes::{ContactChange, ContactChangePicture, ContactFate};
pub use field_map::FieldMap;
pub use histogram::Histogram;
pub use line::LinePlot;
pub use packing::{Network, PackingPicture};
pub use style::PlotFiles;
