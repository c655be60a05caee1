//! Rattlers (SPEC §4): grains that carry no force in a static packing, found from a snapshot's
//! contact records.
//!
//! Found by iterated removal: every grain with fewer than `min_contacts` force-carrying contacts
//! (F_n > 0; contacts with walls count, contacts with grains already removed do not) is removed,
//! until no more grain is removed. The default threshold is 2 for frictional packings and d + 1
//! for frictionless ones (the fewest contacts that can hold a grain in equilibrium).
//!
//! One finder for every consumer of snapshots: the static characterization
//! (`grainwave-analysis`) and the dynamical matrix (`grainwave-linear`) re-export it, so that they
//! always agree on which grains rattle.

use crate::contact::Tangential;
use crate::dim::Dim;
use crate::snapshot::{Counterpart, Snapshot};

/// Iterated rattler removal (see the module docs): flags per grain, storage order.
pub fn find_rattlers<D: Dim>(snapshot: &Snapshot<D>, min_contacts: usize) -> Vec<bool> {
    let n = snapshot.len();
    let index = snapshot.index_by_id();
    let links: Vec<(usize, Option<usize>)> = snapshot
        .contacts
        .iter()
        .filter(|c| c.normal_force > 0.0)
        .map(|c| {
            let i = index[c.i as usize];
            match c.j {
                Counterpart::Grain(j) => (i, Some(index[j as usize])),
                Counterpart::Wall(_) => (i, None),
            }
        })
        .collect();
    let mut removed = vec![false; n];
    loop {
        let mut count = vec![0usize; n];
        for &(i, j) in &links {
            match j {
                Some(j) if !removed[i] && !removed[j] => {
                    count[i] += 1;
                    count[j] += 1;
                }
                None if !removed[i] => count[i] += 1,
                _ => {}
            }
        }
        let mut changed = false;
        for g in 0..n {
            if !removed[g] && count[g] < min_contacts {
                removed[g] = true;
                changed = true;
            }
        }
        if !changed {
            return removed;
        }
    }
}

/// Default rattler threshold: 2 when the grain–grain law has friction, d + 1 otherwise.
pub fn default_rattler_threshold<D: Dim>(snapshot: &Snapshot<D>) -> usize {
    let frictional = !matches!(snapshot.law.tangential, Tangential::None) && snapshot.law.friction > 0.0;
    if frictional {
        2
    } else {
        D::D + 1
    }
}
