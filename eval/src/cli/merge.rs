//! `icp-eval merge`: the part files of a sharded run, rendered as a single run renders its own.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use eval::measure::basin::report as basin_report;
use eval::measure::compare::compare;
use eval::measure::report::RunReport;
use eval::measure::sweep::{points_of, SweepResult};
use eval::pipeline::report;
use eval::render::markdown::table_md;
use eval::render::outdir::OutputDir;
use eval::render::studies::{write_basin, write_comparison};
use eval::render::write_outputs;
use eval::run::lags::lag_pairs;
use eval::run::setup::checked_pairs;
use eval::shard::merge::{check_lag_shape, check_shape, merge, MergedRun};
use eval::shard::DatasetIdentity;
use eval::shard::Work;
use eval::studies::basin::chosen_pairs;

use crate::cli::basin::BasinArgs;
use crate::cli::common::Common;
use crate::cli::compare::CompareArgs;
use crate::cli::data::load_dataset;
use crate::cli::run::RunArgs;

/// The command line of a shard (recorded in its part file), re-read for its dataset options.
#[derive(Parser)]
struct ShardCommandLine {
    #[command(subcommand)]
    command: ShardCommand,
}

/// The commands that shard.
#[derive(Subcommand)]
enum ShardCommand {
    Run(RunArgs),
    Compare(CompareArgs),
    Basin(BasinArgs),
}

#[derive(Args)]
pub(crate) struct MergeArgs {
    /// The shards' part files, or their --out directories (one part each).
    #[arg(required = true)]
    pub(crate) parts: Vec<PathBuf>,
    /// Output directory of the merged run.
    #[arg(long)]
    pub(crate) out: PathBuf,
    #[command(flatten)]
    pub(crate) common: Common,
}

/// `icp-eval merge`: the parts' results, rendered as a single run renders its own.
pub(crate) fn merge_cmd(args: MergeArgs) -> Result<ExitCode> {
    let merged = merge(&args.parts)?;
    let plan = &merged.plan;
    // The dataset is re-loaded from the shard's own options, and checked against the plan.
    let data = match ShardCommandLine::try_parse_from(&merged.command_line)
        .map(|line| line.command)
        .context("re-reading the command line of shard 0 (a run, compare or basin)")?
    {
        ShardCommand::Run(a) => a.data,
        ShardCommand::Compare(a) => a.run.data,
        ShardCommand::Basin(a) => a.data,
    };
    let ds = load_dataset(&data).context("re-loading the dataset of the sharded run")?;
    let identity = DatasetIdentity::of(&ds);
    if identity != plan.dataset {
        bail!(
            "the dataset re-loaded for the merge ({}, {} scans, content {}) is not the one the shards ran ({}, {} scans, content {}): run the merge where the shards' dataset paths lead to the same files",
            identity.name,
            identity.scans,
            identity.content_sha256,
            plan.dataset.name,
            plan.dataset.scans,
            plan.dataset.content_sha256
        );
    }
    let setups = plan.setups(&ds)?;
    let mut dir =
        OutputDir::open(&args.out, args.common.force).context("opening the output directory")?;
    let plots = !args.common.no_plots;
    if merged.runs.len() != setups.len() {
        bail!(
            "the parts hold {} runs, their plan {}",
            merged.runs.len(),
            setups.len()
        );
    }
    let report_of = |i: usize| -> Result<RunReport> {
        let MergedRun::Runs { runs, lagged } = &merged.runs[i] else {
            bail!("run {i} of the plan holds basin rows");
        };
        let setup = &setups[i];
        let (pairs, skipped) = checked_pairs(&ds, setup)?;
        let lag_pairs = lag_pairs(&pairs, setup.lags)?;
        check_shape(runs, setup.method_names().len(), pairs.len())
            .and_then(|()| match lagged {
                Some(l) => check_lag_shape(l, &lag_pairs, setup.variants.len()),
                None if lag_pairs.is_empty() => Ok(()),
                None => Err(format!(
                    "no registration across lags for --lags {}",
                    setup.lags
                )),
            })
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("run {i} of the merged plan"))?;
        // The loops are judged here, with every registration in, as a single run judges them.
        Ok(report(
            &ds,
            &pairs,
            skipped,
            setup,
            runs.clone(),
            lagged.as_ref(),
        ))
    };
    match &plan.work {
        Work::Run(_) => {
            let report = report_of(0)?;
            write_outputs(&mut dir, &ds, &report, plots).context("writing the reports")?;
            println!("{}", table_md(&report));
        }
        Work::Compare { options, sweep, .. } => {
            let report = report_of(0)?;
            write_outputs(&mut dir, &ds, &report, plots).context("writing the reports")?;
            let swept = match sweep {
                Some(s) => {
                    let mut points = Vec::new();
                    for (i, &value) in s.values.iter().enumerate() {
                        points.extend(points_of(value, &report_of(i + 1)?));
                    }
                    Some(SweepResult {
                        param: s.param.clone(),
                        points,
                    })
                }
                None => None,
            };
            let rows = compare(&report, options);
            let md = write_comparison(
                &mut dir,
                &ds,
                &report,
                &rows,
                options,
                swept.as_ref(),
                plots,
            )?;
            println!("{md}");
        }
        Work::Basin(options) => {
            let MergedRun::Basin(rows) = &merged.runs[0] else {
                bail!("the basin's run holds registrations");
            };
            let names: Vec<&str> = setups[0].variants.iter().map(|v| v.name()).collect();
            let chosen = chosen_pairs(&ds, options).len();
            let report = basin_report(&ds, &names, options, chosen, rows.clone());
            println!("{}", write_basin(&mut dir, &ds, &report, plots)?);
        }
    }
    Ok(ExitCode::SUCCESS)
}
