//! Which motion prior the registrations favour ([`super::PriorChoice::Likelier`]): each
//! prior's log-likelihood of the registrations by Laplace's approximation with every constant
//! ([`log_likelihood`]; exact for a linear-Gaussian model), taken beyond the first scans given
//! those ([`predictive`]). The flat priors on scan 0's twist (and, under white noise on jerk,
//! acceleration) make each likelihood improper, by a constant that differs between the priors
//! (their dimensions differ); conditioned on the registrations of the first scans, which
//! determine scan 0's state, the constants cancel (a partial Bayes factor, O'Hagan 1995).

use super::noise::{self, Solved};
use super::system::{Estimates, Model, Reg};
use super::{factors, MotionPrior, SequenceError, SmootherOptions};

/// `ln 2π`.
const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// The first prefix ([`predictive`]) tried, in scans: two seconds at the harbours' 0.2 s.
const PREFIX_SCANS: usize = 10;

/// `ln p(z | model)` of the registrations by Laplace's approximation at a solution whose cost
/// is `cost` and whose Gauss–Newton Hessian over `dim` free scalars has `ln det H` =
/// `log_det_h`: `−J − ½ ln det H + (dim/2) ln 2π` plus each Gaussian factor's normaliser
/// `½ ln det W − (d/2) ln 2π` (the priors', the registrations' own parts', the scans' errors',
/// scan 0's twist and acceleration where given). The registrations' Huber loss is taken with
/// its Gaussian's normaliser: the same for both priors, so it does not move their difference.
pub(crate) fn log_likelihood(model: &Model<'_>, cost: f64, log_det_h: f64, dim: usize) -> f64 {
    let normaliser = |ln_det_w: f64, d: usize| 0.5 * ln_det_w - 0.5 * d as f64 * LN_2PI;
    let order = model.prior.order();
    let ln_qc: f64 = model.qc.iter().map(|q| q.ln()).sum();
    let mut ll = -cost - 0.5 * log_det_h + 0.5 * dim as f64 * LN_2PI;
    for k in 0..model.times_s.len() - 1 {
        // ln det Q⁻¹ = Σ_axis (ln det A⁻¹ − O ln q).
        let ln_det = 3.0 * factors::ln_det_a_inverse(order, model.dt_s(k)) - order as f64 * ln_qc;
        ll += normaliser(ln_det, 3 * order);
    }
    let infos = model.regs.iter().map(|r| &r.info);
    let scan_errors = model.scan_errors.unwrap_or(&[]);
    let initial = model
        .twist0
        .iter()
        .chain(&model.accel0)
        .map(|(_, info)| info);
    for info in infos.chain(scan_errors).chain(initial) {
        ll += normaliser(info.determinant().ln(), 3);
    }
    ll
}

/// `ln p(z_later | z_prefix, model)` at `model`'s `Qc` and the batch solution `solved`: the
/// log-likelihood of every registration ([`log_likelihood`]) less that of the registrations
/// within a prefix of the scans, the shortest of 10, 20, 40, … scans (at most half the run)
/// whose registrations determine its states (a flagged registration early in a run may leave
/// a short prefix undetermined). An error where none does.
pub(crate) fn predictive(
    model: &Model<'_>,
    solved: &Solved,
    options: &SmootherOptions,
) -> Result<f64, SequenceError> {
    let n = model.times_s.len();
    let full = log_likelihood(
        model,
        solved.cost,
        solved.marginals.log_det_h,
        model.layout(0, n).dim(),
    );
    let mut scans = PREFIX_SCANS;
    while scans <= n / 2 {
        if let Ok(prefix) = prefix_log_likelihood(model, &solved.est, scans, options) {
            return Ok(full - prefix);
        }
        scans *= 2;
    }
    Err(SequenceError::Factorisation {
        what: "prior choice (no prefix of at most half the run is determined)",
    })
}

/// [`log_likelihood`] of the registrations within scans `0..scans`, solved from `est`.
fn prefix_log_likelihood(
    model: &Model<'_>,
    est: &Estimates,
    scans: usize,
    options: &SmootherOptions,
) -> Result<f64, SequenceError> {
    let regs: Vec<Reg> = model
        .regs
        .iter()
        .filter(|r| r.reference < scans)
        .copied()
        .collect();
    if regs.is_empty() {
        return Err(SequenceError::NoRegistrations);
    }
    let prefix = Model {
        times_s: &model.times_s[..scans],
        regs: &regs,
        scan_errors: model.scan_errors.map(|infos| &infos[..scans]),
        ..model.clone()
    };
    let solved = noise::batch_with_marginals(&prefix, est.slice(0..scans), options)?;
    let dim = prefix.layout(0, scans).dim();
    Ok(log_likelihood(
        &prefix,
        solved.cost,
        solved.marginals.log_det_h,
        dim,
    ))
}

/// One prior's estimation: its model (at the `Qc` estimated), the EM rounds and EM's last
/// round (the batch solution there).
pub(crate) struct Fit<'a> {
    pub model: Model<'a>,
    pub em_iterations: usize,
    pub last: Solved,
}

/// Of the fits of both priors, the one whose registrations beyond a prefix are likelier
/// ([`predictive`]; the first of equals), and each prior's predictive log-likelihood
/// `[white noise on acceleration, on jerk]` (the fits in that order).
pub(crate) fn likelier<'a>(
    fits: Vec<Fit<'a>>,
    options: &SmootherOptions,
) -> Result<(Fit<'a>, [f64; 2]), SequenceError> {
    let mut scores = [f64::NEG_INFINITY; 2];
    for (fit, score) in fits.iter().zip(&mut scores) {
        *score = predictive(&fit.model, &fit.last, options)?;
    }
    let rounds: usize = fits.iter().map(|f| f.em_iterations).sum();
    let best = usize::from(scores[1] > scores[0]);
    let mut fit = fits.into_iter().nth(best).expect("a fit for each prior");
    debug_assert_eq!(
        fit.model.prior,
        [MotionPrior::WhiteAcceleration, MotionPrior::WhiteJerk][best]
    );
    fit.em_iterations = rounds;
    Ok((fit, scores))
}
