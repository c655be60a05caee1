//! Outputs of the `e3` protocol: per-run files, ensemble aggregates, tables, plots and the summary.

use super::config::{E3Config, Mode};
use super::measure::{self, FieldData, FloorContact, ModuliReport, RawVerdict, RunResult, Symmetry};
use super::plan::{Group, Plan, RunSpec, Variant};
use super::slab::{self, Material, Shape, Sites};
use super::work::{self, ReferenceResult, StoredRun};
use grainwave_study::Result;
use grainwave_analysis::network::{ContactKey, NetworkChanges};
use grainwave_analysis::peaks::{classify_profile, PeakClassification, PeakOptions, PeakShape};
use grainwave_core::prelude::*;
use grainwave_io::plot::{ContactChange, ContactChangePicture, ContactFate, FieldMap, LegendPosition, LinePlot, Network, PackingPicture};
use grainwave_io::vtk::{write_grains_vtp, VtkCells, VtkDataSet, VtkFormat, VtkValues};
use grainwave_analysis::ensemble::{mean_std, MeanStd};
use grainwave_io::{write_csv_atomic, write_json_atomic, CsvTable, Npz, NpzCompression, Series};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// Directory of a run's own files, relative to the output directory.
pub fn run_dir(plan: &Plan, run: &RunSpec) -> String {
    format!("runs/{}/{}", plan.cases[run.case].label, run.label)
}

/// Whether per-run directories are written.
pub fn runs_enabled(cfg: &E3Config) -> bool {
    cfg.output.runs.unwrap_or(cfg.mode != Mode::Sweep)
}

fn plot_err(e: grainwave_io::OutputError) -> grainwave_study::ExperimentError {
    e.into()
}

/// The contact-force difference network as VTK PolyData: one line per contact present before or
/// after, from the centre of the key's first grain along its branch vector (reference state;
/// final state for created contacts), with cell data `force_difference` (3 components),
/// `magnitude`, `normal_force_before`, `normal_force_after`, `normal_change`, `opened`,
/// `created`, `sliding`, `wall` (index, −1 for grain pairs), `i`, `j` (−1 for walls).
pub fn difference_dataset(changes: &NetworkChanges<D2>, reference: &Snapshot<D2>) -> Result<VtkDataSet> {
    let index = reference.index_by_id();
    let mut points = Vec::new();
    let mut lines = Vec::new();
    let (mut df, mut mag, mut fb, mut fa, mut dn, mut opened, mut created, mut sliding, mut wall, mut gi, mut gj) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for c in &changes.contacts {
        let first = c.key.first();
        let a = reference.pos[index[first as usize]];
        let b = a + c.branch();
        points.push([a.x, a.y, 0.0]);
        points.push([b.x, b.y, 0.0]);
        lines.push([(points.len() - 2) as u64, (points.len() - 1) as u64]);
        let d = c.force_difference();
        df.extend([d.x, d.y, 0.0]);
        mag.push(d.length());
        let nb = c.before.map_or(0.0, |s| s.normal_force);
        let na = c.after.map_or(0.0, |s| s.normal_force);
        fb.push(nb);
        fa.push(na);
        dn.push(na - nb);
        opened.push(c.opened() as u8);
        created.push(c.created() as u8);
        sliding.push(c.sliding_after() as u8);
        match c.key {
            ContactKey::Pair(i, j) => {
                wall.push(-1);
                gi.push(i as i64);
                gj.push(j as i64);
            }
            ContactKey::Wall(i, w) => {
                wall.push(w as i32);
                gi.push(i as i64);
                gj.push(-1);
            }
        }
    }
    let mut d = VtkDataSet::new(points, VtkCells::Lines(lines))?;
    d.push_cell_data("force_difference", 3, VtkValues::Float64(df))?;
    d.push_cell_data("magnitude", 1, VtkValues::Float64(mag))?;
    d.push_cell_data("normal_force_before", 1, VtkValues::Float64(fb))?;
    d.push_cell_data("normal_force_after", 1, VtkValues::Float64(fa))?;
    d.push_cell_data("normal_change", 1, VtkValues::Float64(dn))?;
    d.push_cell_data("opened", 1, VtkValues::UInt8(opened))?;
    d.push_cell_data("created", 1, VtkValues::UInt8(created))?;
    d.push_cell_data("sliding", 1, VtkValues::UInt8(sliding))?;
    d.push_cell_data("wall", 1, VtkValues::Int32(wall))?;
    d.push_cell_data("i", 1, VtkValues::Int64(gi))?;
    d.push_cell_data("j", 1, VtkValues::Int64(gj))?;
    Ok(d)
}

/// Segments of a [`ContactChangePicture`].
fn change_segments(changes: &NetworkChanges<D2>, reference: &Snapshot<D2>) -> Vec<ContactChange> {
    let index = reference.index_by_id();
    changes
        .contacts
        .iter()
        .map(|c| {
            let a = reference.pos[index[c.key.first() as usize]];
            let b = a + c.branch();
            let nb = c.before.map_or(0.0, |s| s.normal_force);
            let na = c.after.map_or(0.0, |s| s.normal_force);
            ContactChange {
                from: (a.x, a.y),
                to: (b.x, b.y),
                magnitude: c.force_difference().length(),
                normal_change: na - nb,
                fate: if c.opened() {
                    ContactFate::Opened
                } else if c.created() {
                    ContactFate::Created
                } else {
                    ContactFate::Kept
                },
            }
        })
        .collect()
}

fn field_npz(field: &FieldData, reference: Option<&FieldData>, path: &Path) -> Result<()> {
    let mut npz = Npz::new();
    npz.push_values("x", &[field.nx], field.xs())?;
    npz.push_values("z", &[field.nz], field.zs())?;
    let shape = [field.nz, field.nx];
    npz.push_values("sigma_xx", &shape, field.xx.clone())?;
    npz.push_values("sigma_zz", &shape, field.zz.clone())?;
    npz.push_values("sigma_xz", &shape, field.xz.clone())?;
    if let Some(r) = reference {
        npz.push_values("reference_sigma_xx", &shape, r.xx.clone())?;
        npz.push_values("reference_sigma_zz", &shape, r.zz.clone())?;
        npz.push_values("reference_sigma_xz", &shape, r.xz.clone())?;
    }
    npz.write(path, NpzCompression::Deflated)?;
    Ok(())
}

/// Writes the files of one run into `runs/<case>/<run>/` (called when the run completes).
pub fn write_run_files(
    out: &Path,
    cfg: &E3Config,
    plan: &Plan,
    run: &RunSpec,
    result: &RunResult,
    reference: &Snapshot<D2>,
    after: &Snapshot<D2>,
    changes: &NetworkChanges<D2>,
    reference_field: Option<&FieldData>,
) -> Result<()> {
    if !runs_enabled(cfg) {
        return Ok(());
    }
    let dir = out.join(run_dir(plan, run));
    std::fs::create_dir_all(&dir).map_err(|e| CoreError::Io { action: "cannot create".into(), path: dir.display().to_string(), error: e })?;
    // floor contacts
    let mut t = CsvTable::new();
    t.push_u32("grain", result.floor.iter().map(|c| c.grain))?;
    t.push_f64("x", result.floor.iter().map(|c| c.x))?;
    t.push_f64("fz_reference", result.floor.iter().map(|c| c.reference))?;
    t.push_f64("fz", result.floor.iter().map(|c| c.after))?;
    t.push_f64("dfz", result.floor.iter().map(|c| c.after - c.reference))?;
    t.push_f64("fx_reference", result.floor.iter().map(|c| c.horizontal_reference))?;
    t.push_f64("fx", result.floor.iter().map(|c| c.horizontal_after))?;
    write_csv_atomic(&dir.join("floor_contacts.csv"), &t)?;
    // smoothed profiles
    let mut cols = vec![("x".to_string(), result.grid.clone())];
    for (w, p) in cfg.response.widths.iter().zip(&result.profiles) {
        cols.push((format!("dsigma_w{w}"), p.clone()));
    }
    Series::from_columns(cols)?.write(&dir, "floor_profile")?;
    // contact changes (every contact whose force changed or that opened or closed)
    let mut t = CsvTable::new();
    let rows: Vec<_> = changes.contacts.iter().collect();
    t.push_text("kind", rows.iter().map(|c| if matches!(c.key, ContactKey::Pair(..)) { "pair" } else { "wall" }))?;
    t.push_u32("i", rows.iter().map(|c| c.key.first()))?;
    t.push_u32(
        "j_or_wall",
        rows.iter().map(|c| match c.key {
            ContactKey::Pair(_, j) => j,
            ContactKey::Wall(_, w) => w,
        }),
    )?;
    t.push_f64("x", rows.iter().map(|c| c.point().x))?;
    t.push_f64("z", rows.iter().map(|c| c.point().y))?;
    t.push_f64("dfx", rows.iter().map(|c| c.force_difference().x))?;
    t.push_f64("dfz", rows.iter().map(|c| c.force_difference().y))?;
    t.push_f64("fn_before", rows.iter().map(|c| c.before.map_or(0.0, |s| s.normal_force)))?;
    t.push_f64("fn_after", rows.iter().map(|c| c.after.map_or(0.0, |s| s.normal_force)))?;
    t.push_text(
        "state",
        rows.iter().map(|c| {
            if c.opened() {
                "opened"
            } else if c.created() {
                "created"
            } else if c.sliding_after() {
                "sliding"
            } else {
                "kept"
            }
        }),
    )?;
    write_csv_atomic(&dir.join("contact_changes.csv"), &t)?;
    if let Some(f) = &result.field {
        field_npz(f, reference_field, &dir.join("stress_field.npz"))?;
    }
    if cfg.output.vtk {
        difference_dataset(changes, reference)?.write_as(&dir.join("contact_force_difference.vtp"), VtkFormat::PolyData)?;
        write_grains_vtp(&dir.join("grains.vtp"), after)?;
    }
    if cfg.output.plots {
        let title = format!("ΔF network, F_ext = {} m̄g ({})", run.force, plan.groups[plan.cases[run.case].group].label);
        let mut pic = ContactChangePicture::new(reference, &title).x_label("x [R̄]").y_label("z [R̄]").changes(&change_segments(changes, reference));
        for (&(id, x, z), l) in result.loads.iter().zip(work::run_loads(cfg, plan, run)) {
            let _ = id;
            pic = pic.force((x, z), (l.1.x, l.1.y));
        }
        pic.save(&dir, "network").map_err(plot_err)?;
        if let Some(f) = &result.field {
            FieldMap::new(&format!("Δσ_zz, F_ext = {} m̄g, w = {} R̄", run.force, cfg.response.stress_width), (f.x0, f.dx, f.nx), (f.z0, f.dz, f.nz), &f.zz)
                .x_label("x [R̄]")
                .y_label("z [R̄]")
                .colorbar_label("Δσ_zz [m̄g/R̄]")
                .save(&dir, "stress_zz")
                .map_err(plot_err)?;
        }
        let xs: Vec<f64> = result.floor.iter().map(|c| c.x).collect();
        let per_contact: Vec<f64> = result.floor.iter().map(|c| (c.after - c.reference) / (2.0 * result.force)).collect();
        let mut plot = LinePlot::new(&format!("Floor response, F_ext = {} m̄g", run.force)).x_label("x − x_load [R̄]").y_label("response / F_ext [1/R̄]").scatter(
            "ΔF_z per contact / (2R̄ F_ext)",
            &xs,
            &per_contact,
        );
        for (w, p) in cfg.response.widths.iter().zip(&result.profiles) {
            let y: Vec<f64> = p.iter().map(|v| v / result.force).collect();
            plot = plot.series(&format!("smoothed, w = {w} R̄"), &result.grid, &y);
        }
        plot.save(&dir, "floor_profile").map_err(plot_err)?;
    }
    Ok(())
}


/// An ensemble of runs: one (group, force, variant) over the group's samples.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Aggregate {
    /// Group label.
    pub group: String,
    /// F_ext [m̄g].
    pub force: f64,
    /// Which force(s).
    pub variant: Variant,
    /// Samples averaged.
    pub samples: usize,
    /// Samples whose relaxation converged.
    pub converged: usize,
    /// p_w(0)/F_ext per width: mean [1/R̄].
    pub response_at_zero: Vec<f64>,
    /// Its r.m.s. deviation over samples [1/R̄].
    pub response_at_zero_std: Vec<f64>,
    /// Mean of Σ ΔF_z / (vertical load): the vertical floor balance.
    pub floor_balance: f64,
    /// Mean opened contacts.
    pub opened: f64,
    /// Mean created contacts.
    pub created: f64,
    /// Mean sliding contacts after the load.
    pub sliding: f64,
    /// Mean number of opened contacts in the region connected to the load.
    pub opened_region: f64,
    /// Mean depth of the opened region [R̄].
    pub opened_depth: f64,
    /// Mean width of the opened region [R̄].
    pub opened_width: f64,
    /// Mean number of grain–grain contacts opened in the first-opening region below the load
    /// (the cone of SPEC §7.2.5, connected to the load or not).
    #[serde(default)]
    pub opened_cone: f64,
    /// Mean depth below the load of the deepest of them [R̄].
    #[serde(default)]
    pub cone_depth: f64,
    /// Mean horizontal extent of their contact points [R̄].
    #[serde(default)]
    pub cone_width: f64,
    /// Antisymmetric fraction A_s of the mean floor response (mean ΔF_z per floor grain over the
    /// samples) about the load, with the contacts next to the axis (SPEC §7.2.5, `measure::Symmetry`).
    #[serde(default)]
    pub symmetry: Option<Symmetry>,
    /// A_s of the mean response (NaN without mirrored contacts).
    #[serde(default)]
    pub asymmetry: f64,
    /// Mean of the samples' own A_s.
    #[serde(default)]
    pub asymmetry_of_samples: f64,
    /// Samples whose own A_s exceeds their limit (`measure::asymmetry_limit` with the A_s of their
    /// packing's smallest force).
    #[serde(default)]
    pub asymmetric_samples: usize,
    /// The limit on A_s of this ensemble: `response.asymmetry_threshold`, and under a vertical
    /// load `asymmetry_factor` times the A_s of the group's smallest force.
    #[serde(default)]
    pub asymmetry_limit: f64,
    /// A_s of the mean response exceeds `asymmetry_limit`: reported asymmetric whatever its peak
    /// count.
    #[serde(default)]
    pub asymmetric: bool,
    /// The verdict with the symmetry: `asymmetric` when flagged, else `shape`.
    #[serde(default)]
    pub verdict: String,
    /// Verdict of the classifier on the mean smoothed profile (the verdict of disordered packings).
    pub classification: PeakClassification,
    /// Verdict on the raw per-contact floor forces (ordered lattices; mean ΔF_z per floor grain
    /// over the samples).
    pub raw: Option<RawVerdict>,
    /// The verdict of SPEC §7.2.5: the raw one for ordered lattices (δ = 0), the smoothed one
    /// otherwise.
    pub shape: PeakShape,
    /// Depth of the central dip of the verdict's profile (raw: signed, see `RawVerdict`).
    pub dip: f64,
    /// What the verdict was made on: `raw` or `smoothed`.
    pub verdict_basis: String,
    /// Mean r of the final network, bulk window.
    pub r_bulk: f64,
    /// Mean r of the final network, load window.
    pub r_load: f64,
    /// Mean linear estimate of the first opening (runs that stayed linear) [m̄g].
    pub first_opening_estimate: Option<f64>,
    /// Samples whose run stayed linear.
    pub linear: usize,
    /// Grid of the mean profiles, relative to the load [R̄].
    #[serde(skip)]
    pub grid: Vec<f64>,
    /// Mean profiles per width [m̄g/R̄].
    #[serde(skip)]
    pub profiles: Vec<Vec<f64>>,
    /// Their r.m.s. deviation [m̄g/R̄].
    #[serde(skip)]
    pub profiles_std: Vec<Vec<f64>>,
}

/// Averages the runs `rs` (same group, force and variant).
/// Whether the load of `cfg` is vertical without torque (its responses are expected symmetric).
fn vertical_load(cfg: &E3Config) -> bool {
    cfg.load.angle == 0.0 && cfg.load.torque == 0.0
}

/// A_s of a run.
fn run_asymmetry(r: &RunResult) -> f64 {
    r.symmetry.map_or(f64::NAN, |v| v.antisymmetric_fraction)
}

/// For every run of `plan` (by index), the A_s limit of the asymmetric flag: from the A_s of the
/// smallest-force run of the same case and variant when that run is linear (nothing opened,
/// created or started sliding: the small-force value); otherwise the threshold alone (e.g. a
/// refinement config whose smallest force is already beyond the linear regime).
pub fn run_asymmetry_limits(cfg: &E3Config, plan: &Plan, runs: &[RunResult]) -> Vec<f64> {
    plan.runs
        .iter()
        .map(|r| {
            let small = plan
                .runs
                .iter()
                .filter(|q| q.case == r.case && q.variant == r.variant)
                .min_by(|a, b| a.force.total_cmp(&b.force))
                .filter(|q| runs[q.index].linear)
                .map(|q| run_asymmetry(&runs[q.index]));
            measure::asymmetry_limit(cfg.response.asymmetry_threshold, cfg.response.asymmetry_factor, vertical_load(cfg), small)
        })
        .collect()
}

/// Sets the asymmetric flag and verdict of the ensembles `aggs` of one group: the limit from the
/// A_s of the group's smallest force (per variant) when every sample of it stayed linear.
fn flag_asymmetry(cfg: &E3Config, aggs: &mut [Aggregate]) {
    for v in [Variant::Single, Variant::Left, Variant::Right, Variant::Both] {
        let small = aggs.iter().filter(|a| a.variant == v).min_by(|a, b| a.force.total_cmp(&b.force)).filter(|a| a.linear == a.samples).map(|a| a.asymmetry);
        for a in aggs.iter_mut().filter(|a| a.variant == v) {
            a.asymmetry_limit = measure::asymmetry_limit(cfg.response.asymmetry_threshold, cfg.response.asymmetry_factor, vertical_load(cfg), small);
            a.asymmetric = a.asymmetry > a.asymmetry_limit;
            a.verdict = if a.asymmetric { "asymmetric".into() } else { a.shape.name().into() };
        }
    }
}

/// Averages the runs `rs` (same group, force and variant); `limits` are the per-run A_s limits
/// ([`run_asymmetry_limits`], by run index). The asymmetric flag of the ensemble is set by
/// [`flag_asymmetry`].
pub fn aggregate(cfg: &E3Config, group: &Group, variant: Variant, rs: &[&RunResult], limits: &[f64]) -> Aggregate {
    let step = cfg.response.profile_step;
    // common range of grid indices k (x = k step)
    let k_of = |x: f64| (x / step).round() as i64;
    let lo = rs.iter().map(|r| k_of(r.grid[0])).max().unwrap_or(0);
    let hi = rs.iter().map(|r| k_of(*r.grid.last().unwrap_or(&0.0))).min().unwrap_or(0);
    let grid: Vec<f64> = (lo..=hi).map(|k| k as f64 * step).collect();
    let nw = cfg.response.widths.len();
    let mut profiles = vec![vec![0.0; grid.len()]; nw];
    let mut profiles_std = vec![vec![0.0; grid.len()]; nw];
    for w in 0..nw {
        for (g, _) in grid.iter().enumerate() {
            let vals: Vec<f64> = rs
                .iter()
                .map(|r| {
                    let off = (lo - k_of(r.grid[0])) as usize;
                    r.profiles[w][off + g]
                })
                .collect();
            let MeanStd { mean: m, std: s, .. } = mean_std(&vals);
            profiles[w][g] = m;
            profiles_std[w][g] = s;
        }
    }
    let zero = measure::zero_index(&grid);
    let force = rs[0].force;
    let cw = cfg.response.classifier_width.unwrap_or(cfg.response.widths[0]);
    // the classifier profile: the width's profile if listed, else average the samples' own
    let classified: Vec<f64> = match cfg.response.widths.iter().position(|&w| w == cw) {
        Some(w) => profiles[w].clone(),
        None => {
            let mut acc = vec![0.0; grid.len()];
            for r in rs {
                let xs: Vec<f64> = r.floor.iter().map(|c| c.x).collect();
                let dz: Vec<f64> = r.floor.iter().map(|c| c.after - c.reference).collect();
                let p = grainwave_analysis::coarse_grain::smooth_1d(&xs, &dz, cw, &grid);
                for (a, b) in acc.iter_mut().zip(p) {
                    *a += b / rs.len() as f64;
                }
            }
            acc
        }
    };
    let classification = classify_profile(&grid, &classified, &PeakOptions { prominence: cfg.response.prominence, centre: 0.0 });
    // raw verdict on the mean ΔF_z per floor grain (x from the first sample holding the grain)
    // mean ΔF_z per floor grain over the samples (x from the first sample holding the grain)
    let mean_floor: Vec<FloorContact> = {
        let mut per: BTreeMap<u32, (f64, f64, usize)> = BTreeMap::new();
        for r in rs {
            for c in &r.floor {
                let e = per.entry(c.grain).or_insert((c.x, 0.0, 0));
                e.1 += c.after - c.reference;
                e.2 += 1;
            }
        }
        per.iter()
            .map(|(&grain, &(x, sum, _))| FloorContact { grain, x, reference: 0.0, after: sum / rs.len() as f64, horizontal_reference: 0.0, horizontal_after: 0.0 })
            .collect()
    };
    let raw = if group.delta == 0.0 { measure::raw_floor_verdict(&mean_floor) } else { None };
    let symmetry = measure::floor_symmetry(&mean_floor.iter().map(|c| (c.x, c.after)).collect::<Vec<_>>());
    let asymmetry = symmetry.map_or(f64::NAN, |s| s.antisymmetric_fraction);
    let (shape, dip, verdict_basis) = match &raw {
        Some(v) => (v.shape, v.dip, "raw"),
        None => (classification.shape, classification.dip, "smoothed"),
    };
    let sample_asymmetry: Vec<f64> = rs.iter().map(|r| run_asymmetry(r)).collect();
    let field = |f: &dyn Fn(&RunResult) -> f64| mean_std(&rs.iter().map(|r| f(r)).collect::<Vec<_>>()).mean;
    let linear: Vec<f64> = rs.iter().filter(|r| r.linear).filter_map(|r| r.first_opening_estimate).collect();
    Aggregate {
        group: group.label.clone(),
        force,
        variant,
        samples: rs.len(),
        converged: rs.iter().filter(|r| r.outcome.converged).count(),
        response_at_zero: (0..nw).map(|w| profiles[w][zero] / force).collect(),
        response_at_zero_std: (0..nw).map(|w| profiles_std[w][zero] / force).collect(),
        floor_balance: field(&|r| r.floor_change / r.vertical_load),
        opened: field(&|r| r.counts.opened as f64),
        created: field(&|r| r.counts.created as f64),
        sliding: field(&|r| r.counts.sliding as f64),
        opened_region: field(&|r| r.region.count as f64),
        opened_depth: field(&|r| r.region.depth),
        opened_width: field(&|r| r.region.width),
        opened_cone: field(&|r| r.cone.count as f64),
        cone_depth: field(&|r| r.cone.depth),
        cone_width: field(&|r| r.cone.width),
        symmetry,
        asymmetry,
        asymmetry_of_samples: mean_std(&sample_asymmetry).mean,
        asymmetric_samples: rs.iter().filter(|r| run_asymmetry(r) > limits.get(r.run).copied().unwrap_or(f64::INFINITY)).count(),
        asymmetry_limit: f64::NAN,
        asymmetric: false,
        verdict: shape.name().into(),
        classification,
        raw,
        shape,
        dip,
        verdict_basis: verdict_basis.into(),
        r_bulk: field(&|r| r.moduli_bulk.r),
        r_load: field(&|r| r.moduli_load.r),
        first_opening_estimate: if linear.is_empty() { None } else { Some(mean_std(&linear).mean) },
        linear: rs.iter().filter(|r| r.linear).count(),
        grid,
        profiles,
        profiles_std,
    }
}

/// The reference state of one case, as reported.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseReport {
    /// Seed of the radii.
    pub seed: u64,
    /// Grains.
    pub grains: usize,
    /// Relaxation converged.
    pub converged: bool,
    /// Steps of the relaxation.
    pub steps: u64,
    /// Simulated time of the relaxation [τ].
    pub duration: f64,
    /// Kinetic energy per grain at rest [m̄gR̄].
    pub kinetic_energy_per_grain: f64,
    /// Largest grain acceleration at rest [g].
    pub max_acceleration: f64,
    /// Newton iterations (frictionless).
    pub newton_iterations: usize,
    /// Total weight [m̄g].
    pub weight: f64,
    /// Floor load / weight.
    pub floor_over_weight: f64,
    /// Normal loads of the left and right walls [m̄g].
    pub side_wall_loads: [f64; 2],
    /// Moduli of the reference network, bulk window.
    pub moduli_bulk: ModuliReport,
}

/// Where the first contact opens, for one group, from the runs of `load.forces`. The "anywhere"
/// values count every contact, including nearly unloaded ones far from the load (walls, floor
/// row); the "below the load" bracket counts the grain–grain contacts opened in the cone below
/// the load (SPEC §7.2.5: the first-opening force, found precisely by `[first_opening]`
/// bisection, see `GroupReport::first_opening_bisection`); the "connected" bracket only the
/// opened region connected to the loaded grain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FirstOpening {
    /// Largest force of the list without an opened contact in the region below the load (the
    /// cone of SPEC §7.2.5; every sample) [m̄g].
    pub largest_without_opening_below_load: Option<f64>,
    /// Smallest force of the list with an opened contact in that region (some sample) [m̄g].
    pub smallest_with_opening_below_load: Option<f64>,
    /// Largest force of the list whose opened region connected to the loaded grain is empty (every
    /// sample) [m̄g].
    #[serde(default)]
    pub largest_without_opening_connected: Option<f64>,
    /// Smallest force of the list with an opened contact connected to the loaded grain [m̄g].
    #[serde(default)]
    pub smallest_with_opening_connected: Option<f64>,
    /// Linear estimate (anywhere) from the smallest force whose runs stayed linear [m̄g].
    pub linear_estimate: Option<f64>,
    /// The force of the run the estimate comes from [m̄g].
    pub estimated_from: Option<f64>,
    /// Largest force of the list at which no contact opened anywhere (every sample) [m̄g].
    pub largest_without_opening: Option<f64>,
    /// Smallest force of the list at which some contact opened anywhere [m̄g].
    pub smallest_with_opening: Option<f64>,
}

/// One parameter set in the summary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroupReport {
    /// Label.
    pub label: String,
    /// Layers L.
    pub layers: usize,
    /// Grains per long row M (pile: grains in the bottom layer).
    pub grains_per_layer: usize,
    /// Polydispersity δ.
    pub delta: f64,
    /// Resolved contact parameters.
    pub material: Material,
    /// Reference states.
    pub cases: Vec<CaseReport>,
    /// Responses.
    pub responses: Vec<Aggregate>,
    /// First opening from the force list.
    pub first_opening: Option<FirstOpening>,
    /// First opening below the load by bisection, per reference state (`[first_opening]`).
    pub first_opening_bisection: Vec<work::OpeningBisection>,
    /// The small-force value of the antisymmetric fraction: (F_ext, A_s) of the group's smallest
    /// force (single load), against which larger forces' A_s are read.
    #[serde(default)]
    pub asymmetry_small_force: Option<[f64; 2]>,
    /// `response.asymmetry_threshold`.
    #[serde(default)]
    pub asymmetry_threshold: f64,
    /// `response.asymmetry_factor`.
    #[serde(default)]
    pub asymmetry_factor: f64,
}

/// Superposition check of one case and force.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SuperpositionReport {
    /// Case label.
    pub case: String,
    /// F_ext of each force [m̄g].
    pub force: f64,
    /// Ids of the left and right loaded grains.
    pub grains: [u32; 2],
    /// Their distance [R̄].
    pub separation: f64,
    /// max_c |ΔF_both − ΔF_left − ΔF_right| / max_c |ΔF_both| over contacts.
    pub contact_max_deviation: f64,
    /// r.m.s. of the same over r.m.s. |ΔF_both|.
    pub contact_rms_deviation: f64,
    /// max_x |p_both − p_left − p_right| / max_x |p_both| per width.
    pub profile_max_deviation: Vec<f64>,
    /// Contacts opened in the joint run.
    pub opened_both: usize,
}

/// The lattice-elasticity result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LatticeReport {
    /// The moduli of the configured lattice (a, b, c, d in m̄g/R̄).
    pub moduli: ModuliReport,
    /// Verdict: "double" when r < 0, else "single".
    pub verdict: String,
    /// r against kᵗ/kⁿ: (ratio, r with the horizontal bonds, r without them).
    pub scan: Vec<(f64, f64, f64)>,
}

/// Pile floor stress of one group.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PileReport {
    /// Group label.
    pub group: String,
    /// Floor load / weight (mean over samples).
    pub floor_over_weight: f64,
    /// Smoothed floor stress at the axis, per width [m̄g/R̄].
    pub stress_at_axis: Vec<f64>,
    /// Largest smoothed floor stress, per width [m̄g/R̄].
    pub stress_max: Vec<f64>,
    /// Whether the floor stress dips under the apex (SPEC §7.2.9): judged on the coarse-grained
    /// floor stress σ_zz(x) = Σ_c F_z,c (1/(w√π)) e^{−((x − x_c)/w)²}, w = `pile.verdict_width`
    /// (2R̄), mean over samples: double when its value on the axis is below its maxima on either
    /// side within `verdict_window` (away from the side walls' support), `measure::axis_verdict`.
    pub shape: PeakShape,
    /// Signed depth of that dip, 1 − σ_zz(0)/min(max_L, max_R) (< 0: the axis stands above).
    pub dip: f64,
    /// What `shape` was judged on.
    pub verdict_basis: String,
    /// w of the judged profile [R̄].
    pub verdict_width: f64,
    /// The judged profile's verdict with its axis value and side maxima (x, σ_zz) [R̄, m̄g/R̄].
    pub coarse: Option<RawVerdict>,
    /// [x_min, x_max] searched for the side maxima: 2w inside the innermost wall-supported floor
    /// contact of each side (x from the axis) [R̄].
    pub verdict_window: [f64; 2],
    /// x of the floor contacts of grains touching a side wall (every sample) [R̄].
    pub wall_supported: Vec<f64>,
    /// Verdict on the raw per-contact floor forces F_z (ordered piles; the forces themselves, the
    /// pile under gravity having no reference state to subtract), the floor contacts of grains
    /// touching a side wall left out.
    pub raw: Option<RawVerdict>,
    /// Its verdict.
    pub shape_raw: Option<PeakShape>,
    /// Its signed dip.
    pub dip_raw: f64,
    /// The raw verdict with the wall-supported floor contacts included (earlier versions' rule).
    pub raw_with_edges: Option<RawVerdict>,
    /// Verdict of the classifier on the smoothed profile (first width), always given.
    pub shape_smoothed: PeakShape,
    /// Its dip depth.
    pub dip_smoothed: f64,
}

/// The summary of an `e3` run (`summary.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct E3Summary {
    /// `e3`.
    pub experiment: String,
    /// Mode.
    pub mode: String,
    /// grainwave version.
    pub version: String,
    /// First seed.
    pub seed: u64,
    /// Samples per disordered parameter set.
    pub samples: usize,
    /// Units of every quantity, and their SI values.
    pub units: BTreeMap<String, String>,
    /// Parameter sets.
    pub groups: Vec<GroupReport>,
    /// Superposition checks.
    pub superposition: Vec<SuperpositionReport>,
    /// Pile floor stresses.
    pub piles: Vec<PileReport>,
    /// Lattice elasticity (mode `lattice_elasticity`).
    pub lattice: Option<LatticeReport>,
    /// Runs whose relaxation did not converge (labels).
    pub not_converged: Vec<String>,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
}

fn units_map(cfg: &E3Config) -> BTreeMap<String, String> {
    let u = &cfg.units;
    let mass = std::f64::consts::PI * u.radius * u.radius * u.thickness * u.density;
    let time = (u.radius / u.gravity).sqrt();
    let force = mass * u.gravity;
    let mut m = BTreeMap::new();
    m.insert("length".into(), format!("R̄ (largest radius) = {} m", u.radius));
    m.insert("mass".into(), format!("m̄ (mass of a disk of radius R̄) = {mass:.6e} kg"));
    m.insert("time".into(), format!("τ = √(R̄/g) = {time:.6e} s"));
    m.insert("force".into(), format!("m̄g = {force:.6e} N"));
    m.insert("stiffness, moduli, stresses".into(), format!("m̄g/R̄ = {:.6e} N/m", force / u.radius));
    m.insert("energy".into(), format!("m̄gR̄ = {:.6e} J", force * u.radius));
    m.insert("acceleration".into(), format!("g = {} m/s²", u.gravity));
    m.insert("response_at_zero".into(), "1/R̄ (floor stress per unit applied force)".into());
    m
}

/// Smallest and largest forces bracketing the first opening, and the linear estimate.
fn first_opening(aggs: &[Aggregate]) -> Option<FirstOpening> {
    let singles: Vec<&Aggregate> = aggs.iter().filter(|a| a.variant == Variant::Single).collect();
    if singles.is_empty() {
        return None;
    }
    let mut by_force = singles.clone();
    by_force.sort_by(|a, b| a.force.total_cmp(&b.force));
    let est = by_force.iter().find(|a| a.linear == a.samples && a.first_opening_estimate.is_some());
    Some(FirstOpening {
        largest_without_opening_below_load: by_force
            .iter()
            .filter(|a| a.opened_cone == 0.0)
            .map(|a| a.force)
            .fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.max(f)))),
        smallest_with_opening_below_load: by_force.iter().find(|a| a.opened_cone > 0.0).map(|a| a.force),
        largest_without_opening_connected: by_force
            .iter()
            .filter(|a| a.opened_region == 0.0)
            .map(|a| a.force)
            .fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.max(f)))),
        smallest_with_opening_connected: by_force.iter().find(|a| a.opened_region > 0.0).map(|a| a.force),
        linear_estimate: est.and_then(|a| a.first_opening_estimate),
        estimated_from: est.map(|a| a.force),
        largest_without_opening: by_force.iter().filter(|a| a.opened == 0.0).map(|a| a.force).fold(None, |m: Option<f64>, f| Some(m.map_or(f, |m| m.max(f)))),
        smallest_with_opening: by_force.iter().find(|a| a.opened > 0.0).map(|a| a.force),
    })
}

/// Reads every unit result in the output directory `out` and writes the aggregate outputs
/// (tables, plots, `summary.json`, `timing.json`); returns the summary.
pub fn write_final(out: &Path, cfg: &E3Config, plan: &Plan) -> Result<E3Summary> {
    let out = out.to_path_buf();
    let mut files =
        vec!["config.resolved.toml".to_string(), "summary.json".into(), "timing.json".into(), "run.log".into(), grainwave_study::protocol::CHECKPOINT_FILE.into()];
    let mut summary = E3Summary {
        experiment: "e3".into(),
        mode: cfg.mode.name().into(),
        version: grainwave_core::VERSION.into(),
        seed: cfg.seed,
        samples: cfg.samples,
        units: units_map(cfg),
        groups: Vec::new(),
        superposition: Vec::new(),
        piles: Vec::new(),
        lattice: None,
        not_converged: Vec::new(),
        files: Vec::new(),
    };
    let mut timing = BTreeMap::new();
    if cfg.mode == Mode::LatticeElasticity {
        summary.lattice = Some(lattice_outputs(cfg, &out, &mut files)?);
    }
    let mut references: Vec<ReferenceResult> = Vec::with_capacity(plan.cases.len());
    for case in &plan.cases {
        let r: ReferenceResult = grainwave_core::checkpoint::load(&work::reference_file(&out, case), work::REFERENCE_TAG)?;
        timing.insert(format!("reference {}", case.label), r.wall_clock);
        if !r.outcome.converged {
            summary.not_converged.push(format!("reference {}", case.label));
        }
        references.push(r);
    }
    let mut runs: Vec<RunResult> = Vec::with_capacity(plan.runs.len());
    for run in &plan.runs {
        let s: StoredRun = grainwave_core::checkpoint::load(&work::run_file(&out, plan, run), work::RUN_TAG)?;
        timing.insert(format!("run {}/{}", plan.cases[run.case].label, run.label), s.wall_clock);
        if !s.result.outcome.converged {
            summary.not_converged.push(format!("run {}/{}", plan.cases[run.case].label, run.label));
        }
        runs.push(s.result);
    }
    // per-group aggregates
    let limits = run_asymmetry_limits(cfg, plan, &runs);
    let mut all_aggs: Vec<(usize, Aggregate)> = Vec::new();
    for group in &plan.groups {
        let cases: Vec<CaseReport> = group
            .cases
            .iter()
            .map(|&c| {
                let r = &references[c];
                CaseReport {
                    seed: plan.cases[c].seed,
                    grains: r.sim.len(),
                    converged: r.outcome.converged,
                    steps: r.outcome.steps,
                    duration: r.outcome.duration,
                    kinetic_energy_per_grain: r.outcome.kinetic_energy_per_grain,
                    max_acceleration: r.outcome.max_acceleration,
                    newton_iterations: r.outcome.newton_iterations,
                    weight: r.weight,
                    floor_over_weight: r.wall_loads[0] / r.weight,
                    side_wall_loads: [r.wall_loads[1], r.wall_loads[2]],
                    moduli_bulk: r.moduli_bulk,
                }
            })
            .collect();
        let mut aggs = Vec::new();
        for (fi, _) in cfg.load.forces.iter().enumerate() {
            for variant in [Variant::Single, Variant::Left, Variant::Right, Variant::Both] {
                let rs: Vec<&RunResult> = plan
                    .runs
                    .iter()
                    .filter(|r| plan.cases[r.case].group == group.index && r.force_index == fi && r.variant == variant)
                    .map(|r| &runs[r.index])
                    .collect();
                if rs.is_empty() || cfg.mode == Mode::Pile {
                    continue;
                }
                aggs.push(aggregate(cfg, group, variant, &rs, &limits));
            }
        }
        flag_asymmetry(cfg, &mut aggs);
        for a in &aggs {
            all_aggs.push((group.index, a.clone()));
        }
        let mut bisections = Vec::new();
        if cfg.first_opening.bisection && matches!(cfg.mode, Mode::Slab | Mode::Sweep) {
            for &c in &group.cases {
                let case = &plan.cases[c];
                let probes = work::read_bisection(&out, case)?;
                for (k, p) in probes.iter().enumerate() {
                    timing.insert(format!("opening {}/opening_{k}", case.label), p.wall_clock);
                    if !p.converged {
                        summary.not_converged.push(format!("opening {}/opening_{k}", case.label));
                    }
                }
                bisections.push(work::summarize_bisection(cfg, case, probes));
            }
        }
        let (layers, m) = match group.shape {
            Shape::Slab { layers, grains_per_layer, .. } => (layers, grains_per_layer),
            Shape::Pile { layers, top_grains } => (layers, top_grains + layers - 1),
        };
        summary.groups.push(GroupReport {
            label: group.label.clone(),
            layers,
            grains_per_layer: m,
            delta: group.delta,
            material: Material::resolve(&cfg.material, group.friction, group.ratio),
            cases,
            first_opening: first_opening(&aggs),
            first_opening_bisection: bisections,
            asymmetry_small_force: aggs
                .iter()
                .filter(|a| a.variant == Variant::Single)
                .min_by(|a, b| a.force.total_cmp(&b.force))
                .map(|a| [a.force, a.asymmetry]),
            asymmetry_threshold: cfg.response.asymmetry_threshold,
            asymmetry_factor: cfg.response.asymmetry_factor,
            responses: aggs,
        });
    }
    if cfg.mode != Mode::Pile && cfg.mode != Mode::LatticeElasticity {
        tables(cfg, plan, &runs, &limits, &all_aggs, &out, &mut files)?;
        if cfg.output.plots {
            plots(cfg, plan, &all_aggs, &out, &mut files)?;
        }
    }
    if cfg.mode == Mode::Superposition {
        summary.superposition = superposition(cfg, plan, &runs, &out, &mut files)?;
    }
    if cfg.mode == Mode::Pile {
        summary.piles = pile_outputs(cfg, plan, &references, &out, &mut files)?;
    }
    if runs_enabled(cfg) && !plan.runs.is_empty() {
        files.push("runs/".into());
    }
    if !plan.cases.is_empty() {
        files.push("units/".into());
    }
    summary.files = files;
    grainwave_study::outputs::write_summary(&out, &summary)?;
    write_json_atomic(&out.join("timing.json"), &timing)?;
    Ok(summary)
}

fn tables(cfg: &E3Config, plan: &Plan, runs: &[RunResult], limits: &[f64], aggs: &[(usize, Aggregate)], out: &Path, files: &mut Vec<String>) -> Result<()> {
    let nw = cfg.response.widths.len();
    // one row per run
    let mut t = CsvTable::new();
    t.push_text("group", plan.runs.iter().map(|r| plan.groups[plan.cases[r.case].group].label.clone()))?;
    t.push_u64("seed", plan.runs.iter().map(|r| plan.cases[r.case].seed))?;
    t.push_text("variant", plan.runs.iter().map(|r| r.variant.name()))?;
    t.push_f64("force", plan.runs.iter().map(|r| r.force))?;
    for w in 0..nw {
        t.push_f64(format!("response_at_zero_w{}", cfg.response.widths[w]), runs.iter().map(|r| r.response_at_zero[w]))?;
    }
    t.push_f64("floor_balance", runs.iter().map(|r| r.floor_change / r.vertical_load))?;
    t.push_u64("opened", runs.iter().map(|r| r.counts.opened as u64))?;
    t.push_u64("created", runs.iter().map(|r| r.counts.created as u64))?;
    t.push_u64("sliding", runs.iter().map(|r| r.counts.sliding as u64))?;
    t.push_u64("opened_region", runs.iter().map(|r| r.region.count as u64))?;
    t.push_f64("opened_depth", runs.iter().map(|r| r.region.depth))?;
    t.push_f64("opened_width", runs.iter().map(|r| r.region.width))?;
    t.push_u64("opened_cone", runs.iter().map(|r| r.cone.count as u64))?;
    t.push_f64("cone_depth", runs.iter().map(|r| r.cone.depth))?;
    t.push_f64("cone_shallowest", runs.iter().map(|r| r.cone.shallowest))?;
    t.push_f64("cone_width", runs.iter().map(|r| r.cone.width))?;
    t.push_text("shape_smoothed", runs.iter().map(|r| r.classification.shape.name()))?;
    t.push_f64("dip_smoothed", runs.iter().map(|r| r.classification.dip))?;
    t.push_text("shape_raw", runs.iter().map(|r| r.raw.map_or("none", |v| v.shape.name())))?;
    t.push_f64("raw_dip", runs.iter().map(|r| r.raw.map_or(f64::NAN, |v| v.dip)))?;
    t.push_f64("asymmetry", runs.iter().map(run_asymmetry))?;
    t.push_f64("asymmetry_limit", limits.iter().copied())?;
    t.push_text("asymmetric", runs.iter().zip(limits).map(|(r, l)| if run_asymmetry(r) > *l { "yes" } else { "no" }))?;
    for (name, side) in [("axis_left", 0usize), ("axis_centre", 1), ("axis_right", 2)] {
        let pick = |r: &RunResult| r.symmetry.and_then(|v| [v.left, v.centre, v.right][side]);
        t.push_f64(format!("{name}_x"), runs.iter().map(|r| pick(r).map_or(f64::NAN, |p| p[0])))?;
        t.push_f64(format!("{name}_dfz"), runs.iter().map(|r| pick(r).map_or(f64::NAN, |p| p[1])))?;
    }
    t.push_f64("first_opening_estimate", runs.iter().map(|r| if r.linear { r.first_opening_estimate.unwrap_or(f64::NAN) } else { f64::NAN }))?;
    t.push_f64("r_bulk", runs.iter().map(|r| r.moduli_bulk.r))?;
    t.push_f64("r_load", runs.iter().map(|r| r.moduli_load.r))?;
    t.push_text("converged", runs.iter().map(|r| if r.outcome.converged { "yes" } else { "no" }))?;
    t.push_u64("steps", runs.iter().map(|r| r.outcome.steps))?;
    write_csv_atomic(&out.join("runs.csv"), &t)?;
    files.push("runs.csv".into());
    // one row per ensemble
    let mut t = CsvTable::new();
    let g = |i: usize| &plan.groups[aggs[i].0];
    let idx: Vec<usize> = (0..aggs.len()).collect();
    t.push_text("group", idx.iter().map(|&i| g(i).label.clone()))?;
    t.push_f64("delta", idx.iter().map(|&i| g(i).delta))?;
    t.push_f64("friction", idx.iter().map(|&i| g(i).friction))?;
    t.push_f64("stiffness_ratio", idx.iter().map(|&i| g(i).ratio))?;
    t.push_u32(
        "layers",
        idx.iter().map(|&i| match g(i).shape {
            Shape::Slab { layers, .. } | Shape::Pile { layers, .. } => layers as u32,
        }),
    )?;
    t.push_u32(
        "grains_per_layer",
        idx.iter().map(|&i| match g(i).shape {
            Shape::Slab { grains_per_layer, .. } => grains_per_layer as u32,
            Shape::Pile { layers, top_grains } => (layers + top_grains - 1) as u32,
        }),
    )?;
    t.push_text("variant", idx.iter().map(|&i| aggs[i].1.variant.name()))?;
    t.push_f64("force", idx.iter().map(|&i| aggs[i].1.force))?;
    t.push_u64("samples", idx.iter().map(|&i| aggs[i].1.samples as u64))?;
    for w in 0..nw {
        t.push_f64(format!("response_at_zero_w{}", cfg.response.widths[w]), idx.iter().map(|&i| aggs[i].1.response_at_zero[w]))?;
        t.push_f64(format!("response_at_zero_w{}_std", cfg.response.widths[w]), idx.iter().map(|&i| aggs[i].1.response_at_zero_std[w]))?;
    }
    t.push_f64("floor_balance", idx.iter().map(|&i| aggs[i].1.floor_balance))?;
    t.push_f64("opened", idx.iter().map(|&i| aggs[i].1.opened))?;
    t.push_f64("created", idx.iter().map(|&i| aggs[i].1.created))?;
    t.push_f64("sliding", idx.iter().map(|&i| aggs[i].1.sliding))?;
    t.push_f64("opened_region", idx.iter().map(|&i| aggs[i].1.opened_region))?;
    t.push_f64("opened_depth", idx.iter().map(|&i| aggs[i].1.opened_depth))?;
    t.push_f64("opened_width", idx.iter().map(|&i| aggs[i].1.opened_width))?;
    t.push_f64("opened_cone", idx.iter().map(|&i| aggs[i].1.opened_cone))?;
    t.push_f64("cone_depth", idx.iter().map(|&i| aggs[i].1.cone_depth))?;
    t.push_f64("cone_width", idx.iter().map(|&i| aggs[i].1.cone_width))?;
    t.push_f64("asymmetry", idx.iter().map(|&i| aggs[i].1.asymmetry))?;
    t.push_f64("asymmetry_limit", idx.iter().map(|&i| aggs[i].1.asymmetry_limit))?;
    t.push_text("asymmetric", idx.iter().map(|&i| if aggs[i].1.asymmetric { "yes" } else { "no" }))?;
    t.push_text("verdict", idx.iter().map(|&i| aggs[i].1.verdict.clone()))?;
    t.push_text("shape", idx.iter().map(|&i| aggs[i].1.shape.name()))?;
    t.push_f64("dip", idx.iter().map(|&i| aggs[i].1.dip))?;
    t.push_text("verdict_basis", idx.iter().map(|&i| aggs[i].1.verdict_basis.clone()))?;
    t.push_text("shape_smoothed", idx.iter().map(|&i| aggs[i].1.classification.shape.name()))?;
    t.push_f64("dip_smoothed", idx.iter().map(|&i| aggs[i].1.classification.dip))?;
    t.push_f64("peak_separation_smoothed", idx.iter().map(|&i| aggs[i].1.classification.separation))?;
    t.push_f64("r_bulk", idx.iter().map(|&i| aggs[i].1.r_bulk))?;
    t.push_f64("r_load", idx.iter().map(|&i| aggs[i].1.r_load))?;
    t.push_u64("converged", idx.iter().map(|&i| aggs[i].1.converged as u64))?;
    write_csv_atomic(&out.join("results.csv"), &t)?;
    files.push("results.csv".into());
    // mean profiles, long format
    let mut cols: [Vec<f64>; 7] = Default::default();
    for (gi, a) in aggs {
        let v = match a.variant {
            Variant::Single => 0.0,
            Variant::Left => 1.0,
            Variant::Right => 2.0,
            Variant::Both => 3.0,
        };
        for (w, width) in cfg.response.widths.iter().enumerate() {
            for (k, x) in a.grid.iter().enumerate() {
                for (c, value) in [*gi as f64, a.force, v, *width, *x, a.profiles[w][k], a.profiles_std[w][k]].into_iter().enumerate() {
                    cols[c].push(value);
                }
            }
        }
    }
    let names = ["group", "force", "variant", "width", "x", "mean", "std"];
    Series::from_columns(names.iter().map(|n| n.to_string()).zip(cols))?.write(out, "profiles")?;
    files.push("profiles.csv".into());
    files.push("profiles.npz".into());
    Ok(())
}

fn plots(cfg: &E3Config, plan: &Plan, aggs: &[(usize, Aggregate)], out: &Path, files: &mut Vec<String>) -> Result<()> {
    let w0 = cfg.response.widths[0];
    for group in &plan.groups {
        let mine: Vec<&Aggregate> = aggs.iter().filter(|(g, a)| *g == group.index && a.variant == Variant::Single).map(|(_, a)| a).collect();
        if mine.is_empty() {
            continue;
        }
        // profiles normalized by F, for every force
        let mut plot =
            LinePlot::new(&format!("Floor response / F_ext, w = {w0} R̄ ({})", group.label)).x_label("x − x_load [R̄]").y_label("Δσ_zz(x) / F_ext [1/R̄]");
        for a in &mine {
            let y: Vec<f64> = a.profiles[0].iter().map(|v| v / a.force).collect();
            plot = plot.series(&format!("F = {}", a.force), &a.grid, &y);
        }
        let stem = format!("profiles_{}", group.label);
        plot.save(out, &stem).map_err(plot_err)?;
        files.push(format!("{stem}.png"));
        files.push(format!("{stem}.svg"));
    }
    // linearity: p(0)/F vs F, per group and width
    let mut plot =
        LinePlot::new("Response at x = 0 per unit force").x_label("F_ext [m̄g]").y_label("Δσ_zz(0) / F_ext [1/R̄]").log_x().legend(LegendPosition::LowerLeft);
    let mut any = false;
    for group in &plan.groups {
        let mut mine: Vec<&Aggregate> = aggs.iter().filter(|(g, a)| *g == group.index && a.variant == Variant::Single).map(|(_, a)| a).collect();
        mine.sort_by(|a, b| a.force.total_cmp(&b.force));
        if mine.is_empty() {
            continue;
        }
        any = true;
        let f: Vec<f64> = mine.iter().map(|a| a.force).collect();
        for (w, width) in cfg.response.widths.iter().enumerate() {
            let y: Vec<f64> = mine.iter().map(|a| a.response_at_zero[w]).collect();
            let name = if plan.groups.len() > 1 { format!("{}, w = {width}", group.label) } else { format!("w = {width} R̄") };
            plot = if mine.len() > 1 { plot.series(&name, &f, &y) } else { plot.scatter(&name, &f, &y) };
        }
    }
    if any {
        plot.save(out, "linearity").map_err(plot_err)?;
        files.push("linearity.png".into());
        files.push("linearity.svg".into());
        // opened region
        let mut plot = LinePlot::new("Region of opened contacts").x_label("F_ext [m̄g]").y_label("size [R̄]").log_x().legend(LegendPosition::UpperLeft);
        for group in &plan.groups {
            let mut mine: Vec<&Aggregate> = aggs.iter().filter(|(g, a)| *g == group.index && a.variant == Variant::Single).map(|(_, a)| a).collect();
            mine.sort_by(|a, b| a.force.total_cmp(&b.force));
            if mine.is_empty() {
                continue;
            }
            let f: Vec<f64> = mine.iter().map(|a| a.force).collect();
            let sfx = if plan.groups.len() > 1 { format!(" ({})", group.label) } else { String::new() };
            plot = plot.series(&format!("depth{sfx}"), &f, &mine.iter().map(|a| a.opened_depth).collect::<Vec<_>>());
            plot = plot.dashed(&format!("width{sfx}"), &f, &mine.iter().map(|a| a.opened_width).collect::<Vec<_>>());
        }
        plot.save(out, "opened_region").map_err(plot_err)?;
        files.push("opened_region.png".into());
        files.push("opened_region.svg".into());
    }
    if cfg.mode == Mode::Sweep {
        crossover(cfg, plan, aggs, out, files)?;
    }
    Ok(())
}

/// Crossover diagrams: for every size and δ, F_ext against μ (and against k_T/k_N when that is
/// swept), one marker per ensemble coloured by verdict.
fn crossover(cfg: &E3Config, plan: &Plan, aggs: &[(usize, Aggregate)], out: &Path, files: &mut Vec<String>) -> Result<()> {
    let mut keys: Vec<(String, f64)> = Vec::new();
    for g in &plan.groups {
        let size = match g.shape {
            Shape::Slab { layers, grains_per_layer, .. } => format!("L{layers}xM{grains_per_layer}"),
            Shape::Pile { layers, top_grains } => format!("pile{layers}_top{top_grains}"),
        };
        if !keys.iter().any(|k| k.0 == size && k.1 == g.delta) {
            keys.push((size, g.delta));
        }
    }
    let frictions: Vec<f64> = {
        let mut v: Vec<f64> = plan.groups.iter().map(|g| g.friction).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    let ratios: Vec<f64> = {
        let mut v: Vec<f64> = plan.groups.iter().map(|g| g.ratio).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    let min_positive_mu = frictions.iter().copied().filter(|&m| m > 0.0).fold(f64::INFINITY, f64::min);
    let mu_stand_in = if min_positive_mu.is_finite() { min_positive_mu / 10.0 } else { 0.01 };
    for (size, delta) in keys {
        for (axis, values) in [("friction", &frictions), ("stiffness_ratio", &ratios)] {
            if values.len() < 2 && !(axis == "friction" && ratios.len() < 2) {
                continue;
            }
            let mut pts: BTreeMap<&str, (Vec<f64>, Vec<f64>)> = BTreeMap::new();
            for (gi, a) in aggs.iter().filter(|(_, a)| a.variant == Variant::Single) {
                let g = &plan.groups[*gi];
                let gsize = g.label.split('_').next().unwrap_or("");
                if gsize != size || g.delta != delta {
                    continue;
                }
                let x = if axis == "friction" {
                    if g.friction > 0.0 {
                        g.friction
                    } else {
                        mu_stand_in
                    }
                } else {
                    g.ratio
                };
                let e = pts.entry(a.shape.name()).or_default();
                e.0.push(x);
                e.1.push(a.force);
            }
            if pts.is_empty() {
                continue;
            }
            let title = if axis == "friction" {
                format!("Crossover, {size}, δ = {delta} (μ = 0 drawn at {mu_stand_in})")
            } else {
                format!("Crossover, {size}, δ = {delta}")
            };
            let mut plot = LinePlot::new(&title).x_label(if axis == "friction" { "μ" } else { "k_T/k_N" }).y_label("F_ext [m̄g]").log_y();
            if axis == "friction" {
                plot = plot.log_x();
            }
            for (name, (x, y)) in &pts {
                plot = plot.scatter(&format!("{name} peak"), x, y);
            }
            let stem = format!("crossover_{axis}_{size}_d{delta}");
            plot.save(out, &stem).map_err(plot_err)?;
            files.push(format!("{stem}.png"));
            files.push(format!("{stem}.svg"));
        }
    }
    let _ = cfg;
    Ok(())
}

fn superposition(cfg: &E3Config, plan: &Plan, runs: &[RunResult], out: &Path, files: &mut Vec<String>) -> Result<Vec<SuperpositionReport>> {
    let mut reports = Vec::new();
    for case in &plan.cases {
        for (fi, &force) in cfg.load.forces.iter().enumerate() {
            let find = |v: Variant| plan.runs.iter().find(|r| r.case == case.index && r.force_index == fi && r.variant == v).map(|r| &runs[r.index]);
            let (Some(l), Some(r), Some(b)) = (find(Variant::Left), find(Variant::Right), find(Variant::Both)) else { continue };
            let map = |x: &RunResult| -> BTreeMap<ContactKey, [f64; 2]> { x.contacts.iter().flatten().map(|c| (c.key, c.df)).collect() };
            let (ml, mr, mb) = (map(l), map(r), map(b));
            let mut keys: Vec<ContactKey> = ml.keys().chain(mr.keys()).chain(mb.keys()).copied().collect();
            keys.sort();
            keys.dedup();
            let get = |m: &BTreeMap<ContactKey, [f64; 2]>, k: &ContactKey| m.get(k).copied().unwrap_or([0.0, 0.0]);
            let (mut dev_max, mut both_max, mut dev2, mut both2) = (0.0f64, 0.0f64, 0.0, 0.0);
            for k in &keys {
                let (a, bb, c) = (get(&ml, k), get(&mr, k), get(&mb, k));
                let d = ((c[0] - a[0] - bb[0]).powi(2) + (c[1] - a[1] - bb[1]).powi(2)).sqrt();
                let m = (c[0] * c[0] + c[1] * c[1]).sqrt();
                dev_max = dev_max.max(d);
                both_max = both_max.max(m);
                dev2 += d * d;
                both2 += m * m;
            }
            // profiles: common grid (the origin of all three is the midpoint of the two loads)
            let profile_dev: Vec<f64> = (0..cfg.response.widths.len())
                .map(|w| {
                    let n = b.grid.len().min(l.grid.len()).min(r.grid.len());
                    let mut dm = 0.0f64;
                    let mut pm = 0.0f64;
                    for k in 0..n {
                        dm = dm.max((b.profiles[w][k] - l.profiles[w][k] - r.profiles[w][k]).abs());
                        pm = pm.max(b.profiles[w][k].abs());
                    }
                    dm / pm
                })
                .collect();
            let grains = [b.loads[0].0, b.loads.get(1).map_or(b.loads[0].0, |x| x.0)];
            reports.push(SuperpositionReport {
                case: case.label.clone(),
                force,
                grains,
                separation: b.loads.get(1).map_or(0.0, |x| x.1 - b.loads[0].1),
                contact_max_deviation: dev_max / both_max,
                contact_rms_deviation: (dev2 / both2).sqrt(),
                profile_max_deviation: profile_dev,
                opened_both: b.counts.opened,
            });
            if cfg.output.plots {
                let y = |p: &Vec<f64>| p.iter().map(|v| v / force).collect::<Vec<f64>>();
                let sum: Vec<f64> = l.profiles[0].iter().zip(&r.profiles[0]).map(|(a, c)| (a + c) / force).collect();
                let stem = format!("superposition_{}_F{force}", case.label);
                LinePlot::new(&format!("Superposition, F = {force} m̄g each, w = {} R̄", cfg.response.widths[0]))
                    .x_label("x − x_mid [R̄]")
                    .y_label("Δσ_zz / F_ext [1/R̄]")
                    .series("left", &l.grid, &y(&l.profiles[0]))
                    .series("right", &r.grid, &y(&r.profiles[0]))
                    .series("both", &b.grid, &y(&b.profiles[0]))
                    .dashed("left + right", &l.grid, &sum)
                    .save(out, &stem)
                    .map_err(plot_err)?;
                files.push(format!("{stem}.png"));
                files.push(format!("{stem}.svg"));
            }
        }
    }
    let mut t = CsvTable::new();
    t.push_text("case", reports.iter().map(|r| r.case.clone()))?;
    t.push_f64("force", reports.iter().map(|r| r.force))?;
    t.push_f64("separation", reports.iter().map(|r| r.separation))?;
    t.push_f64("contact_max_deviation", reports.iter().map(|r| r.contact_max_deviation))?;
    t.push_f64("contact_rms_deviation", reports.iter().map(|r| r.contact_rms_deviation))?;
    for (w, width) in cfg.response.widths.iter().enumerate() {
        t.push_f64(format!("profile_max_deviation_w{width}"), reports.iter().map(|r| r.profile_max_deviation[w]))?;
    }
    t.push_u64("opened_both", reports.iter().map(|r| r.opened_both as u64))?;
    write_csv_atomic(&out.join("superposition.csv"), &t)?;
    files.push("superposition.csv".into());
    Ok(reports)
}

fn pile_outputs(cfg: &E3Config, plan: &Plan, references: &[ReferenceResult], out: &Path, files: &mut Vec<String>) -> Result<Vec<PileReport>> {
    let mut reports = Vec::new();
    for group in &plan.groups {
        let sites = Sites::of(group.shape);
        let axis = 0.5 * sites.width;
        let grid = measure::profile_grid(sites.width, axis, cfg.response.profile_step);
        let nw = cfg.response.widths.len();
        let mut mean = vec![vec![0.0; grid.len()]; nw];
        let mut balance = 0.0;
        let mut contacts = CsvTable::new();
        let (mut seeds, mut xs_all, mut fz_all, mut fx_all) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut floor_contacts: Vec<FloorContact> = Vec::new();
        // the coarse-grained floor stress of the verdict (SPEC §7.2.9), mean over samples
        let vw = cfg.pile.verdict_width;
        let mut judged = vec![0.0; grid.len()];
        // floor contacts of grains held by a side wall (x relative to the axis)
        let mut supported: Vec<f64> = Vec::new();
        let mut supported_ids: Vec<u32> = Vec::new();
        for &c in &group.cases {
            let r = &references[c];
            let snap = r.sim.snapshot();
            let floor: Vec<&ContactRecord<D2>> = snap.contacts.iter().filter(|k| k.j == Counterpart::Wall(slab::FLOOR)).collect();
            let index: BTreeMap<u32, usize> = snap.id.iter().enumerate().map(|(k, &id)| (id, k)).collect();
            let xs: Vec<f64> = floor.iter().map(|k| snap.pos[index[&k.i]].x + k.normal.x * k.lever_i - axis).collect();
            let fz: Vec<f64> = floor.iter().map(|k| -k.force_on_i().dot(glam::DVec2::new(0.0, -1.0))).collect();
            let fx: Vec<f64> = floor.iter().map(|k| -k.force_on_i().x).collect();
            let at_side_wall: std::collections::BTreeSet<u32> =
                snap.contacts.iter().filter(|k| matches!(k.j, Counterpart::Wall(w) if w == slab::LEFT || w == slab::RIGHT)).map(|k| k.i).collect();
            for (k, x) in floor.iter().zip(&xs) {
                if at_side_wall.contains(&k.i) {
                    supported.push(*x);
                    if group.delta == 0.0 {
                        supported_ids.push(k.i);
                    }
                }
            }
            for (m, v) in judged.iter_mut().zip(measure::profiles(&xs, &fz, &[vw], &grid).remove(0)) {
                *m += v / group.cases.len() as f64;
            }
            for (w, p) in measure::profiles(&xs, &fz, &cfg.response.widths, &grid).into_iter().enumerate() {
                for (m, v) in mean[w].iter_mut().zip(p) {
                    *m += v / group.cases.len() as f64;
                }
            }
            if group.delta == 0.0 {
                // an ordered pile is one sample (plan: δ = 0 runs once); its floor forces are
                // judged as they are (reference 0)
                let ids = floor.iter().map(|k| k.i);
                floor_contacts.extend(ids.zip(xs.iter().zip(&fz)).map(|(grain, (&x, &f))| FloorContact { grain, x, reference: 0.0, after: f, horizontal_reference: 0.0, horizontal_after: 0.0 }));
            }
            balance += r.wall_loads[0] / r.weight / group.cases.len() as f64;
            seeds.extend(std::iter::repeat_n(plan.cases[c].seed, xs.len()));
            xs_all.extend(xs);
            fz_all.extend(fz);
            fx_all.extend(fx);
            if cfg.output.plots && runs_enabled(cfg) {
                let dir = out.join("runs").join(&plan.cases[c].label);
                PackingPicture::new(&snap, &format!("Pile under gravity ({})", plan.cases[c].label))
                    .x_label("x [R̄]")
                    .y_label("z [R̄]")
                    .network(Network::Force)
                    .save(&dir, "force_network")
                    .map_err(plot_err)?;
                if let Some(f) = &r.field {
                    FieldMap::new(&format!("σ_zz under gravity, w = {} R̄", cfg.response.stress_width), (f.x0, f.dx, f.nx), (f.z0, f.dz, f.nz), &f.zz)
                        .sequential()
                        .x_label("x [R̄]")
                        .y_label("z [R̄]")
                        .colorbar_label("σ_zz [m̄g/R̄]")
                        .save(&dir, "stress_zz")
                        .map_err(plot_err)?;
                    field_npz(f, None, &dir.join("stress_field.npz"))?;
                }
                if cfg.output.vtk {
                    write_grains_vtp(&dir.join("grains.vtp"), &snap)?;
                    grainwave_io::vtk::write_contacts_vtp(&dir.join("contacts.vtp"), &snap)?;
                }
            }
        }
        contacts.push_u64("seed", seeds)?;
        contacts.push_f64("x", xs_all)?;
        contacts.push_f64("fz", fz_all)?;
        contacts.push_f64("fx", fx_all)?;
        let stem = format!("pile_floor_{}", group.label);
        write_csv_atomic(&out.join(format!("{stem}_contacts.csv")), &contacts)?;
        let mut cols = vec![("x".to_string(), grid.clone())];
        for (w, width) in cfg.response.widths.iter().enumerate() {
            cols.push((format!("sigma_zz_w{width}"), mean[w].clone()));
        }
        Series::from_columns(cols)?.write(out, &stem)?;
        files.extend([format!("{stem}_contacts.csv"), format!("{stem}.csv"), format!("{stem}.npz")]);
        let z0 = measure::zero_index(&grid);
        let cl = classify_profile(&grid, &mean[0], &PeakOptions { prominence: cfg.response.prominence, centre: 0.0 });
        if cfg.output.plots {
            let mut plot = LinePlot::new(&format!("Floor stress under a pile ({})", group.label)).x_label("x − x_axis [R̄]").y_label("σ_zz(x) [m̄g/R̄]");
            for (w, width) in cfg.response.widths.iter().enumerate() {
                plot = plot.series(&format!("w = {width} R̄"), &grid, &mean[w]);
            }
            plot.save(out, &stem).map_err(plot_err)?;
            files.extend([format!("{stem}.png"), format!("{stem}.svg")]);
        }
        // the side walls' support: the floor contacts of grains touching a side wall, and the
        // coarse-grained profile within 2w of them (where they contribute more than e^{−4} ≈ 1.8 %
        // of their own peak); the maximum is looked for between
        let half = 0.5 * sites.width;
        let inner_left = supported.iter().copied().filter(|&x| x < 0.0).fold(-half, f64::max);
        let inner_right = supported.iter().copied().filter(|&x| x > 0.0).fold(half, f64::min);
        let window = [inner_left + 2.0 * vw, inner_right - 2.0 * vw];
        let coarse = measure::axis_verdict(&grid, &judged, window);
        // raw per-contact verdict (ordered piles) without the wall-supported floor contacts, and
        // with them (as earlier versions judged)
        let interior: Vec<FloorContact> = floor_contacts.iter().copied().filter(|c| !supported_ids.contains(&c.grain)).collect();
        let raw = if group.delta == 0.0 { measure::raw_floor_verdict(&interior) } else { None };
        let raw_with_edges = if group.delta == 0.0 { measure::raw_floor_verdict(&floor_contacts) } else { None };
        let (shape, dip) = coarse.map_or((PeakShape::Irregular, f64::NAN), |v| (v.shape, v.dip));
        let mut cols = vec![("x".to_string(), grid.clone()), (format!("sigma_zz_w{vw}"), judged.clone())];
        cols.push(("in_window".to_string(), grid.iter().map(|&x| if x >= window[0] && x <= window[1] { 1.0 } else { 0.0 }).collect()));
        Series::from_columns(cols)?.write(out, &format!("{stem}_verdict"))?;
        files.extend([format!("{stem}_verdict.csv"), format!("{stem}_verdict.npz")]);
        reports.push(PileReport {
            group: group.label.clone(),
            floor_over_weight: balance,
            stress_at_axis: (0..nw).map(|w| mean[w][z0]).collect(),
            stress_max: (0..nw).map(|w| mean[w].iter().cloned().fold(f64::NEG_INFINITY, f64::max)).collect(),
            shape,
            dip,
            verdict_basis: format!("coarse-grained floor stress, w = {vw}"),
            verdict_width: vw,
            coarse,
            verdict_window: window,
            wall_supported: supported,
            raw,
            shape_raw: raw.map(|v| v.shape),
            dip_raw: raw.map_or(f64::NAN, |v| v.dip),
            raw_with_edges,
            shape_smoothed: cl.shape,
            dip_smoothed: cl.dip,
        });
    }
    Ok(reports)
}

fn lattice_outputs(cfg: &E3Config, out: &Path, files: &mut Vec<String>) -> Result<LatticeReport> {
    use grainwave_linear::lattice::SpringNetwork;
    let l = &cfg.lattice;
    let report = |h: [f64; 2], o: [f64; 2]| {
        let m = SpringNetwork::triangular(l.spacing, (h[0], h[1]), (o[0], o[1])).moduli();
        ModuliReport { a: m.a, b: m.b, c: m.c, d: m.d, r: m.r(), bonds: 3, window: [0.0; 4] }
    };
    let moduli = report(l.horizontal, l.oblique);
    let scan: Vec<(f64, f64, f64)> = l
        .tangential_ratios
        .iter()
        .map(|&x| {
            let with = report([l.horizontal[0], x * l.horizontal[0]], [l.oblique[0], x * l.oblique[0]]).r;
            let without = report([0.0, 0.0], [l.oblique[0], x * l.oblique[0]]).r;
            (x, with, without)
        })
        .collect();
    if !scan.is_empty() {
        let mut t = CsvTable::new();
        t.push_f64("tangential_ratio", scan.iter().map(|s| s.0))?;
        t.push_f64("r_with_horizontal", scan.iter().map(|s| s.1))?;
        t.push_f64("r_without_horizontal", scan.iter().map(|s| s.2))?;
        write_csv_atomic(&out.join("lattice_scan.csv"), &t)?;
        files.push("lattice_scan.csv".into());
        if cfg.output.plots {
            let x: Vec<f64> = scan.iter().map(|s| s.0).collect();
            LinePlot::new("Half-plane criterion r of a triangular spring lattice")
                .legend(LegendPosition::LowerRight)
                .x_label("k_t/k_n")
                .y_label("r = [ab − c(d+c)]/(bd)")
                .series("horizontal bonds as given", &x, &scan.iter().map(|s| s.1).collect::<Vec<_>>())
                .series("horizontal bonds open", &x, &scan.iter().map(|s| s.2).collect::<Vec<_>>())
                .dashed("r = 0", &[x[0], x[x.len() - 1]], &[0.0, 0.0])
                .save(out, "lattice_scan")
                .map_err(plot_err)?;
            files.extend(["lattice_scan.png".into(), "lattice_scan.svg".into()]);
        }
    }
    Ok(LatticeReport { verdict: if moduli.r < 0.0 { "double".into() } else { "single".into() }, moduli, scan })
}
