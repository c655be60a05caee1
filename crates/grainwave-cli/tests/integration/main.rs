//! The integration tests of grainwave-cli (the program run as a user would), in one test binary (one link of the whole stack instead of
//! one per file): each module is a file of tests of one subject.

mod adversarial;
mod interrupt;
