//! Vessel motion from the whole scan sequence: a smoother over every scan's pose and body twist
//! (issue 35).
//!
//! # Model
//! The state of scan k is its pose `T_k = t_world_body` as `(x m, y m, θ rad)` (scan 0 is the
//! identity and fixes the frame), its body twist `ϖ_k = (surge m/s, sway m/s, yaw rad/s)` and
//! its error `e_k` (below). Three kinds of factor:
//! - each registration `source → reference` at any lag, whose `t_ref_src` parameters
//!   `(x, y, θ)` are predicted by `(T_reference + e_reference)⁻¹ (T_source + e_source)` (the
//!   frames of [`crate::motion`]), with its own part of the registration's 3×3 covariance,
//!   through a Huber loss on the Mahalanobis distance (threshold [`SmootherOptions::huber_k`]);
//! - between consecutive scans, the white-noise-on-acceleration prior of Barfoot, Tong &
//!   Särkkä (2014) as in STEAM: `e = [Log(T_k⁻¹T_k+1) − Δt·ϖ_k ; ϖ_k+1 − ϖ_k]` with covariance
//!   `Q = [[Δt³/3, Δt²/2], [Δt²/2, Δt]] ⊗ Qc`, `Qc = diag(q_surge, q_sway, q_yaw)`, over each
//!   pair's actual Δt (a missing scan is bridged by a longer Δt, whose Q grows as Δt³); or,
//!   as an option ([`MotionPrior::WhiteJerk`]), white noise on jerk, each state then holding a
//!   body acceleration too (Tang, Yoon & Barfoot 2019; the `factors` module);
//! - each scan's error (`(x m, y m, θ rad)` beside its pose, zero-mean): what its noise, its
//!   motion distortion and whatever moved in it do to every registration that uses it, so that
//!   registrations sharing a scan are correlated as they are; the share of a registration's
//!   covariance that is its scans' is estimated from the loops the registrations close, and the
//!   rest is the registration's own (see [`ScanErrors`] and the `scan_errors` module).
//!
//! `Qc` is estimated from the data by expectation–maximisation (Wong et al. 2020): smooth,
//! then set each axis' `q` to the maximum-likelihood value given the expected squared prior
//! residuals (which include the smoothed covariance), until it settles; see [`ProcessNoise`].
//! [`PriorChoice::Likelier`] estimates both priors and keeps the one under which the
//! registrations are likelier (the `evidence` module).
//!
//! # Modes
//! [`Mode::Batch`] solves every scan at once by Gauss–Newton with faer's sparse Cholesky.
//! [`Mode::Causal`] estimates scan k from scans ≤ k (+ a fixed lag) only, in a sliding window
//! whose oldest scan is marginalised out (exact for a linear model: the last scan's estimate
//! equals the batch one's). Both give each scan's pose, twist and marginal covariance and each
//! consecutive pair's fused `t_ref_src` with its covariance (the marginal of the relative pose).
//!
//! The causal mode uses the `Qc` it is given: estimating it needs the whole run, so callers
//! estimate it once in batch (see [`Smoothed::qc`]) or carry it over from earlier data.
//!
//! # Gaps
//! Registrations left out by the caller (flagged ones) leave their steps to the prior and the
//! registrations at other lags; a step no registration spans is marked
//! [`StepEstimate::supported`] `false`, and its covariance is the prior's.

mod band;
mod batch;
mod causal;
mod evidence;
mod factors;
#[cfg(test)]
mod fixtures;
pub(crate) use factors::{exp_from, wrap_rad};
mod noise;
mod scan_errors;
mod system;

use nalgebra::{Cholesky, Isometry2, Matrix3, Vector2, Vector3};

/// The 6×6 covariance of a scan's `[pose; twist]`.
pub type StateCovariance = nalgebra::SMatrix<f64, 6, 6>;
pub use scan_errors::{ScanErrors, ScanShare, MAX_SHARE};
use system::{Estimates, Model, Reg};

/// Errors of the smoother's input and solve.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum SequenceError {
    /// Fewer than two scans: nothing moves.
    #[error("a sequence needs at least two scans, got {scans}")]
    TooFewScans { scans: usize },
    /// A timestamp that is NaN or infinite.
    #[error("scan {index}: non-finite time {time_s}")]
    NonFiniteTime { index: usize, time_s: f64 },
    /// Timestamps not strictly increasing (a duplicate or a step back).
    #[error("scan {index}: time {time_s} s is not after the previous scan's {previous_s} s")]
    NonMonotonicTime {
        index: usize,
        previous_s: f64,
        time_s: f64,
    },
    /// No registration left (none given, or all flagged).
    #[error("no registration to smooth (all pairs flagged or none given)")]
    NoRegistrations,
    /// A registration that cannot be used.
    #[error("registration {index}: {why}")]
    BadRegistration { index: usize, why: &'static str },
    /// An option out of range.
    #[error("option {name}: {why}")]
    BadOption {
        name: &'static str,
        why: &'static str,
    },
    /// The normal equations could not be factorised (the problem is not observable).
    #[error("the smoother's normal equations failed at the {what} stage")]
    Factorisation { what: &'static str },
}

/// How poses compose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Geometry {
    /// Poses on SE(2): body-frame twists, rotations composed (the vessel's case).
    Se2,
    /// `(x, y, θ)` as a vector space, with the body frame the world's: the model is then linear
    /// and Gaussian, so it can be checked against a Kalman/RTS smoother.
    Linear,
}

/// The motion prior between consecutive scans: what the state of a scan holds, and what is
/// white noise.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MotionPrior {
    /// White noise on acceleration, a constant velocity between scans (Barfoot, Tong & Särkkä
    /// 2014; STEAM's): a scan's state is its pose and twist, `Qc` in m²/s³ and rad²/s³.
    #[default]
    WhiteAcceleration,
    /// White noise on jerk, a constant acceleration between scans (Tang, Yoon & Barfoot
    /// 2019): a scan's state also holds its body acceleration, and `Qc` is in m²/s⁵ and
    /// rad²/s⁵. Where a hull's acceleration changes slowly against the scans' rate (its
    /// acceleration correlated from scan to scan), this prior holds it where white noise on
    /// acceleration has to be loose enough for every change of velocity.
    WhiteJerk,
}

impl MotionPrior {
    /// The derivatives a scan's state holds: pose and twist (2), and acceleration (3).
    pub fn order(self) -> usize {
        match self {
            Self::WhiteAcceleration => 2,
            Self::WhiteJerk => 3,
        }
    }
}

/// Which motion prior the smoother takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PriorChoice {
    /// This one.
    Given(MotionPrior),
    /// Both, each with its `Qc` estimated, and the one under which the registrations beyond
    /// the first scans are likelier given those (Laplace's approximation; see
    /// [`Smoothed::prior_evidence`]). Needs [`ProcessNoise::Estimate`] (a `Qc` given is one
    /// prior's) and costs both estimations.
    Likelier,
}

impl Default for PriorChoice {
    fn default() -> Self {
        Self::Given(MotionPrior::default())
    }
}

/// Where the prior's `Qc` comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProcessNoise {
    /// Expectation–maximisation from the data, until every axis changes by less than
    /// `tolerance` (relative), or an EM round raises the log-likelihood of the registrations
    /// (Laplace's approximation) by at most `likelihood_tolerance` nats per scan, or after
    /// `max_iterations` rounds.
    Estimate {
        max_iterations: usize,
        tolerance: f64,
        likelihood_tolerance: f64,
    },
    /// Given: `[surge m²/s³, sway m²/s³, yaw rad²/s³]` (white noise on jerk: per s⁵).
    Fixed([f64; 3]),
}

/// The smoother's options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmootherOptions {
    pub geometry: Geometry,
    /// The motion prior; white noise on acceleration by default.
    pub motion_prior: PriorChoice,
    pub process_noise: ProcessNoise,
    /// Huber threshold on a registration's Mahalanobis distance. Default 3.37 = √χ²₃(0.99): a
    /// registration as good as its covariance says keeps full weight 99 % of the time.
    pub huber_k: f64,
    /// Gauss–Newton iterations at most per solve. Default 100: a solve from a start far from
    /// its minimum takes halved steps (the solvers' step control) and needs more than
    /// the 20 it had; at 20 the aces log's HD_GICP+batch (`--init global --lags 3`) stopped
    /// short, 226 of 439 steps within 0.1 m and 1° against 283 at 100 (as many as the
    /// pairwise registrations). A solve that converges stops earlier: checked on the paper and
    /// rough harbours, whose solves stop in 3–44 iterations.
    pub max_iterations: usize,
    /// Gauss–Newton stops when its step's Newton decrement `δᵀHδ = −gᵀδ` (the step's squared
    /// length in the estimate's own σ, over every state) is at most this. Default 1e-4: a step
    /// of a hundredth of a σ. (It stopped when no state moved by more than 1e-10 before: the
    /// Huber weights make Gauss–Newton converge linearly, so a solve took 14 iterations on the
    /// harbour's size where the first 6 did all but 1e-9 of the cost's descent.)
    pub tolerance: f64,
    /// What is known of scan 0's twist, if anything (a vessel leaving the quay at rest); none
    /// by default.
    pub initial_twist: Option<TwistPrior>,
    /// What is known of scan 0's acceleration `(surge m/s², sway m/s², yaw rad/s²)` under
    /// white noise on jerk, if anything; none by default, and an error under white noise on
    /// acceleration (whose state has none).
    pub initial_acceleration: Option<TwistPrior>,
    /// How much of a registration's error is its scans', shared with their other
    /// registrations ([`scan_errors`](ScanErrors)); estimated from the run's loops by default.
    pub scan_errors: ScanErrors,
}

/// A Gaussian on scan 0's twist `(surge m/s, sway m/s, yaw rad/s)` (or its acceleration).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwistPrior {
    pub mean: Vector3<f64>,
    pub cov: Matrix3<f64>,
}

impl Default for SmootherOptions {
    fn default() -> Self {
        Self {
            geometry: Geometry::Se2,
            motion_prior: PriorChoice::default(),
            process_noise: ProcessNoise::Estimate {
                max_iterations: 50,
                tolerance: 1e-3,
                likelihood_tolerance: 1e-5,
            },
            huber_k: 3.37,
            max_iterations: 100,
            tolerance: 1e-4,
            initial_twist: None,
            initial_acceleration: None,
            scan_errors: ScanErrors::Estimate,
        }
    }
}

/// Batch or causal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Every scan from the whole run.
    Batch,
    /// Scan k from scans ≤ k + `lag_scans` only.
    Causal { lag_scans: usize },
}

/// One registration given to the smoother: `t_ref_src` of `source → reference` (scan indices,
/// `source < reference`) and the covariance of its `(x m, y m, θ rad)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SequenceRegistration {
    pub source: usize,
    pub reference: usize,
    pub t_ref_src: Isometry2<f64>,
    pub cov: Matrix3<f64>,
}

/// One scan's estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanEstimate {
    /// `(x m, y m, θ rad)` of `t_scan0_scan`.
    pub pose: Vector3<f64>,
    /// `(surge m/s, sway m/s, yaw rad/s)` in the scan's frame.
    pub twist: Vector3<f64>,
    /// Marginal covariance of `[pose; twist]` (zero for scan 0's pose, which is the frame).
    pub cov: StateCovariance,
}

/// The fused motion of one consecutive pair `k → k+1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepEstimate {
    /// `t_ref_src` of the pair (the inverse of the vessel's motion, as a registration gives).
    pub t_ref_src: Isometry2<f64>,
    /// Covariance of its `(x m, y m, θ rad)`: the marginal of the relative pose.
    pub cov: Matrix3<f64>,
    /// Whether any registration spans the step (else it rests on the prior alone).
    pub supported: bool,
}

/// How a Gauss–Newton solve of the smoother stopped, from the best to the worst.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum SolveStop {
    /// The last step was shorter than [`SmootherOptions::tolerance`] (in the estimate's σ).
    Converged,
    /// No step along Gauss–Newton's direction, halved down to 1/4096, lowered the cost: a
    /// minimum to within rounding, or a kink of the robust loss.
    NoDescent,
    /// [`SmootherOptions::max_iterations`] reached while states still moved: the estimate may
    /// lie short of its minimum.
    IterationCap,
}

impl SolveStop {
    /// Its name in the outputs.
    pub fn name(self) -> &'static str {
        match self {
            Self::Converged => "converged",
            Self::NoDescent => "no_descent",
            Self::IterationCap => "iteration_cap",
        }
    }
}

/// What the smoother gives.
#[derive(Clone, Debug, PartialEq)]
pub struct Smoothed {
    pub scans: Vec<ScanEstimate>,
    pub steps: Vec<StepEstimate>,
    /// The motion prior used (the likelier one under [`PriorChoice::Likelier`]).
    pub motion_prior: MotionPrior,
    /// The `Qc` used: `[surge m²/s³, sway m²/s³, yaw rad²/s³]` (white noise on jerk: per s⁵).
    pub qc: [f64; 3],
    /// The registrations' log-likelihood at the batch solution (Laplace's approximation with
    /// every constant: exact for a linear-Gaussian model with priors on scan 0's twist and
    /// acceleration; improper, by a constant, without). None in the causal mode.
    pub log_likelihood: Option<f64>,
    /// Under [`PriorChoice::Likelier`]: each prior's log-likelihood of the registrations
    /// beyond the first scans given those, `[white noise on acceleration, on jerk]`, nats.
    pub prior_evidence: Option<[f64; 2]>,
    /// Expectation–maximisation rounds (0 for a fixed `Qc`).
    pub em_iterations: usize,
    /// How the solve that gave the estimates stopped (the causal mode: the worst of its
    /// windows').
    pub stop: SolveStop,
    /// The share of the registrations' covariance given to their scans' errors.
    pub scan_share: ScanShare,
}

/// Smooths the scans at `times_s` from `registrations` (the unflagged ones) in `mode`.
pub fn smooth(
    times_s: &[f64],
    registrations: &[SequenceRegistration],
    mode: Mode,
    options: &SmootherOptions,
) -> Result<Smoothed, SequenceError> {
    validate_times(times_s)?;
    validate_options(options)?;
    let regs = registrations
        .iter()
        .enumerate()
        .map(|(i, r)| to_reg(i, r, times_s.len()))
        .collect::<Result<Vec<_>, _>>()?;
    if regs.is_empty() {
        return Err(SequenceError::NoRegistrations);
    }
    let init = initial_estimates(options.geometry, times_s, &regs);
    let scan_share = scan_errors::share(options.geometry, &regs, options.scan_errors);
    let errors = (scan_share.share > 0.0).then(|| {
        let headings_rad: Vec<f64> = init.poses.iter().map(|p| p.z).collect();
        scan_errors::information(options.geometry, &regs, &headings_rad, scan_share.share)
    });
    let own = scan_errors::own_parts(&regs, scan_share.share);
    let base = Model {
        geometry: options.geometry,
        times_s,
        regs: &own,
        prior: MotionPrior::default(),
        qc: [1.0; 3],
        huber_k: options.huber_k,
        twist0: gaussian("initial_twist", options.initial_twist)?,
        accel0: gaussian("initial_acceleration", options.initial_acceleration)?,
        scan_errors: errors.as_deref(),
    };
    let with = |prior| Model {
        prior,
        ..base.clone()
    };
    let (model, em_iterations, last, prior_evidence) = match options.motion_prior {
        PriorChoice::Given(prior) => {
            let (model, em_iterations, last) = fit(options, with(prior), &init, &regs)?;
            (model, em_iterations, last, None)
        }
        PriorChoice::Likelier => {
            let mut fits = Vec::new();
            for prior in [MotionPrior::WhiteAcceleration, MotionPrior::WhiteJerk] {
                let (model, em_iterations, last) = fit(options, with(prior), &init, &regs)?;
                let last = last.expect("validated: the choice estimates Qc");
                fits.push(evidence::Fit {
                    model,
                    em_iterations,
                    last,
                });
            }
            let (fit, scores) = evidence::likelier(fits, options)?;
            (fit.model, fit.em_iterations, Some(fit.last), Some(scores))
        }
    };
    let qc = model.qc;
    let ((scans, steps), stop, log_likelihood) = match mode {
        // The batch solution is EM's last round's, or solved at a `Qc` given; the causal one
        // starts from the chained start, which uses no scan after the one it estimates.
        Mode::Batch => {
            let solved = match last {
                Some(last) => last,
                None => noise::batch_with_marginals(&model, init, options)?,
            };
            let m = &solved.marginals;
            let pose_twist = |all: &[batch::StateMarginal]| -> Vec<StateCovariance> {
                all.iter()
                    .map(|c| c.fixed_view::<6, 6>(0, 0).into_owned())
                    .collect()
            };
            let (own, cross) = (pose_twist(&m.own), pose_twist(&m.cross));
            let dim = model.layout(0, times_s.len()).dim();
            let ll = evidence::log_likelihood(&model, solved.cost, m.log_det_h, dim);
            let outputs = outputs(&model, &solved.est, &own, &cross);
            (outputs, solved.stop, Some(ll))
        }
        Mode::Causal { lag_scans } => {
            let (outputs, stop) = causal::run(&model, init, lag_scans, options)?;
            (outputs, stop, None)
        }
    };
    Ok(Smoothed {
        scans,
        steps,
        motion_prior: model.prior,
        qc,
        log_likelihood,
        prior_evidence,
        em_iterations,
        stop,
        scan_share,
    })
}

/// `model`'s `Qc`, as given or estimated by EM from `init`: the model at that `Qc`, the EM
/// rounds, and EM's last round (its batch solution), if estimated.
fn fit<'a>(
    options: &SmootherOptions,
    mut model: Model<'a>,
    init: &Estimates,
    regs: &[Reg],
) -> Result<(Model<'a>, usize, Option<noise::Solved>), SequenceError> {
    match options.process_noise {
        ProcessNoise::Fixed(qc) => {
            model.qc = qc;
            Ok((model, 0, None))
        }
        ProcessNoise::Estimate {
            max_iterations,
            tolerance,
            likelihood_tolerance,
        } => {
            let estimated = noise::estimate(
                options,
                &model,
                init.clone(),
                noise::starts(model.geometry, model.prior, model.times_s, regs),
                &noise::EmStop {
                    max_rounds: max_iterations,
                    tolerance,
                    likelihood_tolerance,
                },
            )?;
            // EM's last round: its `Qc`, and the batch solution there.
            model.qc = estimated.last.qc;
            Ok((model, estimated.rounds, Some(estimated.last)))
        }
    }
}

fn validate_times(times_s: &[f64]) -> Result<(), SequenceError> {
    if times_s.len() < 2 {
        return Err(SequenceError::TooFewScans {
            scans: times_s.len(),
        });
    }
    if let Some((index, &time_s)) = times_s.iter().enumerate().find(|(_, t)| !t.is_finite()) {
        return Err(SequenceError::NonFiniteTime { index, time_s });
    }
    match times_s.windows(2).position(|w| w[1] <= w[0]) {
        Some(i) => Err(SequenceError::NonMonotonicTime {
            index: i + 1,
            previous_s: times_s[i],
            time_s: times_s[i + 1],
        }),
        None => Ok(()),
    }
}

fn validate_options(o: &SmootherOptions) -> Result<(), SequenceError> {
    let bad = |name, why| Err(SequenceError::BadOption { name, why });
    if !(o.huber_k.is_finite() && o.huber_k > 0.0) {
        return bad("huber_k", "must be finite and positive");
    }
    if !(o.tolerance.is_finite() && o.tolerance > 0.0) {
        return bad("tolerance", "must be finite and positive");
    }
    if o.initial_acceleration.is_some()
        && o.motion_prior == PriorChoice::Given(MotionPrior::WhiteAcceleration)
    {
        return bad(
            "initial_acceleration",
            "only white noise on jerk has an acceleration in its state",
        );
    }
    if let (PriorChoice::Likelier, ProcessNoise::Fixed(_)) = (o.motion_prior, o.process_noise) {
        return bad(
            "motion_prior",
            "the choice between priors estimates each one's Qc (a Qc given is one prior's)",
        );
    }
    if let ScanErrors::Share(share) = o.scan_errors {
        if !(0.0..=MAX_SHARE).contains(&share) {
            return bad("scan_errors", "the share must lie in [0, MAX_SHARE]");
        }
    }
    match o.process_noise {
        ProcessNoise::Fixed(qc) if qc.iter().any(|q| !(q.is_finite() && *q > 0.0)) => {
            bad("process_noise", "each Qc must be finite and positive")
        }
        ProcessNoise::Estimate {
            tolerance,
            likelihood_tolerance,
            ..
        } if !(tolerance.is_finite()
            && tolerance > 0.0
            && likelihood_tolerance.is_finite()
            && likelihood_tolerance >= 0.0) =>
        {
            bad(
                "process_noise",
                "the EM tolerances must be finite, and positive (the likelihood's may be 0)",
            )
        }
        _ => Ok(()),
    }
}

fn to_reg(index: usize, r: &SequenceRegistration, n: usize) -> Result<Reg, SequenceError> {
    let bad = |why| Err(SequenceError::BadRegistration { index, why });
    if r.source >= r.reference {
        return bad("its source must come before its reference");
    }
    if r.reference >= n {
        return bad("its reference is past the last scan");
    }
    let z = params(&r.t_ref_src);
    if z.iter().chain(r.cov.iter()).any(|v| !v.is_finite()) {
        return bad("non-finite transform or covariance");
    }
    let sym = (r.cov + r.cov.transpose()) * 0.5;
    let Some(chol) = Cholesky::new(sym) else {
        return bad("covariance not positive definite");
    };
    Ok(Reg {
        source: r.source,
        reference: r.reference,
        z,
        info: chol.inverse(),
        cov: sym,
    })
}

/// The mean and information of the option `name`'s prior `prior` on a 3-vector of scan 0.
fn gaussian(
    name: &'static str,
    prior: Option<TwistPrior>,
) -> Result<Option<system::Gaussian3>, SequenceError> {
    let Some(p) = prior else {
        return Ok(None);
    };
    let bad = Err(SequenceError::BadOption {
        name,
        why: "needs a finite mean and a positive-definite covariance",
    });
    if p.mean.iter().chain(p.cov.iter()).any(|v| !v.is_finite()) {
        return bad;
    }
    match Cholesky::new((p.cov + p.cov.transpose()) * 0.5) {
        Some(c) => Ok(Some((p.mean, c.inverse()))),
        None => bad,
    }
}

/// `(x, y, θ)` of a transform.
fn params(t: &Isometry2<f64>) -> Vector3<f64> {
    let v = t.translation.vector;
    Vector3::new(v.x, v.y, t.rotation.angle())
}

/// Starting point: the poses chained through the consecutive registrations; a step without one
/// walks towards where the nearest registration spanning it puts its reference (the latest
/// source, then the earliest reference), in proportion to time; a step nothing spans holds the
/// twist before it. Each twist is its step's. (A start from each scan's shortest registration
/// alone, its twist held over the steps without one, put the aces log's smoother in a wrong
/// minimum after a run of flagged steps: chaining keeps every pose where its registrations
/// say.)
fn initial_estimates(geometry: Geometry, times_s: &[f64], regs: &[Reg]) -> Estimates {
    let n = times_s.len();
    let mut poses = vec![Vector3::zeros(); n];
    let mut twists = vec![Vector3::zeros(); n];
    for k in 0..n - 1 {
        let dt = times_s[k + 1] - times_s[k];
        let spanning = regs
            .iter()
            .filter(|r| r.source <= k && r.reference > k)
            .max_by(|a, b| a.source.cmp(&b.source).then(b.reference.cmp(&a.reference)));
        let xi = match spanning {
            Some(r) => {
                let target = factors::exp_from(
                    geometry,
                    &poses[r.source],
                    &log_from_origin(geometry, &inverse_params(geometry, &r.z)),
                );
                let share = dt / (times_s[r.reference] - times_s[k]);
                factors::log_between(geometry, &poses[k], &target).0 * share
            }
            None => twists[k.max(1) - 1] * dt,
        };
        poses[k + 1] = factors::exp_from(geometry, &poses[k], &xi);
        twists[k] = xi / dt;
    }
    twists[n - 1] = twists[n - 2];
    Estimates::new(poses, twists)
}

/// The constant body twist (times Δt) that moves the origin onto the pose `p`.
fn log_from_origin(geometry: Geometry, p: &Vector3<f64>) -> Vector3<f64> {
    factors::log_between(geometry, &Vector3::zeros(), p).0
}

/// The parameters of the inverse of the transform whose parameters are `z`.
fn inverse_params(geometry: Geometry, z: &Vector3<f64>) -> Vector3<f64> {
    let (t, _, _) = factors::relative(geometry, &Vector3::zeros(), z);
    t
}

/// Every scan's estimate and every consecutive pair's fused step.
pub(crate) type Outputs = (Vec<ScanEstimate>, Vec<StepEstimate>);

/// The scans' and steps' outputs from estimates and marginals (`own[k]`, `cross[k] = Σ_k,k+1`).
fn outputs(
    model: &Model<'_>,
    est: &Estimates,
    own: &[StateCovariance],
    cross: &[StateCovariance],
) -> Outputs {
    let scans = (0..est.poses.len())
        .map(|k| ScanEstimate {
            pose: est.poses[k],
            twist: est.twists[k],
            cov: own[k],
        })
        .collect();
    let steps = (0..est.poses.len() - 1)
        .map(|k| step(model, est, k, &own[k], &own[k + 1], &cross[k]))
        .collect();
    (scans, steps)
}

/// The fused `t_ref_src` of `k → k+1` and its covariance from the joint marginal.
fn step(
    model: &Model<'_>,
    est: &Estimates,
    k: usize,
    own_k: &StateCovariance,
    own_k1: &StateCovariance,
    cross: &StateCovariance,
) -> StepEstimate {
    let (z, j_src, j_ref) = factors::relative(model.geometry, &est.poses[k], &est.poses[k + 1]);
    let p = |m: &StateCovariance| -> Matrix3<f64> { m.fixed_view::<3, 3>(0, 0).into_owned() };
    let c = p(cross);
    let cov = j_src * p(own_k) * j_src.transpose()
        + j_src * c * j_ref.transpose()
        + j_ref * c.transpose() * j_src.transpose()
        + j_ref * p(own_k1) * j_ref.transpose();
    StepEstimate {
        t_ref_src: Isometry2::new(Vector2::new(z.x, z.y), z.z),
        cov: (cov + cov.transpose()) * 0.5,
        supported: model.regs.iter().any(|r| r.source <= k && r.reference > k),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact registrations `a → b` of poses `(x, y, θ)` (SE(2)).
    fn exact(poses: &[Vector3<f64>], pairs: &[(usize, usize)]) -> Vec<Reg> {
        pairs
            .iter()
            .map(|&(a, b)| Reg {
                source: a,
                reference: b,
                z: factors::relative(Geometry::Se2, &poses[a], &poses[b]).0,
                info: Matrix3::identity(),
                cov: Matrix3::identity(),
            })
            .collect()
    }

    #[test]
    fn the_start_lands_where_the_registrations_spanning_a_gap_put_its_end() {
        // A turn of 1.2 rad per second reversed at scan 4; scans 4 and 5 have no registration
        // of their own and 3 → 6 spans both: the start chains the registrations and lands on
        // every other pose exactly. Holding the twist from before the gap put scan 6's
        // heading 4.8 rad off.
        let times_s: Vec<f64> = (0..9).map(f64::from).collect();
        let mut poses = vec![Vector3::zeros()];
        for k in 0..8 {
            let yaw = if k < 4 { 1.2 } else { -1.2 };
            let next = factors::exp_from(Geometry::Se2, &poses[k], &Vector3::new(1.5, 0.1, yaw));
            poses.push(next);
        }
        let pairs = [
            (0, 1),
            (1, 2),
            (2, 3),
            (3, 4),
            (2, 4),
            (3, 6),
            (6, 7),
            (7, 8),
        ];
        let start = initial_estimates(Geometry::Se2, &times_s, &exact(&poses, &pairs));
        for k in [0, 1, 2, 3, 4, 6, 7, 8] {
            let e = factors::pose_minus(Geometry::Se2, &start.poses[k], &poses[k]);
            assert!(e.norm() < 1e-9, "scan {k}: {e:?}");
        }
        // Scan 5 lies on the way from 4 to 6, half the constant-twist arc between them.
        let (xi, _, _) = factors::log_between(Geometry::Se2, &poses[4], &poses[6]);
        let mid = factors::exp_from(Geometry::Se2, &poses[4], &(xi * 0.5));
        assert!(factors::pose_minus(Geometry::Se2, &start.poses[5], &mid).norm() < 1e-9);
    }
}
