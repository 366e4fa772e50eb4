//! `summary.json` (the whole report but the per-pair records) and `config.json` (the
//! configuration that produced the run).

use crate::error::EvalError;
use crate::measure::report::RunReport;
use crate::render::outdir::OutputDir;

/// The name of a run's summary in its output directory.
pub const SUMMARY_FILE: &str = "summary.json";

/// Writes `summary.json` and `config.json`.
pub fn write(out: &mut OutputDir, report: &RunReport) -> Result<(), EvalError> {
    out.write(SUMMARY_FILE, summary_json(report)?.as_bytes())?;
    out.write("config.json", pretty(&report.config)?.as_bytes())
}

/// `value` as pretty JSON with a final newline.
pub fn pretty(value: &impl serde::Serialize) -> Result<String, EvalError> {
    let mut s =
        serde_json::to_string_pretty(value).map_err(|e| EvalError::Serialize(e.to_string()))?;
    s.push('\n');
    Ok(s)
}

/// `summary.json`.
pub fn summary_json(report: &RunReport) -> Result<String, EvalError> {
    pretty(report)
}
