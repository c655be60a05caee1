//! The work of an `e3` run: parameter groups, disorder realizations (cases, one reference state
//! each) and response runs (one force — or a pair of forces — applied to a case's reference).

use super::config::{E3Config, Mode};
use super::slab::Shape;
use serde::{Deserialize, Serialize};

/// One parameter set; its cases differ only by the seed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Group {
    /// Index in the plan.
    pub index: usize,
    /// Shape of the packing.
    pub shape: Shape,
    /// Polydispersity δ.
    pub delta: f64,
    /// Grain–grain friction μ.
    pub friction: f64,
    /// k_T/k_N.
    pub ratio: f64,
    /// Label (file-name safe).
    pub label: String,
    /// Its cases.
    pub cases: Vec<usize>,
}

/// One packing: a group and a seed; one reference state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Case {
    /// Index in the plan.
    pub index: usize,
    /// Its group.
    pub group: usize,
    /// Sample number (0-based).
    pub sample: usize,
    /// Seed of the radii.
    pub seed: u64,
    /// Label (file-name safe), also the directory of its files.
    pub label: String,
}

/// Which force(s) a run applies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variant {
    /// One force (modes `slab`, `sweep`).
    Single,
    /// The left force of a superposition.
    Left,
    /// The right force of a superposition.
    Right,
    /// Both forces together.
    Both,
}

impl Variant {
    /// Suffix of labels.
    pub fn suffix(self) -> &'static str {
        match self {
            Variant::Single => "",
            Variant::Left => "_left",
            Variant::Right => "_right",
            Variant::Both => "_both",
        }
    }
    /// Name.
    pub fn name(self) -> &'static str {
        match self {
            Variant::Single => "single",
            Variant::Left => "left",
            Variant::Right => "right",
            Variant::Both => "both",
        }
    }
}

/// One response run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    /// Index in the plan.
    pub index: usize,
    /// The case whose reference state it loads.
    pub case: usize,
    /// Index into `load.forces`.
    pub force_index: usize,
    /// F_ext [m̄g].
    pub force: f64,
    /// Which force(s).
    pub variant: Variant,
    /// Label within the case (file-name safe).
    pub label: String,
}

/// Everything an `e3` run computes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// Parameter sets.
    pub groups: Vec<Group>,
    /// Packings.
    pub cases: Vec<Case>,
    /// Response runs.
    pub runs: Vec<RunSpec>,
}

fn or_single<T: Clone>(list: &[T], single: T) -> Vec<T> {
    if list.is_empty() {
        vec![single]
    } else {
        list.to_vec()
    }
}

impl Plan {
    /// Checks the structure of a plan read from a checkpoint (a crafted or damaged file must be
    /// refused before anything indexes or allocates by it): every index in order and in range,
    /// each group's grain count within the kernel's hard bound. Returns what is wrong.
    pub fn check_carried(&self) -> Result<(), String> {
        use grainwave_study::limits::{HARD_MAX_GRAINS, MAX_UNITS};
        if (self.cases.len() + self.runs.len()) as f64 > MAX_UNITS {
            return Err(format!("{} cases and {} runs (allowed: at most {MAX_UNITS} units)", self.cases.len(), self.runs.len()));
        }
        for (k, g) in self.groups.iter().enumerate() {
            let (a, b) = match g.shape {
                Shape::Slab { layers, grains_per_layer, .. } => (layers, grains_per_layer),
                Shape::Pile { layers, top_grains } => (layers, top_grains + layers),
            };
            if g.index != k || g.cases.iter().any(|&c| c >= self.cases.len()) || a as f64 * b as f64 > HARD_MAX_GRAINS {
                return Err(format!("group {k} (index {}, cases {:?}, {a} × {b} grains) does not fit the plan", g.index, g.cases));
            }
        }
        for (k, c) in self.cases.iter().enumerate() {
            if c.index != k || c.group >= self.groups.len() {
                return Err(format!("case {k} (index {}, group {}) does not fit the plan", c.index, c.group));
            }
        }
        for (k, r) in self.runs.iter().enumerate() {
            if r.index != k || r.case >= self.cases.len() {
                return Err(format!("run {k} (index {}, case {}) does not fit the plan", r.index, r.case));
            }
        }
        Ok(())
    }

    /// The plan of a (validated) config.
    pub fn new(cfg: &E3Config) -> Plan {
        let mut plan = Plan { groups: Vec::new(), cases: Vec::new(), runs: Vec::new() };
        if cfg.mode == Mode::LatticeElasticity {
            return plan;
        }
        let slab = |layers: usize, m: usize| Shape::Slab { layers, grains_per_layer: m, rows: cfg.slab.rows };
        let (sizes, deltas, frictions, ratios) = if cfg.mode == Mode::Sweep {
            (
                or_single(&cfg.sweep.sizes, [cfg.slab.layers, cfg.slab.grains_per_layer]),
                or_single(&cfg.sweep.deltas, cfg.slab.delta),
                or_single(&cfg.sweep.frictions, cfg.material.friction),
                or_single(&cfg.sweep.stiffness_ratios, cfg.material.tangential_stiffness_ratio),
            )
        } else {
            (
                vec![[cfg.slab.layers, cfg.slab.grains_per_layer]],
                vec![cfg.slab.delta],
                vec![cfg.material.friction],
                vec![cfg.material.tangential_stiffness_ratio],
            )
        };
        let mut shapes: Vec<Shape> = sizes.iter().map(|s| slab(s[0], s[1])).collect();
        let mut deltas = deltas;
        if cfg.mode == Mode::Pile {
            shapes = vec![Shape::Pile { layers: cfg.pile.layers, top_grains: cfg.pile.top_grains }];
            deltas = vec![cfg.pile.delta];
        }
        for shape in &shapes {
            for &delta in &deltas {
                for &friction in &frictions {
                    for &ratio in &ratios {
                        let shape_label = match *shape {
                            Shape::Slab { layers, grains_per_layer, .. } => format!("L{layers}xM{grains_per_layer}"),
                            Shape::Pile { layers, top_grains } => format!("pile{layers}_top{top_grains}"),
                        };
                        let label = format!("{shape_label}_d{delta}_mu{friction}_kt{ratio}");
                        let index = plan.groups.len();
                        let samples = if delta == 0.0 { 1 } else { cfg.samples };
                        let mut cases = Vec::new();
                        for sample in 0..samples {
                            let seed = cfg.seed + sample as u64;
                            let c = plan.cases.len();
                            plan.cases.push(Case { index: c, group: index, sample, seed, label: format!("{label}_s{seed}") });
                            cases.push(c);
                        }
                        plan.groups.push(Group { index, shape: *shape, delta, friction, ratio, label, cases });
                    }
                }
            }
        }
        if cfg.mode == Mode::Pile {
            return plan;
        }
        let variants: &[Variant] = if cfg.mode == Mode::Superposition { &[Variant::Left, Variant::Right, Variant::Both] } else { &[Variant::Single] };
        for c in 0..plan.cases.len() {
            for (fi, &force) in cfg.load.forces.iter().enumerate() {
                for &variant in variants {
                    let index = plan.runs.len();
                    plan.runs.push(RunSpec { index, case: c, force_index: fi, force, variant, label: format!("F{force}{}", variant.suffix()) });
                }
            }
        }
        plan
    }

    /// Runs of case `c`.
    pub fn runs_of(&self, c: usize) -> impl Iterator<Item = &RunSpec> {
        self.runs.iter().filter(move |r| r.case == c)
    }
}
