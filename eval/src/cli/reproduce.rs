//! `icp-eval reproduce`: the paper's four variants on the marina data (when found) and on the
//! synthetic `paper` scenario.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use datasets::marina;
use datasets::synthetic::{self, Scenario};
use eval::render::markdown::table_md;
use eval::run::setup::{EvalSetup, OffsetChoice};
use icp_core::variants::table1;

use crate::cli::common::{evaluate_and_write, Common};

#[derive(Args)]
pub(crate) struct ReproduceArgs {
    /// Directory holding the marina files (or a `marina/` folder); else $ICP_DATA_DIR, then ./datasets.
    #[arg(long)]
    pub(crate) data_dir: Option<PathBuf>,
    /// Output directory (outside the committed reports; `scripts/update-reproduction.sh`
    /// regenerates those).
    #[arg(long, default_value = "results/reproduction")]
    pub(crate) out: PathBuf,
    #[command(flatten)]
    pub(crate) common: Common,
}

pub(crate) fn reproduce(args: ReproduceArgs) -> Result<ExitCode> {
    let setup = EvalSetup::from_specs(&table1(), OffsetChoice::Fixed(0))?;
    match marina::find_data_dir(args.data_dir.as_deref()) {
        Ok(dir) => {
            let ds = marina::load(&dir, &marina::MarinaOptions::default())
                .with_context(|| format!("loading the marina data from {}", dir.display()))?;
            let out = args.out.join("marina");
            let (report, _) = evaluate_and_write(&ds, &setup, &out, &args.common)?;
            println!("{}", table_md(&report));
            println!("(marina reports in {})\n", out.display());
        }
        Err(e) => {
            if args.data_dir.is_some() {
                return Err(e).context("--data-dir was given but holds no marina data");
            }
            eprintln!("note: skipping the marina data: {e}\n");
        }
    }
    let ds = synthetic::generate(&Scenario::paper())
        .context("generating the synthetic `paper` scenario")?;
    let out = args.out.join("synthetic-paper");
    let (report, _) = evaluate_and_write(&ds, &setup, &out, &args.common)?;
    println!("{}", table_md(&report));
    println!("(synthetic reports in {})", out.display());
    Ok(ExitCode::SUCCESS)
}
