//! The files of the studies and of `compare`: `compare.md`/`.json`, `sweep.md`/`.json`,
//! `basin.csv`/`.md`/`.json` and `scaling.md`/`.json`, with their figures. Each writer returns
//! the Markdown it wrote, for the command to print; those of `compare` and `basin` also write
//! `report.html` with their results as its [`Section`]s.

use datasets::Dataset;

use crate::error::EvalError;
use crate::measure::basin::BasinReport;
use crate::measure::compare::{CompareOptions, PairedComparison};
use crate::measure::report::RunReport;
use crate::measure::scaling::ScalingResult;
use crate::measure::sweep::SweepResult;
use crate::render::figures::studies as figures;
use crate::render::html::{self, Section};
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

/// Writes `compare.md` and `compare.json` of the comparisons `rows` of `report`, with a
/// sweep's files when there is one, and `report.html` with the run and them; returns their
/// Markdown.
#[allow(clippy::too_many_arguments)]
pub fn write_comparison(
    dir: &mut OutputDir,
    ds: &Dataset,
    report: &RunReport,
    rows: &[PairedComparison],
    options: &CompareOptions,
    sweep: Option<&SweepResult>,
    plots: bool,
) -> Result<String, EvalError> {
    let md = compare::compare_md(report, rows, options);
    write_md_json(dir, "compare", &md, &comparison_json(rows, options))?;
    let mut sections = vec![section("Paired comparison", md, None)];
    if let Some(result) = sweep {
        let md = sweep::sweep_md(result);
        write_md_json(dir, "sweep", &md, result)?;
        let svg = plots
            .then(|| figures::write_sweep(dir, result))
            .transpose()?;
        sections.push(section("Parameter sweep", md, svg));
    }
    html::write(dir, ds, Some(report), plots, &sections)?;
    Ok(markdown_of(&sections))
}

/// Writes `basin.csv`, `.md` and `.json`, its figures when `plots`, and `report.html`;
/// returns its Markdown.
pub fn write_basin(
    dir: &mut OutputDir,
    ds: &Dataset,
    report: &BasinReport,
    plots: bool,
) -> Result<String, EvalError> {
    dir.write("basin.csv", &crate::render::csv::basin_csv(report)?)?;
    let md = basin::basin_md(report);
    write_md_json(dir, "basin", &md, report)?;
    let svg = plots
        .then(|| figures::write_basin(dir, report))
        .transpose()?;
    let sections = [section("Convergence basin", md, svg)];
    html::write(dir, ds, None, plots, &sections)?;
    Ok(markdown_of(&sections))
}

/// Writes `scaling.md`, `.json` and its figures; returns its Markdown.
pub fn write_scaling(dir: &mut OutputDir, result: &ScalingResult) -> Result<String, EvalError> {
    let md = scaling::scaling_md(result);
    write_md_json(dir, "scaling", &md, result)?;
    figures::write_scaling(dir, result)?;
    Ok(md)
}

/// `compare.json`: the options and every comparison.
pub fn comparison_json(rows: &[PairedComparison], options: &CompareOptions) -> serde_json::Value {
    serde_json::json!({ "options": options, "comparisons": rows })
}

fn section(title: &str, markdown: String, svg: Option<(String, String)>) -> Section {
    Section {
        title: title.to_owned(),
        markdown,
        svgs: svg.into_iter().collect(),
    }
}

fn markdown_of(sections: &[Section]) -> String {
    sections
        .iter()
        .map(|s| s.markdown.as_str())
        .collect::<Vec<_>>()
        .join("\n")
}
