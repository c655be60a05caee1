//! The frame of the pictures drawn in data coordinates ([`super::PackingPicture`],
//! [`super::FieldMap`], [`super::ContactChangePicture`]): the margins around the plot area and
//! the axes with their labels and tick labels, without grid lines (the picture itself fills the
//! area). One place for the axis setup the three pictures share.

use super::chart::snap_zero;
use super::style::{text, tick_label, LABEL_SIZE, TICK_SIZE};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::ops::Range;

/// Width of the y axis area (tick labels and label) [px].
pub(crate) const LEFT: u32 = 84;
/// Space left of the y axis area [px].
pub(crate) const LEFT_MARGIN: u32 = 14;
/// Height of the x axis area [px].
pub(crate) const BOTTOM: u32 = 64;
/// Space below the x axis area [px].
pub(crate) const BOTTOM_MARGIN: u32 = 8;
/// Space right of the plot area when nothing is drawn there [px].
pub(crate) const RIGHT: u32 = 26;

/// A chart in data coordinates.
pub(crate) type DataChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Builds the chart of a picture on `area`: `top` and `right` pixels left free above and right
/// of it (title, notes; nothing or a colour bar), the data ranges `x` × `y`, and the axes drawn
/// with `x_label` and `y_label` (tick labels within 10⁻⁹ of the span of zero read 0).
pub(crate) fn data_axes<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    top: u32,
    right: u32,
    x: Range<f64>,
    y: Range<f64>,
    x_label: &str,
    y_label: &str,
) -> Result<DataChart<'a, DB>, String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (x_span, y_span) = (x.end - x.start, y.end - y.start);
    let mut chart = ChartBuilder::on(area)
        .margin_top(top)
        .margin_right(right)
        .margin_left(LEFT_MARGIN)
        .margin_bottom(BOTTOM_MARGIN)
        .x_label_area_size(BOTTOM)
        .y_label_area_size(LEFT)
        .build_cartesian_2d(x, y)
        .map_err(e)?;
    let x_fmt = move |v: &f64| tick_label(snap_zero(*v, x_span));
    let y_fmt = move |v: &f64| tick_label(snap_zero(*v, y_span));
    chart
        .configure_mesh()
        .disable_mesh()
        .axis_style(BLACK.stroke_width(1))
        .x_desc(x_label)
        .y_desc(y_label)
        .axis_desc_style(text(LABEL_SIZE))
        .label_style(text(TICK_SIZE))
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .draw()
        .map_err(e)?;
    Ok(chart)
}
