//! The pipeline of one run: run every method over every pair ([`crate::run`]), then measure
//! ([`crate::measure::build`]); [`crate::render::write_outputs`] renders the files.

use datasets::Dataset;
use indicatif::ProgressBar;

use crate::error::EvalError;
use crate::measure::build;
use crate::measure::report::RunReport;
use crate::run::covariance::CovarianceMode;
use crate::run::restarts;
use crate::run::runner;
use crate::run::sampled;
use crate::run::setup::{checked_pairs, EvalSetup, GlobalChecks};

/// Runs every variant of `setup` over every consecutive pair of `ds` and builds the report.
pub fn evaluate(
    ds: &Dataset,
    setup: &EvalSetup,
    progress: &ProgressBar,
) -> Result<RunReport, EvalError> {
    let (pairs, skipped) = checked_pairs(ds, setup)?;
    let close = setup.close_start_variants()?;
    let methods = setup.methods(&close);
    progress.set_length((methods.len() * pairs.len()) as u64);
    let plan = runner::RunPlan {
        chain: &setup.init,
        global: &setup.global,
        check: setup.global_check == GlobalChecks::On,
    };
    let mut runs = runner::run_all(ds, &pairs, methods, &plan, progress);
    if setup.covariance == CovarianceMode::Sampled {
        sampled::replace_covariances(ds, &pairs, &setup.variants, &mut runs);
    }
    if setup.covariance == CovarianceMode::Restarts {
        restarts::replace_covariances(ds, &pairs, &setup.variants, &mut runs);
    }
    progress.finish_and_clear();
    Ok(build::build(ds, &pairs, skipped, setup, &runs))
}
