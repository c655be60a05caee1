//! The house style of grainwave figures, the embedded font, and saving a figure as PNG + SVG.

use crate::error::{OutputError, Result};
use crate::series::check_stem;
use grainwave_core::checkpoint::atomic_write;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// DejaVu Sans 2.37 (Bitstream Vera licence, see `fonts/LICENSE-DejaVu.txt`), compiled in so
/// that text renders without any system font library.
static FONT: &[u8] = include_bytes!("../../fonts/DejaVuSans.ttf");

/// Font family of all text: the embedded font is registered under this name (and under
/// plotters' default `sans-serif`); SVG files name it as a CSS font list, so viewers use DejaVu
/// Sans where installed (the PNG's metrics) and their sans-serif font otherwise.
pub(crate) const FAMILY: &str = "DejaVu Sans, sans-serif";
/// Title size in pixels.
pub(crate) const TITLE_SIZE: f64 = 26.0;
/// Axis description size in pixels.
pub(crate) const LABEL_SIZE: f64 = 21.0;
/// Tick label and legend size in pixels.
pub(crate) const TICK_SIZE: f64 = 17.0;
/// Default figure size in pixels (width, height).
pub(crate) const DEFAULT_SIZE: (u32, u32) = (900, 640);
/// Line width of data series in pixels.
pub(crate) const LINE_WIDTH: u32 = 2;

/// Line colours, in order of use: a colour-blind-safe qualitative palette (Okabe–Ito, with
/// black moved to the end).
pub(crate) const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(240, 228, 66),  // yellow
    RGBColor(0, 0, 0),       // black
];

/// Grid lines.
pub(crate) const GRID_BOLD: RGBColor = RGBColor(215, 215, 215);
/// Minor grid lines.
pub(crate) const GRID_LIGHT: RGBColor = RGBColor(238, 238, 238);

/// Registers the embedded font with plotters (once per process).
pub(crate) fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        [FAMILY, "sans-serif"].iter().all(|family| plotters::style::register_font(family, FontStyle::Normal, FONT).is_ok())
    });
    if ok {
        Ok(())
    } else {
        Err("the embedded DejaVu Sans font could not be loaded".into())
    }
}

/// A text style of the house font.
pub(crate) fn text(size: f64) -> TextStyle<'static> {
    (FAMILY, size).into_font().color(&BLACK)
}

const SUPERSCRIPT: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];

fn superscript(n: i32) -> String {
    let mut s = String::new();
    if n < 0 {
        s.push('⁻');
    }
    for d in n.unsigned_abs().to_string().bytes() {
        s.push(SUPERSCRIPT[(d - b'0') as usize]);
    }
    s
}

/// A tick label: plain decimals for magnitudes in [10⁻³, 10⁵), otherwise `m×10ⁿ` (or `10ⁿ`
/// for powers of ten), with at most four significant digits and no trailing zeros.
pub(crate) fn tick_label(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return if v == 0.0 { "0".into() } else { format!("{v}") };
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let digits = (3 - a.log10().floor() as i32).clamp(0, 7) as usize;
        let s = format!("{v:.digits$}");
        let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
        return if s == "-0" { "0".into() } else { s };
    }
    let mut exponent = a.log10().floor() as i32;
    let mut mantissa = v / 10f64.powi(exponent);
    mantissa = (mantissa * 1000.0).round() / 1000.0;
    if mantissa.abs() >= 10.0 {
        mantissa /= 10.0;
        exponent += 1;
    }
    let m = format!("{mantissa:.3}");
    let m = m.trim_end_matches('0').trim_end_matches('.');
    match m {
        "1" => format!("10{}", superscript(exponent)),
        "-1" => format!("−10{}", superscript(exponent)),
        _ => format!("{m}×10{}", superscript(exponent)),
    }
}

/// The two files of a saved figure.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlotFiles {
    /// `<dir>/<stem>.png` (8-bit RGB).
    pub png: PathBuf,
    /// `<dir>/<stem>.svg`.
    pub svg: PathBuf,
}

/// Something that draws itself on any plotters backend.
pub(crate) trait Figure {
    /// Size in pixels (width, height).
    fn size(&self) -> (u32, u32);
    /// Draws the whole figure on `root` (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Draws `figure` twice — into an RGB bitmap encoded as PNG and into an SVG document — and
/// writes `<dir>/<stem>.png` and `<dir>/<stem>.svg` atomically.
pub(crate) fn save<F: Figure>(figure: &F, dir: &Path, stem: &str) -> Result<PlotFiles> {
    check_stem(stem)?;
    let plot_error = |reason: String| OutputError::Plot { stem: stem.to_string(), reason };
    ensure_font().map_err(plot_error)?;
    let (w, h) = figure.size();
    if w < 16 || h < 16 || w > 16384 || h > 16384 {
        return Err(plot_error(format!("figure size {w}×{h} px is outside 16…16384")));
    }
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(e.to_string()))?;
        figure.draw(&root).map_err(plot_error)?;
        root.present().map_err(|e| plot_error(e.to_string()))?;
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(e.to_string()))?;
        figure.draw(&root).map_err(plot_error)?;
        root.present().map_err(|e| plot_error(e.to_string()))?;
    }
    let png = encode_png(&rgb, w, h).map_err(plot_error)?;
    let files = PlotFiles { png: dir.join(format!("{stem}.png")), svg: dir.join(format!("{stem}.svg")) };
    atomic_write(&files.png, &png)?;
    atomic_write(&files.svg, svg.as_bytes())?;
    Ok(files)
}

fn encode_png(rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, w, h);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(rgb).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels() {
        let cases = [
            (0.0, "0"),
            (1.0, "1"),
            (0.5, "0.5"),
            (-2.25, "-2.25"),
            (0.30000000000000004, "0.3"),
            (1234.0, "1234"),
            (12.25, "12.25"),
            (0.0123, "0.0123"),
            (0.001, "0.001"),
            (1e-5, "10⁻⁵"),
            (1e-5 * (1.0 + 2.0 * f64::EPSILON), "10⁻⁵"),
            (2.5e-7, "2.5×10⁻⁷"),
            (1e6, "10⁶"),
            (-3e8, "-3×10⁸"),
            (9.9996e5, "10⁶"),
        ];
        for (v, expected) in cases {
            assert_eq!(tick_label(v), expected, "{v}");
        }
    }

    #[test]
    fn font_registers() {
        ensure_font().unwrap();
        ensure_font().unwrap();
    }
}
