//! The integration tests of the studies together (through the registry that lists them all), in
//! one test binary: every committed example config, the fuzz regressions and seed corpus, the
//! resource limits, the run directory's files, generated edits of configs, the config reference
//! and the scorecard of the validation page.

mod check_run_property;
mod examples;
mod fuzz_regressions;
mod layering;
mod limits;
mod loaders_fuzz;
mod reference;
mod run_dir_files;
mod run_property;
mod validation_page;
mod watchdog;
