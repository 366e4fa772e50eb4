//! The harness's error types: [`EvalError`], and the errors of the run's inputs it wraps
//! (defined here, at the bottom, so that every import points down).

use std::path::PathBuf;

use datasets::DatasetError;
use icp_core::{ConfigError, IcpError};

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
    /// An option that does nothing on this dataset.
    #[error("{option} does not apply to {dataset}: {why}")]
    NotApplicable {
        option: &'static str,
        dataset: String,
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

/// Why an initial-guess option (`--init`, see `run::init`) cannot be used; a mode is
/// named as on the command line.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum InitError {
    /// A mode name that is not registered.
    #[error(
        "unknown init mode {got:?}: expected one of {known}, or a comma-separated chain of them"
    )]
    Unknown { got: String, known: String },
    /// An empty option or chain element.
    #[error("empty init mode in {0:?}")]
    Empty(String),
    /// The same mode twice in a chain: the second try would repeat the first.
    #[error("init mode {0} appears twice in the chain")]
    Repeated(&'static str),
    /// The dataset cannot give what a mode needs.
    #[error("--init {mode} cannot be used on {dataset}: {why}")]
    Unavailable {
        mode: &'static str,
        dataset: String,
        why: &'static str,
    },
}

/// Why an external estimates file (`--estimates`, see `run::estimates`) cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum EstimatesError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A line or field is not what the format says.
    #[error("{path}, line {line}, {field}: {why}")]
    Bad {
        path: PathBuf,
        line: usize,
        field: &'static str,
        why: String,
    },
    /// The file holds no estimate for any pair of the run.
    #[error("{path}: no estimates for the pairs of this run (TUM poses outside the run's time span are left unused)")]
    Empty { path: PathBuf },
    /// A TUM pose is near no scan of the run.
    #[error("{path}, line {line}: the pose at t = {t_s} s is within {tol_s} s of no scan (nearest: {nearest_s} s); is the file of this run?")]
    NoScanAt {
        path: PathBuf,
        line: usize,
        t_s: f64,
        tol_s: f64,
        nearest_s: f64,
    },
    /// Two estimates for the same scan or pair.
    #[error("{path}, line {line}: a second estimate for {what}")]
    Duplicate {
        path: PathBuf,
        line: usize,
        what: String,
    },
    /// The argument is not `NAME=FILE`.
    #[error("--estimates {0:?}: expected NAME=FILE")]
    Spec(String),
    /// The file is not the one the run was planned with (a shard or a merge reads another).
    #[error("{path}: SHA-256 {got}, but the run was planned with {expected}: the file changed")]
    Changed {
        path: PathBuf,
        expected: String,
        got: String,
    },
}
