//! What every command shares: the common options, progress bars, the thread pool, running and
//! writing a run, and running one shard of a plan.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::Args;
use datasets::Dataset;
use eval::measure::report::RunReport;
use eval::pipeline::evaluate;
use eval::render::outdir::OutputDir;
use eval::render::write_outputs;
use eval::run::covariance::CovarianceMode;
use eval::run::setup::EvalSetup;
use eval::shard::Plan;
use eval::shard::Shard;
use eval::shard::ShardOrigin;
use eval::shard::Work;
use icp_core::variants::VariantSpec;
use indicatif::{ProgressBar, ProgressStyle};

#[derive(Args)]
pub(crate) struct Common {
    /// Number of worker threads (results do not depend on it).
    #[arg(long)]
    pub(crate) threads: Option<usize>,
    /// No progress bar.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Skip the figures.
    #[arg(long)]
    pub(crate) no_plots: bool,
    /// Write into an output directory that holds files icp-eval did not list in its
    /// manifest.json (they are left alone); without it such a directory is refused.
    #[arg(long)]
    pub(crate) force: bool,
}

#[derive(Args)]
pub(crate) struct ShardArgs {
    /// Run only part K of N (0 ≤ K < N) of the job list and write it as part-K-of-N.cbor
    /// into --out, for `icp-eval merge`. Without it, a Slurm array task
    /// (SLURM_ARRAY_TASK_ID − SLURM_ARRAY_TASK_MIN of SLURM_ARRAY_TASK_COUNT) or a Kubernetes
    /// indexed Job (JOB_COMPLETION_INDEX, with --shards) is sharded likewise. See
    /// docs/sharding.md.
    #[arg(long)]
    pub(crate) shard: Option<eval::shard::Shard>,
    /// Number of shards of a Kubernetes indexed Job (its completions); checked against the
    /// other sources when given with them.
    #[arg(long)]
    pub(crate) shards: Option<usize>,
    /// Run everything, ignoring the Slurm and Kubernetes variables.
    #[arg(long, conflicts_with_all = ["shard", "shards"])]
    pub(crate) no_shard: bool,
}

pub(crate) fn progress(quiet: bool, label: &str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(0);
    if let Ok(style) =
        ProgressStyle::with_template("{msg:>22} [{bar:40}] {pos}/{len} registrations ({eta})")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(label.to_owned());
    bar
}

pub(crate) fn in_pool<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> Result<T> {
    match threads {
        None => Ok(f()),
        Some(0) => bail!("--threads must be at least 1"),
        Some(n) => Ok(rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .context("building the thread pool")?
            .install(f)),
    }
}

pub(crate) fn evaluate_in_pool(
    ds: &Dataset,
    setup: &EvalSetup,
    common: &Common,
) -> Result<RunReport> {
    let bar = progress(common.quiet, &ds.provenance.name);
    Ok(in_pool(common.threads, || evaluate(ds, setup, &bar))??)
}

/// Runs and writes the reports into `out`; returns the report and the directory, for files
/// a command adds.
pub(crate) fn evaluate_and_write(
    ds: &Dataset,
    setup: &EvalSetup,
    out: &Path,
    common: &Common,
) -> Result<(RunReport, OutputDir)> {
    let mut dir = OutputDir::open(out, common.force).context("opening the output directory")?;
    let report = evaluate_in_pool(ds, setup, common)?;
    write_outputs(&mut dir, ds, &report, !common.no_plots).context("writing the reports")?;
    Ok((report, dir))
}

/// The shard this process runs, from `--shard`, else from the Slurm or Kubernetes variables
/// (unless `--no-shard`).
pub(crate) fn shard_of(args: &ShardArgs) -> Result<Option<(Shard, ShardOrigin)>> {
    let env: BTreeMap<String, String> = if args.no_shard {
        BTreeMap::new()
    } else {
        [
            eval::shard::SLURM_ARRAY_TASK_ID,
            eval::shard::SLURM_ARRAY_TASK_MIN,
            eval::shard::SLURM_ARRAY_TASK_COUNT,
            eval::shard::JOB_COMPLETION_INDEX,
        ]
        .into_iter()
        .filter_map(|name| {
            std::env::var_os(name).map(|v| (name.to_owned(), v.to_string_lossy().into_owned()))
        })
        .collect()
    };
    Ok(eval::shard::resolve(args.shard, args.shards, &env)?)
}

/// Runs one shard of the plan of `work` and writes its part file into `out`.
pub(crate) fn run_shard_cmd(
    ds: &Dataset,
    specs: Vec<VariantSpec>,
    work: Work,
    (shard, origin): (Shard, ShardOrigin),
    out: &Path,
    common: &Common,
) -> Result<ExitCode> {
    if let Work::Run(run) | Work::Compare { run, .. } = &work {
        if matches!(
            run.covariance,
            CovarianceMode::Sampled | CovarianceMode::Restarts
        ) {
            // Its samples are seeded by the pair's position in the run, which a shard does not
            // see yet (restarts: made after the run, which a shard does not do yet): refused
            // rather than giving other numbers than a single run.
            bail!(
                "--covariance {} cannot be sharded yet: run it unsharded (--no-shard)",
                run.covariance
            );
        }
    }
    let plan = Plan::new(ds, specs, work, shard.count)?;
    let slices = eval::shard::slices(&plan.runs, shard);
    let mine: usize = slices.iter().map(|s| s.units.len()).sum();
    let total: usize = plan.runs.iter().map(|r| r.units).sum();
    // Said on every sharded run: a run inside a Slurm array or an indexed Job shards itself.
    eprintln!(
        "icp-eval: shard {shard} (from {origin}): {mine} of the plan's {total} units; writes {} only: merge the parts with `icp-eval merge` (--no-shard runs everything)",
        out.join(shard.file_name()).display()
    );
    let mut dir = OutputDir::open(out, common.force).context("opening the output directory")?;
    let bar = progress(common.quiet, &format!("shard {shard}"));
    let command_line: Vec<String> = std::env::args().collect();
    let part = in_pool(common.threads, || {
        eval::shard::run_shard(ds, &plan, shard, command_line, &bar)
    })??;
    dir.write(&shard.file_name(), &part.to_bytes()?)?;
    Ok(ExitCode::SUCCESS)
}
