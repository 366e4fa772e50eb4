//! `icp-eval gate`: a run's summary.json against a baseline.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::Args;
use eval::measure::gate::{gate, incompatibility, Tolerances};
use eval::measure::report::RunReport;
use eval::render::json::SUMMARY_FILE;
use eval::render::markdown::gate::outcome_md;

/// The name of a tolerance file beside its baseline.
pub(crate) const TOLERANCE_FILE: &str = "tolerance.json";

#[derive(Args)]
pub(crate) struct GateArgs {
    /// The baseline: a summary.json written by `icp-eval baseline` (e.g.
    /// reports/baseline/marina.json).
    #[arg(long, value_name = "FILE")]
    pub(crate) baseline: PathBuf,
    /// The current run's summary.json.
    #[arg(long, value_name = "FILE")]
    pub(crate) current: PathBuf,
    /// The tolerances (JSON). Without it, the gate uses the tolerance.json in the baseline's
    /// folder when there is one, else the built-in tolerances (the same as
    /// reports/baseline/tolerance.json).
    #[arg(long, value_name = "FILE")]
    pub(crate) tolerance: Option<PathBuf>,
}

/// Reads a run's summary.json.
pub(crate) fn read_report(path: &Path) -> Result<RunReport> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{} is not a summary.json of this schema", path.display()))
}

/// The tolerance file that goes with `baseline`: beside it.
pub(crate) fn tolerance_beside(baseline: &Path) -> PathBuf {
    baseline.with_file_name(TOLERANCE_FILE)
}

/// The tolerances the gate uses, and where they came from (said to the user).
fn tolerances(args: &GateArgs) -> Result<(Tolerances, String)> {
    let (path, whence) = match &args.tolerance {
        Some(path) => (path.clone(), "given"),
        None => {
            let beside = tolerance_beside(&args.baseline);
            if !beside.exists() {
                let builtin = Tolerances::builtin()
                    .map_err(anyhow::Error::msg)
                    .context("the built-in tolerance")?;
                return Ok((
                    builtin,
                    format!("built-in (no {TOLERANCE_FILE} beside the baseline)"),
                ));
            }
            (beside, "beside the baseline")
        }
    };
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let tolerances = Tolerances::parse(&text)
        .map_err(anyhow::Error::msg)
        .with_context(|| path.display().to_string())?;
    Ok((tolerances, format!("{} ({whence})", path.display())))
}

/// The command that makes a baseline of the current run (`--from` takes the run's directory
/// or its summary.json).
fn add_command(args: &GateArgs) -> String {
    let from = match (args.current.file_name(), args.current.parent()) {
        (Some(name), Some(dir)) if name == SUMMARY_FILE && !dir.as_os_str().is_empty() => dir,
        _ => &args.current,
    };
    format!(
        "icp-eval baseline --from {} --out {}",
        from.display(),
        args.baseline.display()
    )
}

pub(crate) fn gate_cmd(args: GateArgs) -> Result<ExitCode> {
    let baseline = read_report(&args.baseline)?;
    let current = read_report(&args.current)?;
    let (tolerances, whence) = tolerances(&args)?;
    if let Some(why) = incompatibility(&baseline, &current) {
        bail!(
            "{} and {} cannot be compared: {why}",
            args.baseline.display(),
            args.current.display()
        );
    }
    let outcome = gate(&baseline, &current, &tolerances);
    let name = &current.dataset.name;
    println!("{name}: tolerance {whence}");
    print!("{name}: {}", outcome_md(&outcome, &add_command(&args)));
    Ok(if outcome.passed() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}
