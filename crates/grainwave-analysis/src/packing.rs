//! Static characterization of a packing (SPEC §4, §5.2): solid fractions, rattlers, coordination,
//! force statistics, fabric and stress, in the bulk (grains away from the walls).
//!
//! # Geometry
//!
//! The **compression axis** is the last axis by default (E1: y for `sphere2d`, z for `sphere`): the
//! axis of the piston and of the pulse. Along it the cell is closed by two walls (the lowest wall
//! with inward normal +e and the highest with −e); the other axes are periodic (or closed by walls:
//! their extent is then the wall gap). The **bulk** is the slab `[y_lo + l, y_hi − l]`, l the
//! boundary layer (E1: 3 mean diameters).
//!
//! # Quantities
//!
//! * **Solid fractions**, exact: the part of each grain inside the bulk slab (circular segments,
//!   spherical caps), over the slab's measure. Φ₂ (area fraction; `disk`, `sphere2d`), Φ₃ (volume
//!   fraction: `sphere2d`, spheres in a layer one mean diameter d̄ thick, so Φ₃ = Σ(4/3)πR³/(A d̄);
//!   `sphere`, the volume fraction), Φ₃* (the same over non-rattlers: the mass density entering sound
//!   speeds for ρ = 1).
//! * **Rattlers**, by iterated removal: a grain with fewer than `rattler_min_contacts`
//!   force-carrying contacts (F_n > 0; wall contacts count, contacts with removed grains do not) is
//!   removed, until none is (default threshold 2 with friction, d + 1 without). f₀ = fraction of the
//!   bulk grains (centre in the slab) that are rattlers.
//! * **Coordination** z* = mean number of force-carrying contacts with non-rattlers (grains or walls)
//!   per non-rattler bulk grain; z = the same over all contacts and grains.
//! * **Force statistics** over the force-carrying grain–grain contacts of the bulk grains, each
//!   counted once per bulk grain it touches (a contact between two bulk grains twice, one across the
//!   slab's edge once — the same weights as the grain-wise bulk stress, so that a perfect lattice
//!   gives its exact fabric whatever the slab): ⟨N⟩/(p d̄²), Z(α) = ⟨N^α⟩/⟨N⟩^α (α = 2, 3), samples
//!   N/⟨N⟩ and k_n/⟨k_n⟩ (k_n = dF_n/dξ) for histograms on a common normalization.
//! * **Fabric** over the same contacts: the tensor ⟨n_α n_β⟩, F₂ = ⟨n_y²⟩ (n_y along the compression
//!   axis), F₂^S over strong contacts (N > ⟨N⟩); contact angles of all, strong, weak (N ≤ ⟨N⟩) and
//!   sliding contacts — 2D: the angle of n̂ from the first axis folded into [0, π); 3D: the polar angle
//!   from the compression axis in [0, π/2].
//! * **Stress**, compression positive: the whole cell σ = −(1/V) Σ_c f_c ⊗ b_c over every contact
//!   (f the force on grain i, b its branch vector; wall contacts: centre → contact point), which at
//!   static equilibrium gives exactly the wall loads (σ_yy = F_piston/(L_x d̄) for `sphere2d`); and the
//!   bulk stress from the grain-wise virial, each grain–grain contact shared half–half between its
//!   grains, summed over the grains whose centres lie in the slab, over the slab's volume. V uses the
//!   "3D" convention of `sphere2d` (area × mean diameter), the area for `disk`, the volume for
//!   `sphere`. σ₂ is the principal value whose direction is closest to the compression axis, σ₁ the
//!   other one (3D: the mean of the other two).
//!
//! ```
//! use grainwave_analysis::packing::{segment_area_below, cap_volume_below};
//! let r = 0.5;
//! assert!((segment_area_below(r, 0.0) - std::f64::consts::PI * r * r / 2.0).abs() < 1e-15);
//! assert!((cap_volume_below(r, r) - 4.0 / 3.0 * std::f64::consts::PI * r.powi(3)).abs() < 1e-15);
//! ```

use grainwave_core::dim::{Dim, VectorOps};
use grainwave_core::domain::Domain;
use grainwave_core::grains::GrainKind;
use grainwave_core::snapshot::{ContactRecord, Counterpart, Snapshot};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Options of [`characterize`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CharacterizationOptions {
    /// Boundary layer l excluded next to the walls along the compression axis [length] (default 3,
    /// i.e. three mean diameters in E1 units).
    pub boundary_layer: f64,
    /// Compression axis (default: the last axis).
    pub axis: Option<usize>,
    /// Force-carrying contacts a grain needs not to be a rattler (default 2 with friction, d + 1
    /// without).
    pub rattler_min_contacts: Option<usize>,
    /// The applied pressure p, the unit of ⟨N⟩/(p d̄²) (default: σ₂ of the whole cell).
    pub pressure: Option<f64>,
}

impl Default for CharacterizationOptions {
    fn default() -> Self {
        CharacterizationOptions { boundary_layer: 3.0, axis: None, rattler_min_contacts: None, pressure: None }
    }
}

/// Principal values of a stress tensor, labelled by the compression axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PrincipalStress {
    /// The tensor, row-major (d × d), compression positive [force/area].
    pub tensor: Vec<f64>,
    /// σ₁: the other principal value (3D: mean of the two others) [force/area].
    pub sigma_1: f64,
    /// σ₂: the principal value whose direction is closest to the compression axis [force/area].
    pub sigma_2: f64,
    /// σ₁/σ₂.
    pub ratio: f64,
    /// All principal values, decreasing [force/area].
    pub principal: Vec<f64>,
    /// Angle between the σ₂ direction and the compression axis [rad].
    pub tilt: f64,
}

/// Everything [`characterize`] measures (see the module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PackingStatistics {
    /// Grains in the packing.
    pub grains: usize,
    /// Grains whose centre lies in the bulk slab.
    pub bulk_grains: usize,
    /// Rattlers in the whole packing.
    pub rattlers: usize,
    /// Rattler flags per grain (storage order of the snapshot).
    pub rattler_flags: Vec<bool>,
    /// Mean diameter d̄ [length].
    pub mean_diameter: f64,
    /// Extent along the compression axis: the wall gap [length].
    pub height: f64,
    /// Extents along the other axes [length].
    pub lateral: Vec<f64>,
    /// Lower and upper bounds of the bulk slab along the compression axis [length].
    pub bulk_slab: (f64, f64),
    /// Φ₂, area fraction in the bulk (2D kinds only).
    pub phi2: Option<f64>,
    /// Φ₃, volume fraction in the bulk (`sphere2d`: in a layer one d̄ thick; `sphere`).
    pub phi3: Option<f64>,
    /// Φ₃* over non-rattlers.
    pub phi3_star: Option<f64>,
    /// f₀, fraction of rattlers among the bulk grains.
    pub rattler_fraction: f64,
    /// z*, force-carrying contacts per non-rattler bulk grain.
    pub coordination_star: f64,
    /// z, contacts (F_n > 0) per bulk grain, rattlers included.
    pub coordination: f64,
    /// Force-carrying grain–grain contacts of the bulk grains, counted once per bulk grain.
    pub bulk_contacts: usize,
    /// Sliding fraction of those contacts.
    pub sliding_fraction: f64,
    /// ⟨N⟩ [force].
    pub mean_force: f64,
    /// ⟨N⟩/(p d̄²).
    pub mean_force_over_p: f64,
    /// Z(2) = ⟨N²⟩/⟨N⟩².
    pub z2: f64,
    /// Z(3) = ⟨N³⟩/⟨N⟩³.
    pub z3: f64,
    /// ⟨k_n⟩ [force/length].
    pub mean_stiffness: f64,
    /// F₂ = ⟨n_y²⟩ along the compression axis.
    pub f2: f64,
    /// F₂^S over strong contacts (N > ⟨N⟩).
    pub f2_strong: f64,
    /// Fabric tensor ⟨n_α n_β⟩ (row-major).
    pub fabric: Vec<f64>,
    /// Stress of the whole cell (every contact, walls included) [force/area].
    pub stress: PrincipalStress,
    /// Bulk stress from the grain-wise virial [force/area].
    pub bulk_stress: PrincipalStress,
    /// Pressure used as the unit of ⟨N⟩/(p d̄²) [force/area].
    pub pressure: f64,
    /// N/⟨N⟩ of the bulk contacts.
    pub force_ratios: Vec<f64>,
    /// k_n/⟨k_n⟩ of the bulk contacts.
    pub stiffness_ratios: Vec<f64>,
    /// Contact angles of all bulk contacts [rad].
    pub angles_all: Vec<f64>,
    /// Contact angles of strong contacts (N > ⟨N⟩) [rad].
    pub angles_strong: Vec<f64>,
    /// Contact angles of weak contacts (N ≤ ⟨N⟩) [rad].
    pub angles_weak: Vec<f64>,
    /// Contact angles of sliding contacts [rad].
    pub angles_sliding: Vec<f64>,
}

/// Area of a circle of radius `r` below the line at height `h` above its centre.
pub fn segment_area_below(r: f64, h: f64) -> f64 {
    let h = h.clamp(-r, r);
    r * r * (-h / r).clamp(-1.0, 1.0).acos() + h * (r * r - h * h).max(0.0).sqrt()
}

/// Volume of a sphere of radius `r` below the plane at height `h` above its centre.
pub fn cap_volume_below(r: f64, h: f64) -> f64 {
    let h = h.clamp(-r, r);
    PI * (r + h) * (r + h) * (2.0 * r - h) / 3.0
}

/// The rattler finder of the engine's snapshots (one implementation for analysis and linear).
pub use grainwave_core::rattlers::{default_rattler_threshold, find_rattlers};

/// Walls closing `axis`: (lower coordinate, upper coordinate), from the walls perpendicular to it.
pub fn wall_gap<D: Dim>(domain: &Domain<D>, axis: usize) -> Option<(f64, f64)> {
    let mut lo: Option<f64> = None;
    let mut hi: Option<f64> = None;
    for w in &domain.walls {
        let n = w.normal.get(axis);
        if (n.abs() - 1.0).abs() < 1e-12 {
            let x = w.position.get(axis);
            if n > 0.0 {
                lo = Some(lo.map_or(x, |v: f64| v.max(x)));
            } else {
                hi = Some(hi.map_or(x, |v: f64| v.min(x)));
            }
        }
    }
    match (lo, hi) {
        (Some(a), Some(b)) if b > a => Some((a, b)),
        _ => None,
    }
}

/// Extent of the cell along `axis`: the periodic length, the wall gap, or the domain extent.
pub fn extent<D: Dim>(domain: &Domain<D>, axis: usize) -> f64 {
    if domain.is_periodic(axis) {
        return domain.length(axis);
    }
    match wall_gap(domain, axis) {
        Some((a, b)) => b - a,
        None => domain.length(axis),
    }
}

/// Principal values of the symmetric d × d tensor `s` (row-major) with unit eigenvectors, values
/// decreasing (2D closed form, 3D Jacobi rotations).
pub fn symmetric_eigen(s: &[f64], d: usize) -> (Vec<f64>, Vec<Vec<f64>>) {
    let mut a: Vec<Vec<f64>> = (0..d).map(|r| (0..d).map(|c| 0.5 * (s[r * d + c] + s[c * d + r])).collect()).collect();
    let mut v: Vec<Vec<f64>> = (0..d).map(|r| (0..d).map(|c| if r == c { 1.0 } else { 0.0 }).collect()).collect();
    for _ in 0..100 {
        let mut off = 0.0;
        for p in 0..d {
            for q in p + 1..d {
                off += a[p][q] * a[p][q];
            }
        }
        let scale: f64 = (0..d).map(|k| a[k][k] * a[k][k]).sum::<f64>() + off;
        if off <= 1e-30 * scale || off == 0.0 {
            break;
        }
        for p in 0..d {
            for q in p + 1..d {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = 0.5 * (2.0 * a[p][q]).atan2(a[q][q] - a[p][p]);
                let (sn, cs) = theta.sin_cos();
                // A ← Jᵀ A J with J the rotation in the (p, q) plane that zeroes a[p][q]
                for k in 0..d {
                    let (akp, akq) = (a[k][p], a[k][q]);
                    a[k][p] = cs * akp - sn * akq;
                    a[k][q] = sn * akp + cs * akq;
                }
                for k in 0..d {
                    let (apk, aqk) = (a[p][k], a[q][k]);
                    a[p][k] = cs * apk - sn * aqk;
                    a[q][k] = sn * apk + cs * aqk;
                }
                for k in 0..d {
                    let (vkp, vkq) = (v[k][p], v[k][q]);
                    v[k][p] = cs * vkp - sn * vkq;
                    v[k][q] = sn * vkp + cs * vkq;
                }
            }
        }
    }
    let mut order: Vec<usize> = (0..d).collect();
    order.sort_by(|&x, &y| a[y][y].total_cmp(&a[x][x]));
    let values = order.iter().map(|&k| a[k][k]).collect();
    let vectors = order.iter().map(|&k| (0..d).map(|r| v[r][k]).collect()).collect();
    (values, vectors)
}

/// Principal values of `tensor` labelled by the compression axis `axis`.
pub fn principal_stress(tensor: Vec<f64>, d: usize, axis: usize) -> PrincipalStress {
    let (values, vectors) = symmetric_eigen(&tensor, d);
    let k2 = (0..d).max_by(|&a, &b| vectors[a][axis].abs().total_cmp(&vectors[b][axis].abs())).unwrap_or(0);
    let sigma_2 = values[k2];
    let others: Vec<f64> = (0..d).filter(|&k| k != k2).map(|k| values[k]).collect();
    let sigma_1 = others.iter().sum::<f64>() / others.len().max(1) as f64;
    PrincipalStress { sigma_1, sigma_2, ratio: sigma_1 / sigma_2, principal: values, tilt: vectors[k2][axis].abs().min(1.0).acos(), tensor }
}

/// Contact angle: 2D, the angle of n̂ from axis 0 folded into [0, π); 3D, the polar angle from
/// `axis` in [0, π/2].
fn contact_angle<D: Dim>(n: D::Vector, axis: usize) -> f64 {
    if D::D == 2 {
        let a = n.get(1).atan2(n.get(0));
        let a = if a < 0.0 { a + PI } else { a };
        if a >= PI {
            0.0
        } else {
            a
        }
    } else {
        n.get(axis).abs().min(1.0).acos()
    }
}

/// Static characterization of `snapshot` (see the module docs).
pub fn characterize<D: Dim>(snapshot: &Snapshot<D>, options: &CharacterizationOptions) -> PackingStatistics {
    let d = D::D;
    let axis = options.axis.unwrap_or(d - 1);
    let n = snapshot.len();
    let kind = snapshot.kind;
    let index = snapshot.index_by_id();
    let mean_diameter = if n > 0 { 2.0 * snapshot.radius.iter().sum::<f64>() / n as f64 } else { 0.0 };
    let (y_lo, y_hi) = wall_gap(&snapshot.domain, axis).unwrap_or_else(|| {
        let lo = snapshot.domain.lo.get(axis);
        (lo, lo + snapshot.domain.length(axis))
    });
    let height = y_hi - y_lo;
    let lateral: Vec<f64> = (0..d).filter(|&k| k != axis).map(|k| extent(&snapshot.domain, k)).collect();
    let cross: f64 = lateral.iter().product();
    let l = options.boundary_layer.max(0.0);
    let (a, b) = if 2.0 * l < height { (y_lo + l, y_hi - l) } else { (y_lo, y_hi) };
    let slab = b - a;
    let threshold = options.rattler_min_contacts.unwrap_or_else(|| default_rattler_threshold(snapshot));
    let rattler_flags = find_rattlers(snapshot, threshold);
    let in_slab = |y: f64| y >= a && y <= b;
    let bulk: Vec<bool> = (0..n).map(|g| in_slab(snapshot.pos[g].get(axis))).collect();
    let bulk_grains = bulk.iter().filter(|&&x| x).count();

    // solid fractions
    let (mut area, mut vol, mut vol_star) = (0.0, 0.0, 0.0);
    for g in 0..n {
        let r = snapshot.radius[g];
        let y = snapshot.pos[g].get(axis);
        let ar = segment_area_below(r, b - y) - segment_area_below(r, a - y);
        let vo = cap_volume_below(r, b - y) - cap_volume_below(r, a - y);
        area += ar;
        vol += vo;
        if !rattler_flags[g] {
            vol_star += vo;
        }
    }
    let (phi2, phi3, phi3_star) = match kind {
        GrainKind::Disk { .. } => (Some(area / (cross * slab)), None, None),
        GrainKind::Sphere2d => (Some(area / (cross * slab)), Some(vol / (cross * slab * mean_diameter)), Some(vol_star / (cross * slab * mean_diameter))),
        GrainKind::Sphere => (None, Some(vol / (cross * slab)), Some(vol_star / (cross * slab))),
    };

    // coordination
    let mut z_star_count = vec![0usize; n];
    let mut z_count = vec![0usize; n];
    for c in snapshot.contacts.iter().filter(|c| c.normal_force > 0.0) {
        let i = index[c.i as usize];
        match c.j {
            Counterpart::Grain(j) => {
                let j = index[j as usize];
                z_count[i] += 1;
                z_count[j] += 1;
                if !rattler_flags[i] && !rattler_flags[j] {
                    z_star_count[i] += 1;
                    z_star_count[j] += 1;
                }
            }
            Counterpart::Wall(_) => {
                z_count[i] += 1;
                if !rattler_flags[i] {
                    z_star_count[i] += 1;
                }
            }
        }
    }
    let bulk_idx: Vec<usize> = (0..n).filter(|&g| bulk[g]).collect();
    let bulk_rattlers = bulk_idx.iter().filter(|&&g| rattler_flags[g]).count();
    let carriers: Vec<usize> = bulk_idx.iter().copied().filter(|&g| !rattler_flags[g]).collect();
    let coordination_star = if carriers.is_empty() { 0.0 } else { carriers.iter().map(|&g| z_star_count[g]).sum::<usize>() as f64 / carriers.len() as f64 };
    let coordination = if bulk_idx.is_empty() { 0.0 } else { bulk_idx.iter().map(|&g| z_count[g]).sum::<usize>() as f64 / bulk_idx.len() as f64 };

    // stresses
    let volume_factor = match kind {
        GrainKind::Sphere2d => mean_diameter,
        _ => 1.0,
    };
    let mut whole = vec![0.0; d * d];
    let mut per_grain = vec![vec![0.0; d * d]; n];
    for c in &snapshot.contacts {
        let f = c.force_on_i();
        let i = index[c.i as usize];
        for r in 0..d {
            for s in 0..d {
                let w = -f.get(r) * c.branch.get(s);
                whole[r * d + s] += w;
                match c.j {
                    Counterpart::Grain(j) => {
                        per_grain[i][r * d + s] += 0.5 * w;
                        per_grain[index[j as usize]][r * d + s] += 0.5 * w;
                    }
                    Counterpart::Wall(_) => per_grain[i][r * d + s] += w,
                }
            }
        }
    }
    let v_cell = cross * height * volume_factor;
    whole.iter_mut().for_each(|x| *x /= v_cell);
    let mut bulk_tensor = vec![0.0; d * d];
    for &g in &bulk_idx {
        for k in 0..d * d {
            bulk_tensor[k] += per_grain[g][k];
        }
    }
    let v_bulk = cross * slab * volume_factor;
    bulk_tensor.iter_mut().for_each(|x| *x /= v_bulk);
    let stress = principal_stress(whole, d, axis);
    let bulk_stress = principal_stress(bulk_tensor, d, axis);
    let pressure = options.pressure.unwrap_or(stress.sigma_2);

    // the force-carrying grain–grain contacts of the bulk grains, once per bulk grain they touch
    let mut bulk_contacts: Vec<&ContactRecord<D>> = Vec::new();
    for c in snapshot.contacts.iter().filter(|c| c.normal_force > 0.0) {
        if let Counterpart::Grain(j) = c.j {
            for g in [index[c.i as usize], index[j as usize]] {
                if bulk[g] {
                    bulk_contacts.push(c);
                }
            }
        }
    }
    let m = bulk_contacts.len();
    let mean = |f: &dyn Fn(&ContactRecord<D>) -> f64| if m == 0 { f64::NAN } else { bulk_contacts.iter().map(|c| f(c)).sum::<f64>() / m as f64 };
    let mean_force = mean(&|c| c.normal_force);
    let mean_stiffness = mean(&|c| c.normal_stiffness);
    let z2 = mean(&|c| c.normal_force.powi(2)) / mean_force.powi(2);
    let z3 = mean(&|c| c.normal_force.powi(3)) / mean_force.powi(3);
    let mut fabric = vec![0.0; d * d];
    for c in &bulk_contacts {
        for r in 0..d {
            for s in 0..d {
                fabric[r * d + s] += c.normal.get(r) * c.normal.get(s) / m.max(1) as f64;
            }
        }
    }
    let strong: Vec<&&ContactRecord<D>> = bulk_contacts.iter().filter(|c| c.normal_force > mean_force).collect();
    let f2_strong = if strong.is_empty() { f64::NAN } else { strong.iter().map(|c| c.normal.get(axis).powi(2)).sum::<f64>() / strong.len() as f64 };
    let angle = |c: &ContactRecord<D>| contact_angle::<D>(c.normal, axis);
    PackingStatistics {
        grains: n,
        bulk_grains,
        rattlers: rattler_flags.iter().filter(|&&r| r).count(),
        mean_diameter,
        height,
        lateral,
        bulk_slab: (a, b),
        phi2,
        phi3,
        phi3_star,
        rattler_fraction: if bulk_grains == 0 { 0.0 } else { bulk_rattlers as f64 / bulk_grains as f64 },
        coordination_star,
        coordination,
        bulk_contacts: m,
        sliding_fraction: if m == 0 { 0.0 } else { bulk_contacts.iter().filter(|c| c.sliding).count() as f64 / m as f64 },
        mean_force,
        mean_force_over_p: mean_force / (pressure * mean_diameter * mean_diameter),
        z2,
        z3,
        mean_stiffness,
        f2: fabric[axis * d + axis],
        f2_strong,
        fabric,
        stress,
        bulk_stress,
        pressure,
        force_ratios: bulk_contacts.iter().map(|c| c.normal_force / mean_force).collect(),
        stiffness_ratios: bulk_contacts.iter().map(|c| c.normal_stiffness / mean_stiffness).collect(),
        angles_all: bulk_contacts.iter().map(|c| angle(c)).collect(),
        angles_strong: bulk_contacts.iter().filter(|c| c.normal_force > mean_force).map(|c| angle(c)).collect(),
        angles_weak: bulk_contacts.iter().filter(|c| c.normal_force <= mean_force).map(|c| angle(c)).collect(),
        angles_sliding: bulk_contacts.iter().filter(|c| c.sliding).map(|c| angle(c)).collect(),
        rattler_flags,
    }
}

/// Probability density of `values` over `bins` equal bins of `[min, max]` (values outside are
/// ignored; the density integrates to the fraction inside). Returns bin centres and densities.
pub fn density_histogram(values: &[f64], bins: usize, min: f64, max: f64) -> (Vec<f64>, Vec<f64>) {
    let bins = bins.max(1);
    let w = (max - min) / bins as f64;
    let mut counts = vec![0usize; bins];
    for &v in values {
        if v.is_finite() && v >= min && v <= max {
            let k = (((v - min) / w) as usize).min(bins - 1);
            counts[k] += 1;
        }
    }
    let total = values.len().max(1) as f64;
    let centres = (0..bins).map(|k| min + (k as f64 + 0.5) * w).collect();
    (centres, counts.iter().map(|&c| c as f64 / (total * w)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Circular segments and spherical caps against numerical integration of the chord length
    /// 2√(R² − y²) and of the disk area π(R² − y²) (midpoint rule, 10⁶ slices: error ~1e-12).
    #[test]
    fn segments_and_caps_match_integrals() {
        let r = 0.6;
        for h in [-0.7, -0.6, -0.3, 0.0, 0.1, 0.45, 0.6, 0.9] {
            let n = 1_000_000;
            let (lo, hi) = (-r, f64::min(h, r));
            let (mut area, mut vol) = (0.0, 0.0);
            if hi > lo {
                let dy = (hi - lo) / n as f64;
                for k in 0..n {
                    let y = lo + (k as f64 + 0.5) * dy;
                    area += 2.0 * (r * r - y * y).max(0.0).sqrt() * dy;
                    vol += PI * (r * r - y * y).max(0.0) * dy;
                }
            }
            assert!((segment_area_below(r, h) - area).abs() < 1e-9, "h = {h}: {} vs {area}", segment_area_below(r, h));
            assert!((cap_volume_below(r, h) - vol).abs() < 1e-9, "h = {h}");
        }
    }

    /// Principal values and directions of known tensors; the σ₂ label follows the axis.
    #[test]
    fn principal_values() {
        // 2D: rotate diag(3, 1) by 30°
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let t = vec![3.0 * c * c + s * s, 2.0 * c * s, 2.0 * c * s, 3.0 * s * s + c * c];
        let p = principal_stress(t, 2, 1);
        assert!((p.principal[0] - 3.0).abs() < 1e-12 && (p.principal[1] - 1.0).abs() < 1e-12);
        // the direction of 3 is 30° from x, i.e. 60° from y: σ₂ (closest to y) is 1
        assert!((p.sigma_2 - 1.0).abs() < 1e-12 && (p.sigma_1 - 3.0).abs() < 1e-12 && (p.tilt - 30f64.to_radians()).abs() < 1e-9);
        // 3D: a symmetric matrix with known eigenvalues (Q diag(4, 2, 1) Qᵀ with Q a rotation)
        let q = [[2.0 / 3.0, -1.0 / 3.0, 2.0 / 3.0], [2.0 / 3.0, 2.0 / 3.0, -1.0 / 3.0], [-1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0]];
        let l = [4.0, 2.0, 1.0];
        let mut m = vec![0.0; 9];
        for a in 0..3 {
            for b in 0..3 {
                m[a * 3 + b] = (0..3).map(|k| q[a][k] * l[k] * q[b][k]).sum();
            }
        }
        let (values, vectors) = symmetric_eigen(&m, 3);
        for k in 0..3 {
            assert!((values[k] - l[k]).abs() < 1e-12, "{values:?}");
            let dot: f64 = (0..3).map(|a| vectors[k][a] * q[a][k]).sum();
            assert!((dot.abs() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn histogram_densities_integrate_to_the_fraction_inside() {
        let v: Vec<f64> = (0..1000).map(|k| (k as f64 + 0.5) / 500.0).collect();
        let (c, d) = density_histogram(&v, 10, 0.0, 1.0);
        assert_eq!(c.len(), 10);
        let total: f64 = d.iter().map(|x| x * 0.1).sum();
        assert!((total - 0.5).abs() < 1e-12 && (c[0] - 0.05).abs() < 1e-15);
    }
}
