//! The evaluation harness behind `icp-eval`: runs variants over scan pairs in parallel and
//! reports like the paper (Table 1, Figs. 12–16) and better (robust statistics, reference
//! checks, pose errors, TUM trajectories).
//!
//! Flow: [`evaluate`] runs and builds a [`report::RunReport`]; [`write_outputs`] renders every
//! file from it.
#![forbid(unsafe_code)]

use std::path::PathBuf;

use datasets::{Dataset, DatasetError, ScanPair, SkippedPair};
use icp_core::{ConfigError, IcpError};
use indicatif::ProgressBar;

pub mod basin;
pub mod bound;
pub mod compare;
pub mod compare_files;
pub mod consistency;
pub mod estimates;
pub mod evo;
pub mod evo_zip;
pub mod gate;
pub mod init;
pub mod listing;
pub mod merge;
pub mod outcome;
pub mod outdir;
pub mod output;
pub mod plots;
pub mod published;
pub mod reference;
pub mod report;
pub mod run_options;
pub mod runner;
pub mod sampled;
pub mod scaling;
pub mod shard;
pub mod start_gate;
pub mod stats;
pub mod status;
pub mod sweep;
pub mod trajectory_metrics;

pub use outdir::OutputDir;
pub use reference::ReferenceChecks;
pub use report::{EvalSetup, GlobalChecks, OffsetChoice, RunReport};

/// Errors of the harness.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// A file could not be written or read.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// An output directory cannot be used.
    #[error("output directory {dir}: {why}")]
    OutputDir { dir: PathBuf, why: String },
    /// A report could not be serialized.
    #[error("serialization failed: {0}")]
    Serialize(String),
    /// A figure could not be drawn.
    #[error("figure {figure}: {what}")]
    Plot { figure: String, what: String },
    /// The data could not be loaded.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// A variant could not be built.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// A registration input was refused.
    #[error(transparent)]
    Icp(#[from] IcpError),
    /// Two variants of a run share a name (their files would collide).
    #[error("two variants are named {0}")]
    DuplicateName(String),
    /// An option outside its domain.
    #[error("invalid option {name} = {value}: {why}")]
    BadOption {
        name: &'static str,
        value: f64,
        why: &'static str,
    },
    /// A command that needs a reference that is a rigid 2D pose of the scanner.
    #[error("{what} needs a reference that is a rigid 2D pose of the scanner; {dataset} has none")]
    NeedsRigidReference { what: &'static str, dataset: String },
    /// The initial-guess option cannot be used on this dataset.
    #[error(transparent)]
    Init(#[from] init::InitError),
    /// An external estimates file cannot be used.
    #[error(transparent)]
    Estimates(#[from] estimates::EstimatesError),
    /// The dataset has no pair of consecutive scans at all.
    #[error("{dataset} has {scans} scan(s): no pair of consecutive scans to register")]
    NothingToRegister { dataset: String, scans: usize },
}

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
    if setup.covariance == consistency::CovarianceMode::Sampled {
        sampled::replace_covariances(ds, &pairs, &setup.variants, &mut runs);
    }
    progress.finish_and_clear();
    Ok(report::build(ds, &pairs, skipped, setup, &runs))
}

/// The consecutive pairs of `ds` (and those skipped) that `setup` registers, once `setup` is
/// checked against `ds`: what [`evaluate`] and a shard of a run (see [`shard`]) start from.
pub fn checked_pairs(
    ds: &Dataset,
    setup: &EvalSetup,
) -> Result<(Vec<ScanPair>, Vec<SkippedPair>), EvalError> {
    let (pairs, skipped) = ds.consecutive_pairs();
    if pairs.is_empty() && skipped.is_empty() {
        return Err(EvalError::NothingToRegister {
            dataset: ds.provenance.name.clone(),
            scans: ds.scans.len(),
        });
    }
    let names = setup.method_names();
    for (i, name) in names.iter().enumerate() {
        icp_core::variants::check_name(name)?;
        if names[..i].contains(name) {
            return Err(EvalError::DuplicateName((*name).to_owned()));
        }
    }
    setup.init.check(ds)?;
    Ok((pairs, skipped))
}

/// Writes `summary.json`, `pairs.csv`, `table.md`, `config.json`, one TUM trajectory per
/// variant, `reference.tum` and the evo result zips (`evo/`) where there is a reference, and
/// (unless `plots` is false) the figures into `out`.
pub fn write_outputs(
    out: &mut OutputDir,
    ds: &Dataset,
    report: &RunReport,
    plots: bool,
) -> Result<(), EvalError> {
    out.write("summary.json", output::summary_json(report)?.as_bytes())?;
    out.write("pairs.csv", &output::pairs_csv(report)?)?;
    out.write("table.md", output::table_md(report).as_bytes())?;
    let config = serde_json::to_string_pretty(&report.config)
        .map_err(|e| EvalError::Serialize(e.to_string()))?
        + "\n";
    out.write("config.json", config.as_bytes())?;
    for (i, v) in report.variants.iter().enumerate() {
        out.write(
            &format!("trajectory_{}.tum", v.name),
            output::tum(report, i).as_bytes(),
        )?;
    }
    if let Some(text) = output::reference_tum(report) {
        out.write("reference.tum", text.as_bytes())?;
    }
    write_evo_results(out, ds, report)?;
    if plots {
        plots::write_all(out, ds, report)?;
    }
    Ok(())
}

/// The per-pair errors as evo result zips, `evo/<variant>_<error>.zip` (see [`evo::results`]).
fn write_evo_results(
    out: &mut OutputDir,
    ds: &Dataset,
    report: &RunReport,
) -> Result<(), EvalError> {
    let results = evo::results(report, |k| report::scan_time_s(ds, k));
    if results.is_empty() {
        return Ok(());
    }
    let dir = out.dir().join("evo");
    std::fs::create_dir_all(&dir).map_err(|source| EvalError::Io { path: dir, source })?;
    for (name, result) in &results {
        if let Some(bytes) = evo_zip::result_zip(result)? {
            out.write(&format!("evo/{name}"), &bytes)?;
        }
    }
    Ok(())
}
