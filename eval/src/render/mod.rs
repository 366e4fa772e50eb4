//! Render: every output file of a run, each format in its own file and each read from the
//! [`RunReport`] (none computes a statistic). A new format is one file and one line in
//! [`write_outputs`].

use datasets::Dataset;

use crate::error::EvalError;
use crate::measure::report::RunReport;
use crate::render::outdir::OutputDir;

pub mod csv;
pub mod evo;
pub mod evo_zip;
pub mod figures;
pub mod html;
pub mod json;
pub mod markdown;
pub mod nmea;
pub mod outdir;
pub mod published;
pub mod studies;
pub mod tum;

/// Writes every output of a run into `out`: `summary.json` and `config.json`, `pairs.csv`,
/// `sequence.csv` and `V+causal.nmea` when it smoothed, `table.md`, one TUM trajectory per
/// variant and `reference.tum`, the evo result zips (`evo/`) where there is a reference, the
/// figures (unless `plots` is false) and `report.html`.
pub fn write_outputs(
    out: &mut OutputDir,
    ds: &Dataset,
    report: &RunReport,
    plots: bool,
) -> Result<(), EvalError> {
    json::write(out, report)?;
    csv::write(out, report)?;
    nmea::write(out, report)?;
    markdown::write(out, report)?;
    tum::write(out, report)?;
    evo::write_evo_results(out, ds, report)?;
    if plots {
        figures::run::write_all(out, ds, report)?;
    }
    html::write(out, ds, Some(report), plots, &[])
}
