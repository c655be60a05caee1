//! Spatial sorting: grains stored bin by bin (bins one radius wide, in z, y, x order — the
//! binning LAMMPS sorts its atoms with), so that grains close in space are close in memory.
//! Ids stay stable; only the storage order changes.
//!
//! Large packings are sorted block by block: the bins are grouped into cubic blocks of about
//! [`SORT_BLOCK_GRAINS`] grains, stored block after block (z, y, x), each in bin order. Without
//! blocks, a grain's partners in the next bin layer are a whole layer of the box away in memory
//! — in a 10⁶-sphere box, thousands of grains, so the pass streams through megabytes between a
//! grain and its partners; with them, a layer of one block. Packings of up to about that many
//! grains are one block: the plain bin order.
//! Measured on the 32 000-sphere benchmark tiled 4 × 4 × 2 (1 024 000 spheres, `hooke3d`, one
//! worker, 300 steps, Zen 4): plain bin order 4.28e6 particle-steps/s against 5.59e6 for the
//! tiles' own order (each a binned 32 000-sphere box), one pair; blocks 5.1–5.5e6 (`docs/bench-history.md`,
//! "A million spheres").
//!
//! Measured on the 32 000-sphere benchmark (user CPU, 500 steps): bin order as written by LAMMPS
//! 2.90 s, this sort 2.97 s, Morton (Z-curve) order of the same bins 3.3 s, a random order 3.76 s.
//! Bin order beats the Z-curve here because each grain's pairs are stored with its partners of
//! larger index, which bin order places just ahead in memory.

use super::Simulation;
use crate::dim::{Dim, VectorOps};

/// Grains per block of [`Simulation::sort_spatially`] (about): 2¹⁶, so that the benchmark
/// packings (32 000 spheres, 16 384 disks) are one block.
pub const SORT_BLOCK_GRAINS: usize = 1 << 16;

impl<D: Dim> Simulation<D> {
    /// Reorders the grains bin by bin, in blocks of about [`SORT_BLOCK_GRAINS`] grains (ids are
    /// kept; contact histories follow their grains at the next neighbor-list build, which this
    /// triggers). Physics is unchanged, but sums over contacts are taken in another order, so
    /// results differ from an unsorted run by rounding.
    pub fn sort_spatially(&mut self) {
        self.sort_spatially_in_blocks(SORT_BLOCK_GRAINS);
    }

    /// [`Self::sort_spatially`] with blocks of about `block_grains` grains: cubic blocks of b bins
    /// per edge, b = ⌈(block_grains · bins / grains)^(1/D)⌉ over the bins the grains span, stored
    /// block after block in z, y, x order and bin by bin inside each. A packing of at most
    /// `block_grains` grains is one block: the plain bin order.
    pub fn sort_spatially_in_blocks(&mut self, block_grains: usize) {
        let n = self.len();
        if n < 2 {
            return;
        }
        let g = &self.grains;
        let (_, r_max) = g.radius_range();
        let mut lo = [f64::INFINITY; 3];
        for x in &g.pos {
            for (k, l) in lo.iter_mut().enumerate().take(D::D) {
                *l = l.min(x.get(k));
            }
        }
        let image = self.domain.image();
        let sheared = self.domain.is_sheared();
        let order: Vec<([u64; 3], u32)> = (0..n)
            .map(|k| {
                let x = g.pos[k];
                let s = if sheared { image.fractional(x, self.domain.lo) } else { [0.0; 3] };
                let mut c = [0u64; 3];
                for axis in 0..D::D {
                    let v = if sheared && self.domain.periodic[axis] {
                        (s[axis] - s[axis].floor()) * self.domain.length(axis) / r_max
                    } else {
                        (x.get(axis) - lo[axis]) / r_max
                    };
                    // last axis slowest
                    c[D::D - 1 - axis] = if v.is_finite() { v.clamp(0.0, 1e15) as u64 } else { 0 };
                }
                (c, k as u32)
            })
            .collect();
        // bins spanned along each axis, then the block edge b (in bins): b^D bins hold about
        // block_grains grains at the packing's mean density of grains per bin
        let mut spans = [1.0f64; 3];
        for (c, _) in &order {
            for (s, &v) in spans.iter_mut().zip(c) {
                *s = s.max(v as f64 + 1.0);
            }
        }
        // (a packing of at most block_grains grains is one block, whatever its shape)
        let bins: f64 = spans.iter().product();
        let edge = if n <= block_grains { f64::INFINITY } else { (block_grains as f64 * bins / n as f64).powf(1.0 / D::D as f64).ceil() };
        let edge = if edge.is_finite() && edge >= 1.0 { edge.min(1e15) as u64 } else if edge.is_infinite() { u64::MAX } else { 1 };
        let mut keyed: Vec<([u64; 3], [u64; 3], u32)> = order.into_iter().map(|(c, k)| (c.map(|v| v / edge), c, k)).collect();
        keyed.sort_unstable();
        let perm: Vec<usize> = keyed.iter().map(|&(_, _, k)| k as usize).collect();
        fn apply<T: Copy>(v: &mut Vec<T>, perm: &[usize]) {
            if v.len() == perm.len() {
                *v = perm.iter().map(|&k| v[k]).collect();
            }
        }
        let g = &mut self.grains;
        apply(&mut g.id, &perm);
        apply(&mut g.radius, &perm);
        apply(&mut g.mass, &perm);
        apply(&mut g.inertia, &perm);
        apply(&mut g.pos, &perm);
        apply(&mut g.vel, &perm);
        apply(&mut g.omega, &perm);
        apply(&mut g.orientation, &perm);
        apply(&mut g.image, &perm);
        apply(&mut g.force, &perm);
        apply(&mut g.torque, &perm);
        apply(&mut self.prev_acc, &perm);
        apply(&mut self.prev_ang_acc, &perm);
        self.nlist.stale = true;
    }
}
