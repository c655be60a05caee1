//! Outputs of the `simulation` protocol.

use super::{SeriesData, SimulationState};
use grainwave_study::Result;
use grainwave_study::protocol::RunContext;
use grainwave_core::prelude::*;
use grainwave_io::vtk::{write_contacts_vtp, write_grains_vtp, PvdCollection};
use grainwave_io::plot::{LinePlot, Network, PackingPicture};
use grainwave_io::{write_grains_csv, Series};
use std::path::{Path, PathBuf};
use serde::{Deserialize, Serialize};

/// Normal load and position of one wall at the end of the run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WallReport {
    /// Wall name.
    pub name: String,
    /// Normal force the grains exert on it (outwards) [force].
    pub load: f64,
    /// Displacement along its inward normal since the start [length].
    pub displacement: f64,
}

/// The summary of a `simulation` run (`summary.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimulationReport {
    /// Protocol name.
    pub experiment: String,
    /// grainwave version.
    pub version: String,
    /// Seed.
    pub seed: u64,
    /// Units of the numbers (from the config).
    pub units: String,
    /// 2 or 3.
    pub dimension: usize,
    /// Grain kind.
    pub grain_kind: String,
    /// Number of grains.
    pub grains: usize,
    /// Steps done.
    pub steps: u64,
    /// Simulated time at the end [time].
    pub time: f64,
    /// Time step [time].
    pub dt: f64,
    /// Suggested time step [time].
    pub suggested_dt: f64,
    /// Why the run stopped.
    pub stop_reason: StopReason,
    /// Kinetic energy per grain at the end [energy].
    pub kinetic_energy_per_grain: f64,
    /// Largest grain acceleration at the end [length/time²].
    pub max_acceleration: f64,
    /// Contacts at the end (grain–grain + grain–wall).
    pub contacts: u64,
    /// Sliding contacts at the end.
    pub sliding: u64,
    /// Total weight M|g| [force].
    pub weight: f64,
    /// Sum of the wall loads opposing gravity divided by the weight (1 at static equilibrium
    /// when the walls carry all the weight); absent without gravity.
    pub support_over_weight: Option<f64>,
    /// Every wall.
    pub walls: Vec<WallReport>,
    /// Engine warnings.
    pub warnings: Vec<String>,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
}


/// Appends the current state to the series.
pub fn record_series<D: Dim>(series: &mut SeriesData, sim: &Simulation<D>, stop: &StopCriteria) {
    let p = sim.progress(stop);
    let mut row = vec![
        ("step".to_string(), sim.step as f64),
        ("time".to_string(), sim.time),
        ("kinetic_energy_per_grain".to_string(), p.kinetic_energy_per_grain),
        ("max_acceleration".to_string(), p.max_acceleration),
        ("mean_acceleration".to_string(), p.mean_acceleration),
        ("contacts".to_string(), p.contacts as f64),
        ("sliding".to_string(), p.sliding as f64),
    ];
    for w in &sim.domain.walls {
        row.push((format!("load_{}", w.name), w.normal_load()));
        row.push((format!("displacement_{}", w.name), w.displacement()));
    }
    series.push(&row);
}

/// File names of the VTK snapshot at `step`, relative to the output directory.
pub fn snapshot_files(step: u64) -> [String; 2] {
    [format!("snapshots/grains_{step:010}.vtp"), format!("snapshots/contacts_{step:010}.vtp")]
}

/// Writes VTK snapshots of the grains and of the contact network at the current step.
pub fn write_snapshot<D: Dim>(ctx: &RunContext<'_>, sim: &Simulation<D>) -> Result<()> {
    write_snapshot_in(ctx.out_dir(), sim).map(|_| ())
}

/// Writes the VTK snapshots of the current step under `dir`, as a run does into its output
/// directory ([`snapshot_files`]: `snapshots/grains_<step>.vtp` and `snapshots/contacts_<step>.vtp`,
/// each written atomically); returns their paths. The same bytes as the run's snapshot of the
/// same state: front ends (the Python module) call this.
pub fn write_snapshot_in<D: Dim>(dir: &Path, sim: &Simulation<D>) -> Result<[PathBuf; 2]> {
    let snap = sim.snapshot();
    let [g, c] = snapshot_files(sim.step).map(|f| dir.join(f));
    write_grains_vtp(&g, &snap)?;
    write_contacts_vtp(&c, &snap)?;
    Ok([g, c])
}

/// Writes the final outputs and returns the report.
pub fn write_final<D: Dim>(ctx: &mut RunContext<'_>, state: &SimulationState, sim: &Simulation<D>) -> Result<SimulationReport> {
    let mut files =
        vec!["config.resolved.toml".to_string(), "summary.json".into(), "series.npz".into(), "series.csv".into(), "grains.csv".into()];
    let mut series = Series::from_columns(state.series.names.iter().cloned().zip(state.series.columns.iter().cloned()))?;
    // step numbers and numbers of contacts as integers (`500`, int64), not `500.0`
    let counts: Vec<&str> = ["step", "contacts", "sliding"].into_iter().filter(|c| state.series.column(c).is_some()).collect();
    series.mark_counts(&counts)?;
    series.write(ctx.out_dir(), "series")?;
    let snap = sim.snapshot();
    write_grains_csv(&ctx.path("grains.csv"), &snap)?;
    if state.config.output.vtk {
        // the final state is always part of the collections
        let mut snapshots = state.snapshots.clone();
        if snapshots.last().map(|s| s.1) != Some(sim.step) {
            write_snapshot(ctx, sim)?;
            snapshots.push((sim.time, sim.step));
        }
        let (mut grains_pvd, mut contacts_pvd) = (PvdCollection::new(), PvdCollection::new());
        for (time, step) in &snapshots {
            let [g, c] = snapshot_files(*step);
            grains_pvd.push(*time, g.clone())?;
            contacts_pvd.push(*time, c.clone())?;
            files.push(g);
            files.push(c);
        }
        grains_pvd.write(&ctx.path("grains.pvd"))?;
        contacts_pvd.write(&ctx.path("contacts.pvd"))?;
        files.push("grains.pvd".into());
        files.push("contacts.pvd".into());
    }
    files.push(grainwave_study::protocol::CHECKPOINT_FILE.into());
    files.push(grainwave_study::protocol::LOG_FILE.into());

    if state.config.output.plots {
        files.extend(make_plots(ctx.out_dir(), &series, state.picture().as_ref())?);
    }

    let p = sim.progress(&state.config.stop);
    let g = sim.gravity;
    let g_norm = g.norm();
    let weight = sim.grains.total_mass() * g_norm;
    let support = if g_norm > 0.0 && !sim.domain.walls.is_empty() {
        let up = g * (-1.0 / g_norm);
        Some(sim.domain.walls.iter().map(|w| w.normal_load() * w.normal.dot(up)).sum::<f64>() / weight)
    } else {
        None
    };
    let report = SimulationReport {
        experiment: "simulation".into(),
        version: grainwave_core::VERSION.into(),
        seed: state.config.seed,
        units: state.config.units.clone(),
        dimension: D::D,
        grain_kind: sim.grains.kind.name().into(),
        grains: sim.len(),
        steps: sim.step,
        time: sim.time,
        dt: sim.dt,
        suggested_dt: sim.suggested_dt,
        stop_reason: state.outcome.unwrap_or(StopReason::Interrupted),
        kinetic_energy_per_grain: p.kinetic_energy_per_grain,
        max_acceleration: p.max_acceleration,
        contacts: p.contacts,
        sliding: p.sliding,
        weight,
        support_over_weight: support,
        walls: sim
            .domain
            .walls
            .iter()
            .map(|w| WallReport { name: w.name.clone(), load: w.normal_load(), displacement: w.displacement() })
            .collect(),
        warnings: sim.warnings.clone(),
        files,
    };
    grainwave_study::outputs::write_summary(ctx.out_dir(), &report)?;
    Ok(report)
}

/// Draws the plots of a `simulation` run into `dir/plots/` from its series and, for 2D runs, its
/// final snapshot: kinetic energy and accelerations vs time (log scale), wall loads vs time, and
/// a picture of the packing with its force network. Returns the files, relative to `dir`.
pub fn make_plots(dir: &Path, series: &Series, picture: Option<&Snapshot<D2>>) -> Result<Vec<String>> {
    let plots = dir.join("plots");
    let mut files = Vec::new();
    let mut push = |stem: &str| {
        files.push(format!("plots/{stem}.png"));
        files.push(format!("plots/{stem}.svg"));
    };
    let time = series.column("time").unwrap_or(&[]);
    if time.len() >= 2 {
        let positive = |name: &str| -> (Vec<f64>, Vec<f64>) {
            let y = series.column(name).unwrap_or(&[]);
            time.iter().zip(y).filter(|(_, v)| **v > 0.0 && v.is_finite()).map(|(t, v)| (*t, *v)).unzip()
        };
        let (t_ke, ke) = positive("kinetic_energy_per_grain");
        let (t_a, acc) = positive("max_acceleration");
        if t_ke.len() >= 2 || t_a.len() >= 2 {
            LinePlot::new("Relaxation")
                .x_label("time")
                .y_label("kinetic energy per grain, max acceleration")
                .log_y()
                .series("kinetic energy per grain", &t_ke, &ke)
                .series("max acceleration", &t_a, &acc)
                .save(&plots, "energy")?;
            push("energy");
        }
        let loads: Vec<&str> = series.names().iter().map(String::as_str).filter(|n| n.starts_with("load_")).collect();
        if !loads.is_empty() {
            let mut plot = LinePlot::new("Wall loads").x_label("time").y_label("normal load [force]");
            for name in &loads {
                plot = plot.series(name.trim_start_matches("load_"), time, series.column(name).unwrap_or(&[]));
            }
            plot.save(&plots, "wall_loads")?;
            push("wall_loads");
        }
    }
    if let Some(snap) = picture.filter(|s| !s.is_empty()) {
        PackingPicture::new(snap, "Final state: force network").network(Network::Force).save(&plots, "force_network")?;
        push("force_network");
    }
    Ok(files)
}
