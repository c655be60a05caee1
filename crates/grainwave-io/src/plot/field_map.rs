//! Colour maps of a scalar field on a regular 2D grid (e.g. a coarse-grained stress component),
//! with a colour bar and equal scales on both axes.

use super::chart::snap_zero;
use super::frame::{data_axes, BOTTOM, BOTTOM_MARGIN, LEFT, LEFT_MARGIN};
use super::style::{save, text, tick_label, Figure, PlotFiles, TICK_SIZE, TITLE_SIZE};
use crate::error::{OutputError, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// A scalar field f(x, y) on the grid x = x₀ + i dx, y = y₀ + j dy (i < n_x, j < n_y; values row
/// by row, x fastest), drawn as one coloured cell per grid point and saved as PNG + SVG.
///
/// Colours: a **diverging** map (blue – white – red, symmetric about 0: red positive) for fields
/// of either sign such as stress changes, or a **sequential** map (white – yellow – red – dark red
/// from the minimum to the maximum) for fields of one sign. The colour bar on the right gives the
/// scale; the range defaults to the data (symmetric for diverging maps) and can be fixed; values
/// outside it take the end colours, non-finite values are left white.
///
/// ```
/// use grainwave_io::plot::FieldMap;
/// let (nx, ny) = (40, 20);
/// let values: Vec<f64> = (0..nx * ny).map(|k| ((k % nx) as f64 - 20.0) * ((k / nx) as f64 - 10.0)).collect();
/// let dir = std::env::temp_dir().join(format!("grainwave-field-doc-{}", std::process::id()));
/// let files = FieldMap::new("saddle", (0.0, 0.5, nx), (0.0, 0.5, ny), &values)
///     .x_label("x [R̄]")
///     .y_label("z [R̄]")
///     .colorbar_label("σ_zz [m̄g/R̄]")
///     .save(&dir, "saddle")
///     .unwrap();
/// assert!(files.png.exists() && files.svg.exists());
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct FieldMap {
    title: String,
    x_label: String,
    y_label: String,
    bar_label: String,
    x: (f64, f64, usize),
    y: (f64, f64, usize),
    values: Vec<f64>,
    diverging: bool,
    range: Option<(f64, f64)>,
    width: Option<u32>,
}

/// Pixels around the plotting area.
const TOP: u32 = 52;
const BAR_GAP: u32 = 24;
const BAR_WIDTH: u32 = 22;
const BAR_LABELS: u32 = 96;

/// Blue – white – red for t ∈ [−1, 1].
fn diverging(t: f64) -> RGBColor {
    let t = t.clamp(-1.0, 1.0);
    let (end, s) = if t >= 0.0 { ((178.0, 24.0, 43.0), t) } else { ((33.0, 102.0, 172.0), -t) };
    let mix = |a: f64| (255.0 + (a - 255.0) * s).round() as u8;
    RGBColor(mix(end.0), mix(end.1), mix(end.2))
}

/// White – yellow – red – dark red for t ∈ [0, 1].
fn sequential(t: f64) -> RGBColor {
    let stops = [(0.0, (255.0, 255.0, 255.0)), (0.33, (254.0, 217.0, 118.0)), (0.66, (240.0, 59.0, 32.0)), (1.0, (128.0, 0.0, 38.0))];
    let t = t.clamp(0.0, 1.0);
    for w in stops.windows(2) {
        let ((t0, c0), (t1, c1)) = (w[0], w[1]);
        if t <= t1 {
            let s = (t - t0) / (t1 - t0);
            let m = |a: f64, b: f64| (a + (b - a) * s).round() as u8;
            return RGBColor(m(c0.0, c1.0), m(c0.1, c1.1), m(c0.2, c1.2));
        }
    }
    RGBColor(128, 0, 38)
}

impl FieldMap {
    /// A map of `values` on the grid `x` = (x₀, dx, n_x), `y` = (y₀, dy, n_y); diverging colours.
    pub fn new(title: &str, x: (f64, f64, usize), y: (f64, f64, usize), values: &[f64]) -> Self {
        FieldMap {
            title: title.to_string(),
            x_label: "x".into(),
            y_label: "y".into(),
            bar_label: String::new(),
            x,
            y,
            values: values.to_vec(),
            diverging: true,
            range: None,
            width: None,
        }
    }

    /// Label of the x axis, with units.
    pub fn x_label(mut self, label: &str) -> Self {
        self.x_label = label.to_string();
        self
    }

    /// Label of the y axis, with units.
    pub fn y_label(mut self, label: &str) -> Self {
        self.y_label = label.to_string();
        self
    }

    /// Label of the colour bar (the field and its unit).
    pub fn colorbar_label(mut self, label: &str) -> Self {
        self.bar_label = label.to_string();
        self
    }

    /// Sequential colours from the minimum to the maximum (fields of one sign).
    pub fn sequential(mut self) -> Self {
        self.diverging = false;
        self
    }

    /// Fixes the colour range (otherwise: the data; ±max|f| for diverging maps).
    pub fn range(mut self, min: f64, max: f64) -> Self {
        self.range = Some((min, max));
        self
    }

    /// Width of the plotting area in pixels (default: 8 pixels per cell, between 640 and 1800).
    pub fn width(mut self, pixels: u32) -> Self {
        self.width = Some(pixels);
        self
    }

    /// Draws the map and writes `<dir>/<stem>.png` and `<dir>/<stem>.svg`, each atomically.
    /// Fails if the grid is empty, a spacing is not positive, the values do not fill the grid,
    /// no value is finite, or a fixed range is empty.
    pub fn save(&self, dir: &Path, stem: &str) -> Result<PlotFiles> {
        let fail = |reason: String| OutputError::Plot { stem: stem.to_string(), reason };
        let (nx, ny) = (self.x.2, self.y.2);
        if nx == 0 || ny == 0 || !(self.x.1 > 0.0 && self.y.1 > 0.0) {
            return Err(fail(format!("grid {nx} × {ny} with spacings {} and {} (allowed: at least one point, spacings > 0)", self.x.1, self.y.1)));
        }
        if self.values.len() != nx * ny {
            return Err(fail(format!("{} values for a {nx} × {ny} grid", self.values.len())));
        }
        let finite: Vec<f64> = self.values.iter().copied().filter(|v| v.is_finite()).collect();
        if finite.is_empty() {
            return Err(fail("no finite value to draw".into()));
        }
        let (lo, hi) = match self.range {
            Some(r) => r,
            None if self.diverging => {
                let m = finite.iter().fold(0.0f64, |a, b| a.max(b.abs()));
                (-m, m)
            }
            None => (finite.iter().cloned().fold(f64::INFINITY, f64::min), finite.iter().cloned().fold(f64::NEG_INFINITY, f64::max)),
        };
        let (lo, hi) = if hi > lo { (lo, hi) } else { (lo - 1.0, lo + 1.0) };
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(fail(format!("colour range {lo}…{hi} is not finite")));
        }
        let span_x = nx as f64 * self.x.1;
        let span_y = ny as f64 * self.y.1;
        let plot_w = self.width.unwrap_or_else(|| (nx as f64 * 8.0).clamp(640.0, 1800.0) as u32) as f64;
        let plot_h = (plot_w * span_y / span_x).clamp(60.0, 2000.0);
        save(&Drawn { map: self, range: (lo, hi), plot: (plot_w.round() as u32, plot_h.round() as u32) }, dir, stem)
    }
}

struct Drawn<'a> {
    map: &'a FieldMap,
    range: (f64, f64),
    plot: (u32, u32),
}

impl Drawn<'_> {
    fn colour(&self, v: f64) -> RGBColor {
        let (lo, hi) = self.range;
        if !v.is_finite() {
            return WHITE;
        }
        if self.map.diverging {
            let m = hi.abs().max(lo.abs());
            diverging(if m > 0.0 { v / m } else { 0.0 })
        } else {
            sequential((v - lo) / (hi - lo))
        }
    }
}

impl Figure for Drawn<'_> {
    fn size(&self) -> (u32, u32) {
        (LEFT_MARGIN + LEFT + self.plot.0 + BAR_GAP + BAR_WIDTH + BAR_LABELS, TOP + self.plot.1 + BOTTOM + BOTTOM_MARGIN)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let m = self.map;
        let (x0, dx, nx) = m.x;
        let (y0, dy, ny) = m.y;
        // cells are centred on the grid points
        let (vx0, vx1) = (x0 - 0.5 * dx, x0 + (nx as f64 - 0.5) * dx);
        let (vy0, vy1) = (y0 - 0.5 * dy, y0 + (ny as f64 - 0.5) * dy);
        let (w, h) = self.size();
        let (main, bar) = root.split_horizontally(w - BAR_GAP - BAR_WIDTH - BAR_LABELS);
        let mut chart = data_axes(&main, TOP, 0, vx0..vx1, vy0..vy1, &m.x_label, &m.y_label)?;
        let cells = (0..ny).flat_map(|j| (0..nx).map(move |i| (i, j))).map(|(i, j)| {
            let (cx, cy) = (x0 + i as f64 * dx, y0 + j as f64 * dy);
            Rectangle::new([(cx - 0.5 * dx, cy - 0.5 * dy), (cx + 0.5 * dx, cy + 0.5 * dy)], self.colour(m.values[j * nx + i]).filled())
        });
        chart.draw_series(cells).map_err(e)?;
        // colour bar
        let bar_top = TOP as i32;
        let bar_h = self.plot.1 as i32;
        let steps = 128;
        let (lo, hi) = self.range;
        let (lo_c, hi_c) = if m.diverging {
            let mm = hi.abs().max(lo.abs());
            (-mm, mm)
        } else {
            (lo, hi)
        };
        for k in 0..steps {
            let t0 = k as f64 / steps as f64;
            let v = lo_c + (hi_c - lo_c) * (t0 + 0.5 / steps as f64);
            let ya = bar_top + bar_h - ((k + 1) as f64 / steps as f64 * bar_h as f64).round() as i32;
            let yb = bar_top + bar_h - (t0 * bar_h as f64).round() as i32;
            bar.draw(&Rectangle::new([(BAR_GAP as i32, ya), ((BAR_GAP + BAR_WIDTH) as i32, yb)], self.colour(v).filled())).map_err(e)?;
        }
        bar.draw(&Rectangle::new([(BAR_GAP as i32, bar_top), ((BAR_GAP + BAR_WIDTH) as i32, bar_top + bar_h)], BLACK.stroke_width(1))).map_err(e)?;
        for k in 0..=4 {
            let t = k as f64 / 4.0;
            let v = lo_c + (hi_c - lo_c) * t;
            let y = bar_top + bar_h - (t * bar_h as f64).round() as i32;
            bar.draw(&PathElement::new(vec![((BAR_GAP + BAR_WIDTH) as i32, y), ((BAR_GAP + BAR_WIDTH + 5) as i32, y)], BLACK.stroke_width(1))).map_err(e)?;
            bar.draw(&Text::new(tick_label(snap_zero(v, hi_c - lo_c)), ((BAR_GAP + BAR_WIDTH + 8) as i32, y - 8), text(TICK_SIZE))).map_err(e)?;
        }
        if !m.bar_label.is_empty() {
            bar.draw(&Text::new(m.bar_label.as_str(), (4, (TOP as i32 - 26).max(2)), text(TICK_SIZE))).map_err(e)?;
        }
        if !m.title.is_empty() {
            root.draw(&Text::new(m.title.as_str(), ((LEFT_MARGIN + LEFT) as i32, 12), text(TITLE_SIZE))).map_err(e)?;
        }
        let _ = h;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_maps_have_the_right_ends() {
        assert_eq!(diverging(0.0), RGBColor(255, 255, 255));
        assert_eq!(diverging(1.0), RGBColor(178, 24, 43));
        assert_eq!(diverging(-2.0), RGBColor(33, 102, 172));
        assert_eq!(sequential(0.0), RGBColor(255, 255, 255));
        assert_eq!(sequential(1.0), RGBColor(128, 0, 38));
    }

    #[test]
    fn bad_grids_are_refused() {
        let dir = std::env::temp_dir();
        let e = FieldMap::new("", (0.0, 1.0, 2), (0.0, 1.0, 2), &[1.0; 3]).save(&dir, "x").unwrap_err();
        assert!(e.to_string().contains("3 values"), "{e}");
        let e = FieldMap::new("", (0.0, 1.0, 2), (0.0, 1.0, 1), &[f64::NAN; 2]).save(&dir, "x").unwrap_err();
        assert!(e.to_string().contains("no finite"), "{e}");
    }
}
