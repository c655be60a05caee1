//! The integration tests of the e1 study, in one test binary: runs through the registry
//! (`e1`) and the published numbers (`e1_papers`).

mod e1;
mod e1_papers;

use grainwave_study::registry::{entry, Entry, Registry};

static ONE: [Entry; 1] = [entry::<grainwave_e1::E1Protocol>()];
/// The study alone in a registry: the tests check, run, resume and re-plot configs through the
/// same dispatch as the command line (the table of every study is `grainwave-experiments`').
pub static REGISTRY: Registry = Registry::new(&ONE);
