//! The run report: one typed struct from which `summary.json`, `pairs.csv`, `table.md`, the
//! TUM trajectories, the figures and `report.html` are all rendered (built by the `build`
//! module from the records).

use datasets::{FileProvenance, FirstScans, LoadWarning, Pose2, ReferenceKind, SkippedPair};
use icp_core::variants::VariantSpec;
use icp_core::{BearingSense, SensorModel};
use nalgebra::Isometry2;
use serde::{Deserialize, Serialize};

use crate::measure::bound::{BoundSummary, OverBound};
use crate::measure::consistency::ConsistencySummary;
use crate::measure::cycles::{CycleRecord, CycleSummary};
use crate::measure::odometry_word::OdometryWord;
use crate::measure::outcome::FlagQuality;
use crate::measure::record::PairRecord;
use crate::measure::reference::{FlaggedStep, OffsetEstimate};
use crate::measure::reference_noise::ReferenceNoise;
use crate::measure::stats::Stats;
use crate::measure::trajectory::{EvoMetrics, ReferenceTum};
use crate::run::covariance::CovarianceMode;
use crate::run::estimates::ExternalSource;
use crate::run::init::InitChain;
use crate::run::left_out::{Confusion, DrawnScan};
use crate::run::sequence::{SequenceRecord, SequenceSummary};
use crate::run::setup::{GlobalChecks, OffsetChoice, ReferenceChecks};
use crate::run::start_gate::StartGate;
use icp_core::global::GlobalParams;

/// Version of the `summary.json` layout; bump it when a field changes meaning or goes away.
pub const SCHEMA_VERSION: u32 = 4;

/// Error statistics over one set of pairs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Pairs counted.
    pub pairs: usize,
    /// SOG error, m/s.
    pub sog_err_mps: Option<Stats>,
    /// ΔCOG error, degrees.
    pub dcog_err_deg: Option<Stats>,
    /// Translation error of `t_ref_src`, m (relative pose error at one step).
    pub trans_err_m: Option<Stats>,
    /// Rotation error of `t_ref_src`, degrees.
    pub rot_err_deg: Option<Stats>,
}

/// The chained trajectory's figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrajectoryStats {
    /// Length of the estimated track, m.
    pub length_m: f64,
    /// Pairs that failed and were bridged by the identity.
    pub gaps: usize,
    /// Distance between the chained end point and the reference end point, m.
    pub end_point_error_m: Option<f64>,
    /// End-point error per 100 m of reference track, m (i.e. percent).
    pub drift_m_per_100m: Option<f64>,
    /// Why the drift is not given, when it is not.
    pub note: Option<String>,
    /// RMS of the dead-reckoned heading error over the pairs (`hdg_chained_err_deg`), degrees.
    #[serde(default)]
    pub heading_rms_error_deg: Option<f64>,
    /// The dead-reckoned heading error at the last pair, degrees.
    #[serde(default)]
    pub heading_end_error_deg: Option<f64>,
    /// RMS of the absolute trajectory error after an SE(2) alignment to `reference.tum`, m
    /// (`evo_ape tum reference.tum trajectory_<variant>.tum -a`; `evo.ate_trans_m.rmse`).
    #[serde(default)]
    pub ate_rmse_m: Option<f64>,
    /// ATE and RPE against `reference.tum` with evo's statistics, where there is a reference.
    #[serde(default)]
    pub evo: Option<EvoMetrics>,
}

/// A failed pair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Failure {
    /// Pair index.
    pub pair: usize,
    /// The error.
    pub reason: String,
}

/// Timing of one variant (not reproducible; kept in its own field).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Median time per registration, µs.
    pub median_us: f64,
    /// 95th percentile, µs.
    pub p95_us: f64,
}

/// Everything about one variant's run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VariantSummary {
    /// Variant name.
    pub name: String,
    /// Pairs registered and not flagged (status `ok`).
    pub pairs_ok: usize,
    /// Fraction of the run's pairs that are a failure of this variant: not registered, or
    /// registered and flagged (every status but `ok`).
    #[serde(default)]
    pub failure_rate: f64,
    /// Pairs that failed, with their reasons.
    pub failures: Vec<Failure>,
    /// Pairs registered but flagged degenerate (failures of the variant; their numbers stay in
    /// the statistics).
    #[serde(default)]
    pub degenerate_pairs: Vec<usize>,
    /// Pairs registered but flagged as having no overlap (failures of the variant; their
    /// numbers stay in the statistics).
    #[serde(default)]
    pub no_overlap_pairs: Vec<usize>,
    /// Pairs registered but flagged suspect by the global check (failures of the variant;
    /// their numbers stay in the statistics).
    #[serde(default)]
    pub suspect_pairs: Vec<usize>,
    /// Pairs registered but flagged ambiguous: two distinct poses score nearly alike on the
    /// reference's likelihood grid, or it cannot say where the scans fit (failures of the
    /// variant; their numbers stay in the statistics).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ambiguous_pairs: Vec<usize>,
    /// Pairs registered but flagged inconsistent by the loops across lags (`--lags`; failures
    /// of the variant; their numbers stay in the statistics).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub inconsistent_pairs: Vec<usize>,
    /// Pairs registered but flagged dynamic: so much of a scan moves against the rest that
    /// the evidence for one motion is split (failures of the variant; their numbers, without
    /// the moving returns, stay in the statistics).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub dynamic_pairs: Vec<usize>,
    /// What the variant's detector of moving returns left out (`None`: it has none; see
    /// `crate::run::moving`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub moving_returns: Option<MovingReturnsSummary>,
    /// Fraction of the registered pairs that converged (`None` for an external estimator:
    /// nothing is iterated here).
    pub converged_fraction: Option<f64>,
    /// Mean iterations (`None` for an external estimator).
    pub iterations_mean: Option<f64>,
    /// Largest iteration count (`None` for an external estimator).
    pub iterations_max: Option<usize>,
    /// Over the pairs every variant registered (flagged ones included) that have a reference.
    pub all_pairs: ErrorStats,
    /// Over those of them whose reference step is plausible.
    pub plausible_reference: ErrorStats,
    /// Fraction of the run's pairs registered within [`crate::measure::outcome::SUCCESS_TRANS_M`] and
    /// [`crate::measure::outcome::SUCCESS_ROT_DEG`] of the reference, flagged or not (a pair not registered is
    /// not a success), where the reference is a rigid pose.
    #[serde(default)]
    pub success_rate: Option<f64>,
    /// How well the flags pick out the wrong numbers, where the reference is a rigid pose.
    #[serde(default)]
    pub flag_quality: Option<FlagQuality>,
    /// Odometry's word on the wrong numbers, where the log has odometry of its own (see
    /// [`crate::measure::odometry_word`]).
    #[serde(default)]
    pub odometry_on_wrong: Option<OdometryWord>,
    /// The chained trajectory.
    pub trajectory: TrajectoryStats,
    /// Translation and rotation RMSE as multiples of the Cramér–Rao bound over the registered
    /// pairs that have one (synthetic data with true normals).
    #[serde(default)]
    pub over_bound: Option<OverBound>,
    /// Wall time per registration.
    pub timing: Option<Timing>,
    /// Whether the covariances are honest: NEES against a rigid reference, standardised
    /// SOG and ΔCOG errors (see [`crate::measure::consistency`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub consistency: Option<ConsistencySummary>,
    /// The loops across lags (`--lags` above 1; see [`crate::measure::cycles`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cycles: Option<CycleSummary>,
}

/// What a variant's detector of moving returns left out over a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MovingReturnsSummary {
    /// Pairs with returns left out of either scan.
    pub pairs_with_left_out: usize,
    /// Mean returns left out per scan (source scans of the run's pairs).
    pub left_out_per_scan: f64,
    /// Where the scans carry truth labels: the share of returns labelled moving that were
    /// left out (over the source scans of the run's pairs).
    pub recall: Option<f64>,
    /// …and the share of returns labelled static that were left out.
    pub static_left_out_rate: Option<f64>,
    /// The source scans' labels and what was left out of them, summed.
    pub truth: Option<Confusion>,
}

/// What the dataset was.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetInfo {
    /// Name.
    pub name: String,
    /// Description and citation.
    pub description: String,
    /// Files read, with checksums.
    pub files: Vec<FileProvenance>,
    /// Scans.
    pub scans: usize,
    /// Pairs registered.
    pub pairs: usize,
    /// Consecutive pairs not registered, with reasons.
    pub skipped_pairs: Vec<SkippedPair>,
    /// Nominal time between scans, s.
    pub dt_s: f64,
    /// Sense of the scanner's bearings.
    pub bearing_sense: BearingSense,
    /// Sense of the reference heading.
    pub reference_heading_sense: BearingSense,
    /// What the reference is (`None`: no reference, or a summary written before the field).
    #[serde(default)]
    pub reference_kind: Option<ReferenceKind>,
    /// What the loader noticed about the data.
    #[serde(default)]
    pub warnings: Vec<LoadWarning>,
    /// The dataset's sensor model as the run used it, after `--sensor` (`None` in summaries
    /// written before the field). Each variant's own model is in its configuration.
    #[serde(default)]
    pub sensor: Option<SensorModel>,
    /// Whether the dataset has an odometry channel.
    #[serde(default)]
    pub odometry: bool,
    /// The scanner's pose relative to the reference point, where known.
    #[serde(default)]
    pub scanner_offset: Option<Pose2>,
    /// Time from a scan's first return to its last, s, where the data state it (0: every
    /// return at one instant); the extended covariance's motion term needs it. `None`:
    /// unknown.
    #[serde(default)]
    pub sweep_s: Option<f64>,
    /// When the run kept only the first scans of a dataset read from files (`--scans N`): how
    /// many were asked for and how many the data have (`scans` is the smaller). Absent: every
    /// scan read (a synthetic run generates its `--scans`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub first_scans: Option<FirstScans>,
}

/// The reference's trustworthiness.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceInfo {
    /// Whether the dataset has a reference at all.
    pub available: bool,
    /// Whether it is a rigid 2D pose of the scanner (translation/rotation errors need it).
    pub rigid_pose: bool,
    /// Estimated lag between estimate and reference.
    pub offset_estimate: Option<OffsetEstimate>,
    /// How the offset was chosen.
    pub offset_choice: OffsetChoice,
    /// The offset applied, scans.
    pub offset_applied_scans: i64,
    /// Which estimates the offset was estimated from (the per-pair median of the variants').
    pub offset_from_variant: Option<String>,
    /// Whether reference steps were tested for plausibility.
    #[serde(default)]
    pub checks: ReferenceChecks,
    /// Reference steps flagged as implausible.
    pub flagged_pairs: Vec<FlaggedStep>,
    /// Pairs whose reference step is plausible.
    pub plausible_pairs: usize,
    /// What `reference.tum` holds (`None`: no reference, no file).
    #[serde(default)]
    pub reference_tum: Option<ReferenceTum>,
    /// The reference's own noise (`None`: no reference, ground truth, or too short to
    /// estimate; see `noise_note`).
    #[serde(default)]
    pub noise: Option<ReferenceNoise>,
    /// Why a measured reference's noise is not given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise_note: Option<String>,
}

/// The pairs every variant's statistics are taken over: those every variant registered
/// (flagged or not), so that the variants are compared on the same pairs and a variant that
/// fails more does not drop its hard pairs from its own figures only.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Population {
    /// Pairs in it.
    pub pairs: usize,
    /// Pairs of the run left out of it: some variant did not register them.
    pub left_out: Vec<usize>,
}

/// The global searches of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SearchSummary {
    /// Pairs searched.
    pub pairs: usize,
    /// Searches that could not run, with the reason (their pairs start at the identity and
    /// are not checked).
    pub failures: Vec<Failure>,
    /// Wall time per search (grid and branch and bound; made once per pair, shared by every
    /// variant and left out of their timings).
    pub timing: Option<Timing>,
}

/// The configuration that produced the run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunConfig {
    /// Every variant's full specification, in run order.
    pub variants: Vec<VariantSpec>,
    /// Where each registration started: the init modes tried in turn.
    #[serde(default)]
    pub init: InitChain,
    /// The global search's parameters.
    #[serde(default)]
    pub global: GlobalParams,
    /// Whether results were checked against it.
    #[serde(default)]
    pub global_check: GlobalChecks,
    /// How registrations started close to the motion (the global search's pose, the
    /// reference) gate their correspondences.
    #[serde(default)]
    pub start_gate: StartGate,
    /// The variants whose close starts were gated, and at what distance (m): those whose
    /// metric measures along a surface normal and has no gate of its own
    /// ([`crate::run::start_gate`]); empty when no registration starts close.
    #[serde(default)]
    pub start_gated: Vec<(String, f64)>,
    /// Where each registration's covariance came from.
    #[serde(default)]
    pub covariance: CovarianceMode,
    /// The external estimators evaluated after the variants (`--estimates`), with their
    /// files' SHA-256 (see [`crate::run::estimates`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub estimates: Vec<ExternalSource>,
    /// The longest lag registered (`--lags`; 1: consecutive pairs only, see
    /// [`crate::run::lags`]).
    #[serde(default = "crate::run::options::one_lag")]
    pub lags: usize,
}

/// The whole run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunReport {
    /// Layout version of this file.
    pub schema_version: u32,
    /// Tool name and version.
    pub tool: String,
    /// The data.
    pub dataset: DatasetInfo,
    /// The configuration.
    pub config: RunConfig,
    /// The reference.
    pub reference: ReferenceInfo,
    /// The Cramér–Rao bound over the pairs, where the dataset records true normals.
    #[serde(default)]
    pub bound: Option<BoundSummary>,
    /// The pairs every variant's statistics are taken over.
    #[serde(default)]
    pub population: Population,
    /// One summary per variant, in run order.
    pub variants: Vec<VariantSummary>,
    /// Wall time per scan of its surface estimates (normals and covariances), made once and
    /// shared by every variant and both pairs that use the scan; each variant's `timing` leaves
    /// it out.
    #[serde(default)]
    pub preparation: Option<Timing>,
    /// The pairs' global searches, when they were made (`--init global` or result checks).
    #[serde(default)]
    pub global_search: Option<SearchSummary>,
    /// One record per variant and pair (written to `pairs.csv`, not to `summary.json`).
    #[serde(skip)]
    pub pairs: Vec<PairRecord>,
    /// Chained poses `t_world_scan` per variant, for TUM files and figures.
    #[serde(skip)]
    pub trajectories: Vec<Vec<(f64, Isometry2<f64>)>>,
    /// The reference pose at each pose of the trajectories, where there is one (written to
    /// `reference.tum` with the trajectories' timestamps).
    #[serde(skip)]
    pub reference_trajectory: Vec<Option<Isometry2<f64>>>,
    /// Every loop across lags, per variant (written to `cycles.csv`; empty without `--lags`).
    #[serde(skip)]
    pub cycles: Vec<CycleRecord>,
    /// The smoothed estimators of `--sequence`: what each used and the `Qc` it estimated.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub sequence: Vec<SequenceSummary>,
    /// `sequence.csv`: per smoothed estimator and scan, the fused state (not in
    /// `summary.json`).
    #[serde(skip)]
    pub sequence_scans: Vec<SequenceRecord>,
    /// A scan drawn with the returns a detector of moving returns left out (a figure).
    #[serde(skip)]
    pub drawn_scan: Option<DrawnScan>,
}
