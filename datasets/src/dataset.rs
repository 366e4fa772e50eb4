//! The one type every loader produces.

use std::path::PathBuf;

use icp_core::{BearingSense, Scan, SensorModel};
use serde::{Deserialize, Serialize};

/// A reference pose of the vessel at one scan, in a local level frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferencePose {
    /// First coordinate of the reference position, metres.
    pub x_m: f64,
    /// Second coordinate of the reference position, metres.
    pub y_m: f64,
    /// Heading as the source gives it, radians, growing in the dataset's
    /// `reference_heading_sense`.
    pub heading_rad: f64,
    /// Orientation of the scan frame in the `(x, y)` frame (radians, from `+x` towards `+y`),
    /// when the reference is a true 2D pose of the scanner; `None` when position and heading
    /// are not one rigid frame (the marina `slam_pose`: its positions do not turn with it).
    pub scan_yaw_rad: Option<f64>,
}

impl ReferencePose {
    /// The scanner pose `t_world_scan`, when the reference is a 2D pose of the scanner.
    pub fn scan_pose(&self) -> Option<nalgebra::Isometry2<f64>> {
        self.scan_yaw_rad
            .map(|yaw| nalgebra::Isometry2::new(nalgebra::Vector2::new(self.x_m, self.y_m), yaw))
    }
}

/// One input file and its checksum.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FileProvenance {
    /// Where it was read.
    pub path: PathBuf,
    /// SHA-256 of its bytes, hex.
    pub sha256: String,
    /// Whether the checksum equals the one pinned for this dataset (`None`: nothing pinned).
    pub matches_pinned: Option<bool>,
}

/// Where a dataset came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Short name, e.g. `marina`.
    pub name: String,
    /// Human description with the citation.
    pub description: String,
    /// The files read, if any.
    pub files: Vec<FileProvenance>,
}

/// A pair of consecutive scans to register: `source` (k) onto `reference` (k+1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScanPair {
    /// Index of scan k.
    pub source: usize,
    /// Index of scan k+1.
    pub reference: usize,
}

/// A consecutive pair that cannot be registered, with the reason.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SkippedPair {
    /// The pair.
    pub pair: ScanPair,
    /// Why it is skipped.
    pub reason: String,
}

/// Scans in order, with what is known about them.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// Where the data came from.
    pub provenance: Provenance,
    /// The scans, in acquisition order.
    pub scans: Vec<Scan>,
    /// Reference pose per scan, when the source has one.
    pub reference: Option<Vec<ReferencePose>>,
    /// Sense in which the reference heading grows, seen from above.
    pub reference_heading_sense: BearingSense,
    /// Nominal time between consecutive scans, seconds (used where scans carry no timestamps).
    pub dt_s: f64,
    /// The sensor's error model.
    pub sensor: SensorModel,
    /// Sense in which the scanner's bearings grow, seen from above.
    pub bearing_sense: BearingSense,
}

/// Fewest valid returns a scan needs to take part in a pair.
pub const MIN_RETURNS: usize = icp_core::scan::MIN_POINTS;

impl Dataset {
    /// Consecutive pairs `(k, k+1)`, and the ones skipped because a scan has fewer than
    /// [`MIN_RETURNS`] valid returns.
    pub fn consecutive_pairs(&self) -> (Vec<ScanPair>, Vec<SkippedPair>) {
        let mut pairs = Vec::new();
        let mut skipped = Vec::new();
        for k in 1..self.scans.len() {
            let pair = ScanPair {
                source: k - 1,
                reference: k,
            };
            let short: Vec<String> = [k - 1, k]
                .into_iter()
                .filter(|&i| self.scans[i].len() < MIN_RETURNS)
                .map(|i| {
                    format!(
                        "scan {i} has {} valid returns (< {MIN_RETURNS})",
                        self.scans[i].len()
                    )
                })
                .collect();
            if short.is_empty() {
                pairs.push(pair);
            } else {
                skipped.push(SkippedPair {
                    pair,
                    reason: short.join("; "),
                });
            }
        }
        (pairs, skipped)
    }

    /// Time between the two scans of a pair: from timestamps when both have one, else the
    /// nominal `dt_s` times the index difference.
    pub fn pair_dt_s(&self, pair: ScanPair) -> f64 {
        match (
            self.scans[pair.source].timestamp_s(),
            self.scans[pair.reference].timestamp_s(),
        ) {
            (Some(a), Some(b)) => b - a,
            _ => self.dt_s * (pair.reference - pair.source) as f64,
        }
    }
}
