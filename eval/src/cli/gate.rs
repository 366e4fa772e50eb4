//! `icp-eval gate`: a run's summary.json against a baseline.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::Args;
use eval::measure::gate::{gate, incompatibility, Tolerances};
use eval::measure::report::RunReport;
use eval::render::markdown::gate::outcome_md;

#[derive(Args)]
pub(crate) struct GateArgs {
    /// The committed baseline summary.json.
    #[arg(long)]
    pub(crate) baseline: PathBuf,
    /// The current run's summary.json.
    #[arg(long)]
    pub(crate) current: PathBuf,
    /// Tolerances (JSON); default: reports/baseline/tolerance.json.
    #[arg(long, default_value = "reports/baseline/tolerance.json")]
    pub(crate) tolerance: PathBuf,
}

pub(crate) fn read_report(path: &Path) -> Result<RunReport> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{} is not a summary.json of this schema", path.display()))
}

pub(crate) fn gate_cmd(args: GateArgs) -> Result<ExitCode> {
    let baseline = read_report(&args.baseline)?;
    let current = read_report(&args.current)?;
    let text = std::fs::read_to_string(&args.tolerance)
        .with_context(|| format!("reading {}", args.tolerance.display()))?;
    let tolerances: Tolerances = serde_json::from_str(&text)
        .with_context(|| format!("{} is not a tolerance file", args.tolerance.display()))?;
    tolerances.validate().map_err(anyhow::Error::msg)?;
    if let Some(why) = incompatibility(&baseline, &current) {
        bail!(
            "{} and {} cannot be compared: {why}",
            args.baseline.display(),
            args.current.display()
        );
    }
    let outcome = gate(&baseline, &current, &tolerances);
    print!("{}: {}", current.dataset.name, outcome_md(&outcome));
    Ok(if outcome.regressions.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
