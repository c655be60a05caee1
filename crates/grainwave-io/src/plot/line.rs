//! Line plots: several series with a legend, markers, error bands, linear or log axes.

use super::chart::{Chart, Layer, LegendPosition};
use super::style::{save, PlotFiles};
use crate::error::Result;
use std::path::Path;

/// An x–y plot of one or more series, built step by step and saved as PNG + SVG.
///
/// Every series gets the next colour of a colour-blind-safe palette of eight (after eight the
/// colours repeat with solid and dashed lines, filled and hollow markers swapped) and, if its
/// name is not empty, an entry in the legend. Axis labels should carry units in brackets
/// (`"t [t*]"`, `"E_kin [m d² / t*²]"`). Points that are not finite — or not positive on a
/// logarithmic axis — are skipped and break lines; axis ranges default to the data (padded by
/// 4 %) and anything outside explicit ranges is clipped.
///
/// ```
/// use grainwave_io::plot::LinePlot;
///
/// let t: Vec<f64> = (1..=100).map(|k| k as f64 * 0.1).collect();
/// let decay: Vec<f64> = t.iter().map(|t| t.powf(-1.5)).collect();
/// let guide: Vec<f64> = t.iter().map(|t| 1.2 * t.powf(-1.5)).collect();
/// let dir = std::env::temp_dir().join(format!("grainwave-plot-doc-{}", std::process::id()));
/// let files = LinePlot::new("Energy decay")
///     .x_label("t [t*]")
///     .y_label("E [m d²/t*²]")
///     .log_x()
///     .log_y()
///     .series("simulation", &t, &decay)
///     .dashed("t^-3/2", &t, &guide)
///     .save(&dir, "decay")
///     .unwrap();
/// assert!(files.png.exists() && files.svg.exists());
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct LinePlot {
    chart: Chart,
}

impl LinePlot {
    /// A plot with this title (empty: no title) and no series yet.
    pub fn new(title: &str) -> Self {
        LinePlot { chart: Chart::new(title) }
    }

    /// Label of the x axis, with units (e.g. `"t [t*]"`).
    pub fn x_label(mut self, label: &str) -> Self {
        self.chart.x_label = label.to_string();
        self
    }

    /// Label of the y axis, with units.
    pub fn y_label(mut self, label: &str) -> Self {
        self.chart.y_label = label.to_string();
        self
    }

    /// Logarithmic x axis (base 10).
    pub fn log_x(mut self) -> Self {
        self.chart.log_x = true;
        self
    }

    /// Logarithmic y axis (base 10).
    pub fn log_y(mut self) -> Self {
        self.chart.log_y = true;
        self
    }

    /// Fixes the x range (otherwise: the data, padded).
    pub fn x_range(mut self, min: f64, max: f64) -> Self {
        self.chart.x_range = Some((min, max));
        self
    }

    /// Fixes the y range (otherwise: the data, padded).
    pub fn y_range(mut self, min: f64, max: f64) -> Self {
        self.chart.y_range = Some((min, max));
        self
    }

    /// Figure size in pixels (default 900 × 640); the SVG has the same size.
    pub fn size(mut self, width: u32, height: u32) -> Self {
        self.chart.size = (width, height);
        self
    }

    /// Where the legend goes (default: upper right).
    pub fn legend(mut self, position: LegendPosition) -> Self {
        self.chart.legend = position;
        self
    }

    /// A solid line through (`x[k]`, `y[k]`).
    pub fn series(mut self, name: &str, x: &[f64], y: &[f64]) -> Self {
        self.chart.layers.push(Layer::Line { name: name.to_string(), x: x.to_vec(), y: y.to_vec(), dashed: false });
        self
    }

    /// A dashed line through (`x[k]`, `y[k]`) — for fits, guides and closed-form predictions.
    pub fn dashed(mut self, name: &str, x: &[f64], y: &[f64]) -> Self {
        self.chart.layers.push(Layer::Line { name: name.to_string(), x: x.to_vec(), y: y.to_vec(), dashed: true });
        self
    }

    /// Markers (filled circles) at (`x[k]`, `y[k]`), no line.
    pub fn scatter(mut self, name: &str, x: &[f64], y: &[f64]) -> Self {
        self.chart.layers.push(Layer::Scatter { name: name.to_string(), x: x.to_vec(), y: y.to_vec() });
        self
    }

    /// A line at `mean` with a shaded band from `mean − spread` to `mean + spread` (e.g. the
    /// ensemble mean ± its r.m.s. deviation). On a log y axis a lower edge ≤ 0 is drawn at the
    /// bottom of the axis.
    pub fn band(mut self, name: &str, x: &[f64], mean: &[f64], spread: &[f64]) -> Self {
        self.chart.layers.push(Layer::Band { name: name.to_string(), x: x.to_vec(), mean: mean.to_vec(), spread: spread.to_vec() });
        self
    }

    /// Draws the plot and writes `<dir>/<stem>.png` and `<dir>/<stem>.svg`, each atomically.
    /// Fails (writing nothing) if there is no series, a series' arrays differ in length, no
    /// point is usable, or a fixed range is empty or not positive on a log axis.
    pub fn save(&self, dir: &Path, stem: &str) -> Result<PlotFiles> {
        save(&self.chart, dir, stem)
    }
}

#[cfg(test)]
mod log_axis_tests {
    use super::*;

    /// Regression test named after the bug it caught: on a log axis spanning 1e-14 … 1e2, ticks
    /// below 1e-7 were labelled "0" (linear-axis zero snapping applied to log axes).
    #[test]
    fn small_log_ticks_are_not_labelled_zero() {
        let x: Vec<f64> = (0..50).map(|k| k as f64).collect();
        let y: Vec<f64> = (0..50).map(|k| 10f64.powf(2.0 - 16.0 * k as f64 / 49.0)).collect();
        let dir = std::env::temp_dir().join(format!("grainwave-logticks-{}", std::process::id()));
        let files = LinePlot::new("decay").log_y().series("y", &x, &y).save(&dir, "decay").unwrap();
        let svg = std::fs::read_to_string(&files.svg).unwrap();
        // plotters writes each text element's content on a line of its own
        let labels: Vec<&str> = svg.split("<text").skip(1).filter_map(|t| t.split('>').nth(1)).map(|t| t.split('<').next().unwrap_or("").trim()).collect();
        assert!(labels.iter().any(|l| l.starts_with("10⁻¹")), "small powers of ten are labelled: {labels:?}");
        let zero_labels = labels.iter().filter(|l| **l == "0").count();
        assert!(zero_labels <= 1, "only the x axis may show a 0 label, found {zero_labels} in {labels:?}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
