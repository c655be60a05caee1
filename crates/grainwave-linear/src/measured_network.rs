//! The spring network of a measured 2D packing (SPEC §7.3): the contact records of a snapshot in a
//! window become the bonds of a [`SpringNetwork`], whose affine moduli (a, b, c, d) and half-plane
//! criterion r classify the packing as elastic-like (r > 0, one peak under a point force) or
//! double-peaked (r < 0).
//!
//! Every grain–grain contact whose contact point lies in the window [min, max) (half-open, so that
//! adjacent windows share no contact) contributes one bond: vector = branch vector, kⁿ and kᵗ =
//! the differential stiffnesses of the record. The "cell" area is the window's area, so the moduli
//! are energy densities of the window. Sliding contacts contribute kᵗ = 0 unless asked otherwise
//! (a sliding contact cannot store more tangential force in the direction it slides). Grain–wall
//! contacts are left out: the moduli describe the bulk; keep the window a few grains away from the
//! walls. For a perfect lattice the result is exact when the window spans whole periods (e.g. a
//! multiple of the spacing horizontally and of two rows vertically); otherwise the contacts cut by
//! the window's edges make a relative error of order spacing/size.
//!
//! ```
//! use grainwave_linear::lattice::SpringNetwork;
//! use grainwave_linear::measured_network::{spring_network, NetworkWindow};
//! # use grainwave_core::prelude::*;
//! # use glam::DVec2;
//! // two disks in contact along x inside a 4 × 4 window: one horizontal bond of stiffness 100
//! let mut p = ContactParams::preset("hooke_cundall_strack");
//! p.normal_stiffness = Some(100.0);
//! p.friction = Some(0.0);
//! let law = p.build(Partner::Grain, "contact").unwrap();
//! let mut g = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
//! g.push(DVec2::new(1.0, 2.0), 0.51, 1.0, DVec2::ZERO);
//! g.push(DVec2::new(2.0, 2.0), 0.51, 1.0, DVec2::ZERO);
//! let domain = Domain::new(DVec2::ZERO, DVec2::new(4.0, 4.0), [false; 3]);
//! let sim = SimulationBuilder::new(g, domain, law).max_initial_overlap(0.1).build().unwrap();
//! let window = NetworkWindow { min: [0.0, 0.0], max: [4.0, 4.0] };
//! let net = spring_network(&sim.snapshot(), &window, false);
//! assert_eq!(net.bonds.len(), 1);
//! assert!((net.moduli().a - 100.0 / 16.0).abs() < 1e-12); // kⁿ ℓ²/A with ℓ = 1, A = 16
//! ```

use crate::lattice::{SpringBond, SpringNetwork};
use grainwave_core::dim::{VectorOps, D2};
use grainwave_core::snapshot::{Counterpart, Snapshot};
use serde::{Deserialize, Serialize};

/// A rectangular window [min, max) of the plane.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NetworkWindow {
    /// Lower corner (x, z).
    pub min: [f64; 2],
    /// Upper corner (x, z).
    pub max: [f64; 2],
}

impl NetworkWindow {
    /// Area of the window (0 when empty).
    pub fn area(&self) -> f64 {
        (self.max[0] - self.min[0]).max(0.0) * (self.max[1] - self.min[1]).max(0.0)
    }

    /// True when `p` lies in [min, max).
    pub fn contains(&self, p: [f64; 2]) -> bool {
        (0..2).all(|k| p[k] >= self.min[k] && p[k] < self.max[k])
    }
}

/// The spring network of the grain–grain contacts of `snapshot` whose contact points lie in
/// `window`; `keep_sliding_tangential` keeps kᵗ on sliding contacts (default use: false).
pub fn spring_network(snapshot: &Snapshot<D2>, window: &NetworkWindow, keep_sliding_tangential: bool) -> SpringNetwork {
    let index = snapshot.index_by_id();
    let mut bonds = Vec::new();
    for c in &snapshot.contacts {
        if !matches!(c.j, Counterpart::Grain(_)) {
            continue;
        }
        let point = snapshot.pos[index[c.i as usize]] + c.normal * c.lever_i;
        if !window.contains([point.get(0), point.get(1)]) {
            continue;
        }
        let k_t = if c.sliding && !keep_sliding_tangential { 0.0 } else { c.tangential_stiffness };
        bonds.push(SpringBond { vector: [c.branch.x, c.branch.y], normal_stiffness: c.normal_stiffness, tangential_stiffness: k_t });
    }
    SpringNetwork { cell_area: window.area(), bonds }
}
