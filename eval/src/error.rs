//! The harness's error type.

use std::path::PathBuf;

use datasets::DatasetError;
use icp_core::{ConfigError, IcpError};

use crate::run::estimates::EstimatesError;
use crate::run::init::InitError;

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
    Init(#[from] InitError),
    /// An external estimates file cannot be used.
    #[error(transparent)]
    Estimates(#[from] EstimatesError),
    /// `--lags` outside what the run can register.
    #[error("--lags {lags}: {why}")]
    Lags { lags: usize, why: String },
    /// The dataset has no pair of consecutive scans at all.
    #[error("{dataset} has {scans} scan(s): no pair of consecutive scans to register")]
    NothingToRegister { dataset: String, scans: usize },
}
