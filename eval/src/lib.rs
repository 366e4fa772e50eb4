//! The evaluation harness behind `icp-eval`: runs variants over scan pairs in parallel and
//! reports like the paper (Table 1, Figs. 12–16) and better (robust statistics, reference
//! checks, pose errors, TUM trajectories).
//!
//! Flow: [`evaluate`] runs and builds a [`report::RunReport`]; [`write_outputs`] renders every
//! file from it.
#![forbid(unsafe_code)]

use std::path::PathBuf;

use datasets::{Dataset, DatasetError};
use icp_core::{ConfigError, IcpError};
use indicatif::ProgressBar;

pub mod basin;
pub mod bound;
pub mod compare;
pub mod consistency;
pub mod gate;
pub mod init;
pub mod listing;
pub mod outcome;
pub mod outdir;
pub mod output;
pub mod plots;
pub mod published;
pub mod reference;
pub mod report;
pub mod runner;
pub mod sampled;
pub mod scaling;
pub mod stats;
pub mod status;
pub mod sweep;

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
    let (pairs, skipped) = ds.consecutive_pairs();
    if pairs.is_empty() && skipped.is_empty() {
        return Err(EvalError::NothingToRegister {
            dataset: ds.provenance.name.clone(),
            scans: ds.scans.len(),
        });
    }
    for (i, v) in setup.variants.iter().enumerate() {
        icp_core::variants::check_name(v.name())?;
        if setup.variants[..i].iter().any(|o| o.name() == v.name()) {
            return Err(EvalError::DuplicateName(v.name().to_owned()));
        }
    }
    setup.init.check(ds)?;
    progress.set_length((setup.variants.len() * pairs.len()) as u64);
    let plan = runner::RunPlan {
        chain: &setup.init,
        global: &setup.global,
        check: setup.global_check == GlobalChecks::On,
    };
    let mut runs = runner::run_all(ds, &pairs, &setup.variants, &plan, progress);
    if setup.covariance == consistency::CovarianceMode::Sampled {
        sampled::replace_covariances(ds, &pairs, &setup.variants, &mut runs);
    }
    progress.finish_and_clear();
    Ok(report::build(ds, &pairs, skipped, setup, &runs))
}

/// Writes `summary.json`, `pairs.csv`, `table.md`, `config.json`, one TUM trajectory per
/// variant and (unless `plots` is false) the figures into `out`.
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
    if plots {
        plots::write_all(out, ds, report)?;
    }
    Ok(())
}
