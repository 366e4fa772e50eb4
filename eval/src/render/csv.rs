//! `pairs.csv`: one row per variant and pair, the records as they are; `cycles.csv`: one row
//! per variant and loop across lags; `sequence.csv`: one row per smoothed estimator and scan.

use crate::error::EvalError;
use crate::measure::basin::BasinReport;
use crate::measure::report::RunReport;
use crate::render::outdir::OutputDir;

/// Writes `pairs.csv`, `cycles.csv` when the run registered across lags, and `sequence.csv`
/// when it smoothed.
pub fn write(out: &mut OutputDir, report: &RunReport) -> Result<(), EvalError> {
    out.write("pairs.csv", &pairs_csv(report)?)?;
    if !report.cycles.is_empty() {
        out.write("cycles.csv", &rows_csv(&report.cycles)?)?;
    }
    if !report.sequence_scans.is_empty() {
        out.write("sequence.csv", &rows_csv(&report.sequence_scans)?)?;
    }
    Ok(())
}

/// Serialises `rows` as CSV with a header from their field names.
pub fn rows_csv<T: serde::Serialize>(rows: &[T]) -> Result<Vec<u8>, EvalError> {
    let mut w = ::csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(r)
            .map_err(|e| EvalError::Serialize(e.to_string()))?;
    }
    w.into_inner()
        .map_err(|e| EvalError::Serialize(e.to_string()))
}

/// `pairs.csv`: one row per variant and pair.
pub fn pairs_csv(report: &RunReport) -> Result<Vec<u8>, EvalError> {
    rows_csv(&report.pairs)
}

/// `basin.csv`: one row per registration.
pub fn basin_csv(report: &BasinReport) -> Result<Vec<u8>, EvalError> {
    rows_csv(&report.rows)
}
