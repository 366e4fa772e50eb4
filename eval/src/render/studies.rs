//! The files of the studies and of `compare`: `compare.md`/`.json`, `sweep.md`/`.json`,
//! `basin.csv`/`.md`/`.json` and `scaling.md`/`.json`, with their figures. Each writer returns
//! the Markdown it wrote, for the command to print.

use crate::error::EvalError;
use crate::measure::basin::BasinReport;
use crate::measure::compare::{CompareOptions, PairedComparison};
use crate::measure::report::RunReport;
use crate::measure::scaling::ScalingResult;
use crate::measure::sweep::SweepResult;
use crate::render::figures::studies as figures;
use crate::render::json::pretty;
use crate::render::markdown::{basin, compare, scaling, sweep};
use crate::render::outdir::OutputDir;

/// Writes `<stem>.md` and `<stem>.json` (pretty, newline-terminated) into `dir`, atomically.
pub fn write_md_json(
    dir: &mut OutputDir,
    stem: &str,
    md: &str,
    value: &impl serde::Serialize,
) -> Result<(), EvalError> {
    dir.write(&format!("{stem}.md"), md.as_bytes())?;
    dir.write(&format!("{stem}.json"), pretty(value)?.as_bytes())
}

/// Writes `compare.md` and `compare.json` of the comparisons `rows` of `report`.
pub fn write_compare(
    dir: &mut OutputDir,
    report: &RunReport,
    rows: &[PairedComparison],
    options: &CompareOptions,
) -> Result<String, EvalError> {
    let md = compare::compare_md(report, rows, options);
    let json = serde_json::json!({ "options": options, "comparisons": rows });
    write_md_json(dir, "compare", &md, &json)?;
    Ok(md)
}

/// Writes `sweep.md` and `sweep.json` (and the sweep's figures when `plots`).
pub fn write_sweep(
    dir: &mut OutputDir,
    result: &SweepResult,
    plots: bool,
) -> Result<String, EvalError> {
    let md = sweep::sweep_md(result);
    write_md_json(dir, "sweep", &md, result)?;
    if plots {
        figures::write_sweep(dir, result)?;
    }
    Ok(md)
}

/// Writes `basin.csv`, `.md` and `.json` (and its figures when `plots`).
pub fn write_basin(
    dir: &mut OutputDir,
    report: &BasinReport,
    plots: bool,
) -> Result<String, EvalError> {
    dir.write("basin.csv", &crate::render::csv::basin_csv(report)?)?;
    let md = basin::basin_md(report);
    write_md_json(dir, "basin", &md, report)?;
    if plots {
        figures::write_basin(dir, report)?;
    }
    Ok(md)
}

/// Writes `scaling.md`, `.json` and its figures.
pub fn write_scaling(dir: &mut OutputDir, result: &ScalingResult) -> Result<String, EvalError> {
    let md = scaling::scaling_md(result);
    write_md_json(dir, "scaling", &md, result)?;
    figures::write_scaling(dir, result)?;
    Ok(md)
}
