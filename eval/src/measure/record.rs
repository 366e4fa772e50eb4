//! One record per variant and pair: the bottom of every measure. [`record`] makes it from a
//! registration, its movement parameters and the reference's; every statistic, check and
//! output is computed from these.

use datasets::ScanPair;
use icp_core::motion::{wrap_deg, MovementParams};
use serde::{Deserialize, Serialize};

use crate::data::RefMotion;
use crate::measure::bound::PairBound;
use crate::run::init::InitMode;
use crate::run::left_out::Confusion;
use crate::run::runner::PairRun;
use crate::run::status::StatusKind;

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
    /// `ok`, `degenerate`, `no_overlap` or `failed` (see [`crate::run::status::PairStatus`]); every status but
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
    /// Minimisation steps (empty: not registered, or an external estimate); for a pair
    /// registered again without its moving returns, the steps of every registration.
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
    /// The pair's Cramér–Rao bound (see [`crate::measure::bound`]): square root of the trace of its
    /// translation block, m; empty where the dataset has no true normals or the motion is
    /// unobservable in some direction.
    pub bound_trans_m: Option<f64>,
    /// The bound's rotation standard deviation, degrees.
    pub bound_rot_deg: Option<f64>,
    /// False when the reference step is flagged as implausible (or absent).
    pub ref_plausible: bool,
    /// The covariance of this row's `tx_m`, `ty_m` and θ in radians (see
    /// the `consistency` module): `bounded`, `unbounded` (a direction the pairs leave
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
    /// The same with the reference's own step covariance added, where the reference is a
    /// measured rigid pose (in `summary.json` only, not a `pairs.csv` column).
    #[serde(skip)]
    pub nees_with_reference_noise: Option<f64>,
    /// Returns of the source scan its variant's detector of moving returns left out of the
    /// registration (empty: the variant has no detector; see `crate::run::moving`).
    #[serde(default)]
    pub left_out_src: Option<usize>,
    /// …of the reference scan.
    #[serde(default)]
    pub left_out_ref: Option<usize>,
    /// The source scan's detection scored against its truth labels, where it has them (in
    /// `summary.json` only, not a `pairs.csv` column).
    #[serde(skip)]
    pub left_out_truth: Option<Confusion>,
    /// Wall time of the registration, its scans' surface estimates aside, µs (not
    /// reproducible; last column so checks can drop it; empty for an external estimate).
    pub time_us: Option<f64>,
}

#[allow(clippy::too_many_arguments)]
pub fn record(
    variant: &str,
    i: usize,
    pair: ScanPair,
    dt_s: f64,
    run: &PairRun,
    all_registered: bool,
    est: Option<MovementParams>,
    reference: Option<RefMotion>,
    bound: Option<PairBound>,
    plausible: bool,
) -> PairRecord {
    let reg = run.result.as_ref().ok();
    let both = |f: &dyn Fn(&MovementParams, &RefMotion) -> f64| {
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
        nees_with_reference_noise: None,
        left_out_src: run.left_out.as_ref().map(|l| l.source),
        left_out_ref: run.left_out.as_ref().map(|l| l.reference),
        left_out_truth: run.left_out.as_ref().and_then(|l| l.source_truth),
        time_us: run.time_us,
    }
}
