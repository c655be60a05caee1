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

/// The normal and tangential elastic parts of a specialised law, per contact.
pub(super) trait WindowLaw: Copy + Send + Sync {
    /// F_el, k_n, secant k̄ and the contact radius √(R*ξ) (0 when not used), as `NormalElastic::response`.
    fn normal(&self, r_eff: f64, overlap: f64) -> (f64, f64, f64, f64);
    /// k_t from the contact radius, as `Tangential::stiffness`.
    fn tangential_stiffness(&self, contact_radius: f64) -> f64;
    /// Trial force and the history kept when not sliding, from the rotated history.
    fn trial<const DIM: usize>(&self, rotated: [f64; 3], v_t: [f64; 3], k_t: f64, gamma_t: f64, dt: f64) -> ([f64; 3], [f64; 3]);
    /// The history kept when sliding with force `f`.
    fn slid<const DIM: usize>(&self, f: [f64; 3]) -> [f64; 3];
    fn damping(&self) -> NormalDamping;
    fn tangential_damping(&self) -> TangentialDamping;
    fn friction(&self) -> f64;
}

impl WindowLaw for HertzMindlin {
    #[inline(always)]
    fn normal(&self, r_eff: f64, overlap: f64) -> (f64, f64, f64, f64) {
        let a = (r_eff * overlap).sqrt();
        let secant = 4.0 / 3.0 * self.effective_modulus * a;
        (secant * overlap, 2.0 * self.effective_modulus * a, secant, a)
    }
    #[inline(always)]
    fn tangential_stiffness(&self, a: f64) -> f64 {
        8.0 * self.effective_shear_modulus * a
    }
    #[inline(always)]
    fn trial<const DIM: usize>(&self, rotated: [f64; 3], v_t: [f64; 3], k_t: f64, gamma_t: f64, dt: f64) -> ([f64; 3], [f64; 3]) {
        // Mindlin: elastic = rotated + v_t k_t dt; trial = elastic + γ_t v_t
        let (mut elastic, mut trial) = ([0.0; 3], [0.0; 3]);
        for c in 0..DIM {
            elastic[c] = rotated[c] + v_t[c] * (k_t * dt);
            trial[c] = elastic[c] + v_t[c] * gamma_t;
        }
        (trial, elastic)
    }
    #[inline(always)]
    fn slid<const DIM: usize>(&self, f: [f64; 3]) -> [f64; 3] {
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
    fn normal(&self, _r_eff: f64, overlap: f64) -> (f64, f64, f64, f64) {
        let k = self.normal_stiffness;
        (k * overlap, k, k, 0.0)
    }
    #[inline(always)]
    fn tangential_stiffness(&self, _a: f64) -> f64 {
        self.tangential_stiffness
    }
    #[inline(always)]
    fn trial<const DIM: usize>(&self, rotated: [f64; 3], v_t: [f64; 3], k_t: f64, gamma_t: f64, dt: f64) -> ([f64; 3], [f64; 3]) {
        // Cundall–Strack: s = rotated + v_t dt; trial = k_t s + γ_t v_t
        let (mut s, mut trial) = ([0.0; 3], [0.0; 3]);
        for c in 0..DIM {
            s[c] = rotated[c] + v_t[c] * dt;
            trial[c] = s[c] * k_t + v_t[c] * gamma_t;
        }
        (trial, s)
    }
    #[inline(always)]
    fn slid<const DIM: usize>(&self, f: [f64; 3]) -> [f64; 3] {
        let mut s = [0.0; 3];
        for c in 0..DIM {
            s[c] = f[c] / self.tangential_stiffness;
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
trait Dampers: Copy {
    /// γ_n from m*, k_n and the secant stiffness (as `NormalDamping::coefficient`).
    fn normal(&self, m_eff: f64, k_n: f64, secant: f64) -> f64;
    /// γ_t (as `TangentialDamping::coefficient`).
    fn tangential(&self, m_eff: f64, k_t: f64, gamma_n: f64) -> f64;
}

impl Dampers for (NormalDamping, TangentialDamping) {
    #[inline(always)]
    fn normal(&self, m_eff: f64, k_n: f64, secant: f64) -> f64 {
        self.0.coefficient(m_eff, k_n, secant)
    }
    #[inline(always)]
    fn tangential(&self, m_eff: f64, k_t: f64, gamma_n: f64) -> f64 {
        self.1.coefficient(m_eff, k_t, gamma_n)
    }
}

/// Tsuji normal damping, tangential a fraction of it (`hertz_mindlin` with `tsuji_restitution`).
#[derive(Clone, Copy)]
struct TsujiFraction(f64, f64);
impl Dampers for TsujiFraction {
    #[inline(always)]
    fn normal(&self, m_eff: f64, _k_n: f64, secant: f64) -> f64 {
        self.0 * (m_eff * secant).sqrt()
    }
    #[inline(always)]
    fn tangential(&self, _m_eff: f64, _k_t: f64, gamma_n: f64) -> f64 {
        self.1 * gamma_n
    }
}

/// Normal damping proportional to m*, tangential a fraction of it (LAMMPS `gran/hooke/history`).
#[derive(Clone, Copy)]
struct RateFraction(f64, f64);
impl Dampers for RateFraction {
    #[inline(always)]
    fn normal(&self, m_eff: f64, _k_n: f64, _secant: f64) -> f64 {
        self.0 * m_eff
    }
    #[inline(always)]
    fn tangential(&self, _m_eff: f64, _k_t: f64, gamma_n: f64) -> f64 {
        self.1 * gamma_n
    }
}

/// A fraction of critical damping on the normal part, tangential a fraction of the normal
/// coefficient (`hooke_cundall_strack` with `restitution`).
#[derive(Clone, Copy)]
struct CriticalFraction(f64, f64);
impl Dampers for CriticalFraction {
    #[inline(always)]
    fn normal(&self, m_eff: f64, k_n: f64, _secant: f64) -> f64 {
        self.0 * 2.0 * (m_eff * k_n).sqrt()
    }
    #[inline(always)]
    fn tangential(&self, _m_eff: f64, _k_t: f64, gamma_n: f64) -> f64 {
        self.1 * gamma_n
    }
}

/// A fraction of critical damping on both parts (`hertz_mindlin` with `damping_fraction`).
#[derive(Clone, Copy)]
struct CriticalBoth(f64, f64);
impl Dampers for CriticalBoth {
    #[inline(always)]
    fn normal(&self, m_eff: f64, k_n: f64, _secant: f64) -> f64 {
        self.0 * 2.0 * (m_eff * k_n).sqrt()
    }
    #[inline(always)]
    fn tangential(&self, m_eff: f64, k_t: f64, _gamma_n: f64) -> f64 {
        self.1 * 2.0 * (m_eff * k_t).sqrt()
    }
}

/// Evaluates the window (lanes `len..CAP` hold stale but finite data and are ignored). Uses AVX2
/// when the processor has it (same bits either way).
pub(super) fn compute<D: Dim, L: WindowLaw>(law: &L, w: &mut Window, dt: f64) {
    select::<D, L, false>(law, w, dt);
}

/// [`compute`] compiled into the caller (which enables the vector extensions it wants).
#[inline(always)]
pub(super) fn compute_inline<D: Dim, L: WindowLaw>(law: &L, w: &mut Window, dt: f64) {
    select::<D, L, true>(law, w, dt);
}

/// Picks the dampers of the law, then runs the kernel inline (`INLINE`) or through the run-time
/// AVX2 dispatch.
#[inline(always)]
fn select<D: Dim, L: WindowLaw, const INLINE: bool>(law: &L, w: &mut Window, dt: f64) {
    use NormalDamping as N;
    use TangentialDamping as T;
    #[inline(always)]
    fn run<D: Dim, L: WindowLaw, P: Dampers, const INLINE: bool>(law: &L, damp: P, w: &mut Window, dt: f64) {
        if INLINE {
            compute_impl::<D, L, P>(law, damp, w, dt)
        } else {
            dispatch::<D, L, P>(law, damp, w, dt)
        }
    }
    match (law.damping(), law.tangential_damping()) {
        (N::Tsuji { alpha }, T::FractionOfNormal { ratio }) => run::<D, L, _, INLINE>(law, TsujiFraction(alpha, ratio), w, dt),
        (N::MassProportional { rate }, T::FractionOfNormal { ratio }) => run::<D, L, _, INLINE>(law, RateFraction(rate, ratio), w, dt),
        (N::CriticalFraction { zeta }, T::FractionOfNormal { ratio }) => run::<D, L, _, INLINE>(law, CriticalFraction(zeta, ratio), w, dt),
        (N::CriticalFraction { zeta }, T::CriticalFraction { zeta: zt }) => run::<D, L, _, INLINE>(law, CriticalBoth(zeta, zt), w, dt),
        (n, t) => run::<D, L, _, INLINE>(law, (n, t), w, dt),
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
fn dot<const DIM: usize>(a: [f64; 3], b: [f64; 3]) -> f64 {
    // component order of `VectorOps::dot`
    let mut s = a[0] * b[0];
    for c in 1..DIM {
        s += a[c] * b[c];
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

#[inline(always)]
fn lanes<const DIM: usize, const ROT: usize, L: WindowLaw, P: Dampers>(law: &L, damp: P, w: &mut Window, dt: f64) {
    let mu = law.friction();
    for k in 0..CAP {
        let get = |a: &[Lane; 3]| [a[0][k], a[1][k], if DIM == 3 { a[2][k] } else { 0.0 }];
        let (r, v_rel, w_i, w_j, spring) = (get(&w.r), get(&w.v_rel), get(&w.w_i), get(&w.w_j), get(&w.spring));
        let (rad_i, rad_j, mass_i, mass_j) = (w.rad_i[k], w.rad_j[k], w.mass_i[k], w.mass_j[k]);

        // kinematics (as `pair_kinematics`)
        let sum = rad_i + rad_j;
        let dist = w.dist2[k].sqrt();
        let overlap = sum - dist;
        let mut n = [0.0; 3];
        for c in 0..DIM {
            n[c] = r[c] / dist;
        }
        let lever_i = rad_i - 0.5 * overlap;
        let lever_j = rad_j - 0.5 * overlap;
        let v_n = dot::<DIM>(v_rel, n);
        let mut wsum = [0.0; 3];
        for c in 0..ROT {
            wsum[c] = w_i[c] * lever_i + w_j[c] * lever_j;
        }
        let mut v_c = [0.0; 3];
        if DIM == 3 {
            // glam's DVec3::cross(wsum, n)
            v_c[0] = v_rel[0] - (wsum[1] * n[2] - n[1] * wsum[2]);
            v_c[1] = v_rel[1] - (wsum[2] * n[0] - n[2] * wsum[0]);
            v_c[2] = v_rel[2] - (wsum[0] * n[1] - n[0] * wsum[1]);
        } else {
            v_c[0] = v_rel[0] - -wsum[0] * n[1];
            v_c[1] = v_rel[1] - wsum[0] * n[0];
        }
        let vcn = dot::<DIM>(v_c, n);
        let mut v_t = [0.0; 3];
        for c in 0..DIM {
            v_t[c] = v_c[c] - n[c] * vcn;
        }
        let r_eff = rad_i * rad_j / sum;
        let m_eff = mass_i * mass_j / (mass_i + mass_j);

        // normal force (clamped) and stiffnesses
        let (f_el, k_n, secant, a) = law.normal(r_eff, overlap);
        let gamma_n = damp.normal(m_eff, k_n, secant);
        let f_n = (f_el - gamma_n * v_n).max(0.0);
        let k_t = law.tangential_stiffness(a);
        let gamma_t = damp.tangential(m_eff, k_t, gamma_n);

        // history into the tangent plane keeping its length (as `into_tangent_plane`)
        let len2 = dot::<DIM>(spring, spring);
        let sdn = dot::<DIM>(spring, n);
        let mut p = [0.0; 3];
        for c in 0..DIM {
            p[c] = spring[c] - n[c] * sdn;
        }
        let p2 = dot::<DIM>(p, p);
        let scale = (len2 / p2).sqrt();
        let mut rotated = [0.0; 3];
        for c in 0..DIM {
            let v = if p2 == 0.0 {
                0.0
            } else if p2 == len2 {
                p[c]
            } else {
                p[c] * scale
            };
            rotated[c] = if len2 == 0.0 { spring[c] } else { v };
        }

        // tangential force, Coulomb cap (as `coulomb_cap`), history
        let (trial, kept) = law.trial::<DIM>(rotated, v_t, k_t, gamma_t, dt);
        let t2 = dot::<DIM>(trial, trial);
        let cap = mu * f_n;
        let sliding = t2 > cap * cap;
        let shrink = cap / t2.sqrt();
        let mut f = [0.0; 3];
        for c in 0..DIM {
            let capped = if cap > 0.0 { trial[c] * shrink } else { 0.0 };
            f[c] = if sliding { capped } else { trial[c] };
        }
        let slid = law.slid::<DIM>(f);

        // forces and torques: F_i = F_t − F_n n̂, τ_i = a_i n̂ × F_t, τ_j = a_j n̂ × F_t
        let mut t = [0.0; 3];
        if DIM == 3 {
            t[0] = n[1] * f[2] - f[1] * n[2];
            t[1] = n[2] * f[0] - f[2] * n[0];
            t[2] = n[0] * f[1] - f[0] * n[1];
        } else {
            t[0] = n[0] * f[1] - n[1] * f[0];
        }
        w.overlap[k] = overlap;
        w.sliding[k] = sliding;
        for c in 0..DIM {
            w.new_spring[c][k] = if sliding { slid[c] } else { kept[c] };
            w.force[c][k] = f[c] - n[c] * f_n;
        }
        for c in 0..ROT {
            w.torque_i[c][k] = t[c] * lever_i + 0.0;
            w.torque_j[c][k] = t[c] * lever_j - 0.0;
        }
    }
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
