//! Hysteretic linear normal law (Walton & Braun 1986, J. Rheol. 30, 949; the plastic normal
//! law of Thornton's and Luding's reviews): a law with its own per-contact history.
//!
//! Loading along k₁ while the overlap ξ exceeds its largest value so far ξ_max, unloading and
//! reloading along k₂ ≥ k₁ from (ξ_max, k₁ ξ_max):
//!
//! F_el = k₁ ξ for ξ ≥ ξ_max (loading; ξ_max ← ξ),
//! F_el = max(0, k₂ (ξ − ξ₀)) with ξ₀ = ξ_max (1 − k₁/k₂) otherwise,
//!
//! with ξ_max per contact ([`MaxOverlap`]), zero when the contact forms. An undamped binary
//! collision returns ½ k₂ (ξ_max − ξ₀)² = (k₁/k₂) ½ k₁ ξ_max² of the energy stored on loading:
//! the coefficient of restitution is e = √(k₁/k₂), whatever the impact speed.
//!
//! Config: `[contact.normal] law = "hysteretic"` with `loading_stiffness` k₁ and
//! `unloading_stiffness` k₂ (the Hooke composition otherwise: tangential spring ratio × k₁,
//! any damping except the `restitution` and `tsuji` dashpots, which are defined for the
//! reversible laws). For grain–wall contacts too (`[wall_contact.normal]` or a wall's
//! `contact.normal`): each grain–wall contact keeps its own ξ_max, with the wall's effective
//! mass the grain's (a grain hitting a hysteretic wall rebounds with e = √(k₁/k₂)).

use super::{Composition, NormalContext, NormalLaw, NormalResponse};
use crate::contact::scalar_history;
use crate::error::{require_positive, CoreError, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// The hysteretic law: loading stiffness k₁ and unloading stiffness k₂ ≥ k₁ (force/length).
/// Loading along k₁ past the contact's largest overlap so far ξ_max, unloading and reloading
/// along k₂ from (ξ_max, k₁ ξ_max); a binary collision's restitution is √(k₁/k₂). The Hooke
/// composition otherwise (tangential stiffness ratio × k₁); see docs/engine.md.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct Hysteretic {
    /// k₁ [force/length].
    pub loading_stiffness: f64,
    /// k₂ ≥ k₁ [force/length].
    pub unloading_stiffness: f64,
}

/// The history of one contact: its largest overlap so far ξ_max (0 when the contact forms).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MaxOverlap(pub f64);

scalar_history!(MaxOverlap, "hysteretic.max_overlap");

impl NormalLaw for Hysteretic {
    type Params = Hysteretic;
    type History = MaxOverlap;

    fn composition(params: &Hysteretic) -> Composition {
        Composition::Hooke { stiffness: params.loading_stiffness, key: "loading_stiffness" }
    }

    /// The law of the table, checked; the `restitution` and `tsuji` dashpots are refused
    /// (defined for reversible laws), in the `[contact.damping]` table and as the flat keys
    /// `restitution`, `tsuji_restitution` alike.
    fn build(params: &Hysteretic, at: &NormalContext) -> Result<Self> {
        params.validate(at.field)?;
        if let Some(d) = at.damping.as_ref().filter(|d| matches!(d.law, "restitution" | "tsuji")) {
            return Err(CoreError::invalid(
                d.key.clone(),
                d.value.clone(),
                format!(
                    "no {} dashpot with the hysteretic normal law: damping \"none\", \"dashpot\", \"critical_fraction\" or \"mass_proportional\" (its restitution √(k₁/k₂) comes from the hysteresis; the restitution dashpots are defined for reversible laws)",
                    d.law
                ),
            ));
        }
        Ok(*params)
    }

    /// Checks k₁ > 0 and k₁ ≤ k₂ < ∞ (keys `{field}.normal.loading_stiffness`, …).
    fn validate(&self, field: &str) -> Result<()> {
        let key = |k: &str| format!("{field}.normal.{k}");
        require_positive(&key("loading_stiffness"), self.loading_stiffness)?;
        let (k1, k2) = (self.loading_stiffness, self.unloading_stiffness);
        if !(k2.is_finite() && k2 >= k1) {
            return Err(CoreError::invalid(
                key("unloading_stiffness"),
                k2,
                format!("a finite stiffness ≥ loading_stiffness = {k1} (k₂ = k₁ is the elastic Hooke law; restitution e = √(k₁/k₂))"),
            ));
        }
        Ok(())
    }

    /// The response at overlap `xi` with the contact's largest overlap so far `max_overlap`,
    /// which it updates (the module documentation's law). Stiffness: k₁ loading, k₂ unloading
    /// while F_el > 0, 0 past ξ₀; secant F_el/ξ.
    #[inline(always)]
    fn response_lanes<R: Real>(&self, xi: R, _r_eff: R, max_overlap: &mut R) -> NormalResponse<R> {
        let zero = R::splat(0.0);
        let (k1, k2) = (R::splat(self.loading_stiffness), R::splat(self.unloading_stiffness));
        // loading where ξ ≥ ξ_max (then ξ_max ← ξ)
        let xi_max = xi.max(*max_overlap);
        let loading = xi.eq(xi_max);
        let xi0 = xi_max * R::splat(1.0 - self.loading_stiffness / self.unloading_stiffness);
        let unloaded = (k2 * (xi - xi0)).max_zero();
        let force = R::select(loading, k1 * xi, unloaded);
        let stiffness = R::select(loading, k1, R::select(unloaded.gt(zero), k2, zero));
        *max_overlap = xi_max;
        NormalResponse { force, stiffness, secant: force / xi }
    }

    /// The energy returned on unloading from ξ: with ξ_m = max(ξ, ξ_max) and
    /// ξ₀ = ξ_m (1 − k₁/k₂), ∫_{ξ₀}^{ξ} k₂ (ξ' − ξ₀) dξ' = ½ k₂ (ξ − ξ₀)² for ξ > ξ₀, 0 otherwise.
    /// On the loading branch (ξ = ξ_m) it is (k₁/k₂) ½ k₁ ξ²: the rest of the work ½ k₁ ξ² done
    /// on loading is dissipated.
    fn energy(&self, xi: f64, _r_eff: f64, history: &MaxOverlap) -> f64 {
        let (k1, k2) = (self.loading_stiffness, self.unloading_stiffness);
        let xi0 = xi.max(history.0) * (1.0 - k1 / k2);
        let d = (xi - xi0).max(0.0);
        0.5 * k2 * d * d
    }

    /// k₂, the stiffer of the two branches.
    fn max_stiffness(&self, _xi: f64, _r_eff: f64) -> f64 {
        self.unloading_stiffness
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::damping::normal::{DashpotTable, RestitutionTable, TsujiTable};
    use crate::contact::{ContactLaw, ContactParams, DampingTable, NormalElastic, NormalTable, Partner};
    use crate::dim::{Dim, D2, D3};
    use crate::domain::Domain;
    use crate::grains::{GrainKind, Grains};
    use crate::sim::{Simulation, SimulationBuilder};

    fn params(k1: f64, k2: f64) -> ContactParams {
        let mut p = ContactParams { normal: Some(NormalTable::Hysteretic(Hysteretic { loading_stiffness: k1, unloading_stiffness: k2 })), ..Default::default() };
        p.friction = Some(0.0);
        p
    }

    /// Two grains of radius ½, mass 1, a gap `gap` apart, approaching head on at relative speed
    /// `v` along x in a periodic box, with time step `dt`.
    fn pair<D: Dim>(law: ContactLaw, gap: f64, v: f64, dt: f64) -> Simulation<D> {
        let mut grains = Grains::<D>::new(if D::D == 2 { GrainKind::Disk { thickness: 1.0 } } else { GrainKind::Sphere });
        let at = |x: f64| {
            let mut p = D::Vector::ZERO;
            p.set(0, x);
            for k in 1..D::D {
                p.set(k, 2.0);
            }
            p
        };
        let vel = |s: f64| {
            let mut u = D::Vector::ZERO;
            u.set(0, s);
            u
        };
        grains.push_with_mass(at(1.5 - 0.5 * gap), 0.5, 1.0, vel(0.5 * v));
        grains.push_with_mass(at(2.5 + 0.5 * gap), 0.5, 1.0, vel(-0.5 * v));
        let mut hi = D::Vector::ZERO;
        for k in 0..D::D {
            hi.set(k, 4.0);
        }
        SimulationBuilder::new(grains, Domain::new(D::Vector::ZERO, hi, [true; 3]), law).dt(dt).build().unwrap()
    }

    use crate::dim::VectorOps;

    fn relative_speed<D: Dim>(s: &Simulation<D>) -> f64 {
        s.grains.vel[1].get(0) - s.grains.vel[0].get(0)
    }

    /// Steps `s` until its contacts have formed and all ended again.
    fn through_contact<D: Dim>(s: &mut Simulation<D>) {
        let mut touched = false;
        for _ in 0..100_000 {
            s.step().unwrap();
            touched |= s.counters.contacts > 0;
            if touched && s.counters.contacts == 0 {
                break;
            }
        }
        assert!(touched && s.counters.contacts == 0);
    }

    /// Positions and velocities, to the bit.
    fn bits(s: &Simulation<D3>) -> String {
        format!("{:?} {:?}", s.grains.pos, s.grains.vel)
    }

    /// `steps` steps of `s`, with a list rebuild forced before each where `rebuild`.
    fn run_steps(s: &mut Simulation<D3>, steps: usize, rebuild: bool) {
        for _ in 0..steps {
            if rebuild {
                s.nlist.stale = true;
            }
            s.step().unwrap();
        }
    }

    /// Runs `make()` 130 steps into a contact (where `check` looks at it) and 300 more three ways — on from there, from a checkpoint taken there, and
    /// with a list rebuild at every step — and a fresh `make()` 430 steps on 2 workers with a
    /// rebuild at every step: all four the same bits. Returns the first run.
    fn same_bits_across_checkpoint_rebuilds_and_threads(make: impl Fn() -> Simulation<D3>, check: impl Fn(&Simulation<D3>)) -> Simulation<D3> {
        let mut a = make();
        run_steps(&mut a, 130, false);
        check(&a);
        let ckpt = crate::checkpoint::encode("simulation-3d", &a).unwrap();
        let mut b: Simulation<D3> = crate::checkpoint::decode(&ckpt, "simulation-3d", "test").unwrap();
        let mut c = a.clone();
        run_steps(&mut a, 300, false);
        run_steps(&mut b, 300, false);
        let builds = c.nlist.builds;
        run_steps(&mut c, 300, true);
        assert!(c.nlist.builds >= builds + 300);
        assert_eq!(bits(&a), bits(&b));
        assert_eq!(bits(&a), bits(&c));
        let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let mut d = make();
        two.install(|| run_steps(&mut d, 430, true));
        assert_eq!(bits(&a), bits(&d));
        assert_eq!(a.state_hash(), d.state_hash());
        a
    }

    /// An undamped head-on collision leaves with e = √(k₁/k₂) of its impact speed, in 2D and
    /// 3D, for three stiffness ratios. With ≥ 200 steps per contact the discrete loading and
    /// unloading turn points are within one step's overlap change v Δt of the exact ones,
    /// an error O(Δt/t_c) < 1 % on e (the tolerance), measured much smaller.
    #[test]
    fn head_on_collision_has_restitution_sqrt_k1_over_k2() {
        fn run<D: Dim>(ratio: f64) -> f64 {
            let (k1, v) = (1e4, 0.1);
            let law = params(k1, k1 / ratio).build(Partner::Grain, "contact").unwrap();
            // contact time ≥ π √(m*/k₂) = π √(0.5/k₂): Δt a 200th of it
            let dt = std::f64::consts::PI * (0.5 / (k1 / ratio)).sqrt() / 200.0;
            let mut s = pair::<D>(law, 1e-3, v, dt);
            through_contact(&mut s);
            relative_speed(&s) / v
        }
        for ratio in [1.0, 0.5, 0.1] {
            for e in [run::<D2>(ratio), run::<D3>(ratio)] {
                assert!((e - ratio.sqrt()).abs() < 0.01 * ratio.sqrt(), "k1/k2 = {ratio}: e = {e}, expected {}", ratio.sqrt());
            }
        }
    }

    /// A checkpoint taken mid-contact (ξ_max stored, the contact unloading) resumes to the
    /// bits of the uninterrupted run, and a list rebuild forced at every step keeps ξ_max (the
    /// same bits as a run that never rebuilds mid-contact); 1 and 2 workers give the same bits.
    #[test]
    fn history_survives_checkpoints_rebuilds_and_threads() {
        let law = params(1e4, 4e4).build(Partner::Grain, "contact").unwrap();
        let dt = std::f64::consts::PI * (0.5f64 / 4e4).sqrt() / 100.0;
        // contact after 10 steps, loading for ≈ 100 steps, unloading along k₂ for ≈ 50 steps
        // with force and ≈ 95 more without: at step 130 past the turn (unloading along k₂)
        let a = same_bits_across_checkpoint_rebuilds_and_threads(|| pair::<D3>(law, 10.0 * 0.1 * dt, 0.1, dt), |a| assert!(a.counters.contacts == 1));
        // without the history the rebuilt run would have unloaded along k₁ (e = 1): it did not
        assert!(relative_speed(&a) / 0.1 < 0.6, "{}", relative_speed(&a) / 0.1);
        // grains stored right one first, re-sorted mid-contact: the rebuild that matches
        // contacts by id pair (the two grains swapped storage order) carries ξ_max too
        let mut e = pair::<D3>(law, 10.0 * 0.1 * dt, 0.1, dt);
        e.grains.pos.swap(0, 1);
        e.grains.vel.swap(0, 1);
        e.nlist.stale = true;
        run_steps(&mut e, 130, false);
        let first = e.grains.id[0];
        e.sort_spatially();
        assert_ne!(e.grains.id[0], first);
        run_steps(&mut e, 300, false);
        let speed = (e.grains.vel[e.grains.index_of(0).unwrap()].x - e.grains.vel[e.grains.index_of(1).unwrap()].x) / 0.1;
        assert!((speed - 0.5).abs() < 0.005, "{speed}");
    }

    /// Bad stiffnesses and the restitution dashpots are refused naming the key, the value and
    /// what is allowed.
    #[test]
    fn bad_values_are_refused_with_their_keys() {
        let e = params(1e4, 5e3).build(Partner::Grain, "contact").unwrap_err().to_string();
        assert!(e.contains("contact.normal.unloading_stiffness") && e.contains("5000") && e.contains("≥ loading_stiffness"), "{e}");
        let e = params(-1.0, 5e3).build(Partner::Grain, "contact").unwrap_err().to_string();
        assert!(e.contains("contact.normal.loading_stiffness") && e.contains("-1"), "{e}");
        let e = params(1e4, f64::INFINITY).build(Partner::Grain, "contact").unwrap_err().to_string();
        assert!(e.contains("contact.normal.unloading_stiffness") && e.contains("inf"), "{e}");
        let mut p = params(1e4, 2e4);
        p.damping = Some(DampingTable::Restitution(RestitutionTable { restitution: 0.5, tangential_ratio: None, tangential_rate: None }));
        let e = p.build(Partner::Grain, "contact").unwrap_err().to_string();
        assert!(e.contains("contact.damping.law") && e.contains("restitution") && e.contains("dashpot"), "{e}");
        p.damping = Some(DampingTable::Tsuji(TsujiTable { restitution: 0.5, tangential_ratio: None }));
        let e = p.build(Partner::Grain, "contact").unwrap_err().to_string();
        assert!(e.contains("contact.damping.law") && e.contains("\"tsuji\""), "{e}");
        // the same dashpots as flat keys beside the family tables: refused naming the flat key
        // (they were once accepted, lowered to a critical fraction computed for a linear law)
        p.damping = None;
        p.restitution = Some(0.5);
        let e = p.build(Partner::Grain, "contact").unwrap_err().to_string();
        assert!(e.contains("contact.restitution") && e.contains("0.5") && e.contains("no restitution dashpot") && e.contains("hysteresis"), "{e}");
        p.restitution = None;
        p.tsuji_restitution = Some(0.5);
        let e = p.build(Partner::Grain, "contact.wall").unwrap_err().to_string();
        assert!(e.contains("contact.wall.tsuji_restitution") && e.contains("no tsuji dashpot"), "{e}");
        // a flat dashpot coefficient is a damping the law allows
        p.tsuji_restitution = None;
        p.normal_damping = Some(0.1);
        assert_eq!(p.build(Partner::Grain, "contact").unwrap().normal, NormalElastic::Hysteretic(Hysteretic { loading_stiffness: 1e4, unloading_stiffness: 2e4 }));
        p.normal_damping = None;
        p.damping = Some(DampingTable::Dashpot(DashpotTable { coefficient: 0.1, tangential_ratio: None, tangential_rate: None }));
        let law = p.build(Partner::Grain, "contact").unwrap();
        assert_eq!(law.normal, NormalElastic::Hysteretic(Hysteretic { loading_stiffness: 1e4, unloading_stiffness: 2e4 }));
        // frictionless: no tangential part, the general kernel; with friction, the specialised
        // composition of a normal law with history
        assert!(!law.specialize().has_window_kernel());
        p.friction = Some(0.3);
        let law = p.build(Partner::Grain, "contact").unwrap();
        assert!(matches!(law.specialize(), crate::contact::Specialized::NormalHistory(..)));
    }

    /// The energy read from the history is the work the contact returns on unloading, ∫ F dξ
    /// from ξ down to 0 along the law itself (history updated at every point), for a contact
    /// loaded to ξ_m and then partly unloaded, and on the loading branch (k₁/k₂) ½ k₁ ξ². The
    /// force is piecewise linear, so the trapezoidal sum with 10⁵ points is exact but for the
    /// one interval holding the kink at ξ₀, an error ≤ k₂ h² / 8 relative to ½ k₂ (ξ − ξ₀)²,
    /// below 1e-9 here (the tolerance 1e-8).
    #[test]
    fn energy_is_the_work_returned_on_unloading() {
        let law = Hysteretic { loading_stiffness: 1e4, unloading_stiffness: 4e4 };
        let mut h = 0.0;
        for k in 0..=100 {
            law.response_lanes(1e-3 * k as f64 / 100.0, 0.5, &mut h);
        }
        assert_eq!(h, 1e-3);
        for xi in [1e-3, 0.9e-3, 0.8e-3, 0.7e-3] {
            let stored = MaxOverlap(h);
            let n = 100_000;
            let (mut work, mut hist) = (0.0, h);
            let mut f_prev = law.response_lanes(xi, 0.5, &mut hist).force;
            for k in 1..=n {
                let x = xi * (1.0 - k as f64 / n as f64);
                let f = law.response_lanes(x, 0.5, &mut hist).force;
                work += 0.5 * (f + f_prev) * xi / n as f64;
                f_prev = f;
            }
            let e = law.energy(xi, 0.5, &stored);
            assert!((e - work).abs() <= 1e-8 * work.max(1e-300), "ξ = {xi}: energy {e}, work {work}");
        }
        // ξ₀ = ¾ ξ_m: unloaded past it, nothing is stored
        assert_eq!(law.energy(0.7e-3, 0.5, &MaxOverlap(1e-3)), 0.0);
        // the loading branch (a contact that has just formed)
        let xi = 2e-3;
        let e = NormalElastic::from(law).energy(xi, 0.5);
        assert!((e - 0.25 * 0.5 * 1e4 * xi * xi).abs() < 1e-15 * e, "{e}");
    }

    /// Grain 0 (radius ½, mass 1) a gap `gap` above a hysteretic floor (k₁, k₂), moving down
    /// at `v`; with `beside`, grain 1 moving at `v` towards a Hooke wall (k₂, undamped) on the
    /// left, the two contacts at the same time. No gravity, no friction.
    fn on_walls<D: Dim>(k1: f64, k2: f64, gap: f64, v: f64, dt: f64, beside: bool) -> Simulation<D> {
        let floor = params(k1, k2).build(Partner::Wall, "wall_contact").unwrap();
        let mut hooke = ContactParams::preset("hooke_cundall_strack");
        hooke.normal_stiffness = Some(k2);
        hooke.friction = Some(0.0);
        let left = hooke.build(Partner::Wall, "wall_contact").unwrap();
        let mut grains = Grains::<D>::new(if D::D == 2 { GrainKind::Disk { thickness: 1.0 } } else { GrainKind::Sphere });
        let vector = |x: f64, y: f64, rest: f64| {
            let mut p = D::Vector::ZERO;
            for k in 2..D::D {
                p.set(k, rest);
            }
            p.set(0, x);
            p.set(1, y);
            p
        };
        grains.push_with_mass(vector(2.0, 0.5 + gap, 2.0), 0.5, 1.0, vector(0.0, -v, 0.0));
        if beside {
            grains.push_with_mass(vector(0.5 + gap, 3.0, 2.0), 0.5, 1.0, vector(-v, 0.0, 0.0));
        }
        let domain = Domain::new(D::Vector::ZERO, vector(5.0, 5.0, 5.0), [false; 3])
            .with_wall(crate::domain::Wall::axis_aligned("floor", 1, 0.0, true, floor))
            .with_wall(crate::domain::Wall::axis_aligned("left", 0, 0.0, true, left));
        let grain_law = params(k1, k2).build(Partner::Grain, "contact").unwrap();
        SimulationBuilder::new(grains, domain, grain_law).dt(dt).build().unwrap()
    }

    /// Grain–wall contacts keep the wall law's history, each its own: a grain bouncing off a
    /// hysteretic floor leaves with e = √(k₁/k₂) (2D and 3D, three ratios; the tolerance as for
    /// the head-on collision: ≥ 200 steps per contact, O(Δt/t_c) < 1 %), while a grain hitting
    /// a Hooke wall beside it at the same time leaves with e = 1 (the walls' columns are
    /// separate). A checkpoint taken mid-contact while unloading resumes to the bits of the
    /// uninterrupted run, a list rebuild at every step keeps ξ_max (same bits), and 2 workers
    /// give the bits of 1. With the default history read at each step (what a wall contact
    /// did before it kept one) the floor would return e = 1.
    #[test]
    fn grain_wall_contacts_keep_their_history() {
        fn rebound<D: Dim>(ratio: f64) -> (f64, f64) {
            let (k1, v) = (1e4, 0.1);
            // contact time ≥ π √(m/k₂), m = 1 against a wall: Δt a 200th of it
            let dt = std::f64::consts::PI * (1.0 / (k1 / ratio)).sqrt() / 200.0;
            let mut s = on_walls::<D>(k1, k1 / ratio, 1e-3, v, dt, true);
            through_contact(&mut s);
            let (floor, left) = (s.grains.index_of(0).unwrap(), s.grains.index_of(1).unwrap());
            (s.grains.vel[floor].get(1) / v, s.grains.vel[left].get(0) / v)
        }
        for ratio in [1.0, 0.5, 0.1] {
            for (floor, left) in [rebound::<D2>(ratio), rebound::<D3>(ratio)] {
                assert!((floor - ratio.sqrt()).abs() < 0.01 * ratio.sqrt(), "k1/k2 = {ratio}: e = {floor}, expected {}", ratio.sqrt());
                assert!((left - 1.0).abs() < 0.01, "Hooke wall: e = {left}");
            }
        }
        // checkpoint, rebuilds, threads: at step 130 the floor contact unloads along k₂
        // (loading ≈ 100 steps from step ≈ 10, unloading ≈ 50); the Hooke wall's (≈ 100 steps
        // from step ≈ 10) has just ended
        let (k1, k2) = (1e4, 4e4);
        let dt = std::f64::consts::PI * (1.0f64 / k2).sqrt() / 100.0;
        let a = same_bits_across_checkpoint_rebuilds_and_threads(
            || on_walls::<D3>(k1, k2, 10.0 * 0.1 * dt, 0.1, dt, true),
            |a| {
                assert_eq!(a.counters.contacts, 1);
                assert!(a.nlist.wall_extra.is_stored());
            },
        );
        let floor = a.grains.index_of(0).unwrap();
        assert!(a.grains.vel[floor].get(1) / 0.1 < 0.6, "{}", a.grains.vel[floor].get(1) / 0.1);
    }

    /// The energy and the contact record of a grain–wall contact read its stored ξ_max: on the
    /// unloading branch the elastic energy is ½ k₂ (ξ − ξ₀)² and the normal force k₂ (ξ − ξ₀),
    /// and kinetic + elastic energy is conserved along it (tolerances as for the grain pair
    /// below: 1e-9 for two ways of computing ξ, 1e-3 for velocity Verlet's energy oscillation
    /// at 200 steps per contact). Read with the default history, the energy would be the
    /// loading branch's and the force k₁ ξ.
    #[test]
    fn grain_wall_energy_and_records_read_the_stored_maximum_overlap() {
        fn run<D: Dim>() {
            let (k1, k2, v) = (1e4, 4e4, 0.1);
            let dt = std::f64::consts::PI * (1.0 / k2).sqrt() / 200.0;
            let mut s = on_walls::<D>(k1, k2, 1e-3, v, dt, false);
            let (mut xi_max, mut turn, mut unloading_steps) = (0.0f64, None::<f64>, 0);
            for _ in 0..100_000 {
                s.step().unwrap();
                let xi = 0.5 - s.grains.pos[0].get(1);
                if xi <= 0.0 {
                    if xi_max > 0.0 {
                        break;
                    }
                    continue;
                }
                let f = s.contact_records()[0].normal_force;
                let e = s.elastic_energy();
                let total = s.kinetic_energy() + e;
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1e-300);
                if xi >= xi_max {
                    xi_max = xi;
                    assert!(close(f, k1 * xi), "loading: F = {f}, k1 ξ = {}", k1 * xi);
                } else {
                    let d = (xi - xi_max * (1.0 - k1 / k2)).max(0.0);
                    assert!(close(f, k2 * d) || (d == 0.0 && f == 0.0), "unloading: F = {f}, k2 (ξ − ξ0) = {}", k2 * d);
                    assert!(close(e, 0.5 * k2 * d * d) || (d == 0.0 && e == 0.0), "unloading: E = {e}, ½ k2 (ξ − ξ0)² = {}", 0.5 * k2 * d * d);
                    if d > 0.0 {
                        let t = *turn.get_or_insert(total);
                        assert!((total - t).abs() <= 1e-3 * t, "unloading: KE + E = {total}, at the turn {t}");
                        unloading_steps += 1;
                    }
                }
            }
            assert!(unloading_steps > 20, "{unloading_steps} unloading steps");
        }
        run::<D2>();
        run::<D3>();
    }

    /// What the engine reports of a contact reads its stored ξ_max: along an undamped head-on
    /// collision, `Simulation::elastic_energy` is ½ k₂ (ξ − ξ₀)² on the unloading branch (ξ₀ =
    /// ξ_max (1 − k₁/k₂), ξ_max the largest overlap the run went through), the contact record's
    /// normal force is k₂ (ξ − ξ₀) there and k₁ ξ while loading, and kinetic + elastic energy is
    /// conserved along the (reversible) unloading branch. Read with the default history instead,
    /// the energy would be the loading branch's (k₁/k₂) ½ k₁ ξ² and the force k₁ ξ: at k₁/k₂ =
    /// ¼ the sum would rise by up to (1 − k₁/k₂)² = 56 % of its value at the turn.
    /// Tolerances: the formulas are evaluated from the same positions as the engine, 1e-9
    /// relative covers the two ways of computing ξ (√ of the squared distance, or the norm of
    /// the displacement); the energy sum of velocity Verlet at 200 steps per contact time
    /// oscillates by O((ω Δt)²) ≈ 2.5e-4 of the energy, bounded by 1e-3.
    #[test]
    fn energy_and_records_read_the_stored_maximum_overlap() {
        fn run<D: Dim>() {
            let (k1, k2, v) = (1e4, 4e4, 0.1);
            let law = params(k1, k2).build(Partner::Grain, "contact").unwrap();
            let dt = std::f64::consts::PI * (0.5 / k2).sqrt() / 200.0;
            let mut s = pair::<D>(law, 1e-3, v, dt);
            let overlap = |s: &Simulation<D>| 1.0 - (s.grains.pos[1].get(0) - s.grains.pos[0].get(0));
            let (mut xi_max, mut turn, mut unloading_steps, mut loading_steps) = (0.0f64, None::<f64>, 0, 0);
            for _ in 0..100_000 {
                s.step().unwrap();
                let xi = overlap(&s);
                if xi <= 0.0 {
                    if xi_max > 0.0 {
                        break;
                    }
                    continue;
                }
                let records = s.contact_records();
                let f = records[0].normal_force;
                let e = s.elastic_energy();
                let total = s.kinetic_energy() + e;
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1e-300);
                if xi >= xi_max {
                    xi_max = xi;
                    loading_steps += 1;
                    assert!(close(f, k1 * xi), "loading: F = {f}, k1 ξ = {}", k1 * xi);
                    assert!(close(e, 0.5 * k1 * k1 / k2 * xi * xi), "loading: E = {e}");
                } else {
                    let xi0 = xi_max * (1.0 - k1 / k2);
                    let d = (xi - xi0).max(0.0);
                    assert!(close(f, k2 * d) || (d == 0.0 && f == 0.0), "unloading: F = {f}, k2 (ξ − ξ0) = {}", k2 * d);
                    assert!(close(e, 0.5 * k2 * d * d) || (d == 0.0 && e == 0.0), "unloading: E = {e}, ½ k2 (ξ − ξ0)² = {}", 0.5 * k2 * d * d);
                    if d > 0.0 {
                        let t = *turn.get_or_insert(total);
                        assert!((total - t).abs() <= 1e-3 * t, "unloading: KE + E = {total}, at the turn {t}");
                        unloading_steps += 1;
                    }
                }
            }
            // both branches were sampled (≈ 100 steps each at 200 steps per k₂ contact time)
            assert!(loading_steps > 50 && unloading_steps > 20, "{loading_steps} loading, {unloading_steps} unloading steps");
        }
        run::<D2>();
        run::<D3>();
    }
}
