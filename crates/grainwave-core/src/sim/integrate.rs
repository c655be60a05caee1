//! Time integration: velocity Verlet and Beeman, translations and rotations, walls and pistons.

use super::{Integrator, Simulation};
use crate::dim::{Dim, VectorOps};
use crate::domain::WallMotion;
use crate::error::Result;
use crate::neighbor::{max_displacement2, nan_max};
use rayon::prelude::*;

/// Grains per parallel work item of the per-grain passes.
pub(crate) const MIN_LEN: usize = 1024;

impl<D: Dim> Simulation<D> {
    /// Advances the simulation by one time step.
    pub fn step(&mut self) -> Result<()> {
        D::engine_step(self)
    }

    /// [`Simulation::step`], compiled here for D2 and D3 ([`Dim::engine_step`]).
    pub(crate) fn step_here(&mut self) -> Result<()> {
        match self.integrator {
            Integrator::VelocityVerlet => self.step_verlet()?,
            Integrator::Beeman => self.step_beeman()?,
        }
        self.step += 1;
        if self.counters.network_changes == 0 {
            self.counters.steps_network_unchanged += 1;
        } else {
            self.counters.steps_network_unchanged = 0;
        }
        Ok(())
    }

    /// Advances by `n` steps (inside the rayon pool).
    pub fn steps(&mut self, n: u64) -> Result<()> {
        crate::util::in_pool(|| {
            for _ in 0..n {
                self.step()?;
            }
            Ok(())
        })
    }

    /// Advances by `n` steps in pieces of at most [`super::INTERRUPT_POLL_STEPS`], asking `stop`
    /// between pieces, so that a chunk length chosen in a config (`check_every` = 2³²) does not
    /// make an interrupt wait for it. Returns false when `stop` said so before the `n` steps were
    /// done; the steps taken stand, and the rest can be taken later with the same bits (steps do
    /// not depend on how they are grouped).
    pub fn steps_until(&mut self, n: u64, mut stop: impl FnMut() -> bool) -> Result<bool> {
        let mut left = n;
        while left > 0 {
            let m = left.min(super::INTERRUPT_POLL_STEPS);
            self.steps(m)?;
            left -= m;
            if left > 0 && stop() {
                return Ok(false);
            }
        }
        Ok(true)
    }

    fn step_verlet(&mut self) -> Result<()> {
        let dt = self.dt;
        let h = 0.5 * dt;
        // Kick, drift, wrap, turn, and measure how far the grains moved since the neighbor list
        // was built.
        let (max_displacement2, max_close2) = {
            let Simulation { grains: g, domain: dom, nlist, work, .. } = self;
            let image = dom.image();
            let (lo, hi) = dom.wrap_bounds();
            let reference = &nlist.ref_pos;
            let track = reference.len() == g.pos.len();
            // In 3D, the close list's reference too (the force pass's own check, done here in
            // the same sweep). 2D keeps the pass with one reference: the second one cost its
            // two-worker runs 9–15 % (docs/bench-history.md), and 2D keeps no close list.
            let close = &work.cross.close_ref;
            let track_close = D::D == 3 && work.cross.close_ok && close.len() == g.pos.len();
            let chunks = g
                .pos
                .par_chunks_mut(MIN_LEN)
                .zip(g.vel.par_chunks_mut(MIN_LEN))
                .zip(g.image.par_chunks_mut(MIN_LEN))
                .zip(g.force.par_chunks(MIN_LEN))
                .zip(g.omega.par_chunks_mut(MIN_LEN))
                .zip(g.orientation.par_chunks_mut(MIN_LEN))
                .zip(g.torque.par_chunks(MIN_LEN))
                .enumerate();
            let drift = |c: usize, x: &mut [D::Vector], v: &mut [D::Vector], im: &mut [[i32; 3]], f: &[D::Vector], w: &mut [D::AngVector], o: &mut [D::Orientation], t: &[D::AngVector], close: Option<&[D::Vector]>| {
                let base = c * MIN_LEN;
                let n = x.len();
                let chunk = DriftChunk {
                    dt,
                    mass: &g.mass[base..base + n],
                    inertia: &g.inertia[base..base + n],
                    x,
                    v,
                    im,
                    f,
                    w,
                    o,
                    t,
                    dom: &*dom,
                    image: &image,
                    lo,
                    hi,
                    reference: if track { Some(&reference[base..base + n]) } else { None },
                    close: close.map(|r| &r[base..base + n]),
                };
                chunk.run()
            };
            if track_close {
                let m = chunks
                    .map(|(c, ((((((x, v), im), f), w), o), t))| drift(c, x, v, im, f, w, o, t, Some(close)))
                    .reduce(|| (0.0, 0.0), |a, b| (nan_max(a.0, b.0), nan_max(a.1, b.1)));
                (m.0, Some(m.1))
            } else {
                (chunks.map(|(c, ((((((x, v), im), f), w), o), t))| drift(c, x, v, im, f, w, o, t, None).0).reduce(|| 0.0, nan_max), None)
            }
        };
        let t0 = self.time;
        for w in &mut self.domain.walls {
            match &w.motion {
                WallMotion::Fixed => w.speed = 0.0,
                WallMotion::Velocity { speed } => {
                    w.speed = speed.eval(t0 + h);
                    w.position += w.normal * (w.speed * dt);
                }
                WallMotion::Piston { .. } => {
                    w.speed += h * w.accel;
                    w.position += w.normal * (w.speed * dt);
                }
            }
        }
        self.time = t0 + dt;
        self.domain.advance_tilt(dt);
        self.prepare_neighbors(Some(max_displacement2))?;
        self.work.cross.close_known = max_close2;
        // forces, then the second half kick in the same per-grain pass
        self.compute_forces(dt, false, Some(h))?;
        self.update_piston_accelerations();
        let t1 = self.time;
        for w in &mut self.domain.walls {
            match &w.motion {
                WallMotion::Fixed => {}
                WallMotion::Velocity { speed } => w.speed = speed.eval(t1),
                WallMotion::Piston { .. } => w.speed += h * w.accel,
            }
        }
        Ok(())
    }

    fn step_beeman(&mut self) -> Result<()> {
        let dt = self.dt;
        let n = self.len();
        if self.prev_acc.len() != n || self.prev_ang_acc.len() != n {
            // first step (or after a change of integrator): start with a(t − dt) = a(t)
            self.prev_acc = (0..n).map(|k| self.grains.force[k] / self.grains.mass[k]).collect();
            self.prev_ang_acc = (0..n).map(|k| self.grains.torque[k] / self.grains.inertia[k]).collect();
        }
        // a(t) before the forces are overwritten (buffers kept between steps).
        let mut acc = std::mem::take(&mut self.work.acc);
        let mut ang = std::mem::take(&mut self.work.ang_acc);
        acc.resize(n, D::Vector::ZERO);
        ang.resize(n, D::AngVector::ZERO);
        {
            let g = &self.grains;
            acc.par_iter_mut().zip(g.force.par_iter().zip(g.mass.par_iter())).with_min_len(MIN_LEN).for_each(|(a, (f, m))| *a = *f / *m);
            ang.par_iter_mut().zip(g.torque.par_iter().zip(g.inertia.par_iter())).with_min_len(MIN_LEN).for_each(|(a, (t, i))| *a = *t / *i);
        }
        {
            let Simulation { grains: g, domain: dom, prev_acc, prev_ang_acc, work, .. } = self;
            work.vel_eval.resize(n, D::Vector::ZERO);
            work.omega_eval.resize(n, D::AngVector::ZERO);
            let c2 = dt * dt / 6.0;
            g.pos
                .par_iter_mut()
                .zip(g.image.par_iter_mut())
                .zip(work.vel_eval.par_iter_mut())
                .zip(g.vel.par_iter_mut())
                .zip(acc.par_iter().zip(prev_acc.par_iter()))
                .with_min_len(MIN_LEN)
                .for_each(|((((x, im), ve), v), (a, ap))| {
                    *x += *v * dt + (*a * 4.0 - *ap) * c2;
                    dom.wrap_moving(x, v, im);
                    *ve = *v + (*a * 3.0 - *ap) * (0.5 * dt);
                });
            g.orientation
                .par_iter_mut()
                .zip(work.omega_eval.par_iter_mut())
                .zip(g.omega.par_iter())
                .zip(ang.par_iter().zip(prev_ang_acc.par_iter()))
                .with_min_len(MIN_LEN)
                .for_each(|(((o, we), w), (a, ap))| {
                    let turn = *w * dt + (*a * 4.0 - *ap) * c2;
                    *o = D::rotate_orientation(*o, turn, 1.0);
                    *we = *w + (*a * 3.0 - *ap) * (0.5 * dt);
                });
        }
        let t0 = self.time;
        let mut wall_accel = std::mem::take(&mut self.work.wall_accel);
        wall_accel.clear();
        for w in &mut self.domain.walls {
            wall_accel.push(w.accel);
            match &w.motion {
                WallMotion::Fixed => w.speed = 0.0,
                WallMotion::Velocity { speed } => {
                    w.position += w.normal * (speed.eval(t0 + 0.5 * dt) * dt);
                    w.speed = speed.eval(t0 + dt);
                }
                WallMotion::Piston { .. } => {
                    let shift = w.speed * dt + (4.0 * w.accel - w.prev_accel) * dt * dt / 6.0;
                    w.position += w.normal * shift;
                    // predicted speed seen by the contacts; corrected below
                    w.speed += (3.0 * w.accel - w.prev_accel) * 0.5 * dt;
                }
            }
        }
        self.time = t0 + dt;
        self.domain.advance_tilt(dt);
        self.prepare_neighbors(None)?;
        self.compute_forces(dt, true, None)?;
        {
            let Simulation { grains: g, prev_acc, prev_ang_acc, .. } = self;
            g.vel
                .par_iter_mut()
                .zip(g.force.par_iter().zip(g.mass.par_iter()))
                .zip(acc.par_iter().zip(prev_acc.par_iter_mut()))
                .with_min_len(MIN_LEN)
                .for_each(|((v, (f, m)), (a, ap))| {
                    let a_new = *f / *m;
                    *v += (a_new * 2.0 + *a * 5.0 - *ap) * (dt / 6.0);
                    *ap = *a;
                });
            g.omega
                .par_iter_mut()
                .zip(g.torque.par_iter().zip(g.inertia.par_iter()))
                .zip(ang.par_iter().zip(prev_ang_acc.par_iter_mut()))
                .with_min_len(MIN_LEN)
                .for_each(|((w, (t, i)), (a, ap))| {
                    let a_new = *t / *i;
                    *w += (a_new * 2.0 + *a * 5.0 - *ap) * (dt / 6.0);
                    *ap = *a;
                });
        }
        self.work.acc = acc;
        self.work.ang_acc = ang;
        self.update_piston_accelerations();
        for (w, &a_old) in self.domain.walls.iter_mut().zip(&wall_accel) {
            if let WallMotion::Piston { .. } = w.motion {
                // undo the prediction, then apply the corrector
                let v_t = w.speed - (3.0 * a_old - w.prev_accel) * 0.5 * dt;
                w.speed = v_t + (2.0 * w.accel + 5.0 * a_old - w.prev_accel) * dt / 6.0;
                w.prev_accel = a_old;
            }
        }
        self.work.wall_accel = wall_accel;
        Ok(())
    }
}

/// One chunk of velocity Verlet's first half: kick, drift, wrap, turn, and the largest squared
/// displacements since the neighbor list's reference and the close list's (0 when not tracked).
struct DriftChunk<'a, D: Dim> {
    dt: f64,
    mass: &'a [f64],
    inertia: &'a [f64],
    x: &'a mut [D::Vector],
    v: &'a mut [D::Vector],
    im: &'a mut [[i32; 3]],
    f: &'a [D::Vector],
    w: &'a mut [D::AngVector],
    o: &'a mut [D::Orientation],
    t: &'a [D::AngVector],
    dom: &'a crate::domain::Domain<D>,
    image: &'a crate::domain::PeriodicImage<D>,
    lo: D::Vector,
    hi: D::Vector,
    reference: Option<&'a [D::Vector]>,
    close: Option<&'a [D::Vector]>,
}

impl<D: Dim> DriftChunk<'_, D> {
    /// Runs the chunk, compiled for the widest vector extension the processor has (the same
    /// operations in the same order on every path: the same bits).
    fn run(self) -> (f64, f64) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("avx512vl") {
                // SAFETY: the processor supports AVX-512 F and VL.
                return unsafe { self.run_avx512() };
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the processor supports AVX2.
                return unsafe { self.run_avx2() };
            }
        }
        self.body()
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    unsafe fn run_avx512(self) -> (f64, f64) {
        self.body_with(true)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn run_avx2(self) -> (f64, f64) {
        self.body()
    }

    #[inline(always)]
    fn body(self) -> (f64, f64) {
        self.body_with(false)
    }

    /// The chunk; with `wide` (3D, AVX-512 F available) the kick, drift and spin kick of eight
    /// grains at a time with AVX-512 intrinsics on the interleaved coordinates (the same
    /// operations on each coordinate: the same bits).
    #[inline(always)]
    fn body_with(self, wide: bool) -> (f64, f64) {
        let DriftChunk { dt, mass, inertia, x, v, im, f, w, o, t, dom, image, lo, hi, reference, close } = self;
        let h = 0.5 * dt;
        let n = x.len();
        // h/m and h/I first, in loops the compiler vectorizes (the same quotients as inline)
        let (mut km, mut ki) = ([0.0; MIN_LEN], [0.0; MIN_LEN]);
        for k in 0..n {
            km[k] = h / mass[k];
        }
        for k in 0..n {
            ki[k] = h / inertia[k];
        }
        let mut done = 0;
        #[cfg(target_arch = "x86_64")]
        if wide && D::D == 3 && !image.sheared && std::mem::size_of::<D::Vector>() == 24 && std::mem::size_of::<D::AngVector>() == 24 && w.len() == n && t.len() == n {
            done = n - n % 8;
            let bounds = [lo.get(0), lo.get(1), lo.get(2), hi.get(0), hi.get(1), hi.get(2)];
            // SAFETY: AVX-512 F is available (`wide`); vectors and spins are three f64 here,
            // and all the slices hold n ≥ `done` grains.
            let flagged = unsafe { wide::kick_drift_3d(x.as_mut_ptr() as *mut f64, v.as_mut_ptr() as *mut f64, f.as_ptr() as *const f64, &km, w.as_mut_ptr() as *mut f64, t.as_ptr() as *const f64, &ki, dt, bounds, done) };
            // the grains that left the cell: wrapped as below
            for k in flagged.iter() {
                dom.wrap_in(image, &mut x[k], &mut v[k], &mut im[k]);
            }
        }
        for k in done..n {
            v[k] += f[k] * km[k];
            x[k] += v[k] * dt;
            // most grains stay inside the cell: the full wrap only for the others
            // (non-short-circuit `|`: one test per grain instead of a branch per bound)
            let mut out = image.sheared;
            for c in 0..D::D {
                out |= (x[k].get(c) >= hi.get(c)) | (x[k].get(c) < lo.get(c));
            }
            if out {
                dom.wrap_in(image, &mut x[k], &mut v[k], &mut im[k]);
            }
        }
        let max_d2 = reference.map_or(0.0, |r| max_displacement2(image, r, x));
        let max_close2 = close.map_or(0.0, |r| max_displacement2(image, r, x));
        for k in done.min(w.len())..w.len() {
            w[k] += t[k] * ki[k];
        }
        D::rotate_orientations(o, w, dt);
        (max_d2, max_close2)
    }
}

/// Grain indices of a chunk that left the cell, in increasing order.
struct Flagged {
    list: [u32; MIN_LEN],
    len: usize,
}

impl Flagged {
    fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        self.list[..self.len].iter().map(|&k| k as usize)
    }
}

#[cfg(target_arch = "x86_64")]
mod wide {
    use super::{Flagged, MIN_LEN};
    use crate::simd512::{idx, per_coordinate};
    use std::arch::x86_64::*;

    /// v += f·km, x += v·dt, ω += τ·ki for the first `n` (a multiple of 8) grains, eight at a
    /// time on the interleaved coordinates; returns the grains with a coordinate ≥ the upper
    /// bound or < the lower one (`bounds`: lower x, y, z, upper x, y, z), which the caller
    /// wraps.
    ///
    /// # Safety
    /// The pointers hold 3n f64 (`km`, `ki` n values); AVX-512 F is available.
    #[target_feature(enable = "avx2,avx512f")]
    #[allow(clippy::too_many_arguments)]
    pub(super) unsafe fn kick_drift_3d(x: *mut f64, v: *mut f64, f: *const f64, km: &[f64; MIN_LEN], w: *mut f64, t: *const f64, ki: &[f64; MIN_LEN], dt: f64, bounds: [f64; 6], n: usize) -> Flagged {
        assert!(n % 8 == 0 && n <= MIN_LEN, "kick_drift_3d: {n} grains");
        let mut flagged = Flagged { list: [0; MIN_LEN], len: 0 };
        // SAFETY: the caller's contract.
        unsafe {
            // the factor of grain l for each coordinate of three rows of 8 f64
            let spread = [idx([0, 0, 0, 1, 1, 1, 2, 2]), idx([2, 3, 3, 3, 4, 4, 4, 5]), idx([5, 5, 6, 6, 6, 7, 7, 7])];
            let lo = per_coordinate([bounds[0], bounds[1], bounds[2]]);
            let hi = per_coordinate([bounds[3], bounds[4], bounds[5]]);
            let dtv = _mm512_set1_pd(dt);
            for k in (0..n).step_by(8) {
                let (kmv, kiv) = (_mm512_loadu_pd(km.as_ptr().add(k)), _mm512_loadu_pd(ki.as_ptr().add(k)));
                let mut out = 0u32;
                for r in 0..3 {
                    let e = 3 * k + 8 * r;
                    let vr = _mm512_add_pd(_mm512_loadu_pd(v.add(e)), _mm512_mul_pd(_mm512_loadu_pd(f.add(e)), _mm512_permutexvar_pd(spread[r], kmv)));
                    _mm512_storeu_pd(v.add(e), vr);
                    let xr = _mm512_add_pd(_mm512_loadu_pd(x.add(e)), _mm512_mul_pd(vr, dtv));
                    _mm512_storeu_pd(x.add(e), xr);
                    let m = _mm512_cmp_pd_mask::<_CMP_GE_OQ>(xr, hi[r]) | _mm512_cmp_pd_mask::<_CMP_LT_OQ>(xr, lo[r]);
                    out |= (m as u32) << (8 * r);
                    let wr = _mm512_add_pd(_mm512_loadu_pd(w.add(e)), _mm512_mul_pd(_mm512_loadu_pd(t.add(e)), _mm512_permutexvar_pd(spread[r], kiv)));
                    _mm512_storeu_pd(w.add(e), wr);
                }
                // coordinate c of the 24 → grain c / 3, each once
                let mut last = usize::MAX;
                while out != 0 {
                    let g = k + out.trailing_zeros() as usize / 3;
                    out &= out - 1;
                    if g != last {
                        flagged.list[flagged.len] = g as u32;
                        flagged.len += 1;
                        last = g;
                    }
                }
            }
        }
        flagged
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::D3;
    use crate::domain::Domain;
    use glam::{DQuat, DVec3};

    /// The drift chunk on AVX-512 (eight grains at a time) gives the bits of the element-wise
    /// loop: grains leaving the cell on either side of each periodic axis, a non-periodic axis,
    /// a NaN force, lengths that leave a remainder, both displacement checks. (Where the
    /// processor lacks AVX-512 both sides run the element-wise loop.)
    #[test]
    fn the_wide_drift_chunk_gives_the_bits_of_the_plain_one() {
        if !crate::util::avx512_or_skip("the_wide_drift_chunk_gives_the_bits_of_the_plain_one: the AVX-512 drift chunk not run") {
            return;
        }
        let dom: Domain<D3> = Domain::new(DVec3::ZERO, DVec3::new(4.0, 3.0, 5.0), [true, true, false]);
        let image = dom.image();
        let (lo, hi) = dom.wrap_bounds();
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [0usize, 7, 8, 29, 1024] {
            let vec3 = |rnd: &mut dyn FnMut() -> f64, s: DVec3, o: f64| DVec3::new((rnd() - o) * s.x, (rnd() - o) * s.y, (rnd() - o) * s.z);
            let x0: Vec<DVec3> = (0..n).map(|_| vec3(&mut rnd, DVec3::new(4.0, 3.0, 5.0), 0.0)).collect();
            // fast enough that some grains cross the boundaries in one step
            let v0: Vec<DVec3> = (0..n).map(|_| vec3(&mut rnd, DVec3::splat(200.0), 0.5)).collect();
            let mut f: Vec<DVec3> = (0..n).map(|_| vec3(&mut rnd, DVec3::splat(10.0), 0.5)).collect();
            if n > 20 {
                f[19].y = f64::NAN;
            }
            let t: Vec<DVec3> = (0..n).map(|_| vec3(&mut rnd, DVec3::splat(3.0), 0.5)).collect();
            let w0: Vec<DVec3> = (0..n).map(|_| vec3(&mut rnd, DVec3::splat(5.0), 0.5)).collect();
            let mass: Vec<f64> = (0..n).map(|_| 0.5 + rnd()).collect();
            let inertia: Vec<f64> = (0..n).map(|_| 0.1 + rnd()).collect();
            let reference: Vec<DVec3> = x0.iter().map(|x| *x + DVec3::splat(0.01)).collect();
            let run = |wide: bool| {
                let (mut x, mut v, mut w) = (x0.clone(), v0.clone(), w0.clone());
                let mut im = vec![[0i32; 3]; n];
                let mut o = vec![DQuat::IDENTITY; n];
                let chunk = DriftChunk::<D3> {
                    dt: 1e-2,
                    mass: &mass,
                    inertia: &inertia,
                    x: &mut x,
                    v: &mut v,
                    im: &mut im,
                    f: &f,
                    w: &mut w,
                    o: &mut o,
                    t: &t,
                    dom: &dom,
                    image: &image,
                    lo,
                    hi,
                    reference: Some(&reference),
                    close: Some(&x0),
                };
                let m = if wide {
                    // SAFETY: the processor has AVX-512 F and VL (checked above).
                    #[cfg(target_arch = "x86_64")]
                    unsafe {
                        chunk.run_avx512()
                    }
                    #[cfg(not(target_arch = "x86_64"))]
                    unreachable!("AVX-512 on another architecture")
                } else {
                    chunk.body()
                };
                let bits = |a: &[DVec3]| a.iter().flat_map(|p| p.to_array()).map(f64::to_bits).collect::<Vec<_>>();
                (m.0.to_bits(), m.1.to_bits(), bits(&x), bits(&v), bits(&w), im, o.iter().flat_map(|q| q.to_array()).map(f64::to_bits).collect::<Vec<_>>())
            };
            let (wide, plain) = (run(true), run(false));
            assert!(n < 8 || plain.5.iter().any(|i| i.iter().any(|&c| c != 0)), "n = {n}: no grain wrapped");
            assert!(wide == plain, "n = {n}");
        }
    }
}
