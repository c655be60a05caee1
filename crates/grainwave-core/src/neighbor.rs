//! Neighbor search: a cell list builds a Verlet half-list with a skin; the per-pair contact
//! history is stored alongside it (structure of arrays, in list order) and carried across rebuilds
//! by stable id pair.
//!
//! **Layout.** Pair (i, j) is stored once, with i < j (storage indices), under grain i: the pairs
//! of grain i are `owner_start[i]..owner_start[i + 1]`, sorted by j. The contact history of pair
//! `p` is `spring[p]`, `overlap[p]`, … in the same order, so the force loop reads the list and the
//! histories as straight streams with no lookup. Grain–wall candidates are kept sorted by
//! (grain, wall).
//!
//! The list is rebuilt when a grain has moved more than half the skin since the last build (or a
//! wall has moved so that a new grain–wall contact could have formed).

use crate::contact::{ContactState, HistoryColumn, TangentialHistory, WallHistory};
use crate::dim::{Dim, VectorOps};
use crate::domain::{Domain, PeriodicImage};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A grain–grain candidate pair with its contact state, as returned by [`NeighborList::pairs`].
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Pair<D: Dim> {
    /// First grain (storage index), i < j: forces and histories are those acting on it.
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

/// The grain–grain half-list with the contact histories (see the module documentation).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct PairList<D: Dim> {
    /// Pairs of grain `i` (as the smaller index) are `owner_start[i]..owner_start[i + 1]`.
    pub(crate) owner_start: Vec<u32>,
    /// Partner grain (storage index, larger than the owner's) of each pair, sorted per owner.
    pub(crate) partner: Vec<u32>,
    /// Tangential history of each pair: the spring s (linear law) or the elastic force (Mindlin), on the owner.
    pub(crate) spring: Vec<TangentialHistory<<D as Dim>::Vector>>,
    /// Overlap at the last evaluation (0: not in contact).
    pub(crate) overlap: Vec<f64>,
    /// Sliding at the last evaluation.
    pub(crate) sliding: Vec<bool>,
    /// Rolling spring (on the owner).
    pub(crate) rolling: Vec<<D as Dim>::AngVector>,
    /// Twisting spring.
    pub(crate) twist: Vec<f64>,
    /// The law's own history of each pair ([`crate::contact::LawHistory`]; empty for laws
    /// without one), carried across rebuilds with the other histories.
    #[serde(default)]
    pub(crate) extra: HistoryColumn,
}

impl<D: Dim> PairList<D> {
    /// Number of candidate pairs.
    pub fn len(&self) -> usize {
        self.partner.len()
    }

    /// True when there is no candidate pair.
    pub fn is_empty(&self) -> bool {
        self.partner.is_empty()
    }

    /// Contact state of pair `p`.
    #[inline]
    pub(crate) fn state(&self, p: usize) -> ContactState<D> {
        ContactState {
            spring: self.spring[p],
            rolling: self.rolling[p],
            twist: self.twist[p],
            overlap: self.overlap[p],
            sliding: self.sliding[p],
        }
    }

    /// Every pair, sorted by (i, j).
    pub fn iter(&self) -> impl Iterator<Item = Pair<D>> + '_ {
        (0..self.owner_start.len().saturating_sub(1)).flat_map(move |i| {
            (self.owner_start[i] as usize..self.owner_start[i + 1] as usize).map(move |p| Pair { i: i as u32, j: self.partner[p], state: self.state(p) })
        })
    }

    /// The owner of pair `p`.
    pub(crate) fn owner_of(&self, p: usize) -> usize {
        self.owner_start.partition_point(|&s| s as usize <= p) - 1
    }
}

/// Verlet neighbor list with contact histories.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct NeighborList<D: Dim> {
    /// Skin distance added to the contact distance.
    pub skin: f64,
    /// Grain–grain candidates and their histories.
    pub list: PairList<D>,
    /// Grain–wall candidates sorted by (grain, wall).
    pub wall_pairs: Vec<WallPair<D>>,
    /// Grain positions at the last build.
    pub ref_pos: Vec<D::Vector>,
    /// Wall positions at the last build.
    pub ref_wall_pos: Vec<D::Vector>,
    /// Tilt factors of the periodic cell at the last build.
    pub ref_tilt: [f64; 3],
    /// Stable ids of the grains, in storage order, at the last build.
    pub ref_ids: Vec<u32>,
    /// Number of builds so far.
    pub builds: u64,
    /// Force a rebuild at the next check (radii or domain changed).
    pub stale: bool,
    /// The wall laws' own history of each grain–wall candidate ([`WallHistory`]; empty when no
    /// wall law keeps one), carried across rebuilds with the other grain–wall histories.
    #[serde(default)]
    pub(crate) wall_extra: WallHistory,
}

/// Per-grain index of the grain–wall candidates (not stored in checkpoints: rebuilt on demand).
#[derive(Clone, Debug, Default)]
pub struct WallIndex {
    /// `start[g]..start[g+1]` are the grain's entries in `wall_pairs`.
    pub start: Vec<u32>,
}

impl<D: Dim> NeighborList<D> {
    /// An empty list that will be built at the first check.
    pub fn new(skin: f64) -> Self {
        NeighborList {
            skin,
            list: PairList::default(),
            wall_pairs: Vec::new(),
            ref_pos: Vec::new(),
            ref_wall_pos: Vec::new(),
            ref_tilt: [0.0; 3],
            ref_ids: Vec::new(),
            builds: 0,
            stale: true,
            wall_extra: WallHistory::default(),
        }
    }

    /// Every grain–grain candidate pair with its state, sorted by (i, j).
    pub fn pairs(&self) -> impl Iterator<Item = Pair<D>> + '_ {
        self.list.iter()
    }

    /// Number of pairs currently in contact.
    pub fn contact_count(&self) -> usize {
        self.list.overlap.iter().filter(|&&o| o > 0.0).count() + self.wall_pairs.iter().filter(|p| p.state.in_contact()).count()
    }

    /// True when the list must be rebuilt before the next force evaluation. `max_displacement2`
    /// is the largest squared displacement of a grain since the last build, when the caller has
    /// it already (it is computed here otherwise).
    pub fn needs_rebuild(&self, pos: &[D::Vector], domain: &Domain<D>, max_displacement2: Option<f64>) -> bool {
        if self.stale || self.ref_pos.len() != pos.len() || self.ref_wall_pos.len() != domain.walls.len() {
            return true;
        }
        let max_d2 = max_displacement2.unwrap_or_else(|| max_displacement2_since(&self.ref_pos, pos, domain));
        let max_d = max_d2.sqrt();
        // In a shearing cell the images across a tilted boundary move with the tilt.
        let tilt_change: f64 = domain.tilt.iter().zip(&self.ref_tilt).map(|(t, r)| (t - r).abs()).sum();
        if !(2.0 * max_d + tilt_change <= self.skin) {
            return true;
        }
        let max_wall = domain
            .walls
            .iter()
            .zip(&self.ref_wall_pos)
            .map(|(w, &r)| (w.position - r).dot(w.normal).abs())
            .fold(0.0, nan_max);
        // negated: a NaN (a wall at a non-finite position) forces a rebuild, whose checks report it
        !(max_d + max_wall <= self.skin)
    }

    /// Rebuilds the candidate lists from scratch with a cell list, carrying over the state of every
    /// pair that was in contact (matched by the stable ids `ids`).
    pub fn rebuild(&mut self, pos: &[D::Vector], radius: &[f64], ids: &[u32], domain: &Domain<D>) {
        let n = pos.len();
        let mut list = build_list::<D>(pos, radius, domain, self.skin);
        let old = &self.list;
        if self.ref_ids.as_slice() == ids {
            // Same grains in the same storage order: both lists are sorted by (i, j); merge them,
            // in parallel over chunks of owners (each pair's state is set on its own).
            let m = n.min(old.owner_start.len().saturating_sub(1));
            let parts = owner_parts(&list.owner_start[..=m], OWNER_CHUNK);
            let mut spring = split_parts(&mut list.spring, &parts).into_iter();
            let mut overlap = split_parts(&mut list.overlap, &parts).into_iter();
            let mut sliding = split_parts(&mut list.sliding, &parts).into_iter();
            let mut rolling = split_parts(&mut list.rolling, &parts).into_iter();
            let mut twist = split_parts(&mut list.twist, &parts).into_iter();
            let jobs: Vec<_> = parts
                .iter()
                .map(|(g, p)| (g.clone(), p.start, spring.next().unwrap(), overlap.next().unwrap(), sliding.next().unwrap(), rolling.next().unwrap(), twist.next().unwrap()))
                .collect();
            let (new_start, new_partner) = (&list.owner_start, &list.partner);
            jobs.into_par_iter().for_each(|(grains, first, spring, overlap, sliding, rolling, twist)| {
                for i in grains {
                    let (mut o, o_end) = (old.owner_start[i] as usize, old.owner_start[i + 1] as usize);
                    for p in new_start[i] as usize..new_start[i + 1] as usize {
                        let j = new_partner[p];
                        while o < o_end && old.partner[o] < j {
                            o += 1;
                        }
                        if o < o_end && old.partner[o] == j {
                            let q = p - first;
                            spring[q] = old.spring[o];
                            overlap[q] = old.overlap[o];
                            sliding[q] = old.sliding[o];
                            rolling[q] = old.rolling[o];
                            twist[q] = old.twist[o];
                        }
                    }
                }
            });
            if old.extra.is_stored() {
                // the law's own history: where each new pair's entry comes from, by the same
                // merge (a pass of its own, so that the merge above is that of the laws without)
                let mut from = vec![(u32::MAX, false); list.partner.len()];
                for i in 0..m {
                    let (mut o, o_end) = (old.owner_start[i] as usize, old.owner_start[i + 1] as usize);
                    for p in list.owner_start[i] as usize..list.owner_start[i + 1] as usize {
                        let j = list.partner[p];
                        while o < o_end && old.partner[o] < j {
                            o += 1;
                        }
                        if o < o_end && old.partner[o] == j {
                            from[p] = (o as u32, false);
                        }
                    }
                }
                list.extra = old.extra.remap(&from);
            }
        } else {
            // Grains added, removed or reordered: match contacts by stable id pair (smaller id
            // first), with the orientation they were stored in (histories act on the grain of
            // smaller storage index).
            let ref_ids = &self.ref_ids;
            let mut carried: Vec<(u64, bool, ContactState<D>, u32)> = old
                .iter()
                .enumerate()
                .filter(|(_, p)| p.state.in_contact() && (p.i as usize) < ref_ids.len() && (p.j as usize) < ref_ids.len())
                .map(|(k, p)| {
                    let (a, b) = (ref_ids[p.i as usize], ref_ids[p.j as usize]);
                    (id_key(a, b), a < b, p.state, k as u32)
                })
                .collect();
            let mut from = if old.extra.is_stored() { vec![(u32::MAX, false); list.partner.len()] } else { Vec::new() };
            carried.sort_unstable_by_key(|e| e.0);
            if !carried.is_empty() {
                for i in 0..n {
                    let a = ids[i];
                    for p in list.owner_start[i] as usize..list.owner_start[i + 1] as usize {
                        let b = ids[list.partner[p] as usize];
                        if let Ok(e) = carried.binary_search_by_key(&id_key(a, b), |e| e.0) {
                            let (_, stored_ascending, mut s, o) = carried[e];
                            if let Some(f) = from.get_mut(p) {
                                *f = (o, stored_ascending != (a < b));
                            }
                            if stored_ascending != (a < b) {
                                // the storage order of the two grains changed: histories act on the other one
                                s.spring = -s.spring;
                                s.rolling = -s.rolling;
                            }
                            list.spring[p] = s.spring;
                            list.overlap[p] = s.overlap;
                            list.sliding[p] = s.sliding;
                            list.rolling[p] = s.rolling;
                            list.twist[p] = s.twist;
                        }
                    }
                }
            }
            list.extra = old.extra.remap(&from);
        }
        let ref_ids = if self.ref_ids.is_empty() { ids } else { &self.ref_ids };
        // (key, state, index in the old list) of the grain–wall contacts
        let mut old_wall: Vec<((u32, u32), ContactState<D>, u32)> = self
            .wall_pairs
            .iter()
            .enumerate()
            .filter(|(_, p)| p.state.in_contact() && (p.grain as usize) < ref_ids.len())
            .map(|(k, p)| ((ref_ids[p.grain as usize], p.wall), p.state, k as u32))
            .collect();
        old_wall.sort_unstable_by_key(|e| e.0);
        self.list = list;

        let mut wall_pairs = Vec::new();
        // where each new wall pair's law history comes from (only when a wall law keeps one)
        let carry = self.wall_extra.is_stored();
        let mut from = Vec::new();
        for g in 0..n {
            for (w, wall) in domain.walls.iter().enumerate() {
                if wall.distance(pos[g]) < radius[g] + self.skin {
                    let key = (ids[g], w as u32);
                    let (state, old) = match old_wall.binary_search_by_key(&key, |e| e.0) {
                        Ok(k) => (old_wall[k].1, old_wall[k].2),
                        Err(_) => (ContactState::default(), u32::MAX),
                    };
                    wall_pairs.push(WallPair { grain: g as u32, wall: w as u32, state });
                    if carry {
                        from.push((old, false));
                    }
                }
            }
        }
        if carry {
            self.wall_extra = self.wall_extra.remap(&from);
        }
        self.wall_pairs = wall_pairs;
        self.ref_pos = pos.to_vec();
        self.ref_wall_pos = domain.walls.iter().map(|w| w.position).collect();
        self.ref_tilt = domain.tilt;
        self.ref_ids.clear();
        self.ref_ids.extend_from_slice(ids);
        self.builds += 1;
        self.stale = false;
    }

    /// Builds the per-grain index of the grain–wall candidates.
    pub fn wall_index(&self, n: usize) -> WallIndex {
        let mut start = vec![0u32; n + 1];
        for wp in &self.wall_pairs {
            start[wp.grain as usize + 1] += 1;
        }
        for g in 0..n {
            start[g + 1] += start[g];
        }
        WallIndex { start }
    }
}

/// Key of an unordered id pair.
#[inline]
fn id_key(a: u32, b: u32) -> u64 {
    ((a.min(b) as u64) << 32) | a.max(b) as u64
}

/// Largest squared displacement (nearest image) between `reference` and `pos`; NaN when a
/// position is not finite.
pub fn max_displacement2_since<D: Dim>(reference: &[D::Vector], pos: &[D::Vector], domain: &Domain<D>) -> f64 {
    let image = domain.image();
    pos.par_chunks(4096)
        .zip(reference.par_chunks(4096))
        .map(|(x, r)| max_displacement2(&image, r, x))
        // NaN-propagating max: a non-finite position forces a rebuild, whose checks report it
        .reduce(|| 0.0, nan_max)
}

/// Largest squared nearest-image displacement from `reference` to `pos` (as a fold of
/// [`nan_max`] from 0: NaN when any is NaN), without a branch per grain: four running maxima
/// (`x > m ? x : m`, which skips NaN) and a separate NaN flag, so the loop vectorizes. The maximum
/// of the same values, so the same bits as the fold.
#[inline]
pub(crate) fn max_displacement2<D: Dim>(image: &PeriodicImage<D>, reference: &[D::Vector], pos: &[D::Vector]) -> f64 {
    const L: usize = 4;
    let (mut m, mut nan) = ([0.0f64; L], [false; L]);
    let n = reference.len().min(pos.len());
    let (mut reference, mut pos) = (&reference[..n], &pos[..n]);
    #[cfg(target_arch = "x86_64")]
    let mut wide = 0.0;
    #[cfg(target_arch = "x86_64")]
    if D::D == 3 && !image.sheared && std::mem::size_of::<D::Vector>() == 24 && n >= 8 && std::arch::is_x86_feature_detected!("avx512f") {
        // eight grains at a time (the same operations), the rest below
        let split = n - n % 8;
        let (period, inverse) = image.lengths_and_inverses();
        // SAFETY: AVX-512 F is available; D::Vector is three f64 here (3D, 24 bytes), so the
        // first `split` grains are 3·split consecutive f64.
        wide = unsafe { max_displacement2_3d_avx512(period, inverse, reference.as_ptr() as *const f64, pos.as_ptr() as *const f64, split) };
        (reference, pos) = (&reference[split..], &pos[split..]);
    }
    let n = pos.len();
    let split = n - n % L;
    for (r, x) in reference[..split].chunks_exact(L).zip(pos[..split].chunks_exact(L)) {
        for l in 0..L {
            let d2 = image.displacement(r[l], x[l]).norm2();
            m[l] = if d2 > m[l] { d2 } else { m[l] };
            nan[l] |= d2.is_nan();
        }
    }
    for k in split..n {
        let d2 = image.displacement(reference[k], pos[k]).norm2();
        m[0] = if d2 > m[0] { d2 } else { m[0] };
        nan[0] |= d2.is_nan();
    }
    if nan.iter().any(|&b| b) {
        return f64::NAN;
    }
    let m = m.iter().fold(0.0, |a, &b| if b > a { b } else { a });
    #[cfg(target_arch = "x86_64")]
    let m = nan_max(m, wide);
    m
}

/// [`max_displacement2`] of `n` (a multiple of 8) grains in 3D in a cell that is not sheared,
/// eight at a time with AVX-512: the same operations on each coordinate (on the interleaved
/// rows: x, y, z of each grain), then the squares summed x, y, z; NaN when any is NaN.
///
/// # Safety
/// `reference` and `pos` point to `3 n` f64; AVX-512 F is available.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f")]
unsafe fn max_displacement2_3d_avx512(period: [f64; 3], inverse: [f64; 3], reference: *const f64, pos: *const f64, n: usize) -> f64 {
    use crate::domain::nearest_image_axis;
    use crate::simd512::{deinterleave3, per_coordinate, Wide8};
    use std::arch::x86_64::*;
    assert!(n % 8 == 0, "max_displacement2_3d_avx512: {n} grains, not a multiple of 8");
    // SAFETY: the caller's contract.
    unsafe {
        let (per, inv) = (per_coordinate(period), per_coordinate(inverse));
        let (mut m, mut nan) = (_mm512_setzero_pd(), 0u8);
        for k in (0..3 * n).step_by(24) {
            let mut sq = [_mm512_setzero_pd(); 3];
            for r in 0..3 {
                let d = _mm512_sub_pd(_mm512_loadu_pd(pos.add(k + 8 * r)), _mm512_loadu_pd(reference.add(k + 8 * r)));
                // the domain's minimum image, with the cell length of each lane's coordinate
                let d = nearest_image_axis(Wide8(d), Wide8(per[r]), Wide8(inv[r])).0 .0;
                sq[r] = _mm512_mul_pd(d, d);
            }
            // squares of x, y, z of the eight grains
            let [x, y, z] = deinterleave3(sq[0], sq[1], sq[2]);
            let d2 = _mm512_add_pd(_mm512_add_pd(x, y), z);
            // d2 > m ? d2 : m (skips NaN), and the NaN flag
            m = _mm512_max_pd(d2, m);
            nan |= _mm512_cmp_pd_mask::<_CMP_UNORD_Q>(d2, d2);
        }
        if nan != 0 {
            return f64::NAN;
        }
        let mut lanes = [0.0; 8];
        _mm512_storeu_pd(lanes.as_mut_ptr(), m);
        lanes.iter().fold(0.0, |a, &b| if b > a { b } else { a })
    }
}

/// max(a, b), NaN when either is NaN.
#[inline]
pub fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Owners per parallel work item of the passes over the pair list at a rebuild.
const OWNER_CHUNK: usize = 2048;

/// Consecutive chunks of at most `chunk` owners of a list with `owner_start` (one more entry than
/// owners): the owners and their pairs.
fn owner_parts(owner_start: &[u32], chunk: usize) -> Vec<(std::ops::Range<usize>, std::ops::Range<usize>)> {
    let n = owner_start.len().saturating_sub(1);
    (0..n.div_ceil(chunk))
        .map(|c| {
            let g = c * chunk..((c + 1) * chunk).min(n);
            (g.clone(), owner_start[g.start] as usize..owner_start[g.end] as usize)
        })
        .collect()
}

/// The pieces of `data` holding the pairs of each part (consecutive, from the start).
fn split_parts<'a, T>(mut data: &'a mut [T], parts: &[(std::ops::Range<usize>, std::ops::Range<usize>)]) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(parts.len());
    let mut at = parts.first().map_or(0, |p| p.1.start);
    data = &mut data[at..];
    for (_, pairs) in parts {
        // the parts must be consecutive, or pairs would be handed to the wrong owners
        assert_eq!(pairs.start, at, "split_parts: parts not consecutive");
        let (head, tail) = std::mem::take(&mut data).split_at_mut(pairs.end - at);
        out.push(head);
        data = tail;
        at = pairs.end;
    }
    out
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

    /// The cell at offset `o` (each component −1, 0 or 1) from cell `c`, wrapped along
    /// periodic axes (by a comparison: one step off the grid at most); `None` past a
    /// non-periodic edge.
    #[inline(always)]
    fn offset_cell(&self, c: [usize; 3], o: [i64; 3]) -> Option<usize> {
        let mut nc = [0usize; 3];
        for k in 0..3 {
            let raw = c[k] as i64 + o[k];
            let w = self.n[k] as i64;
            let v = if raw < 0 {
                raw + w
            } else if raw >= w {
                raw - w
            } else {
                raw
            };
            if v != raw && !self.periodic[k] {
                return None;
            }
            nc[k] = v as usize;
        }
        Some(self.flat(nc))
    }

    /// Distinct coordinates within one cell of `c` along axis `k` (wrapping periodic axes), sorted.
    fn range(&self, c: usize, k: usize) -> ([usize; 3], usize) {
        let mut r = [0usize; 3];
        let mut len = 0;
        let n = self.n[k] as i64;
        for off in [-1i64, 0, 1] {
            let v = c as i64 + off;
            let v = if self.periodic[k] {
                v.rem_euclid(n)
            } else if v >= 0 && v < n {
                v
            } else {
                continue;
            };
            if !r[..len].contains(&(v as usize)) {
                r[len] = v as usize;
                len += 1;
            }
        }
        r[..len].sort_unstable();
        (r, len)
    }

    /// Cells within one cell of `c` in every axis but `fixed`, whose coordinate is `layer`
    /// (`fixed` = 3: no fixed axis), sorted.
    fn neighbors(&self, c: [usize; 3], dim: usize, fixed: usize, layer: usize, out: &mut Vec<usize>) {
        out.clear();
        let mut ranges = [([0usize; 3], 1usize); 3];
        for (k, range) in ranges.iter_mut().enumerate().take(dim) {
            *range = if k == fixed { ([layer, 0, 0], 1) } else { self.range(c[k], k) };
        }
        for &z in &ranges[2].0[..ranges[2].1] {
            for &y in &ranges[1].0[..ranges[1].1] {
                for &x in &ranges[0].0[..ranges[0].1] {
                    out.push(self.flat([x, y, z]));
                }
            }
        }
        out.sort_unstable();
    }
}

/// Builds the half-list (histories at zero) of all pairs with |r_ij| < R_i + R_j + skin.
fn build_list<D: Dim>(pos: &[D::Vector], radius: &[f64], domain: &Domain<D>, skin: f64) -> PairList<D> {
    let n = pos.len();
    let mut list = PairList::<D> { owner_start: vec![0; n + 1], ..Default::default() };
    if n < 2 {
        return list;
    }
    let r_max = radius.iter().cloned().fold(0.0, f64::max);
    let cutoff = 2.0 * r_max + skin;
    let image = domain.image();
    let sheared = domain.is_sheared();
    // Along periodic axes of a sheared cell, cells are laid out in fractional coordinates; their
    // count follows from the widths of the cell across its faces.
    let widths = if sheared { image.face_widths() } else { [0.0; 3] };
    let mut lo = [0.0; 3];
    let mut extent = [cutoff; 3];
    let mut periodic = [false; 3];
    for k in 0..D::D {
        if domain.is_periodic(k) {
            lo[k] = domain.lo.get(k);
            extent[k] = if sheared { widths[k] } else { domain.length(k) };
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
    let cell: Vec<[usize; 3]> = if sheared {
        pos.iter()
            .map(|&x| {
                let s = image.fractional(x, domain.lo);
                let mut c = grid.cell_of(x, D::D);
                for k in 0..D::D {
                    if periodic[k] {
                        // a grain wrapped in the cell of an earlier tilt may lie just outside
                        let f = ((s[k] - s[k].floor()) * counts[k] as f64).floor();
                        c[k] = if f.is_nan() || f < 0.0 { 0 } else { (f as usize).min(counts[k] - 1) };
                    }
                }
                c
            })
            .collect()
    } else {
        pos.iter().map(|&x| grid.cell_of(x, D::D)).collect()
    };
    let mut start = vec![0usize; n_cells + 1];
    for c in &cell {
        start[grid.flat(*c) + 1] += 1;
    }
    for c in 0..n_cells {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut items = vec![0u32; n];
    for (g, c) in cell.iter().enumerate() {
        let f = grid.flat(*c);
        items[fill[f]] = g as u32;
        fill[f] += 1;
    }

    let reach = |i: usize, j: usize| {
        let d = image.displacement(pos[i], pos[j]);
        let r = radius[i] + radius[j] + skin;
        d.norm2() < r * r
    };
    // Minimal stencil: every pair of neighbouring cells is visited once, from the cell that comes
    // first in (z, y, x) order (13 forward neighbours in 3D, 4 in 2D, plus the cell itself). It
    // needs at least three cells along every periodic axis (fewer and a neighbour would be seen
    // through both sides); otherwise every grain scans all its neighbouring cells for larger indices.
    let half = (0..D::D).all(|k| !periodic[k] || counts[k] >= 3);
    let mut forward: Vec<[i64; 3]> = Vec::new();
    for dz in -1..=1i64 {
        for dy in -1..=1i64 {
            for dx in -1..=1i64 {
                let o = [dx, dy, dz];
                if (0..3).all(|k| k < D::D || o[k] == 0) && (dz, dy, dx) > (0, 0, 0) {
                    forward.push(o);
                }
            }
        }
    }
    const CHUNK: usize = 256;
    // 3D cells that are not sheared, on AVX-512: the grains in cell order as coordinate
    // arrays, and eight candidates at a time (`wide_cells`, the same pairs)
    #[cfg(target_arch = "x86_64")]
    let wide = (D::D == 3 && !sheared && half && std::mem::size_of::<D::Vector>() == 24 && n < u32::MAX as usize)
        .then(|| std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl"))
        .unwrap_or(false)
        .then(|| {
            let mut slots = CellOrder { x: Vec::with_capacity(n), y: Vec::with_capacity(n), z: Vec::with_capacity(n), r: Vec::with_capacity(n) };
            for &g in &items {
                let (x, g) = (pos[g as usize], g as usize);
                slots.x.push(x.get(0));
                slots.y.push(x.get(1));
                slots.z.push(x.get(2));
                slots.r.push(radius[g]);
            }
            slots
        });
    let found: Vec<Vec<(u32, u32)>> = (0..n_cells.div_ceil(CHUNK))
        .into_par_iter()
        .map(|chunk| {
            let mut out = Vec::new();
            let cells_here = chunk * CHUNK..((chunk + 1) * CHUNK).min(n_cells);
            #[cfg(target_arch = "x86_64")]
            if let Some(slots) = &wide {
                let (length, inverse) = image.lengths_and_inverses();
                let geometry = WideGeometry { grid: &grid, forward: &forward, length, inverse, skin };
                // SAFETY: AVX-512 F and VL are available (checked above); the slot arrays and
                // `items` hold the n grains in cell order, `start` the cells' slot ranges.
                unsafe { wide_cells(cells_here, &geometry, &start, &items, slots, &mut out) };
                return out;
            }
            let mut cells = Vec::with_capacity(27);
            for c in cells_here {
                let here = &items[start[c]..start[c + 1]];
                if here.is_empty() {
                    continue;
                }
                let cc = [c % counts[0], (c / counts[0]) % counts[1], c / (counts[0] * counts[1])];
                if half {
                    for (a, &i) in here.iter().enumerate() {
                        for &j in &here[a + 1..] {
                            if reach(i as usize, j as usize) {
                                out.push((i.min(j), i.max(j)));
                            }
                        }
                    }
                    for &o in &forward {
                        let Some(f) = grid.offset_cell(cc, o) else {
                            continue;
                        };
                        for &i in here {
                            for &j in &items[start[f]..start[f + 1]] {
                                if reach(i as usize, j as usize) {
                                    out.push((i.min(j), i.max(j)));
                                }
                            }
                        }
                    }
                } else {
                    grid.neighbors(cc, D::D, 3, 0, &mut cells);
                    for &i in here {
                        for &nc in &cells {
                            for &j in &items[start[nc]..start[nc + 1]] {
                                if j > i && reach(i as usize, j as usize) {
                                    out.push((i, j));
                                }
                            }
                        }
                    }
                }
            }
            out
        })
        .collect();
    // Group by owner (the smaller index), partners sorted: a counting sort, then small sorts.
    let total: usize = found.iter().map(Vec::len).sum();
    for v in &found {
        for &(i, _) in v {
            list.owner_start[i as usize + 1] += 1;
        }
    }
    for i in 0..n {
        list.owner_start[i + 1] += list.owner_start[i];
    }
    let mut fill: Vec<u32> = list.owner_start[..n].to_vec();
    list.partner = vec![0; total];
    for v in &found {
        for &(i, j) in v {
            list.partner[fill[i as usize] as usize] = j;
            fill[i as usize] += 1;
        }
    }
    // each owner's partners in increasing order, in parallel over chunks of owners
    let parts = owner_parts(&list.owner_start, OWNER_CHUNK);
    let owner_start = &list.owner_start;
    split_parts(&mut list.partner, &parts).into_par_iter().zip(parts.par_iter()).for_each(|(partner, (grains, pairs))| {
        for i in grains.clone() {
            partner[owner_start[i] as usize - pairs.start..owner_start[i + 1] as usize - pairs.start].sort_unstable();
        }
    });
    let m = list.len();
    list.spring = vec![TangentialHistory::ZERO; m];
    list.overlap = vec![0.0; m];
    list.sliding = vec![false; m];
    list.rolling = vec![D::AngVector::ZERO; m];
    list.twist = vec![0.0; m];
    list
}

/// Grains in cell order (slot s holds grain `items[s]`): positions and radii as arrays.
#[cfg(target_arch = "x86_64")]
struct CellOrder {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    r: Vec<f64>,
}

/// What [`wide_cells`] needs of the cell grid and the periodic cell.
#[cfg(target_arch = "x86_64")]
struct WideGeometry<'a> {
    grid: &'a CellGrid,
    forward: &'a [[i64; 3]],
    length: [f64; 3],
    inverse: [f64; 3],
    skin: f64,
}

/// The pairs of [`build_list`]'s minimal stencil for the cells `cells` (3D, cell not sheared, at
/// least three cells along every periodic axis), eight candidates at a time: each grain of a
/// cell against the later grains of its cell and the grains of its forward cells, read as runs of
/// consecutive slots (neighbouring cells along x are consecutive in cell order, so the 13 forward
/// cells make about five runs). Every candidate gets the operations of the element-wise test
/// (`PeriodicImage::displacement` from the cell's grain to the candidate, |d|² summed x, y, z,
/// `|d|² < (rᵢ + rⱼ + skin)²`), so the same pairs are found; they are appended to `out` as
/// (smaller, larger) grain index, in an order the caller does not rely on.
///
/// # Safety
/// AVX-512 F and VL are available; `slots` and `items` have one entry per grain, `start` one
/// more than cells.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl,popcnt")]
unsafe fn wide_cells(cells: std::ops::Range<usize>, geo: &WideGeometry<'_>, start: &[usize], items: &[u32], slots: &CellOrder, out: &mut Vec<(u32, u32)>) {
    use crate::domain::nearest_image_axis;
    use crate::simd512::{first_lanes, Wide8};
    use std::arch::x86_64::*;
    let WideGeometry { grid, forward, length, inverse, skin } = *geo;
    let counts = grid.n;
    // SAFETY: the caller's contract; every slot read lies below n (runs come from `start`).
    unsafe {
        let (lx, ly, lz) = (_mm512_set1_pd(length[0]), _mm512_set1_pd(length[1]), _mm512_set1_pd(length[2]));
        let (ix, iy, iz) = (_mm512_set1_pd(inverse[0]), _mm512_set1_pd(inverse[1]), _mm512_set1_pd(inverse[2]));
        let skin_v = _mm512_set1_pd(skin);
        let (sx, sy, sz, sr, sid) = (slots.x.as_ptr(), slots.y.as_ptr(), slots.z.as_ptr(), slots.r.as_ptr(), items.as_ptr());
        let mut hits = [0u32; 8];
        for c in cells {
            let (hs, he) = (start[c], start[c + 1]);
            if hs == he {
                continue;
            }
            let cc = [c % counts[0], (c / counts[0]) % counts[1], c / (counts[0] * counts[1])];
            // the forward cells in cell order, then their slots as merged runs
            let mut nb = [0usize; 13];
            let mut m = 0;
            for &o in forward {
                if let Some(f) = grid.offset_cell(cc, o) {
                    nb[m] = f;
                    m += 1;
                }
            }
            nb[..m].sort_unstable();
            let mut runs = [(0usize, 0usize); 14];
            let mut nr = 0;
            for &f in &nb[..m] {
                let (s, e) = (start[f], start[f + 1]);
                if s == e {
                    continue;
                }
                if nr > 0 && runs[nr - 1].1 == s {
                    runs[nr - 1].1 = e;
                } else {
                    runs[nr] = (s, e);
                    nr += 1;
                }
            }
            // the cell's own later grains join the first run when it follows the cell
            let joined = nr > 0 && runs[0].0 == he;
            for a in hs..he {
                let i = *sid.add(a);
                let (xi, yi, zi, ri) = (_mm512_set1_pd(*sx.add(a)), _mm512_set1_pd(*sy.add(a)), _mm512_set1_pd(*sz.add(a)), _mm512_set1_pd(*sr.add(a)));
                let own = (a + 1, if joined { runs[0].1 } else { he });
                let rest = &runs[joined as usize..nr];
                for &(s, e) in std::iter::once(&own).chain(rest) {
                    let mut k = s;
                    while k < e {
                        let live = first_lanes(e - k);
                        let dx = _mm512_sub_pd(_mm512_maskz_loadu_pd(live, sx.add(k)), xi);
                        let dy = _mm512_sub_pd(_mm512_maskz_loadu_pd(live, sy.add(k)), yi);
                        let dz = _mm512_sub_pd(_mm512_maskz_loadu_pd(live, sz.add(k)), zi);
                        // the domain's minimum image along each axis (the cell is not sheared here)
                        let dx = nearest_image_axis(Wide8(dx), Wide8(lx), Wide8(ix)).0 .0;
                        let dy = nearest_image_axis(Wide8(dy), Wide8(ly), Wide8(iy)).0 .0;
                        let dz = nearest_image_axis(Wide8(dz), Wide8(lz), Wide8(iz)).0 .0;
                        let d2 = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy)), _mm512_mul_pd(dz, dz));
                        let reach = _mm512_add_pd(_mm512_add_pd(ri, _mm512_maskz_loadu_pd(live, sr.add(k))), skin_v);
                        let hit = _mm512_mask_cmp_pd_mask::<_CMP_LT_OQ>(live, d2, _mm512_mul_pd(reach, reach));
                        if hit != 0 {
                            let ids = _mm256_maskz_loadu_epi32(live, sid.add(k) as *const i32);
                            _mm256_mask_compressstoreu_epi32(hits.as_mut_ptr() as *mut i32, hit, ids);
                            for &j in &hits[..hit.count_ones() as usize] {
                                out.push((i.min(j), i.max(j)));
                            }
                        }
                        k += 8;
                    }
                }
            }
        }
    }
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

    /// `n` grains uniform in the box [0, size), then their radii uniform in [0.1, 0.2).
    fn random_3d(rng: &mut ChaCha8Rng, n: usize, size: DVec3) -> (Vec<DVec3>, Vec<f64>) {
        let pos = (0..n).map(|_| DVec3::new(rng.random::<f64>() * size.x, rng.random::<f64>() * size.y, rng.random::<f64>() * size.z)).collect();
        let rad = (0..n).map(|_| 0.1 + 0.1 * rng.random::<f64>()).collect();
        (pos, rad)
    }

    /// Every pair once, sorted.
    fn check<D: Dim>(pos: &[D::Vector], radius: &[f64], domain: &Domain<D>, skin: f64) {
        let list = build_list(pos, radius, domain, skin);
        let found: Vec<(u32, u32)> = list.iter().map(|p| (p.i, p.j)).collect();
        assert_eq!(found, brute(pos, radius, domain, skin));
    }

    #[test]
    fn cell_list_matches_brute_force_2d_and_3d() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for periodic in [[true, true, true], [false, true, false], [false, false, false], [true, false, true]] {
            let d2: Domain<D2> = Domain::new(DVec2::ZERO, DVec2::new(7.0, 5.0), periodic);
            let pos: Vec<DVec2> = (0..300).map(|_| DVec2::new(rng.random::<f64>() * 7.0, rng.random::<f64>() * 5.0)).collect();
            let rad: Vec<f64> = (0..300).map(|_| 0.1 + 0.2 * rng.random::<f64>()).collect();
            check(&pos, &rad, &d2, 0.05);
            // small periodic box: fewer than 3 cells along an axis
            let d3: Domain<D3> = Domain::new(DVec3::ZERO, DVec3::new(1.3, 4.0, 2.0), periodic);
            let (pos, rad) = random_3d(&mut rng, 200, DVec3::new(1.3, 4.0, 2.0));
            check(&pos, &rad, &d3, 0.1);
        }
        // sheared cells: x–y tilt (2D and 3D), and all three tilts in 3D, beyond half a cell
        for tilt in [[1.7, 0.0, 0.0], [-3.2, 0.0, 0.0], [2.9, -1.3, 0.8]] {
            let mut d2: Domain<D2> = Domain::new(DVec2::ZERO, DVec2::new(7.0, 5.0), [true, true, false]);
            d2.tilt = [tilt[0], 0.0, 0.0];
            let pos: Vec<DVec2> = (0..300).map(|_| DVec2::new(rng.random::<f64>() * 7.0, rng.random::<f64>() * 5.0)).collect();
            let pos: Vec<DVec2> = pos.into_iter().map(|mut x| {
                d2.wrap(&mut x, &mut [0; 3]);
                x
            }).collect();
            let rad: Vec<f64> = (0..300).map(|_| 0.1 + 0.2 * rng.random::<f64>()).collect();
            check(&pos, &rad, &d2, 0.05);
            let mut d3: Domain<D3> = Domain::new(DVec3::ZERO, DVec3::new(4.0, 3.5, 4.5), [true; 3]);
            d3.tilt = tilt;
            let pos: Vec<DVec3> = (0..400)
                .map(|_| {
                    let mut x = DVec3::new(rng.random::<f64>() * 4.0, rng.random::<f64>() * 3.5, rng.random::<f64>() * 4.5);
                    d3.wrap(&mut x, &mut [0; 3]);
                    x
                })
                .collect();
            let rad: Vec<f64> = (0..400).map(|_| 0.1 + 0.1 * rng.random::<f64>()).collect();
            check(&pos, &rad, &d3, 0.1);
        }
    }

    /// 3D boxes with at least three cells along every axis, where the candidates go eight at a
    /// time through AVX-512 when the processor has it (`wide_cells`): random polydisperse
    /// grains, periodic and walled axes, and a lattice whose spacing is exactly the reach
    /// (r_i + r_j + skin), so that every decision at the boundary — across the periodic faces
    /// too — must be the element-wise one (a `≤` instead of `<`, or a different rounding of the
    /// image shift, adds or drops pairs).
    #[test]
    fn wide_cell_search_matches_brute_force_3d() {
        crate::util::avx512_or_skip("wide_cell_search_matches_brute_force_3d: the AVX-512 cell search not run (the element-wise one is checked)");
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for periodic in [[true; 3], [true, true, false], [false, true, true]] {
            let dom: Domain<D3> = Domain::new(DVec3::ZERO, DVec3::new(5.0, 4.5, 6.0), periodic);
            let (pos, rad) = random_3d(&mut rng, 1500, DVec3::new(5.0, 4.5, 6.0));
            check(&pos, &rad, &dom, 0.1);
            // simple cubic lattice of spacing 0.5 = 0.2 + 0.2 + 0.1, the box a whole number of
            // spacings (neighbours across the faces at exactly the reach), plus a slightly
            // shifted copy of every tenth grain
            let dom: Domain<D3> = Domain::new(DVec3::ZERO, DVec3::new(4.0, 3.5, 5.0), periodic);
            let mut pos = Vec::new();
            for z in 0..10 {
                for y in 0..7 {
                    for x in 0..8 {
                        pos.push(DVec3::new(0.5 * x as f64, 0.5 * y as f64, 0.5 * z as f64));
                    }
                }
            }
            let extra: Vec<DVec3> = pos.iter().step_by(10).map(|p| *p + DVec3::new(0.25, 1e-12, -0.49999999999)).collect();
            let mut pos: Vec<DVec3> = pos.into_iter().chain(extra).collect();
            for p in &mut pos {
                dom.wrap(p, &mut [0; 3]);
            }
            let rad = vec![0.2; pos.len()];
            check(&pos, &rad, &dom, 0.1);
        }
    }

    /// The lane-wise maximum is the fold of `nan_max` from 0, bit for bit: lengths that are and
    /// are not multiples of the lane count, images across the periodic boundary, a NaN anywhere.
    #[test]
    fn max_displacement_is_the_nan_max_fold() {
        let dom: Domain<D2> = Domain::new(DVec2::ZERO, DVec2::new(7.0, 5.0), [true, false, false]);
        let image = dom.image();
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [0, 1, 3, 4, 5, 17, 64] {
            let reference: Vec<DVec2> = (0..n).map(|_| DVec2::new(7.0 * next(), 5.0 * next())).collect();
            let mut pos: Vec<DVec2> = reference.iter().map(|r| *r + DVec2::new(next() - 0.5, next() - 0.5) * 3.0).collect();
            let fold = |p: &[DVec2]| reference.iter().zip(p).fold(0.0, |m, (r, x)| nan_max(m, image.displacement(*r, *x).norm2()));
            let got = max_displacement2(&image, &reference, &pos);
            assert_eq!(got.to_bits(), fold(&pos).to_bits(), "n = {n}");
            if n > 0 {
                assert!(got > 0.0);
                pos[n - 1].y = f64::NAN;
                assert!(max_displacement2(&image, &reference, &pos).is_nan(), "n = {n}");
                assert!(fold(&pos).is_nan());
            }
        }
    }

    /// The same in 3D, where eight grains at a time go through AVX-512 when the processor has it
    /// (the rest element by element): lengths around multiples of 8, a non-periodic axis, a
    /// NaN in the vector part and in the rest, displacements across the boundary.
    #[test]
    fn max_displacement_3d_is_the_nan_max_fold() {
        crate::util::avx512_or_skip("max_displacement_3d_is_the_nan_max_fold: the AVX-512 displacement check not run (the element-wise one is checked)");
        for periodic in [[true, true, true], [true, false, true]] {
            let dom: Domain<D3> = Domain::new(DVec3::ZERO, DVec3::new(7.0, 5.0, 6.0), periodic);
            let image = dom.image();
            let mut seed = 54321u64;
            let mut next = || {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (seed >> 11) as f64 / (1u64 << 53) as f64
            };
            for n in [0usize, 5, 8, 9, 16, 23, 64, 1027] {
                let reference: Vec<DVec3> = (0..n).map(|_| DVec3::new(7.0 * next(), 5.0 * next(), 6.0 * next())).collect();
                let mut pos: Vec<DVec3> = reference.iter().map(|r| *r + DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 4.0).collect();
                let fold = |p: &[DVec3]| reference.iter().zip(p).fold(0.0, |m, (r, x)| nan_max(m, image.displacement(*r, *x).norm2()));
                let got = max_displacement2(&image, &reference, &pos);
                assert_eq!(got.to_bits(), fold(&pos).to_bits(), "n = {n}, {periodic:?}");
                for k in [0, n / 2, n.saturating_sub(1)] {
                    if k < n {
                        let keep = pos[k];
                        pos[k].z = f64::NAN;
                        assert!(max_displacement2(&image, &reference, &pos).is_nan(), "n = {n}, NaN at {k}");
                        pos[k] = keep;
                    }
                }
            }
        }
    }
}
