//! The applications' tests: the paper's experiment, its fixtures and its
//! pipeline run small.

plsr_testkit::run_from_the_repository_root!();

mod paper_experiment;
