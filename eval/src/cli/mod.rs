//! The command line: one file per command with its arguments; [`Cli`] gathers them and
//! [`run()`] dispatches.

pub mod baseline;
pub mod basin;
pub mod common;
pub mod compare;
pub mod data;
pub mod gate;
pub mod list;
pub mod merge;
pub mod reproduce;
pub mod run;
pub mod scaling;
pub mod synth;
pub mod variants;

use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};
use eval::run::covariance::CovarianceMode;
use eval::run::init::MODES;
use icp_core::matching::MATCHERS;
use icp_core::variants::builtin_names;

use crate::cli::baseline::BaselineArgs;
use crate::cli::basin::BasinArgs;
use crate::cli::compare::CompareArgs;
use crate::cli::gate::GateArgs;
use crate::cli::merge::MergeArgs;
use crate::cli::reproduce::ReproduceArgs;
use crate::cli::run::RunArgs;
use crate::cli::scaling::ScalingArgs;
use crate::cli::synth::SynthArgs;

/// Weighted-ICP evaluation for 2D LIDAR (Naus & Marchel 2019): runs the variants over every
/// consecutive scan pair and reports SOG/ΔCOG errors like the paper's Table 1, and more.
#[derive(Parser)]
#[command(name = "icp-eval", version, about)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub(crate) command: Command,
}

#[derive(Subcommand)]
pub(crate) enum Command {
    /// Reproduce the paper: the four variants on the marina data (when found) and on the
    /// synthetic `paper` scenario; writes reports and prints the tables.
    Reproduce(ReproduceArgs),
    /// Run chosen variants on one dataset.
    Run(RunArgs),
    /// Compare variants pair by pair (bootstrap interval, Wilcoxon test), optionally over a
    /// parameter sweep.
    Compare(CompareArgs),
    /// Compare a run's summary.json with a baseline: exit 0 if nothing got worse beyond the
    /// tolerances, 1 with what regressed or which baseline variant the run lacks, 2 on
    /// unusable input.
    ///
    /// Every metric of every variant that both runs have is compared with the baseline's and
    /// may move the wrong way by at most max(abs, rel·|baseline|) from the tolerance file
    /// (--tolerance; without it, the tolerance.json in the baseline's folder, else the
    /// built-in tolerances); the gate says which tolerances it used. A variant of the baseline
    /// that the current run lacks is a failure (exit 1); a variant only in the current run is
    /// not gated, and the gate says how to add it to the baseline. Runs on other data or of
    /// another schema cannot be compared (exit 2).
    Gate(GateArgs),
    /// Make a baseline for `gate` from a run: check its summary.json, write it to --out and
    /// put the built-in tolerances beside it unless a tolerance.json is there.
    ///
    /// The run must be of this icp-eval's summary schema, on data with a reference (a run
    /// without one has no error statistics to gate) and hold at least one variant; otherwise
    /// nothing is written and the exit code is 2. Commit the baseline and its tolerance.json,
    /// then gate later runs of the same data and variants against it: icp-eval gate
    /// --baseline FILE --current RUN_DIR/summary.json.
    Baseline(BaselineArgs),
    /// The convergence-basin protocol (Pomerleau et al. 2013): each pair registered from
    /// seeded starts around its true motion; success against the start's offset (basin.csv,
    /// .json, .md, .png, .svg). Needs a rigid reference.
    Basin(BasinArgs),
    /// Generate a synthetic harbour dataset and write it in our CSV format.
    Synth(SynthArgs),
    /// Time one variant on synthetic scan pairs of growing size: time per registration,
    /// iterations and time per point and iteration (scaling.md, .json, .png, .svg).
    Scaling(ScalingArgs),
    /// List the built-in variants and the stages a configuration file can name.
    List,
    /// Merge the part files of a sharded `run`, `compare` or `basin` (`--shard K/N`) into
    /// the files a single run writes (timings aside); checks that the parts are of one plan
    /// and cover it exactly once.
    Merge(MergeArgs),
}

/// The command line, with the help of the variant options generated from the registered
/// variants and matchers (so it cannot go stale).
pub(crate) fn cli_command() -> clap::Command {
    let variants = format!(
        "Built-in variants, comma-separated: {}. Default: the four of Table 1, or none when \
         --config is given",
        builtin_names().join(", ")
    );
    let matchers = format!(
        "Nearest-neighbour matcher of the built-in variants: {} (all exact)",
        MATCHERS.names().join(", ")
    );
    let init = format!(
        "Where each registration starts: {}. A comma-separated chain tries the next mode while \
         a registration is flagged (e.g. constant-velocity,identity). See docs/starts-and-flags.md",
        MODES
            .iter()
            .map(|(_, name, help)| format!("{name}: {help}"))
            .collect::<Vec<_>>()
            .join("; ")
    );
    let patch = |c: clap::Command| {
        c.mut_arg("variants", |a| a.help(variants.clone()))
            .mut_arg("matcher", |a| a.help(matchers.clone()))
            .mut_arg("init", |a| a.help(init.clone()))
            .mut_arg("covariance", |a| {
                a.help(format!(
                    "{}. See docs/covariances.md",
                    CovarianceMode::help()
                ))
            })
    };
    <Cli as clap::CommandFactory>::command()
        .mut_subcommand("run", patch)
        .mut_subcommand("compare", patch)
        .mut_subcommand("basin", |c| {
            c.mut_arg("variants", |a| a.help(variants.clone()))
                .mut_arg("matcher", |a| a.help(matchers.clone()))
        })
}

/// The error and its causes, each said once: our errors already print their cause.
pub(crate) fn message(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1).map(|c| c.to_string()) {
        if !msg.contains(&cause) {
            msg = format!("{msg}: {cause}");
        }
    }
    msg
}

pub(crate) fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Reproduce(args) => reproduce::reproduce(args),
        Command::Run(args) => run::run_one(args),
        Command::Compare(args) => compare::compare_cmd(args),
        Command::Gate(args) => gate::gate_cmd(args),
        Command::Baseline(args) => baseline::baseline_cmd(args),
        Command::Basin(args) => basin::basin_cmd(args),
        Command::Synth(args) => synth::synth(args),
        Command::Scaling(args) => scaling::scaling(args),
        Command::List => list::list(),
        Command::Merge(args) => merge::merge_cmd(args),
    }
}
