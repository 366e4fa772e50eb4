//! `icp-eval compare`: the variants pair by pair (bootstrap interval, Wilcoxon test), optionally
//! over a parameter sweep.

use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use eval::measure::compare::{compare, CompareOptions};
use eval::measure::sweep::parse_sweep;
use eval::render::studies::write_comparison;
use eval::shard::SweepPlan;
use eval::shard::Work;
use eval::studies::sweep;

use crate::cli::common::{evaluate_and_write, in_pool, progress, run_shard_cmd, shard_of};
use crate::cli::data::load_dataset;
use crate::cli::run::{note_estimates, RunArgs};
use crate::cli::variants::resolve_variants;

#[derive(Args)]
pub(crate) struct CompareArgs {
    #[command(flatten)]
    pub(crate) run: RunArgs,
    /// Bootstrap resamples.
    #[arg(long, default_value_t = 10_000)]
    pub(crate) bootstrap: usize,
    /// Bootstrap seed.
    #[arg(long, default_value_t = 0)]
    pub(crate) bootstrap_seed: u64,
    /// Also re-run the variants over values of one parameter: sigma_alpha_deg=0.1,0.5,... or
    /// huber_c=1,2.0138,3.
    #[arg(long)]
    pub(crate) sweep: Option<String>,
}

pub(crate) fn compare_cmd(args: CompareArgs) -> Result<ExitCode> {
    let run = &args.run;
    let ds = load_dataset(&run.data)?;
    run.refuse_reference_options(&ds)?;
    let variants = resolve_variants(&run.variants, &ds)?;
    let options = CompareOptions {
        resamples: args.bootstrap,
        seed: args.bootstrap_seed,
    };
    let sweep = args
        .sweep
        .as_deref()
        .map(|text| {
            parse_sweep(text)
                .map(|(param, values)| SweepPlan { param, values })
                .map_err(anyhow::Error::msg)
                .context("--sweep")
        })
        .transpose()?;
    if let Some(shard) = shard_of(&run.shard)? {
        let work = Work::Compare {
            run: run.run_options()?,
            options,
            sweep,
        };
        return run_shard_cmd(&ds, variants, work, shard, &run.out, &run.common);
    }
    let setup = run.run_options()?.setup(&variants, &ds)?;
    note_estimates(&setup);
    let (report, mut dir) = evaluate_and_write(&ds, &setup, &run.out, &run.common)?;
    let swept = match sweep {
        Some(SweepPlan { param, values }) => {
            let bar = progress(run.common.quiet, "sweep");
            Some(in_pool(run.common.threads, || {
                sweep::sweep(&ds, &setup, &variants, param, &values, &bar)
            })??)
        }
        None => None,
    };
    let rows = compare(&report, &options);
    let plots = !run.common.no_plots;
    let md = write_comparison(
        &mut dir,
        &ds,
        &report,
        &rows,
        &options,
        swept.as_ref(),
        plots,
    )?;
    println!("{md}");
    Ok(ExitCode::SUCCESS)
}
