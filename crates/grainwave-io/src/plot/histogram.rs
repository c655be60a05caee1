//! Histograms of one or more samples over shared bins.

use super::chart::{Chart, Layer, LegendPosition};
use super::style::{save, PlotFiles};
use crate::error::{OutputError, Result};
use std::path::Path;

/// A histogram of one or more samples over the same equal-width bins, saved as PNG + SVG.
///
/// Bins span `range` (default: the smallest to the largest finite value of all samples) in
/// `bins` equal parts (default 30); values outside the range are not counted. Heights are counts,
/// or probability densities count / (N × bin width) with [`density`](Histogram::density) (N: the
/// number of values of that sample inside the range), so that samples of different sizes compare
/// and a known distribution can be overlaid with [`curve`](Histogram::curve).
/// Several samples are drawn semi-transparent on top of each other.
///
/// ```
/// use grainwave_io::plot::Histogram;
///
/// let forces: Vec<f64> = (0..1000).map(|k| -((k as f64 + 0.5) / 1000.0).ln()).collect();
/// let dir = std::env::temp_dir().join(format!("grainwave-hist-doc-{}", std::process::id()));
/// Histogram::new("Contact forces")
///     .x_label("f = F_n / <F_n>")
///     .y_label("P(f)")
///     .density()
///     .log_y()
///     .sample("all contacts", &forces)
///     .save(&dir, "forces")
///     .unwrap();
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Histogram {
    chart: Chart,
    bins: usize,
    range: Option<(f64, f64)>,
    density: bool,
    samples: Vec<(String, Vec<f64>)>,
    curves: Vec<(String, Vec<f64>, Vec<f64>)>,
}

impl Histogram {
    /// A histogram with this title and no samples yet; 30 bins.
    pub fn new(title: &str) -> Self {
        let mut chart = Chart::new(title);
        chart.y_label = "count".into();
        Histogram { chart, bins: 30, range: None, density: false, samples: Vec::new(), curves: Vec::new() }
    }

    /// Label of the x axis, with units.
    pub fn x_label(mut self, label: &str) -> Self {
        self.chart.x_label = label.to_string();
        self
    }

    /// Label of the y axis (default `count`).
    pub fn y_label(mut self, label: &str) -> Self {
        self.chart.y_label = label.to_string();
        self
    }

    /// Number of bins (at least 1).
    pub fn bins(mut self, bins: usize) -> Self {
        self.bins = bins;
        self
    }

    /// Range covered by the bins; values outside are not counted.
    pub fn range(mut self, min: f64, max: f64) -> Self {
        self.range = Some((min, max));
        self
    }

    /// Heights as probability densities instead of counts.
    pub fn density(mut self) -> Self {
        self.density = true;
        self
    }

    /// Logarithmic y axis (empty bins are then not drawn).
    pub fn log_y(mut self) -> Self {
        self.chart.log_y = true;
        self
    }

    /// Figure size in pixels (default 900 × 640).
    pub fn size(mut self, width: u32, height: u32) -> Self {
        self.chart.size = (width, height);
        self
    }

    /// Where the legend goes (default: upper right).
    pub fn legend(mut self, position: LegendPosition) -> Self {
        self.chart.legend = position;
        self
    }

    /// Adds a sample (non-finite values are ignored).
    pub fn sample(mut self, name: &str, values: &[f64]) -> Self {
        self.samples.push((name.to_string(), values.to_vec()));
        self
    }

    /// Adds a dashed curve (x, y) on top of the bars, e.g. a closed-form distribution.
    pub fn curve(mut self, name: &str, x: &[f64], y: &[f64]) -> Self {
        self.curves.push((name.to_string(), x.to_vec(), y.to_vec()));
        self
    }

    /// Bin edges (`bins + 1` values) and, per sample, the bar heights (counts or densities).
    pub fn heights(&self) -> Result<(Vec<f64>, Vec<Vec<f64>>)> {
        // Labelled with the title here; `save` relabels with the file stem.
        let fail = |reason: String| OutputError::Plot { stem: self.chart.title.clone(), reason };
        if self.bins == 0 {
            return Err(fail("a histogram needs at least one bin".into()));
        }
        let (lo, hi) = match self.range {
            Some(r) => r,
            None => {
                let all = self.samples.iter().flat_map(|(_, v)| v.iter().copied()).filter(|v| v.is_finite());
                all.fold(None, |acc: Option<(f64, f64)>, v| Some(acc.map_or((v, v), |(a, b)| (a.min(v), b.max(v)))))
                    .ok_or_else(|| fail("no finite values to count".into()))?
            }
        };
        let (lo, hi) = if hi > lo { (lo, hi) } else { (lo - 0.5, hi + 0.5) };
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(fail(format!("invalid histogram range {lo}…{hi}")));
        }
        let width = (hi - lo) / self.bins as f64;
        let edges: Vec<f64> = (0..=self.bins).map(|k| if k == self.bins { hi } else { lo + k as f64 * width }).collect();
        let mut out = Vec::new();
        for (_, values) in &self.samples {
            let mut counts = vec![0.0; self.bins];
            let mut inside = 0usize;
            for &v in values {
                if v.is_finite() && v >= lo && v <= hi {
                    let k = (((v - lo) / width) as usize).min(self.bins - 1);
                    counts[k] += 1.0;
                    inside += 1;
                }
            }
            if self.density && inside > 0 {
                for c in &mut counts {
                    *c /= inside as f64 * width;
                }
            }
            out.push(counts);
        }
        Ok((edges, out))
    }

    /// Draws the histogram and writes `<dir>/<stem>.png` and `<dir>/<stem>.svg`, each atomically.
    pub fn save(&self, dir: &Path, stem: &str) -> Result<PlotFiles> {
        let (edges, heights) = self.heights().map_err(|e| match e {
            OutputError::Plot { reason, .. } => OutputError::Plot { stem: stem.to_string(), reason },
            other => other,
        })?;
        let mut chart = self.chart.clone();
        if self.density && chart.y_label == "count" {
            chart.y_label = "probability density".into();
        }
        for ((name, _), h) in self.samples.iter().zip(heights) {
            chart.layers.push(Layer::Bars { name: name.clone(), edges: edges.clone(), heights: h });
        }
        for (name, x, y) in &self.curves {
            chart.layers.push(Layer::Line { name: name.clone(), x: x.clone(), y: y.clone(), dashed: true });
        }
        save(&chart, dir, stem)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_densities() {
        let h = Histogram::new("h").bins(4).range(0.0, 4.0).sample("a", &[0.5, 1.5, 1.6, 3.9, 4.0, 7.0, f64::NAN]);
        let (edges, heights) = h.heights().unwrap();
        assert_eq!(edges, [0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(heights[0], [1.0, 2.0, 0.0, 2.0], "4.0 falls in the last bin, 7.0 and NaN nowhere");
        let (_, d) = h.density().heights().unwrap();
        let total: f64 = d[0].iter().sum::<f64>() * 1.0;
        assert!((total - 1.0).abs() < 1e-12, "densities integrate to 1: {total}");
        assert!(Histogram::new("h").bins(0).sample("a", &[1.0]).heights().is_err());
        assert!(Histogram::new("h").sample("a", &[f64::NAN]).heights().is_err());
    }
}
