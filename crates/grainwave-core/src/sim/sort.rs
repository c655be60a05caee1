//! Spatial sorting: grains stored bin by bin (bins one radius wide, in z, y, x order — the
//! binning LAMMPS sorts its atoms with), so that grains close in space are close in memory.
//! Ids stay stable; only the storage order changes.
//!
//! Measured on the 32 000-sphere benchmark (user CPU, 500 steps): bin order as written by LAMMPS
//! 2.90 s, this sort 2.97 s, Morton (Z-curve) order of the same bins 3.3 s, a random order 3.76 s.
//! Bin order beats the Z-curve here because each grain's pairs are stored with its partners of
//! larger index, which bin order places just ahead in memory.

use super::Simulation;
use crate::dim::{Dim, VectorOps};

impl<D: Dim> Simulation<D> {
    /// Reorders the grains bin by bin (ids are kept; contact histories follow their grains at the
    /// next neighbor-list build, which this triggers). Physics is unchanged, but sums over contacts
    /// are taken in another order, so results differ from an unsorted run by rounding.
    pub fn sort_spatially(&mut self) {
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
        let mut order: Vec<([u64; 3], u32)> = (0..n)
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
        order.sort_unstable();
        let perm: Vec<usize> = order.iter().map(|&(_, k)| k as usize).collect();
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
