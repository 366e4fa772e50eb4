//! External estimates (issue 15, "external estimators on the same pairs"): another tool's
//! motions read from a file and turned into one `t_ref_src` per pair of the run, so that they
//! can be evaluated like a built-in variant. Two formats, told apart by the first line:
//!
//! - TUM poses, `timestamp x y z qx qy qz qw` per line (`#` comments allowed), one pose per
//!   scan: each pose belongs to the scan whose time (its timestamp, else `k · dt_s`, the clock
//!   of our own TUM files) is within [`MATCH_TOLERANCE_S`]. A pose outside the run's time span
//!   is left unused and counted (a trajectory of the whole log, the run on part of it); one
//!   inside it and near no scan is an error (another clock, or the file of another run). A pair's motion is `t_ref_src = pose_ref⁻¹ · pose_src`, and
//!   a pair with a scan the file has no pose for has no estimate (a failure of the estimator).
//! - A CSV of per-pair motions with the header `source,reference,tx_m,ty_m,theta_deg`
//!   (`t_ref_src`, as in pairs.csv): a pair without a row has no estimate, a row of a pair
//!   the run does not register is counted and left unused, a row naming a scan the dataset
//!   does not have is an error (a 1-based file, or another log's).
//!
//! A file whose first line holds a comma is the CSV (its header checked), any other TUM.
//! Readers: `tum` and `pair_csv`.
//!
//! `icp-eval run` and `compare` take `--estimates NAME=FILE` ([`EstimatesSpec`]); the runner
//! assesses each estimate at its pose like a registration ([`icp_core::assess()`]: the same
//! overlap, conditioning and global checks flag it), and the report treats the estimator as
//! one more variant: the same pairs, statistics, figures, `compare` verdicts and gate. It has
//! no iterations, timing or covariance (empty cells, `null` in summary.json), and the file's
//! SHA-256 is in `config.estimates`.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use nalgebra::Isometry2;

use datasets::ScanPair;

use crate::error::EstimatesError;

mod pair_csv;
mod tum;

pub use pair_csv::per_pair_from_csv;
pub use tum::per_scan_from_tum;

/// A TUM pose belongs to a scan when their times differ by at most this, s: far above the
/// rounding of TUM files (1 µs at 6 decimals), far below any scan spacing (25 ms at 40 Hz).
pub const MATCH_TOLERANCE_S: f64 = 1e-3;

/// The CSV header of per-pair motions.
pub const PAIR_CSV_HEADER: &str = "source,reference,tx_m,ty_m,theta_deg";

/// A TUM pose tilted more than this out of the plane (roll and pitch, dropped: the run is
/// planar) is counted in [`ExternalSource::tilted_poses`], degrees: far above the tilt a
/// planar estimator's rounding leaves, below any real tilt of a 3D estimator gone wrong.
pub const TILT_NOTE_DEG: f64 = 1.0;

/// One `t_ref_src` (or pose) per slot (pair or scan), `None` where the file has none.
pub type Slots = Vec<Option<Isometry2<f64>>>;

/// Which of the two formats a file is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EstimatesFormat {
    /// TUM poses, one per scan.
    Tum,
    /// A CSV of per-pair motions ([`PAIR_CSV_HEADER`]).
    PairCsv,
}

impl std::fmt::Display for EstimatesFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Tum => "TUM poses per scan",
            Self::PairCsv => "per-pair motions CSV",
        })
    }
}

/// What the reports say about an external estimator (`config.estimates`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ExternalSource {
    /// Its name (the variant name in the reports).
    pub name: String,
    /// The file, as given.
    pub path: PathBuf,
    /// The file's SHA-256, hex.
    pub sha256: String,
    /// Its format.
    pub format: EstimatesFormat,
    /// Pairs of the run the file has an estimate for (the others are failures of the
    /// estimator).
    pub pairs_estimated: usize,
    /// Estimates in the file for no pair of the run, left unused: TUM poses outside the run's
    /// time span, CSV rows of pairs the run does not register.
    #[serde(default)]
    pub unused: usize,
    /// TUM poses tilted more than [`TILT_NOTE_DEG`] out of the plane (their roll and pitch
    /// dropped), and the largest tilt, degrees (0 for a CSV).
    #[serde(default)]
    pub tilted_poses: usize,
    /// The largest tilt of a pose out of the plane, degrees.
    #[serde(default)]
    pub max_tilt_deg: f64,
}

/// What a reader found: one slot per scan (TUM) or pair (CSV), and what it left aside.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Read {
    /// The estimates.
    pub slots: Slots,
    /// Estimates for no scan or pair of the run, left unused.
    pub unused: usize,
    /// Poses tilted more than [`TILT_NOTE_DEG`] out of the plane.
    pub tilted: usize,
    /// The largest tilt, degrees.
    pub max_tilt_deg: f64,
}

/// One external estimator's motions on the pairs of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct ExternalEstimates {
    /// Where they come from.
    pub source: ExternalSource,
    /// Per pair of the run, `t_ref_src`, or `None` where the file has none.
    pub per_pair: Slots,
}

/// An `--estimates NAME=FILE` as a run (and a sharded run's plan) records it: with the file's
/// SHA-256 taken when the option is read, so that a shard or a merge that would read another
/// file is refused ([`EstimatesError::Changed`]).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct EstimatesSpec {
    /// The estimator's name.
    pub name: String,
    /// The file.
    pub path: PathBuf,
    /// Its SHA-256, hex.
    pub sha256: String,
}

impl FromStr for EstimatesSpec {
    type Err = EstimatesError;
    /// `NAME=FILE`, the file read for its hash.
    fn from_str(spec: &str) -> Result<Self, EstimatesError> {
        let (name, path) = parse_spec(spec)?;
        let sha256 = datasets::FileProvenance::of(path.clone(), &read_file(&path)?).sha256;
        Ok(Self { name, path, sha256 })
    }
}

impl EstimatesSpec {
    /// The estimates on `pairs` of `ds`, from the file this spec was made from.
    pub fn load(
        &self,
        ds: &datasets::Dataset,
        pairs: &[ScanPair],
    ) -> Result<ExternalEstimates, EstimatesError> {
        let times: Vec<f64> = (0..ds.scans.len())
            .map(|k| crate::data::scan_time_s(ds, k))
            .collect();
        let e = load(&self.name, &self.path, &times, pairs)?;
        if e.source.sha256 != self.sha256 {
            return Err(EstimatesError::Changed {
                path: self.path.clone(),
                expected: self.sha256.clone(),
                got: e.source.sha256,
            });
        }
        Ok(e)
    }
}

fn read_file(path: &Path) -> Result<Vec<u8>, EstimatesError> {
    std::fs::read(path).map_err(|source| EstimatesError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// `NAME=FILE`.
pub fn parse_spec(spec: &str) -> Result<(String, PathBuf), EstimatesError> {
    match spec.split_once('=') {
        Some((name, file)) if !name.is_empty() && !file.is_empty() => {
            Ok((name.to_owned(), PathBuf::from(file)))
        }
        _ => Err(EstimatesError::Spec(spec.to_owned())),
    }
}

/// Reads `path` and gives the motion of each of `pairs`; `scan_times_s[k]` is scan k's time.
pub fn load(
    name: &str,
    path: &Path,
    scan_times_s: &[f64],
    pairs: &[ScanPair],
) -> Result<ExternalEstimates, EstimatesError> {
    let bytes = read_file(path)?;
    let sha256 = datasets::FileProvenance::of(path.to_path_buf(), &bytes).sha256;
    let text = String::from_utf8_lossy(&bytes);
    let first = content_lines(&text).next().map(|(_, l)| l);
    let format = if first.is_some_and(|l| l.contains(',')) {
        EstimatesFormat::PairCsv
    } else {
        EstimatesFormat::Tum
    };
    let read = match format {
        EstimatesFormat::PairCsv => per_pair_from_csv(&text, path, pairs, scan_times_s.len())?,
        EstimatesFormat::Tum => {
            let poses = per_scan_from_tum(&text, path, scan_times_s)?;
            Read {
                slots: pairs
                    .iter()
                    .map(|p| Some(poses.slots[p.reference]?.inverse() * poses.slots[p.source]?))
                    .collect(),
                ..poses
            }
        }
    };
    let per_pair = read.slots;
    if per_pair.iter().all(Option::is_none) {
        return Err(EstimatesError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(ExternalEstimates {
        source: ExternalSource {
            name: name.to_owned(),
            path: path.to_path_buf(),
            sha256,
            format,
            pairs_estimated: per_pair.iter().flatten().count(),
            unused: read.unused,
            tilted_poses: read.tilted,
            max_tilt_deg: read.max_tilt_deg,
        },
        per_pair,
    })
}

/// The finite number in `text`, or why not (naming the file, line and field).
fn number(
    path: &Path,
    line: usize,
    field: &'static str,
    text: &str,
) -> Result<f64, EstimatesError> {
    let bad = |why: String| EstimatesError::Bad {
        path: path.to_path_buf(),
        line,
        field,
        why,
    };
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| bad(format!("{text:?} is not a number")))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(bad(format!("{text:?} is not finite")))
    }
}

/// The lines of `text` that are neither blank nor `#` comments, trimmed, with their 1-based
/// line numbers.
fn content_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

#[cfg(test)]
mod tests {
    use nalgebra::UnitComplex;
    use proptest::prelude::*;

    use super::*;

    /// Text made of the pieces both formats are made of, and of the pieces that break them.
    fn messy_text() -> impl Strategy<Value = String> {
        let piece = prop_oneof![
            Just("source,reference,tx_m,ty_m,theta_deg".to_owned()),
            Just("#".to_owned()),
            Just(",".to_owned()),
            Just(" ".to_owned()),
            Just("\n".to_owned()),
            Just("NaN".to_owned()),
            Just("-inf".to_owned()),
            Just("1e308".to_owned()),
            Just("\u{feff}".to_owned()),
            (0usize..6).prop_map(|k| k.to_string()),
            (-10.0f64..10.0).prop_map(|v| v.to_string()),
            "[ -~]{0,6}",
        ];
        prop::collection::vec(piece, 0..60).prop_map(|v| v.concat())
    }

    fn pairs() -> Vec<ScanPair> {
        (0..5)
            .map(|k| ScanPair {
                source: k,
                reference: k + 1,
            })
            .collect()
    }

    proptest! {
        /// Whatever the text, each reader gives estimates or a typed error, never a panic,
        /// and an estimate is always a finite pose.
        #[test]
        fn any_text_gives_estimates_or_a_typed_error(text in messy_text()) {
            let path = Path::new("fuzzed.txt");
            let times: Vec<f64> = (0..6).map(|k| k as f64 * 0.2).collect();
            let read = [
                per_scan_from_tum(&text, path, &times),
                per_pair_from_csv(&text, path, &pairs(), 6),
            ];
            for p in read.into_iter().flatten().flat_map(|r| r.slots).flatten() {
                prop_assert!(p.translation.vector.iter().all(|v| v.is_finite()));
                prop_assert!(p.rotation.angle().is_finite());
            }
        }

        /// Poses written as TUM lines (yaw as a z-axis quaternion, 12 decimals) at jittered
        /// scan times read back to the same poses, each on its own scan.
        #[test]
        fn tum_lines_read_back_to_their_poses(
            poses in prop::collection::vec((-50.0f64..50.0, -50.0f64..50.0, -3.1f64..3.1), 6),
            jitter_s in prop::collection::vec(-9e-4f64..9e-4, 6),
        ) {
            let times: Vec<f64> = (0..6).map(|k| 100.0 + k as f64 * 0.1).collect();
            let text: String = poses
                .iter()
                .zip(&times)
                .zip(&jitter_s)
                .map(|((&(x, y, yaw), t), j)| {
                    let (s, c) = (0.5 * yaw).sin_cos();
                    format!("{:.6} {x:.12} {y:.12} 0 0 0 {s:.12} {c:.12}\n", t + j)
                })
                .collect();
            let read = per_scan_from_tum(&text, Path::new("p.tum"), &times).unwrap();
            prop_assert_eq!((read.unused, read.tilted), (0, 0));
            for (got, &(x, y, yaw)) in read.slots.iter().zip(&poses) {
                let got = got.unwrap();
                prop_assert!((got.translation.x - x).abs() < 1e-9);
                prop_assert!((got.translation.y - y).abs() < 1e-9);
                prop_assert!(got.rotation.angle_to(&UnitComplex::new(yaw)).abs() < 1e-9);
            }
        }
    }
}
