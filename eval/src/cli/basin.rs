//! `icp-eval basin`: the convergence-basin protocol (Pomerleau et al. 2013).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use eval::measure::basin::BasinOptions;
use eval::render::outdir::OutputDir;
use eval::render::studies::write_basin;
use eval::run::setup::{EvalSetup, OffsetChoice};
use eval::shard::Work;
use eval::studies::basin;

use crate::cli::common::{in_pool, progress, run_shard_cmd, shard_of, Common, ShardArgs};
use crate::cli::data::{load_dataset, DataArgs};
use crate::cli::variants::{resolve_variants, VariantArgs};

#[derive(Args)]
pub(crate) struct BasinArgs {
    #[command(flatten)]
    pub(crate) data: DataArgs,
    #[command(flatten)]
    pub(crate) variants: VariantArgs,
    /// Starts per pair.
    #[arg(long, default_value_t = BasinOptions::default().perturbations)]
    pub(crate) perturbations: usize,
    /// Largest distance of a start's translation from the true one, m.
    #[arg(long, default_value_t = BasinOptions::default().max_translation_m)]
    pub(crate) max_translation_m: f64,
    /// Largest rotation of a start from the true one, degrees.
    #[arg(long, default_value_t = BasinOptions::default().max_rotation_deg)]
    pub(crate) max_rotation_deg: f64,
    /// Seed of the starts (the same for every variant).
    #[arg(long, default_value_t = 0)]
    pub(crate) perturbation_seed: u64,
    /// Run every n-th pair only.
    #[arg(long, default_value_t = 1)]
    pub(crate) pair_stride: usize,
    /// Only 1: the basin makes no loops across lags (`run --lags` does). Each start is judged
    /// against the true motion, and a loop would chain the independent starts of
    /// neighbouring pairs, so it says nothing about one start.
    #[arg(long, default_value_t = 1)]
    pub(crate) lags: usize,
    /// Output directory.
    #[arg(long)]
    pub(crate) out: PathBuf,
    #[command(flatten)]
    pub(crate) common: Common,
    #[command(flatten)]
    pub(crate) shard: ShardArgs,
}

pub(crate) fn basin_cmd(args: BasinArgs) -> Result<ExitCode> {
    basin::check_lags(args.lags)?;
    let ds = load_dataset(&args.data)?;
    let setup = EvalSetup::from_specs(
        &resolve_variants(&args.variants, &ds)?,
        OffsetChoice::Fixed(0),
    )?;
    let options = BasinOptions {
        perturbations: args.perturbations,
        max_translation_m: args.max_translation_m,
        max_rotation_deg: args.max_rotation_deg,
        seed: args.perturbation_seed,
        pair_stride: args.pair_stride,
        ..BasinOptions::default()
    };
    options.validate()?;
    if let Some(shard) = shard_of(&args.shard)? {
        let specs = setup.variants.iter().map(|v| v.spec()).collect();
        let work = Work::Basin(options);
        return run_shard_cmd(&ds, specs, work, shard, &args.out, &args.common);
    }
    let mut dir =
        OutputDir::open(&args.out, args.common.force).context("opening the output directory")?;
    let bar = progress(args.common.quiet, "basin");
    let report = in_pool(args.common.threads, || {
        basin::run(&ds, &setup.variants, &options, &bar)
    })??;
    bar.finish_and_clear();
    println!(
        "{}",
        write_basin(&mut dir, &ds, &report, !args.common.no_plots)?
    );
    Ok(ExitCode::SUCCESS)
}
