//! Scan logs in, one [`Dataset`] out: the eval and core crates never see file formats.
//!
//! Loaders: [`marina`] (the paper's public MATLAB files), [`carmen`] (CARMEN `FLASER` logs),
//! [`csvdir`] (our CSV format) and [`synthetic`] (the simulated harbour). Each says what its
//! reference is ([`ReferenceKind`]), carries the odometry where the source has one, and lists
//! what it noticed about the data ([`LoadWarning`]).
#![forbid(unsafe_code)]

pub mod carmen;
pub mod csvdir;
pub mod dataset;
pub mod error;
pub mod marina;
pub mod matv5;
pub mod rosbag;
pub mod source;
pub mod synthetic;

pub use dataset::{
    Dataset, FileProvenance, LoadWarning, Pose2, PoseChannel, Provenance, ReferenceKind,
    ReferencePose, ScanPair, SkippedPair,
};
pub use error::DatasetError;
pub use source::{open, DatasetSource, SourceError};
