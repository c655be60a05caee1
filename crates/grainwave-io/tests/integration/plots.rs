//! Figures are produced as valid, non-empty PNG and SVG files with rendered text.
//!
//! Set `GRAINWAVE_PLOT_DIR=/some/dir` to keep the figures for looking at them.

use crate::common;

use common::{periodic_pile, scratch_dir, settled_pile};
use grainwave_core::prelude::*;
use grainwave_io::plot::{Histogram, LegendPosition, LinePlot, Network, PackingPicture, PlotFiles};
use grainwave_io::OutputError;
use std::path::PathBuf;

/// Where figures go: `$GRAINWAVE_PLOT_DIR` (kept) or a scratch directory (removed by the test).
fn out_dir(name: &str) -> (PathBuf, bool) {
    match std::env::var_os("GRAINWAVE_PLOT_DIR") {
        Some(d) => (PathBuf::from(d), true),
        None => (scratch_dir(name), false),
    }
}

struct Png {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
}

impl Png {
    fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let k = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[k], self.rgb[k + 1], self.rgb[k + 2]]
    }

    /// Number of pixels in rows `y0..y1` matching `pred`.
    fn count(&self, y0: u32, y1: u32, pred: impl Fn([u8; 3]) -> bool) -> usize {
        (y0..y1.min(self.height)).flat_map(|y| (0..self.width).map(move |x| (x, y))).filter(|&(x, y)| pred(self.pixel(x, y))).count()
    }
}

/// Checks the PNG signature, decodes the image and returns it; checks the SVG is a document with
/// text in it (`needles` must all appear).
fn check_files(files: &PlotFiles, needles: &[&str]) -> Png {
    let bytes = std::fs::read(&files.png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{}", files.png.display());
    let decoder = png::Decoder::new(std::io::Cursor::new(&bytes[..]));
    let mut reader = decoder.read_info().unwrap();
    let mut rgb = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut rgb).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert!(info.width >= 100 && info.height >= 100, "{}×{}", info.width, info.height);
    rgb.truncate(info.buffer_size());
    let png = Png { width: info.width, height: info.height, rgb };
    let non_white = png.count(0, png.height, |p| p != [255, 255, 255]);
    assert!(non_white > 2000, "{}: only {non_white} non-white pixels", files.png.display());
    let svg = std::fs::read_to_string(&files.svg).unwrap();
    assert!(svg.contains("<svg"), "{}", files.svg.display());
    assert!(svg.contains(&format!("width=\"{}\"", png.width)) && svg.contains(&format!("height=\"{}\"", png.height)), "same size as the PNG");
    assert!(svg.contains("<text"), "{}: no text", files.svg.display());
    for needle in needles {
        assert!(svg.contains(needle), "{}: `{needle}` missing", files.svg.display());
    }
    png
}

/// Dark pixels (text, axes) in the top `rows` rows: the title was rendered with the embedded font.
fn assert_title_rendered(png: &Png, rows: u32) {
    let dark = png.count(0, rows, |p| p.iter().all(|&c| c < 100));
    assert!(dark > 150, "title rows have only {dark} dark pixels: text not rendered");
}

#[test]
fn line_plots_legends_log_axes_and_bands() {
    let (dir, keep) = out_dir("plots-lines");
    // A power law on log–log axes, with a dashed guide and noisy points.
    let t: Vec<f64> = (0..60).map(|k| 10f64.powf(-1.0 + k as f64 / 20.0)).collect();
    let e: Vec<f64> = t.iter().map(|t| 0.5 * t.powf(-1.5) / (1.0 + 0.02 * t)).collect();
    let guide: Vec<f64> = t.iter().map(|t| 0.5 * t.powf(-1.5)).collect();
    let noisy: Vec<f64> = e.iter().enumerate().map(|(k, e)| e * (1.0 + 0.3 * ((k * 7919 % 13) as f64 / 13.0 - 0.5))).step_by(3).collect();
    let t_noisy: Vec<f64> = t.iter().copied().step_by(3).collect();
    let files = LinePlot::new("Kinetic energy decay")
        .x_label("t [t*]")
        .y_label("E_kin [m d² / t*²]")
        .log_x()
        .log_y()
        .series("simulation", &t, &e)
        .dashed("0.5 t^-3/2", &t, &guide)
        .scatter("samples", &t_noisy, &noisy)
        .save(&dir, "line_loglog")
        .unwrap();
    let png = check_files(&files, &["Kinetic energy decay", "t [t*]", "simulation", "0.5 t^-3/2"]);
    assert_eq!((png.width, png.height), (900, 640));
    assert_title_rendered(&png, 45);
    // Coloured pixels of the first series (blue 0, 114, 178).
    assert!(png.count(0, png.height, |p| p == [0, 114, 178]) > 300, "the solid series is drawn");

    // Ensemble mean ± r.m.s. on linear axes, three signals, legend at the lower right.
    let x: Vec<f64> = (0..400).map(|k| k as f64 * 0.05).collect();
    let mut plot = LinePlot::new("Signals at three depths").x_label("t [t*]").y_label("v_y [d / t*]").legend(LegendPosition::LowerRight);
    for (k, depth) in [2.0, 5.0, 10.0].iter().enumerate() {
        let mean: Vec<f64> = x.iter().map(|t| (-(t - depth).powi(2) / (0.5 + 0.2 * k as f64)).exp() * (t - depth).sin()).collect();
        let rms: Vec<f64> = mean.iter().map(|m| 0.05 + 0.2 * m.abs()).collect();
        plot = plot.band(&format!("depth {depth} d"), &x, &mean, &rms);
    }
    let files = plot.save(&dir, "line_bands").unwrap();
    let png = check_files(&files, &["depth 2 d", "depth 10 d"]);
    assert_title_rendered(&png, 45);
    if !keep {
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn series_past_the_palette_are_told_apart_by_dashes() {
    // Nine solid series: the ninth gets the first one's colour (blue 0, 114, 178) again, so it
    // must be drawn dashed. Series 0 runs along the bottom of the plot, series 8 along the top,
    // the others in the middle: the top half holds far fewer blue pixels than the bottom half
    // (dashes of 9 px on, 6 off: ≈ 60 %), where two solid lines would give about the same.
    let (dir, keep) = out_dir("plots-palette");
    let x: Vec<f64> = (0..50).map(|k| k as f64).collect();
    let mut plot = LinePlot::new("Nine series").x_label("x").y_label("y");
    for k in 0..9 {
        let y = match k {
            0 => 0.0,
            8 => 1.0,
            _ => 0.5,
        };
        plot = plot.series(&format!("s{k}"), &x, &vec![y; x.len()]);
    }
    let files = plot.save(&dir, "palette_rounds").unwrap();
    let png = check_files(&files, &["s0", "s8"]);
    let blue = |p: [u8; 3]| p == [0, 114, 178];
    let (top, bottom) = (png.count(0, png.height / 2, blue), png.count(png.height / 2, png.height, blue));
    assert!(bottom > 1000, "the solid first series is drawn: {bottom} px");
    assert!((top as f64) < 0.8 * bottom as f64, "the ninth series is not dashed: {top} blue px on top vs {bottom} below");
    if !keep {
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn histogram_of_contact_forces() {
    let (dir, keep) = out_dir("plots-hist");
    let s = settled_pile();
    let mean = s.contacts.iter().map(|c| c.normal_force).sum::<f64>() / s.contacts.len() as f64;
    let f: Vec<f64> = s.contacts.iter().map(|c| c.normal_force / mean).collect();
    let x: Vec<f64> = (0..100).map(|k| k as f64 * 0.05).collect();
    let exp: Vec<f64> = x.iter().map(|x| (-x).exp()).collect();
    let files = Histogram::new("Normal contact forces")
        .x_label("f = F_n / <F_n>")
        .density()
        .log_y()
        .bins(20)
        .sample("settled pile", &f)
        .curve("exp(-f)", &x, &exp)
        .save(&dir, "force_histogram")
        .unwrap();
    let png = check_files(&files, &["Normal contact forces", "probability density", "exp(-f)"]);
    assert_title_rendered(&png, 45);
    if !keep {
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn packing_pictures_force_and_stiffness_networks_arrows_arrival_map() {
    let (dir, keep) = out_dir("plots-packing");
    let s = settled_pile();
    assert!(s.contacts.len() > 150, "a connected pile: {} contacts", s.contacts.len());
    let at = |id: u32| s.pos[s.id.iter().position(|&k| k == id).unwrap()];
    let periodic = s.contacts.iter().filter(|c| matches!(c.j, Counterpart::Grain(j) if (at(j).x - (at(c.i).x + c.branch.x)).abs() > 1.0)).count();
    assert!(periodic > 0, "the fixture has contacts through the periodic boundary");

    let grains = PackingPicture::new(&s, "Settled pile").x_label("x [d]").y_label("y [d]").save(&dir, "packing_grains").unwrap();
    let png = check_files(&grains, &["Settled pile", "x [d]"]);
    assert_title_rendered(&png, 40);

    let force = PackingPicture::new(&s, "Force network").x_label("x [d]").y_label("y [d]").network(Network::Force).save(&dir, "packing_force_network").unwrap();
    let png = check_files(&force, &["Force network", "line width ∝ F_n"]);
    // Force lines are near-black (20, 20, 20); grains are light grey.
    let lines = png.count(70, png.height - 64, |p| p == [20, 20, 20]);
    assert!(lines > 3000, "force chains drawn: {lines} pixels");
    let empty = PackingPicture::new(&s, "").save(&dir, "packing_plain_untitled").unwrap();
    let plain = check_files(&empty, &[]);
    assert!(plain.count(0, plain.height, |p| p == [20, 20, 20]) < lines / 10, "no network without asking for it");

    let stiffness = PackingPicture::new(&s, "Stiffness network").network(Network::Stiffness).save(&dir, "packing_stiffness_network").unwrap();
    let png = check_files(&stiffness, &["line width ∝ k_n"]);
    assert!(png.count(70, png.height, |p| p == [0, 100, 170]) > 3000, "stiffness lines drawn");

    // A displacement field: rotation about the pile's centre, growing with height.
    let field: Vec<_> = s.pos.iter().map(|p| glam::DVec2::new(-(p.y - 4.0), p.x - 4.8) * (0.01 * p.y)).collect();
    let arrows = PackingPicture::new(&s, "Displacement").arrows(&field, None).save(&dir, "packing_arrows").unwrap();
    let png = check_files(&arrows, &["longest arrow"]);
    assert!(png.count(70, png.height, |p| p == [200, 30, 30]) > 1000, "arrows drawn");

    // Arrival times: a front spreading from the middle of the floor at speed 2, two bands;
    // grains above y = 6 are never reached.
    let times: Vec<f64> = s.pos.iter().map(|p| if p.y > 6.0 { f64::INFINITY } else { ((p.x - 4.8).powi(2) + p.y.powi(2)).sqrt() / 2.0 }).collect();
    let t_f = times.iter().copied().filter(|t| t.is_finite()).fold(0.0, f64::max);
    let arrival = PackingPicture::new(&s, "Arrival times").arrival_times(&times, t_f, 2.0).save(&dir, "packing_arrival_times").unwrap();
    let png = check_files(&arrival, &["not reached"]);
    // Inside the plotting area (clear of title, note and tick labels): many grey levels.
    let mut greys = std::collections::BTreeSet::new();
    for y in 90..png.height - 80 {
        for x in 90..png.width - 40 {
            let p = png.pixel(x, y);
            if p[0] == p[1] && p[1] == p[2] {
                greys.insert(p[0]);
            }
        }
    }
    let pink = png.count(0, png.height, |p| p == [250, 196, 205]);
    assert!(greys.len() > 40 && pink > 1000, "grey bands ({} grey levels) and unreached grains ({pink} pink pixels)", greys.len());

    // The tiny periodic pile with walls and a periodic contact.
    let small = periodic_pile();
    let files = PackingPicture::new(&small, "Periodic contact").network(Network::Force).save(&dir, "packing_periodic_small").unwrap();
    check_files(&files, &["Periodic contact"]);
    if !keep {
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn bad_figures_are_errors_and_write_nothing() {
    let dir = scratch_dir("plots-bad");
    let err = LinePlot::new("empty").save(&dir, "empty").unwrap_err();
    assert!(matches!(err, OutputError::Plot { .. }) && err.to_string().contains("no data series"), "{err}");
    let err = LinePlot::new("lengths").series("a", &[1.0, 2.0], &[1.0]).save(&dir, "lengths").unwrap_err();
    assert!(err.to_string().contains("same length"), "{err}");
    let err = LinePlot::new("log").log_y().series("a", &[1.0, 2.0], &[-1.0, 0.0]).save(&dir, "log").unwrap_err();
    assert!(err.to_string().contains("no finite data"), "{err}");
    let err = LinePlot::new("range").x_range(2.0, 1.0).series("a", &[1.0, 2.0], &[1.0, 2.0]).save(&dir, "range").unwrap_err();
    assert!(err.to_string().contains("invalid x range"), "{err}");
    assert!(LinePlot::new("stem").series("a", &[1.0], &[1.0]).save(&dir, "../x").is_err());
    let s = periodic_pile();
    let err = PackingPicture::new(&s, "t").arrival_times(&[1.0], 1.0, 2.0).save(&dir, "arrival").unwrap_err();
    assert!(err.to_string().contains("3 grains"), "{err}");
    let err = PackingPicture::new(&s, "t").arrival_times(&[1.0; 3], 0.0, 2.0).save(&dir, "arrival").unwrap_err();
    assert!(err.to_string().contains("final time"), "{err}");
    let names: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(names.is_empty(), "nothing written: {names:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
