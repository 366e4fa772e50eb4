//! Per-pair motions, `source,reference,tx_m,ty_m,theta_deg` (`t_ref_src`, as in pairs.csv).

use std::collections::HashMap;
use std::path::Path;

use datasets::ScanPair;
use nalgebra::{Isometry2, Vector2};

use super::{content_lines, number, Read, PAIR_CSV_HEADER};
use crate::error::EstimatesError;

/// The per-pair motions of a CSV with the header [`PAIR_CSV_HEADER`], one slot per pair of
/// `pairs`; a row of a pair the run does not register is counted and left unused, a row
/// naming a scan at or beyond `scans` (the dataset's count) is an error.
pub fn per_pair_from_csv(
    text: &str,
    path: &Path,
    pairs: &[ScanPair],
    scans: usize,
) -> Result<Read, EstimatesError> {
    const FIELDS: [&str; 5] = ["source", "reference", "tx_m", "ty_m", "theta_deg"];
    let bad = |line: usize, field: &'static str, why: String| EstimatesError::Bad {
        path: path.to_path_buf(),
        line,
        field,
        why,
    };
    let slot_of: HashMap<(usize, usize), usize> = pairs
        .iter()
        .map(|p| (p.source, p.reference))
        .zip(0..)
        .collect();
    let mut read = Read {
        slots: vec![None; pairs.len()],
        ..Read::default()
    };
    let mut header = true;
    for (line, raw) in content_lines(text) {
        let cells: Vec<&str> = raw.split(',').map(str::trim).collect();
        if header {
            if cells != FIELDS {
                let why = format!("{raw:?}, expected {PAIR_CSV_HEADER:?}");
                return Err(bad(line, "header", why));
            }
            header = false;
            continue;
        }
        if cells.len() != FIELDS.len() {
            let why = format!("{} cells, expected 5 ({PAIR_CSV_HEADER})", cells.len());
            return Err(bad(line, "fields", why));
        }
        let index = |k: usize| -> Result<usize, EstimatesError> {
            let scan: usize = cells[k].parse().map_err(|_| {
                bad(
                    line,
                    FIELDS[k],
                    format!("{:?} is not a scan index", cells[k]),
                )
            })?;
            if scan >= scans {
                let why = format!(
                    "scan {scan}, but the dataset has {scans} scans (0 to {}): is the file 1-based, or of another log?",
                    scans.saturating_sub(1)
                );
                return Err(bad(line, FIELDS[k], why));
            }
            Ok(scan)
        };
        let pair = ScanPair {
            source: index(0)?,
            reference: index(1)?,
        };
        let tx = number(path, line, FIELDS[2], cells[2])?;
        let ty = number(path, line, FIELDS[3], cells[3])?;
        let theta = number(path, line, FIELDS[4], cells[4])?;
        // A row of a pair the run does not register (not consecutive, or skipped) is left
        // unused, and counted.
        let Some(&slot) = slot_of.get(&(pair.source, pair.reference)) else {
            read.unused += 1;
            continue;
        };
        if read.slots[slot].is_some() {
            return Err(EstimatesError::Duplicate {
                path: path.to_path_buf(),
                line,
                what: format!("pair {} → {}", pair.source, pair.reference),
            });
        }
        read.slots[slot] = Some(Isometry2::new(Vector2::new(tx, ty), theta.to_radians()));
    }
    if header {
        return Err(EstimatesError::Empty {
            path: path.to_path_buf(),
        });
    }
    Ok(read)
}
