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
use crate::run::sequence;
use crate::run::setup::{checked_pairs, EvalSetup};

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
    let plan = setup.run_plan();
    let lag_pairs = lags::lag_pairs(&pairs, setup.lags)?;
    progress.inc_length((setup.variants.len() * lag_pairs.len()) as u64);
    let mut runs = runner::run_all(ds, &pairs, methods, &plan, progress);
    let mut lagged = lags::run(ds, lag_pairs, setup.lags, methods, &plan, progress);
    moving::apply(ds, &pairs, methods, &mut runs, lagged.as_mut(), &plan);
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
/// lags `lagged`, whose loops flag the inconsistent ones first), with the smoothed estimators
/// of `--sequence` (made here from the flagged registrations): what a single run and the
/// merge of a sharded one both make, once every registration is in.
pub fn report(
    ds: &Dataset,
    pairs: &[ScanPair],
    skipped: Vec<SkippedPair>,
    setup: &EvalSetup,
    mut runs: Runs,
    lagged: Option<&LagRuns>,
) -> RunReport {
    // The loops' flags (only ever on a registration nothing else flagged) join the others
    // before the records are made, and before the smoother leaves flagged ones out.
    let checked = lagged.map(|lagged| cycles::check(setup, &runs, lagged));
    if let Some(checked) = &checked {
        for (variant, flags) in runs.per_variant.iter_mut().zip(&checked.flags) {
            for (run, flag) in variant.iter_mut().zip(flags) {
                if let Some(flag) = flag {
                    run.status = flag.clone();
                }
            }
        }
    }
    let smoothed =
        (!setup.sequence.is_empty()).then(|| sequence::smooth(ds, pairs, setup, &runs, lagged));
    if let Some(s) = &smoothed {
        runs.per_variant.extend(s.runs.iter().cloned());
    }
    let mut report = build::build(ds, pairs, skipped, setup, &runs);
    let names: Vec<&str> = report.variants.iter().map(|v| v.name.as_str()).collect();
    report.drawn_scan = moving::drawn_scan(&names, pairs, &runs);
    if let Some(checked) = checked {
        for (v, summary) in report.variants.iter_mut().zip(checked.summaries) {
            v.cycles = Some(summary);
        }
        report.cycles = checked.records;
    }
    if let Some(s) = smoothed {
        report.sequence = s.summaries;
        report.sequence_scans = s.records;
    }
    report
}
