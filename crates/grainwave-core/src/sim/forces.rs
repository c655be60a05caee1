//! Force evaluation: one pass over the neighbor list that also completes every grain.
//!
//! **Fixed summation order.** The force (and torque) on grain g is summed over its partners in
//! increasing storage index, starting from zero, then the walls in list order, then the body
//! force, then external loads — whatever the number of threads, the way work is split, or when
//! the neighbor list was last rebuilt. Results are therefore bitwise identical for any number of
//! threads.
//!
//! **How.** Grains are cut into contiguous blocks (one per thread-sized piece of work; a single
//! block with one thread). Pair (i, j), i < j, is *intra-block* when both grains are in one
//! block, *cross-block* otherwise. Phase A evaluates the cross-block pairs (in parallel) into a
//! small buffer. Phase B walks each block (blocks in parallel) grain by grain in increasing
//! index: every grain starts from the sum of its cross-block contributions from lower blocks
//! (whose partners all have smaller indices), receives the intra-block contributions of smaller
//! owners as they are evaluated, then adds its own pairs in increasing partner index (evaluated
//! now, or read from the buffer). At that point its force is complete, so the same loop adds
//! walls, body force and loads, checks finiteness and applies velocity Verlet's second half
//! kick: one pass over the grains, no per-pair force buffer for intra-block pairs, and each pair
//! evaluated exactly once.
//!
//! **Close list (3D).** The neighbor list holds every pair within r_i + r_j + skin, and with the
//! benchmark skin (0.1 of a diameter) only ≈ 77 % (3D) / 83 % (2D) of those pairs touch. In 3D
//! the fused pass (`fused`, either lane width) therefore walks a second, shorter list of each block's intra-block
//! pairs: those within r_i + r_j + m, m = 0.3 × skin, plus any pair still holding a contact
//! (so that its opening is seen and its history forgotten as before), in list order. A pair left
//! out cannot touch before some grain has moved m/2 from where it was when the close list was
//! built, so the list is rebuilt (a linear pass over the neighbor list, no cell search) as soon
//! as 2·max|x − x_ref| + Σ|Δtilt| exceeds 0.9 m (the slack covers rounding in the distances;
//! NaN positions always rebuild, keeping their pairs), and whenever the neighbor list or the
//! blocks change. The displacement is measured by velocity Verlet's drift pass in the sweep
//! that measures it for the neighbor list. Skipped pairs touch nobody and hold no contact: the
//! evaluation would add nothing to any sum and change no history, so every bit of a run is as
//! without the close list (tested against the general kernel, `tests/force_blocks.rs`). On the
//! benchmark packings it holds 83 % (3D) / would hold 90 % (2D) of the pairs, rebuilt every ≈ 14
//! (3D) / 52 (2D) steps at m = 0.2 × skin. In 2D it gained 3–6 % on one worker, but the second
//! displacement reference in the drift pass tipped two-worker runs into rayon's workers sleeping
//! between the parallel regions of the short 2D steps (−6 to −15 %), so it is kept in 3D only
//! (`docs/bench-history.md`, the Zen 4 sections).

use super::lanes::{self, Window, WindowLaw, CAP};
use super::{CrossForce, CrossIndex, Simulation, WallForce};
use crate::contact::{contact_loads, evaluate_parts, pair_kinematics, wall_kinematics, ContactLaw, ContactState, HistoryColumn, Hooke, LawHistory, LawParts, NormalElastic, Rolling, TangentialHistory, Twisting};
use crate::dim::{Dim, VectorOps};
use crate::domain::{Domain, PeriodicImage, WallMotion};
use crate::error::{CoreError, Result};
use crate::neighbor::{max_displacement2_since, PairList};
use rayon::prelude::*;

/// The fused pass: on eight AVX2 lanes and on sixteen AVX-512 lanes.
#[cfg(target_arch = "x86_64")]
mod fused;
/// The AVX-512 filling of the windows (touching pairs eight candidates at a time).
#[cfg(target_arch = "x86_64")]
mod window512;

/// Per-evaluation statistics, merged associatively and commutatively (so deterministically).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ForceStats {
    pub changes: u64,
    pub contacts: u64,
    pub sliding: u64,
    /// (overlap / smaller radius, is_wall, index) of the deepest contact.
    pub deepest: (f64, u8, usize),
    /// First grain whose force or torque is not finite (usize::MAX: none).
    pub bad: usize,
}

impl ForceStats {
    fn new() -> Self {
        ForceStats { bad: usize::MAX, ..Default::default() }
    }

    fn merge(a: Self, b: Self) -> Self {
        let deepest = if b.deepest.0 > a.deepest.0 || (b.deepest.0 == a.deepest.0 && (b.deepest.1, b.deepest.2) < (a.deepest.1, a.deepest.2)) {
            b.deepest
        } else {
            a.deepest
        };
        ForceStats {
            changes: a.changes + b.changes,
            contacts: a.contacts + b.contacts,
            sliding: a.sliding + b.sliding,
            deepest,
            bad: a.bad.min(b.bad),
        }
    }
}

/// Smallest block (grains): below it, handing work to another thread costs more than it gains.
const MIN_BLOCK: usize = 512;

/// Number of grains per block for `n` grains on `threads` threads: one block for one thread,
/// otherwise two blocks per thread: a second one lets the work be balanced, more add cross-block
/// pairs (phase A) and passes. Measured on two threads: two blocks per thread beat four by 5–8 %
/// and one by up to 7 % (`docs/bench-history.md`).
pub(super) fn block_len(n: usize, threads: usize) -> usize {
    if threads <= 1 || n < 2 * MIN_BLOCK {
        return n.max(1);
    }
    n.div_ceil(2 * threads).max(MIN_BLOCK)
}

/// Read-only inputs of the pair evaluations.
struct Inputs<'a, D: Dim> {
    image: PeriodicImage<D>,
    dt: f64,
    pos: &'a [D::Vector],
    radius: &'a [f64],
    mass: &'a [f64],
    owner_start: &'a [u32],
    partner: &'a [u32],
}

/// The mutable history of a contiguous range of pairs starting at pair `base`: the shared parts
/// and the law's own history `extra` ([`LawParts::Extra`]; `()`, which stores nothing, for the
/// laws without one).
struct History<'a, D: Dim, H: LawHistory = ()> {
    base: usize,
    spring: &'a mut [TangentialHistory<D::Vector>],
    overlap: &'a mut [f64],
    sliding: &'a mut [bool],
    rolling: &'a mut [D::AngVector],
    twist: &'a mut [f64],
    extra: &'a mut [H],
}

impl<'a, D: Dim, H: LawHistory> History<'a, D, H> {
    /// The contact of pair `base + q` opened: forgets its history and counts the change.
    #[inline(always)]
    fn forget(&mut self, q: usize, st: &mut ForceStats) {
        self.spring[q] = TangentialHistory::ZERO;
        self.overlap[q] = 0.0;
        self.sliding[q] = false;
        self.rolling[q] = D::AngVector::ZERO;
        self.twist[q] = 0.0;
        *self.extra_at(q) = H::default();
        st.changes += 1;
    }

    /// The law's own history of pair `base + q`; for `()` no access at all (no bounds check):
    /// the kernels of the laws without history are the code they were before histories existed.
    #[inline(always)]
    fn extra_at(&mut self, q: usize) -> &mut H {
        if std::mem::size_of::<H>() == 0 {
            // SAFETY: a zero-sized value occupies no memory; a dangling, aligned, non-null
            // pointer is a valid reference to one.
            unsafe { std::ptr::NonNull::<H>::dangling().as_mut() }
        } else {
            &mut self.extra[q]
        }
    }

    /// Splits at absolute pair index `at`.
    fn split(self, at: usize) -> (Self, Self) {
        let k = at - self.base;
        let (s0, s1) = self.spring.split_at_mut(k);
        let (o0, o1) = self.overlap.split_at_mut(k);
        let (l0, l1) = self.sliding.split_at_mut(k);
        let (r0, r1) = self.rolling.split_at_mut(k);
        let (t0, t1) = self.twist.split_at_mut(k);
        let (e0, e1) = self.extra.split_at_mut(k);
        (
            History { base: self.base, spring: s0, overlap: o0, sliding: l0, rolling: r0, twist: t0, extra: e0 },
            History { base: at, spring: s1, overlap: o1, sliding: l1, rolling: r1, twist: t1, extra: e1 },
        )
    }

    /// The same pairs with the law's own history of type `E` taken from `column` (one entry
    /// per pair of the whole list; this history must start at pair 0).
    fn with_extra<E: LawHistory>(self, column: &'a mut HistoryColumn) -> History<'a, D, E> {
        debug_assert_eq!(self.base, 0);
        let extra = column.typed_mut::<E>(self.overlap.len());
        History { base: self.base, spring: self.spring, overlap: self.overlap, sliding: self.sliding, rolling: self.rolling, twist: self.twist, extra }
    }
}

/// One grain as the pair kernel sees it.
#[derive(Clone, Copy)]
struct Body<D: Dim> {
    x: D::Vector,
    v: D::Vector,
    w: D::AngVector,
    r: f64,
    m: f64,
}

/// Force on i and torques on i and j of one pair.
struct PairOut<D: Dim> {
    force: D::Vector,
    torque_i: D::AngVector,
    torque_j: D::AngVector,
}

/// Evaluates pair `p` (absolute index) between `a` (the smaller index) and `b` (grain `j`),
/// updating its history and the statistics. `None` when the grains are apart.
#[inline(always)]
fn eval_pair<D: Dim, P: LawParts>(law: &P, inp: &Inputs<D>, h: &mut History<D, P::Extra>, p: usize, a: &Body<D>, b: &Body<D>, st: &mut ForceStats) -> Option<PairOut<D>> {
    let q = p - h.base;
    let (r, dv) = inp.image.displacement_velocity(a.x, b.x);
    // the image of j moves with the cell in a shearing cell
    let vj = if inp.image.sheared { b.v + dv } else { b.v };
    let was = h.overlap[q];
    match pair_kinematics::<D>(r, a.r, b.r, a.m, b.m, a.v, vj, a.w, b.w) {
        None => {
            if was > 0.0 {
                h.forget(q, st);
            }
            None
        }
        Some(kin) => {
            let resists_rolling = law.rolling() != Rolling::None || law.twisting() != Twisting::None;
            let mut state = ContactState {
                spring: h.spring[q],
                rolling: if resists_rolling { h.rolling[q] } else { D::AngVector::ZERO },
                twist: if resists_rolling { h.twist[q] } else { 0.0 },
                overlap: was,
                sliding: h.sliding[q],
            };
            let o = evaluate_parts(law, &kin, &mut state, h.extra_at(q), inp.dt);
            h.spring[q] = state.spring;
            h.overlap[q] = state.overlap;
            h.sliding[q] = state.sliding;
            if resists_rolling {
                h.rolling[q] = state.rolling;
                h.twist[q] = state.twist;
            }
            st.changes += (was <= 0.0) as u64;
            st.contacts += 1;
            st.sliding += o.sliding as u64;
            let ratio = kin.overlap / if a.r < b.r { a.r } else { b.r };
            if ratio > st.deepest.0 {
                st.deepest = (ratio, 0, p);
            }
            let (force, torque_i, torque_j) = contact_loads(&kin, &o);
            Some(PairOut { force, torque_i, torque_j })
        }
    }
}

/// Phase A: the cross-block pairs of blocks `blocks`, into `out` (slots from `slot_base`).
fn cross_pairs<D: Dim, P: LawParts>(
    law: &P,
    inp: &Inputs<D>,
    vel: &[D::Vector],
    omega: &[D::AngVector],
    cross: &CrossIndex<D>,
    blocks: std::ops::Range<usize>,
    mut h: History<D, P::Extra>,
    out: &mut [CrossForce<D>],
    slot_base: usize,
) -> ForceStats {
    if blocks.len() > 1 {
        let mid = (blocks.start + blocks.end) / 2;
        let (h0, h1) = h.split(inp.owner_start[(mid * cross.block_len).min(cross.n)] as usize);
        let s = cross.block_slot_start[mid] as usize;
        let (o0, o1) = out.split_at_mut(s - slot_base);
        let (a, b) = rayon::join(
            || cross_pairs(law, inp, vel, omega, cross, blocks.start..mid, h0, o0, slot_base),
            || cross_pairs(law, inp, vel, omega, cross, mid..blocks.end, h1, o1, s),
        );
        return ForceStats::merge(a, b);
    }
    let mut st = ForceStats::new();
    let b = blocks.start;
    for i in b * cross.block_len..((b + 1) * cross.block_len).min(cross.n) {
        let a = Body { x: inp.pos[i], v: vel[i], w: omega[i], r: inp.radius[i], m: inp.mass[i] };
        let mut slot = cross.cross_slot[i] as usize - slot_base;
        for p in cross.cross_begin[i] as usize..inp.owner_start[i + 1] as usize {
            let j = inp.partner[p] as usize;
            let bj = Body { x: inp.pos[j], v: vel[j], w: omega[j], r: inp.radius[j], m: inp.mass[j] };
            out[slot] = match eval_pair(law, inp, &mut h, p, &a, &bj, &mut st) {
                Some(o) => CrossForce { force: o.force, torque_i: o.torque_i, torque_j: o.torque_j },
                None => CrossForce::default(),
            };
            slot += 1;
        }
    }
    st
}

/// What completes a grain once its pair forces are summed.
struct Finish<'a, D: Dim> {
    gravity: D::Vector,
    inertia: &'a [f64],
    wall_start: &'a [u32],
    wall_force: &'a [WallForce<D>],
    /// (grain, force, torque) of the external loads now, sorted by grain (stable).
    loads: &'a [(usize, D::Vector, D::AngVector)],
    /// Velocity Verlet's half kick h (forces only when `None`).
    kick: Option<f64>,
}

/// The per-grain arrays of a block of grains starting at grain `base`.
struct Grain<'a, D: Dim> {
    base: usize,
    force: &'a mut [D::Vector],
    torque: &'a mut [D::AngVector],
    vel: &'a mut [D::Vector],
    omega: &'a mut [D::AngVector],
}

impl<D: Dim> Grain<'_, D> {
    fn split(self, at: usize) -> (Self, Self) {
        let k = at - self.base;
        let (f0, f1) = self.force.split_at_mut(k);
        let (t0, t1) = self.torque.split_at_mut(k);
        let (v0, v1) = self.vel.split_at_mut(k);
        let (w0, w1) = self.omega.split_at_mut(k);
        (Grain { base: self.base, force: f0, torque: t0, vel: v0, omega: w0 }, Grain { base: at, force: f1, torque: t1, vel: v1, omega: w1 })
    }
}

/// Phase B: blocks `blocks` (see the module documentation).
#[allow(clippy::too_many_arguments)]
fn blocks_pass<D: Dim, P: LawParts>(
    law: &P,
    inp: &Inputs<D>,
    cross: &CrossIndex<D>,
    fin: &Finish<D>,
    blocks: std::ops::Range<usize>,
    h: History<D, P::Extra>,
    g: Grain<D>,
) -> ForceStats {
    if blocks.len() > 1 {
        let mid = (blocks.start + blocks.end) / 2;
        let at = (mid * cross.block_len).min(cross.n);
        let (h0, h1) = h.split(inp.owner_start[at] as usize);
        let (g0, g1) = g.split(at);
        let (a, b) = rayon::join(|| blocks_pass(law, inp, cross, fin, blocks.start..mid, h0, g0), || blocks_pass(law, inp, cross, fin, mid..blocks.end, h1, g1));
        return ForceStats::merge(a, b);
    }
    block(law, inp, cross, fin, blocks.start, h, g)
}

/// Completes grain `i` (block starting at grain `g0`) once its intra-block pairs are summed into
/// `force`/`torque`: its cross-block pairs in order, walls, body force, loads, finiteness check,
/// kick.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn finish_grain<D: Dim>(
    inp: &Inputs<D>,
    cross: &CrossIndex<D>,
    fin: &Finish<D>,
    i: usize,
    g0: usize,
    force: &mut [D::Vector],
    torque: &mut [D::AngVector],
    vel: &mut [D::Vector],
    omega: &mut [D::AngVector],
    load: &mut usize,
    st: &mut ForceStats,
) {
    let li = i - g0;
    let (mut fi, mut ti) = (force[li], torque[li]);
    // (one block: no cross-block pairs; no walls: no wall contacts)
    if !cross.forces.is_empty() {
        let cb = cross.cross_begin[i] as usize;
        for c in &cross.forces[cross.cross_slot[i] as usize..cross.cross_slot[i] as usize + (inp.owner_start[i + 1] as usize - cb)] {
            fi += c.force;
            ti += c.torque_i;
        }
    }
    if !fin.wall_force.is_empty() {
        for c in &fin.wall_force[fin.wall_start[i] as usize..fin.wall_start[i + 1] as usize] {
            fi += c.force;
            ti += c.torque;
        }
    }
    let m = inp.mass[i];
    fi = fi + fin.gravity * m;
    while *load < fin.loads.len() && fin.loads[*load].0 == i {
        fi += fin.loads[*load].1;
        ti += fin.loads[*load].2;
        *load += 1;
    }
    if !all_finite::<D>(fi, ti) {
        st.bad = st.bad.min(i);
    } else if let Some(hk) = fin.kick {
        vel[li] += fi * (hk / m);
        omega[li] += ti * (hk / fin.inertia[i]);
    }
    force[li] = fi;
    torque[li] = ti;
}

/// True when every component of `f` and `t` is finite (as `is_finite_vec` on both), without a
/// branch per component: x − x is +0 for a finite x and NaN for ±∞ or NaN, and a sum of +0s is
/// +0 while a NaN term makes it NaN.
#[inline(always)]
#[allow(clippy::eq_op)] // x − x is the point: +0 or NaN
fn all_finite<D: Dim>(f: D::Vector, t: D::AngVector) -> bool {
    let mut s = 0.0;
    for c in 0..<D::Vector as VectorOps>::LEN {
        let x = f.get(c);
        s += x - x;
    }
    for c in 0..<D::AngVector as VectorOps>::LEN {
        let x = t.get(c);
        s += x - x;
    }
    s == 0.0
}

/// Starts the sums of grains `g0..g1` (a block) from the contributions of their cross-block pairs
/// with lower blocks (partners of smaller index), in order.
#[inline(always)]
fn start_block<D: Dim>(cross: &CrossIndex<D>, g0: usize, g1: usize, force: &mut [D::Vector], torque: &mut [D::AngVector]) {
    for j in g0..g1 {
        let mut f = D::Vector::ZERO;
        let mut t = D::AngVector::ZERO;
        for &s in &cross.in_slot[cross.in_start[j] as usize..cross.in_start[j + 1] as usize] {
            let c = &cross.forces[s as usize];
            f -= c.force;
            t += c.torque_j;
        }
        force[j - g0] = f;
        torque[j - g0] = t;
    }
}

/// Phase B for one block.
#[inline(always)]
fn block<D: Dim, P: LawParts>(law: &P, inp: &Inputs<D>, cross: &CrossIndex<D>, fin: &Finish<D>, b: usize, mut h: History<D, P::Extra>, g: Grain<D>) -> ForceStats {
    let mut st = ForceStats::new();
    let (g0, g1) = (b * cross.block_len, ((b + 1) * cross.block_len).min(cross.n));
    let Grain { force, torque, vel, omega, .. } = g;
    start_block(cross, g0, g1, force, torque);
    let mut load = fin.loads.partition_point(|l| l.0 < g0);
    for i in g0..g1 {
        let li = i - g0;
        let a = Body { x: inp.pos[i], v: vel[li], w: omega[li], r: inp.radius[i], m: inp.mass[i] };
        let mut fi = force[li];
        let mut ti = torque[li];
        let cb = cross.cross_begin[i] as usize;
        for p in inp.owner_start[i] as usize..cb {
            let j = inp.partner[p] as usize;
            let lj = j - g0;
            let bj = Body { x: inp.pos[j], v: vel[lj], w: omega[lj], r: inp.radius[j], m: inp.mass[j] };
            if let Some(o) = eval_pair(law, inp, &mut h, p, &a, &bj, &mut st) {
                fi += o.force;
                ti += o.torque_i;
                force[lj] -= o.force;
                torque[lj] += o.torque_j;
            }
        }
        force[li] = fi;
        torque[li] = ti;
        finish_grain(inp, cross, fin, i, g0, force, torque, vel, omega, &mut load, &mut st);
    }
    st
}


/// Where the velocities of a window's grains come from: the whole arrays (phase A) or a block
/// starting at grain `base` (phase B).
#[derive(Clone, Copy)]
struct Velocities<'a, D: Dim> {
    base: usize,
    vel: &'a [D::Vector],
    omega: &'a [D::AngVector],
}

/// Looks at pair `p` = (i, j): when the grains overlap, adds the pair to window `w` (inputs
/// copied in); otherwise forgets a history the pair may still hold (the contact opened) — as
/// `eval_pair`.
///
/// Indices come from the neighbor list and the cross index, which only hold valid grains and
/// pairs of the block being processed; they are checked in debug builds.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn push_pair<D: Dim, H: LawHistory>(w: &mut Window, inp: &Inputs<D>, h: &mut History<D, H>, v: Velocities<D>, a: &Body<D>, p: usize, i: usize, j: usize, st: &mut ForceStats) {
    let k = w.len & (CAP - 1);
    let q = p - h.base;
    debug_assert!(w.len < CAP && j < inp.pos.len() && i >= v.base && j - v.base < v.vel.len() && q < h.spring.len());
    // SAFETY: see above.
    unsafe {
        let xj = *inp.pos.get_unchecked(j);
        let (r, dv) = inp.image.displacement_velocity(a.x, xj);
        let dist2 = r.norm2();
        let (ri, rj) = (a.r, *inp.radius.get_unchecked(j));
        let sum = ri + rj;
        let was = *h.overlap.get_unchecked(q);
        if dist2 >= sum * sum {
            if was > 0.0 {
                h.forget(q, st);
            }
            return;
        }
        w.was[k] = was;
        w.pair[k] = p as u32;
        w.i[k] = i as u32;
        w.j[k] = j as u32;
        lanes::put(&mut w.r, k, r);
        w.dist2[k] = dist2;
        let vj = *v.vel.get_unchecked(j - v.base);
        let vj = if inp.image.sheared { vj + dv } else { vj };
        lanes::put(&mut w.v_rel, k, vj - a.v);
        lanes::put(&mut w.w_i, k, a.w);
        lanes::put(&mut w.w_j, k, *v.omega.get_unchecked(j - v.base));
        w.rad_i[k] = ri;
        w.rad_j[k] = rj;
        w.mass_i[k] = a.m;
        w.mass_j[k] = *inp.mass.get_unchecked(j);
        lanes::put(&mut w.spring, k, h.spring.get_unchecked(q).0);
    }
    w.len += 1;
}

/// Evaluates window `w` (contacts only) and stores the new histories and the statistics (as
/// `eval_pair`). With `VEC` the window was filled by `window512::push_pairs` and the caller enables
/// AVX-512.
#[inline(always)]
fn eval_window<D: Dim, L: WindowLaw, const VEC: bool>(law: &L, inp: &Inputs<D>, h: &mut History<D, L::Extra>, w: &mut Window, st: &mut ForceStats) {
    let len = w.len.min(CAP);
    if law.rolls() {
        // the rolling springs, gathered here (the window's fillers do not know the law)
        for k in 0..len {
            let q = w.pair[k] as usize - h.base;
            debug_assert!(q < h.rolling.len());
            // SAFETY: the window only holds pairs of this history range (`push_pair`, `push_pairs`).
            lanes::put(&mut w.rolling, k, unsafe { *h.rolling.get_unchecked(q) });
        }
    }
    // the law's own histories, gathered here too (none for `()`: no code)
    let mut extra: lanes::Extras<L> = [L::Extra::default(); CAP];
    if std::mem::size_of::<L::Extra>() != 0 {
        for (k, e) in extra.iter_mut().enumerate().take(len) {
            let q = w.pair[k] as usize - h.base;
            debug_assert!(q < h.extra.len());
            // SAFETY: the window only holds pairs of this history range (`push_pair`, `push_pairs`).
            *e = unsafe { *h.extra.get_unchecked(q) };
        }
    }
    if VEC {
        // compiled into the caller, which enables AVX-512
        lanes::compute_inline::<D, L>(law, w, &mut extra, inp.dt);
    } else {
        lanes::compute::<D, L>(law, w, &mut extra, inp.dt);
    }
    let (mut changes, mut sliding) = (0, 0);
    for k in 0..len {
        let q = w.pair[k] as usize - h.base;
        debug_assert!(q < h.spring.len());
        // SAFETY: the window only holds pairs of this history range (`push_pair`, `push_pairs`).
        unsafe {
            *h.spring.get_unchecked_mut(q) = TangentialHistory(lanes::get(&w.new_spring, k));
            *h.overlap.get_unchecked_mut(q) = w.overlap[k];
            *h.sliding.get_unchecked_mut(q) = w.sliding[k];
            if law.rolls() {
                *h.rolling.get_unchecked_mut(q) = lanes::get(&w.new_rolling, k);
            }
            if std::mem::size_of::<L::Extra>() != 0 {
                *h.extra.get_unchecked_mut(q) = extra[k];
            }
        }
        changes += (w.was[k] <= 0.0) as u64;
        sliding += w.sliding[k] as u64;
    }
    st.changes += changes;
    st.contacts += len as u64;
    st.sliding += sliding;
    // Deepest contact: overlap / smaller radius over all lanes at once (stale lanes are
    // ignored), then the first contact reaching a new maximum (as `eval_pair`).
    let mut ratio = [0.0; CAP];
    for k in 0..CAP {
        ratio[k] = w.overlap[k] / if w.rad_i[k] < w.rad_j[k] { w.rad_i[k] } else { w.rad_j[k] };
    }
    let mut top = st.deepest.0;
    for &r in &ratio[..len] {
        top = if r > top { r } else { top };
    }
    if top > st.deepest.0 {
        if let Some(k) = ratio[..len].iter().position(|&r| r == top) {
            st.deepest = (top, 0, w.pair[k] as usize);
        }
    }
}

/// Pushes the pairs `s..e` of owner `i` (`a`) into window `w` one at a time, evaluating the
/// window with `flush` whenever it is full.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn push_owner<D: Dim, H: LawHistory>(
    w: &mut Window,
    inp: &Inputs<D>,
    h: &mut History<D, H>,
    v: Velocities<D>,
    a: &Body<D>,
    i: usize,
    s: usize,
    e: usize,
    st: &mut ForceStats,
    mut flush: impl FnMut(&mut Window, &mut History<D, H>, &mut ForceStats),
) {
    for p in s..e {
        push_pair(w, inp, h, v, a, p, i, inp.partner[p] as usize, st);
        if w.len == CAP {
            flush(w, h, st);
        }
    }
}

/// How the specialised kernels run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Path {
    /// Windows filled pair by pair, the law vectorized by the compiler.
    Portable,
    /// The fused AVX2 pass (`fused`).
    Avx2,
    /// Windows filled eight candidates at a time with AVX-512 (`window512`).
    Avx512,
    /// The fused pass on 512-bit lanes (`fused::Wide16`, AVX-512 F and VL).
    Fused512,
}

impl Path {
    /// The fused pass, on either lane width.
    fn fused(self) -> bool {
        matches!(self, Path::Avx2 | Path::Fused512)
    }
}

/// The path for `level` (0 portable, 1 the fused AVX2 pass, 2 the AVX-512 windows, 3 the fused
/// pass on 512-bit lanes — the default —), each only when the processor has it, the next lower
/// level otherwise. On the AVX-512 processor measured last (a Zen-5 AMD EPYC, `docs/bench-history.md`)
/// the 512-bit lanes were faster than the AVX2 pass (eight lanes: +5.5 to +14 %; sixteen: a
/// further +5 to +16 %), which in turn had been faster than the AVX-512 windows on an Intel Xeon.
fn path(level: u8) -> Path {
    #[cfg(target_arch = "x86_64")]
    {
        if level >= 3 && fused::wide_available() {
            return Path::Fused512;
        }
        if level >= 2 && window512::available() {
            return Path::Avx512;
        }
        if level >= 1 && fused::available() {
            return Path::Avx2;
        }
    }
    let _ = level;
    Path::Portable
}

/// Phase A of the force pass (cross-block pairs) for a law given by its type
/// ([`lanes::with_law`]): the window or fused kernels of a specialised law, the general kernel
/// otherwise.
struct CrossPairs<'a, 'h, D: Dim> {
    inp: &'a Inputs<'a, D>,
    vel: &'a [D::Vector],
    omega: &'a [D::AngVector],
    cross: &'a CrossIndex<D>,
    blocks: usize,
    h: History<'h, D>,
    /// The law's own history of every pair ([`History::with_extra`]).
    extra: &'h mut HistoryColumn,
    out: &'a mut [CrossForce<D>],
    path: Path,
}

impl<D: Dim> lanes::WithLaw for CrossPairs<'_, '_, D> {
    type Out = ForceStats;
    fn special<L: WindowLaw>(self, law: &L) -> ForceStats {
        let h = self.h.with_extra::<L::Extra>(self.extra);
        cross_pairs_windowed(law, self.inp, self.vel, self.omega, self.cross, 0..self.blocks, h, self.out, 0, self.path)
    }
    fn general<P: LawParts>(self, law: &P) -> ForceStats {
        let h = self.h.with_extra::<P::Extra>(self.extra);
        cross_pairs::<D, P>(law, self.inp, self.vel, self.omega, self.cross, 0..self.blocks, h, self.out, 0)
    }
}

/// Phase B of the force pass (blocks, each grain completed as soon as its pairs are summed) for
/// a law given by its type ([`lanes::with_law`]).
struct BlocksPass<'a, 'h, D: Dim> {
    inp: &'a Inputs<'a, D>,
    cross: &'a CrossIndex<D>,
    fin: &'a Finish<'a, D>,
    blocks: usize,
    h: History<'h, D>,
    /// The law's own history of every pair ([`History::with_extra`]).
    extra: &'h mut HistoryColumn,
    g: Grain<'h, D>,
    path: Path,
}

impl<D: Dim> lanes::WithLaw for BlocksPass<'_, '_, D> {
    type Out = ForceStats;
    fn special<L: WindowLaw>(self, law: &L) -> ForceStats {
        let h = self.h.with_extra::<L::Extra>(self.extra);
        blocks_pass_windowed(law, self.inp, self.cross, self.fin, 0..self.blocks, h, self.g, self.path)
    }
    fn general<P: LawParts>(self, law: &P) -> ForceStats {
        let h = self.h.with_extra::<P::Extra>(self.extra);
        blocks_pass::<D, P>(law, self.inp, self.cross, self.fin, 0..self.blocks, h, self.g)
    }
}

/// Phase A with a window kernel.
#[allow(clippy::too_many_arguments)]
fn cross_pairs_windowed<D: Dim, L: WindowLaw>(
    law: &L,
    inp: &Inputs<D>,
    vel: &[D::Vector],
    omega: &[D::AngVector],
    cross: &CrossIndex<D>,
    blocks: std::ops::Range<usize>,
    h: History<D, L::Extra>,
    out: &mut [CrossForce<D>],
    slot_base: usize,
    path: Path,
) -> ForceStats {
    if blocks.len() > 1 {
        let mid = (blocks.start + blocks.end) / 2;
        let (h0, h1) = h.split(inp.owner_start[(mid * cross.block_len).min(cross.n)] as usize);
        let s = cross.block_slot_start[mid] as usize;
        let (o0, o1) = out.split_at_mut(s - slot_base);
        let (a, b) = rayon::join(
            || cross_pairs_windowed(law, inp, vel, omega, cross, blocks.start..mid, h0, o0, slot_base, path),
            || cross_pairs_windowed(law, inp, vel, omega, cross, mid..blocks.end, h1, o1, s, path),
        );
        return ForceStats::merge(a, b);
    }
    // pairs apart contribute zero
    let b = blocks.start;
    out[cross.block_slot_start[b] as usize - slot_base..cross.block_slot_start[b + 1] as usize - slot_base].fill(CrossForce::default());
    #[cfg(target_arch = "x86_64")]
    if path.fused() {
        return lanes::with_dampers(law, fused::CrossPass { law, inp, vel, omega, cross, b, h, out, slot_base, wide: path == Path::Fused512 });
    }
    lanes::with_window(|w| {
        #[cfg(target_arch = "x86_64")]
        if path == Path::Avx512 {
            // SAFETY: this path is chosen only when the processor has AVX-512 F and VL.
            return unsafe { cross_block_avx512(law, inp, vel, omega, cross, blocks.start, h, out, slot_base, w) };
        }
        cross_block::<D, L, false>(law, inp, vel, omega, cross, blocks.start, h, out, slot_base, w)
    })
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,popcnt")]
#[allow(clippy::too_many_arguments)]
fn cross_block_avx512<D: Dim, L: WindowLaw>(
    law: &L,
    inp: &Inputs<D>,
    vel: &[D::Vector],
    omega: &[D::AngVector],
    cross: &CrossIndex<D>,
    b: usize,
    h: History<D, L::Extra>,
    out: &mut [CrossForce<D>],
    slot_base: usize,
    w: &mut Window,
) -> ForceStats {
    cross_block::<D, L, true>(law, inp, vel, omega, cross, b, h, out, slot_base, w)
}

/// Phase A for block `b` (its buffer slots already zeroed: pairs apart contribute zero).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn cross_block<D: Dim, L: WindowLaw, const VEC: bool>(
    law: &L,
    inp: &Inputs<D>,
    vel: &[D::Vector],
    omega: &[D::AngVector],
    cross: &CrossIndex<D>,
    b: usize,
    mut h: History<D, L::Extra>,
    out: &mut [CrossForce<D>],
    slot_base: usize,
    w: &mut Window,
) -> ForceStats {
    let mut st = ForceStats::new();
    let v = Velocities { base: 0, vel, omega };
    let g1 = ((b + 1) * cross.block_len).min(cross.n);
    let (mut s, e) = (cross.block_slot_start[b] as usize, cross.block_slot_start[b + 1] as usize);
    if VEC {
        // the block's cross-block pairs eight at a time across owners, through their slots
        while s < e {
            if w.len + 8 > CAP {
                flush_cross::<D, L, VEC>(law, inp, cross, &mut h, w, &mut st, out, slot_base);
            }
            let q = (s + 8).min(e);
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the slots of block b hold pairs of `h` (cross index); w.len + 8 ≤ CAP;
            // `VEC` only with AVX-512 enabled.
            unsafe {
                window512::push_pairs::<D, L::Extra, true>(w, inp, &mut h, v, &cross.owner, &cross.slot_pair, g1, false, s, q, &mut st);
            }
            s = q;
        }
    } else {
        for i in b * cross.block_len..g1 {
            let (s, e) = (cross.cross_begin[i] as usize, inp.owner_start[i + 1] as usize);
            let a = Body { x: inp.pos[i], v: vel[i], w: omega[i], r: inp.radius[i], m: inp.mass[i] };
            push_owner(w, inp, &mut h, v, &a, i, s, e, &mut st, |w, h, st| flush_cross::<D, L, VEC>(law, inp, cross, h, w, st, out, slot_base));
        }
    }
    if w.len > 0 {
        flush_cross::<D, L, VEC>(law, inp, cross, &mut h, w, &mut st, out, slot_base);
    }
    st
}

/// Evaluates the window of phase A and stores its forces in their buffer slots.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn flush_cross<D: Dim, L: WindowLaw, const VEC: bool>(
    law: &L,
    inp: &Inputs<D>,
    cross: &CrossIndex<D>,
    h: &mut History<D, L::Extra>,
    w: &mut Window,
    st: &mut ForceStats,
    out: &mut [CrossForce<D>],
    slot_base: usize,
) {
    eval_window::<D, L, VEC>(law, inp, h, w, st);
    for k in 0..w.len.min(CAP) {
        // buffer slot of pair p (owner i): its cross pairs use consecutive slots
        let (i, p) = (w.i[k] as usize, w.pair[k] as usize);
        let slot = cross.cross_slot[i] as usize + (p - cross.cross_begin[i] as usize) - slot_base;
        out[slot] = CrossForce { force: lanes::get(&w.force, k), torque_i: lanes::get(&w.torque_i, k), torque_j: lanes::get(&w.torque_j, k) };
    }
    w.len = 0;
}

/// Phase B with a window kernel: intra-block pairs are evaluated a window at a time, then added
/// in list order; a grain is completed once all its pairs have been added.
#[allow(clippy::too_many_arguments)]
fn blocks_pass_windowed<D: Dim, L: WindowLaw>(
    law: &L,
    inp: &Inputs<D>,
    cross: &CrossIndex<D>,
    fin: &Finish<D>,
    blocks: std::ops::Range<usize>,
    h: History<D, L::Extra>,
    g: Grain<D>,
    path: Path,
) -> ForceStats {
    if blocks.len() > 1 {
        let mid = (blocks.start + blocks.end) / 2;
        let at = (mid * cross.block_len).min(cross.n);
        let (h0, h1) = h.split(inp.owner_start[at] as usize);
        let (g0, g1) = g.split(at);
        let (a, b) = rayon::join(
            || blocks_pass_windowed(law, inp, cross, fin, blocks.start..mid, h0, g0, path),
            || blocks_pass_windowed(law, inp, cross, fin, mid..blocks.end, h1, g1, path),
        );
        return ForceStats::merge(a, b);
    }
    #[cfg(target_arch = "x86_64")]
    if path.fused() {
        return lanes::with_dampers(law, fused::BlockPass { law, inp, cross, fin, b: blocks.start, h, g, wide: path == Path::Fused512 });
    }
    lanes::with_window(|w| {
        #[cfg(target_arch = "x86_64")]
        if path == Path::Avx512 {
            // SAFETY: this path is chosen only when the processor has AVX-512 F and VL.
            return unsafe { block_windowed_avx512(law, inp, cross, fin, blocks.start, h, g, w) };
        }
        block_windowed::<D, L, false>(law, inp, cross, fin, blocks.start, h, g, w)
    })
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,popcnt")]
#[allow(clippy::too_many_arguments)]
fn block_windowed_avx512<D: Dim, L: WindowLaw>(law: &L, inp: &Inputs<D>, cross: &CrossIndex<D>, fin: &Finish<D>, b: usize, h: History<D, L::Extra>, g: Grain<D>, w: &mut Window) -> ForceStats {
    block_windowed::<D, L, true>(law, inp, cross, fin, b, h, g, w)
}

/// Evaluates the window of phase B and adds its forces to the block's grains in list order.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn flush_block<D: Dim, L: WindowLaw, const VEC: bool>(
    law: &L,
    inp: &Inputs<D>,
    g0: usize,
    h: &mut History<D, L::Extra>,
    w: &mut Window,
    st: &mut ForceStats,
    force: &mut [D::Vector],
    torque: &mut [D::AngVector],
) {
    eval_window::<D, L, VEC>(law, inp, h, w, st);
    // In list order; consecutive pairs of one grain are summed in registers (same order).
    let len = w.len.min(CAP);
    let mut k = 0;
    while k < len {
        let li = w.i[k] as usize - g0;
        let (mut fi, mut ti) = (force[li], torque[li]);
        while k < len && w.i[k] as usize - g0 == li {
            let lj = w.j[k] as usize - g0;
            debug_assert!(lj < force.len() && lj != li);
            let f: D::Vector = lanes::get(&w.force, k);
            fi += f;
            ti += lanes::get::<D::AngVector>(&w.torque_i, k);
            // SAFETY: intra-block partners lie in the block (cross index).
            unsafe {
                *force.get_unchecked_mut(lj) -= f;
                *torque.get_unchecked_mut(lj) += lanes::get::<D::AngVector>(&w.torque_j, k);
            }
            k += 1;
        }
        force[li] = fi;
        torque[li] = ti;
    }
    w.len = 0;
}

/// Phase B for block `b`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn block_windowed<D: Dim, L: WindowLaw, const VEC: bool>(law: &L, inp: &Inputs<D>, cross: &CrossIndex<D>, fin: &Finish<D>, b: usize, mut h: History<D, L::Extra>, g: Grain<D>, w: &mut Window) -> ForceStats {
    let mut st = ForceStats::new();
    let (g0, g1) = (b * cross.block_len, ((b + 1) * cross.block_len).min(cross.n));
    let Grain { force, torque, vel, omega, .. } = g;
    start_block(cross, g0, g1, force, torque);
    let mut load = fin.loads.partition_point(|l| l.0 < g0);
    if VEC {
        // The block's pairs eight at a time across owners (its cross-block pairs left out);
        // after each flush, the grains whose intra-block pairs were all pushed are complete
        // (pairs where they are the partner come earlier in the list).
        let mut done = g0;
        let (mut p, e) = (inp.owner_start[g0] as usize, inp.owner_start[g1] as usize);
        while p < e {
            if w.len + 8 > CAP {
                flush_block::<D, L, VEC>(law, inp, g0, &mut h, w, &mut st, force, torque);
                while done < g1 && cross.cross_begin[done] as usize <= p {
                    finish_grain(inp, cross, fin, done, g0, force, torque, vel, omega, &mut load, &mut st);
                    done += 1;
                }
            }
            let q = (p + 8).min(e);
            #[cfg(target_arch = "x86_64")]
            // SAFETY: the block's pairs are pairs of `h` with owners in the block; intra-block
            // partners lie in the block; w.len + 8 ≤ CAP; `VEC` only with AVX-512 enabled.
            unsafe {
                window512::push_pairs::<D, L::Extra, false>(w, inp, &mut h, Velocities { base: g0, vel: &*vel, omega: &*omega }, &cross.owner, &[], g1, true, p, q, &mut st);
            }
            p = q;
        }
        if w.len > 0 {
            flush_block::<D, L, VEC>(law, inp, g0, &mut h, w, &mut st, force, torque);
        }
        while done < g1 {
            finish_grain(inp, cross, fin, done, g0, force, torque, vel, omega, &mut load, &mut st);
            done += 1;
        }
        return st;
    }
    // grains < `pushed` have all their intra-block pairs in the window or added; grains < `done`
    // are complete
    let (mut pushed, mut done) = (g0, g0);
    for i in g0..g1 {
        let a = Body { x: inp.pos[i], v: vel[i - g0], w: omega[i - g0], r: inp.radius[i], m: inp.mass[i] };
        let (s, e) = (inp.owner_start[i] as usize, cross.cross_begin[i] as usize);
        let mut flushed = false;
        {
            let v = Velocities { base: g0, vel: &*vel, omega: &*omega };
            push_owner(w, inp, &mut h, v, &a, i, s, e, &mut st, |w, h, st| {
                flush_block::<D, L, VEC>(law, inp, g0, h, w, st, force, torque);
                flushed = true;
            });
        }
        if flushed {
            while done < pushed {
                finish_grain(inp, cross, fin, done, g0, force, torque, vel, omega, &mut load, &mut st);
                done += 1;
            }
        }
        pushed = i + 1;
        if w.len == 0 {
            while done < pushed {
                finish_grain(inp, cross, fin, done, g0, force, torque, vel, omega, &mut load, &mut st);
                done += 1;
            }
        }
    }
    if w.len > 0 {
        flush_block::<D, L, VEC>(law, inp, g0, &mut h, w, &mut st, force, torque);
    }
    while done < g1 {
        finish_grain(inp, cross, fin, done, g0, force, torque, vel, omega, &mut load, &mut st);
        done += 1;
    }
    st
}

impl<D: Dim> Simulation<D> {
    /// Rebuilds the neighbor list if needed (`max_displacement2`: the largest squared
    /// displacement since the last build, when already known), and the derived buffers.
    pub(crate) fn prepare_neighbors(&mut self, max_displacement2: Option<f64>) -> Result<()> {
        // The force passes index the per-grain arrays and the histories with the list's indices
        // without checking them (raw pointers on the vector paths): checked here, in safe code,
        // every time (the lengths; O(1)) and whenever the index of the passes is rebuilt (the
        // list's structure; O(pairs), once per list build). A decoded simulation was checked
        // already (`sim::validate`); this guards states changed by hand through the public fields.
        let n = self.grains.len();
        let g = &self.grains;
        let lens = [g.radius.len(), g.mass.len(), g.inertia.len(), g.pos.len(), g.vel.len(), g.omega.len(), g.orientation.len(), g.image.len(), g.force.len(), g.torque.len()];
        if lens.iter().any(|&l| l != n) {
            return Err(CoreError::Inconsistent(format!("per-grain arrays of different lengths ({lens:?} for {n} grain ids)")));
        }
        // a wall driven beyond what can be integrated (a piston of tiny mass under a huge force,
        // a huge speed) reaches a non-finite position or velocity: the grains near it would follow
        // to non-finite positions, and a run could end "converged" with them (checked every step:
        // O(walls))
        self.check_walls()?;
        if self.nlist.needs_rebuild(&self.grains.pos, &self.domain, max_displacement2) {
            self.check_confinement()?;
            self.nlist.rebuild(&self.grains.pos, &self.grains.radius, &self.grains.id, &self.domain);
        }
        if self.work.wall_index_builds != self.nlist.builds || self.work.wall_force.len() != self.nlist.wall_pairs.len() {
            self.work.wall_index = self.nlist.wall_index(n);
            self.work.wall_force = vec![WallForce::default(); self.nlist.wall_pairs.len()];
            self.work.wall_index_builds = self.nlist.builds;
        }
        let len = self.work.block_len.unwrap_or_else(|| block_len(n, rayon::current_num_threads()));
        if self.work.cross.builds != self.nlist.builds || self.work.cross.block_len != len || self.work.cross.n != n {
            self.nlist.list.check_structure(n, true).map_err(|e| CoreError::Inconsistent(format!("neighbor list: {e}")))?;
            self.work.cross.rebuild(&self.nlist.list, n, len, self.nlist.builds);
        }
        Ok(())
    }

    /// Blow-up check done at every rebuild: finite positions, no grain behind a wall.
    fn check_confinement(&self) -> Result<()> {
        let g = &self.grains;
        if let Some(k) = (0..g.len()).into_par_iter().find_first(|&k| !g.pos[k].is_finite_vec() || !g.vel[k].is_finite_vec()) {
            return Err(self.blow_up(k, "non-finite position or velocity".into()));
        }
        for wall in &self.domain.walls {
            if let Some(k) = (0..g.len()).into_par_iter().find_first(|&k| wall.distance(g.pos[k]) < 0.0) {
                return Err(self.blow_up(k, format!("the grain left the domain through wall `{}`", wall.name)));
            }
        }
        Ok(())
    }

    /// Blow-up check done at every step: every wall's position and velocity finite.
    fn check_walls(&self) -> Result<()> {
        for wall in &self.domain.walls {
            let (x, v) = (wall.position, wall.velocity());
            if !(x.is_finite_vec() && v.is_finite_vec()) {
                let reason = format!(
                    "wall `{}` reached a non-finite position {:?} or velocity {:?} (its motion — speed, or piston force / mass — is beyond what the integration can represent)",
                    wall.name,
                    x.to_array3(),
                    v.to_array3()
                );
                if self.grains.len() > 0 {
                    return Err(self.blow_up(0, reason));
                }
                return Err(CoreError::BlowUp { step: self.step, time: self.time, grain: 0, reason, position: [0.0; 3], velocity: [0.0; 3], force: [0.0; 3] });
            }
        }
        Ok(())
    }

    /// Builds the blow-up error for grain (storage index) `k`.
    pub(crate) fn blow_up(&self, k: usize, reason: String) -> CoreError {
        let g = &self.grains;
        CoreError::BlowUp {
            step: self.step,
            time: self.time,
            grain: g.id[k],
            reason,
            position: g.pos[k].to_array3(),
            velocity: g.vel[k].to_array3(),
            force: g.force[k].to_array3(),
        }
    }

    /// Computes all forces and torques at the current positions (call
    /// [`Simulation::prepare_neighbors`] first). Contact histories advance by `dt_hist` (0
    /// re-evaluates without advancing). With `use_eval` the velocities in the workspace
    /// (Beeman's predicted velocities) are used instead of the grains' own. With `kick = Some(h)`
    /// the pass that completes each grain's force also advances its velocity by h·F/m and its
    /// angular velocity by h·τ/I (velocity Verlet's second half kick).
    pub(crate) fn compute_forces(&mut self, dt_hist: f64, use_eval: bool, kick: Option<f64>) -> Result<()> {
        let specialized = if self.work.general_kernel { self.law.general() } else { self.law.specialize() };
        let time = self.time;
        let (grain_law, overlap_limit) = (self.law, self.safety.max_overlap_fraction);
        let Simulation { grains, domain, nlist, work, loads, gravity, .. } = self;
        let n = grains.len();

        // Grain–wall contacts, into their buffer: the walls whose law keeps no history of its
        // own in one pass over the wall pairs, then each wall whose law keeps one in a pass of
        // its own over its column ([`WallHistory`](crate::contact::WallHistory))
        let walls = &domain.walls;
        let (pos, radius, mass) = (&grains.pos, &grains.radius, &grains.mass);
        let (vel, omega) = if use_eval { (&work.vel_eval[..], &work.omega_eval[..]) } else { (&grains.vel[..], &grains.omega[..]) };
        let at = WallInputs { walls, pos, radius, mass, vel, omega, dt: dt_hist, grain_law, overlap_limit };
        let with_history = walls.iter().any(|w| w.law.has_history());
        let mut wall_stats = nlist
            .wall_pairs
            .par_iter_mut()
            .zip(work.wall_force.par_iter_mut())
            .enumerate()
            .with_min_len(512)
            .map(|(k, (wp, out))| {
                let law = &walls[wp.wall as usize].law;
                if with_history && law.has_history() {
                    return ForceStats::new();
                }
                wall_contact(law, &at, k, wp, out, &mut ())
            })
            .reduce(ForceStats::new, ForceStats::merge);
        if with_history {
            for (w, wall) in walls.iter().enumerate().filter(|(_, wall)| wall.law.has_history()) {
                let column = nlist.wall_extra.column_mut(w, walls.len());
                let pass = WallPass { wall: w as u32, at: &at, pairs: &mut nlist.wall_pairs, out: &mut work.wall_force, column };
                wall_stats = ForceStats::merge(wall_stats, NormalElastic::route(&wall.law, pass));
            }
        }

        // External loads now, by grain.
        work.loads.clear();
        for load in loads.iter() {
            if let Some(k) = grains.index_of(load.grain) {
                let s = load.profile.eval(time);
                work.loads.push((k, load.force * s, load.torque * s));
            }
        }
        work.loads.sort_by_key(|l| l.0);

        let list = &mut nlist.list;
        let cross = &mut work.cross;
        let mut forces = std::mem::take(&mut cross.forces);
        let inp = Inputs { image: domain.image(), dt: dt_hist, pos, radius, mass, owner_start: &list.owner_start, partner: &list.partner };
        let blocks = n.div_ceil(cross.block_len);
        let mut kernels = path(work.simd);
        // The fused pass keeps grain and pair indices, and three times them, in 32-bit lanes
        // (signed compares): far beyond any packing that fits in memory, but checked.
        const FUSED_LIMIT: usize = (u32::MAX / 3) as usize;
        if kernels.fused() && (n > FUSED_LIMIT || list.partner.len() > FUSED_LIMIT) {
            kernels = Path::Portable;
        }

        // Phase A: cross-block pairs.
        let cross_stats = if forces.is_empty() {
            ForceStats::new()
        } else {
            let h = History::of_parts(&mut list.spring, &mut list.overlap, &mut list.sliding, &mut list.rolling, &mut list.twist);
            lanes::with_law(specialized, CrossPairs { inp: &inp, vel, omega, cross, blocks, h, extra: &mut list.extra, out: &mut forces, path: kernels })
        };
        cross.forces = forces;

        // Phase B: blocks, each grain completed as soon as its pairs are summed.
        let fin = Finish {
            gravity: *gravity,
            inertia: &grains.inertia,
            wall_start: &work.wall_index.start,
            wall_force: &work.wall_force,
            loads: &work.loads,
            kick: if use_eval { None } else { kick },
        };
        // (a displacement measured by the drift pass is for these positions only: always taken)
        let known = work.cross.close_known.take();
        // (3D only: in 2D the list would skip only ≈ 10 % of the pairs, and its displacement
        // check cost two-worker runs 6–15 %, docs/bench-history.md)
        if D::D == 3 && kernels.fused() && specialized.has_window_kernel() && n > 0 {
            work.cross.ensure_close(list, pos, radius, mass, domain, CLOSE_FRACTION * nlist.skin, known, kernels == Path::Fused512);
        }
        let (gv, gw) = if use_eval { (&mut work.vel_eval, &mut work.omega_eval) } else { (&mut grains.vel, &mut grains.omega) };
        let g = Grain { base: 0, force: &mut grains.force, torque: &mut grains.torque, vel: gv, omega: gw };
        let h = History::of_parts(&mut list.spring, &mut list.overlap, &mut list.sliding, &mut list.rolling, &mut list.twist);
        let cross = &work.cross;
        let pair_stats = if n == 0 {
            ForceStats::new()
        } else {
            lanes::with_law(specialized, BlocksPass { inp: &inp, cross, fin: &fin, blocks, h, extra: &mut list.extra, g, path: kernels })
        };
        let stats = ForceStats::merge(ForceStats::merge(pair_stats, cross_stats), wall_stats);

        // Forces on walls, in list order.
        for w in domain.walls.iter_mut() {
            w.force = D::Vector::ZERO;
        }
        for (wp, out) in nlist.wall_pairs.iter().zip(work.wall_force.iter()) {
            domain.walls[wp.wall as usize].force -= out.force;
        }

        self.counters.network_changes = stats.changes;
        self.counters.contacts = stats.contacts;
        self.counters.sliding = stats.sliding;
        if stats.deepest.0 > self.counters.max_overlap_ratio_seen {
            self.counters.max_overlap_ratio_seen = stats.deepest.0;
        }
        if stats.bad < n {
            return Err(self.blow_up(stats.bad, "non-finite force or torque".into()));
        }
        if stats.deepest.0 > self.safety.max_overlap_fraction {
            let (ratio, is_wall, idx) = stats.deepest;
            let limit = self.safety.max_overlap_fraction;
            let (k, partner, ratio, limit) = if is_wall == 0 {
                let list = &self.nlist.list;
                (list.owner_of(idx), format!("grain id {}", self.grains.id[list.partner[idx] as usize]), ratio, limit)
            } else {
                let wp = &self.nlist.wall_pairs[idx];
                let wall = &self.domain.walls[wp.wall as usize];
                let scale = wall_overlap_scale(&self.law, &wall.law, limit);
                (wp.grain as usize, format!("wall `{}`", wall.name), ratio / scale, limit / scale)
            };
            return Err(self.blow_up(
                k,
                format!("overlap with {partner} reached {ratio:.3} of the smaller radius (limit {limit:.3}, key `max_overlap_fraction`)"),
            ));
        }
        Ok(())
    }

    /// Piston accelerations from the current wall forces: M a = F_ext(t) + F_grains·n̂.
    pub(crate) fn update_piston_accelerations(&mut self) {
        let t = self.time;
        for w in &mut self.domain.walls {
            if let WallMotion::Piston { mass, force } = &w.motion {
                w.accel = (force.eval(t) + w.force.dot(w.normal)) / mass;
            }
        }
    }
}

impl<'a, D: Dim> History<'a, D> {
    fn of_parts(
        spring: &'a mut [TangentialHistory<D::Vector>],
        overlap: &'a mut [f64],
        sliding: &'a mut [bool],
        rolling: &'a mut [D::AngVector],
        twist: &'a mut [f64],
    ) -> Self {
        // (a slice of zero-sized values: no memory, no loop)
        let extra = crate::contact::zero_sized_slice(overlap.len());
        History { base: 0, spring, overlap, sliding, rolling, twist, extra }
    }
}

impl<D: Dim> CrossIndex<D> {
    /// Index of the cross-block pairs of `list` for `n` grains in blocks of `block_len`.
    pub(super) fn rebuild(&mut self, list: &PairList<D>, n: usize, block_len: usize, builds: u64) {
        let blocks = n.div_ceil(block_len);
        self.builds = builds;
        self.block_len = block_len;
        self.n = n;
        self.owner.clear();
        self.owner.resize(list.partner.len(), 0);
        for i in 0..n {
            self.owner[list.owner_start[i] as usize..list.owner_start[i + 1] as usize].fill(i as u32);
        }
        self.cross_begin.resize(n, 0);
        self.cross_slot.resize(n, 0);
        self.block_slot_start.clear();
        self.slot_pair.clear();
        let mut slots = 0u32;
        for b in 0..blocks {
            self.block_slot_start.push(slots);
            let end = ((b + 1) * block_len).min(n);
            for i in b * block_len..end {
                let (s, e) = (list.owner_start[i] as usize, list.owner_start[i + 1] as usize);
                let cb = s + list.partner[s..e].partition_point(|&j| (j as usize) < end);
                self.cross_begin[i] = cb as u32;
                self.cross_slot[i] = slots;
                self.slot_pair.extend(cb as u32..e as u32);
                slots += (e - cb) as u32;
            }
        }
        self.block_slot_start.push(slots);
        // Incoming contributions per partner, in slot order (that is, by owner).
        self.in_start.clear();
        self.in_start.resize(n + 1, 0);
        for i in 0..n {
            for p in self.cross_begin[i] as usize..list.owner_start[i + 1] as usize {
                self.in_start[list.partner[p] as usize + 1] += 1;
            }
        }
        for j in 0..n {
            self.in_start[j + 1] += self.in_start[j];
        }
        self.in_slot.resize(slots as usize, 0);
        let mut fill = self.in_start.clone();
        for i in 0..n {
            let mut slot = self.cross_slot[i];
            for p in self.cross_begin[i] as usize..list.owner_start[i + 1] as usize {
                let j = list.partner[p] as usize;
                self.in_slot[fill[j] as usize] = slot;
                fill[j] += 1;
                slot += 1;
            }
        }
        self.forces.clear();
        self.forces.resize(slots as usize, CrossForce::default());
        self.close_ok = false;
    }

    /// Keeps the close list valid for the grains at `pos` (see "Close list" in the module
    /// documentation): rebuilt when it is missing, when the margin changed, or when a grain may
    /// have moved so far since it was built (2·max|x − x_ref| + Σ|Δtilt| above 0.9 × margin;
    /// the 10 % slack covers rounding in the distances) that an excluded pair could touch.
    /// `known`: max|x − close_ref|² when already measured (by the drift pass).
    #[allow(clippy::too_many_arguments)]
    fn ensure_close(&mut self, list: &PairList<D>, pos: &[D::Vector], radius: &[f64], mass: &[f64], domain: &Domain<D>, margin: f64, known: Option<f64>, wide: bool) {
        let tilt = domain.tilt;
        if self.close_ok && self.close_margin == margin && self.close_ref.len() == pos.len() {
            let tilt_change: f64 = tilt.iter().zip(&self.close_tilt).map(|(t, r)| (t - r).abs()).sum();
            let max_d2 = known.unwrap_or_else(|| max_displacement2_since(&self.close_ref, pos, domain));
            // false for NaN: rebuilt (and the pairs of NaN grains kept)
            if 2.0 * max_d2.sqrt() + tilt_change <= 0.9 * margin {
                return;
            }
        }
        let blocks = self.n.div_ceil(self.block_len.max(1));
        let image = &domain.image();
        // 3D cells that are not sheared: eight pairs at a time on AVX-512 (the same decisions)
        #[cfg(target_arch = "x86_64")]
        let wide = wide && D::D == 3 && !image.sheared && std::mem::size_of::<D::Vector>() == 24 && fused::wide_available() && self.owner.len() == list.partner.len();
        #[cfg(target_arch = "x86_64")]
        let (period, inverse) = image.lengths_and_inverses();
        #[cfg(not(target_arch = "x86_64"))]
        let _ = wide;
        let this = &*self;
        let parts: Vec<[Vec<u32>; 3]> = (0..blocks)
            .into_par_iter()
            .map(|b| {
                let (g0, g1) = (b * this.block_len, ((b + 1) * this.block_len).min(this.n));
                let mut out: [Vec<u32>; 3] = Default::default();
                #[cfg(target_arch = "x86_64")]
                if wide {
                    let pairs = list.owner_start[g0] as usize..list.owner_start[g1] as usize;
                    // SAFETY: AVX-512 F and VL are available (`wide`); 3D vectors are three
                    // f64; the block's pairs index the list's arrays and their grains `pos`.
                    unsafe { fused::close_filter_wide(pos.as_ptr() as *const f64, radius, &this.owner, &list.partner, &list.overlap, pairs, g1, margin, period, inverse, &mut out) };
                    return out;
                }
                for i in g0..g1 {
                    let (xi, ri) = (pos[i], radius[i]);
                    for p in list.owner_start[i] as usize..this.cross_begin[i] as usize {
                        let j = list.partner[p] as usize;
                        let d = image.displacement(xi, pos[j]);
                        let cut = ri + radius[j] + margin;
                        // true for NaN; a held contact is kept so that its opening is seen
                        if !(d.dot(d) >= cut * cut) || list.overlap[p] > 0.0 {
                            out[0].push(p as u32);
                            out[1].push(i as u32);
                            out[2].push(j as u32);
                        }
                    }
                }
                out
            })
            .collect();
        self.close_start.clear();
        self.close_pair.clear();
        self.close_owner.clear();
        self.close_partner.clear();
        for [pair, owner, partner] in &parts {
            self.close_start.push(self.close_pair.len() as u32);
            self.close_pair.extend_from_slice(pair);
            self.close_owner.extend_from_slice(owner);
            self.close_partner.extend_from_slice(partner);
        }
        // the radii and reduced mass of each kept pair (as `lanes::contact` computes it)
        let m = self.close_pair.len();
        for a in [&mut self.close_rad_i, &mut self.close_rad_j, &mut self.close_m_eff] {
            a.resize(m, 0.0);
        }
        self.close_rad_i
            .par_iter_mut()
            .zip(self.close_rad_j.par_iter_mut())
            .zip(self.close_m_eff.par_iter_mut())
            .zip(self.close_owner.par_iter().zip(self.close_partner.par_iter()))
            .with_min_len(4096)
            .for_each(|(((ri, rj), me), (&i, &j))| {
                let (i, j) = (i as usize, j as usize);
                (*ri, *rj) = (radius[i], radius[j]);
                *me = mass[i] * mass[j] / (mass[i] + mass[j]);
            });
        self.close_start.push(self.close_pair.len() as u32);
        self.close_ref.clear();
        self.close_ref.extend_from_slice(pos);
        self.close_tilt = tilt;
        self.close_margin = margin;
        self.close_ok = true;
        self.close_builds += 1;
    }
}

/// Margin of the close list as a fraction of the neighbor-list skin.
const CLOSE_FRACTION: f64 = 0.3;

/// Read-only inputs of the grain–wall evaluations.
struct WallInputs<'a, D: Dim> {
    walls: &'a [crate::domain::Wall<D>],
    pos: &'a [D::Vector],
    radius: &'a [f64],
    mass: &'a [f64],
    vel: &'a [D::Vector],
    omega: &'a [D::AngVector],
    dt: f64,
    grain_law: ContactLaw,
    overlap_limit: f64,
}

/// Evaluates grain–wall pair `k` (`wp`) with the parts `law` of its wall's law, reading and
/// updating the law's own history `extra` (`()` for a law without: the code of the general
/// evaluation); forgets its histories when the contact has opened. Its force and torque on the
/// grain go to `out`.
#[inline(always)]
fn wall_contact<D: Dim, P: LawParts>(law: &P, at: &WallInputs<D>, k: usize, wp: &mut crate::neighbor::WallPair<D>, out: &mut WallForce<D>, extra: &mut P::Extra) -> ForceStats {
    let g = wp.grain as usize;
    let wall = &at.walls[wp.wall as usize];
    let kin = wall_kinematics::<D>(wall.distance(at.pos[g]), wall.normal, wall.velocity(), at.radius[g], at.mass[g], at.vel[g], at.omega[g]);
    let was = wp.state.in_contact();
    match kin {
        None => {
            *out = WallForce::default();
            if was {
                wp.state = ContactState::default();
                *extra = Default::default();
            }
            ForceStats { changes: was as u64, ..ForceStats::new() }
        }
        Some(kin) => {
            let o = evaluate_parts(law, &kin, &mut wp.state, extra, at.dt);
            (out.force, out.torque, _) = contact_loads(&kin, &o);
            ForceStats {
                changes: !was as u64,
                contacts: 1,
                sliding: o.sliding as u64,
                deepest: (kin.overlap / at.radius[g] * wall_overlap_scale(&at.grain_law, &wall.law, at.overlap_limit), 1, k),
                bad: usize::MAX,
            }
        }
    }
}

/// The pass over the pairs of one wall whose law keeps a history of its own: run with the law's
/// parts as a type (`NormalElastic::route`), so that the wall's column is opened as that law's
/// history (one entry per wall pair; those of other walls' pairs are left as they are).
struct WallPass<'a, 'b, D: Dim> {
    wall: u32,
    at: &'a WallInputs<'b, D>,
    pairs: &'a mut [crate::neighbor::WallPair<D>],
    out: &'a mut [WallForce<D>],
    column: &'a mut HistoryColumn,
}

impl<D: Dim> crate::contact::VisitParts for WallPass<'_, '_, D> {
    type Out = ForceStats;
    fn visit<P: LawParts>(self, law: &P) -> ForceStats {
        let WallPass { wall, at, pairs, out, column } = self;
        let history = column.typed_mut::<P::Extra>(pairs.len());
        pairs
            .par_iter_mut()
            .zip(out.par_iter_mut())
            .zip(history.par_iter_mut())
            .enumerate()
            .with_min_len(512)
            .filter(|(_, ((wp, _), _))| wp.wall == wall)
            .map(|(k, ((wp, out), extra))| wall_contact(law, at, k, wp, out, extra))
            .reduce(ForceStats::new, ForceStats::merge)
    }
}

/// Factor applied to a grain–wall overlap ratio ξ/R before the blow-up guard compares it with
/// `limit` (`max_overlap_fraction`): a linear wall softer than the linear grain law by k_g/k_w
/// (an absorbing wall, SPEC §6.7: K_n/√N) carries the force of a grain contact at an overlap
/// k_g/k_w times deeper, so its guard is `limit` × k_g/k_w, capped at 1 (the grain's centre on the
/// wall plane, past which the confinement check stops the run anyway). Every other pair: 1.
pub(crate) fn wall_overlap_scale(grain: &ContactLaw, wall: &ContactLaw, limit: f64) -> f64 {
    match (&grain.normal, &wall.normal) {
        (&NormalElastic::Hooke(Hooke { stiffness: kg }), &NormalElastic::Hooke(Hooke { stiffness: kw })) if kw > 0.0 && kw < kg => {
            let wall_limit = (limit * kg / kw).min(1.0).max(limit);
            limit / wall_limit
        }
        _ => 1.0,
    }
}
