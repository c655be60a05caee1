//! What is measured on a reference state and on a response (SPEC §7.2.4, §7.2.5, §7.3).
//!
//! * **Floor forces**: for every floor contact, the force the grain exerts on the floor, vertical
//!   (F_z, positive pushing down) and horizontal (F_x); contacts are matched by grain id, a contact
//!   missing on one side counts as zero there. The response of a contact is ΔF_z = F_z − F_z^ref.
//! * **Smoothed floor profile**: p_w(x) = Σ_c ΔF_z,c (1/(w√π)) e^{−((x − x_c)/w)²}, x measured from
//!   the loaded grain (the midpoint of the two in a superposition), on a grid of `profile_step`
//!   containing x = 0; ∫ p_w dx = Σ_c ΔF_z,c, which equals the vertical component of F_ext when
//!   the side walls carry nothing of it. The **response at x = 0** is p_w(0)/F_ext.
//! * **Coarse-grained stress** σ_αβ(x, z) (Goldhirsch, w = `stress_width`) of the final state minus
//!   that of the reference, on a grid of `stress_step` over the box (compression positive).
//! * **Contact network**: contacts opened, created, sliding (friction fully mobilized at rest:
//!   |F_t| ≥ (1 − 10⁻⁶) μ F_n, `grainwave_analysis::network::mark_mobilized`); depth and width of the region of
//!   opened contacts connected to the load (grainwave-analysis `network`: seeded within
//!   [`REGION_SEED`] of the loaded grain, linked within [`REGION_LINK`]).
//! * **First opening, linear estimate**: in a run where no contact opened or started sliding the
//!   response is linear in F_ext, so a contact whose normal force drops by ΔF_n < 0 would open at
//!   F_ext F_n^ref/(−ΔF_n); the smallest such value over all contacts.
//! * **Affine moduli** (a, b, c, d) and r of the measured contact network (grainwave-linear
//!   `measured_network`) in the bulk window (the box minus `boundary_layer` along the walls, the
//!   floor and the free surface) and in the load window (the bulk window within half the slab's
//!   height of the load).

use super::config::E3Config;
use super::slab::{FLOOR, LEFT, RIGHT};
use grainwave_analysis::coarse_grain::{coarse_grain, smooth_1d, CoarseGrainOptions, Grid};
use grainwave_analysis::network::{compare_networks, mark_mobilized, ContactKey, NetworkChanges, NetworkCounts, RegionSize, MOBILIZED_TOLERANCE};
use grainwave_analysis::peaks::{classify_profile, PeakClassification, PeakOptions};
use grainwave_core::prelude::*;
use grainwave_linear::measured_network::{spring_network, NetworkWindow};
use serde::{Deserialize, Serialize};

/// Opened contacts within this distance of the load start the opened region [R̄].
pub const REGION_SEED: f64 = 3.0;
/// Opened contacts within this distance of a member join the opened region [R̄].
pub const REGION_LINK: f64 = 2.5;

/// Force of one grain on the floor.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FloorContact {
    /// Grain id.
    pub grain: u32,
    /// Contact point x, relative to the profile origin [R̄].
    pub x: f64,
    /// Vertical force on the floor in the reference state (0 if not in contact) [m̄g].
    pub reference: f64,
    /// Vertical force on the floor after the load [m̄g].
    pub after: f64,
    /// Horizontal force on the floor, reference [m̄g].
    pub horizontal_reference: f64,
    /// Horizontal force on the floor, after [m̄g].
    pub horizontal_after: f64,
}

/// A scalar field on a regular (x, z) grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FieldData {
    /// x of the first column [R̄].
    pub x0: f64,
    /// z of the first row [R̄].
    pub z0: f64,
    /// Spacing along x [R̄].
    pub dx: f64,
    /// Spacing along z [R̄].
    pub dz: f64,
    /// Columns.
    pub nx: usize,
    /// Rows.
    pub nz: usize,
    /// σ_xx, row by row (x fastest) [m̄g/R̄].
    pub xx: Vec<f64>,
    /// σ_zz [m̄g/R̄].
    pub zz: Vec<f64>,
    /// σ_xz [m̄g/R̄].
    pub xz: Vec<f64>,
}

impl FieldData {
    /// `self − other`.
    pub fn minus(&self, other: &FieldData) -> FieldData {
        let d = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x - y).collect();
        FieldData { xx: d(&self.xx, &other.xx), zz: d(&self.zz, &other.zz), xz: d(&self.xz, &other.xz), ..self.clone() }
    }
    /// x coordinates of the columns.
    pub fn xs(&self) -> Vec<f64> {
        (0..self.nx).map(|i| self.x0 + i as f64 * self.dx).collect()
    }
    /// z coordinates of the rows.
    pub fn zs(&self) -> Vec<f64> {
        (0..self.nz).map(|k| self.z0 + k as f64 * self.dz).collect()
    }
}

/// Affine moduli of a measured network.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModuliReport {
    /// a = C_xxxx [m̄g/R̄].
    pub a: f64,
    /// b = C_zzzz [m̄g/R̄].
    pub b: f64,
    /// c = C_xxzz [m̄g/R̄].
    pub c: f64,
    /// d = 2 C_xzxz, the half-plane criterion's convention (SPEC §7.3) [m̄g/R̄].
    pub d: f64,
    /// r = [ab − c(d + c)]/(bd); < 0: double-peaked half-plane response.
    pub r: f64,
    /// Bonds in the window.
    pub bonds: usize,
    /// Window [x_min, z_min, x_max, z_max] [R̄].
    pub window: [f64; 4],
}

/// Single/double verdict of an ordered lattice on the raw per-contact floor forces (SPEC §7.2.5):
/// no smoothing, a central dip of any depth counts.
///
/// With ΔF_z,k the floor-force changes of the floor contacts sorted by x (relative to the load),
/// p₀ that of the contact under the load (see [`raw_floor_verdict`] for a load between two floor
/// contacts), p_L and p_R the largest on its left and on its right: **double** when p₀ < min(p_L, p_R) (the centre is below a higher contact
/// on each side), **single** when p₀ ≥ max(p_L, p_R) (the centre is the maximum), otherwise
/// **irregular** (higher on one side only, e.g. an inclined force). The dip depth
/// 1 − p₀/min(p_L, p_R) is reported signed: > 0 is the depth of the central dip, < 0 says by how
/// much the centre exceeds the lower of the two side maxima.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RawVerdict {
    /// The verdict.
    pub shape: grainwave_analysis::peaks::PeakShape,
    /// 1 − p₀/min(p_L, p_R) (signed; NaN when min(p_L, p_R) ≤ 0).
    pub dip: f64,
    /// x of the central contact [R̄].
    pub centre_x: f64,
    /// ΔF_z of the central contact [m̄g].
    pub centre: f64,
    /// (x, ΔF_z) of the largest change left of the centre [R̄, m̄g].
    pub left: [f64; 2],
    /// (x, ΔF_z) of the largest change right of the centre [R̄, m̄g].
    pub right: [f64; 2],
}

/// The raw-force verdict of `floor` (see [`RawVerdict`]); None without a contact on each side of
/// the centre.
///
/// The centre is the floor contact nearest x = 0 — or, when the load stands between two floor
/// contacts (slabs with an even number of rows: the bottom row is shifted by R̄ from the top row),
/// both contacts within 0.5 R̄ of that distance, p₀ being the larger of them; "left" and "right"
/// are the contacts beyond the central ones.
pub fn raw_floor_verdict(floor: &[FloorContact]) -> Option<RawVerdict> {
    let mut pts: Vec<(f64, f64)> = floor.iter().map(|c| (c.x, c.after - c.reference)).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let nearest = pts.iter().map(|p| p.0.abs()).fold(f64::INFINITY, f64::min);
    let central: Vec<usize> = (0..pts.len()).filter(|&k| pts[k].0.abs() <= nearest + 0.5).collect();
    let (&first, &last) = (central.first()?, central.last()?);
    let c = central.iter().copied().max_by(|&a, &b| pts[a].1.total_cmp(&pts[b].1))?;
    let best = |r: &[(f64, f64)]| r.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1));
    let (left, right) = (best(&pts[..first])?, best(&pts[last + 1..])?);
    Some(verdict_on_axis(pts[c], left, right))
}

/// The verdict from the value on the axis `centre` = (x, p₀) and the largest values `left` and
/// `right` on either side, each (x, value): **double** when p₀ < min(p_L, p_R), **single** when
/// p₀ ≥ max(p_L, p_R), otherwise irregular; dip 1 − p₀/min(p_L, p_R) (NaN when that minimum is
/// not positive).
fn verdict_on_axis(centre: (f64, f64), left: (f64, f64), right: (f64, f64)) -> RawVerdict {
    use grainwave_analysis::peaks::PeakShape;
    let p0 = centre.1;
    let low = left.1.min(right.1);
    let shape = if p0 < low {
        PeakShape::Double
    } else if p0 >= left.1.max(right.1) {
        PeakShape::Single
    } else {
        PeakShape::Irregular
    };
    let dip = if low > 0.0 { 1.0 - p0 / low } else { f64::NAN };
    RawVerdict { shape, dip, centre_x: centre.0, centre: p0, left: [left.0, left.1], right: [right.0, right.1] }
}

/// Contacts whose mirror images lie within this distance of a floor contact pair with it [R̄]:
/// a quarter of the floor-contact spacing 2R̄ of the lattice, far above the displacements of a
/// relaxed ordered slab (≲ 1e-2 R̄) and of δ = 0.01 radii, far below the spacing.
pub const MIRROR_TOLERANCE: f64 = 0.5;

/// Defaults of the **asymmetric** flag (the config's, where the keys are defined).
pub use super::config::{ASYMMETRY_FACTOR, ASYMMETRY_THRESHOLD};

/// The A_s above which a response is reported asymmetric: `threshold`, and under a vertical load
/// without torque also `factor` times the small-force value `small` (when known and finite).
pub fn asymmetry_limit(threshold: f64, factor: f64, vertical: bool, small: Option<f64>) -> f64 {
    match small {
        Some(s) if vertical && s.is_finite() => threshold.max(factor * s),
        _ => threshold,
    }
}

/// Mirror symmetry of a floor response about the load (SPEC §7.2.5).
///
/// The **antisymmetric fraction** A_s = Σ_c |ΔF(x_c) − ΔF(−x_c)| / Σ_c |ΔF(x_c) + ΔF(−x_c)|, the
/// sums over the floor contacts c that have a mirror partner: the contact nearest −x_c, accepted
/// when within [`MIRROR_TOLERANCE`] of −x_c (x measured from the loaded grain's reference
/// position; a contact within MIRROR_TOLERANCE/2 of the axis is its own partner and adds 0 above,
/// 2|ΔF| below). Contacts without a partner (a floor contact at a side wall whose image lies
/// beyond the other wall) are counted in `unpaired` and left out of both sums. A_s = 0 for a
/// mirror-symmetric response, 1 for a response on one side only (every ΔF(−x) = 0 where
/// ΔF(x) ≠ 0), and unbounded (∞ when the denominator vanishes) for an antisymmetric one
/// (ΔF(−x) = −ΔF(x)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Symmetry {
    /// A_s.
    pub antisymmetric_fraction: f64,
    /// Contacts with a mirror partner.
    pub paired: usize,
    /// Contacts without one.
    pub unpaired: usize,
    /// (x, ΔF_z) of the contact on the axis (|x| ≤ MIRROR_TOLERANCE), if any [R̄, m̄g].
    pub centre: Option<[f64; 2]>,
    /// (x, ΔF_z) of the nearest contact left of the axis (x < −MIRROR_TOLERANCE/2 … the first
    /// beyond the centre) [R̄, m̄g].
    pub left: Option<[f64; 2]>,
    /// (x, ΔF_z) of the nearest contact right of the axis [R̄, m̄g].
    pub right: Option<[f64; 2]>,
}

/// The mirror symmetry of the floor response `points` = (x, ΔF_z), x from the load (see
/// [`Symmetry`]); None without any paired contact.
pub fn floor_symmetry(points: &[(f64, f64)]) -> Option<Symmetry> {
    let (mut num, mut den, mut paired) = (0.0, 0.0, 0usize);
    for &(x, f) in points {
        let partner = points.iter().min_by(|a, b| (a.0 + x).abs().total_cmp(&(b.0 + x).abs()))?;
        if (partner.0 + x).abs() <= MIRROR_TOLERANCE {
            num += (f - partner.1).abs();
            den += (f + partner.1).abs();
            paired += 1;
        }
    }
    if paired == 0 {
        return None;
    }
    let half = 0.5 * MIRROR_TOLERANCE;
    let centre = points.iter().filter(|p| p.0.abs() <= half).min_by(|a, b| a.0.abs().total_cmp(&b.0.abs())).map(|p| [p.0, p.1]);
    let left = points.iter().filter(|p| p.0 < -half).max_by(|a, b| a.0.total_cmp(&b.0)).map(|p| [p.0, p.1]);
    let right = points.iter().filter(|p| p.0 > half).min_by(|a, b| a.0.total_cmp(&b.0)).map(|p| [p.0, p.1]);
    let antisymmetric_fraction = if den > 0.0 { num / den } else if num > 0.0 { f64::INFINITY } else { 0.0 };
    Some(Symmetry { antisymmetric_fraction, paired, unpaired: points.len() - paired, centre, left, right })
}

/// Half-angle of the first-opening region: the lattice directions through the loaded grain, 30°
/// from the vertical (SPEC §7.2.5).
pub const CONE_HALF_ANGLE_DEG: f64 = 30.0;
/// Margin of the first-opening region beyond those directions, measured horizontally: one grain
/// (the lattice spacing 2R̄) [R̄].
pub const CONE_MARGIN: f64 = 2.0;
/// Rounding allowance of the region's edges [R̄]. On the triangular lattice of spacing 2R̄ the
/// contact points below a top-row grain lie at |Δx| − Δz tan 30° ∈ {…, 1, 2, 3, …} R̄ and at heights
/// Δz ∈ (√3/2) ℕ R̄, so an allowance of half a radius puts each edge halfway between two rows of
/// contact positions: the contacts on the lattice line one grain outside (|Δx| − Δz tan 30° = 2)
/// and the loaded grain's own horizontal contacts (Δz = 0) count, the next ones (3) do not.
pub const CONE_ALLOWANCE: f64 = 0.5;

/// Whether a contact point at (Δx, Δz) from the loaded grain's centre (Δz > 0 below it) lies in
/// the first-opening region of SPEC §7.2.5: Δz ≥ −[`CONE_ALLOWANCE`] and
/// |Δx| ≤ Δz tan 30° + [`CONE_MARGIN`] + [`CONE_ALLOWANCE`].
pub fn in_opening_cone(dx: f64, dz: f64) -> bool {
    dz >= -CONE_ALLOWANCE && dx.abs() <= dz.max(0.0) * CONE_HALF_ANGLE_DEG.to_radians().tan() + CONE_MARGIN + CONE_ALLOWANCE
}

/// Grain–grain contacts opened in the first-opening region below the load (SPEC §7.2.5), whether
/// or not connected to the loaded grain: their number, the depth below the load of the deepest and
/// of the shallowest [R̄], and the horizontal extent of their contact points [R̄].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ConeOpening {
    /// Opened grain–grain contacts in the region.
    pub count: usize,
    /// Largest depth below the load of one of them (0 when none) [R̄].
    pub depth: f64,
    /// Smallest depth below the load of one of them (0 when none) [R̄].
    pub shallowest: f64,
    /// Horizontal extent (max − min) of their contact points (0 when fewer than two) [R̄].
    pub width: f64,
}

/// The opened grain–grain contacts of `changes` in the first-opening region of the load at
/// `load` = (x, z) (contact points of the reference state).
pub fn cone_opening(changes: &NetworkChanges<D2>, load: [f64; 2]) -> ConeOpening {
    let mut r = ConeOpening::default();
    let (mut lo, mut hi, mut shallow) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY);
    for c in changes.contacts.iter().filter(|c| c.opened() && matches!(c.key, ContactKey::Pair(..))) {
        let p = c.point();
        let (dx, dz) = (p.x - load[0], load[1] - p.y);
        if in_opening_cone(dx, dz) {
            r.count += 1;
            r.depth = r.depth.max(dz);
            shallow = shallow.min(dz);
            lo = lo.min(p.x);
            hi = hi.max(p.x);
        }
    }
    if r.count > 0 {
        r.shallowest = shallow;
    }
    if r.count >= 2 {
        r.width = hi - lo;
    }
    r
}

/// The verdict of a smoothed profile on its axis (the pile rule of SPEC §7.2.9): p₀ = `values` at
/// x = 0 (the grid point nearest it), p_L and p_R the largest values at x < 0 and x > 0 within
/// `window` = [x_min, x_max] (the profile away from the side walls' support); **double** (a dip
/// on the axis) when p₀ < min(p_L, p_R), **single** when p₀ ≥ max(p_L, p_R), otherwise
/// irregular; dip 1 − p₀/min(p_L, p_R), signed as in [`RawVerdict`]. None when a side of the
/// window holds no grid point.
pub fn axis_verdict(grid: &[f64], values: &[f64], window: [f64; 2]) -> Option<RawVerdict> {
    let z = zero_index(grid);
    let best = |pred: &dyn Fn(f64) -> bool| {
        grid.iter().zip(values).filter(|(x, _)| pred(**x) && **x >= window[0] && **x <= window[1]).map(|(x, v)| (*x, *v)).max_by(|a, b| a.1.total_cmp(&b.1))
    };
    let left = best(&|x| x < grid[z])?;
    let right = best(&|x| x > grid[z])?;
    Some(verdict_on_axis((grid[z], values[z]), left, right))
}

/// The force difference of one contact (superposition comparisons).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContactDelta {
    /// The contact.
    pub key: ContactKey,
    /// Force difference on the key's first grain [m̄g].
    pub df: [f64; 2],
}

/// Everything measured on one response run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    /// Index of the run in the plan.
    pub run: usize,
    /// F_ext [m̄g].
    pub force: f64,
    /// Loaded grains (id, reference x, reference z).
    pub loads: Vec<(u32, f64, f64)>,
    /// x of the profile origin (the load, or the midpoint of the loads) [R̄].
    pub origin: f64,
    /// How the relaxation ended.
    pub outcome: super::relax::RelaxOutcome,
    /// Floor contacts.
    pub floor: Vec<FloorContact>,
    /// Grid of the smoothed profiles, relative to the origin [R̄].
    pub grid: Vec<f64>,
    /// Smoothed profiles of ΔF_z, one per width [m̄g/R̄].
    pub profiles: Vec<Vec<f64>>,
    /// p_w(0)/F_ext per width [1/R̄].
    pub response_at_zero: Vec<f64>,
    /// Σ ΔF_z over floor contacts [m̄g].
    pub floor_change: f64,
    /// Vertical component of the applied force(s) [m̄g].
    pub vertical_load: f64,
    /// Change of the normal loads of the left and right walls [m̄g].
    pub side_wall_change: [f64; 2],
    /// Contact counts.
    pub counts: NetworkCounts,
    /// Region of opened contacts connected to the load (grown from the loaded grain).
    pub region: RegionSize,
    /// Grain–grain contacts opened in the first-opening region below the load (SPEC §7.2.5; the
    /// cone of the two lattice directions through the load, one grain of margin), connected to the
    /// load or not.
    #[serde(default)]
    pub cone: ConeOpening,
    /// Mirror symmetry of the floor response about the origin (SPEC §7.2.5).
    #[serde(default)]
    pub symmetry: Option<Symmetry>,
    /// The run stayed linear: no contact opened, none was created, none started sliding.
    pub linear: bool,
    /// Linear estimate of the force at which the first contact opens [m̄g].
    pub first_opening_estimate: Option<f64>,
    /// The contact whose opening that is.
    pub first_opening_contact: Option<ContactKey>,
    /// Classifier verdict on the profile of the classifier width.
    pub classification: PeakClassification,
    /// Verdict on the raw per-contact floor forces (the verdict of ordered lattices).
    #[serde(default)]
    pub raw: Option<RawVerdict>,
    /// Moduli of the final network, bulk window.
    pub moduli_bulk: ModuliReport,
    /// Moduli of the final network, load window.
    pub moduli_load: ModuliReport,
    /// Coarse-grained stress change (when computed).
    pub field: Option<FieldData>,
    /// Per-contact force differences (superposition runs).
    pub contacts: Option<Vec<ContactDelta>>,
}

/// Floor contacts of two snapshots (reference, after), x relative to `origin`.
pub fn floor_contacts(changes: &NetworkChanges<D2>, origin: f64) -> Vec<FloorContact> {
    changes
        .contacts
        .iter()
        .filter_map(|c| match c.key {
            ContactKey::Wall(grain, w) if w == FLOOR => {
                // force on the grain from the floor; the grain pushes the floor with the opposite
                let v = |s: &Option<grainwave_analysis::network::ContactSide<D2>>| s.map_or((0.0, 0.0), |s| (s.force.y, -s.force.x));
                let (fr, hr) = v(&c.before);
                let (fa, ha) = v(&c.after);
                Some(FloorContact { grain, x: c.point().x - origin, reference: fr, after: fa, horizontal_reference: hr, horizontal_after: ha })
            }
            _ => None,
        })
        .collect()
}

/// The x grid of the profiles: multiples of `step` between the side walls, relative to `origin`.
pub fn profile_grid(width: f64, origin: f64, step: f64) -> Vec<f64> {
    let lo = ((0.0 - origin) / step).ceil() as i64;
    let hi = ((width - origin) / step).floor() as i64;
    (lo..=hi).map(|k| k as f64 * step).collect()
}

/// Index of x = 0 in a grid from [`profile_grid`].
pub fn zero_index(grid: &[f64]) -> usize {
    grid.iter().position(|&x| x == 0.0).unwrap_or_else(|| grid.iter().enumerate().min_by(|a, b| a.1.abs().total_cmp(&b.1.abs())).map(|(k, _)| k).unwrap_or(0))
}

/// Smoothed profiles of `values` at `x` for every width.
pub fn profiles(x: &[f64], values: &[f64], widths: &[f64], grid: &[f64]) -> Vec<Vec<f64>> {
    widths.iter().map(|&w| smooth_1d(x, values, w, grid)).collect()
}

/// The grid of the stress fields: the box [0, width] × [0, top].
pub fn field_grid(width: f64, top: f64, step: f64) -> Grid<D2> {
    Grid::<D2>::covering(glam::DVec2::new(0.0, 0.0), glam::DVec2::new(width, top), step)
}

impl FieldData {
    /// The grid of this field.
    pub fn grid(&self) -> Grid<D2> {
        Grid { origin: glam::DVec2::new(self.x0, self.z0), spacing: glam::DVec2::new(self.dx, self.dz), counts: [self.nx, self.nz, 1] }
    }
}

/// The coarse-grained stress of `snapshot` on `grid`.
pub fn stress_field(snapshot: &Snapshot<D2>, cfg: &E3Config, grid: &Grid<D2>) -> FieldData {
    let grid = grid.clone();
    let options = CoarseGrainOptions { width: cfg.response.stress_width, ..Default::default() };
    let f = coarse_grain(snapshot, &grid, &options);
    FieldData {
        x0: grid.origin.x,
        z0: grid.origin.y,
        dx: grid.spacing.x,
        dz: grid.spacing.y,
        nx: grid.counts[0],
        nz: grid.counts[1],
        xx: f.component(0, 0),
        zz: f.component(1, 1),
        xz: f.component(0, 1),
    }
}

/// Affine moduli of the grain–grain network of `snapshot` in `window`.
pub fn moduli(snapshot: &Snapshot<D2>, window: [f64; 4]) -> ModuliReport {
    let w = NetworkWindow { min: [window[0], window[1]], max: [window[2], window[3]] };
    if w.area() <= 0.0 {
        return ModuliReport { window, ..Default::default() };
    }
    let net = spring_network(snapshot, &w, false);
    let m = net.moduli();
    ModuliReport { a: m.a, b: m.b, c: m.c, d: m.d, r: m.r(), bonds: net.bonds.len(), window }
}

/// The bulk window of a box of `width` whose grains reach height `top`.
pub fn bulk_window(width: f64, top: f64, layer: f64) -> [f64; 4] {
    [layer, layer, width - layer, top - layer]
}

/// The load window: the bulk window within half the height of x = `origin`.
pub fn load_window(width: f64, top: f64, layer: f64, origin: f64) -> [f64; 4] {
    let half = 0.5 * top;
    [(origin - half).max(layer), layer, (origin + half).min(width - layer), top - layer]
}

/// Height of the highest grain top of a snapshot.
pub fn top_of(snapshot: &Snapshot<D2>) -> f64 {
    snapshot.pos.iter().zip(&snapshot.radius).map(|(p, r)| p.y + r).fold(0.0, f64::max)
}

/// Normal load of wall `w` in a snapshot.
pub fn wall_load(snapshot: &Snapshot<D2>, w: u32) -> f64 {
    snapshot.wall_load(w)
}

/// Inputs of [`measure_run`] besides the snapshots.
pub struct RunInputs<'a> {
    /// The config.
    pub cfg: &'a E3Config,
    /// Index of the run.
    pub run: usize,
    /// F_ext.
    pub force: f64,
    /// Loaded grains (id, x, z) in the reference.
    pub loads: Vec<(u32, f64, f64)>,
    /// x of the origin of the profiles (the load; for superpositions the midpoint of the two
    /// loaded grains, for all three runs).
    pub origin: f64,
    /// Vertical component of all applied forces.
    pub vertical_load: f64,
    /// Box width.
    pub width: f64,
    /// Reference field (for the difference), when fields are computed.
    pub reference_field: Option<&'a FieldData>,
    /// Keep per-contact differences.
    pub keep_contacts: bool,
    /// How the relaxation ended.
    pub outcome: super::relax::RelaxOutcome,
    /// Friction coefficients: grain–grain, floor, side walls.
    pub friction: [f64; 3],
}

/// Measures a response: `reference` before, `after` the load.
pub fn measure_run(input: RunInputs<'_>, reference: &Snapshot<D2>, after: &Snapshot<D2>) -> (RunResult, NetworkChanges<D2>) {
    let cfg = input.cfg;
    let rc = &cfg.response;
    let origin = input.origin;
    let load_z = input.loads.iter().map(|l| l.2).fold(f64::NEG_INFINITY, f64::max);
    // both states are at rest: a contact counts as sliding when its friction is fully mobilized
    // (|F_t| ≥ (1 − 1e-6) μ F_n), not only when the cap acted at the last step
    let [mu, mu_floor, mu_side] = input.friction;
    let friction = |j: Counterpart| match j {
        Counterpart::Grain(_) => mu,
        Counterpart::Wall(w) if w == FLOOR => mu_floor,
        Counterpart::Wall(_) => mu_side,
    };
    let (mut reference, mut after) = (reference.clone(), after.clone());
    mark_mobilized(&mut reference.contacts, friction, MOBILIZED_TOLERANCE);
    mark_mobilized(&mut after.contacts, friction, MOBILIZED_TOLERANCE);
    let (reference, after) = (&reference, &after);
    let changes = compare_networks(reference, after);
    let floor = floor_contacts(&changes, origin);
    let grid = profile_grid(input.width, origin, rc.profile_step);
    let xs: Vec<f64> = floor.iter().map(|c| c.x).collect();
    let dfz: Vec<f64> = floor.iter().map(|c| c.after - c.reference).collect();
    let profiles = profiles(&xs, &dfz, &rc.widths, &grid);
    let z0 = zero_index(&grid);
    let response_at_zero = profiles.iter().map(|p| p[z0] / input.force).collect();
    let classifier_width = rc.classifier_width.unwrap_or(rc.widths[0]);
    let classified = smooth_1d(&xs, &dfz, classifier_width, &grid);
    let classification = classify_profile(&grid, &classified, &PeakOptions { prominence: rc.prominence, centre: 0.0 });
    let raw = raw_floor_verdict(&floor);
    let counts = changes.counts();
    // the opened contacts connected to the load: seeded within 3 R̄ (the loaded grain's contacts
    // and its neighbours'), linked within 2.5 R̄ (contacts sharing a grain)
    let region = changes.opened_region(glam::DVec2::new(origin, load_z), 1, 0, REGION_SEED, REGION_LINK);
    // the opened contacts in the cone below the load, connected or not (a superposition's two
    // loads: the cone below their midpoint)
    let cone = cone_opening(&changes, [origin, load_z]);
    let symmetry = floor_symmetry(&xs.iter().copied().zip(dfz.iter().copied()).collect::<Vec<_>>());
    // linear estimate of the first opening
    let mut estimate: Option<(f64, ContactKey)> = None;
    for c in &changes.contacts {
        if let (Some(b), Some(a)) = (c.before, c.after) {
            let dn = a.normal_force - b.normal_force;
            if dn < 0.0 && b.normal_force > 0.0 {
                let f = input.force * b.normal_force / (-dn);
                if estimate.is_none_or(|(e, _)| f < e) {
                    estimate = Some((f, c.key));
                }
            }
        }
    }
    let started_sliding = changes.contacts.iter().any(|c| c.sliding_after() && !c.before.is_some_and(|b| b.sliding));
    let linear = counts.opened == 0 && counts.created == 0 && !started_sliding;
    let top = top_of(reference);
    let bulk = bulk_window(input.width, top, rc.boundary_layer);
    let field = input.reference_field.map(|rf| stress_field(after, cfg, &rf.grid()).minus(rf));
    let contacts = input.keep_contacts.then(|| {
        changes
            .contacts
            .iter()
            .map(|c| {
                let d = c.force_difference();
                ContactDelta { key: c.key, df: [d.x, d.y] }
            })
            .collect()
    });
    let result = RunResult {
        run: input.run,
        force: input.force,
        loads: input.loads.clone(),
        origin,
        outcome: input.outcome,
        floor_change: dfz.iter().sum(),
        floor,
        grid,
        profiles,
        response_at_zero,
        vertical_load: input.vertical_load,
        side_wall_change: [wall_load(after, LEFT) - wall_load(reference, LEFT), wall_load(after, RIGHT) - wall_load(reference, RIGHT)],
        counts,
        region,
        cone,
        symmetry,
        linear,
        first_opening_estimate: estimate.map(|e| e.0),
        first_opening_contact: estimate.map(|e| e.1),
        classification,
        raw,
        moduli_bulk: moduli(after, bulk),
        moduli_load: moduli(after, load_window(input.width, top, rc.boundary_layer, origin)),
        field,
        contacts,
    };
    (result, changes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use grainwave_analysis::peaks::PeakShape;

    fn floor(values: &[(f64, f64)]) -> Vec<FloorContact> {
        values
            .iter()
            .enumerate()
            .map(|(k, &(x, dz))| FloorContact { grain: k as u32, x, reference: 1.0, after: 1.0 + dz, horizontal_reference: 0.0, horizontal_after: 0.0 })
            .collect()
    }

    #[test]
    fn raw_verdict_counts_a_dip_of_any_depth_and_reports_it() {
        // a 1 % central dip between two side maxima: double, depth 0.01 (a 5 %-prominence
        // classifier on a smoothed profile would call this single)
        let v = raw_floor_verdict(&floor(&[(-6.0, 0.1), (-4.0, 0.5), (-2.0, 1.0), (0.0, 0.99), (2.0, 1.0), (4.0, 0.5), (6.0, 0.1)])).unwrap();
        assert_eq!(v.shape, PeakShape::Double);
        assert!((v.dip - 0.01).abs() < 1e-12, "{v:?}");
        assert_eq!((v.left[0], v.right[0], v.centre_x), (-2.0, 2.0, 0.0));
        // the centre is the maximum: single, negative depth (centre 25 % above the side maxima)
        let v = raw_floor_verdict(&floor(&[(-4.0, 0.2), (-2.0, 0.8), (0.0, 1.0), (2.0, 0.8), (4.0, 0.2)])).unwrap();
        assert_eq!(v.shape, PeakShape::Single);
        assert!((v.dip + 0.25).abs() < 1e-12);
        // higher on one side only: irregular; unordered input is sorted first
        let v = raw_floor_verdict(&floor(&[(2.0, 1.2), (-2.0, 0.5), (0.0, 1.0), (4.0, 0.3)])).unwrap();
        assert_eq!(v.shape, PeakShape::Irregular);
        assert!(raw_floor_verdict(&floor(&[(0.0, 1.0), (2.0, 0.5)])).is_none());
        // a load between two floor contacts (x = ±1): both are central, the larger is p₀
        let v = raw_floor_verdict(&floor(&[(-5.0, 0.3), (-3.0, 0.9), (-1.0, 1.0), (1.0, 1.01), (3.0, 0.9), (5.0, 0.3)])).unwrap();
        assert_eq!((v.shape, v.centre_x), (PeakShape::Single, 1.0));
        let v = raw_floor_verdict(&floor(&[(-5.0, 0.3), (-3.0, 1.1), (-1.0, 1.0), (1.0, 0.98), (3.0, 1.05), (5.0, 0.3)])).unwrap();
        assert_eq!(v.shape, PeakShape::Double);
        assert!((v.dip - (1.0 - 1.0 / 1.05)).abs() < 1e-12);
    }

    #[test]
    fn antisymmetric_fraction_of_synthetic_floor_profiles() {
        // floor contacts at x = −8 … 8 (step 2) plus an unpaired one at −10 (its image, +10, is
        // beyond the right wall); profile g(x) = e^{−x²/16} + 0.1
        let xs: Vec<f64> = (-4..=4).map(|k| 2.0 * k as f64).collect();
        let g = |x: f64| (-x * x / 16.0).exp() + 0.1;
        let with_edge = |pts: Vec<(f64, f64)>| [vec![(-10.0, 0.7)], pts].concat();
        // exactly mirrored: A_s = 0, 9 contacts paired, the edge one not
        let s = floor_symmetry(&with_edge(xs.iter().map(|&x| (x, g(x))).collect())).unwrap();
        assert_eq!((s.antisymmetric_fraction, s.paired, s.unpaired), (0.0, 9, 1));
        assert_eq!((s.centre, s.left, s.right), (Some([0.0, g(0.0)]), Some([-2.0, g(-2.0)]), Some([2.0, g(2.0)])));
        // a response on one side only (x > 0): every pair gives |a − 0| / |a + 0|, A_s = 1
        let s = floor_symmetry(&with_edge(xs.iter().map(|&x| (x, if x > 0.0 { g(x) } else { 0.0 })).collect())).unwrap();
        assert!((s.antisymmetric_fraction - 1.0).abs() < 1e-15, "{s:?}");
        // antisymmetric, ΔF(−x) = −ΔF(x): the denominator vanishes, A_s = ∞
        let s = floor_symmetry(&xs.iter().map(|&x| (x, x * g(x))).collect::<Vec<_>>()).unwrap();
        assert_eq!(s.antisymmetric_fraction, f64::INFINITY);
        // a symmetric part S and an antisymmetric part a·A: A_s = Σ|2aA| / Σ|2S| exactly
        let a = 0.1;
        let pts: Vec<(f64, f64)> = xs.iter().map(|&x| (x, g(x) + a * x * g(x))).collect();
        let expected = xs.iter().map(|&x| (2.0 * a * x * g(x)).abs()).sum::<f64>() / xs.iter().map(|&x| 2.0 * g(x)).sum::<f64>();
        assert!((floor_symmetry(&pts).unwrap().antisymmetric_fraction - expected).abs() < 1e-14);
        // images within the tolerance pair (a relaxed lattice, small disorder); a load between two
        // floor contacts (x = ±1, ±3): no centre, the nearest on each side are named
        let pts = [(-3.0, 0.5), (-1.01, 1.0), (0.99, 1.0), (3.0, 0.5)];
        let s = floor_symmetry(&pts).unwrap();
        assert_eq!((s.antisymmetric_fraction, s.paired, s.centre), (0.0, 4, None));
        assert_eq!((s.left, s.right), (Some([-1.01, 1.0]), Some([0.99, 1.0])));
        // no mirror partner within the tolerance at all
        assert!(floor_symmetry(&[(1.0, 1.0), (-1.7, 1.0)]).is_none());
    }

    #[test]
    fn first_opening_region_is_the_cone_below_the_load_with_one_grain_of_margin() {
        let t = (30f64).to_radians().tan();
        // on the lattice lines through the load and one grain (2R̄) outside them: inside
        for k in 1..=14 {
            let dz = k as f64 * 3f64.sqrt();
            for s in [-1.0, 1.0] {
                assert!(in_opening_cone(s * dz * t, dz), "on the line, row {k}");
                assert!(in_opening_cone(s * (dz * t + 2.0), dz), "one grain outside, row {k}");
                // the horizontal contact just beyond the margin (|Δx| − Δz tan 30° = 3): outside
                assert!(!in_opening_cone(s * (dz * t + 3.0), dz), "beyond the margin, row {k}");
            }
        }
        // the loaded grain's own horizontal contacts (Δz = 0, Δx = ±1) and its neighbours' (±3)
        assert!(in_opening_cone(1.0, 0.0) && in_opening_cone(-1.0, 0.0));
        assert!(!in_opening_cone(3.0, 0.0));
        // above the load: outside
        assert!(!in_opening_cone(0.0, -1.0));
        // a contact straight below at any depth: inside
        assert!(in_opening_cone(0.0, 40.0));
    }
}
