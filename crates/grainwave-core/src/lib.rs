//! # grainwave-core
//!
//! The discrete-element engine of grainwave: grains (disks, planar spheres, spheres), a domain
//! with periodic axes and walls, contact laws composed of parts (Hooke/Hertz, dashpots,
//! Cundall–Strack/Mindlin, Coulomb, rolling), a cell-list Verlet neighbor list carrying contact
//! histories, velocity-Verlet and Beeman integration, stop criteria, snapshots with contact
//! records and bit-exact checkpoints.
//!
//! Results are bitwise identical for any number of threads: forces are computed pair by pair into
//! a buffer and summed per grain in a fixed order, and every global sum uses fixed chunks.
//!
//! ```
//! use grainwave_core::prelude::*;
//! use glam::DVec2;
//!
//! // Two disks colliding head-on, Hooke law with restitution 0.9.
//! let mut params = ContactParams::preset("hooke_cundall_strack");
//! params.normal_stiffness = Some(1e4);
//! params.restitution = Some(0.9);
//! let law = params.build(Partner::Grain, "contact").unwrap();
//! let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
//! grains.push(DVec2::new(-0.6, 0.0), 0.5, 1.0, DVec2::new(1.0, 0.0));
//! grains.push(DVec2::new(0.6, 0.0), 0.5, 1.0, DVec2::new(-1.0, 0.0));
//! let domain = Domain::new(DVec2::new(-5.0, -5.0), DVec2::new(5.0, 5.0), [false; 3]);
//! let mut sim = SimulationBuilder::new(grains, domain, law).build().unwrap();
//! let stop = StopCriteria { time_limit: Some(0.5), ..Default::default() };
//! sim.run(&stop, &mut |_| Control::Continue).unwrap();
//! assert!(sim.grains.vel[0].x < 0.0); // it bounced
//! ```
#![warn(missing_docs)]

pub mod checkpoint;
pub mod contact;
pub mod dim;
pub mod domain;
pub mod error;
pub mod files;
pub mod grains;
pub mod neighbor;
pub mod placement;
pub mod rattlers;
pub(crate) mod real;
pub mod sim;
#[cfg(target_arch = "x86_64")]
pub(crate) mod simd512;
pub mod snapshot;
pub mod timestep;
pub mod util;

pub use error::{CoreError, Result};

/// Version of grainwave-core (recorded in outputs).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The names most programs need.
pub mod prelude {
    pub use crate::checkpoint::{load_simulation, AnySimulation};
    pub use crate::contact::{ContactLaw, ContactParams, NormalDamping, NormalElastic, Partner, Rolling, Tangential, TangentialDamping, Twisting};
    pub use crate::dim::{Dim, VectorOps, D2, D3};
    pub use crate::domain::{Domain, TimeFunction, Wall, WallMotion};
    pub use crate::grains::{GrainKind, Grains, SizeDistribution};
    pub use crate::sim::{Control, ExternalLoad, Integrator, Progress, RunHooks, RunOutcome, Simulation, SimulationBuilder, StopCriteria, StopReason};
    pub use crate::snapshot::{ContactRecord, Counterpart, Snapshot};
    pub use crate::{CoreError, Result};
}
