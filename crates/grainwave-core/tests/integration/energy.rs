//! Energy conservation without dissipation or friction (SPEC §3): dense (jammed) periodic
//! packings in 2D and 3D, agitated so that contacts keep opening and closing, 10⁴ steps at the
//! suggested time step.
//!
//! The packings are jammed with a damped law, then the law is switched to the elastic one and
//! every grain gets a random velocity. Velocity Verlet conserves a shadow energy; the true energy
//! oscillates around it with a relative amplitude ~ (ω dt)²/8. *Drift* is measured between the
//! averages of the first and the last 500 steps, which removes these bounded oscillations and
//! keeps any systematic trend (e.g. from contacts opening and closing). Measured values are
//! printed; at the time of writing: 2D Hooke 3e-8, 3D Hertz 3e-6.

use crate::common;
use common::*;
use grainwave_core::contact::Partner;
use grainwave_core::prelude::*;

struct Drift {
    drift: f64,
    max_deviation: f64,
    contact_events: u64,
}

fn measure<D: Dim>(mut sim: Simulation<D>, steps: usize) -> Drift {
    let window = 500;
    let e0 = total_energy(&sim);
    let mut energies = Vec::with_capacity(steps);
    let mut events = 0;
    for _ in 0..steps {
        sim.step().unwrap();
        events += sim.counters.network_changes;
        energies.push(total_energy(&sim));
    }
    let first: f64 = energies[..window].iter().sum::<f64>() / window as f64;
    let last: f64 = energies[steps - window..].iter().sum::<f64>() / window as f64;
    let max_deviation = energies.iter().map(|e| (e - e0).abs()).fold(0.0, f64::max) / e0;
    Drift { drift: (last - first).abs() / e0, max_deviation, contact_events: events }
}

both_dims! {
    /// Hooke on 2000 disks (2D), Hertz on 500 spheres (3D), frictionless.
    fn dense_periodic_packing_conserves_energy<D>() {
        let (damped, elastic) = D::pick((hooke(1.0e3, Some(0.3), 0.0), hooke(1.0e3, None, 0.0)), (hertz(1.0e3, 0.3, 0.0, Some(0.3)), hertz(1.0e3, 0.3, 0.0, None)));
        let (damped, elastic) = (damped.build(Partner::Grain, "contact").unwrap(), elastic.build(Partner::Grain, "contact").unwrap());
        let b = D::dense((40, 50), 5, damped, 0.0, D::pick(11, 12));
        let b = if D::D == 3 { b.expected_overlap(0.05) } else { b };
        let sim = jam_then_heat(b.build().unwrap(), elastic, 1e-8, D::pick(0.3, 0.2), 3);
        let (contacts, agitation) = D::pick((5000, 0.01), (2000, 0.02));
        assert!(sim.counters.contacts > contacts, "dense: {} contacts for {} grains", sim.counters.contacts, sim.len());
        assert!(sim.kinetic_energy() > agitation * sim.elastic_energy(), "agitated");
        let d = measure(sim, 10_000);
        eprintln!("{} {}: drift {:.3e}, max deviation {:.3e}, {} contact events", D::NAME, D::pick("Hooke", "Hertz"), d.drift, d.max_deviation, d.contact_events);
        assert!(d.contact_events > 10_000, "contacts must open and close during the test");
        assert!(d.drift < 1e-5, "relative energy drift {:e}", d.drift);
        assert!(d.max_deviation < 1e-3, "energy oscillation {:e}", d.max_deviation);
    }
}

#[test]
fn beeman_energy_error_stays_bounded() {
    // Beeman is not symplectic; for a conservative system its energy error still stays small
    // over this horizon (same order as Verlet's oscillation).
    let damped = hertz(1.0e3, 0.0, 0.0, Some(0.3)).build(Partner::Grain, "contact").unwrap();
    let elastic = hertz(1.0e3, 0.0, 0.0, None).build(Partner::Grain, "contact").unwrap();
    let sim = dense_2d(20, 20, damped, 0.0, 5).integrator(Integrator::Beeman).expected_overlap(0.05).build().unwrap();
    let sim = jam_then_heat(sim, elastic, 1e-8, 0.2, 4);
    let d = measure(sim, 10_000);
    eprintln!("2D Hertz Beeman: drift {:.3e}, max deviation {:.3e}", d.drift, d.max_deviation);
    assert!(d.drift < 1e-4, "relative energy drift {:e}", d.drift);
}
