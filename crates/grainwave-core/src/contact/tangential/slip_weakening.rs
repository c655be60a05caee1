//! Linear slip-weakening friction (Ida 1972, J. Geophys. Res. 77, 3796; Palmer & Rice 1973,
//! Proc. R. Soc. A 332, 527): a Cundall–Strack spring whose Coulomb coefficient falls from its
//! static value to a residual one over a slip distance D_c, the friction of fault and
//! sheared-gouge models. A tangential law with a per-contact history of its own: the slip δ the
//! contact has accumulated since it formed.
//!
//! μ(δ) = μ_s − (μ_s − μ_d) min(δ/D_c, 1),  μ_s = the contact law's `friction`, μ_d = r μ_s,
//!
//! F_t = k_t s + γ_t v_t on grain i with s ← s + v_t Δt, capped at μ(δ) F_n (δ before the
//! step); where the contact slides, s is reset to F_t/k_t and the length cut off the spring is
//! the slip of the step, δ ← δ + |s_trial − s_cap|. δ is zero when the contact forms (a
//! contact that opens has healed) and never decreases. r = 1 (or D_c = ∞) is the linear law.
//!
//! The work of the friction force over the weakening, ∫₀^{D_c} μ(δ) F_n dδ = ½ (μ_s + μ_d) F_n D_c,
//! exceeds the residual sliding work μ_d F_n D_c by the fracture energy ½ (μ_s − μ_d) F_n D_c.

use super::linear::linear_spring_parts;
use super::linear::spring_stiffness;
use super::{HistoryKind, Linear, Tangential, TangentialContext, TangentialLaw};
use crate::contact::{scalar_history, spring_step};
use crate::error::{CoreError, Result};
use crate::real::{Real, Vec3};
use serde::{Deserialize, Serialize};

/// Linear spring k_t with a Coulomb coefficient weakening linearly with the contact's
/// accumulated slip δ, from μ_s (the contact law's `friction`) to `residual_ratio` × μ_s over
/// `weakening_distance` D_c (see the module documentation). History: the spring s (a length,
/// as the linear law) and the slip δ ([`Slip`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SlipWeakening {
    /// k_t (force/length).
    pub stiffness: f64,
    /// r = μ_d/μ_s ∈ [0, 1] (dimensionless).
    pub residual_ratio: f64,
    /// D_c (length), > 0.
    pub weakening_distance: f64,
}

/// The history of one contact beyond its spring: the slip δ it has accumulated (a length; 0
/// when the contact forms).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Slip(pub f64);

scalar_history!(Slip, "slip_weakening.slip");

impl SlipWeakening {
    /// The spring without the weakening: the linear law of the same k_t, whose stiffness,
    /// elastic force, increment and reset this law shares.
    #[inline(always)]
    fn spring(&self) -> Linear {
        Linear { stiffness: self.stiffness }
    }

    /// μ(δ)/μ_s = 1 − (1 − r) min(δ/D_c, 1), on every lane.
    #[inline(always)]
    fn weakening<R: Real>(&self, slip: R) -> R {
        let one = R::splat(1.0);
        one - R::splat(1.0 - self.residual_ratio) * (slip / R::splat(self.weakening_distance)).min(one)
    }
}

/// `[contact.tangential]` with `law = "slip_weakening"`: k_t = `stiffness_ratio` × k_n of the
/// linear normal law, μ_d/μ_s = `residual_ratio` and D_c = `weakening_distance` (μ_s is
/// `contact.friction`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(schemars::JsonSchema))]
#[serde(deny_unknown_fields)]
pub struct SlipWeakeningTable {
    /// k_t / k_n, default 2/7.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness_ratio: Option<f64>,
    /// r = μ_d/μ_s ∈ [0, 1].
    pub residual_ratio: f64,
    /// D_c [length], > 0 (may be inf: no weakening).
    pub weakening_distance: f64,
}

impl TangentialLaw for SlipWeakening {
    const HISTORY: HistoryKind = HistoryKind::Displacement;
    type Extra = Slip;
    type Params = SlipWeakeningTable;

    fn build(params: &SlipWeakeningTable, at: &TangentialContext) -> Result<Tangential> {
        let stiffness = spring_stiffness(params.stiffness_ratio, at, "slip_weakening")?;
        let law = SlipWeakening { stiffness, residual_ratio: params.residual_ratio, weakening_distance: params.weakening_distance };
        law.validate(&format!("{}.tangential", at.field))?;
        Ok(law.into())
    }

    /// k_t > 0 (the linear law's check), r ∈ [0, 1] and D_c > 0 (may be infinite).
    fn validate(&self, field: &str) -> Result<()> {
        self.spring().validate(field)?;
        let r = self.residual_ratio;
        if !(0.0..=1.0).contains(&r) {
            return Err(CoreError::invalid(format!("{field}.residual_ratio"), r, "a ratio μ_d/μ_s in [0, 1] (1: no weakening)"));
        }
        let d = self.weakening_distance;
        if !(d > 0.0) {
            return Err(CoreError::invalid(format!("{field}.weakening_distance"), d, "a length D_c > 0 (may be inf: no weakening)"));
        }
        Ok(())
    }

    linear_spring_parts!();

    /// The linear law's step with the cap μ(δ) F_n, then δ ← δ + |s_trial − s_cap| where the
    /// contact slides.
    #[inline(always)]
    fn step_lanes<R: Real, const N: usize>(&self, rotated: Vec3<R>, v_t: Vec3<R>, k_t: R, gamma_t: R, dt: f64, cap: R, slip: &mut R) -> (Vec3<R>, Vec3<R>, R::Mask) {
        let cap = cap * self.weakening(*slip);
        spring_step::<R, N, Self>(self, rotated, v_t, k_t, gamma_t, dt, cap, |kept, at_cap, sliding| {
            let zero = R::splat(0.0);
            let mut cut = zero;
            for c in 0..N {
                let d = kept[c] - at_cap[c];
                cut = cut + d * d;
            }
            *slip = *slip + R::select(sliding, cut.sqrt(), zero);
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::{ContactLaw, Hooke, Hysteretic, NormalDamping, Rolling, Tangential, TangentialDamping, Twisting};
    use crate::dim::{Dim, VectorOps, D2, D3};
    use crate::domain::{Domain, Wall};
    use crate::grains::{GrainKind, Grains};
    use crate::sim::{Simulation, SimulationBuilder};

    /// Hooke normal spring `k_n` (or the hysteretic law k_n, 2 k_n where `hysteretic`), the
    /// slip-weakening spring k_t = k_n/2 with r and D_c, μ_s, no damping.
    fn law(k_n: f64, friction: f64, residual_ratio: f64, weakening_distance: f64, hysteretic: bool) -> ContactLaw {
        ContactLaw {
            normal: if hysteretic { Hysteretic { loading_stiffness: k_n, unloading_stiffness: 2.0 * k_n }.into() } else { Hooke { stiffness: k_n }.into() },
            damping: NormalDamping::None,
            tangential: SlipWeakening { stiffness: 0.5 * k_n, residual_ratio, weakening_distance }.into(),
            tangential_damping: TangentialDamping::None,
            friction,
            rolling: Rolling::None,
            twisting: Twisting::None,
        }
    }

    fn vector<D: Dim>(x: f64, y: f64, rest: f64) -> D::Vector {
        let mut p = D::Vector::ZERO;
        for k in 2..D::D {
            p.set(k, rest);
        }
        p.set(0, x);
        p.set(1, y);
        p
    }

    /// A grain of radius ½ and mass 1 resting on a floor of law `floor` under gravity g (at
    /// its equilibrium overlap g/k_n), sliding along x at `v0` without spin (periodic along x
    /// and z, 4 long).
    fn on_floor<D: Dim>(floor: ContactLaw, k_n: f64, g: f64, v0: f64, dt: f64) -> Simulation<D> {
        let mut grains = Grains::<D>::new(if D::D == 2 { GrainKind::Disk { thickness: 1.0 } } else { GrainKind::Sphere });
        grains.push_with_mass(vector::<D>(1.0, 0.5 - g / k_n, 1.0), 0.5, 1.0, vector::<D>(v0, 0.0, 0.0));
        let domain = Domain::new(D::Vector::ZERO, vector::<D>(4.0, 2.0, 4.0), [true, false, true]).with_wall(Wall::axis_aligned("floor", 1, 0.0, true, floor));
        let frictionless = ContactLaw { friction: 0.0, tangential: Tangential::None, ..floor };
        SimulationBuilder::new(grains, domain, frictionless).dt(dt).gravity(vector::<D>(0.0, -g, 0.0)).build().unwrap()
    }

    /// The slip a sliding grain accumulates before it rolls: its slip velocity v_s = v − ωR
    /// falls at (1 + mR²/I) g μ(δ) while dδ/dt = v_s, so v_s² = v₀² − 2 (1 + mR²/I) g ∫₀^δ μ,
    /// and it stops at the δ where ∫₀^δ μ = v₀²/(2 (1 + mR²/I) g) (mR²/I = 2 for a disk,
    /// 5/2 for a sphere).
    fn slip_to_rolling(v0: f64, g: f64, inertia_factor: f64, mu_s: f64, r: f64, d_c: f64) -> f64 {
        let target = v0 * v0 / (2.0 * (1.0 + inertia_factor) * g);
        let dmu = (1.0 - r) * mu_s;
        // ∫₀^{D_c} μ = μ_s D_c − Δμ D_c/2
        let weakened = mu_s * d_c - 0.5 * dmu * d_c;
        if target <= weakened {
            // Δμ/(2D_c) δ² − μ_s δ + target = 0, the smaller root
            (mu_s - (mu_s * mu_s - 2.0 * dmu * target / d_c).sqrt()) * d_c / dmu
        } else {
            d_c + (target - weakened) / (r * mu_s)
        }
    }

    /// A grain sliding on a slip-weakening floor stops slipping (rolls) after the slip of the
    /// closed form above, in 2D and 3D, with the weakening complete before it stops (D_c = 0.01)
    /// and not (D_c = 0.2); the engine's stored δ is that slip, and it lies between the slips
    /// of the constant coefficients μ_s and μ_d. Without its history (δ read as 0 at every step)
    /// the law would be the constant μ_s: 0.033 (disk) instead of 0.076. Tolerance 1 %: the
    /// spring's own length μ m g/k_t ≈ 1e-4 of the slip, the slip of one step v Δt ≈ 1e-3 of it.
    #[test]
    fn a_sliding_grain_rolls_after_the_slip_of_the_weakening_law() {
        fn run<D: Dim>(d_c: f64) {
            let (k_n, g, v0, mu_s, r) = (1e5, 10.0, 1.0, 0.5, 0.4);
            let dt = 1e-4;
            let mut s = on_floor::<D>(law(k_n, mu_s, r, d_c, false), k_n, g, v0, dt);
            let f = if D::D == 2 { 2.0 } else { 2.5 };
            let expected = slip_to_rolling(v0, g, f, mu_s, r, d_c);
            // rolls after t ≤ v₀/((1 + f) g μ_d) ≈ 0.17 s; run twice as long
            let steps = (2.0 * v0 / ((1.0 + f) * g * r * mu_s) / dt) as usize;
            let slip = |s: &Simulation<D>| s.nlist.wall_extra.column(0).get::<Slip>(1, 0).0;
            let mut rolled = 0.0;
            for k in 0..steps {
                s.step().unwrap();
                assert_eq!(s.nlist.wall_pairs.len(), 1);
                if k == 3 * steps / 4 {
                    rolled = slip(&s);
                }
            }
            // no slip over the last quarter (the stuck spring oscillates, undamped, with the
            // force it held when the grain began to roll: v − ωR swings by ≈ μ_d m g/√(k_t m/3))
            let slip = slip(&s);
            assert!(slip - rolled < 1e-3 * expected, "still slipping: {rolled} then {slip}");
            assert!((slip - expected).abs() < 0.01 * expected, "{}D, D_c = {d_c}: slip {slip}, closed form {expected}", D::D);
            // the constant coefficients μ_s and μ_d: ∫₀^δ μ = μ δ
            let target = v0 * v0 / (2.0 * (1.0 + f) * g);
            let (strong, weak) = (target / mu_s, target / (r * mu_s));
            assert!(strong < slip && slip < weak, "{strong} < {slip} < {weak}");
        }
        for d_c in [0.01, 0.2] {
            run::<D2>(d_c);
            run::<D3>(d_c);
        }
    }

    /// One step past the cap against the closed form: the force is μ(δ) F_n along the trial
    /// force, the spring holds it, and the slip grows by the length cut off the spring; below
    /// the cap nothing slips. At δ ≥ D_c the cap is μ_d F_n.
    #[test]
    fn one_sliding_step_cuts_the_spring_and_adds_the_slip() {
        let law = SlipWeakening { stiffness: 2.0, residual_ratio: 0.25, weakening_distance: 0.1 };
        let (mu_f_n, v) = (1.0, [0.0, 3.0, 0.0]);
        for (slip, weakening) in [(0.0, 1.0), (0.05, 1.0 - 0.75 * 0.5), (0.3, 0.25)] {
            let mut h = slip;
            let (f, s, sliding) = law.step_lanes::<f64, 3>([0.0, 0.5, 0.0], v, 2.0, 0.0, 0.1, mu_f_n, &mut h);
            // trial spring 0.5 + 0.3 = 0.8, trial force 1.6 > μ(δ) F_n
            assert!(sliding);
            assert!((f[1] - weakening * mu_f_n).abs() < 1e-15 && f[0] == 0.0, "{f:?}");
            assert!((s[1] - weakening * mu_f_n / 2.0).abs() < 1e-15, "{s:?}");
            assert!((h - (slip + 0.8 - s[1])).abs() < 1e-15, "{h}");
        }
        let mut h = 0.05;
        let (f, s, sliding) = law.step_lanes::<f64, 3>([0.0, 0.1, 0.0], [0.0, 1.0, 0.0], 2.0, 0.0, 0.1, mu_f_n, &mut h);
        assert!(!sliding && h == 0.05 && (f[1] - 0.4).abs() < 1e-15 && (s[1] - 0.2).abs() < 1e-15);
    }

    /// Positions, velocities and spins, to the bit.
    fn bits<D: Dim>(s: &Simulation<D>) -> String {
        format!("{:?} {:?} {:?}", s.grains.pos, s.grains.vel, s.grains.omega)
    }

    /// `steps` steps of `s`, with a list rebuild forced before each where `rebuild`.
    fn run_steps<D: Dim>(s: &mut Simulation<D>, steps: usize, rebuild: bool) {
        for _ in 0..steps {
            if rebuild {
                s.nlist.stale = true;
            }
            s.step().unwrap();
        }
    }

    /// Runs `make()` `first` steps (where `check` looks at it) and 300 more three ways — on
    /// from there, from a checkpoint taken there, and with a list rebuild at every step — and
    /// a fresh `make()` on 2 workers with a rebuild at every step: all four the same bits.
    fn same_bits_across_checkpoint_rebuilds_and_threads(make: impl Fn() -> Simulation<D3>, first: usize, check: impl Fn(&Simulation<D3>)) -> Simulation<D3> {
        let mut a = make();
        run_steps(&mut a, first, false);
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
        two.install(|| run_steps(&mut d, first + 300, true));
        assert_eq!(bits(&a), bits(&d));
        assert_eq!(a.state_hash(), d.state_hash());
        a
    }

    /// Two grains of radius ½, mass 1, colliding obliquely (relative velocity (−0.1, 0.1, 0)
    /// with the centres offset along x) in a periodic box without walls, under `law`.
    fn oblique(law: ContactLaw, dt: f64) -> Simulation<D3> {
        let mut grains = Grains::<D3>::new(GrainKind::Sphere);
        let gap = 20.0 * 0.1 * dt;
        grains.push_with_mass(vector::<D3>(1.5 - 0.5 * gap, 2.0, 2.0), 0.5, 1.0, vector::<D3>(0.05, -0.05, 0.0));
        grains.push_with_mass(vector::<D3>(2.5 + 0.5 * gap, 2.0, 2.0), 0.5, 1.0, vector::<D3>(-0.05, 0.05, 0.0));
        SimulationBuilder::new(grains, Domain::new(vector::<D3>(0.0, 0.0, 0.0), vector::<D3>(4.0, 4.0, 4.0), [true; 3]), law).dt(dt).build().unwrap()
    }

    /// The slip survives checkpoints, list rebuilds at every step and two workers to the bit:
    /// on a floor (the grain–wall column) and between two grains colliding obliquely (the pair
    /// list's column), with the Hooke normal law (the history is the slip alone) and with the
    /// hysteretic one (the history is the pair of ξ_max and δ, one column named after both).
    /// The colliding pair slides, and its rebound differs from that of the same law read
    /// without its history (δ = 0 at every step: μ_s throughout) — the history is used — while
    /// its normal rebound keeps the hysteretic restitution √(k₁/k₂) (tolerance 1 %: O(Δt/t_c)
    /// as in the hysteretic law's tests): the two histories of a pair do not mix.
    #[test]
    fn the_slip_survives_checkpoints_rebuilds_and_threads() {
        let (k_n, g, dt) = (1e5, 10.0, 1e-4);
        let a = same_bits_across_checkpoint_rebuilds_and_threads(
            || on_floor::<D3>(law(k_n, 0.5, 0.4, 0.01, false), k_n, g, 1.0, dt),
            300,
            |a| assert!(a.nlist.wall_extra.column(0).get::<Slip>(1, 0).0 > 0.0),
        );
        assert!(a.nlist.wall_extra.is_stored());
        // 200 steps per half period of the stiffer (unloading) spring
        let dt = std::f64::consts::PI * (0.5f64 / 4e4).sqrt() / 200.0;
        for hysteretic in [false, true] {
            let with = law(2e4, 0.3, 0.0, 1e-5, hysteretic);
            let a = same_bits_across_checkpoint_rebuilds_and_threads(|| oblique(with, dt), 100, |a| assert_eq!(a.counters.contacts, 1));
            // the pair's column, under the name of its histories
            let names = if hysteretic { "hysteretic.max_overlap+slip_weakening.slip" } else { "slip_weakening.slip" };
            let mut b = oblique(with, dt);
            run_steps(&mut b, 100, false);
            assert_eq!(b.nlist.list.extra.name().as_deref(), Some(names));
            // to the end of the contact, and the same law without weakening
            let (mut a, mut strong) = (a, oblique(law(2e4, 0.3, 1.0, 1e-5, hysteretic), dt));
            for s in [&mut a, &mut strong] {
                run_steps(s, 2000, false);
                assert_eq!(s.counters.contacts, 0);
            }
            let tangential = |s: &Simulation<D3>| s.grains.vel[1].y - s.grains.vel[0].y;
            assert!((tangential(&a) - tangential(&strong)).abs() > 1e-3, "{} {}", tangential(&a), tangential(&strong));
            let normal = (a.grains.vel[1].x - a.grains.vel[0].x) / 0.1;
            let e = if hysteretic { 0.5f64.sqrt() } else { 1.0 };
            assert!((normal - e).abs() < 0.01 * e, "normal restitution {normal}, expected {e}");
        }
    }

    /// Bad values are refused naming the key, the value and what is allowed.
    #[test]
    fn bad_values_are_refused_with_their_keys() {
        let law = |stiffness, residual_ratio, weakening_distance| SlipWeakening { stiffness, residual_ratio, weakening_distance };
        assert!(law(1.0, 0.5, 0.1).validate("contact").is_ok());
        assert!(law(1.0, 1.0, f64::INFINITY).validate("contact").is_ok());
        for r in [-0.1, 1.5, f64::NAN] {
            let e = law(1.0, r, 0.1).validate("contact").unwrap_err().to_string();
            assert!(e.contains("contact.residual_ratio") && e.contains("[0, 1]"), "{e}");
        }
        for d in [0.0, -1.0, f64::NAN] {
            let e = law(1.0, 0.5, d).validate("contact").unwrap_err().to_string();
            assert!(e.contains("contact.weakening_distance") && e.contains("D_c > 0"), "{e}");
        }
        assert!(law(0.0, 0.5, 0.1).validate("contact").unwrap_err().to_string().contains("contact.tangential_stiffness"));
        // through the contact law, under its key
        let wall = ContactLaw { tangential: law(1.0, 2.0, 0.1).into(), ..super::tests::law(1.0, 0.5, 0.5, 0.1, false) };
        assert!(wall.validate("wall_contact").unwrap_err().to_string().contains("wall_contact.residual_ratio"));
    }
}
