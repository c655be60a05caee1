//! The specialised contact kernels, evaluated a window of pairs at a time.
//!
//! A window holds up to [`CAP`] pairs copied into structure-of-arrays scratch (all in L1 cache).
//! Every stage of the contact law is then a branch-free loop over the window — conditions become
//! selects — that the compiler vectorizes: 2 pairs per instruction with the baseline x86-64 target
//! (SSE2), 4 with AVX2, which is detected at run time ([`compute`]). Each lane performs exactly
//! the floating-point operations of [`evaluate_parts`](crate::contact::evaluate_parts) on the
//! same parts, in the same order (no fused multiply–add), so the result is bitwise that of the
//! general kernel (tested on whole runs).

use crate::contact::{HertzMindlin, HookeCundallStrack, NormalDamping, TangentialDamping};
use crate::dim::{Dim, VectorOps};
use crate::domain::{nearest_integer, PeriodicImage, TILT_AXES};

/// Pairs per window.
pub(super) const CAP: usize = 32;

type Lane = [f64; CAP];
const ZERO: Lane = [0.0; CAP];

/// Structure-of-arrays scratch for one window of pairs.
#[derive(Clone)]
pub(super) struct Window {
    /// Pairs in the window.
    pub len: usize,
    /// Pair index, first grain, second grain.
    pub pair: [u32; CAP],
    pub i: [u32; CAP],
    pub j: [u32; CAP],
    // inputs (filled by the caller)
    /// Centre-to-centre vector x_j − x_i before the nearest image is taken, per component.
    pub r: [Lane; 3],
    /// v_j when filled, v_j − v_i once the nearest image is known.
    pub v_rel: [Lane; 3],
    /// v_i.
    pub v_i: [Lane; 3],
    /// ω_i, ω_j (one component in 2D).
    pub w_i: [Lane; 3],
    pub w_j: [Lane; 3],
    pub rad_i: Lane,
    pub rad_j: Lane,
    pub mass_i: Lane,
    pub mass_j: Lane,
    /// Stored tangential history.
    pub spring: [Lane; 3],
    // kinematics
    pub contact: [bool; CAP],
    pub overlap: Lane,
    pub lever_i: Lane,
    pub lever_j: Lane,
    n: [Lane; 3],
    v_n: Lane,
    v_t: [Lane; 3],
    r_eff: Lane,
    m_eff: Lane,
    // law
    /// √(R* ξ) (Hertz).
    contact_radius: Lane,
    f_el: Lane,
    k_n: Lane,
    secant: Lane,
    gamma_n: Lane,
    f_n: Lane,
    k_t: Lane,
    gamma_t: Lane,
    // outputs
    pub sliding: [bool; CAP],
    pub new_spring: [Lane; 3],
    pub force: [Lane; 3],
    pub torque_i: [Lane; 3],
    pub torque_j: [Lane; 3],
}

impl Window {
    pub fn new() -> Self {
        Window {
            len: 0,
            pair: [0; CAP],
            i: [0; CAP],
            j: [0; CAP],
            r: [ZERO; 3],
            v_rel: [ZERO; 3],
            v_i: [ZERO; 3],
            w_i: [ZERO; 3],
            w_j: [ZERO; 3],
            rad_i: ZERO,
            rad_j: ZERO,
            mass_i: ZERO,
            mass_j: ZERO,
            spring: [ZERO; 3],
            contact: [false; CAP],
            overlap: ZERO,
            lever_i: ZERO,
            lever_j: ZERO,
            n: [ZERO; 3],
            v_n: ZERO,
            v_t: [ZERO; 3],
            r_eff: ZERO,
            m_eff: ZERO,
            contact_radius: ZERO,
            f_el: ZERO,
            k_n: ZERO,
            secant: ZERO,
            gamma_n: ZERO,
            f_n: ZERO,
            k_t: ZERO,
            gamma_t: ZERO,
            sliding: [false; CAP],
            new_spring: [ZERO; 3],
            force: [ZERO; 3],
            torque_i: [ZERO; 3],
            torque_j: [ZERO; 3],
        }
    }
}

/// A specialised law, evaluated on a window.
pub(super) trait WindowLaw: Copy + Send + Sync {
    /// Normal elastic part: fills `f_el`, `k_n`, `secant`.
    fn normal(&self, w: &mut Window);
    /// Tangential stiffness: fills `k_t`.
    fn tangential_stiffness(&self, w: &mut Window);
    /// Tangential update from the history rotated into the tangent plane: fills `new_spring`,
    /// `force` (the tangential force, for now) and `sliding`.
    fn tangential(&self, w: &mut Window, rotated: &[Lane; 3], dt: f64, dim: usize);
    fn damping(&self) -> NormalDamping;
    fn tangential_damping(&self) -> TangentialDamping;
}

/// Caps the trial force (per lane, as `coulomb_cap`): returns the force in `f` and the flag.
#[inline(always)]
fn coulomb(trial: &[Lane; 3], cap_factor: f64, f_n: &Lane, dim: usize, f: &mut [Lane; 3], sliding: &mut [bool; CAP]) {
    let mut t2 = ZERO;
    dot(trial, trial, dim, &mut t2);
    let mut any = false;
    for k in 0..CAP {
        let cap = cap_factor * f_n[k];
        sliding[k] = t2[k] > cap * cap;
        any |= sliding[k];
    }
    *f = *trial;
    if any {
        for k in 0..CAP {
            let cap = cap_factor * f_n[k];
            let scale = cap / t2[k].sqrt();
            for c in 0..dim {
                let capped = if cap > 0.0 { trial[c][k] * scale } else { 0.0 };
                f[c][k] = if sliding[k] { capped } else { trial[c][k] };
            }
        }
    }
}

/// out = Σ_c a_c b_c, summed in component order as `VectorOps::dot`.
#[inline(always)]
fn dot(a: &[Lane; 3], b: &[Lane; 3], dim: usize, out: &mut Lane) {
    for k in 0..CAP {
        out[k] = a[0][k] * b[0][k];
    }
    for c in 1..dim {
        for k in 0..CAP {
            out[k] += a[c][k] * b[c][k];
        }
    }
}

impl WindowLaw for HertzMindlin {
    #[inline(always)]
    fn normal(&self, w: &mut Window) {
        let e = self.effective_modulus;
        let c = 4.0 / 3.0 * e;
        for k in 0..CAP {
            let a = (w.r_eff[k] * w.overlap[k]).sqrt();
            w.contact_radius[k] = a;
            w.secant[k] = c * a;
            w.f_el[k] = w.secant[k] * w.overlap[k];
            w.k_n[k] = 2.0 * e * a;
        }
    }
    #[inline(always)]
    fn tangential_stiffness(&self, w: &mut Window) {
        let g = self.effective_shear_modulus;
        for k in 0..CAP {
            w.k_t[k] = 8.0 * g * w.contact_radius[k];
        }
    }
    #[inline(always)]
    fn tangential(&self, w: &mut Window, rotated: &[Lane; 3], dt: f64, dim: usize) {
        // Mindlin: elastic = rotated + v_t k_t dt; trial = elastic + γ_t v_t; history = capped force
        let mut elastic = [ZERO; 3];
        let mut trial = [ZERO; 3];
        for c in 0..dim {
            for k in 0..CAP {
                elastic[c][k] = rotated[c][k] + w.v_t[c][k] * (w.k_t[k] * dt);
                trial[c][k] = elastic[c][k] + w.v_t[c][k] * w.gamma_t[k];
            }
        }
        let mut f = [ZERO; 3];
        coulomb(&trial, self.friction, &w.f_n, dim, &mut f, &mut w.sliding);
        for c in 0..dim {
            for k in 0..CAP {
                w.new_spring[c][k] = if w.sliding[k] { f[c][k] } else { elastic[c][k] };
            }
        }
        w.force = f;
    }
    fn damping(&self) -> NormalDamping {
        self.damping
    }
    fn tangential_damping(&self) -> TangentialDamping {
        self.tangential_damping
    }
}

impl WindowLaw for HookeCundallStrack {
    #[inline(always)]
    fn normal(&self, w: &mut Window) {
        let kn = self.normal_stiffness;
        for k in 0..CAP {
            w.f_el[k] = kn * w.overlap[k];
            w.k_n[k] = kn;
            w.secant[k] = kn;
        }
    }
    #[inline(always)]
    fn tangential_stiffness(&self, w: &mut Window) {
        w.k_t = [self.tangential_stiffness; CAP];
    }
    #[inline(always)]
    fn tangential(&self, w: &mut Window, rotated: &[Lane; 3], dt: f64, dim: usize) {
        // Cundall–Strack: s = rotated + v_t dt; trial = k_t s + γ_t v_t; history s or F/k_t
        let kt = self.tangential_stiffness;
        let mut s = [ZERO; 3];
        let mut trial = [ZERO; 3];
        for c in 0..dim {
            for k in 0..CAP {
                s[c][k] = rotated[c][k] + w.v_t[c][k] * dt;
                trial[c][k] = s[c][k] * kt + w.v_t[c][k] * w.gamma_t[k];
            }
        }
        let mut f = [ZERO; 3];
        coulomb(&trial, self.friction, &w.f_n, dim, &mut f, &mut w.sliding);
        for c in 0..dim {
            for k in 0..CAP {
                w.new_spring[c][k] = if w.sliding[k] { f[c][k] / kt } else { s[c][k] };
            }
        }
        w.force = f;
    }
    fn damping(&self) -> NormalDamping {
        self.damping
    }
    fn tangential_damping(&self) -> TangentialDamping {
        self.tangential_damping
    }
}

/// Evaluates the window: contact flags, forces, torques, new histories. Uses AVX2 when the
/// processor has it (same bits either way).
pub(super) fn compute<D: Dim, L: WindowLaw>(law: &L, w: &mut Window, image: &PeriodicImage<D>, dt: f64) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor supports AVX2.
            unsafe { compute_avx2::<D, L>(law, w, image, dt) };
            return;
        }
    }
    compute_impl::<D, L>(law, w, image, dt);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn compute_avx2<D: Dim, L: WindowLaw>(law: &L, w: &mut Window, image: &PeriodicImage<D>, dt: f64) {
    compute_impl::<D, L>(law, w, image, dt);
}

#[inline(always)]
fn compute_impl<D: Dim, L: WindowLaw>(law: &L, w: &mut Window, image: &PeriodicImage<D>, dt: f64) {
    let dim = D::D;
    let rot = D::ROT;
    // nearest image (as `PeriodicImage::displacement_velocity`), from the last axis down; in a
    // shearing cell the image of j moves with the cell: v_j + dv
    let mut dv = [ZERO; 3];
    for c in (0..dim).rev() {
        let (l, inv) = (image.length.get(c), image.inverse.get(c));
        let mut n = ZERO;
        for k in 0..CAP {
            let d = w.r[c][k];
            n[k] = nearest_integer(d * inv);
            w.r[c][k] = d - l * n[k];
        }
        if image.sheared {
            for (t, &(edge, along)) in TILT_AXES.iter().enumerate() {
                if edge == c && image.tilt[t] != 0.0 {
                    for k in 0..CAP {
                        w.r[along][k] -= n[k] * image.tilt[t];
                    }
                }
                if edge == c && image.rate[t] != 0.0 {
                    for k in 0..CAP {
                        dv[along][k] -= n[k] * image.rate[t];
                    }
                }
            }
        }
    }
    // w.v_rel holds v_j until here
    for c in 0..dim {
        for k in 0..CAP {
            let vj = if image.sheared { w.v_rel[c][k] + dv[c][k] } else { w.v_rel[c][k] };
            w.v_rel[c][k] = vj - w.v_i[c][k];
        }
    }
    // kinematics (as `pair_kinematics`)
    let mut dist2 = ZERO;
    dot(&w.r, &w.r, dim, &mut dist2);
    let mut wsum = [ZERO; 3];
    for k in 0..CAP {
        let sum = w.rad_i[k] + w.rad_j[k];
        w.contact[k] = !(dist2[k] >= sum * sum);
        let dist = dist2[k].sqrt();
        let overlap = sum - dist;
        w.overlap[k] = overlap;
        for c in 0..dim {
            w.n[c][k] = w.r[c][k] / dist;
        }
        w.lever_i[k] = w.rad_i[k] - 0.5 * overlap;
        w.lever_j[k] = w.rad_j[k] - 0.5 * overlap;
        w.r_eff[k] = w.rad_i[k] * w.rad_j[k] / sum;
        w.m_eff[k] = w.mass_i[k] * w.mass_j[k] / (w.mass_i[k] + w.mass_j[k]);
        for c in 0..rot {
            wsum[c][k] = w.w_i[c][k] * w.lever_i[k] + w.w_j[c][k] * w.lever_j[k];
        }
    }
    dot(&w.v_rel, &w.n, dim, &mut w.v_n);
    // v_c = v_rel − ang_cross(wsum, n)
    let mut v_c = [ZERO; 3];
    for k in 0..CAP {
        if dim == 3 {
            let (a, n) = ([wsum[0][k], wsum[1][k], wsum[2][k]], [w.n[0][k], w.n[1][k], w.n[2][k]]);
            // glam's DVec3::cross
            let cx = a[1] * n[2] - n[1] * a[2];
            let cy = a[2] * n[0] - n[2] * a[0];
            let cz = a[0] * n[1] - n[0] * a[1];
            v_c[0][k] = w.v_rel[0][k] - cx;
            v_c[1][k] = w.v_rel[1][k] - cy;
            v_c[2][k] = w.v_rel[2][k] - cz;
        } else {
            let a = wsum[0][k];
            v_c[0][k] = w.v_rel[0][k] - -a * w.n[1][k];
            v_c[1][k] = w.v_rel[1][k] - a * w.n[0][k];
        }
    }
    let mut vcn = ZERO;
    dot(&v_c, &w.n, dim, &mut vcn);
    for c in 0..dim {
        for k in 0..CAP {
            w.v_t[c][k] = v_c[c][k] - w.n[c][k] * vcn[k];
        }
    }

    // normal force and damping
    law.normal(w);
    match law.damping() {
        NormalDamping::None => w.gamma_n = ZERO,
        NormalDamping::Dashpot { coefficient } => w.gamma_n = [coefficient; CAP],
        NormalDamping::CriticalFraction { zeta } => {
            for k in 0..CAP {
                w.gamma_n[k] = zeta * 2.0 * (w.m_eff[k] * w.k_n[k]).sqrt();
            }
        }
        NormalDamping::MassProportional { rate } => {
            for k in 0..CAP {
                w.gamma_n[k] = rate * w.m_eff[k];
            }
        }
        NormalDamping::Tsuji { alpha } => {
            for k in 0..CAP {
                w.gamma_n[k] = alpha * (w.m_eff[k] * w.secant[k]).sqrt();
            }
        }
    }
    for k in 0..CAP {
        w.f_n[k] = (w.f_el[k] - w.gamma_n[k] * w.v_n[k]).max(0.0);
    }
    law.tangential_stiffness(w);
    match law.tangential_damping() {
        TangentialDamping::None => w.gamma_t = ZERO,
        TangentialDamping::Coefficient { coefficient } => w.gamma_t = [coefficient; CAP],
        TangentialDamping::FractionOfNormal { ratio } => {
            for k in 0..CAP {
                w.gamma_t[k] = ratio * w.gamma_n[k];
            }
        }
        TangentialDamping::CriticalFraction { zeta } => {
            for k in 0..CAP {
                w.gamma_t[k] = zeta * 2.0 * (w.m_eff[k] * w.k_t[k]).sqrt();
            }
        }
        TangentialDamping::MassProportional { rate } => {
            for k in 0..CAP {
                w.gamma_t[k] = rate * w.m_eff[k];
            }
        }
    }

    // history into the current tangent plane, keeping its length (as `into_tangent_plane`)
    let mut len2 = ZERO;
    dot(&w.spring, &w.spring, dim, &mut len2);
    let mut sdn = ZERO;
    dot(&w.spring, &w.n, dim, &mut sdn);
    let mut p = [ZERO; 3];
    for c in 0..dim {
        for k in 0..CAP {
            p[c][k] = w.spring[c][k] - w.n[c][k] * sdn[k];
        }
    }
    let mut p2 = ZERO;
    dot(&p, &p, dim, &mut p2);
    let mut rotated = [ZERO; 3];
    for k in 0..CAP {
        let scale = (len2[k] / p2[k]).sqrt();
        for c in 0..dim {
            let v = if p2[k] == 0.0 {
                0.0
            } else if p2[k] == len2[k] {
                p[c][k]
            } else {
                p[c][k] * scale
            };
            rotated[c][k] = if len2[k] == 0.0 { w.spring[c][k] } else { v };
        }
    }
    law.tangential(w, &rotated, dt, dim);

    // forces and torques: F_i = F_t − F_n n̂, τ_i = a_i n̂ × F_t, τ_j = a_j n̂ × F_t
    for k in 0..CAP {
        let f = [w.force[0][k], w.force[1][k], if dim == 3 { w.force[2][k] } else { 0.0 }];
        let n = [w.n[0][k], w.n[1][k], if dim == 3 { w.n[2][k] } else { 0.0 }];
        let mut t = [0.0; 3];
        if dim == 3 {
            t[0] = n[1] * f[2] - f[1] * n[2];
            t[1] = n[2] * f[0] - f[2] * n[0];
            t[2] = n[0] * f[1] - f[0] * n[1];
        } else {
            t[0] = n[0] * f[1] - n[1] * f[0];
        }
        for c in 0..rot {
            w.torque_i[c][k] = t[c] * w.lever_i[k] + 0.0;
            w.torque_j[c][k] = t[c] * w.lever_j[k] - 0.0;
        }
        for c in 0..dim {
            w.force[c][k] = f[c] - n[c] * w.f_n[k];
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
