//! Rattlers (SPEC §4): grains that carry no force in the static packing.
//!
//! Found by iterated removal: every grain with fewer than `min_contacts` force-carrying contacts
//! (F_n > 0; contacts with walls count, contacts with grains already removed do not) is removed,
//! until no more grain is removed. The default threshold is 2 for frictional packings and d + 1
//! for frictionless ones (the fewest contacts that can hold a grain in equilibrium).

use grainwave_core::contact::Tangential;
use grainwave_core::dim::Dim;
use grainwave_core::snapshot::{Counterpart, Snapshot};

/// Default threshold: 2 with friction (the grain–grain law has a tangential part and μ > 0),
/// d + 1 without.
pub fn default_min_contacts<D: Dim>(snapshot: &Snapshot<D>) -> usize {
    let frictional = !matches!(snapshot.law.tangential, Tangential::None) && snapshot.law.friction > 0.0;
    if frictional {
        2
    } else {
        D::D + 1
    }
}

/// Map from stable grain id to storage index in the snapshot.
pub(crate) fn id_to_index<D: Dim>(snapshot: &Snapshot<D>) -> Vec<usize> {
    let max = snapshot.id.iter().copied().max().map_or(0, |m| m as usize + 1);
    let mut map = vec![usize::MAX; max];
    for (k, &id) in snapshot.id.iter().enumerate() {
        map[id as usize] = k;
    }
    map
}

/// Rattler flags per grain (storage order), by iterated removal with threshold `min_contacts`.
pub fn find_rattlers<D: Dim>(snapshot: &Snapshot<D>, min_contacts: usize) -> Vec<bool> {
    let n = snapshot.len();
    let index = id_to_index(snapshot);
    // (i, Some(j)) for grain pairs, (i, None) for wall contacts; force-carrying only
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
                Some(j) => {
                    if !removed[i] && !removed[j] {
                        count[i] += 1;
                        count[j] += 1;
                    }
                }
                None => {
                    if !removed[i] {
                        count[i] += 1;
                    }
                }
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
