//! Scan logs in, one [`Dataset`] out: the eval and core crates never see file formats.
//!
//! Loaders: [`marina`] (the paper's public MATLAB files), [`carmen`] (CARMEN `FLASER` logs),
//! [`csvdir`] (our CSV format), [`rosbag`] (ROS 2 bags, MCAP or sqlite3: `LaserScan` scans, a
//! reference from `Odometry`, `PoseStamped`, `PoseWithCovarianceStamped` or `NavSatFix`) and
//! [`synthetic`] (the simulated harbour). Each says what its reference is ([`ReferenceKind`]),
//! carries the odometry where the source has one, and lists what it noticed about the data
//! ([`LoadWarning`]).
//!
//! [`open`] loads any of them from one string, `kind[:target][?key=value&...]`
//! (`carmen:aces.log.gz?fov_deg=180`, `rosbag:run/?scan=/scan&reference=/odom`), through the
//! registry in [`source`], where each kind and its options are listed once.
#![forbid(unsafe_code)]

pub mod carmen;
pub mod csvdir;
pub mod dataset;
pub mod error;
pub mod marina;
pub mod matv5;
mod odom_lines;
pub mod rosbag;
pub mod source;
pub mod synthetic;

pub use dataset::{
    Dataset, FileProvenance, FirstScans, LoadWarning, Pose2, PoseChannel, Provenance,
    ReferenceKind, ReferencePose, ScanPair, SkippedPair,
};
pub use error::DatasetError;
pub use odom_lines::MAX_ODOM_GAP_S;
pub use source::{open, DatasetSource, SourceError};
