//! Scan logs in, one [`Dataset`] out: the eval and core crates never see file formats.
//!
//! Loaders: [`marina`] (the paper's public MATLAB files).
#![forbid(unsafe_code)]

pub mod carmen;
pub mod csvdir;
pub mod dataset;
pub mod error;
pub mod marina;
pub mod matv5;
pub mod synthetic;

pub use dataset::{Dataset, FileProvenance, Provenance, ReferencePose, ScanPair, SkippedPair};
pub use error::DatasetError;
