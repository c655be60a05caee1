//! Initial configurations: random non-overlapping gases and lattices.

use crate::dim::{Dim, VectorOps};
use crate::domain::Domain;
use crate::error::{CoreError, Result};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;

/// Places grains of the given radii at random, without overlaps, inside the box `[lo, hi]`
/// (random sequential addition). Along axes that are not periodic the whole grain stays inside
/// the box; along periodic axes overlaps are checked through the boundary, with the minimum image
/// of the domain `Domain::new(lo, hi, periodic)` ([`Domain::displacement`]). Grains are placed
/// largest first; the returned positions are in the order of `radii`.
///
/// The box is rectangular. A sheared simulation starts from it: [`Domain::set_shear_rate`] sets
/// a tilt *rate* and the tilt starts at 0, where the images are those of the rectangular box, so
/// a gas placed here has no overlap in the sheared domain either (tested). There is no placement
/// into a cell that is already tilted.
pub fn random_gas<D: Dim>(
    radii: &[f64],
    lo: D::Vector,
    hi: D::Vector,
    periodic: [bool; 3],
    rng: &mut ChaCha8Rng,
    max_attempts: usize,
) -> Result<Vec<D::Vector>> {
    let n = radii.len();
    let r_max = radii.iter().cloned().fold(0.0, f64::max);
    for k in 0..D::D {
        let l = hi.get(k) - lo.get(k);
        if !(l > 0.0) {
            return Err(CoreError::invalid(format!("box size[{k}]"), l, "a length > 0"));
        }
        if !periodic[k] && l < 2.0 * r_max {
            return Err(CoreError::invalid(format!("box size[{k}]"), l, format!("at least the largest diameter {}", 2.0 * r_max)));
        }
        // the grid-sizing loop below ends only in a box of finite lengths
        if !l.is_finite() {
            return Err(CoreError::invalid(format!("box size[{k}]"), l, "a finite length (a gas fraction or density too small for the grains?)"));
        }
    }
    // Cell edge ≥ the largest diameter (so the search reaches one cell in every direction); in
    // a sparse box the edge grows until there are at most a few cells per grain, so the grid's
    // size is bounded by the grain count whatever the box size. The overlap test is exact, so
    // the cell size does not change which positions are accepted.
    let mut cell = 2.0 * r_max;
    // the loop below grows `cell` geometrically until the grid is small enough: it ends only
    // from a cell > 0 (and finite box lengths, checked above)
    if !(cell > 0.0 && cell.is_finite()) {
        return Err(CoreError::invalid("largest radius", r_max, "a finite radius > 0"));
    }
    let cap = (4 * n).max(27);
    let mut dims = [1usize; 3];
    loop {
        let mut total = 1usize;
        for k in 0..D::D {
            let l = hi.get(k) - lo.get(k);
            dims[k] = ((l / cell).floor().min(usize::MAX as f64) as usize).max(1);
            total = total.saturating_mul(dims[k]);
        }
        if total <= cap {
            break;
        }
        cell *= 1.26;
    }
    let size: Vec<f64> = (0..3).map(|k| if k < D::D { (hi.get(k) - lo.get(k)) / dims[k] as f64 } else { 1.0 }).collect();
    let mut grid: Vec<Vec<u32>> = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
    let cell_of = |x: D::Vector| -> [usize; 3] {
        let mut c = [0usize; 3];
        for k in 0..D::D {
            c[k] = (((x.get(k) - lo.get(k)) / size[k]).floor().max(0.0) as usize).min(dims[k] - 1);
        }
        c
    };
    // nearest images through the periodic axes, as the simulation will see them
    let image = Domain::<D>::new(lo, hi, periodic).image();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| radii[b].total_cmp(&radii[a]).then(a.cmp(&b)));
    let mut pos = vec![D::Vector::ZERO; n];
    let mut placed = vec![false; n];
    for (count, &g) in order.iter().enumerate() {
        let r = radii[g];
        let mut ok = false;
        for _ in 0..max_attempts {
            let mut x = D::Vector::ZERO;
            for k in 0..D::D {
                let (a, b) = if periodic[k] { (lo.get(k), hi.get(k)) } else { (lo.get(k) + r, hi.get(k) - r) };
                x.set(k, a + (b - a) * rng.random::<f64>());
            }
            let c = cell_of(x);
            // The search reaches ⌈(r + r_max)/cell⌉ = 1 cell in every direction.
            let mut clear = true;
            'search: for dz in -1i64..=1 {
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let off = [dx, dy, dz];
                        let mut cc = [0usize; 3];
                        let mut valid = true;
                        for k in 0..3 {
                            if k >= D::D {
                                if off[k] != 0 {
                                    valid = false;
                                }
                                continue;
                            }
                            let v = c[k] as i64 + off[k];
                            let nk = dims[k] as i64;
                            if periodic[k] {
                                cc[k] = v.rem_euclid(nk) as usize;
                            } else if v < 0 || v >= nk {
                                valid = false;
                            } else {
                                cc[k] = v as usize;
                            }
                        }
                        if !valid {
                            continue;
                        }
                        for &o in &grid[(cc[2] * dims[1] + cc[1]) * dims[0] + cc[0]] {
                            let o = o as usize;
                            let d = image.displacement(x, pos[o]);
                            let reach = r + radii[o];
                            if d.norm2() < reach * reach {
                                clear = false;
                                break 'search;
                            }
                        }
                    }
                }
            }
            if clear {
                pos[g] = x;
                placed[g] = true;
                grid[(c[2] * dims[1] + c[1]) * dims[0] + c[0]].push(g as u32);
                ok = true;
                break;
            }
        }
        if !ok {
            return Err(CoreError::Inconsistent(format!(
                "could not place grain {} of {n} without overlap after {max_attempts} random attempts ({count} placed): \
                 the gas is too dense for its box; enlarge the box or use fewer grains",
                count + 1
            )));
        }
    }
    assert!(placed.iter().all(|&p| p), "random_gas: a grain was left unplaced");
    Ok(pos)
}

/// Centres of a triangular lattice in 2D: `rows` rows of `cols` grains, spacing `a`, first
/// centre at `origin`; odd rows are shifted by a/2 and rows are a√3/2 apart (one lattice
/// direction along x).
pub fn triangular_lattice(rows: usize, cols: usize, a: f64, origin: [f64; 2]) -> Vec<[f64; 2]> {
    let mut out = Vec::with_capacity(rows * cols);
    let dy = a * 3f64.sqrt() / 2.0;
    for r in 0..rows {
        let shift = if r % 2 == 1 { 0.5 * a } else { 0.0 };
        for c in 0..cols {
            out.push([origin[0] + shift + c as f64 * a, origin[1] + r as f64 * dy]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::{D2, D3};
    use rand::SeedableRng;

    #[test]
    fn a_zero_radius_or_an_infinite_box_is_refused_not_looped_on() {
        // the grid-sizing loop grows the cell by × 1.26 from the largest diameter: from 0, or in
        // a box of infinite length, it would never end
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let hi = glam::DVec2::new(10.0, 10.0);
        let e = random_gas::<D2>(&[0.0, 0.0], glam::DVec2::ZERO, hi, [true, true, false], &mut rng, 10).unwrap_err();
        assert!(e.to_string().contains("largest radius"), "{e}");
        let tall = glam::DVec2::new(10.0, f64::INFINITY);
        let e = random_gas::<D2>(&[0.5, 0.5], glam::DVec2::ZERO, tall, [false; 3], &mut rng, 10).unwrap_err();
        assert!(e.to_string().contains("finite length"), "{e}");
    }

    /// Checks a dense periodic gas pair by pair against the domain's minimum image (an
    /// independent all-pairs test, not the placement's cell search), in a still and in a sheared
    /// domain; returns the pairs that are within reach only through a periodic boundary (so that
    /// the test is known to look at images).
    fn check_gas<D: Dim>(hi: D::Vector, periodic: [bool; 3], n: usize, seed: u64) -> usize {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let radii: Vec<f64> = (0..n).map(|i| 0.5 + 0.1 * (i % 3) as f64).collect();
        let pos = random_gas::<D>(&radii, D::Vector::ZERO, hi, periodic, &mut rng, 100_000).unwrap();
        let mut domain = Domain::<D>::new(D::Vector::ZERO, hi, periodic);
        let mut through = 0;
        // a sheared cell needs periodic x and y
        let shears: &[f64] = if periodic[0] && periodic[1] { &[0.0, 0.3] } else { &[0.0] };
        for &shear in shears {
            if shear != 0.0 {
                domain.set_shear_rate(shear).unwrap();
                assert!(domain.is_sheared());
            }
            for i in 0..n {
                for k in 0..D::D {
                    let x = pos[i].get(k);
                    if periodic[k] {
                        assert!((0.0..hi.get(k)).contains(&x));
                    } else {
                        assert!(x >= radii[i] && x <= hi.get(k) - radii[i]);
                    }
                }
                for j in i + 1..n {
                    let reach = radii[i] + radii[j];
                    let d = domain.displacement(pos[i], pos[j]).norm2().sqrt();
                    assert!(d >= reach, "grains {i} and {j} overlap: distance {d} < {reach}");
                    if shear == 0.0 && d < reach + 0.5 && (pos[j] - pos[i]).norm2().sqrt() > reach + 0.5 {
                        through += 1;
                    }
                }
            }
        }
        through
    }

    #[test]
    fn random_gas_has_no_overlap_through_periodic_boundaries_2d() {
        // 220 disks of radii 0.5–0.7 in 30 × 20 (area fraction ≈ 0.42, below the random
        // sequential addition limit 0.55): many pairs close through the periodic x boundary,
        // walls along y
        let through = check_gas::<D2>(glam::DVec2::new(30.0, 20.0), [true, false, false], 220, 1);
        assert!(through > 5, "only {through} pairs near each other through the boundary");
        let through = check_gas::<D2>(glam::DVec2::new(20.0, 20.0), [true, true, false], 140, 2);
        assert!(through > 5, "only {through} pairs near each other through the boundaries");
    }

    #[test]
    fn random_gas_has_no_overlap_through_periodic_boundaries_3d() {
        // volume fraction ≈ 0.28 and 0.22 (random sequential addition limit 0.38)
        let through = check_gas::<D3>(glam::DVec3::new(8.0, 8.0, 8.0), [true, true, true], 150, 3);
        assert!(through > 5, "only {through} pairs near each other through the boundaries");
        let through = check_gas::<D3>(glam::DVec3::new(8.0, 8.0, 10.0), [true, true, false], 150, 4);
        assert!(through > 5, "only {through} pairs near each other through the boundaries");
    }
}
