//! Pictures of 2D packings: grains, force and stiffness networks, arrows, arrival-time maps.

use super::frame::{data_axes, BOTTOM, BOTTOM_MARGIN, LEFT, LEFT_MARGIN, RIGHT};
use super::geometry::{clip_polygon, clip_segment, Rect};
use super::style::{save, text, tick_label, Figure, PlotFiles, TICK_SIZE, TITLE_SIZE};
use crate::error::Result;
use grainwave_core::dim::{Dim, VectorOps, D2};
use grainwave_core::snapshot::{Counterpart, Snapshot};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Which contact quantity sets the line widths of a network picture.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Network {
    /// Line width ∝ normal force F_n (the force network); sliding contacts in orange.
    Force,
    /// Line width ∝ normal stiffness k_n (the stiffness network).
    Stiffness,
}

/// A picture of a 2D packing, saved as PNG + SVG with equal scales on both axes.
///
/// Layers, bottom to top: the periodic cell edges (dashed, along periodic axes), the grains
/// (disks of their radius), a contact network, the walls (thick lines), arrows. Along a periodic
/// axis the picture shows exactly one cell: grains crossing its edge appear on both sides, and a
/// contact through the edge is drawn as two half-lines, each inside the cell. The scale of each
/// layer is written under the title.
///
/// * [`network`](Self::network): one line per contact from the centre of grain i to the centre
///   of j (or to the contact point on a wall), of width proportional to F_n or k_n — the widest
///   line is 0.7 (force) or 0.4 (stiffness) mean radii wide; lines thinner than a pixel are
///   drawn one pixel wide.
/// * [`arrows`](Self::arrows): a per-grain vector field (displacement, velocity, …) drawn from
///   each centre; by default the longest arrow is 0.9 mean diameters long.
/// * [`arrival_times`](Self::arrival_times): each grain filled with the grey level
///   frac(J t_i / t_f) (0 black, 1 white), so that J bands of equal arrival time appear;
///   grains with a non-finite time (never reached) are pink.
///
/// ```
/// use grainwave_core::prelude::*;
/// use grainwave_io::plot::{Network, PackingPicture};
/// # use glam::DVec2;
/// # let mut p = ContactParams::preset("hooke_cundall_strack");
/// # p.normal_stiffness = Some(1e4);
/// # p.restitution = Some(0.5);
/// # let law = p.build(Partner::Grain, "contact").unwrap();
/// let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
/// grains.push(DVec2::new(0.0, 0.0), 0.5, 1.0, DVec2::ZERO);
/// grains.push(DVec2::new(0.995, 0.0), 0.5, 1.0, DVec2::ZERO);
/// let domain = Domain::new(DVec2::splat(-2.0), DVec2::splat(2.0), [false; 3]);
/// let snapshot = SimulationBuilder::new(grains, domain, law).build().unwrap().snapshot();
/// let dir = std::env::temp_dir().join(format!("grainwave-packing-doc-{}", std::process::id()));
/// PackingPicture::new(&snapshot, "Two disks").network(Network::Force).save(&dir, "pair").unwrap();
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
#[derive(Clone, Debug)]
pub struct PackingPicture<'a> {
    snapshot: &'a Snapshot<D2>,
    title: String,
    x_label: String,
    y_label: String,
    network: Option<Network>,
    arrows: Option<ArrowField>,
    arrival: Option<(Vec<f64>, f64, f64)>,
    width: Option<u32>,
}

/// Per-grain vectors (x, y) and the optional arrow length per unit of the field.
type ArrowField = (Vec<(f64, f64)>, Option<f64>);

const GRAIN_FILL: RGBColor = RGBColor(226, 226, 226);
const GRAIN_FILL_UNDER_NETWORK: RGBColor = RGBColor(242, 242, 242);
const GRAIN_EDGE: RGBColor = RGBColor(140, 140, 140);
const NEVER_ARRIVED: RGBColor = RGBColor(250, 196, 205);
const FORCE_LINE: RGBColor = RGBColor(20, 20, 20);
const SLIDING_LINE: RGBColor = RGBColor(230, 120, 0);
const STIFFNESS_LINE: RGBColor = RGBColor(0, 100, 170);
const ARROW: RGBColor = RGBColor(200, 30, 30);
const WALL: RGBColor = RGBColor(60, 60, 60);
const CELL_EDGE: RGBColor = RGBColor(150, 150, 150);

/// Width of the widest force line, in mean radii.
const FORCE_WIDEST: f64 = 0.7;
/// Width of the widest stiffness line, in mean radii (stiffness varies less than force:
/// k_n ∝ F_n^⅓ for Hertz contacts, constant for Hooke contacts).
const STIFFNESS_WIDEST: f64 = 0.4;

/// Pixels reserved around the plotting area.
const TOP_TITLE: u32 = 46;
const TOP_NOTE: u32 = 26;

impl<'a> PackingPicture<'a> {
    /// A picture of `snapshot` with this title (empty: none), showing the grains only.
    pub fn new(snapshot: &'a Snapshot<D2>, title: &str) -> Self {
        PackingPicture {
            snapshot,
            title: title.to_string(),
            x_label: "x".into(),
            y_label: "y".into(),
            network: None,
            arrows: None,
            arrival: None,
            width: None,
        }
    }

    /// Label of the x axis, with units (default `x`).
    pub fn x_label(mut self, label: &str) -> Self {
        self.x_label = label.to_string();
        self
    }

    /// Label of the y axis, with units (default `y`).
    pub fn y_label(mut self, label: &str) -> Self {
        self.y_label = label.to_string();
        self
    }

    /// Draws the force or stiffness network.
    pub fn network(mut self, network: Network) -> Self {
        self.network = Some(network);
        self
    }

    /// Draws one arrow per grain (in storage order) from its centre along `field` (e.g.
    /// displacements or velocities). With `scale` = `Some(s)` an arrow is s × the vector long
    /// (in length units); with `None` the longest arrow is 0.9 mean diameters long.
    pub fn arrows(mut self, field: &[<D2 as Dim>::Vector], scale: Option<f64>) -> Self {
        self.arrows = Some((field.iter().map(|v| (v.get(0), v.get(1))).collect(), scale));
        self
    }

    /// Fills every grain (in storage order) with the grey level frac(`bands` × t_i / `final_time`)
    /// given its arrival time t_i (non-finite: never arrived, drawn pink).
    pub fn arrival_times(mut self, times: &[f64], final_time: f64, bands: f64) -> Self {
        self.arrival = Some((times.to_vec(), final_time, bands));
        self
    }

    /// Width of the plotting area in pixels (default: about 28 pixels per mean diameter, between
    /// 640 and 2000); the height follows from the packing's aspect ratio.
    pub fn width(mut self, pixels: u32) -> Self {
        self.width = Some(pixels);
        self
    }

    /// Draws the picture and writes `<dir>/<stem>.png` and `<dir>/<stem>.svg`, each atomically.
    /// Fails (writing nothing) if the snapshot has no grains, a per-grain field has the wrong
    /// length, or an arrival-time map has a final time or band count that is not positive.
    pub fn save(&self, dir: &Path, stem: &str) -> Result<PlotFiles> {
        let layout = self.layout().map_err(|reason| crate::error::OutputError::Plot { stem: stem.to_string(), reason })?;
        save(&Drawn { picture: self, layout }, dir, stem)
    }

    fn layout(&self) -> Result<Layout, String> {
        let s = self.snapshot;
        let n = s.len();
        if n == 0 {
            return Err("the snapshot has no grains".into());
        }
        if s.pos.len() != n || s.radius.len() != n {
            return Err(format!("the snapshot has {n} ids but {} positions and {} radii", s.pos.len(), s.radius.len()));
        }
        if let Some((field, scale)) = &self.arrows {
            if field.len() != n {
                return Err(format!("the arrow field has {} vectors for {n} grains", field.len()));
            }
            if scale.is_some_and(|s| !(s.is_finite() && s > 0.0)) {
                return Err(format!("arrow scale {scale:?} is not a positive number"));
            }
        }
        if let Some((times, final_time, bands)) = &self.arrival {
            if times.len() != n {
                return Err(format!("the arrival-time map has {} times for {n} grains", times.len()));
            }
            if !(final_time.is_finite() && *final_time > 0.0 && bands.is_finite() && *bands > 0.0) {
                return Err(format!("arrival-time map needs a final time > 0 and a band count > 0, got {final_time} and {bands}"));
            }
        }
        let mean_radius = s.radius.iter().sum::<f64>() / n as f64;
        // View: the grains, the periodic cell, and the axis-aligned walls.
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for (p, r) in s.pos.iter().zip(&s.radius) {
            for k in 0..2 {
                lo[k] = lo[k].min(p.get(k) - r);
                hi[k] = hi[k].max(p.get(k) + r);
            }
        }
        let domain = &s.domain;
        for k in 0..2 {
            if domain.is_periodic(k) {
                lo[k] = domain.lo.get(k);
                hi[k] = domain.hi.get(k);
            }
        }
        for wall in &domain.walls {
            for k in 0..2 {
                if wall.normal.get(k).abs() > 1.0 - 1e-9 && !domain.is_periodic(k) {
                    lo[k] = lo[k].min(wall.position.get(k));
                    hi[k] = hi[k].max(wall.position.get(k));
                }
            }
        }
        if !(lo.iter().chain(&hi).all(|v| v.is_finite()) && mean_radius.is_finite() && mean_radius > 0.0) {
            return Err("grain positions or radii are not finite".into());
        }
        let margin = 0.03 * (hi[0] - lo[0]).max(hi[1] - lo[1]) + 0.25 * mean_radius;
        let mut view = Rect { x0: lo[0], x1: hi[0], y0: lo[1], y1: hi[1] };
        let mut clip = view;
        if !domain.is_periodic(0) {
            view.x0 -= margin;
            view.x1 += margin;
            clip.x0 = view.x0;
            clip.x1 = view.x1;
        } else {
            view.x0 -= 0.5 * margin;
            view.x1 += 0.5 * margin;
        }
        if !domain.is_periodic(1) {
            view.y0 -= margin;
            view.y1 += margin;
            clip.y0 = view.y0;
            clip.y1 = view.y1;
        } else {
            view.y0 -= 0.5 * margin;
            view.y1 += 0.5 * margin;
        }
        let (w, h) = (view.x1 - view.x0, view.y1 - view.y0);
        let mut plot_w = self.width.unwrap_or_else(|| ((w / (2.0 * mean_radius)) * 28.0).clamp(640.0, 2000.0) as u32) as f64;
        let mut plot_h = plot_w * h / w;
        if plot_h > 2000.0 && self.width.is_none() {
            plot_w *= 2000.0 / plot_h;
            plot_h = 2000.0;
        }
        let (plot_w, plot_h) = (plot_w.round().max(50.0) as u32, plot_h.round().max(50.0) as u32);
        Ok(Layout { view, clip, plot: (plot_w, plot_h), mean_radius })
    }
}

struct Layout {
    /// Data range of the axes.
    view: Rect,
    /// Everything is clipped to this rectangle (the periodic cell along periodic axes).
    clip: Rect,
    /// Plotting area in pixels.
    plot: (u32, u32),
    mean_radius: f64,
}

struct Drawn<'p, 'a> {
    picture: &'p PackingPicture<'a>,
    layout: Layout,
}

/// Periodic translates to try: 0 and ±L along periodic axes.
fn shifts(s: &Snapshot<D2>) -> Vec<(f64, f64)> {
    let options = |k: usize| {
        if s.domain.is_periodic(k) {
            let l = s.domain.length(k);
            vec![0.0, -l, l]
        } else {
            vec![0.0]
        }
    };
    let (ox, oy) = (options(0), options(1));
    ox.iter().flat_map(|&a| oy.iter().map(move |&b| (a, b))).collect()
}

/// A rectangle of width `width` around segment a–b, as a polygon.
fn thick_segment(a: (f64, f64), b: (f64, f64), width: f64) -> Vec<(f64, f64)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = (dx * dx + dy * dy).sqrt().max(f64::MIN_POSITIVE);
    let (nx, ny) = (-dy / len * 0.5 * width, dx / len * 0.5 * width);
    vec![(a.0 + nx, a.1 + ny), (b.0 + nx, b.1 + ny), (b.0 - nx, b.1 - ny), (a.0 - nx, a.1 - ny)]
}

fn circle(c: (f64, f64), r: f64, vertices: usize) -> Vec<(f64, f64)> {
    (0..vertices)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / vertices as f64;
            (c.0 + r * a.cos(), c.1 + r * a.sin())
        })
        .collect()
}

fn grey(level: f64) -> RGBColor {
    let g = (level.clamp(0.0, 1.0) * 255.0).round() as u8;
    RGBColor(g, g, g)
}

impl Drawn<'_, '_> {
    fn note(&self, network_max: Option<f64>, sliding: usize, arrow_max: Option<f64>, arrow_scale: f64) -> String {
        let p = self.picture;
        let mut parts = Vec::new();
        match (p.network, network_max) {
            (Some(Network::Force), Some(m)) if m > 0.0 => {
                parts.push(format!("line width ∝ F_n, widest F_n = {}", tick_label(m)));
                if sliding > 0 {
                    parts.push(format!("{sliding} sliding contacts in orange"));
                }
            }
            (Some(Network::Stiffness), Some(m)) if m > 0.0 => parts.push(format!("line width ∝ k_n, widest k_n = {}", tick_label(m))),
            (Some(_), _) => parts.push("no contact with a positive value".into()),
            (None, _) => {}
        }
        if let Some(m) = arrow_max {
            parts.push(format!("longest arrow |v| = {} (length {} × |v|)", tick_label(m), tick_label(arrow_scale)));
        }
        if let Some((_, t_f, bands)) = &p.arrival {
            parts.push(format!("grey = frac({} t/t_f), t_f = {}; pink: not reached", tick_label(*bands), tick_label(*t_f)));
        }
        parts.join("  ·  ")
    }
}

impl Figure for Drawn<'_, '_> {
    fn size(&self) -> (u32, u32) {
        let (w, h) = self.layout.plot;
        (w + LEFT_MARGIN + LEFT + RIGHT, h + BOTTOM + BOTTOM_MARGIN + TOP_TITLE + TOP_NOTE)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
        let p = self.picture;
        let s = p.snapshot;
        let Layout { view, clip, plot, mean_radius } = self.layout;
        let px_per_unit = plot.0 as f64 / (view.x1 - view.x0);
        let shifts = shifts(s);

        let mut chart = data_axes(root, TOP_TITLE + TOP_NOTE, RIGHT, view.x0..view.x1, view.y0..view.y1, &p.x_label, &p.y_label)?;

        // Polygon and segment drawing with periodic translates, clipped to the cell.
        let mut polygons: Vec<(Vec<(f64, f64)>, ShapeStyle)> = Vec::new();
        let mut paths: Vec<(Vec<(f64, f64)>, ShapeStyle)> = Vec::new();
        let push_polygon = |poly: &[(f64, f64)], fill: Option<ShapeStyle>, edge: Option<ShapeStyle>, polygons: &mut Vec<_>, paths: &mut Vec<_>| {
            for &(dx, dy) in &shifts {
                let moved: Vec<(f64, f64)> = poly.iter().map(|&(x, y)| (x + dx, y + dy)).collect();
                let visible = clip_polygon(&moved, &clip);
                if visible.len() < 3 {
                    continue;
                }
                if let Some(edge) = edge {
                    let mut closed = visible.clone();
                    closed.push(visible[0]);
                    paths.push((closed, edge));
                }
                if let Some(fill) = fill {
                    polygons.push((visible, fill));
                }
            }
        };
        let segment_pieces = |a: (f64, f64), b: (f64, f64)| -> Vec<((f64, f64), (f64, f64))> {
            shifts.iter().filter_map(|&(dx, dy)| clip_segment((a.0 + dx, a.1 + dy), (b.0 + dx, b.1 + dy), &clip)).collect()
        };

        // Periodic cell edges.
        let dashed = CELL_EDGE.stroke_width(1);
        for k in 0..2 {
            if s.domain.is_periodic(k) {
                for edge in [s.domain.lo.get(k), s.domain.hi.get(k)] {
                    let (a, b) = if k == 0 { ((edge, view.y0), (edge, view.y1)) } else { ((view.x0, edge), (view.x1, edge)) };
                    chart.draw_series(DashedLineSeries::new(vec![a, b], 6, 5, dashed)).map_err(e)?;
                }
            }
        }

        // Grains.
        let under_network = p.network.is_some() || p.arrows.is_some();
        for k in 0..s.len() {
            let c = (s.pos[k].get(0), s.pos[k].get(1));
            let r = s.radius[k];
            let vertices = ((std::f64::consts::TAU * r * px_per_unit / 4.0).round() as usize).clamp(12, 90);
            let fill = match &p.arrival {
                Some((times, t_f, bands)) if times[k].is_finite() => grey((bands * times[k] / t_f).rem_euclid(1.0)),
                Some(_) => NEVER_ARRIVED,
                None if under_network => GRAIN_FILL_UNDER_NETWORK,
                None => GRAIN_FILL,
            };
            let edge = if p.arrival.is_some() { RGBColor(90, 90, 90) } else { GRAIN_EDGE };
            push_polygon(&circle(c, r, vertices), Some(fill.filled()), Some(edge.stroke_width(1)), &mut polygons, &mut paths);
        }
        chart.draw_series(polygons.drain(..).map(|(poly, style)| Polygon::new(poly, style))).map_err(e)?;
        chart.draw_series(paths.drain(..).map(|(path, style)| PathElement::new(path, style))).map_err(e)?;

        // Contact network.
        let index: std::collections::HashMap<u32, usize> = s.id.iter().enumerate().map(|(k, &id)| (id, k)).collect();
        let mut network_max = None;
        let mut sliding = 0;
        if let Some(network) = p.network {
            let value = |c: &grainwave_core::snapshot::ContactRecord<D2>| match network {
                Network::Force => c.normal_force,
                Network::Stiffness => c.normal_stiffness,
            };
            let max = s.contacts.iter().map(value).filter(|v| v.is_finite()).fold(0.0f64, f64::max);
            network_max = Some(max);
            let widest = match network {
                Network::Force => FORCE_WIDEST,
                Network::Stiffness => STIFFNESS_WIDEST,
            } * mean_radius;
            // Thin lines first, so that strong chains are drawn on top.
            let mut order: Vec<usize> = (0..s.contacts.len()).collect();
            order.sort_by(|&a, &b| value(&s.contacts[a]).total_cmp(&value(&s.contacts[b])));
            for k in order {
                let c = &s.contacts[k];
                let v = value(c);
                let Some(&i) = index.get(&c.i) else { return Err(format!("a contact refers to grain id {}, which is not in the snapshot", c.i)) };
                if !(v.is_finite() && v > 0.0 && max > 0.0) {
                    continue;
                }
                let colour = match network {
                    Network::Force if c.sliding => SLIDING_LINE,
                    Network::Force => FORCE_LINE,
                    Network::Stiffness => STIFFNESS_LINE,
                };
                if c.sliding && network == Network::Force {
                    sliding += 1;
                }
                let a = (s.pos[i].get(0), s.pos[i].get(1));
                let b = (a.0 + c.branch.get(0), a.1 + c.branch.get(1));
                let width = widest * v / max;
                // A contact through a periodic edge: draw i → i + branch and j → j − branch.
                let mut segments = vec![(a, b)];
                if let Counterpart::Grain(j) = c.j {
                    let j = *index.get(&j).ok_or_else(|| format!("a contact refers to grain id {j}, which is not in the snapshot"))?;
                    let pj = (s.pos[j].get(0), s.pos[j].get(1));
                    if ((pj.0 - b.0).powi(2) + (pj.1 - b.1).powi(2)).sqrt() > 1e-9 * mean_radius {
                        segments.push((pj, (pj.0 - c.branch.get(0), pj.1 - c.branch.get(1))));
                    }
                }
                for (a, b) in segments {
                    for (a, b) in segment_pieces(a, b) {
                        if width * px_per_unit >= 1.0 {
                            let visible = clip_polygon(&thick_segment(a, b, width), &clip);
                            if visible.len() >= 3 {
                                polygons.push((visible, colour.filled()));
                            }
                        } else {
                            paths.push((vec![a, b], colour.stroke_width(1)));
                        }
                    }
                }
            }
            chart.draw_series(paths.drain(..).map(|(path, style)| PathElement::new(path, style))).map_err(e)?;
            chart.draw_series(polygons.drain(..).map(|(poly, style)| Polygon::new(poly, style))).map_err(e)?;
        }

        // Walls: the line of each wall across the view.
        for wall in &s.domain.walls {
            let (nx, ny) = (wall.normal.get(0), wall.normal.get(1));
            let (px, py) = (wall.position.get(0), wall.position.get(1));
            let reach = 2.0 * ((view.x1 - view.x0) + (view.y1 - view.y0));
            if let Some((a, b)) = clip_segment((px - ny * reach, py + nx * reach), (px + ny * reach, py - nx * reach), &view) {
                chart.draw_series(std::iter::once(PathElement::new(vec![a, b], WALL.stroke_width(3)))).map_err(e)?;
            }
        }

        // Arrows.
        let mut arrow_max = None;
        let mut arrow_scale = 0.0;
        if let Some((field, scale)) = &p.arrows {
            let max = field.iter().map(|&(x, y)| (x * x + y * y).sqrt()).filter(|v| v.is_finite()).fold(0.0f64, f64::max);
            arrow_max = Some(max);
            arrow_scale = scale.unwrap_or(if max > 0.0 { 1.8 * mean_radius / max } else { 0.0 });
            for (k, &(vx, vy)) in field.iter().enumerate() {
                let len = (vx * vx + vy * vy).sqrt() * arrow_scale;
                if !len.is_finite() || len * px_per_unit < 1.0 {
                    continue;
                }
                let a = (s.pos[k].get(0), s.pos[k].get(1));
                let (ux, uy) = (vx * arrow_scale / len, vy * arrow_scale / len);
                let head = (0.35 * len).min(0.45 * mean_radius);
                let shaft_end = (a.0 + ux * (len - head), a.1 + uy * (len - head));
                let tip = (a.0 + ux * len, a.1 + uy * len);
                let half = 0.5 * head;
                let head_poly = [tip, (shaft_end.0 - uy * half, shaft_end.1 + ux * half), (shaft_end.0 + uy * half, shaft_end.1 - ux * half)];
                for (sa, sb) in segment_pieces(a, shaft_end) {
                    paths.push((vec![sa, sb], ARROW.stroke_width(2)));
                }
                push_polygon(&head_poly, Some(ARROW.filled()), None, &mut polygons, &mut paths);
            }
            chart.draw_series(paths.drain(..).map(|(path, style)| PathElement::new(path, style))).map_err(e)?;
            chart.draw_series(polygons.drain(..).map(|(poly, style)| Polygon::new(poly, style))).map_err(e)?;
        }

        // Title and the scale note.
        if !p.title.is_empty() {
            root.draw(&Text::new(p.title.as_str(), ((LEFT_MARGIN + LEFT) as i32, 12), text(TITLE_SIZE))).map_err(e)?;
        }
        let note = self.note(network_max, sliding, arrow_max, arrow_scale);
        if !note.is_empty() {
            let style = text(TICK_SIZE - 1.0).color(&RGBColor(70, 70, 70));
            root.draw(&Text::new(note, ((LEFT_MARGIN + LEFT) as i32, (TOP_TITLE + 4) as i32), style)).map_err(e)?;
        }
        Ok(())
    }
}
