//! The run report: one typed struct from which `summary.json`, `pairs.csv`, `table.md`, the
//! TUM trajectories and the figures are all rendered.

use datasets::{Dataset, FileProvenance, LoadWarning, Pose2, ReferenceKind, ScanPair, SkippedPair};
use icp_core::motion::{wrap_deg, MovementParams};
use icp_core::variants::VariantSpec;
use icp_core::{BearingSense, ConfigError, Registrar, SensorModel};
use nalgebra::Isometry2;
use serde::{Deserialize, Serialize};

use crate::bound::{self, BoundSummary, OverBound, PairBound};
use crate::consistency::{self, ConsistencySummary, CovarianceMode};
use crate::estimates::{ExternalEstimates, ExternalSource};
use crate::evo::{EvoMetrics, ReferenceTum};
use crate::init::{InitChain, InitMode};
use crate::outcome::{self, FlagQuality};
use crate::reference::{self, FlaggedStep, OffsetEstimate, ReferenceChecks};
use crate::runner::{PairRun, Runs};
use crate::start_gate::{self, StartGate};
use crate::stats::{median_p95, Stats};
use crate::status::StatusKind;
use icp_core::global::GlobalParams;

/// Version of the `summary.json` layout; bump it when a field changes meaning or goes away.
pub const SCHEMA_VERSION: u32 = 4;

/// How the reference is aligned in time with the scans.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "mode", content = "scans", rename_all = "snake_case")]
pub enum OffsetChoice {
    /// Apply this many scans (0: none).
    Fixed(i64),
    /// Apply the estimated offset.
    Auto,
}

impl std::str::FromStr for OffsetChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Self::Auto);
        }
        s.parse::<i64>()
            .map(Self::Fixed)
            .map_err(|_| format!("expected an integer number of scans or 'auto', got {s:?}"))
    }
}

/// One row of `pairs.csv`: one variant on one pair. Unknown values are empty cells.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairRecord {
    /// Variant name.
    pub variant: String,
    /// Pair index in the run.
    pub pair: usize,
    /// Scan k.
    pub source: usize,
    /// Scan k+1.
    pub reference: usize,
    /// Time between the scans, s.
    pub dt_s: f64,
    /// `ok`, `degenerate`, `no_overlap` or `failed` (see [`PairStatus`]); every status but
    /// `ok` is a failure of the variant on the pair.
    pub status: StatusKind,
    /// Why the status is not `ok`, with its figures (empty when it is).
    pub status_reason: String,
    /// Whether every variant of the run registered the pair (flagged or not): the statistics
    /// of every variant are taken over these pairs only, so they compare.
    pub all_registered: bool,
    /// The initial-guess mode whose start gave this registration (empty: an external
    /// estimate, not started here).
    pub init: Option<InitMode>,
    /// Registrations made along the init chain for this one (the last is kept; 0 for an
    /// external estimate).
    pub init_attempts: usize,
    /// Whether the mean pair distance settled (empty: not registered, or an external
    /// estimate, which is not iterated here).
    pub converged: Option<bool>,
    /// Minimisation steps (empty: not registered, or an external estimate).
    pub iterations: Option<usize>,
    /// Pairs the metric used at the solution.
    pub n_pairs: usize,
    /// Pairs the metric could not use at the solution (no surface estimate, beyond its gate).
    pub n_unusable: usize,
    /// Sum of the final weights.
    pub weight_sum: Option<f64>,
    /// Final mean residual of the metric, m (the pair distance for point-to-point).
    pub mean_residual_m: Option<f64>,
    /// Registered `t_ref_src`: translation x, m.
    pub tx_m: Option<f64>,
    /// Registered `t_ref_src`: translation y, m.
    pub ty_m: Option<f64>,
    /// Registered `t_ref_src`: rotation, degrees.
    pub theta_deg: Option<f64>,
    /// Estimated SOG, m/s.
    pub sog_est_mps: Option<f64>,
    /// Reference SOG, m/s.
    pub sog_ref_mps: Option<f64>,
    /// SOG error (estimate − reference), m/s.
    pub sog_err_mps: Option<f64>,
    /// Estimated ΔCOG (heading change, clockwise positive), degrees.
    pub dcog_est_deg: Option<f64>,
    /// Reference ΔCOG, degrees.
    pub dcog_ref_deg: Option<f64>,
    /// ΔCOG error, degrees, wrapped to (−180, 180].
    pub dcog_err_deg: Option<f64>,
    /// Estimated heading after the step, HDG₀ + ΔCOG with HDG₀ the reference heading at the
    /// source scan, degrees in [0, 360), clockwise (its error is the ΔCOG error).
    pub hdg_est_deg: Option<f64>,
    /// Reference heading at the reference scan, degrees, clockwise.
    pub hdg_ref_deg: Option<f64>,
    /// Error of the heading dead-reckoned from the first pair's reference heading through this
    /// variant's ΔCOG estimates (a pair not registered adds 0), degrees, wrapped: how heading
    /// error accumulates without a compass.
    pub hdg_chained_err_deg: Option<f64>,
    /// Estimated rate of turn, °/s.
    pub rot_est_dps: Option<f64>,
    /// Reference rate of turn, °/s.
    pub rot_ref_dps: Option<f64>,
    /// ‖t_est − t_true‖ of `t_ref_src`, m, where the reference is a rigid 2D pose.
    pub trans_err_m: Option<f64>,
    /// Rotation error of `t_ref_src`, degrees, where the reference is a rigid 2D pose.
    pub rot_err_deg: Option<f64>,
    /// The pair's global search (when results are checked): its best score on the reference's
    /// likelihood grid, in [0, 1].
    pub global_best_score: Option<f64>,
    /// The registration's score on the same grid.
    pub global_result_score: Option<f64>,
    /// Distance from the registration to the search's best pose, m.
    pub global_apart_m: Option<f64>,
    /// Rotation between them, degrees.
    pub global_apart_deg: Option<f64>,
    /// Conditioning of the registration: smallest over largest eigenvalue of its Hessian
    /// (below `icp_core::quality::DEGENERATE_RATIO` the pair is flagged `degenerate`).
    pub cond_ratio: Option<f64>,
    /// Fraction of the final pairs closer than `icp_core::quality::OVERLAP_GATE_M` (below
    /// `icp_core::quality::MIN_OVERLAP` the pair is flagged `no overlap`).
    pub overlap: Option<f64>,
    /// The pair's Cramér–Rao bound (see [`crate::bound`]): square root of the trace of its
    /// translation block, m; empty where the dataset has no true normals or the motion is
    /// unobservable in some direction.
    pub bound_trans_m: Option<f64>,
    /// The bound's rotation standard deviation, degrees.
    pub bound_rot_deg: Option<f64>,
    /// False when the reference step is flagged as implausible (or absent).
    pub ref_plausible: bool,
    /// The covariance of this row's `tx_m`, `ty_m` and θ in radians (see
    /// [`crate::consistency`]): `bounded`, `unbounded` (a direction the pairs leave
    /// unconstrained: the `cov_*` cells are empty) or empty (none: `--covariance off`, or
    /// the closed form of a point-to-point variant).
    #[serde(default)]
    pub cov_status: String,
    /// Covariance of `tx`, m².
    #[serde(default)]
    pub cov_xx_m2: Option<f64>,
    /// Covariance of `tx` and `ty`, m².
    #[serde(default)]
    pub cov_xy_m2: Option<f64>,
    /// Covariance of `tx` and θ, m·rad.
    #[serde(default)]
    pub cov_xt_m_rad: Option<f64>,
    /// Covariance of `ty`, m².
    #[serde(default)]
    pub cov_yy_m2: Option<f64>,
    /// Covariance of `ty` and θ, m·rad.
    #[serde(default)]
    pub cov_yt_m_rad: Option<f64>,
    /// Variance of θ, rad².
    #[serde(default)]
    pub cov_tt_rad2: Option<f64>,
    /// Standard error of the SOG estimate, m/s (first order through eq. 23).
    #[serde(default)]
    pub sog_sigma_mps: Option<f64>,
    /// Standard error of the ΔCOG estimate, degrees (eq. 24).
    #[serde(default)]
    pub dcog_sigma_deg: Option<f64>,
    /// Standard error of the ROT estimate, °/s (eq. 25).
    #[serde(default)]
    pub rot_sigma_dps: Option<f64>,
    /// NEES of `(tx, ty, θ)` against the reference, where it is a rigid pose.
    #[serde(default)]
    pub nees: Option<f64>,
    /// Wall time of the registration, its scans' surface estimates aside, µs (not
    /// reproducible; last column so checks can drop it; empty for an external estimate).
    pub time_us: Option<f64>,
}

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
    /// Fraction of the run's pairs registered within [`outcome::SUCCESS_TRANS_M`] and
    /// [`outcome::SUCCESS_ROT_DEG`] of the reference, flagged or not (a pair not registered is
    /// not a success), where the reference is a rigid pose.
    #[serde(default)]
    pub success_rate: Option<f64>,
    /// How well the flags pick out the wrong numbers, where the reference is a rigid pose.
    #[serde(default)]
    pub flag_quality: Option<FlagQuality>,
    /// The chained trajectory.
    pub trajectory: TrajectoryStats,
    /// Translation and rotation RMSE as multiples of the Cramér–Rao bound over the registered
    /// pairs that have one (synthetic data with true normals).
    #[serde(default)]
    pub over_bound: Option<OverBound>,
    /// Wall time per registration.
    pub timing: Option<Timing>,
    /// Whether the covariances are honest: NEES against a rigid reference, standardised
    /// SOG and ΔCOG errors (see [`crate::consistency`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub consistency: Option<ConsistencySummary>,
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
    /// ([`crate::start_gate`]); empty when no registration starts close.
    #[serde(default)]
    pub start_gated: Vec<(String, f64)>,
    /// Where each registration's covariance came from.
    #[serde(default)]
    pub covariance: CovarianceMode,
    /// The external estimators evaluated after the variants (`--estimates`), with their
    /// files' SHA-256 (see [`crate::estimates`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub estimates: Vec<ExternalSource>,
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
}

/// What to evaluate.
pub struct EvalSetup {
    /// The registration methods, in order: built-in or configured chains, or written in user
    /// code (each reports what it is through [`Registrar::spec`]).
    pub variants: Vec<Box<dyn Registrar>>,
    /// Reference time alignment.
    pub offset: OffsetChoice,
    /// Whether reference steps are tested for plausibility.
    pub reference_checks: ReferenceChecks,
    /// Where each registration starts.
    pub init: InitChain,
    /// The global search's parameters (for `--init global` and the result checks).
    pub global: GlobalParams,
    /// Whether every result is checked against the pair's global search (a result far from a
    /// clearly better pose is flagged suspect).
    pub global_check: GlobalChecks,
    /// How registrations started close to the motion gate their correspondences.
    pub start_gate: StartGate,
    /// Where each registration's covariance comes from.
    pub covariance: CovarianceMode,
    /// Estimates made elsewhere, evaluated after the variants like one more variant each
    /// (see [`crate::estimates`]).
    pub estimates: Vec<ExternalEstimates>,
}

/// Whether registrations are checked against a global search of their pair.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum GlobalChecks {
    /// Every result is scored on the reference's likelihood grid against the search's best.
    On,
    /// No search is made for the check (the paper's run).
    #[default]
    Off,
}

impl EvalSetup {
    /// The chains `specs` describe, built, with the reference alignment `offset` and the
    /// reference checks on.
    pub fn from_specs(specs: &[VariantSpec], offset: OffsetChoice) -> Result<Self, ConfigError> {
        Ok(Self {
            variants: specs
                .iter()
                .map(|s| Ok(Box::new(s.build()?) as Box<dyn Registrar>))
                .collect::<Result<_, ConfigError>>()?,
            offset,
            reference_checks: ReferenceChecks::On,
            init: InitChain::default(),
            global: GlobalParams::default(),
            global_check: GlobalChecks::Off,
            start_gate: StartGate::default(),
            covariance: CovarianceMode::Off,
            estimates: Vec::new(),
        })
    }

    /// The same setup with the external estimates `estimates` (evaluated after the variants).
    pub fn with_estimates(mut self, estimates: Vec<ExternalEstimates>) -> Self {
        self.estimates = estimates;
        self
    }

    /// The methods the runner runs: the variants (with `close`, their close-start twins from
    /// [`Self::close_start_variants`]), then the external estimates.
    pub fn methods<'a>(
        &'a self,
        close: &'a [Option<Box<dyn Registrar>>],
    ) -> crate::runner::Methods<'a> {
        crate::runner::Methods {
            registrars: &self.variants,
            close,
            external: &self.estimates,
        }
    }

    /// The names of the methods, in the order of their results: the variants, then the
    /// external estimators.
    pub fn method_names(&self) -> Vec<&str> {
        self.variants
            .iter()
            .map(|v| v.name())
            .chain(self.estimates.iter().map(|e| e.source.name.as_str()))
            .collect()
    }

    /// The same setup with the correspondence gate `gate` of registrations started at the
    /// global search.
    pub fn with_start_gate(mut self, gate: StartGate) -> Self {
        self.start_gate = gate;
        self
    }

    /// Per variant, the spec a close start (the global search's pose or the reference,
    /// [`InitMode::is_close`]) runs instead of it, when the chain has such starts and they are
    /// gated ([`crate::start_gate`]); empty when none is.
    /// A variant with a stage written in user code (its spec does not build) runs as it is.
    pub fn close_start_specs(&self) -> Result<Vec<Option<VariantSpec>>, ConfigError> {
        let Some(gate_m) = self
            .init
            .close_starts()
            .then(|| self.start_gate.metres(&self.global))
            .flatten()
        else {
            return Ok(Vec::new());
        };
        self.variants
            .iter()
            .map(|v| {
                let spec = v.spec();
                match spec.build() {
                    Ok(_) => start_gate::gated(&spec, gate_m),
                    Err(_) => Ok(None),
                }
            })
            .collect()
    }

    /// Per variant, the registrar a close start runs instead of it (built from
    /// [`Self::close_start_specs`]), for the runner's plan.
    pub fn close_start_variants(&self) -> Result<Vec<Option<Box<dyn Registrar>>>, ConfigError> {
        self.close_start_specs()?
            .into_iter()
            .map(|s| {
                s.map(|s| Ok(Box::new(s.build()?) as Box<dyn Registrar>))
                    .transpose()
            })
            .collect()
    }

    /// The same setup with the covariances of `mode`.
    pub fn with_covariance(mut self, mode: CovarianceMode) -> Self {
        self.covariance = mode;
        self
    }

    /// The same setup with the global search's parameters `global` and checks `check`.
    pub fn with_global(mut self, global: GlobalParams, check: GlobalChecks) -> Self {
        self.global = global;
        self.global_check = check;
        self
    }

    /// The same setup with the initial guesses of `init`.
    pub fn with_init(mut self, init: InitChain) -> Self {
        self.init = init;
        self
    }

    /// The same setup with the reference checks `checks`.
    pub fn with_reference_checks(mut self, checks: ReferenceChecks) -> Self {
        self.reference_checks = checks;
        self
    }
}

/// Builds the report from the runs.
pub fn build(
    ds: &Dataset,
    pairs: &[ScanPair],
    skipped: Vec<SkippedPair>,
    setup: &EvalSetup,
    all_runs: &Runs,
) -> RunReport {
    let runs = &all_runs.per_variant;
    let dts: Vec<f64> = pairs.iter().map(|p| ds.pair_dt_s(*p)).collect();
    let estimates: Vec<Vec<Option<MovementParams>>> = runs
        .iter()
        .map(|rs| {
            rs.iter()
                .zip(pairs.iter().zip(&dts))
                .map(|(r, (p, &dt))| {
                    let reg = r.result.as_ref().ok()?;
                    let hdg0 = reference::motion(ds, p.source, p.reference, dt)
                        .map_or(0.0, |m| m.hdg0_deg);
                    MovementParams::from_registration(&reg.t_ref_src, dt, hdg0, ds.bearing_sense)
                        .ok()
                })
                .collect()
        })
        .collect();

    // The reference at lag 0, and the offset estimate.
    let ref_at = |lag: i64| -> Vec<Option<reference::RefMotion>> {
        pairs
            .iter()
            .zip(&dts)
            .map(|(p, &dt)| {
                let a = usize::try_from(p.source as i64 + lag).ok()?;
                let b = usize::try_from(p.reference as i64 + lag).ok()?;
                reference::motion(ds, a, b, dt)
            })
            .collect()
    };
    let ref0 = ref_at(0);
    // The offset is estimated from the per-pair median of the variants' estimates: no variant
    // is singled out by name, and one variant's failures do not move it. External estimates
    // are left out: adding one changes no built-in variant's figures through the offset.
    let series = |f: &dyn Fn(&MovementParams) -> f64| -> Vec<f64> {
        (0..pairs.len())
            .map(|i| {
                let mut v: Vec<f64> = estimates[..setup.variants.len()]
                    .iter()
                    .filter_map(|e| e[i].as_ref().map(f))
                    .collect();
                v.sort_by(f64::total_cmp);
                if v.is_empty() {
                    f64::NAN
                } else {
                    crate::stats::quantile_sorted(&v, 0.5)
                }
            })
            .collect()
    };
    let ref_series = |f: &dyn Fn(&reference::RefMotion) -> f64| -> Vec<f64> {
        ref0.iter()
            .map(|m| m.as_ref().map_or(f64::NAN, f))
            .collect()
    };
    let offset_estimate = reference::estimate_offset(
        &series(&|m| m.sog_mps),
        &series(&|m| m.dcog_deg),
        &ref_series(&|m| m.sog_mps),
        &ref_series(&|m| m.dcog_deg),
        ds.dt_s,
    );
    let applied = match setup.offset {
        OffsetChoice::Fixed(n) => n,
        OffsetChoice::Auto => offset_estimate.map_or(0, |o| o.scans),
    };
    let refs = ref_at(applied);
    let ref_sog: Vec<f64> = refs
        .iter()
        .map(|m| m.map_or(f64::NAN, |m| m.sog_mps))
        .collect();
    let ref_rot: Vec<f64> = refs
        .iter()
        .zip(&dts)
        .map(|(m, dt)| m.map_or(f64::NAN, |m| m.dcog_deg / dt))
        .collect();
    let flagged = match (&ds.reference, setup.reference_checks) {
        (Some(_), ReferenceChecks::On) => reference::flag_implausible(pairs, &ref_sog, &ref_rot),
        _ => Vec::new(),
    };
    let plausible: Vec<bool> = (0..pairs.len())
        .map(|i| ds.reference.is_some() && !flagged.iter().any(|f| f.pair == i))
        .collect();

    let bounds = bound::pair_bounds(ds, pairs, &ref0);
    let all_registered: Vec<bool> = (0..pairs.len())
        .map(|i| runs.iter().all(|rs| rs[i].result.is_ok()))
        .collect();
    let rigid = ds.rigid_reference();
    let (reference_trajectory, reference_tum) =
        crate::evo::reference_trajectory(ds, pairs, applied);
    let mut records = Vec::new();
    let mut summaries = Vec::new();
    let mut trajectories = Vec::new();
    for (vi, name) in setup.method_names().into_iter().enumerate() {
        let mut rows = Vec::with_capacity(pairs.len());
        let chained = chained_heading_errors(pairs, &estimates[vi], &refs);
        // An external estimate has no covariance: no inflation of one.
        let inflation = setup.variants.get(vi).map_or(1.0, |v| {
            consistency::closed_form_inflation(&v.spec().metric)
        });
        for (i, (pair, run)) in pairs.iter().zip(&runs[vi]).enumerate() {
            rows.push(record(
                name,
                i,
                *pair,
                dts[i],
                run,
                all_registered[i],
                estimates[vi][i],
                refs[i],
                bounds[i],
                plausible[i],
            ));
            rows[i].hdg_chained_err_deg = chained[i];
            consistency::fill(
                &mut rows[i],
                run.result.as_ref().ok(),
                refs[i].and_then(|r| r.t_ref_src),
                setup.covariance,
                inflation,
            );
        }
        trajectories.push(chain(ds, pairs, &runs[vi]));
        summaries.push(summarize(
            name,
            &rows,
            &runs[vi],
            ds,
            pairs,
            trajectories.last().expect("just pushed"),
            rigid,
        ));
        if let (Some(kind), Some(summary)) = (reference_tum, summaries.last_mut()) {
            let traj = trajectories.last().expect("just pushed");
            let evo = crate::evo::evo_metrics(traj, &reference_trajectory, kind);
            summary.trajectory.ate_rmse_m = evo.as_ref().map(|e| e.ate_trans_m.rmse);
            summary.trajectory.evo = evo;
        }
        // An external estimate has no covariance to judge.
        if let Some(last) = summaries.last_mut().filter(|_| vi < setup.variants.len()) {
            last.consistency = consistency::summarize(
                &rows,
                setup.covariance,
                inflation,
                // Ground truth carries no noise of its own to estimate.
                if rigid {
                    None
                } else {
                    consistency::reference_noise(&rows)
                },
            );
        }
        records.extend(rows);
    }
    RunReport {
        schema_version: SCHEMA_VERSION,
        tool: format!("icp-eval {}", env!("CARGO_PKG_VERSION")),
        dataset: DatasetInfo {
            name: ds.provenance.name.clone(),
            description: ds.provenance.description.clone(),
            files: ds.provenance.files.clone(),
            scans: ds.scans.len(),
            pairs: pairs.len(),
            skipped_pairs: skipped,
            dt_s: ds.dt_s,
            bearing_sense: ds.bearing_sense,
            reference_heading_sense: ds.reference_heading_sense,
            reference_kind: ds.reference_kind,
            warnings: ds.warnings.clone(),
            sensor: Some(ds.sensor),
            odometry: ds.odometry.is_some(),
            scanner_offset: ds.scanner_offset,
        },
        config: RunConfig {
            variants: setup.variants.iter().map(|v| v.spec()).collect(),
            init: setup.init.clone(),
            global: setup.global,
            global_check: setup.global_check,
            start_gate: setup.start_gate,
            covariance: setup.covariance,
            estimates: setup.estimates.iter().map(|e| e.source.clone()).collect(),
            start_gated: setup
                .close_start_specs()
                .unwrap_or_default()
                .into_iter()
                .flatten()
                .filter_map(|s| {
                    Some((
                        s.name.clone(),
                        s.metric.params.get("max_pair_distance_m")?.as_f64()?,
                    ))
                })
                .collect(),
        },
        reference: ReferenceInfo {
            available: ds.reference.is_some(),
            rigid_pose: rigid,
            offset_estimate,
            offset_choice: setup.offset,
            offset_applied_scans: applied,
            offset_from_variant: (!setup.variants.is_empty()).then(|| {
                let names: Vec<&str> = setup.variants.iter().map(|v| v.name()).collect();
                format!("the per-pair median of {}", names.join(", "))
            }),
            plausible_pairs: plausible.iter().filter(|&&p| p).count(),
            checks: setup.reference_checks,
            flagged_pairs: flagged,
            reference_tum,
        },
        bound: bound::summarize(&bounds),
        population: Population {
            pairs: all_registered.iter().filter(|&&a| a).count(),
            left_out: (0..pairs.len()).filter(|&i| !all_registered[i]).collect(),
        },
        variants: summaries,
        preparation: median_p95(&all_runs.prepare_us)
            .map(|(median_us, p95_us)| Timing { median_us, p95_us }),
        global_search: (!all_runs.searches.is_empty()).then(|| SearchSummary {
            pairs: all_runs.searches.len(),
            failures: all_runs
                .searches
                .iter()
                .enumerate()
                .filter_map(|(i, s)| {
                    s.result.as_ref().err().map(|e| Failure {
                        pair: i,
                        reason: e.to_string(),
                    })
                })
                .collect(),
            timing: median_p95(
                &all_runs
                    .searches
                    .iter()
                    .map(|s| s.time_us)
                    .collect::<Vec<_>>(),
            )
            .map(|(median_us, p95_us)| Timing { median_us, p95_us }),
        }),
        pairs: records,
        trajectories,
        reference_trajectory,
    }
}

#[allow(clippy::too_many_arguments)]
fn record(
    variant: &str,
    i: usize,
    pair: ScanPair,
    dt_s: f64,
    run: &PairRun,
    all_registered: bool,
    est: Option<MovementParams>,
    reference: Option<reference::RefMotion>,
    bound: Option<PairBound>,
    plausible: bool,
) -> PairRecord {
    let reg = run.result.as_ref().ok();
    let both = |f: &dyn Fn(&MovementParams, &reference::RefMotion) -> f64| {
        Some(f(est.as_ref()?, reference.as_ref()?))
    };
    let truth_err = reg
        .zip(reference.and_then(|r| r.t_ref_src))
        .map(|(reg, truth)| {
            let dt = (reg.t_ref_src.translation.vector - truth.translation.vector).norm();
            let dr =
                wrap_deg((reg.t_ref_src.rotation.angle() - truth.rotation.angle()).to_degrees());
            (dt, dr)
        });
    PairRecord {
        variant: variant.to_owned(),
        pair: i,
        source: pair.source,
        reference: pair.reference,
        dt_s,
        status: run.status.kind(),
        status_reason: run.status.to_string(),
        all_registered,
        init: run.init,
        init_attempts: run.attempts,
        converged: reg.filter(|r| r.iterated()).map(|r| r.converged()),
        iterations: reg.filter(|r| r.iterated()).map(|r| r.iterations),
        n_pairs: reg.map_or(0, |r| r.n_pairs),
        n_unusable: reg.map_or(0, |r| r.n_unusable),
        weight_sum: reg.map(|r| r.weight_sum),
        mean_residual_m: reg.map(|r| r.mean_residual_m),
        tx_m: reg.map(|r| r.t_ref_src.translation.x),
        ty_m: reg.map(|r| r.t_ref_src.translation.y),
        theta_deg: reg.map(|r| r.t_ref_src.rotation.angle().to_degrees()),
        sog_est_mps: est.map(|m| m.sog_mps),
        sog_ref_mps: reference.map(|r| r.sog_mps),
        sog_err_mps: both(&|m, r| m.sog_mps - r.sog_mps),
        dcog_est_deg: est.map(|m| m.dcog_deg),
        dcog_ref_deg: reference.map(|r| r.dcog_deg),
        dcog_err_deg: both(&|m, r| wrap_deg(m.dcog_deg - r.dcog_deg)),
        hdg_est_deg: est.filter(|_| reference.is_some()).map(|m| m.hdg_deg),
        hdg_ref_deg: reference.map(|r| r.hdg1_deg),
        hdg_chained_err_deg: None,
        rot_est_dps: est.map(|m| m.rot_dps),
        rot_ref_dps: reference.map(|r| r.dcog_deg / dt_s),
        global_best_score: run.check.map(|c| c.best_score),
        global_result_score: run.check.map(|c| c.result_score),
        global_apart_m: run.check.and_then(|c| c.apart()).map(|a| a.0),
        global_apart_deg: run.check.and_then(|c| c.apart()).map(|a| a.1),
        cond_ratio: reg.and_then(|r| r.conditioning).map(|c| c.ratio),
        overlap: reg.map(|r| r.overlap),
        trans_err_m: truth_err.map(|e| e.0),
        rot_err_deg: truth_err.map(|e| e.1),
        bound_trans_m: bound.and_then(|b| b.trans_m()),
        bound_rot_deg: bound.and_then(|b| b.rot_deg()),
        ref_plausible: plausible,
        cov_status: String::new(),
        cov_xx_m2: None,
        cov_xy_m2: None,
        cov_xt_m_rad: None,
        cov_yy_m2: None,
        cov_yt_m_rad: None,
        cov_tt_rad2: None,
        sog_sigma_mps: None,
        dcog_sigma_deg: None,
        rot_sigma_dps: None,
        nees: None,
        time_us: run.time_us,
    }
}

fn error_stats<'a>(rows: impl Iterator<Item = &'a PairRecord> + Clone) -> ErrorStats {
    let col = |f: fn(&PairRecord) -> Option<f64>| -> Option<Stats> {
        let v: Vec<f64> = rows.clone().filter_map(f).collect();
        Stats::of(&v)
    };
    ErrorStats {
        pairs: rows.clone().count(),
        sog_err_mps: col(|r| r.sog_err_mps),
        dcog_err_deg: col(|r| r.dcog_err_deg),
        trans_err_m: col(|r| r.trans_err_m),
        rot_err_deg: col(|r| r.rot_err_deg),
    }
}

fn summarize(
    name: &str,
    rows: &[PairRecord],
    runs: &[PairRun],
    ds: &Dataset,
    pairs: &[ScanPair],
    traj: &[(f64, Isometry2<f64>)],
    rigid: bool,
) -> VariantSummary {
    let ok = rows.iter().filter(|r| r.status == StatusKind::Ok).count();
    // Every variant's figures over the same pairs: those every variant registered.
    let common: Vec<&PairRecord> = rows.iter().filter(|r| r.all_registered).collect();
    let with_ref = common.iter().copied().filter(|r| r.sog_ref_mps.is_some());
    let times: Vec<f64> = runs.iter().filter_map(|r| r.time_us).collect();
    let failures: Vec<Failure> = runs
        .iter()
        .enumerate()
        .filter_map(|(i, r)| {
            r.result.as_ref().err().map(|e| Failure {
                pair: i,
                reason: e.to_string(),
            })
        })
        .collect();
    let fraction = |n: usize, of: usize| if of == 0 { 0.0 } else { n as f64 / of as f64 };
    // An external estimator's runs are not started here (and not iterated).
    let iterated = runs.iter().any(|r| r.init.is_some());
    VariantSummary {
        name: name.to_owned(),
        pairs_ok: ok,
        failure_rate: fraction(rows.len() - ok, rows.len()),
        converged_fraction: iterated.then(|| {
            fraction(
                common.iter().filter(|r| r.converged == Some(true)).count(),
                common.len(),
            )
        }),
        iterations_mean: iterated.then(|| {
            fraction(
                common.iter().filter_map(|r| r.iterations).sum(),
                common.len(),
            )
        }),
        iterations_max: iterated.then(|| {
            common
                .iter()
                .filter_map(|r| r.iterations)
                .max()
                .unwrap_or(0)
        }),
        all_pairs: error_stats(with_ref.clone()),
        plausible_reference: error_stats(with_ref.filter(|r| r.ref_plausible)),
        success_rate: outcome::success_rate(rows, rigid),
        flag_quality: FlagQuality::of(rows),
        degenerate_pairs: flagged(rows, StatusKind::Degenerate),
        no_overlap_pairs: flagged(rows, StatusKind::NoOverlap),
        suspect_pairs: flagged(rows, StatusKind::Suspect),
        trajectory: TrajectoryStats {
            heading_rms_error_deg: {
                let e: Vec<f64> = rows.iter().filter_map(|r| r.hdg_chained_err_deg).collect();
                (!e.is_empty())
                    .then(|| (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt())
            },
            heading_end_error_deg: rows.last().and_then(|r| r.hdg_chained_err_deg),
            ..trajectory_stats(ds, pairs, traj, failures.len())
        },
        over_bound: OverBound::of(common.iter().filter_map(|r| {
            let bound = PairBound::Bounded {
                trans_m: r.bound_trans_m?,
                rot_deg: r.bound_rot_deg?,
            };
            Some((r.trans_err_m?, r.rot_err_deg?, bound))
        })),
        timing: median_p95(&times).map(|(median_us, p95_us)| Timing { median_us, p95_us }),
        failures,
        consistency: None,
    }
}

/// The pairs whose status is `kind`.
fn flagged(rows: &[PairRecord], kind: StatusKind) -> Vec<usize> {
    rows.iter()
        .filter(|r| r.status == kind)
        .map(|r| r.pair)
        .collect()
}

/// Per pair, the error of the heading dead-reckoned through the ΔCOG `estimates` (a pair
/// without one adds 0) from the reference heading at the first pair's source scan, against
/// the reference heading at each pair's reference scan; restarted from the reference where the
/// pairs are not consecutive. `None` without a reference.
fn chained_heading_errors(
    pairs: &[ScanPair],
    estimates: &[Option<MovementParams>],
    refs: &[Option<reference::RefMotion>],
) -> Vec<Option<f64>> {
    let mut heading: Option<f64> = None;
    let mut previous: Option<ScanPair> = None;
    pairs
        .iter()
        .zip(estimates.iter().zip(refs))
        .map(|(pair, (est, reference))| {
            let reference = reference.as_ref()?;
            let consecutive = previous.is_some_and(|p| p.reference == pair.source);
            previous = Some(*pair);
            let start = match heading {
                Some(h) if consecutive => h,
                _ => reference.hdg0_deg,
            };
            let h = start + est.map_or(0.0, |m| m.dcog_deg);
            heading = Some(h);
            Some(wrap_deg(h - reference.hdg1_deg))
        })
        .collect()
}

/// The time of scan `k` on the trajectories' clock: its timestamp, else `k` nominal steps.
pub fn scan_time_s(ds: &Dataset, k: usize) -> f64 {
    ds.scans[k].timestamp_s().unwrap_or(k as f64 * ds.dt_s)
}

/// Chains the registrations into scanner poses `t_world_scan`, starting at the reference pose
/// of the first scan when it is a rigid pose (else at the origin). A failed pair is bridged by
/// the identity and counted as a gap.
fn chain(ds: &Dataset, pairs: &[ScanPair], runs: &[PairRun]) -> Vec<(f64, Isometry2<f64>)> {
    let Some(first) = pairs.first() else {
        return Vec::new();
    };
    let start = ds
        .reference
        .as_ref()
        .and_then(|r| r[first.source].scan_pose())
        .unwrap_or_else(Isometry2::identity);
    let time = |k: usize| scan_time_s(ds, k);
    let mut poses = vec![(time(first.source), start)];
    let mut pose = start;
    for (pair, run) in pairs.iter().zip(runs) {
        if let Ok(reg) = &run.result {
            pose *= reg.t_ref_src.inverse();
        }
        poses.push((time(pair.reference), pose));
    }
    poses
}

fn trajectory_stats(
    ds: &Dataset,
    pairs: &[ScanPair],
    traj: &[(f64, Isometry2<f64>)],
    gaps: usize,
) -> TrajectoryStats {
    let length_m = traj
        .windows(2)
        .map(|w| (w[1].1.translation.vector - w[0].1.translation.vector).norm())
        .sum();
    let contiguous = pairs.windows(2).all(|w| w[0].reference == w[1].source);
    let truth: Option<Vec<Isometry2<f64>>> = ds.reference.as_ref().and_then(|r| {
        let first = pairs.first()?;
        std::iter::once(first.source)
            .chain(pairs.iter().map(|p| p.reference))
            .map(|k| r[k].scan_pose())
            .collect()
    });
    let (end_point_error_m, drift_m_per_100m, note) = match (truth, contiguous) {
        (Some(t), true) if t.len() == traj.len() && !t.is_empty() => {
            let ref_len: f64 = t
                .windows(2)
                .map(|w| (w[1].translation.vector - w[0].translation.vector).norm())
                .sum();
            let end = (traj[traj.len() - 1].1.translation.vector
                - t[t.len() - 1].translation.vector)
                .norm();
            (
                Some(end),
                (ref_len > 0.0).then(|| 100.0 * end / ref_len),
                None,
            )
        }
        (Some(_), _) => (None, None, Some("the pairs are not contiguous".to_owned())),
        (None, _) => (
            None,
            None,
            Some("the reference is not a rigid 2D pose of the scanner".to_owned()),
        ),
    };
    TrajectoryStats {
        length_m,
        gaps,
        end_point_error_m,
        drift_m_per_100m,
        note,
        heading_rms_error_deg: None,
        heading_end_error_deg: None,
        ate_rmse_m: None,
        evo: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dead_reckoned_heading_by_hand() {
        let pair = |k: usize| ScanPair {
            source: k,
            reference: k + 1,
        };
        let reference = |h0: f64, h1: f64| {
            Some(reference::RefMotion {
                sog_mps: 1.0,
                dcog_deg: wrap_deg(h1 - h0),
                hdg0_deg: h0,
                hdg1_deg: h1,
                t_ref_src: None,
            })
        };
        let est = |dcog_deg: f64| {
            Some(MovementParams {
                sog_mps: 1.0,
                dcog_deg,
                rot_dps: dcog_deg,
                hdg_deg: 0.0,
            })
        };
        // Truth turns 10° per step from 355°; the estimates say 11°, nothing (failed), 10°;
        // then a gap (pair 5→6) restarts from the reference.
        let pairs = [pair(0), pair(1), pair(2), pair(5)];
        let refs = [
            reference(355.0, 5.0),
            reference(5.0, 15.0),
            reference(15.0, 25.0),
            reference(45.0, 55.0),
        ];
        let estimates = [est(11.0), None, est(10.0), est(12.0)];
        let e = chained_heading_errors(&pairs, &estimates, &refs);
        let expected = [1.0, -9.0, -9.0, 2.0];
        for (got, want) in e.iter().zip(expected) {
            assert!((got.unwrap() - want).abs() < 1e-9, "{e:?}");
        }
        assert_eq!(
            chained_heading_errors(&pairs[..1], &[est(1.0)], &[None]),
            vec![None]
        );
    }
}
