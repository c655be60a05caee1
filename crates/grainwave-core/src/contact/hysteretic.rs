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
//! reversible laws). Runs on the general kernel (`Specialized::Hysteretic`); grain–wall contacts
//! keep no law history yet, so walls need another normal law (`[wall_contact.normal]` or the
//! wall's `contact.normal`).

use super::{ContactLaw, DampingTable, LawHistory, LawParts, NormalDamping, NormalElastic, NormalResponse, Rolling, Tangential, TangentialDamping, Twisting};
use crate::error::{require_positive, CoreError, Result};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// The parameters: loading stiffness k₁ and unloading stiffness k₂ ≥ k₁ (force/length).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct HystereticNormal {
    /// k₁.
    pub loading_stiffness: f64,
    /// k₂ ≥ k₁.
    pub unloading_stiffness: f64,
}

/// The history of one contact: its largest overlap so far ξ_max (0 when the contact forms).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MaxOverlap(pub f64);

impl LawHistory for MaxOverlap {
    const NAME: &'static str = "hysteretic.max_overlap";
    const WIDTH: usize = 1;
    type Lanes<R: Real> = R;
    #[inline(always)]
    fn to_lane(self) -> f64 {
        self.0
    }
    #[inline(always)]
    fn from_lane(l: f64) -> Self {
        MaxOverlap(l)
    }
    fn encode(&self, out: &mut Vec<f64>) {
        out.push(self.0);
    }
    fn decode(values: &[f64]) -> Self {
        MaxOverlap(values[0])
    }
}

impl HystereticNormal {
    /// The response at overlap `xi` with the contact's largest overlap so far `max_overlap`,
    /// which it updates (the module documentation's law). Stiffness: k₁ loading, k₂ unloading
    /// while F_el > 0, 0 past ξ₀; secant F_el/ξ.
    #[inline(always)]
    pub(crate) fn response_with_history<R: Real>(&self, xi: R, max_overlap: &mut R) -> NormalResponse<R> {
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

    /// The stateless response (no history known): the loading branch's force k₁ ξ, and as its
    /// stiffness the largest one of the law, k₂, which bounds the contact's frequency (time-step
    /// suggestions).
    #[inline(always)]
    pub(crate) fn response_lanes<R: Real>(&self, xi: R) -> NormalResponse<R> {
        let k1 = R::splat(self.loading_stiffness);
        NormalResponse { force: k1 * xi, stiffness: R::splat(self.unloading_stiffness), secant: k1 }
    }

    /// Elastic energy without the history: that of the loading branch, ½ k₁ ξ² (an upper bound
    /// of what an unloading contact returns).
    pub fn energy(&self, xi: f64) -> f64 {
        0.5 * self.loading_stiffness * xi * xi
    }

    /// Checks k₁ > 0 and k₁ ≤ k₂ < ∞; `field` prefixes the key names.
    pub fn validate(&self, field: &str) -> Result<()> {
        require_positive(&format!("{field}.loading_stiffness"), self.loading_stiffness)?;
        let (k1, k2) = (self.loading_stiffness, self.unloading_stiffness);
        if !(k2.is_finite() && k2 >= k1) {
            return Err(CoreError::invalid(
                format!("{field}.unloading_stiffness"),
                k2,
                format!("a finite stiffness ≥ loading_stiffness = {k1} (k₂ = k₁ is the elastic Hooke law; restitution e = √(k₁/k₂))"),
            ));
        }
        Ok(())
    }

    /// The law of a config whose `[contact.normal]` names `hysteretic`: `law` is the Hooke
    /// composition built with k_n = k₁ (its other families already checked), `damping` the
    /// `[contact.damping]` table's law name if one was given; `field` prefixes the key names.
    pub(crate) fn apply(self, law: &mut ContactLaw, damping: Option<&DampingTable>, field: &str) -> Result<()> {
        self.validate(&format!("{field}.normal"))?;
        let refused = match damping {
            Some(DampingTable::Restitution { .. }) => Some("restitution"),
            Some(DampingTable::Tsuji { .. }) => Some("tsuji"),
            _ => None,
        };
        if let Some(name) = refused {
            return Err(CoreError::invalid(
                format!("{field}.damping.law"),
                format!("\"{name}\""),
                "\"none\", \"dashpot\", \"critical_fraction\" or \"mass_proportional\" with the hysteretic normal law (its restitution √(k₁/k₂) comes from the hysteresis; the restitution dashpots are defined for reversible laws)",
            ));
        }
        law.normal = NormalElastic::Hysteretic(self);
        Ok(())
    }
}

/// A contact law whose normal part is [`HystereticNormal`], every other part that of `law`
/// (read at each contact, as on the general kernel): the composition the engine runs for it,
/// with the per-contact history [`MaxOverlap`].
#[derive(Clone, Copy, Debug)]
pub struct Hysteretic {
    pub(crate) law: ContactLaw,
    pub(crate) normal: HystereticNormal,
}

impl LawParts for Hysteretic {
    type Extra = MaxOverlap;
    #[inline(always)]
    fn normal_response<R: Real>(&self, xi: R, _r_eff: R, extra: &mut R) -> NormalResponse<R> {
        self.normal.response_with_history(xi, extra)
    }
    #[inline(always)]
    fn normal(&self) -> NormalElastic {
        self.law.normal
    }
    #[inline(always)]
    fn damping(&self) -> NormalDamping {
        self.law.damping
    }
    #[inline(always)]
    fn tangential(&self) -> Tangential {
        self.law.tangential
    }
    #[inline(always)]
    fn tangential_damping(&self) -> TangentialDamping {
        self.law.tangential_damping
    }
    #[inline(always)]
    fn friction(&self) -> f64 {
        self.law.friction
    }
    #[inline(always)]
    fn rolling(&self) -> Rolling {
        self.law.rolling
    }
    #[inline(always)]
    fn twisting(&self) -> Twisting {
        self.law.twisting
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::{ContactParams, NormalTable, Partner};
    use crate::dim::{Dim, D2, D3};
    use crate::domain::Domain;
    use crate::grains::{GrainKind, Grains};
    use crate::sim::{Simulation, SimulationBuilder};

    fn params(k1: f64, k2: f64) -> ContactParams {
        let mut p = ContactParams { normal: Some(NormalTable::Hysteretic { loading_stiffness: k1, unloading_stiffness: k2 }), ..Default::default() };
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
            let mut touched = false;
            for _ in 0..100_000 {
                s.step().unwrap();
                touched |= s.counters.contacts > 0;
                if touched && s.counters.contacts == 0 {
                    break;
                }
            }
            assert!(touched && s.counters.contacts == 0);
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
        let bits = |s: &Simulation<D3>| format!("{:?} {:?}", s.grains.pos, s.grains.vel);
        let run = |s: &mut Simulation<D3>, steps: usize, rebuild: bool| {
            for _ in 0..steps {
                if rebuild {
                    s.nlist.stale = true;
                }
                s.step().unwrap();
            }
        };
        // contact after 10 steps, loading for ≈ 100 steps, unloading along k₂ for ≈ 50 steps
        // with force and ≈ 95 more without
        let mut a = pair::<D3>(law, 10.0 * 0.1 * dt, 0.1, dt);
        // into the contact, past the turn (unloading along k₂)
        run(&mut a, 130, false);
        assert!(a.counters.contacts == 1);
        let ckpt = crate::checkpoint::encode("simulation-3d", &a).unwrap();
        let mut b: Simulation<D3> = crate::checkpoint::decode(&ckpt, "simulation-3d", "test").unwrap();
        let mut c = a.clone();
        run(&mut a, 300, false);
        run(&mut b, 300, false);
        let builds = c.nlist.builds;
        run(&mut c, 300, true);
        assert!(c.nlist.builds >= builds + 300);
        assert_eq!(bits(&a), bits(&b));
        assert_eq!(bits(&a), bits(&c));
        // without the history the rebuilt run would have unloaded along k₁ (e = 1): it did not
        assert!(relative_speed(&a) / 0.1 < 0.6, "{}", relative_speed(&a) / 0.1);
        let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let mut d = pair::<D3>(law, 10.0 * 0.1 * dt, 0.1, dt);
        two.install(|| run(&mut d, 430, true));
        assert_eq!(bits(&a), bits(&d));
        // grains stored right one first, re-sorted mid-contact: the rebuild that matches
        // contacts by id pair (the two grains swapped storage order) carries ξ_max too
        let mut e = pair::<D3>(law, 10.0 * 0.1 * dt, 0.1, dt);
        e.grains.pos.swap(0, 1);
        e.grains.vel.swap(0, 1);
        e.nlist.stale = true;
        run(&mut e, 130, false);
        let first = e.grains.id[0];
        e.sort_spatially();
        assert_ne!(e.grains.id[0], first);
        run(&mut e, 300, false);
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
        p.damping = Some(DampingTable::Restitution { restitution: 0.5, tangential_ratio: None, tangential_rate: None });
        let e = p.build(Partner::Grain, "contact").unwrap_err().to_string();
        assert!(e.contains("contact.damping.law") && e.contains("restitution") && e.contains("dashpot"), "{e}");
        p.damping = Some(DampingTable::Dashpot { coefficient: 0.1, tangential_ratio: None, tangential_rate: None });
        let law = p.build(Partner::Grain, "contact").unwrap();
        assert_eq!(law.normal, NormalElastic::Hysteretic(HystereticNormal { loading_stiffness: 1e4, unloading_stiffness: 2e4 }));
        assert!(matches!(law.specialize(), crate::contact::Specialized::Hysteretic(_)));
    }
}
