//! Incremental (piecewise-linear) propagation: the two-branch rule of contacts at the Coulomb
//! limit against the engine's own law, a hand-solved packing, homogeneity, and the bilateral
//! limits against the existing linear propagation.

use crate::common;

use common::{hooke_params, lattice_2d};
use glam::DVec2;
use grainwave_core::contact::{pair_kinematics, ContactLaw, ContactOutput, ContactState, NormalDamping, TangentialDamping};
use grainwave_core::prelude::*;
use grainwave_core::snapshot::Snapshot;
use grainwave_linear::contact::{LinearContact, Partner as LinearPartner};
use grainwave_linear::incremental::{contact_step, BranchRule, CoulombLimit, IncrementState, IncrementalOptions, IncrementalPropagator};
use grainwave_linear::prelude::*;

const MU: f64 = 0.3;

/// The engine's Hooke law of the single-contact tests (k_n = 100, k_t = 50, μ = 0.3), undamped.
fn undamped_law() -> ContactLaw {
    let mut law = hooke_params(100.0, 0.5, MU).build(Partner::Grain, "contact").unwrap();
    law.damping = NormalDamping::None;
    law.tangential_damping = TangentialDamping::None;
    law
}

/// The linearized contact of two grains (levers 0.45) at the Coulomb limit, from the engine's
/// state at rest `rest` along `normal`, branch vector `branch`.
fn contact_at_the_limit<D: Dim>(normal: D::Vector, branch: D::Vector, rest: &ContactOutput<D>) -> LinearContact<D> {
    LinearContact::<D> {
        i: 0,
        j: LinearPartner::Grain(1),
        normal,
        branch,
        lever_i: 0.45,
        lever_j: 0.45,
        normal_stiffness: rest.normal_stiffness,
        tangential_stiffness: rest.tangential_stiffness,
        rolling_stiffness: 0.0,
        twisting_stiffness: 0.0,
        normal_force: rest.normal_force,
        prestress: 0.0,
        tangential_force: rest.tangential_force,
        rolling_torque: D::AngVector::ZERO,
        full_geometry: false,
        sliding: true,
    }
}

/// A single grain–grain contact held at the Coulomb limit by the engine's law (Hooke k_n = 100,
/// k_t = 50, μ = 0.3, no damping), then moved by a small relative displacement δ of j in one
/// step: the engine's change of F_n and of F_t·t̂ against the incremental rule.
///
/// Cases (s = direction of F_t on i): δ along −s·(sign that pushes F_t on), against it, normal
/// compression, normal opening. The engine slides in the first and fourth and sticks in the
/// others; the incremental rule must give the same increments (tolerance 1e-6 of k ε: the
/// engine's increments carry the rounding of forces of size μ F_n ≈ 3 over k ε = 1e-5, i.e.
/// ~1e-10 relative, and second-order geometry ε/|b| ≈ 1e-7), and the all-stick rule must be
/// wrong by k_t ε in the sliding case (so the test can tell the branches apart).
#[test]
fn single_contact_at_the_limit_follows_the_engine() {
    let law = undamped_law();
    let (ri, rj, m) = (0.5, 0.5, 1.0);
    let r0 = DVec2::new(0.9, 0.0);
    let dt = 1e-3;
    let kin = |r: DVec2, v: DVec2| pair_kinematics::<D2>(r, ri, rj, m, m, DVec2::ZERO, v, 0.0, 0.0).unwrap();
    // drive the spring to the cap: one large tangential step, then one at rest
    let mut state = ContactState::<D2>::default();
    let out = law.evaluate(&kin(r0, DVec2::new(0.0, 1e3)), &mut state, dt);
    assert!(out.sliding, "the loading step must reach the cap");
    let rest = law.evaluate(&kin(r0, DVec2::ZERO), &mut state, dt);
    let (f_n, f_t) = (rest.normal_force, rest.tangential_force);
    assert!((f_t.length() - MU * f_n).abs() < 1e-12 * f_n, "at rest on the limit: |F_t| = {}, μF_n = {}", f_t.length(), MU * f_n);
    let n = DVec2::X;
    let t = DVec2::new(-n.y, n.x);
    let c = contact_at_the_limit::<D2>(n, r0, &rest);
    let s = f_t / f_t.length();
    let limit = CoulombLimit::<D2> { s, mu: MU, ..CoulombLimit::STICK };
    let eps = 1e-7;
    let scale = 100.0 * eps;
    // F_t on i grows with the tangential displacement of j relative to i (k_t Δ_t), so δ = +ε s pushes it on
    let cases = [("push on", s * eps, true), ("release", -s * eps, false), ("compress", -n * eps, false), ("open", n * eps, true)];
    for (name, delta, slides) in cases {
        let mut st = state;
        let new = law.evaluate(&kin(r0 + delta, delta / dt), &mut st, dt);
        let t_new = {
            let nn = (r0 + delta).normalize();
            DVec2::new(-nn.y, nn.x)
        };
        let (dfn_engine, dft_engine) = (new.normal_force - f_n, new.tangential_force.dot(t_new) - f_t.dot(t));
        assert_eq!(new.sliding, slides, "{name}: engine sliding flag");
        for (rule, must_match) in [(BranchRule::Incremental, true), (BranchRule::Stick, !slides)] {
            let mut inc = IncrementState::<D2>::ZERO;
            let l = contact_step(&c, &limit, &mut inc, rule, DVec2::ZERO, 0.0, delta, 0.0, DVec2::ZERO);
            // force on i: k_n (Δ·n̂) n̂ + ΔF_t, and the normal force on i is −F_n n̂
            let dfn = -l.force_i.dot(n);
            let dft = l.force_i.dot(t);
            let err = (dfn - dfn_engine).abs().max((dft - dft_engine).abs());
            eprintln!("{name} {rule:?}: engine ΔF_n {dfn_engine:.6e} ΔF_t {dft_engine:.6e}; linear {dfn:.6e} {dft:.6e}");
            if must_match {
                assert!(err < 1e-6 * scale, "{name}, {rule:?}: error {err:e}");
                assert_eq!(inc.slipping, slides && rule == BranchRule::Incremental, "{name}: branch");
            } else {
                assert!(err > 0.1 * 50.0 * eps, "{name}, {rule:?}: the stick rule should miss the slip, error {err:e}");
            }
        }
    }
}

/// The same single contact in 3D, along an oblique normal, where the tangential increment is a
/// vector: besides pushing on, releasing, compressing and opening, an increment perpendicular to
/// the sliding direction s (the engine caps the trial force and turns it: to first order its
/// change is k_t δ, the stick answer, which the rule gives since it does not push along s) and
/// oblique ones (push on plus perpendicular: slip along s, k_t δ across it; release plus
/// perpendicular: stick). Compared in the contact's frame as in 2D: ΔF_n and the change of F_t
/// in the tangent plane (the engine's old F_t carried into the new plane first), tolerance 1e-6
/// of k ε for the same reasons.
#[test]
fn single_contact_at_the_limit_follows_the_engine_in_3d() {
    use glam::DVec3;
    let law = undamped_law();
    let (ri, rj, m) = (0.5, 0.5, 1.0);
    let n = DVec3::new(1.0, 0.4, -0.3).normalize();
    let r0 = n * 0.9;
    let dt = 1e-3;
    let kin = |r: DVec3, v: DVec3| pair_kinematics::<D3>(r, ri, rj, m, m, DVec3::ZERO, v, DVec3::ZERO, DVec3::ZERO).unwrap();
    // a tangential loading direction, not along a coordinate axis of the contact's frame
    let load = (DVec3::new(0.2, -0.7, 0.5) - n * n.dot(DVec3::new(0.2, -0.7, 0.5))).normalize();
    let mut state = ContactState::<D3>::default();
    let out = law.evaluate(&kin(r0, load * 1e3), &mut state, dt);
    assert!(out.sliding, "the loading step must reach the cap");
    let rest = law.evaluate(&kin(r0, DVec3::ZERO), &mut state, dt);
    let (f_n, f_t) = (rest.normal_force, rest.tangential_force);
    assert!((f_t.length() - MU * f_n).abs() < 1e-12 * f_n, "at rest on the limit: |F_t| = {}, μF_n = {}", f_t.length(), MU * f_n);
    assert!(f_t.dot(n).abs() < 1e-12 * f_n, "F_t in the tangent plane");
    let c = contact_at_the_limit::<D3>(n, r0, &rest);
    let s = f_t / f_t.length();
    let p = n.cross(s); // in the tangent plane, across s
    let limit = CoulombLimit::<D3> { s, mu: MU, ..CoulombLimit::STICK };
    let eps = 1e-7;
    let scale = 100.0 * eps;
    let in_plane = |v: DVec3, nn: DVec3| v - nn * nn.dot(v);
    let cases = [
        ("push on", s * eps, true),
        ("release", -s * eps, false),
        ("compress", -n * eps, false),
        ("open", n * eps, true),
        ("across s", p * eps, true),
        ("push on and across", (s + p) * eps, true),
        ("release and across", (p - s) * eps, false),
    ];
    for (name, delta, engine_slides) in cases {
        let mut st = state;
        let new = law.evaluate(&kin(r0 + delta, delta / dt), &mut st, dt);
        let n_new = (r0 + delta).normalize();
        let dfn_engine = new.normal_force - f_n;
        let dft_engine = in_plane(new.tangential_force - in_plane(f_t, n_new), n);
        assert_eq!(new.sliding, engine_slides, "{name}: engine sliding flag");
        // the incremental rule slips where the increment pushes F_t on along s
        let rule_slips = matches!(name, "push on" | "open" | "push on and across");
        let mut inc = IncrementState::<D3>::ZERO;
        let l = contact_step(&c, &limit, &mut inc, BranchRule::Incremental, DVec3::ZERO, DVec3::ZERO, delta, DVec3::ZERO, DVec3::ZERO);
        let dfn = -l.force_i.dot(n);
        let dft = in_plane(l.force_i, n);
        let err = (dfn - dfn_engine).abs().max((dft - dft_engine).length());
        eprintln!("3d {name}: engine ΔF_n {dfn_engine:.6e} ΔF_t {dft_engine:?}; linear {dfn:.6e} {dft:?}");
        assert!(err < 1e-6 * scale, "{name}: error {err:e}");
        assert_eq!(inc.slipping, rule_slips, "{name}: branch");
        // the all-stick rule misses every increment that slides along s
        let mut inc = IncrementState::<D3>::ZERO;
        let l = contact_step(&c, &limit, &mut inc, BranchRule::Stick, DVec3::ZERO, DVec3::ZERO, delta, DVec3::ZERO, DVec3::ZERO);
        let err_stick = (-l.force_i.dot(n) - dfn_engine).abs().max((in_plane(l.force_i, n) - dft_engine).length());
        if rule_slips {
            assert!(err_stick > 0.1 * 50.0 * eps, "{name}: the stick rule should miss the slip, error {err_stick:e}");
        } else {
            assert!(err_stick < 1e-6 * scale, "{name}: stick and incremental agree off the slip branch, error {err_stick:e}");
        }
    }
}

/// One disk (R = 0.5, m = 1, I = m R²/2) on a frictional floor, its friction fully mobilised
/// along +x on the disk (s = +x̂), kicked horizontally with velocity v.
///
/// By hand: with w = u_x + a θ the contact-point slip, the stick branch is m ü_x = −k_t w,
/// I θ̈ = −k_t a w, so ẅ = −ω² w, ω² = k_t (1/m + a²/I), w = (v/ω) sin ωt. Pushing the disk
/// to −x (v < 0) drives F_t further along s: it slips at once and moves freely, u_x = v t. Pushing
/// it to +x (v > 0) unloads the contact: it sticks for half a period, and when w returns to 0 at
/// t₁ = π/ω it starts slipping back (w < 0 pushes F_t along s) with the velocity it has then,
/// u̇_x(t₁) = v (1 − 2 (1/m)/(1/m + a²/I)) (= v/3 for a ≈ R), and the rotation rate
/// θ̇(t₁) = −2 k_t a v/(I ω²), both constant afterwards (no tangential force on the slip branch).
/// Velocity Verlet at 4000 steps per shortest period: the branch switch happens where ü = 0, so
/// the switching error is second order; tolerance 1e-4 of v.
#[test]
fn disk_on_a_frictional_floor_by_hand() {
    let params = hooke_params(100.0, 0.5, MU);
    let law = params.build(Partner::Grain, "contact").unwrap();
    let wall = params.build(Partner::Wall, "contact.wall").unwrap();
    let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
    g.push_with_mass(DVec2::new(0.0, 0.49), 0.5, 1.0, DVec2::ZERO);
    let domain = Domain::new(DVec2::new(-5.0, 0.0), DVec2::new(5.0, 5.0), [false; 3]).with_wall(Wall::axis_aligned("bottom", 1, 0.0, true, wall));
    let sim = SimulationBuilder::new(g, domain, law).max_initial_overlap(0.1).build().unwrap();
    let mut snap = sim.snapshot();
    assert_eq!(snap.contacts.len(), 1);
    let fn0 = snap.contacts[0].normal_force;
    snap.contacts[0].tangential_force = DVec2::new(MU * fn0, 0.0);
    let (m, inertia) = (snap.mass[0], snap.inertia[0]);
    let a = snap.contacts[0].lever_i;
    let k_t = snap.contacts[0].tangential_stiffness;
    let omega = (k_t * (1.0 / m + a * a / inertia)).sqrt();
    let opts = IncrementalOptions { steps_per_period: 4000.0, wall_damping: false, ..Default::default() };
    for v in [1.0, -1.0] {
        let mut p = IncrementalPropagator::<D2>::new(&snap, None, &opts).unwrap();
        assert_eq!(p.counts().at_limit, 1);
        p.set_velocity(&[v, 0.0, 0.0]).unwrap();
        let t1 = std::f64::consts::PI / omega;
        let t_end = 3.0 * t1;
        p.advance_to(t_end).unwrap();
        let vel = p.velocity().to_vec();
        let (vx, w) = if v > 0.0 {
            (v * (1.0 - 2.0 * (1.0 / m) / (1.0 / m + a * a / inertia)), -2.0 * k_t * a * v / (inertia * omega * omega))
        } else {
            (v, 0.0)
        };
        eprintln!("v = {v}: u̇_x {} (hand {vx}), θ̇ {} (hand {w}), switches {:?}", vel[0], vel[2], p.history());
        assert!((vel[0] - vx).abs() < 1e-4, "v = {v}: u̇_x {} against {vx}", vel[0]);
        assert!((vel[2] - w).abs() < 1e-4 * (k_t * a / (inertia * omega)).max(1.0), "v = {v}: θ̇ {} against {w}", vel[2]);
        let h = p.history()[0];
        assert!(h.slipping, "v = {v}: slipping at the end");
        if v > 0.0 {
            assert_eq!(h.switches, 1);
            let first = h.first_slip.unwrap();
            assert!((first - t1).abs() < 2.0 * p.max_step(), "switch at {first}, hand {t1}");
        } else {
            assert_eq!(h.switches, 1);
            assert!(h.first_slip.unwrap() <= p.max_step() * 1.0001);
        }
    }
}

/// A compressed triangular lattice (6 × 8 Hooke disks between two walls, μ = 0.3), with every
/// third grain–grain contact put at the Coulomb limit (F_t = ±μ F_n t̂, alternating signs) and
/// flagged sliding.
fn limit_lattice(at_limit: bool) -> Snapshot<D2> {
    let sim = lattice_2d(6, 8, GrainKind::Disk { thickness: 1.0 }, &hooke_params(100.0, 0.5, MU), true, Some(1.0), 3, &[]).build().unwrap();
    let mut snap = sim.snapshot();
    let mut k = 0;
    for c in snap.contacts.iter_mut() {
        c.sliding = false;
        c.tangential_force = DVec2::ZERO;
        if at_limit && matches!(c.j, grainwave_core::snapshot::Counterpart::Grain(_)) {
            if k % 3 == 0 {
                let t = DVec2::new(-c.normal.y, c.normal.x);
                let sign = if (k / 3) % 2 == 0 { 1.0 } else { -1.0 };
                c.tangential_force = t * (sign * MU * c.normal_force);
                c.sliding = true;
            }
            k += 1;
        }
    }
    snap
}

/// Kick: the grains of the bottom row get velocity `a` (ŷ + 0.3 x̂).
fn kick(snap: &Snapshot<D2>, a: f64) -> Vec<f64> {
    let ymin = snap.pos.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let mut v = vec![0.0; 3 * snap.len()];
    for (g, p) in snap.pos.iter().enumerate() {
        if p.y < ymin + 0.1 {
            v[3 * g] = 0.3 * a;
            v[3 * g + 1] = a;
        }
    }
    v
}

fn run(snap: &Snapshot<D2>, rule: BranchRule, a: f64, t: f64) -> (Vec<f64>, IncrementalPropagator<D2>) {
    let opts = IncrementalOptions { branches: rule, wall_damping: false, ..Default::default() };
    let mut p = IncrementalPropagator::<D2>::new(snap, None, &opts).unwrap();
    p.set_velocity(&kick(snap, a)).unwrap();
    p.advance_to(t).unwrap();
    (p.displacement().to_vec(), p)
}

/// The same packing with the existing linear propagation (velocity Verlet at the same step).
fn linear(snap: &Snapshot<D2>, sliding: SlidingContacts, a: f64, t: f64, dt: f64) -> Vec<f64> {
    let dm = DynamicalMatrix::assemble(snap, &AssemblyOptions { sliding, ..Default::default() }).unwrap();
    let system = dm.free_system(&Constraints::new(), ZeroRows::Keep).unwrap();
    assert_eq!(system.dofs(), dm.dofs());
    let spp = 50.0;
    let options = PropagationOptions { scheme: Scheme::VelocityVerlet, steps_per_period: spp, omega_max: Some(2.0 * std::f64::consts::PI / (spp * dt)), ..Default::default() };
    let state = InitialState { displacement: vec![0.0; dm.dofs()], velocity: kick(snap, a) };
    let mut p = Propagator::new(&system, system.mass(), &state, None, &options).unwrap();
    p.advance_to(t).unwrap();
    p.displacement().to_vec()
}

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

fn max_diff(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).fold(0.0, |m, (a, b)| m.max((a - b).abs()))
}

/// Bilateral limits: with no contact at the limit the incremental network is the `Stick`
/// network; forcing every contact at the limit to stick or to lose its tangential stiffness gives
/// the `Stick` and `Free` propagations. Same scheme and step, so the only difference is the
/// order of the floating-point sums (D u assembled by blocks against contact loads summed per
/// grain): tolerance 1e-10 of max |u| after ~150 steps. And the incremental rule is neither bound
/// (it differs from each by more than 1 % of max |u|).
#[test]
fn bilateral_limits_are_the_stick_and_free_propagations() {
    let t = 6.0;
    // no contact at the limit
    let plain = limit_lattice(false);
    let (u, p) = run(&plain, BranchRule::Incremental, 1.0, t);
    assert_eq!(p.counts().at_limit, 0);
    assert_eq!(p.slipping(), 0);
    let reference = linear(&plain, SlidingContacts::Stick, 1.0, t, p.max_step());
    let tol = 1e-10 * max_abs(&reference);
    assert!(max_diff(&u, &reference) < tol, "no contact at the limit: {:e}", max_diff(&u, &reference));
    // contacts at the limit, forced to one branch
    let snap = limit_lattice(true);
    let (stick, p) = run(&snap, BranchRule::Stick, 1.0, t);
    let at_limit = p.counts().at_limit;
    assert!(at_limit >= 10, "{at_limit} contacts at the limit");
    assert_eq!(at_limit, snap.contacts.iter().filter(|c| c.sliding).count(), "the mobilised set is the sliding set");
    let reference = linear(&snap, SlidingContacts::Stick, 1.0, t, p.max_step());
    assert!(max_diff(&stick, &reference) < 1e-10 * max_abs(&reference), "stick: {:e}", max_diff(&stick, &reference));
    let (free, _) = run(&snap, BranchRule::Free, 1.0, t);
    let reference = linear(&snap, SlidingContacts::Free, 1.0, t, p.max_step());
    assert!(max_diff(&free, &reference) < 1e-10 * max_abs(&reference), "free: {:e}", max_diff(&free, &reference));
    let (inc, _) = run(&snap, BranchRule::Incremental, 1.0, t);
    assert!(max_diff(&inc, &stick) > 1e-2 * max_abs(&stick), "incremental = stick?");
    assert!(max_diff(&inc, &free) > 1e-2 * max_abs(&free), "incremental = free?");
}

/// Homogeneity of degree one: amplitude 2 gives exactly (bit for bit: a power of two scales every
/// floating-point operation exactly) twice the response to 1, amplitude 3 three times it to
/// rounding (1e-12 relative: a few hundred steps of sums, and branch tests d < 0 whose sign is
/// never decided by rounding here), with the same branch histories; amplitude −1 is not −1 × the
/// response to 1 (differs by more than 1 % of max |u|), and at least a quarter of the contacts at
/// the limit first slip at other times (more than one step apart) for the two signs.
#[test]
fn response_is_positively_homogeneous_of_degree_one() {
    let t = 6.0;
    let snap = limit_lattice(true);
    let (u1, p1) = run(&snap, BranchRule::Incremental, 1.0, t);
    let (u2, p2) = run(&snap, BranchRule::Incremental, 2.0, t);
    let (u3, p3) = run(&snap, BranchRule::Incremental, 3.0, t);
    let (um, pm) = run(&snap, BranchRule::Incremental, -1.0, t);
    for (a, b) in u1.iter().zip(&u2) {
        assert_eq!(2.0 * a, *b);
    }
    let scale = max_abs(&u1);
    for (a, b) in u1.iter().zip(&u3) {
        assert!((3.0 * a - b).abs() <= 1e-12 * 3.0 * scale, "{a} {b}");
    }
    assert_eq!(p1.history(), p2.history());
    assert_eq!(p1.history(), p3.history());
    // over 6 time units the reverberating waves make every contact at the limit slip at some
    // time for both signs; the signs differ in which contacts slip first and when
    let first = |p: &IncrementalPropagator<D2>| p.history().iter().map(|h| h.first_slip).collect::<Vec<_>>();
    let (f1, fm) = (first(&p1), first(&pm));
    let differ = f1.iter().zip(&fm).filter(|(a, b)| match (a, b) {
        (Some(a), Some(b)) => (a - b).abs() > 1.5 * p1.max_step(),
        (a, b) => a.is_some() != b.is_some(),
    });
    let differ = differ.count();
    eprintln!("{} contacts at the limit; first slip at a different time for ±1: {differ}", p1.counts().at_limit);
    assert!(differ >= p1.counts().at_limit / 4, "the two signs slip the same contacts at the same times ({differ} differ)");
    let mirror: Vec<f64> = u1.iter().map(|x| -x).collect();
    assert!(max_diff(&um, &mirror) > 1e-2 * scale, "−1 gives −(response to +1)");
}

/// Bad options are refused with the key, the value and what is allowed.
#[test]
fn bad_options_are_refused() {
    let snap = limit_lattice(false);
    let e = IncrementalPropagator::<D2>::new(&snap, None, &IncrementalOptions { steps_per_period: 2.0, ..Default::default() }).err().unwrap().to_string();
    assert!(e.contains("incremental.steps_per_period") && e.contains('2') && e.contains("> π"), "{e}");
    let e = IncrementalPropagator::<D2>::new(&snap, None, &IncrementalOptions { mobilisation_tolerance: 1.5, ..Default::default() }).err().unwrap().to_string();
    assert!(e.contains("incremental.mobilisation_tolerance") && e.contains("1.5"), "{e}");
}
