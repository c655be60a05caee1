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

use crate::contact::VisitParts;
use crate::contact::{contact_loads_lanes, NormalElastic, law_lanes, pair_kinematics_lanes, ContactLaw, HertzMindlin, HistoryNormal, HistoryRest, HistoryTangential, LawHistory, LawIn, NormalLaw, Specialized, HookeCundallStrack, HookeSlipActivation, LawParts, NormalDamping, Rolling, TangentialDamping, TangentialLaw, TangentialRest, VisitNormal, VisitTangential, WithRolling};
use crate::real::dot;
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
    /// Stored rolling spring θ_r (one component in 2D; laws with rolling resistance only).
    pub rolling: [Lane; 3],
    /// Overlap at the last evaluation (the stored one).
    pub was: Lane,
    // outputs
    pub overlap: Lane,
    pub sliding: [bool; CAP],
    pub new_spring: [Lane; 3],
    pub new_rolling: [Lane; 3],
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
            rolling: [ZERO; 3],
            was: ZERO,
            overlap: ZERO,
            sliding: [false; CAP],
            new_spring: [ZERO; 3],
            new_rolling: [ZERO; 3],
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

/// A law with a specialised kernel: its normal and tangential parts are fixed at compile time
/// (the [`LawParts`] of the presets return a constant variant, so every `match` on a part
/// folds away in the kernel), and so is whether it has rolling resistance. Its own per-contact
/// history ([`LawParts::Extra`]) is gathered per lane beside the tangential spring and scattered
/// back as the spring is; `()` (the presets) gathers nothing and compiles to no code.
pub(super) trait WindowLaw: LawParts {
    /// Whether the law has rolling resistance: its contacts then read and write the rolling
    /// spring (a constant of the law's type).
    #[inline(always)]
    fn rolls(&self) -> bool {
        !matches!(self.rolling(), Rolling::None)
    }
}
impl WindowLaw for HertzMindlin {}
impl WindowLaw for HookeCundallStrack {}
impl WindowLaw for HookeSlipActivation {}
impl<L: WindowLaw> WindowLaw for WithRolling<L> {}
impl<N: NormalLaw, L: WindowLaw + LawParts<Extra = ()>> WindowLaw for HistoryNormal<N, L> {}
impl<T: TangentialLaw, L: WindowLaw + LawParts<Extra = ()>> WindowLaw for HistoryTangential<T, L> {}

pub(crate) use crate::contact::Dampers;

/// Something run with a contact law as its type ([`with_law`]): a specialised law
/// ([`WindowLaw`]) or the general kernel ([`crate::contact::ContactLaw`], or a law with its own history).
pub(super) trait WithLaw {
    type Out;
    /// Runs with a law whose parts are constants of its type (the window and fused kernels).
    fn special<L: WindowLaw>(self, law: &L) -> Self::Out;
    /// Runs with the general kernel: the general law (its parts read at every contact), or a
    /// composition with its own per-contact history ([`LawParts::Extra`]).
    fn general<P: LawParts>(self, law: &P) -> Self::Out;
}

/// Runs `v` with the law of `specialized` as a type: the one place where the specialised
/// compositions of the presets ([`Specialized`]) meet the kernels, so that a force pass is
/// written once for every law.
#[inline(always)]
pub(super) fn with_law<V: WithLaw>(specialized: Specialized, v: V) -> V::Out {
    match specialized {
        Specialized::HertzMindlin(law) => v.special(&law),
        Specialized::HookeCundallStrack(law) => v.special(&law),
        Specialized::HertzMindlinRolling(law) => v.special(&law),
        Specialized::HookeCundallStrackRolling(law) => v.special(&law),
        Specialized::HookeSlipActivation(law) => v.special(&law),
        Specialized::HookeSlipActivationRolling(law) => v.special(&law),
        Specialized::NormalHistory(law, rest) => law.normal.route_history(WithHistory { v, law, rest }),
        Specialized::TangentialHistory(law, rest) => law.tangential.route_history(WithTangentialHistory { v, law, rest }),
        Specialized::General(law) => NormalElastic::route(&law, General(v)),
    }
}

/// A visitor of the specialised kernels of a tangential law with history and the parts `rest`
/// beside it ([`HistoryTangential`]), with the tangential law as its type
/// (`Tangential::route_history`).
struct WithTangentialHistory<V> {
    v: V,
    law: ContactLaw,
    rest: TangentialRest,
}

impl<V: WithLaw> VisitTangential for WithTangentialHistory<V> {
    type Out = V::Out;
    #[inline(always)]
    fn visit<T: TangentialLaw>(self, tangential: T) -> V::Out {
        match self.rest {
            TangentialRest::Hooke(law) => self.v.special(&HistoryTangential { tangential, law }),
            TangentialRest::HookeRolling(law) => self.v.special(&HistoryTangential { tangential, law }),
        }
    }
    /// (not reached: `specialize` gives `TangentialHistory` for laws with history only) the
    /// general kernel
    #[inline(always)]
    fn without_history(self) -> V::Out {
        NormalElastic::route(&self.law, General(self.v))
    }
}

/// A visitor of the specialised kernels of a normal law with history and the parts `rest`
/// beside it ([`HistoryNormal`]), with the normal law as its type (`NormalElastic::route_history`).
struct WithHistory<V> {
    v: V,
    law: ContactLaw,
    rest: HistoryRest,
}

impl<V: WithLaw> VisitNormal for WithHistory<V> {
    type Out = V::Out;
    #[inline(always)]
    fn visit<N: NormalLaw>(self, normal: N) -> V::Out {
        let elastic = self.law.normal;
        match self.rest {
            HistoryRest::Linear(law) => self.v.special(&HistoryNormal { normal, elastic, law }),
            HistoryRest::LinearRolling(law) => self.v.special(&HistoryNormal { normal, elastic, law }),
            HistoryRest::SlipActivation(law) => self.v.special(&HistoryNormal { normal, elastic, law }),
            HistoryRest::SlipActivationRolling(law) => self.v.special(&HistoryNormal { normal, elastic, law }),
        }
    }
    /// (not reached: `specialize` gives `NormalHistory` for laws with history only) the general kernel
    #[inline(always)]
    fn without_history(self) -> V::Out {
        NormalElastic::route(&self.law, General(self.v))
    }
}

/// A visitor of the general kernel as one of the parts of a law (`NormalElastic::route`).
struct General<V>(V);

impl<V: WithLaw> VisitParts for General<V> {
    type Out = V::Out;
    #[inline(always)]
    fn visit<P: LawParts>(self, law: &P) -> V::Out {
        self.0.general(law)
    }
}


/// Something run with the dampers of a law as a type ([`with_dampers`]).
pub(super) trait WithDampers {
    type Out;
    fn run<P: Dampers>(self, damp: P) -> Self::Out;
}

/// Runs `v` with the dampers of `law`, resolved for the presets' combinations: the pair of
/// their law types (`hertz_mindlin` with `tsuji_restitution`: Tsuji and a fraction of it; LAMMPS
/// `gran/hooke/history`: γ_n ∝ m* and a fraction of it; `hooke_cundall_strack` with
/// `restitution`: a fraction of critical damping and a fraction of it; `hertz_mindlin` with
/// `damping_fraction`: a fraction of critical damping on both parts), else the pair of enums.
#[inline(always)]
pub(super) fn with_dampers<L: WindowLaw, V: WithDampers>(law: &L, v: V) -> V::Out {
    use NormalDamping as N;
    use TangentialDamping as T;
    match (law.damping(), law.tangential_damping()) {
        (N::Tsuji(n), T::FractionOfNormal(t)) => v.run((n, t)),
        (N::MassProportional(n), T::FractionOfNormal(t)) => v.run((n, t)),
        (N::CriticalFraction(n), T::FractionOfNormal(t)) => v.run((n, t)),
        (N::CriticalFraction(n), T::CriticalFraction(t)) => v.run((n, t)),
        (n, t) => v.run((n, t)),
    }
}

/// The law's own history of each contact of a window, lane `k` that of contact `k` (gathered
/// from the pair list and scattered back by the force pass; nothing for `()`).
pub(super) type Extras<L> = [<L as LawParts>::Extra; CAP];

/// Evaluates the window (lanes `len..CAP` hold stale but finite data and are ignored), reading
/// and updating the law's own history of each contact in `extra`. Uses AVX2 when the processor
/// has it (same bits either way).
pub(super) fn compute<D: Dim, L: WindowLaw>(law: &L, w: &mut Window, extra: &mut Extras<L>, dt: f64) {
    with_dampers(law, Run::<D, L, false> { law, w, extra, dt, dim: std::marker::PhantomData });
}

/// [`compute`] compiled into the caller (which enables the vector extensions it wants).
#[inline(always)]
pub(super) fn compute_inline<D: Dim, L: WindowLaw>(law: &L, w: &mut Window, extra: &mut Extras<L>, dt: f64) {
    with_dampers(law, Run::<D, L, true> { law, w, extra, dt, dim: std::marker::PhantomData });
}

/// The window kernel with the dampers resolved: inline (`INLINE`) or through the run-time AVX2
/// dispatch.
struct Run<'a, D, L: LawParts, const INLINE: bool> {
    law: &'a L,
    w: &'a mut Window,
    extra: &'a mut Extras<L>,
    dt: f64,
    dim: std::marker::PhantomData<D>,
}

impl<D: Dim, L: WindowLaw, const INLINE: bool> WithDampers for Run<'_, D, L, INLINE> {
    type Out = ();
    #[inline(always)]
    fn run<P: Dampers>(self, damp: P) {
        if INLINE {
            compute_impl::<D, L, P>(self.law, damp, self.w, self.extra, self.dt)
        } else {
            dispatch::<D, L, P>(self.law, damp, self.w, self.extra, self.dt)
        }
    }
}

#[inline(always)]
fn dispatch<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, w: &mut Window, extra: &mut Extras<L>, dt: f64) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor supports AVX2.
            unsafe { compute_avx2::<D, L, P>(law, damp, w, extra, dt) };
            return;
        }
    }
    compute_impl::<D, L, P>(law, damp, w, extra, dt);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn compute_avx2<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, w: &mut Window, extra: &mut Extras<L>, dt: f64) {
    compute_impl::<D, L, P>(law, damp, w, extra, dt);
}


#[inline(always)]
fn compute_impl<D: Dim, L: WindowLaw, P: Dampers>(law: &L, damp: P, w: &mut Window, extra: &mut Extras<L>, dt: f64) {
    match D::D {
        2 => lanes::<2, 1, L, P>(law, damp, w, extra, dt),
        _ => lanes::<3, 3, L, P>(law, damp, w, extra, dt),
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
    /// Stored rolling spring θ_r (`ROT` components; read only by laws with rolling resistance).
    pub rolling: [R; 3],
}

/// What the contact law gives for one contact per lane.
#[derive(Clone, Copy)]
pub(super) struct ContactOut<R: Real> {
    pub overlap: R,
    pub sliding: R::Mask,
    pub new_spring: [R; 3],
    /// The rolling spring to store (laws with rolling resistance only; zero otherwise).
    pub new_rolling: [R; 3],
    /// Force on i, torques on i and j.
    pub force: [R; 3],
    pub torque_i: [R; 3],
    pub torque_j: [R; 3],
}

#[inline(always)]
fn lanes<const DIM: usize, const ROT: usize, L: WindowLaw, P: Dampers>(law: &L, damp: P, w: &mut Window, extra: &mut Extras<L>, dt: f64) {
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
            rolling: [w.rolling[0][k], if ROT == 3 { w.rolling[1][k] } else { 0.0 }, if ROT == 3 { w.rolling[2][k] } else { 0.0 }],
        };
        let mut e = extra[k].to_lane();
        let o = contact::<f64, DIM, ROT, L, P>(law, damp, &input, &mut e, dt);
        extra[k] = L::Extra::from_lane(e);
        w.overlap[k] = o.overlap;
        w.sliding[k] = o.sliding;
        for c in 0..DIM {
            w.new_spring[c][k] = o.new_spring[c];
            w.force[c][k] = o.force[c];
        }
        for c in 0..ROT {
            w.torque_i[c][k] = o.torque_i[c];
            w.torque_j[c][k] = o.torque_j[c];
            if law.rolls() {
                w.new_rolling[c][k] = o.new_rolling[c];
            }
        }
    }
}

/// The specialised contact law on touching contacts, branch-free: the pair kinematics, the one
/// statement of the law ([`law_lanes`], which the general kernel runs on one lane) and the loads.
/// `extra`: the law's own history of each lane's contact, read and updated.
#[inline(always)]
pub(super) fn contact<R: Real, const DIM: usize, const ROT: usize, L: WindowLaw, P: Dampers>(
    law: &L,
    damp: P,
    x: &ContactIn<R>,
    extra: &mut <L::Extra as LawHistory>::Lanes<R>,
    dt: f64,
) -> ContactOut<R> {
    let zero = R::splat(0.0);
    let k = pair_kinematics_lanes::<R, DIM, ROT>(x.r, x.dist2, x.rad_i, x.rad_j, x.v_rel, x.w_i, x.w_j);
    let n = k.normal;
    let m_eff = match x.m_eff {
        Some(m) => m,
        None => x.mass_i * x.mass_j / (x.mass_i + x.mass_j),
    };
    // w_r = ω_j − ω_i less its twist component (`Dim::ang_perp`), for laws with rolling
    // resistance (the kernels' laws have no twisting resistance)
    let mut w_roll = [zero; 3];
    if law.rolls() {
        for c in 0..ROT {
            w_roll[c] = x.w_j[c] - x.w_i[c];
        }
        if ROT == 3 {
            let twist = dot::<R, 3>(w_roll, n);
            for c in 0..3 {
                w_roll[c] = w_roll[c] - n[c] * twist;
            }
        }
    }
    let input = LawIn {
        normal: n,
        overlap: k.overlap,
        r_eff: k.r_eff,
        m_eff,
        v_n: k.v_n,
        v_t: k.v_t,
        w_roll,
        w_twist: zero,
        spring: x.spring,
        rolling: x.rolling,
        twist: zero,
        was: zero,
    };
    let o = law_lanes::<R, DIM, ROT, L, P>(law, damp, &input, extra, dt);
    // forces and torques (M_r = 0 without rolling resistance: adding the zero keeps the bits)
    let (force, torque_i, torque_j) = contact_loads_lanes::<R, DIM, ROT>(n, o.tangential_force, o.normal_force, k.lever_i, k.lever_j, o.torque);
    ContactOut { overlap: k.overlap, sliding: o.sliding, new_spring: o.spring, new_rolling: o.rolling, force, torque_i, torque_j }
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
