//! Neighbor search: a cell list builds a Verlet half-list with a skin; per-pair contact history
//! lives in the list and is carried across rebuilds by stable id pair.
//!
//! The list is rebuilt when a grain has moved more than half the skin since the last build (or a
//! wall has moved so that a new grain–wall contact could have formed). Pairs are stored sorted by
//! storage index (i, j), i < j, and grain–wall candidates by (grain, wall): this fixed order is
//! what makes the per-grain force reduction — and therefore the whole run — independent of the
//! number of threads.

use crate::contact::ContactState;
use crate::dim::{Dim, VectorOps};
use crate::domain::Domain;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A grain–grain candidate pair (storage indices) with its contact state.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Pair<D: Dim> {
    /// First grain (storage index), i < j.
    pub i: u32,
    /// Second grain (storage index).
    pub j: u32,
    /// Contact history.
    pub state: ContactState<D>,
}

/// A grain–wall candidate with its contact state.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct WallPair<D: Dim> {
    /// Grain (storage index).
    pub grain: u32,
    /// Wall index in the domain.
    pub wall: u32,
    /// Contact history.
    pub state: ContactState<D>,
}

/// Verlet neighbor list with contact histories.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct NeighborList<D: Dim> {
    /// Skin distance added to the contact distance.
    pub skin: f64,
    /// Grain–grain candidates sorted by (i, j).
    pub pairs: Vec<Pair<D>>,
    /// Grain–wall candidates sorted by (grain, wall).
    pub wall_pairs: Vec<WallPair<D>>,
    /// Grain positions at the last build.
    pub ref_pos: Vec<D::Vector>,
    /// Wall positions at the last build.
    pub ref_wall_pos: Vec<D::Vector>,
    /// Number of builds so far.
    pub builds: u64,
    /// Force a rebuild at the next check (radii or domain changed).
    pub stale: bool,
}

/// Per-grain adjacency derived from the list (not stored in checkpoints: rebuilt on demand).
#[derive(Clone, Debug, Default)]
pub struct Adjacency {
    /// `start[g]..start[g+1]` indexes `entries` for grain g.
    pub start: Vec<u32>,
    /// `(pair_index << 1) | role`, role 0 when g is the pair's `i`, 1 when it is `j`; in pair order.
    pub entries: Vec<u32>,
    /// `wall_start[g]..wall_start[g+1]` are the grain's entries in `wall_pairs`.
    pub wall_start: Vec<u32>,
}

impl<D: Dim> NeighborList<D> {
    /// An empty list that will be built at the first check.
    pub fn new(skin: f64) -> Self {
        NeighborList {
            skin,
            pairs: Vec::new(),
            wall_pairs: Vec::new(),
            ref_pos: Vec::new(),
            ref_wall_pos: Vec::new(),
            builds: 0,
            stale: true,
        }
    }

    /// Number of pairs currently in contact.
    pub fn contact_count(&self) -> usize {
        self.pairs.iter().filter(|p| p.state.in_contact()).count()
            + self.wall_pairs.iter().filter(|p| p.state.in_contact()).count()
    }

    /// True when the list must be rebuilt before the next force evaluation.
    pub fn needs_rebuild(&self, pos: &[D::Vector], domain: &Domain<D>) -> bool {
        if self.stale || self.ref_pos.len() != pos.len() || self.ref_wall_pos.len() != domain.walls.len() {
            return true;
        }
        let max_d2 = pos
            .par_iter()
            .with_min_len(4096)
            .zip(self.ref_pos.par_iter())
            .map(|(&x, &r)| domain.displacement(r, x).norm2())
            // NaN-propagating max: a non-finite position forces a rebuild, whose checks report it
            .reduce(|| 0.0, |a, b| if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) });
        let max_d = max_d2.sqrt();
        if !(2.0 * max_d <= self.skin) {
            return true;
        }
        let max_wall = domain
            .walls
            .iter()
            .zip(&self.ref_wall_pos)
            .map(|(w, &r)| (w.position - r).dot(w.normal).abs())
            .fold(0.0, f64::max);
        max_d + max_wall > self.skin
    }

    /// Rebuilds the candidate lists from scratch with a cell list, carrying over the state of every
    /// pair that was in contact (matched by the stable ids `ids`).
    pub fn rebuild(&mut self, pos: &[D::Vector], radius: &[f64], ids: &[u32], domain: &Domain<D>) {
        let n = pos.len();
        // Old contacts keyed by stable ids.
        let mut old: Vec<((u32, u32), ContactState<D>)> = self
            .pairs
            .iter()
            .filter(|p| p.state.in_contact())
            .map(|p| {
                let (a, b) = (ids[p.i as usize], ids[p.j as usize]);
                ((a.min(b), a.max(b)), p.state)
            })
            .collect();
        old.sort_unstable_by_key(|e| e.0);
        let mut old_wall: Vec<((u32, u32), ContactState<D>)> = self
            .wall_pairs
            .iter()
            .filter(|p| p.state.in_contact())
            .map(|p| ((ids[p.grain as usize], p.wall), p.state))
            .collect();
        old_wall.sort_unstable_by_key(|e| e.0);

        let candidates = build_pairs(pos, radius, domain, self.skin);
        self.pairs = candidates
            .into_iter()
            .map(|(i, j)| {
                let (a, b) = (ids[i as usize], ids[j as usize]);
                let key = (a.min(b), a.max(b));
                let state = match old.binary_search_by_key(&key, |e| e.0) {
                    Ok(k) => old[k].1,
                    Err(_) => ContactState::default(),
                };
                Pair { i, j, state }
            })
            .collect();

        let mut wall_pairs = Vec::new();
        for g in 0..n {
            for (w, wall) in domain.walls.iter().enumerate() {
                if wall.distance(pos[g]) < radius[g] + self.skin {
                    let key = (ids[g], w as u32);
                    let state = match old_wall.binary_search_by_key(&key, |e| e.0) {
                        Ok(k) => old_wall[k].1,
                        Err(_) => ContactState::default(),
                    };
                    wall_pairs.push(WallPair { grain: g as u32, wall: w as u32, state });
                }
            }
        }
        self.wall_pairs = wall_pairs;
        self.ref_pos = pos.to_vec();
        self.ref_wall_pos = domain.walls.iter().map(|w| w.position).collect();
        self.builds += 1;
        self.stale = false;
    }

    /// Builds the per-grain adjacency of the current lists.
    pub fn adjacency(&self, n: usize) -> Adjacency {
        let mut count = vec![0u32; n + 1];
        for p in &self.pairs {
            count[p.i as usize + 1] += 1;
            count[p.j as usize + 1] += 1;
        }
        for g in 0..n {
            count[g + 1] += count[g];
        }
        let start = count.clone();
        let mut fill = count;
        let mut entries = vec![0u32; self.pairs.len() * 2];
        for (k, p) in self.pairs.iter().enumerate() {
            let k = k as u32;
            entries[fill[p.i as usize] as usize] = k << 1;
            fill[p.i as usize] += 1;
            entries[fill[p.j as usize] as usize] = (k << 1) | 1;
            fill[p.j as usize] += 1;
        }
        let mut wall_start = vec![0u32; n + 1];
        for wp in &self.wall_pairs {
            wall_start[wp.grain as usize + 1] += 1;
        }
        for g in 0..n {
            wall_start[g + 1] += wall_start[g];
        }
        Adjacency { start, entries, wall_start }
    }
}

/// Cell grid over the grains.
struct CellGrid {
    lo: [f64; 3],
    size: [f64; 3],
    n: [usize; 3],
    periodic: [bool; 3],
}

impl CellGrid {
    fn cell_of<V: VectorOps>(&self, x: V, dim: usize) -> [usize; 3] {
        let mut c = [0usize; 3];
        for k in 0..dim {
            let f = ((x.get(k) - self.lo[k]) / self.size[k]).floor();
            c[k] = if f.is_nan() || f < 0.0 { 0 } else { (f as usize).min(self.n[k] - 1) };
        }
        c
    }

    fn flat(&self, c: [usize; 3]) -> usize {
        (c[2] * self.n[1] + c[1]) * self.n[0] + c[0]
    }

    /// Distinct cells within one cell of `c` (wrapping periodic axes), sorted.
    fn neighbors(&self, c: [usize; 3], dim: usize, out: &mut Vec<usize>) {
        out.clear();
        let mut ranges: [Vec<usize>; 3] = [vec![0], vec![0], vec![0]];
        for k in 0..dim {
            let mut r = Vec::with_capacity(3);
            for off in [-1i64, 0, 1] {
                let v = c[k] as i64 + off;
                let n = self.n[k] as i64;
                if self.periodic[k] {
                    r.push(v.rem_euclid(n) as usize);
                } else if v >= 0 && v < n {
                    r.push(v as usize);
                }
            }
            r.sort_unstable();
            r.dedup();
            ranges[k] = r;
        }
        for &z in &ranges[2] {
            for &y in &ranges[1] {
                for &x in &ranges[0] {
                    out.push(self.flat([x, y, z]));
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

/// All pairs (i, j), i < j, with |r_ij| < R_i + R_j + skin, sorted by (i, j).
pub fn build_pairs<D: Dim>(pos: &[D::Vector], radius: &[f64], domain: &Domain<D>, skin: f64) -> Vec<(u32, u32)> {
    let n = pos.len();
    if n < 2 {
        return Vec::new();
    }
    let r_max = radius.iter().cloned().fold(0.0, f64::max);
    let cutoff = 2.0 * r_max + skin;
    let mut lo = [0.0; 3];
    let mut extent = [cutoff; 3];
    let mut periodic = [false; 3];
    for k in 0..D::D {
        if domain.is_periodic(k) {
            lo[k] = domain.lo.get(k);
            extent[k] = domain.length(k);
            periodic[k] = true;
        } else {
            let (mn, mx) = pos.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x.get(k)), b.max(x.get(k))));
            lo[k] = mn;
            extent[k] = (mx - mn).max(cutoff);
        }
    }
    // Cell edge ≥ cutoff; cap the cell count at a few per grain for sparse systems.
    let mut edge = cutoff;
    let cap = (4 * n).max(27);
    let mut counts = [1usize; 3];
    loop {
        let mut total = 1usize;
        for k in 0..D::D {
            counts[k] = ((extent[k] / edge).floor() as usize).max(1);
            total = total.saturating_mul(counts[k]);
        }
        if total <= cap {
            break;
        }
        edge *= 1.26;
    }
    let mut size = [1.0; 3];
    for k in 0..D::D {
        size[k] = extent[k] / counts[k] as f64;
    }
    let grid = CellGrid { lo, size, n: counts, periodic };
    let n_cells = counts[0] * counts[1] * counts[2];

    // Counting sort of grains into cells (grain order kept within a cell).
    let cell: Vec<usize> = pos.iter().map(|&x| grid.flat(grid.cell_of(x, D::D))).collect();
    let mut start = vec![0usize; n_cells + 1];
    for &c in &cell {
        start[c + 1] += 1;
    }
    for c in 0..n_cells {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut items = vec![0u32; n];
    for (g, &c) in cell.iter().enumerate() {
        items[fill[c]] = g as u32;
        fill[c] += 1;
    }

    const CHUNK: usize = 1024;
    let chunks: Vec<Vec<(u32, u32)>> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let mut out = Vec::new();
            let mut cells = Vec::with_capacity(27);
            let mut js: Vec<u32> = Vec::new();
            for i in chunk * CHUNK..((chunk + 1) * CHUNK).min(n) {
                let ci = grid.cell_of(pos[i], D::D);
                grid.neighbors(ci, D::D, &mut cells);
                js.clear();
                for &c in &cells {
                    for &j in &items[start[c]..start[c + 1]] {
                        if (j as usize) <= i {
                            continue;
                        }
                        let d = domain.displacement(pos[i], pos[j as usize]);
                        let reach = radius[i] + radius[j as usize] + skin;
                        if d.norm2() < reach * reach {
                            js.push(j);
                        }
                    }
                }
                js.sort_unstable();
                out.extend(js.iter().map(|&j| (i as u32, j)));
            }
            out
        })
        .collect();
    let total: usize = chunks.iter().map(Vec::len).sum();
    let mut pairs = Vec::with_capacity(total);
    for c in chunks {
        pairs.extend(c);
    }
    pairs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::{D2, D3};
    use glam::{DVec2, DVec3};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn brute<D: Dim>(pos: &[D::Vector], radius: &[f64], domain: &Domain<D>, skin: f64) -> Vec<(u32, u32)> {
        let mut v = Vec::new();
        for i in 0..pos.len() {
            for j in i + 1..pos.len() {
                let reach = radius[i] + radius[j] + skin;
                if domain.displacement(pos[i], pos[j]).norm2() < reach * reach {
                    v.push((i as u32, j as u32));
                }
            }
        }
        v
    }

    #[test]
    fn cell_list_matches_brute_force_2d_and_3d() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for periodic in [[true, true, true], [false, true, false], [false, false, false]] {
            let d2: Domain<D2> = Domain::new(DVec2::ZERO, DVec2::new(7.0, 5.0), periodic);
            let pos: Vec<DVec2> = (0..300).map(|_| DVec2::new(rng.random::<f64>() * 7.0, rng.random::<f64>() * 5.0)).collect();
            let rad: Vec<f64> = (0..300).map(|_| 0.1 + 0.2 * rng.random::<f64>()).collect();
            assert_eq!(build_pairs(&pos, &rad, &d2, 0.05), brute(&pos, &rad, &d2, 0.05));
            // small periodic box: fewer than 3 cells along an axis
            let d3: Domain<D3> = Domain::new(DVec3::ZERO, DVec3::new(1.3, 4.0, 2.0), periodic);
            let pos: Vec<DVec3> = (0..200)
                .map(|_| DVec3::new(rng.random::<f64>() * 1.3, rng.random::<f64>() * 4.0, rng.random::<f64>() * 2.0))
                .collect();
            let rad: Vec<f64> = (0..200).map(|_| 0.1 + 0.1 * rng.random::<f64>()).collect();
            assert_eq!(build_pairs(&pos, &rad, &d3, 0.1), brute(&pos, &rad, &d3, 0.1));
        }
    }
}
