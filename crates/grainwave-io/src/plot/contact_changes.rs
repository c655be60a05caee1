//! Pictures of a change of a 2D contact network: the contact-force difference between two states
//! of a packing, with opened and created contacts marked and applied forces drawn as arrows.

use super::frame::{data_axes, BOTTOM, BOTTOM_MARGIN, LEFT, LEFT_MARGIN, RIGHT};
use super::geometry::{clip_polygon, clip_segment, Rect};
use super::style::{save, text, tick_label, Figure, PlotFiles, TICK_SIZE, TITLE_SIZE};
use crate::error::{OutputError, Result};
use grainwave_core::dim::{VectorOps, D2};
use grainwave_core::snapshot::Snapshot;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// What happened to a contact between the two states.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactFate {
    /// In contact in both states.
    Kept,
    /// In contact before only.
    Opened,
    /// In contact after only.
    Created,
}

/// One contact of a [`ContactChangePicture`]: a segment (centre to centre, or centre to the
/// contact point on a wall), the magnitude of the force difference |ΔF| and the sign of the
/// change of its normal force.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactChange {
    /// First end (x, y).
    pub from: (f64, f64),
    /// Second end (x, y).
    pub to: (f64, f64),
    /// |ΔF| (sets the line width).
    pub magnitude: f64,
    /// ΔF_n: > 0 the contact is more compressed (red), < 0 less (blue).
    pub normal_change: f64,
    /// Kept, opened or created.
    pub fate: ContactFate,
}

/// A packing (grains of a snapshot, light grey, with its walls) overlaid with the contact-force
/// difference network: line width ∝ |ΔF| (the widest 0.8 mean radii), red where the normal force
/// grew and blue where it dropped; opened contacts are drawn in green and created ones in purple
/// over their difference line, at least 0.15 mean radii wide so that they remain visible. Applied
/// forces appear as black arrows. Saved as PNG + SVG with equal scales on both axes.
///
/// ```
/// use grainwave_core::prelude::*;
/// use grainwave_io::plot::{ContactChange, ContactChangePicture, ContactFate};
/// # use glam::DVec2;
/// # let mut p = ContactParams::preset("hooke_cundall_strack");
/// # p.normal_stiffness = Some(1e4);
/// # let law = p.build(Partner::Grain, "contact").unwrap();
/// let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
/// grains.push(DVec2::new(0.0, 0.0), 0.5, 1.0, DVec2::ZERO);
/// grains.push(DVec2::new(1.0, 0.0), 0.5, 1.0, DVec2::ZERO);
/// let domain = Domain::new(DVec2::splat(-2.0), DVec2::splat(2.0), [false; 3]);
/// let snapshot = SimulationBuilder::new(grains, domain, law).build().unwrap().snapshot();
/// let change = ContactChange { from: (0.0, 0.0), to: (1.0, 0.0), magnitude: 1.0, normal_change: -1.0, fate: ContactFate::Opened };
/// let dir = std::env::temp_dir().join(format!("grainwave-change-doc-{}", std::process::id()));
/// ContactChangePicture::new(&snapshot, "opened").changes(&[change]).force((0.0, 0.5), (0.0, -1.0)).save(&dir, "opened").unwrap();
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Clone, Debug)]
pub struct ContactChangePicture<'a> {
    snapshot: &'a Snapshot<D2>,
    title: String,
    x_label: String,
    y_label: String,
    changes: Vec<ContactChange>,
    forces: Vec<((f64, f64), (f64, f64))>,
    width: Option<u32>,
}

const GRAIN_FILL: RGBColor = RGBColor(240, 240, 240);
const GRAIN_EDGE: RGBColor = RGBColor(170, 170, 170);
const MORE: RGBColor = RGBColor(200, 30, 40);
const LESS: RGBColor = RGBColor(30, 90, 190);
const OPENED: RGBColor = RGBColor(0, 160, 80);
const CREATED: RGBColor = RGBColor(150, 60, 170);
const WALL: RGBColor = RGBColor(60, 60, 60);
const TOP: u32 = 82;

impl<'a> ContactChangePicture<'a> {
    /// A picture of the grains of `snapshot` with this title.
    pub fn new(snapshot: &'a Snapshot<D2>, title: &str) -> Self {
        ContactChangePicture {
            snapshot,
            title: title.to_string(),
            x_label: "x".into(),
            y_label: "y".into(),
            changes: Vec::new(),
            forces: Vec::new(),
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

    /// The contact changes to draw.
    pub fn changes(mut self, changes: &[ContactChange]) -> Self {
        self.changes = changes.to_vec();
        self
    }

    /// An applied force at `point` along `direction` (drawn as an arrow of 3 mean radii ending at
    /// the point).
    pub fn force(mut self, point: (f64, f64), direction: (f64, f64)) -> Self {
        self.forces.push((point, direction));
        self
    }

    /// Width of the plotting area in pixels (default: about 24 pixels per mean diameter, between
    /// 640 and 2000).
    pub fn width(mut self, pixels: u32) -> Self {
        self.width = Some(pixels);
        self
    }

    /// Draws the picture and writes `<dir>/<stem>.png` and `<dir>/<stem>.svg`, each atomically.
    pub fn save(&self, dir: &Path, stem: &str) -> Result<PlotFiles> {
        let s = self.snapshot;
        let fail = |reason: String| OutputError::Plot { stem: stem.to_string(), reason };
        if s.is_empty() {
            return Err(fail("the snapshot has no grains".into()));
        }
        let mean_radius = s.radius.iter().sum::<f64>() / s.len() as f64;
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (p, r) in s.pos.iter().zip(&s.radius) {
            for k in 0..2 {
                lo[k] = lo[k].min(p.get(k) - r);
                hi[k] = hi[k].max(p.get(k) + r);
            }
        }
        for wall in &s.domain.walls {
            for k in 0..2 {
                if wall.normal.get(k).abs() > 1.0 - 1e-9 {
                    lo[k] = lo[k].min(wall.position.get(k));
                    hi[k] = hi[k].max(wall.position.get(k));
                }
            }
        }
        for (p, _) in &self.forces {
            hi[1] = hi[1].max(p.1 + 3.0 * mean_radius);
        }
        if !(lo.iter().chain(&hi).all(|v| v.is_finite()) && mean_radius > 0.0) {
            return Err(fail("grain positions or radii are not finite".into()));
        }
        let margin = 0.02 * (hi[0] - lo[0]).max(hi[1] - lo[1]) + 0.25 * mean_radius;
        let view = Rect { x0: lo[0] - margin, x1: hi[0] + margin, y0: lo[1] - margin, y1: hi[1] + margin };
        let (w, h) = (view.x1 - view.x0, view.y1 - view.y0);
        let plot_w = self.width.unwrap_or_else(|| (w / (2.0 * mean_radius) * 24.0).clamp(640.0, 2000.0) as u32) as f64;
        let plot_h = (plot_w * h / w).clamp(50.0, 3000.0);
        save(&Drawn { picture: self, view, plot: (plot_w.round() as u32, plot_h.round() as u32), mean_radius }, dir, stem)
    }
}

struct Drawn<'p, 'a> {
    picture: &'p ContactChangePicture<'a>,
    view: Rect,
    plot: (u32, u32),
    mean_radius: f64,
}

fn thick_segment(a: (f64, f64), b: (f64, f64), width: f64) -> Vec<(f64, f64)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = (dx * dx + dy * dy).sqrt().max(f64::MIN_POSITIVE);
    let (nx, ny) = (-dy / len * 0.5 * width, dx / len * 0.5 * width);
    vec![(a.0 + nx, a.1 + ny), (b.0 + nx, b.1 + ny), (b.0 - nx, b.1 - ny), (a.0 - nx, a.1 - ny)]
}

impl Figure for Drawn<'_, '_> {
    fn size(&self) -> (u32, u32) {
        (self.plot.0 + LEFT_MARGIN + LEFT + RIGHT, self.plot.1 + BOTTOM + BOTTOM_MARGIN + TOP)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let p = self.picture;
        let s = p.snapshot;
        let view = self.view;
        let r_mean = self.mean_radius;
        let px = self.plot.0 as f64 / (view.x1 - view.x0);
        let mut chart = data_axes(root, TOP, RIGHT, view.x0..view.x1, view.y0..view.y1, &p.x_label, &p.y_label)?;
        // grains
        let mut polys: Vec<(Vec<(f64, f64)>, ShapeStyle)> = Vec::new();
        let mut paths: Vec<(Vec<(f64, f64)>, ShapeStyle)> = Vec::new();
        for k in 0..s.len() {
            let c = (s.pos[k].get(0), s.pos[k].get(1));
            let r = s.radius[k];
            let n = ((std::f64::consts::TAU * r * px / 4.0).round() as usize).clamp(12, 72);
            let circle: Vec<(f64, f64)> = (0..n)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / n as f64;
                    (c.0 + r * a.cos(), c.1 + r * a.sin())
                })
                .collect();
            let visible = clip_polygon(&circle, &view);
            if visible.len() >= 3 {
                let mut closed = visible.clone();
                closed.push(visible[0]);
                paths.push((closed, GRAIN_EDGE.stroke_width(1)));
                polys.push((visible, GRAIN_FILL.filled()));
            }
        }
        chart.draw_series(polys.drain(..).map(|(q, st)| Polygon::new(q, st))).map_err(e)?;
        chart.draw_series(paths.drain(..).map(|(q, st)| PathElement::new(q, st))).map_err(e)?;
        // difference network, weakest first
        let max = p.changes.iter().map(|c| c.magnitude).filter(|v| v.is_finite()).fold(0.0f64, f64::max);
        let widest = 0.8 * r_mean;
        let mut order: Vec<usize> = (0..p.changes.len()).collect();
        order.sort_by(|&a, &b| p.changes[a].magnitude.total_cmp(&p.changes[b].magnitude));
        let mut counts = (0, 0);
        let mut marks: Vec<(Vec<(f64, f64)>, ShapeStyle)> = Vec::new();
        for k in order {
            let c = &p.changes[k];
            let Some((a, b)) = clip_segment(c.from, c.to, &view) else { continue };
            if max > 0.0 && c.magnitude.is_finite() && c.magnitude > 0.0 {
                let colour = if c.normal_change >= 0.0 { MORE } else { LESS };
                let width = widest * c.magnitude / max;
                if width * px >= 1.0 {
                    let q = clip_polygon(&thick_segment(a, b, width), &view);
                    if q.len() >= 3 {
                        polys.push((q, colour.filled()));
                    }
                } else {
                    paths.push((vec![a, b], colour.stroke_width(1)));
                }
            }
            let mark = match c.fate {
                ContactFate::Kept => None,
                ContactFate::Opened => {
                    counts.0 += 1;
                    Some(OPENED)
                }
                ContactFate::Created => {
                    counts.1 += 1;
                    Some(CREATED)
                }
            };
            if let Some(colour) = mark {
                let width = (0.15 * r_mean).max(2.0 / px);
                let q = clip_polygon(&thick_segment(a, b, width), &view);
                if q.len() >= 3 {
                    marks.push((q, colour.filled()));
                }
            }
        }
        chart.draw_series(paths.drain(..).map(|(q, st)| PathElement::new(q, st))).map_err(e)?;
        chart.draw_series(polys.drain(..).map(|(q, st)| Polygon::new(q, st))).map_err(e)?;
        chart.draw_series(marks.drain(..).map(|(q, st)| Polygon::new(q, st))).map_err(e)?;
        // walls
        for wall in &s.domain.walls {
            let (nx, ny) = (wall.normal.get(0), wall.normal.get(1));
            let (wx, wy) = (wall.position.get(0), wall.position.get(1));
            let reach = 2.0 * ((view.x1 - view.x0) + (view.y1 - view.y0));
            if let Some((a, b)) = clip_segment((wx - ny * reach, wy + nx * reach), (wx + ny * reach, wy - nx * reach), &view) {
                chart.draw_series(std::iter::once(PathElement::new(vec![a, b], WALL.stroke_width(3)))).map_err(e)?;
            }
        }
        // applied forces
        for &(point, dir) in &p.forces {
            let len = (dir.0 * dir.0 + dir.1 * dir.1).sqrt();
            if !(len > 0.0) {
                continue;
            }
            let (ux, uy) = (dir.0 / len, dir.1 / len);
            let total = 3.0 * r_mean;
            let head = 0.8 * r_mean;
            let start = (point.0 - ux * total, point.1 - uy * total);
            let shaft_end = (point.0 - ux * head, point.1 - uy * head);
            chart.draw_series(std::iter::once(PathElement::new(vec![start, shaft_end], BLACK.stroke_width(3)))).map_err(e)?;
            let half = 0.4 * r_mean;
            let tri = vec![point, (shaft_end.0 - uy * half, shaft_end.1 + ux * half), (shaft_end.0 + uy * half, shaft_end.1 - ux * half)];
            chart.draw_series(std::iter::once(Polygon::new(tri, BLACK.filled()))).map_err(e)?;
        }
        if !p.title.is_empty() {
            root.draw(&Text::new(p.title.as_str(), ((LEFT_MARGIN + LEFT) as i32, 10), text(TITLE_SIZE))).map_err(e)?;
        }
        let style = text(TICK_SIZE - 1.0).color(&RGBColor(70, 70, 70));
        let first = format!("line width ∝ |ΔF|, widest |ΔF| = {}; red: F_n grew, blue: F_n dropped", tick_label(max));
        let second = format!("{} opened contacts (green), {} created (purple)", counts.0, counts.1);
        root.draw(&Text::new(first, ((LEFT_MARGIN + LEFT) as i32, 38), style.clone())).map_err(e)?;
        root.draw(&Text::new(second, ((LEFT_MARGIN + LEFT) as i32, 56), style)).map_err(e)?;
        Ok(())
    }
}
