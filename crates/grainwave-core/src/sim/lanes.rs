//! The specialised contact kernels, evaluated a window of contacts at a time.
//!
//! A window holds up to [`CAP`] contacts (pairs known to overlap) copied into structure-of-arrays
//! scratch. The whole contact law is then one branch-free loop over the window — conditions
//! become selects — that the compiler vectorizes: 2 contacts per instruction with the baseline
//! x86-64 target (SSE2), 4 with AVX2, which is detected at run time ([`compute`]). Each lane
//! performs exactly the floating-point operations of
//! [`evaluate_parts`](crate::contact::evaluate_parts) on the same parts, in the same order (no
//! fused multiply–add), so the result is bitwise that of the general kernel (tested on whole
//! runs).

use crate::contact::{HertzMindlin, HookeCundallStrack, NormalDamping, TangentialDamping};
use crate::dim::{Dim, VectorOps};

/// Contacts per window.
pub(super) const CAP: usize = 32;

type Lane = [f64; CAP];
const ZERO: Lane = [0.0; CAP];

/// Structure-of-arrays scratch for one window of contacts.
#[derive(Clone)]
pub(super) struct Window {
    /// Contacts in the window.
    pub len: usize,
    /// Pair index, first grain, second grain.
    pub pair: [u32; CAP],
    pub i: [u32; CAP],
    pub j: [u32; CAP],
    // inputs
    /// Centre-to-centre vector (nearest image) and its squared length.
    pub r: [Lane; 3],
    pub dist2: Lane,
    /// v_j − v_i (v_j of the image of j).
    pub v_rel: [Lane; 3],
    /// ω_i, ω_j (one component in 2D).
    pub w_i: [Lane; 3],
    pub w_j: [Lane; 3],
    pub rad_i: Lane,
    pub rad_j: Lane,
    pub mass_i: Lane,
    pub mass_j: Lane,
    /// Stored tangential history.
    pub spring: [Lane; 3],
    /// Overlap at the last evaluation (the stored one).
    pub was: Lane,
    // outputs
    pub overlap: Lane,
    pub sliding: [bool; CAP],
    pub new_spring: [Lane; 3],
    pub force: [Lane; 3],
    pub torque_i: [Lane; 3],
    pub torque_j: [Lane; 3],
}

impl Window {
    pub fn new() -> Box<Self> {
        Box::new(Window {
            len: 0,
            pair: [0; CAP],
            i: [0; CAP],
            j: [0; CAP],
            r: [ZERO; 3],
            dist2: ZERO,
            v_rel: [ZERO; 3],
            w_i: [ZERO; 3],
            w_j: [ZERO; 3],
            rad_i: [1.0; CAP],
            rad_j: [1.0; CAP],
            mass_i: [1.0; CAP],
            mass_j: [1.0; CAP],
            spring: [ZERO; 3],
            was: ZERO,
            overlap: ZERO,
            sliding: [false; CAP],
            new_spring: [ZERO; 3],
            force: [ZERO; 3],
            torque_i: [ZERO; 3],
            torque_j: [ZERO; 3],
        })
    }
}

thread_local! {
    /// One window per thread, allocated once.
    static WINDOW: std::cell::RefCell<Box<Window>> = std::cell::RefCell::new(Window::new());
}

/// Runs `f` with this thread's window (emptied).
pub(super) fn with_window<R>(f: impl FnOnce(&mut Window) -> R) -> R {
    WINDOW.with(|w| {
        let mut w = w.borrow_mut();
        w.len = 0;
        f(&mut w)
    })
}

pub(crate) use crate::real::Real;

/// The normal and tangential elastic parts of a specialised law, per contact.
pub(super) trait WindowLaw: Copy + Send + Sync {
    /// F_el, k_n, secant k̄ and the contact radius √(R*ξ) (0 when not used), as `NormalElastic::response`.
    fn normal<R: Real>(&self, r_eff: R, overlap: R) -> (R, R, R, R);
    /// k_t from the contact radius, as `Tangential::stiffness`.
    fn tangential_stiffness<R: Real>(&self, contact_radius: R) -> R;
    /// Trial force and the history kept when not sliding, from the rotated history.
    fn trial<R: Real, const DIM: usize>(&self, rotated: [R; 3], v_t: [R; 3], k_t: R, gamma_t: R, dt: f64) -> ([R; 3], [R; 3]);
    /// The history kept when sliding with force `f`.
    fn slid<R: Real, const DIM: usize>(&self, f: [R; 3]) -> [R; 3];
    fn damping(&self) -> NormalDamping;
    fn tangential_damping(&self) -> TangentialDamping;
    fn friction(&self) -> f64;
}

impl WindowLaw for HertzMindlin {
    #[inline(always)]
    fn normal<R: Real>(&self, r_eff: R, overlap: R) -> (R, R, R, R) {
        let a = (r_eff * overlap).sqrt();
        let secant = R::splat(4.0 / 3.0 * self.effective_modulus) * a;
        (secant * overlap, R::splat(2.0 * self.effective_modulus) * a, secant, a)
    }
    #[inline(always)]
    fn tangential_stiffness<R: Real>(&self, a: R) -> R {
        R::splat(8.0 * self.effective_shear_modulus) * a
    }
    #[inline(always)]
    fn trial<R: Real, const DIM: usize>(&self, rotated: [R; 3], v_t: [R; 3], k_t: R, gamma_t: R, dt: f64) -> ([R; 3], [R; 3]) {
        // Mindlin: elastic = rotated + v_t k_t dt; trial = elastic + γ_t v_t
        let (mut elastic, mut trial) = ([R::splat(0.0); 3], [R::splat(0.0); 3]);
        let kdt = k_t * R::splat(dt);
        for c in 0..DIM {
            elastic[c] = rotated[c] + v_t[c] * kdt;
            trial[c] = elastic[c] + v_t[c] * gamma_t;
        }
        (trial, elastic)
    }
    #[inline(always)]
    fn slid<R: Real, const DIM: usize>(&self, f: [R; 3]) -> [R; 3] {
        f
    }
    fn damping(&self) -> NormalDamping {
        self.damping
    }
    fn tangential_damping(&self) -> TangentialDamping {
        self.tangential_damping
    }
    fn friction(&self) -> f64 {
        self.friction
    }
}

impl WindowLaw for HookeCundallStrack {
    #[inline(always)]
    fn normal<R: Real>(&self, _r_eff: R, overlap: R) -> (R, R, R, R) {
        let k = R::splat(self.normal_stiffness);
        (k * overlap, k, k, R::splat(0.0))
    }
    #[inline(always)]
    fn tangential_stiffness<R: Real>(&self, _a: R) -> R {
        R::splat(self.tangential_stiffness)
    }
    #[inline(always)]
    fn trial<R: Real, const DIM: usize>(&self, rotated: [R; 3], v_t: [R; 3], k_t: R, gamma_t: R, dt: f64) -> ([R; 3], [R; 3]) {
        // Cundall–Strack: s = rotated + v_t dt; trial = k_t s + γ_t v_t
        let (mut s, mut trial) = ([R::splat(0.0); 3], [R::splat(0.0); 3]);
        for c in 0..DIM {
            s[c] = rotated[c] + v_t[c] * R::splat(dt);
            trial[c] = s[c] * k_t + v_t[c] * gamma_t;
        }
        (trial, s)
    }
    #[inline(always)]
    fn slid<R: Real, const DIM: usize>(&self, f: [R; 3]) -> [R; 3] {
        let mut s = [R::splat(0.0); 3];
        for c in 0..DIM {
            s[c] = f[c] / R::splat(self.tangential_stiffness);
        }
        s
    }
    fn damping(&self) -> NormalDamping {
        self.damping
    }
    fn tangential_damping(&self) -> TangentialDamping {
        self.tangential_damping
    }
    fn friction(&self) -> f64 {
        self.friction
    }
}

/// Normal and tangential damping coefficients, resolved at compile time for the combinations of
/// the presets (the general [`Dampers`] matches on the parts at every contact).
pub(super) trait Dampers: Copy {
    /// γ_n from m*, k_n and the secant stiffness (as `NormalDamping::coefficient`).
    fn normal<R: Real>(&self, m_eff: R, k_n: R, secant: R) -> R;
    /// γ_t (as `TangentialDamping::coefficient`).
    fn tangential<R: Real>(&self, m_eff: R, k_t: R, gamma_n: R) -> R;
}

impl Dampers for (NormalDamping, TangentialDamping) {
    #[inline(always)]
    fn normal<R: Real>(&self, m_eff: R, k_n: R, secant: R) -> R {
        R::map3(m_eff, k_n, secant, |m, k, s| self.0.coefficient(m, k, s))
    }
    #[inline(always)]
    fn tangential<R: Real>(&self, m_eff: R, k_t: R, gamma_n: R) -> R {
        R::map3(m_eff, k_t, gamma_n, |m, k, g| self.1.coefficient(m, k, g))
    }
}

/// Tsuji normal damping, tangential a fraction of it (`hertz_mindlin` with `tsuji_restitution`).
#[derive(Clone, Copy)]
struct TsujiFraction(f64, f64);
impl Dampers for TsujiFraction {
    #[inline(always)]
    fn normal<R: Real>(&self, m_eff: R, _k_n: R, secant: R) -> R {
        R::splat(self.0) * (m_eff * secant).sqrt()
    }
    #[inline(always)]
    fn tangential<R: Real>(&self, _m_eff: R, _k_t: R, gamma_n: R) -> R {
        R::splat(self.1) * gamma_n
    }
}

/// Normal damping proportional to m*, tangential a fraction of it (LAMMPS `gran/hooke/history`).
#[derive(Clone, Copy)]
struct RateFraction(f64, f64);
impl Dampers for RateFraction {
    #[inline(always)]
    fn normal<R: Real>(&self, m_eff: R, _k_n: R, _secant: R) -> R {
        R::splat(self.0) * m_eff
    }
    #[inline(always)]
    fn tangential<R: Real>(&self, _m_eff: R, _k_t: R, gamma_n: R) -> R {
        R::splat(self.1) * gamma_n
    }
}

/// A fraction of critical damping on the normal part, tangential a fraction of the normal
/// coefficient (`hooke_cundall_strack` with `restitution`).
#[derive(Clone, Copy)]
struct CriticalFraction(f64, f64);
impl Dampers for CriticalFraction {
    #[inline(always)]
    fn normal<R: Real>(&self, m_eff: R, k_n: R, _secant: R) -> R {
        R::splat(self.0 * 2.0) * (m_eff * k_n).sqrt()
    }
    #[inline(always)]
    fn tangential<R: Real>(&self, _m_eff: R, _k_t: R, gamma_n: R) -> R {
        R::splat(self.1) * gamma_n
    }
}

/// A fraction of critical damping on both parts (`hertz_mindlin` with `damping_fraction`).
#[derive(Clone, Copy)]
struct CriticalBoth(f64, f64);
impl Dampers for CriticalBoth {
    #[inline(always)]
    fn normal<R: Real>(&self, m_eff: R, k_n: R, _secant: R) -> R {
        R::splat(self.0 * 2.0) * (m_eff * k_n).sqrt()
    }
    #[inline(always)]
    fn tangential<R: Real>(&self, m_eff: R, k_t: R, _gamma_n: R) -> R {
        R::splat(self.1 * 2.0) * (m_eff * k_t).sqrt()
    }
}

/// Something run with the dampers of a law as a type ([`with_dampers`]).
pub(super) trait WithDampers {
    type Out;
    fn run<P: Dampers>(self, damp: P) -> Self::Out;
}

/// Runs `v` with the dampers of `law`, resolved for the presets' combinations.
#[inline(always)]
pub(super) fn with_dampers<L: WindowLaw, V: WithDampers>(law: &L, v: V) -> V::Out {
    use NormalDamping as N;
    use TangentialDamping as T;
    match (law.damping(), law.tangential_damping()) {
        (N::Tsuji { alpha }, T::FractionOfNormal { ratio }) => v.run(TsujiFraction(alpha, ratio)),
        (N::MassProportional { rate }, T::FractionOfNormal { ratio }) => v.run(RateFraction(rate, ratio)),
        (N::CriticalFraction { zeta }, T::FractionOfNormal { ratio }) => v.run(CriticalFraction(zeta, ratio)),
        (N::CriticalFraction { zeta }, T::CriticalFraction { zeta: zt }) => v.run(CriticalBoth(zeta, zt)),
        (n, t) => v.run((n, t)),
    }
}

/// Evaluates the window (lanes `len..CAP` hold stale but finite data and are ignored). Uses AVX2
/// when the processor has it (same bits either way).
pub(super) fn compute<D: Dim, L: WindowLaw>(law: &L, w: &mut Window, dt: f64) {
    with_dampers(law, Run::<D, L, false> { law, w, dt, dim: std::marker::PhantomData });
}

/// [`compute`] compiled into the caller (which enables the vector extensions it wants).
#[inline(always)]
pub(super) fn compute_inline<D: Dim, L: WindowLaw>(law: &L, w: &mut Window, dt: f64) {
    with_dampers(law, Run::<D, L, true> { law, w, dt, dim: std::marker::PhantomData });
}

/// The window kernel with the dampers resolved: inline (`INLINE`) or through the run-time AVX2
/// dispatch.
struct Run<'a, D, L, const INLINE: bool> {
    law: &'a L,
    w: &'a mut Window,
    dt: f64,
    dim: std::marker::PhantomData<D>,
}

impl<D: Dim, L: WindowLaw, const INLINE: bool> WithDampers for Run<'_, D, L, INLINE> {
    type Out = ();
    #[inline(always)]
    fn run<P: Dampers>(self, damp: P) {
        if INLINE {
            compute_impl::<D, L, P>(self.law, damp, self.w, self.dt)
        } else {
            dispatch::<D, L, P>(self.law, damp, self.w, self.dt)
        }
    }
}

#[inline(always)]
fn dispatch<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, w: &mut Window, dt: f64) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor supports AVX2.
            unsafe { compute_avx2::<D, L, P>(law, damp, w, dt) };
            return;
        }
    }
    compute_impl::<D, L, P>(law, damp, w, dt);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn compute_avx2<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, w: &mut Window, dt: f64) {
    compute_impl::<D, L, P>(law, damp, w, dt);
}

#[inline(always)]
fn dot<R: Real, const DIM: usize>(a: [R; 3], b: [R; 3]) -> R {
    // component order of `VectorOps::dot`
    let mut s = a[0] * b[0];
    for c in 1..DIM {
        s = s + a[c] * b[c];
    }
    s
}

#[inline(always)]
fn compute_impl<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, w: &mut Window, dt: f64) {
    match D::D {
        2 => lanes::<2, 1, L, P>(law, damp, w, dt),
        _ => lanes::<3, 3, L, P>(law, damp, w, dt),
    }
}

/// The inputs of the contact law for one contact per lane (components past the dimension unused).
#[derive(Clone, Copy)]
pub(super) struct ContactIn<R> {
    /// Centre-to-centre vector (nearest image) and its squared length.
    pub r: [R; 3],
    pub dist2: R,
    /// v_j − v_i (v_j of the image of j).
    pub v_rel: [R; 3],
    /// ω_i, ω_j (one component in 2D).
    pub w_i: [R; 3],
    pub w_j: [R; 3],
    pub rad_i: R,
    pub rad_j: R,
    pub mass_i: R,
    pub mass_j: R,
    /// The reduced mass m_i m_j / (m_i + m_j) when the caller has it already (then `mass_i`
    /// and `mass_j` are not read).
    pub m_eff: Option<R>,
    /// Stored tangential history.
    pub spring: [R; 3],
}

/// What the contact law gives for one contact per lane.
#[derive(Clone, Copy)]
pub(super) struct ContactOut<R: Real> {
    pub overlap: R,
    pub sliding: R::Mask,
    pub new_spring: [R; 3],
    /// Force on i, torques on i and j.
    pub force: [R; 3],
    pub torque_i: [R; 3],
    pub torque_j: [R; 3],
}

#[inline(always)]
fn lanes<const DIM: usize, const ROT: usize, L: WindowLaw, P: Dampers>(law: &L, damp: P, w: &mut Window, dt: f64) {
    for k in 0..CAP {
        let get = |a: &[Lane; 3]| [a[0][k], a[1][k], if DIM == 3 { a[2][k] } else { 0.0 }];
        let input = ContactIn {
            r: get(&w.r),
            dist2: w.dist2[k],
            v_rel: get(&w.v_rel),
            w_i: get(&w.w_i),
            w_j: get(&w.w_j),
            rad_i: w.rad_i[k],
            rad_j: w.rad_j[k],
            mass_i: w.mass_i[k],
            mass_j: w.mass_j[k],
            m_eff: None,
            spring: get(&w.spring),
        };
        let o = contact::<f64, DIM, ROT, L, P>(law, damp, &input, dt);
        w.overlap[k] = o.overlap;
        w.sliding[k] = o.sliding;
        for c in 0..DIM {
            w.new_spring[c][k] = o.new_spring[c];
            w.force[c][k] = o.force[c];
        }
        for c in 0..ROT {
            w.torque_i[c][k] = o.torque_i[c];
            w.torque_j[c][k] = o.torque_j[c];
        }
    }
}

/// The specialised contact law on touching contacts, branch-free: exactly the floating-point
/// operations of [`evaluate_parts`](crate::contact::evaluate_parts) in the same order.
#[inline(always)]
pub(super) fn contact<R: Real, const DIM: usize, const ROT: usize, L: WindowLaw, P: Dampers>(law: &L, damp: P, x: &ContactIn<R>, dt: f64) -> ContactOut<R> {
    let zero = R::splat(0.0);
    let (r, v_rel, w_i, w_j, spring) = (x.r, x.v_rel, x.w_i, x.w_j, x.spring);
    let (rad_i, rad_j, mass_i, mass_j) = (x.rad_i, x.rad_j, x.mass_i, x.mass_j);

    // kinematics (as `pair_kinematics`)
    let sum = rad_i + rad_j;
    let dist = x.dist2.sqrt();
    let overlap = sum - dist;
    let mut n = [zero; 3];
    for c in 0..DIM {
        n[c] = r[c] / dist;
    }
    let half = R::splat(0.5);
    let lever_i = rad_i - half * overlap;
    let lever_j = rad_j - half * overlap;
    let v_n = dot::<R, DIM>(v_rel, n);
    let mut wsum = [zero; 3];
    for c in 0..ROT {
        wsum[c] = w_i[c] * lever_i + w_j[c] * lever_j;
    }
    let mut v_c = [zero; 3];
    if DIM == 3 {
        // glam's DVec3::cross(wsum, n)
        v_c[0] = v_rel[0] - (wsum[1] * n[2] - n[1] * wsum[2]);
        v_c[1] = v_rel[1] - (wsum[2] * n[0] - n[2] * wsum[0]);
        v_c[2] = v_rel[2] - (wsum[0] * n[1] - n[0] * wsum[1]);
    } else {
        v_c[0] = v_rel[0] - -wsum[0] * n[1];
        v_c[1] = v_rel[1] - wsum[0] * n[0];
    }
    let vcn = dot::<R, DIM>(v_c, n);
    let mut v_t = [zero; 3];
    for c in 0..DIM {
        v_t[c] = v_c[c] - n[c] * vcn;
    }
    let r_eff = rad_i * rad_j / sum;
    let m_eff = match x.m_eff {
        Some(m) => m,
        None => mass_i * mass_j / (mass_i + mass_j),
    };

    // normal force (clamped) and stiffnesses
    let (f_el, k_n, secant, a) = law.normal(r_eff, overlap);
    let gamma_n = damp.normal(m_eff, k_n, secant);
    let f_n = (f_el - gamma_n * v_n).max_zero();
    let k_t = law.tangential_stiffness(a);
    let gamma_t = damp.tangential(m_eff, k_t, gamma_n);

    // history into the tangent plane keeping its length (as `into_tangent_plane`)
    let len2 = dot::<R, DIM>(spring, spring);
    let sdn = dot::<R, DIM>(spring, n);
    let mut p = [zero; 3];
    for c in 0..DIM {
        p[c] = spring[c] - n[c] * sdn;
    }
    let p2 = dot::<R, DIM>(p, p);
    let scale = (len2 / p2).sqrt();
    let (p_zero, p_same, len_zero) = (p2.eq(zero), p2.eq(len2), len2.eq(zero));
    let mut rotated = [zero; 3];
    for c in 0..DIM {
        let v = R::select(p_zero, zero, R::select(p_same, p[c], p[c] * scale));
        rotated[c] = R::select(len_zero, spring[c], v);
    }

    // tangential force, Coulomb cap (as `coulomb_cap`), history
    let (trial, kept) = law.trial::<R, DIM>(rotated, v_t, k_t, gamma_t, dt);
    let t2 = dot::<R, DIM>(trial, trial);
    let cap = R::splat(law.friction()) * f_n;
    let sliding = t2.gt(cap * cap);
    // Branch-free: the capped force is computed on every lane and selected where the lane
    // slides (a branch skipping it when no lane of a vector slides was mispredicted often
    // enough to cost 3–4 % on `hooke2d`, BENCHMARKS.md; the same bits either way).
    let shrink = cap / t2.sqrt();
    let cap_pos = cap.gt(zero);
    let mut f = [zero; 3];
    for c in 0..DIM {
        let capped = R::select(cap_pos, trial[c] * shrink, zero);
        f[c] = R::select(sliding, capped, trial[c]);
    }
    let slid = law.slid::<R, DIM>(f);

    // forces and torques: F_i = F_t − F_n n̂, τ_i = a_i n̂ × F_t, τ_j = a_j n̂ × F_t
    let mut t = [zero; 3];
    if DIM == 3 {
        t[0] = n[1] * f[2] - f[1] * n[2];
        t[1] = n[2] * f[0] - f[2] * n[0];
        t[2] = n[0] * f[1] - f[0] * n[1];
    } else {
        t[0] = n[0] * f[1] - n[1] * f[0];
    }
    let mut out = ContactOut { overlap, sliding, new_spring: [zero; 3], force: [zero; 3], torque_i: [zero; 3], torque_j: [zero; 3] };
    for c in 0..DIM {
        out.new_spring[c] = R::select(sliding, slid[c], kept[c]);
        out.force[c] = f[c] - n[c] * f_n;
    }
    for c in 0..ROT {
        out.torque_i[c] = t[c] * lever_i + zero;
        out.torque_j[c] = t[c] * lever_j - zero;
    }
    out
}

/// Copies a vector into lane `k`.
#[inline(always)]
pub(super) fn put<V: VectorOps>(lanes: &mut [Lane; 3], k: usize, v: V) {
    for c in 0..V::LEN {
        lanes[c][k] = v.get(c);
    }
}

/// Reads lane `k` as a vector.
#[inline(always)]
pub(super) fn get<V: VectorOps>(lanes: &[Lane; 3], k: usize) -> V {
    let mut v = V::ZERO;
    for c in 0..V::LEN {
        v.set(c, lanes[c][k]);
    }
    v
}
