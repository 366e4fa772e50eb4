//! TUM poses (`timestamp x y z qx qy qz qw`), one per scan, matched to the scans by time.

use std::path::Path;

use nalgebra::{Isometry2, UnitComplex, Vector2};

use super::{content_lines, number, Read, MATCH_TOLERANCE_S, TILT_NOTE_DEG};
use crate::error::EstimatesError;

/// A unit quaternion's norm may be off by this much (rounded text) before it is refused.
const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

/// The TUM poses of `text`, one slot per scan of `scan_times_s` (`None`: no pose for that
/// scan). A pose belongs to the scan within [`MATCH_TOLERANCE_S`] of its time; a pose outside
/// the scans' time span is counted and left unused, one inside it near no scan is an error.
/// The yaw is kept; a tilt out of the plane beyond [`TILT_NOTE_DEG`] is counted.
pub fn per_scan_from_tum(
    text: &str,
    path: &Path,
    scan_times_s: &[f64],
) -> Result<Read, EstimatesError> {
    const FIELDS: [&str; 8] = ["timestamp", "x", "y", "z", "qx", "qy", "qz", "qw"];
    let bad = |line: usize, field: &'static str, why: String| EstimatesError::Bad {
        path: path.to_path_buf(),
        line,
        field,
        why,
    };
    // The scans by time, for a binary search per pose.
    let mut by_time: Vec<(f64, usize)> = scan_times_s.iter().copied().zip(0..).collect();
    by_time.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (first_s, last_s) = match (by_time.first(), by_time.last()) {
        (Some(a), Some(b)) => (a.0, b.0),
        _ => (f64::NAN, f64::NAN),
    };
    let mut read = Read {
        slots: vec![None; scan_times_s.len()],
        ..Read::default()
    };
    let mut seen = false;
    for (line, raw) in content_lines(text) {
        let cells: Vec<&str> = raw.split_whitespace().collect();
        if cells.len() != FIELDS.len() {
            let why = format!(
                "{} fields, a TUM line has 8 (timestamp x y z qx qy qz qw)",
                cells.len()
            );
            return Err(bad(line, "fields", why));
        }
        let mut v = [0.0; 8];
        for (k, cell) in cells.iter().enumerate() {
            v[k] = number(path, line, FIELDS[k], cell)?;
        }
        let [t_s, x, y, _z, qx, qy, qz, qw] = v;
        let norm = (qx * qx + qy * qy + qz * qz + qw * qw).sqrt();
        if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
            let why = format!("not a unit quaternion (norm {norm})");
            return Err(bad(line, "qx qy qz qw", why));
        }
        seen = true;
        // The nearest scan: the neighbours of the pose's place in time order.
        let at = by_time.partition_point(|(s, _)| *s < t_s);
        let nearest = [at.checked_sub(1), Some(at)]
            .into_iter()
            .flatten()
            .filter_map(|i| by_time.get(i))
            .min_by(|a, b| (a.0 - t_s).abs().total_cmp(&(b.0 - t_s).abs()));
        let Some(&(nearest_s, k)) = nearest.filter(|n| (n.0 - t_s).abs() <= MATCH_TOLERANCE_S)
        else {
            // NaN spans (a run without scans) hold nothing: every pose is outside.
            if !(t_s >= first_s - MATCH_TOLERANCE_S && t_s <= last_s + MATCH_TOLERANCE_S) {
                read.unused += 1;
                continue;
            }
            return Err(EstimatesError::NoScanAt {
                path: path.to_path_buf(),
                line,
                t_s,
                tol_s: MATCH_TOLERANCE_S,
                nearest_s: nearest.map_or(f64::NAN, |n| n.0),
            });
        };
        if read.slots[k].is_some() {
            return Err(EstimatesError::Duplicate {
                path: path.to_path_buf(),
                line,
                what: format!("scan {k} (t = {nearest_s} s)"),
            });
        }
        let (qx, qy, qz, qw) = (qx / norm, qy / norm, qz / norm, qw / norm);
        // The angle between the pose's z axis and the plane's normal (roll and pitch).
        let tilt_deg = (1.0 - 2.0 * (qx * qx + qy * qy))
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees();
        if tilt_deg > TILT_NOTE_DEG {
            read.tilted += 1;
        }
        read.max_tilt_deg = read.max_tilt_deg.max(tilt_deg);
        let yaw = (2.0 * (qw * qz + qx * qy)).atan2(1.0 - 2.0 * (qy * qy + qz * qz));
        read.slots[k] = Some(Isometry2::from_parts(
            Vector2::new(x, y).into(),
            UnitComplex::new(yaw),
        ));
    }
    if !seen {
        return Err(EstimatesError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(read)
}
