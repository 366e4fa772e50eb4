//! Typed loader errors: each names the file and what is wrong with it.

use std::path::PathBuf;

use icp_core::IcpError;

/// Errors of the dataset loaders.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file is not a MATLAB v5 file the reader understands (truncated, wrong magic, ...).
    #[error("{path} is not a readable MATLAB v5 file: {reason}")]
    MatParse { path: PathBuf, reason: String },
    /// A variable the loader needs is absent.
    #[error("{path} has no variable {name:?} (found: {found:?})")]
    MissingVariable {
        path: PathBuf,
        name: String,
        found: Vec<String>,
    },
    /// A variable holds something other than real double-precision numbers.
    #[error("variable {name:?} in {path} is not a real double matrix")]
    NotRealDouble { path: PathBuf, name: String },
    /// A variable or a field has the wrong shape.
    #[error("{name:?} in {path} has shape {got:?}, expected {expected}")]
    Shape {
        path: PathBuf,
        name: String,
        expected: String,
        got: Vec<usize>,
    },
    /// A file with one row per scan whose row count is not the scan count (a CSV dataset's
    /// `poses.csv` or `odometry.csv` against its `scans.csv`).
    #[error(
        "{path} has {rows} {what} rows but {scans_path} has {scans} scans: one {what} row per scan"
    )]
    RowsPerScan {
        path: PathBuf,
        /// What a row holds (`pose`, `odometry pose`).
        what: &'static str,
        rows: usize,
        scans_path: PathBuf,
        scans: usize,
    },
    /// A line of a text log that cannot be read.
    #[error("{path}:{line}: {what}")]
    Parse {
        path: PathBuf,
        line: usize,
        what: String,
    },
    /// A value that is not usable data (non-finite pose, negative range, ...).
    #[error("{path}: {what}")]
    BadValue { path: PathBuf, what: String },
    /// A scan failed validation.
    #[error("{path}: scan {scan}: {source}")]
    Scan {
        path: PathBuf,
        scan: usize,
        #[source]
        source: IcpError,
    },
    /// The data directory was not found.
    #[error("the {dataset} data was not found; looked in:\n{}\n{hint}", looked.iter().map(|p| format!("  - {}", p.display())).collect::<Vec<_>>().join("\n"))]
    NotFound {
        dataset: &'static str,
        looked: Vec<PathBuf>,
        hint: String,
    },
    /// A bag's storage file cannot be read (not MCAP or sqlite3, truncated, damaged).
    #[error("{path}: {what}")]
    BagStorage { path: PathBuf, what: String },
    /// A bag lacks the topic asked for, or has several where one is needed.
    #[error("{path}: {what}")]
    BagTopic { path: PathBuf, what: String },
    /// A bag message that does not decode as its topic's type.
    #[error("{path}: message {index} of topic {topic}: {source}")]
    BagMessage {
        path: PathBuf,
        topic: String,
        index: usize,
        #[source]
        source: crate::rosbag::cdr::CdrError,
    },
    /// A bag's static transforms that give no usable scanner offset: a transform that is not
    /// rigid, or a scanner tilted out of the body's plane.
    #[error("{path}: {topic}: {source}; ?tf=off takes the reference as the scanner's pose")]
    BagTf {
        path: PathBuf,
        topic: String,
        #[source]
        source: Box<crate::rosbag::tf::TfError>,
    },
    /// Boats for the rough harbour that cannot be used.
    #[error(transparent)]
    Boats(#[from] crate::synthetic::BoatsError),
    /// A `--dataset` string that does not name a loadable dataset.
    #[error(transparent)]
    Source(#[from] crate::source::SourceError),
    /// A parameter of the loader is out of range.
    #[error("invalid loader parameter {name} = {value}: {reason}")]
    InvalidParameter {
        name: &'static str,
        value: f64,
        reason: &'static str,
    },
}

impl DatasetError {
    /// `Err` naming the sensor model a loader was given when it is not usable.
    pub(crate) fn check_sensor(sensor: &icp_core::SensorModel) -> Result<(), Self> {
        sensor.validate().map_err(|e| Self::BadValue {
            path: PathBuf::from("<sensor model>"),
            what: e.to_string(),
        })
    }
}
