//! The pipeline of one run: run every method over every pair ([`crate::run`]), then measure
//! ([`crate::measure::build`]); `render::write_outputs` renders the files.

use datasets::{Dataset, ScanPair, SkippedPair};
use indicatif::ProgressBar;

use crate::error::EvalError;
use crate::measure::build;
use crate::measure::cycles;
use crate::measure::report::RunReport;
use crate::run::covariance::CovarianceMode;
use crate::run::lags::{self, LagRuns};
use crate::run::moving;
use crate::run::restarts;
use crate::run::runner::{self, Runs};
use crate::run::sampled;
use crate::run::setup::{checked_pairs, EvalSetup, GlobalChecks};

/// Runs every variant of `setup` over every consecutive pair of `ds` (and across lags, with
/// `setup.lags` above 1: their loops flag inconsistent registrations) and builds the report.
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
        ambiguity: setup.covariance.is_extended(),
    };
    let lag_pairs = lags::lag_pairs(&pairs, setup.lags)?;
    progress.inc_length((setup.variants.len() * lag_pairs.len()) as u64);
    let mut runs = runner::run_all(ds, &pairs, methods, &plan, progress);
    let mut lagged = lags::run(ds, lag_pairs, setup.lags, methods, &plan, progress);
    moving::apply(ds, &pairs, methods.registrars, &mut runs, lagged.as_mut());
    if setup.covariance == CovarianceMode::Sampled {
        sampled::replace_covariances(ds, &pairs, &setup.variants, &mut runs);
    }
    if setup.covariance == CovarianceMode::Restarts {
        restarts::replace_covariances(ds, &pairs, &setup.variants, &mut runs);
    }
    progress.finish_and_clear();
    Ok(report(ds, &pairs, skipped, setup, runs, lagged.as_ref()))
}

/// The report of a run's registrations `runs` of `pairs` (and, with `--lags`, those across
/// lags `lagged`, whose loops flag the inconsistent ones first): what a single run and the
/// merge of a sharded one both make, once every registration is in.
pub fn report(
    ds: &Dataset,
    pairs: &[ScanPair],
    skipped: Vec<SkippedPair>,
    setup: &EvalSetup,
    mut runs: Runs,
    lagged: Option<&LagRuns>,
) -> RunReport {
    let Some(lagged) = lagged else {
        return build::build(ds, pairs, skipped, setup, &runs);
    };
    // The loops' flags (only ever on a registration nothing else flagged) join the others
    // before the records are made.
    let checked = cycles::check(setup, &runs, lagged);
    for (variant, flags) in runs.per_variant.iter_mut().zip(&checked.flags) {
        for (run, flag) in variant.iter_mut().zip(flags) {
            if let Some(flag) = flag {
                run.status = flag.clone();
            }
        }
    }
    let mut report = build::build(ds, pairs, skipped, setup, &runs);
    for (v, summary) in report.variants.iter_mut().zip(checked.summaries) {
        v.cycles = Some(summary);
    }
    report.cycles = checked.records;
    report
}
