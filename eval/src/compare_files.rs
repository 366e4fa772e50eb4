//! The files of a comparison (`compare.md`, `compare.json`), written the same way by
//! `icp-eval compare` and by the Python package's `icp_bench.compare`.

use crate::compare::{compare, compare_md, CompareOptions};
use crate::{EvalError, OutputDir, RunReport};

/// Compares the variants of `report` with `options`, writes `compare.md` and `compare.json`
/// (`{"options", "comparisons"}`) into `dir`, and returns the table and the JSON value.
pub fn write_compare(
    dir: &mut OutputDir,
    report: &RunReport,
    options: &CompareOptions,
) -> Result<(String, serde_json::Value), EvalError> {
    let rows = compare(report, options);
    let md = compare_md(report, &rows, options);
    let json = serde_json::json!({ "options": options, "comparisons": rows });
    dir.write("compare.md", md.as_bytes())?;
    let text = serde_json::to_string_pretty(&json)
        .map_err(|e| EvalError::Serialize(e.to_string()))?
        + "\n";
    dir.write("compare.json", text.as_bytes())?;
    Ok((md, json))
}
