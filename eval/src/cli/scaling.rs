//! `icp-eval scaling`: one variant timed on synthetic scan pairs of growing size.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use eval::render::outdir::OutputDir;
use eval::render::studies::write_scaling;
use eval::studies::scaling::measure;
use icp_core::variants::{builtin, builtin_names};

#[derive(Args)]
pub(crate) struct ScalingArgs {
    /// Built-in variant to time.
    #[arg(long, default_value = "HD_ICP")]
    pub(crate) variant: String,
    /// Beams per scanner revolution, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "100,300,1000,3000,10000,30000,100000"
    )]
    pub(crate) beams: Vec<usize>,
    /// Seconds spent timing each size (at least 3 registrations each).
    #[arg(long, default_value_t = 1.0)]
    pub(crate) budget_s: f64,
    /// Output directory (outside the committed reports).
    #[arg(long, default_value = "results/performance")]
    pub(crate) out: PathBuf,
    /// Write into a directory that holds files icp-eval did not list.
    #[arg(long)]
    pub(crate) force: bool,
}

pub(crate) fn scaling(args: ScalingArgs) -> Result<ExitCode> {
    let spec = builtin(&args.variant).with_context(|| {
        format!(
            "unknown variant {:?}: expected one of {}",
            args.variant,
            builtin_names().join(", ")
        )
    })?;
    let result = measure(&spec, &args.beams, args.budget_s)?;
    let mut dir = OutputDir::open(&args.out, args.force)?;
    print!("{}", write_scaling(&mut dir, &result)?);
    Ok(ExitCode::SUCCESS)
}
