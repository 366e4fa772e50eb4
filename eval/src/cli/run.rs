//! `icp-eval run`: chosen variants on one dataset.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::Args;
use datasets::Dataset;
use eval::render::markdown::table_md;
use eval::run::covariance::CovarianceMode;
use eval::run::estimates::{EstimatesSpec, TILT_NOTE_DEG};
use eval::run::init::InitChain;
use eval::run::options::{refuse_reference_options, RunOptions};
use eval::run::sequence_setup::{SequenceMode, SequencePrior};
use eval::run::setup::{EvalSetup, GlobalChecks, OffsetChoice, ReferenceChecks};
use eval::run::start_gate::StartGate;
use eval::shard::Work;
use icp_core::global::{GlobalParams, RotationMode};

use crate::cli::common::{evaluate_and_write, run_shard_cmd, shard_of, Common, ShardArgs};
use crate::cli::data::{load_dataset, DataArgs};
use crate::cli::variants::{resolve_variants, VariantArgs};

#[derive(Args)]
pub(crate) struct RunArgs {
    #[command(flatten)]
    pub(crate) data: DataArgs,
    #[command(flatten)]
    pub(crate) variants: VariantArgs,
    /// Reference time offset to apply: N scans (the reference of pair k + N is compared with
    /// estimate k), or `auto`: the estimated one (the lag whose correlation beats lag 0 by
    /// 0.05 or more, else 0). The default, 0, never applies one, whatever table.md says was
    /// estimated. Refused on a dataset without a reference. See docs/reference.md.
    #[arg(long)]
    pub(crate) reference_offset: Option<OffsetChoice>,
    /// Test the reference steps for plausibility (`on`, the default, for measured references
    /// such as GNSS) or take every step as plausible (`off`, for ground truth). Refused on a
    /// dataset without a reference.
    #[arg(long, value_enum)]
    pub(crate) reference_checks: Option<ReferenceChecks>,
    /// Where each registration starts (help generated from the registered modes).
    #[arg(long, default_value = "identity")]
    pub(crate) init: InitChain,
    /// Check every result against a global search of its pair (correlative scan matching):
    /// a result far from a clearly better pose is flagged suspect. See
    /// docs/starts-and-flags.md.
    #[arg(long, value_enum, default_value_t = GlobalChecks::On)]
    pub(crate) global_check: GlobalChecks,
    /// Correspondence gate of registrations started close to the motion (at the global
    /// search's pose or the reference), for variants whose metric measures along a surface
    /// normal and has no gate of its own: auto (2 cells of the search, 0.2 m by default), off,
    /// or a distance in metres. See docs/starts-and-flags.md.
    #[arg(long, default_value = "auto")]
    pub(crate) start_gate: StartGate,
    /// Half-width of the global search's translation window around the identity, m.
    #[arg(long, default_value_t = GlobalParams::default().window_m)]
    pub(crate) global_window_m: f64,
    /// Rotation candidates of the global search: histogram (around the peaks of the
    /// surface-normal orientation histograms, and the identity) or full (every step over
    /// ±180°).
    #[arg(long, value_enum, default_value_t = GlobalRotation::Histogram)]
    pub(crate) global_rotation: GlobalRotation,
    /// Where each registration's covariance comes from (help generated from the registered
    /// modes).
    #[arg(long, default_value = "extended")]
    pub(crate) covariance: CovarianceMode,
    /// Another estimator's results, evaluated after the variants like one more variant:
    /// NAME=FILE, the file TUM poses per scan (`timestamp x y z qx qy qz qw`, matched to the
    /// scans' times within 1 ms) or a CSV of per-pair motions
    /// (`source,reference,tx_m,ty_m,theta_deg`, t_ref_src as in pairs.csv). Repeatable. See
    /// docs/estimates.md.
    #[arg(long)]
    pub(crate) estimates: Vec<EstimatesSpec>,
    /// Also register every scan k to scan k+ℓ for 2 ≤ ℓ ≤ LAGS, and flag a consecutive
    /// registration that disagrees with every trusted loop through its neighbours (one whose
    /// registrations are all ok; `cycles.csv`; 1: consecutive pairs only). See
    /// docs/reference.md.
    #[arg(long, default_value_t = 1)]
    pub(crate) lags: usize,
    /// Also smooth each variant V's registrations (with `--lags`, those across lags too) over
    /// the whole scan sequence: estimators `V+batch` (every scan from the whole run),
    /// `V+causal` (each scan from the scans up to it) and `V+deskew` (the pairs registered
    /// again on scans deskewed by `V+batch`'s twists; needs the dataset's sweep), and
    /// `sequence.csv`. Comma-separated. See docs/sequence.md.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub(crate) sequence: Vec<SequenceMode>,
    /// The smoothers' motion prior between consecutive scans (with `--sequence`): white noise
    /// on acceleration (a constant velocity), on jerk (a constant acceleration, for a hull
    /// whose acceleration changes slowly against the scans' rate), or per variant the one
    /// under which its registrations are likelier (both estimated: twice the smoothing time).
    /// See docs/sequence.md.
    #[arg(long, value_enum, default_value_t = SequencePrior::WhiteAcceleration)]
    pub(crate) motion_prior: SequencePrior,
    /// Output directory.
    #[arg(long)]
    pub(crate) out: PathBuf,
    #[command(flatten)]
    pub(crate) common: Common,
    #[command(flatten)]
    pub(crate) shard: ShardArgs,
}

/// The global search's rotation modes on the command line.
#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum GlobalRotation {
    Full,
    Histogram,
}

impl RunArgs {
    /// The options a sharded run's plan records.
    pub(crate) fn run_options(&self) -> Result<RunOptions> {
        Ok(RunOptions {
            offset: self.reference_offset.unwrap_or(OffsetChoice::Fixed(0)),
            reference_checks: self.reference_checks.unwrap_or(ReferenceChecks::On),
            init: self.init.clone(),
            global: self.global()?,
            global_check: self.global_check,
            start_gate: self.start_gate,
            covariance: self.covariance,
            estimates: self.estimates.clone(),
            lags: self.lags,
            sequence: self.sequence.clone(),
            motion_prior: self.motion_prior,
        })
    }

    /// Refuses `--reference-offset` and `--reference-checks` on a dataset without a reference.
    pub(crate) fn refuse_reference_options(&self, ds: &Dataset) -> Result<()> {
        let given: Vec<&'static str> = [
            ("--reference-offset", self.reference_offset.is_some()),
            ("--reference-checks", self.reference_checks.is_some()),
        ]
        .into_iter()
        .filter_map(|(flag, set)| set.then_some(flag))
        .collect();
        Ok(refuse_reference_options(ds, &given)?)
    }

    /// The global search's parameters from the options.
    pub(crate) fn global(&self) -> Result<GlobalParams> {
        let params = GlobalParams {
            window_m: self.global_window_m,
            rotation: match self.global_rotation {
                GlobalRotation::Full => RotationMode::Full,
                GlobalRotation::Histogram => RotationMode::Histogram,
            },
            ..GlobalParams::default()
        };
        params
            .validate()
            .map_err(|e| anyhow::anyhow!("--global-window-m: {e}"))?;
        Ok(params)
    }
}

pub(crate) fn run_one(args: RunArgs) -> Result<ExitCode> {
    let ds = load_dataset(&args.data)?;
    args.refuse_reference_options(&ds)?;
    let specs = resolve_variants(&args.variants, &ds)?;
    if let Some(shard) = shard_of(&args.shard)? {
        let work = Work::Run(args.run_options()?);
        return run_shard_cmd(&ds, specs, work, shard, &args.out, &args.common);
    }
    let setup = args.run_options()?.setup(&specs, &ds)?;
    note_estimates(&setup);
    let (report, _) = evaluate_and_write(&ds, &setup, &args.out, &args.common)?;
    println!("{}", table_md(&report));
    Ok(ExitCode::SUCCESS)
}

/// Says on the terminal what an external estimates file held that the run does not use (also
/// in table.md): a count that is not 0 may be a file of another run, or of a 3D estimator.
pub(crate) fn note_estimates(setup: &EvalSetup) {
    for e in &setup.estimates {
        let s = &e.source;
        if s.unused > 0 {
            eprintln!(
                "note: --estimates {}: {} of the estimates in {} are for no pair of this run (left unused)",
                s.name,
                s.unused,
                s.path.display()
            );
        }
        if s.tilted_poses > 0 {
            eprintln!(
                "note: --estimates {}: {} poses of {} are tilted more than {}° out of the plane (up to {:.1}°): their roll and pitch are dropped",
                s.name,
                s.tilted_poses,
                s.path.display(),
                TILT_NOTE_DEG,
                s.max_tilt_deg
            );
        }
    }
}
