//! The integration tests of grainwave-analysis, in one test binary (one link of the whole stack instead of
//! one per file): each module is a file of tests of one subject.

mod coarse_grain;
mod peaks;
