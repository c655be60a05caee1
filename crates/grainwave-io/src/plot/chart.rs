//! The x–y chart behind [`LinePlot`](super::LinePlot) and [`Histogram`](super::Histogram):
//! axes (linear or logarithmic), layers of lines, markers, error bands and bars, and a legend.

use super::geometry::{clip_polygon, clip_segment, Rect};
use super::style::{text, tick_label, Figure, GRID_BOLD, GRID_LIGHT, LABEL_SIZE, LINE_WIDTH, PALETTE, TICK_SIZE, TITLE_SIZE};
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::Shift;
use plotters::prelude::*;

/// Where the legend goes inside the plotting area.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LegendPosition {
    /// Top right corner (default).
    #[default]
    UpperRight,
    /// Top left corner.
    UpperLeft,
    /// Bottom right corner.
    LowerRight,
    /// Bottom left corner.
    LowerLeft,
}

impl LegendPosition {
    fn plotters(self) -> SeriesLabelPosition {
        match self {
            LegendPosition::UpperRight => SeriesLabelPosition::UpperRight,
            LegendPosition::UpperLeft => SeriesLabelPosition::UpperLeft,
            LegendPosition::LowerRight => SeriesLabelPosition::LowerRight,
            LegendPosition::LowerLeft => SeriesLabelPosition::LowerLeft,
        }
    }
}

/// One thing drawn on the axes.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Layer {
    /// A polyline through (x, y); non-finite points (and non-positive ones on log axes) break it.
    Line { name: String, x: Vec<f64>, y: Vec<f64>, dashed: bool },
    /// Markers at (x, y).
    Scatter { name: String, x: Vec<f64>, y: Vec<f64> },
    /// A line at `mean` and a shaded band mean ± spread.
    Band { name: String, x: Vec<f64>, mean: Vec<f64>, spread: Vec<f64> },
    /// Bars over bins `edges[k]..edges[k+1]` of height `heights[k]`, from the bottom of the axis.
    Bars { name: String, edges: Vec<f64>, heights: Vec<f64> },
}

impl Layer {
    fn name(&self) -> &str {
        match self {
            Layer::Line { name, .. } | Layer::Scatter { name, .. } | Layer::Band { name, .. } | Layer::Bars { name, .. } => name,
        }
    }

    /// Number of points (x, y) that must match.
    fn check(&self) -> Result<(), String> {
        let (what, lengths): (&str, Vec<usize>) = match self {
            Layer::Line { x, y, .. } | Layer::Scatter { x, y, .. } => ("x and y", vec![x.len(), y.len()]),
            Layer::Band { x, mean, spread, .. } => ("x, mean and spread", vec![x.len(), mean.len(), spread.len()]),
            Layer::Bars { edges, heights, .. } => ("edges and heights + 1", vec![edges.len(), heights.len() + 1]),
        };
        if lengths.windows(2).any(|w| w[0] != w[1]) {
            return Err(format!("series `{}`: {what} must have the same length, got {lengths:?}", self.name()));
        }
        Ok(())
    }
}

/// The x and y ranges of a chart, each (min, max).
type Ranges = ((f64, f64), (f64, f64));

/// Axis settings shared by all chart figures.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub log_x: bool,
    pub log_y: bool,
    pub x_range: Option<(f64, f64)>,
    pub y_range: Option<(f64, f64)>,
    pub size: (u32, u32),
    pub legend: LegendPosition,
    pub layers: Vec<Layer>,
}

/// Smallest and largest usable value (finite; positive on a log axis).
fn extent(values: impl Iterator<Item = f64>, log: bool) -> Option<(f64, f64)> {
    values.filter(|v| v.is_finite() && (!log || *v > 0.0)).fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

fn union(a: Option<(f64, f64)>, b: Option<(f64, f64)>) -> Option<(f64, f64)> {
    match (a, b) {
        (Some(a), Some(b)) => Some((a.0.min(b.0), a.1.max(b.1))),
        (a, None) => a,
        (None, b) => b,
    }
}

/// Most decades a log axis spans by default: data further below the largest value are clipped
/// (a range of hundreds of decades, e.g. a kinetic energy that reaches 1e-300, is unreadable and
/// makes the tick generation of the plotting backend practically endless).
pub(crate) const MAX_LOG_DECADES: f64 = 40.0;

/// Widens a data extent by 4 % on each side (in log space on a log axis); a degenerate extent
/// becomes ±1 around its value (× or ÷ 10 on a log axis). A log axis spans at most
/// [`MAX_LOG_DECADES`] below its largest value.
fn pad((lo, hi): (f64, f64), log: bool) -> (f64, f64) {
    if log {
        let (a, b) = (lo.log10(), hi.log10());
        let a = a.max(b - MAX_LOG_DECADES);
        let (a, b) = if b - a < 1e-12 { (a - 1.0, b + 1.0) } else { (a - 0.04 * (b - a), b + 0.04 * (b - a)) };
        (10f64.powf(a), 10f64.powf(b))
    } else if hi - lo <= 1e-12 * hi.abs().max(lo.abs()).max(f64::MIN_POSITIVE) {
        (lo - lo.abs().max(1.0), hi + hi.abs().max(1.0))
    } else {
        (lo - 0.04 * (hi - lo), hi + 0.04 * (hi - lo))
    }
}

/// A tick value that is zero up to rounding (|v| < 10⁻⁹ × axis span) is shown as 0.
pub(crate) fn snap_zero(v: f64, span: f64) -> f64 {
    if v.abs() < 1e-9 * span.abs() {
        0.0
    } else {
        v
    }
}

fn to_axis(v: f64, log: bool) -> f64 {
    if log {
        v.log10()
    } else {
        v
    }
}

fn from_axis(v: f64, log: bool) -> f64 {
    if log {
        10f64.powf(v)
    } else {
        v
    }
}

impl Chart {
    pub(crate) fn new(title: &str) -> Self {
        Chart {
            title: title.to_string(),
            x_label: String::new(),
            y_label: String::new(),
            log_x: false,
            log_y: false,
            x_range: None,
            y_range: None,
            size: super::style::DEFAULT_SIZE,
            legend: LegendPosition::default(),
            layers: Vec::new(),
        }
    }

    /// The axis ranges: given ones, or the data extent padded; with bars on a linear y axis,
    /// the range includes 0.
    fn ranges(&self) -> Result<Ranges, String> {
        let mut xs = None;
        let mut ys = None;
        for layer in &self.layers {
            layer.check()?;
            match layer {
                Layer::Line { x, y, .. } | Layer::Scatter { x, y, .. } => {
                    let ok: Vec<(f64, f64)> = x.iter().zip(y).map(|(&a, &b)| (a, b)).filter(|p| self.usable(*p)).collect();
                    xs = union(xs, extent(ok.iter().map(|p| p.0), self.log_x));
                    ys = union(ys, extent(ok.iter().map(|p| p.1), self.log_y));
                }
                Layer::Band { x, mean, spread, .. } => {
                    let ok: Vec<usize> = (0..x.len()).filter(|&k| self.usable((x[k], mean[k])) && spread[k].is_finite()).collect();
                    xs = union(xs, extent(ok.iter().map(|&k| x[k]), self.log_x));
                    ys = union(ys, extent(ok.iter().flat_map(|&k| [mean[k] - spread[k].abs(), mean[k] + spread[k].abs()]), self.log_y));
                    ys = union(ys, extent(ok.iter().map(|&k| mean[k]), self.log_y));
                }
                Layer::Bars { edges, heights, .. } => {
                    xs = union(xs, extent(edges.iter().copied(), self.log_x));
                    ys = union(ys, extent(heights.iter().copied(), self.log_y));
                    if !self.log_y {
                        ys = union(ys, Some((0.0, 0.0)));
                    }
                }
            }
        }
        let bars_only_linear_y = !self.log_y && self.layers.iter().all(|l| matches!(l, Layer::Bars { .. }));
        let x = match self.x_range {
            Some(r) => r,
            None => pad(xs.ok_or("no finite data to plot (on a log axis, values must be > 0)")?, self.log_x),
        };
        let y = match self.y_range {
            Some(r) => r,
            None => {
                let (lo, hi) = pad(ys.ok_or("no finite data to plot (on a log axis, values must be > 0)")?, self.log_y);
                // Histograms start at zero.
                if bars_only_linear_y {
                    (0.0, hi)
                } else {
                    (lo, hi)
                }
            }
        };
        for ((lo, hi), log, axis) in [(x, self.log_x, "x"), (y, self.log_y, "y")] {
            if !(lo.is_finite() && hi.is_finite() && lo < hi) || (log && lo <= 0.0) {
                return Err(format!("invalid {axis} range {lo}…{hi}{}", if log { " for a log axis" } else { "" }));
            }
        }
        Ok((x, y))
    }

    fn usable(&self, (x, y): (f64, f64)) -> bool {
        x.is_finite() && y.is_finite() && (!self.log_x || x > 0.0) && (!self.log_y || y > 0.0)
    }

    /// Clipping rectangle in axis space (log10 of the values on log axes).
    fn clip_rect(&self, (x, y): Ranges) -> Rect {
        Rect { x0: to_axis(x.0, self.log_x), x1: to_axis(x.1, self.log_x), y0: to_axis(y.0, self.log_y), y1: to_axis(y.1, self.log_y) }
    }

    fn point_to_axis(&self, p: (f64, f64)) -> (f64, f64) {
        (to_axis(p.0, self.log_x), to_axis(p.1, self.log_y))
    }

    fn point_from_axis(&self, p: (f64, f64)) -> (f64, f64) {
        (from_axis(p.0, self.log_x), from_axis(p.1, self.log_y))
    }

    /// The visible pieces of the polyline through `points`, in data coordinates.
    fn polylines(&self, points: impl Iterator<Item = (f64, f64)>, rect: &Rect) -> Vec<Vec<(f64, f64)>> {
        let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
        let mut current: Vec<(f64, f64)> = Vec::new();
        let mut prev: Option<(f64, f64)> = None;
        for p in points {
            if !self.usable(p) {
                prev = None;
                continue;
            }
            let q = self.point_to_axis(p);
            if let Some(a) = prev {
                match clip_segment(a, q, rect) {
                    Some((s, e)) => {
                        let continues = current.last().is_some_and(|&l| l == self.point_from_axis(s));
                        if !continues && !current.is_empty() {
                            out.push(std::mem::take(&mut current));
                        }
                        if current.is_empty() {
                            current.push(self.point_from_axis(s));
                        }
                        current.push(self.point_from_axis(e));
                    }
                    None => {
                        if !current.is_empty() {
                            out.push(std::mem::take(&mut current));
                        }
                    }
                }
            } else if rect.contains(q) && current.is_empty() {
                current.push(p);
            }
            prev = Some(q);
        }
        if !current.is_empty() {
            out.push(current);
        }
        out
    }

    /// The visible part of a polygon given in data coordinates.
    fn polygon(&self, points: &[(f64, f64)], rect: &Rect) -> Vec<(f64, f64)> {
        let axis: Vec<(f64, f64)> = points.iter().map(|&p| self.point_to_axis(p)).collect();
        clip_polygon(&axis, rect).into_iter().map(|p| self.point_from_axis(p)).collect()
    }

    fn draw_layers<'a, DB, X, Y>(&self, chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>, ranges: Ranges) -> Result<(), String>
    where
        DB: DrawingBackend + 'a,
        X: Ranged<ValueType = f64> + ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
    {
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let (x_span, y_span) = (ranges.0 .1 - ranges.0 .0, ranges.1 .1 - ranges.1 .0);
        // Rounding residues near zero are snapped on linear axes only: on a log axis every tick is
        // a genuine (positive) value, however small.
        let (log_x, log_y) = (self.log_x, self.log_y);
        let x_fmt = move |v: &f64| tick_label(if log_x { *v } else { snap_zero(*v, x_span) });
        let y_fmt = move |v: &f64| tick_label(if log_y { *v } else { snap_zero(*v, y_span) });
        chart
            .configure_mesh()
            .bold_line_style(GRID_BOLD)
            .light_line_style(GRID_LIGHT)
            .max_light_lines(4)
            .axis_style(BLACK.stroke_width(1))
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .axis_desc_style(text(LABEL_SIZE))
            .label_style(text(TICK_SIZE))
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .x_labels(8)
            .y_labels(8)
            .draw()
            .map_err(e)?;
        let rect = self.clip_rect(ranges);
        let y_bottom = ranges.1 .0;
        let mut legend = false;
        for (colour_index, layer) in self.layers.iter().enumerate() {
            let colour = PALETTE[colour_index % PALETTE.len()];
            // past the palette's length the colours repeat; every second round of them flips
            // solid and dashed lines and fills, so that no two series look alike
            let second_round = (colour_index / PALETTE.len()) % 2 == 1;
            let name = layer.name().to_string();
            let line = colour.stroke_width(LINE_WIDTH);
            let anno = match layer {
                Layer::Line { x, y, dashed, .. } => {
                    let dashed = *dashed != second_round;
                    let pieces = self.polylines(x.iter().copied().zip(y.iter().copied()), &rect);
                    let mut anno = None;
                    for piece in pieces {
                        anno = Some(if dashed {
                            chart.draw_series(DashedLineSeries::new(piece, 9, 6, line)).map_err(e)?
                        } else {
                            chart.draw_series(LineSeries::new(piece, line)).map_err(e)?
                        });
                    }
                    anno.map(|a| {
                        if dashed {
                            a.legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 8, y)], line).into_dyn())
                        } else {
                            a.legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], line).into_dyn())
                        }
                    })
                }
                Layer::Scatter { x, y, .. } => {
                    let points: Vec<(f64, f64)> = x.iter().copied().zip(y.iter().copied()).filter(|&p| self.usable(p) && rect.contains(self.point_to_axis(p))).collect();
                    let fill = if second_round { colour.stroke_width(2) } else { colour.filled() };
                    let a = chart.draw_series(points.into_iter().map(|p| Circle::new(p, 4, fill))).map_err(e)?;
                    Some(a.legend(move |(x, y)| Circle::new((x + 11, y), 4, fill).into_dyn()))
                }
                Layer::Band { x, mean, spread, .. } => {
                    let idx: Vec<usize> = (0..x.len()).filter(|&k| self.usable((x[k], mean[k])) && spread[k].is_finite()).collect();
                    // On a log axis a lower edge ≤ 0 is drawn at the bottom of the axis.
                    let lower = |k: usize| {
                        let v = mean[k] - spread[k].abs();
                        if self.log_y && v <= 0.0 {
                            y_bottom
                        } else {
                            v
                        }
                    };
                    // One polygon per run of consecutive usable points (upper edge forward, lower
                    // edge back). Sutherland–Hodgman clipping against the convex plotting
                    // rectangle fills correctly for such non-convex polygons too.
                    let shade = colour.mix(0.22).filled();
                    let mut runs: Vec<Vec<usize>> = Vec::new();
                    for &k in &idx {
                        match runs.last_mut() {
                            Some(run) if *run.last().expect("runs are non-empty") + 1 == k => run.push(k),
                            _ => runs.push(vec![k]),
                        }
                    }
                    for run in runs.iter().filter(|r| r.len() >= 2) {
                        let mut outline: Vec<(f64, f64)> = run.iter().map(|&k| (x[k], mean[k] + spread[k].abs())).collect();
                        outline.extend(run.iter().rev().map(|&k| (x[k], lower(k))));
                        let visible = self.polygon(&outline, &rect);
                        if visible.len() >= 3 {
                            chart.draw_series(std::iter::once(Polygon::new(visible, shade))).map_err(e)?;
                        }
                    }
                    let mut anno = None;
                    for piece in self.polylines(idx.iter().map(|&k| (x[k], mean[k])), &rect) {
                        anno = Some(chart.draw_series(LineSeries::new(piece, line)).map_err(e)?);
                    }
                    anno.map(|a| {
                        a.legend(move |(x, y)| {
                            EmptyElement::at((x, y))
                                + Rectangle::new([(0, -6), (22, 6)], shade)
                                + PathElement::new(vec![(0, 0), (22, 0)], line)
                        })
                    })
                }
                Layer::Bars { edges, heights, .. } => {
                    let fill = colour.mix(0.55).filled();
                    let border = colour.stroke_width(1);
                    let mut anno = None;
                    for (k, &h) in heights.iter().enumerate() {
                        let (x0, x1) = (edges[k], edges[k + 1]);
                        if !(h.is_finite() && x0.is_finite() && x1.is_finite()) || (self.log_y && h <= 0.0) || (self.log_x && x0 <= 0.0) {
                            continue;
                        }
                        let visible = self.polygon(&[(x0, y_bottom), (x1, y_bottom), (x1, h), (x0, h)], &rect);
                        if visible.len() >= 3 {
                            let mut closed = visible.clone();
                            closed.push(visible[0]);
                            chart.draw_series(std::iter::once(Polygon::new(visible, fill))).map_err(e)?;
                            anno = Some(chart.draw_series(std::iter::once(PathElement::new(closed, border))).map_err(e)?);
                        }
                    }
                    anno.map(|a| a.legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 22, y + 6)], fill).into_dyn()))
                }
            };
            if let Some(anno) = anno {
                if !name.is_empty() {
                    anno.label(name);
                    legend = true;
                }
            }
        }
        if legend {
            chart
                .configure_series_labels()
                .position(self.legend.plotters())
                .margin(12)
                .legend_area_size(30)
                .label_font(text(TICK_SIZE))
                .background_style(WHITE.mix(0.85))
                .border_style(RGBColor(160, 160, 160))
                .draw()
                .map_err(e)?;
        }
        Ok(())
    }
}

impl Figure for Chart {
    fn size(&self) -> (u32, u32) {
        self.size
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        if self.layers.is_empty() {
            return Err("the plot has no data series".into());
        }
        let ranges = self.ranges()?;
        let ((x0, x1), (y0, y1)) = ranges;
        let mut builder = ChartBuilder::on(root);
        builder.margin(18).margin_right(28).x_label_area_size(62).y_label_area_size(if self.y_label.is_empty() { 80 } else { 104 });
        if !self.title.is_empty() {
            builder.caption(&self.title, text(TITLE_SIZE));
        }
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        match (self.log_x, self.log_y) {
            (false, false) => {
                let mut c = builder.build_cartesian_2d(x0..x1, y0..y1).map_err(e)?;
                self.draw_layers(&mut c, ranges)
            }
            (true, false) => {
                let mut c = builder.build_cartesian_2d((x0..x1).log_scale(), y0..y1).map_err(e)?;
                self.draw_layers(&mut c, ranges)
            }
            (false, true) => {
                let mut c = builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()).map_err(e)?;
                self.draw_layers(&mut c, ranges)
            }
            (true, true) => {
                let mut c = builder.build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale()).map_err(e)?;
                self.draw_layers(&mut c, ranges)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axes_span_at_most_max_log_decades_and_still_render() {
        let mut c = Chart::new("t");
        c.log_y = true;
        c.layers.push(Layer::Line { name: "ke".into(), x: vec![0.0, 1.0, 2.0], y: vec![1.0, 1e-150, 1e-300], dashed: false });
        let (_, (y0, y1)) = c.ranges().unwrap();
        assert!(y1 > 1.0 && y0 >= 10f64.powf(-1.05 * MAX_LOG_DECADES) && y0 < 1e-39, "{y0} {y1}"); // 40 decades + 4 % padding
        // a span of 300 decades used to keep the backend's tick generation busy practically forever
        let dir = std::env::temp_dir().join(format!("grainwave-io-{}-logspan", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        crate::plot::LinePlot::new("t").log_y().series("ke", &[0.0, 1.0, 2.0], &[1.0, 1e-150, 1e-300]).save(&dir, "ke").unwrap();
        assert!(std::fs::metadata(dir.join("ke.png")).unwrap().len() > 0);
    }

    #[test]
    fn ranges_follow_data_and_axes() {
        let mut c = Chart::new("t");
        c.layers.push(Layer::Line { name: "a".into(), x: vec![1.0, 10.0, 100.0], y: vec![-1.0, 2.0, f64::NAN], dashed: false });
        let ((x0, x1), (y0, y1)) = c.ranges().unwrap();
        assert!(x0 < 1.0 && x1 > 10.0 && x1 < 100.0, "the NaN point is ignored: {x0} {x1}");
        assert!(y0 < -1.0 && y1 > 2.0);
        c.log_y = true;
        let (_, (y0, y1)) = c.ranges().unwrap();
        assert!(y0 > 0.0 && y0 < 2.0 && y1 > 2.0, "only y = 2 is usable on a log axis: {y0} {y1}");
        c.layers[0] = Layer::Line { name: "a".into(), x: vec![1.0], y: vec![-1.0], dashed: false };
        assert!(c.ranges().unwrap_err().contains("no finite data"));
        c.layers[0] = Layer::Line { name: "a".into(), x: vec![1.0, 2.0], y: vec![1.0], dashed: false };
        assert!(c.ranges().unwrap_err().contains("same length"));
    }

    #[test]
    fn polylines_break_at_gaps_and_clip() {
        let mut c = Chart::new("t");
        c.x_range = Some((0.0, 10.0));
        let rect = Rect { x0: 0.0, x1: 10.0, y0: 0.0, y1: 1.0 };
        let pts = [(-5.0, 0.5), (5.0, 0.5), (f64::NAN, 0.0), (6.0, 0.5), (7.0, 0.5), (8.0, 5.0), (9.0, 0.5)];
        let pieces = c.polylines(pts.iter().copied(), &rect);
        assert_eq!(pieces.len(), 3, "{pieces:?}");
        assert_eq!(pieces[0], vec![(0.0, 0.5), (5.0, 0.5)]);
        assert_eq!(pieces[1][..2], [(6.0, 0.5), (7.0, 0.5)]);
        assert!(pieces[1].last().unwrap().1 == 1.0 && pieces[2][0].1 == 1.0, "cut at the top edge: {pieces:?}");
        c.log_x = true;
        let rect = Rect { x0: 0.0, x1: 2.0, y0: 0.0, y1: 1.0 };
        let pieces = c.polylines([(1.0, 0.5), (10.0, 0.5), (1000.0, 0.5)].into_iter(), &rect);
        let end = pieces[0].last().unwrap().0;
        assert!((end - 100.0).abs() < 1e-9, "clipped at 10² in log space: {pieces:?}");
    }
}
