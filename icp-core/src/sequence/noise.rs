//! The prior's process noise `Qc` from the data: expectation–maximisation (Wong, Yoon,
//! Schoellig & Barfoot 2020, "Variational inference with parameter learning applied to vehicle
//! trajectory estimation"), with the batch smoother as the E-step.

use nalgebra::SMatrix;

use super::batch::{self, Marginals, SparseSystem, StateMarginal};
use super::factors;
use super::system::{Estimates, Layout, Model, Reg};
use super::{Geometry, MotionPrior, SequenceError, SmootherOptions, SolveStop};

/// Smallest `q` an axis may take, so that `Q` stays invertible when an axis does not move.
const Q_FLOOR: f64 = 1e-12;

/// The least share of a registration's variance along an axis that the prior lets the
/// position move by over a step ([`floors`]): a prior a million times as informative as a
/// registration, whose motion no registration could see.
const RELATIVE_FLOOR: f64 = 1e-6;

/// The smallest `q` each axis may take in the estimation: [`Q_FLOOR`], or where larger the `q`
/// whose prior moves the position over the median step by [`RELATIVE_FLOOR`] of the median
/// variance of the consecutive registrations along the axis (`q · A₀₀(Δt)`, `A₀₀` = Δt³/3
/// under white noise on acceleration, Δt⁵/20 on jerk). An axis that does not move (a vessel's
/// sway on the paper harbour) sends EM's `q` towards 0; under white noise on jerk at the
/// harbour's 0.2 s its prior then weighed 1e16 times a registration (`q` 9e-11 m²/s⁵ against
/// this floor's 1.9–2.7e-6), beyond what the causal windows' dense factorisations hold in double
/// precision (seed 3, HD_GICP: a window's system, eigenvalues 8.8 to 8.8e16, was not
/// factorised and the estimator failed; scaled to a unit diagonal with a ridge, it factorised
/// and diverged, 137 steps more than 0.05 m/s off with σ of 3e-7). Under white noise on
/// acceleration the paper harbour's sway `q` (1.7–7.5e-8 m²/s³ on seeds 3, 13 and 2022) lies
/// 1.5–5 times above its floor (1.1–1.6e-8 from seed 3), and the moving axes' far above
/// theirs: it binds nowhere under that prior on the harbours, marina or aces.
fn floors(model: &Model<'_>) -> [f64; 3] {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied()
    };
    let dt_s = median(model.times_s.windows(2).map(|w| w[1] - w[0]).collect());
    let order = model.prior.order();
    std::array::from_fn(|axis| {
        let lag1 = model.regs.iter().filter(|r| r.reference == r.source + 1);
        let variance = median(lag1.map(|r| r.cov[(axis, axis)]).collect());
        match (variance, dt_s) {
            (Some(v), Some(dt)) => {
                let step = factors::position_variance(order, dt);
                (RELATIVE_FLOOR * v / step).max(Q_FLOOR)
            }
            _ => Q_FLOOR,
        }
    })
}

/// The batch solve at `model`'s `Qc` from `init`, with every scan's marginal covariance and
/// the cross-covariance of consecutive scans, and how the solve stopped.
pub(crate) fn batch_with_marginals(
    model: &Model<'_>,
    est: Estimates,
    options: &SmootherOptions,
) -> Result<Solved, SequenceError> {
    let layout = model.layout(0, est.poses.len());
    let mut sys = SparseSystem::new(model, &layout, est.poses.len())?;
    let (est, marginals, (cost, stop)) =
        solve_with_marginals(model, est, &mut sys, &layout, options)?;
    Ok(Solved {
        qc: model.qc,
        est,
        marginals,
        stop,
        cost,
    })
}

/// The batch solution at one `Qc`: the estimates, their marginals ([`batch::marginals`]) and
/// how the solve stopped.
pub(crate) struct Solved {
    pub qc: [f64; 3],
    pub est: Estimates,
    pub marginals: Marginals,
    pub stop: SolveStop,
    /// The cost at the solution (robust registrations', priors', scan errors').
    pub cost: f64,
}

/// [`batch_with_marginals`] on the system `sys` already laid out (its symbolic factorisation
/// made once for every round of the estimation); also the cost at the solution.
fn solve_with_marginals(
    model: &Model<'_>,
    mut est: Estimates,
    sys: &mut SparseSystem,
    layout: &Layout,
    options: &SmootherOptions,
) -> Result<(Estimates, Marginals, (f64, SolveStop)), SequenceError> {
    let solved = batch::solve(
        model,
        &mut est,
        sys,
        layout,
        options.max_iterations,
        options.tolerance,
    )?;
    let marginals = batch::marginals(sys, layout, est.poses.len())?;
    Ok((est, marginals, solved))
}

/// The log-likelihood of the registrations given `qc`, by Laplace's approximation at the
/// solution, up to a constant: `−J − ½ ln det H − ½ Σ_k ln det Q_k`, J the cost there (robust
/// registrations' and priors'), H its Gauss–Newton Hessian and `Q_k = A_k ⊗ Qc` the priors'
/// covariances, whose `ln det` is `O Σ_axis ln q` (O the state's derivatives, `order`) plus
/// what does not depend on `Qc`.
fn log_evidence(qc: &[f64; 3], order: usize, priors: usize, cost: f64, log_det_h: f64) -> f64 {
    let per_prior = 0.5 * order as f64 * priors as f64;
    -cost - 0.5 * log_det_h - per_prior * qc.iter().map(|q| q.ln()).sum::<f64>()
}

/// Where the estimation of `Qc` starts, from the data: per axis, the mean and the largest
/// squared change of the lag-1 registrations' twists over the time between them (measurement
/// noise and wrong registrations included); under white noise on jerk, of their second
/// difference over the time cubed. EM is a local method, and with the robust loss
/// the smoother has more than one fixed point: a prior too stiff in the first round
/// down-weights the registrations that disagree with it, and later rounds, each from the
/// round before's solution, stay there. On the aces log (PL_ICP, `--init global --lags 3`) the
/// mean (0.014, 0.0012, 0.052) led to `Qc` (0.042, 0.0036, 0.174) with a log-likelihood of
/// −31 874 and a cost of 19 376, the largest change to (0.096, 0.0099, 0.181), −22 374 and
/// 9 350; on `synthetic:corridor` the mean did better on seeds 11 and 13 (by 4.6 and 12 nats)
/// and as well on seed 7. [`estimate`] starts from the mean, and where that start proved low
/// (EM raised `q` on some axis, as on aces) also from the largest change, keeping the
/// likelier. (Always from both doubled the EM rounds on the paper harbour, 16 → 33, for the
/// same `Qc`; from the largest alone took 13–16 rounds on the rough harbour where the mean
/// took 7–8.)
pub(crate) fn starts(
    geometry: Geometry,
    prior: MotionPrior,
    times_s: &[f64],
    regs: &[Reg],
) -> ([f64; 3], Option<[f64; 3]>) {
    let n = times_s.len();
    let mut twist = vec![None; n];
    for r in regs.iter().filter(|r| r.reference == r.source + 1) {
        let motion = super::inverse_params(geometry, &r.z);
        let xi = super::log_from_origin(geometry, &motion);
        twist[r.source] = Some(xi / (times_s[r.reference] - times_s[r.source]));
    }
    let mut sum = [0.0; 3];
    let mut largest = [0.0_f64; 3];
    let mut count = 0usize;
    let span = match prior {
        MotionPrior::WhiteAcceleration => 2,
        MotionPrior::WhiteJerk => 3,
    };
    for k in 0..n.saturating_sub(span) {
        let changes = match (prior, twist[k], twist[k + 1], twist.get(k + 2)) {
            (MotionPrior::WhiteAcceleration, Some(a), Some(b), _) => {
                let dt = 0.5 * (times_s[k + 2] - times_s[k]);
                (b - a).map(|d| d.powi(2) / dt)
            }
            (MotionPrior::WhiteJerk, Some(a), Some(b), Some(Some(c))) => {
                let dt = (times_s[k + 3] - times_s[k]) / 3.0;
                (c - 2.0 * b + a).map(|d| d.powi(2) / dt.powi(3))
            }
            _ => continue,
        };
        for axis in 0..3 {
            sum[axis] += changes[axis];
            largest[axis] = largest[axis].max(changes[axis]);
        }
        count += 1;
    }
    if count == 0 {
        return ([1.0; 3], None);
    }
    let mean = sum.map(|s| (s / count as f64).max(Q_FLOOR));
    let largest = largest.map(|q| q.max(Q_FLOOR));
    (mean, (largest != mean).then_some(largest))
}

/// Expectation–maximisation of `Qc` from the first of the starts, then from the second where
/// there is one and the first proved low (from the estimates `est` each time: [`starts`]),
/// keeping the one whose last round has the higher log-likelihood ([`log_evidence`]; the
/// first of equals): the EM rounds taken over all starts and the kept start's last round
/// (its `Qc` and the smoother's solution there with its marginals, the E-step of that round).
/// From one start ([`from_start`]), accelerated by SQUAREM (Varadhan & Roland
/// 2008) on `ln Qc`, axis by axis: two EM rounds give each axis' step `r` and its change `v`,
/// the extrapolation `ln q₀ − 2αr + α²v` (`α = −|r|/|v|`, at most −1: no slower than plain EM)
/// is followed by one EM round, which keeps every `q` an M-step's value. Each axis takes its
/// own `α` because the axes converge at their own rates: an axis whose `q` heads for 0 does so
/// geometrically (sublinear EM, `v ≈ 0`, a long jump), while one that has settled oscillates
/// (a short one); one `α` for all would overshoot the settled axes. An extrapolation that
/// lowers the log-likelihood ([`log_evidence`]) below the second EM round's start is dropped
/// for that round's M-step (EM itself never lowers it).
///
/// Stops when a round moves no axis by more than `tolerance` (relative), when an EM round
/// raises the log-likelihood by at most `likelihood_tolerance` nats per scan (and not below 0) (an axis heading
/// for 0 never settles in `q`, but the likelihood does), or after `max_rounds` EM rounds.
/// The answer is the last round's `Qc` with its E-step, not the M-step that followed: within
/// the tolerance of it when EM settled, and solved (to the smoother's own tolerance) at the
/// `Qc` it states, so the batch mode needs no solve of its own. (Solving again at the M-step's
/// `Qc` cost 3 Gauss–Newton steps and a round of marginals on the paper harbour.)
pub(crate) fn estimate(
    options: &SmootherOptions,
    base: &Model<'_>,
    est: Estimates,
    (first, second): ([f64; 3], Option<[f64; 3]>),
    stop: &EmStop,
) -> Result<Estimated, SequenceError> {
    let again = second.map(|_| est.clone());
    let floor = floors(base);
    let floored = |q: [f64; 3]| std::array::from_fn(|a| q[a].max(floor[a]));
    let (first, second) = (floored(first), second.map(floored));
    let mut em = Em {
        options,
        base: base.clone(),
        layout: base.layout(0, base.times_s.len()),
        sys: None,
        est,
        rounds: 0,
        floor,
    };
    let mut best = from_start(&mut em, first, stop)?;
    // Only a start that proved low on some axis (its `q` climbed) can have locked the robust
    // loss onto the prior; from above, the higher start would descend to the same place.
    let climbed = best
        .as_ref()
        .is_some_and(|(s, _)| s.qc.iter().zip(&first).any(|(q, q0)| q > q0));
    // A second start the smoother cannot solve (a prior so loose that the normal equations
    // fail) leaves the first's answer.
    if let (true, Some(qc0), Some(est)) = (climbed, second, again) {
        em.est = est;
        if let Ok(Some(other)) = from_start(&mut em, qc0, stop) {
            if best
                .as_ref()
                .is_none_or(|(_, evidence)| other.1 > *evidence)
            {
                best = Some(other);
            }
        }
    }
    let last = match best {
        Some((last, _)) => last,
        // No round ran (`max_rounds` 0): the first start's `Qc`.
        None => {
            let model = Model {
                qc: first,
                ..base.clone()
            };
            batch_with_marginals(&model, em.est, options)?
        }
    };
    Ok(Estimated {
        rounds: em.rounds,
        last,
    })
}

/// What [`estimate`] gives: the EM rounds taken over all starts, and the kept start's last
/// round.
pub(crate) struct Estimated {
    pub rounds: usize,
    pub last: Solved,
}

/// [`estimate`] from `qc0` alone, in `em` (whose estimates it starts from and leaves at its
/// last round's solution): the last round kept (an extrapolation that lost likelihood is not)
/// and its log-likelihood.
fn from_start(
    em: &mut Em<'_>,
    qc0: [f64; 3],
    stop: &EmStop,
) -> Result<Option<(Solved, f64)>, SequenceError> {
    let times_s = em.base.times_s;
    let first_round = em.rounds;
    let tolerance = stop.tolerance;
    let settled =
        |a: &[f64; 3], b: &[f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tolerance * y);
    let per_scan = (times_s.len() - 1) as f64;
    // A round that lowered the likelihood says the approximation (Huber weights, a nonlinear
    // model) is off there, not that EM settled: only a small gain stops.
    let flat =
        |from: f64, to: f64| (0.0..=stop.likelihood_tolerance * per_scan).contains(&(to - from));
    let mut q0 = qc0;
    let mut last = None;
    while em.rounds - first_round < stop.max_rounds {
        let (q1, r0) = em.round(q0)?;
        if settled(&q1, &q0) || em.rounds - first_round + 2 > stop.max_rounds {
            return Ok(Some(r0));
        }
        let (q2, r1) = em.round(q1)?;
        if settled(&q2, &q1) || flat(r0.1, r1.1) {
            return Ok(Some(r1));
        }
        let (l0, l1, l2) = (q0.map(f64::ln), q1.map(f64::ln), q2.map(f64::ln));
        let jump: [f64; 3] = std::array::from_fn(|a| {
            let (r, v) = (l1[a] - l0[a], l2[a] - 2.0 * l1[a] + l0[a]);
            let alpha = if v != 0.0 {
                (-r.abs() / v.abs()).min(-1.0)
            } else {
                -1.0
            };
            (l0[a] - 2.0 * alpha * r + alpha * alpha * v)
                .exp()
                .max(em.floor[a])
        });
        if !jump.iter().all(|q| q.is_finite()) {
            (q0, last) = (q2, Some(r1));
            continue;
        }
        // An extrapolation the smoother cannot solve, or that lost likelihood: EM's q2.
        match em.round(jump) {
            Ok((q3, r)) if r.1 >= r1.1 => {
                if settled(&q3, &q2) {
                    return Ok(Some(r));
                }
                (q0, last) = (q3, Some(r));
            }
            _ => (q0, last) = (q2, Some(r1)),
        }
    }
    Ok(last)
}

/// When the estimation of `Qc` stops (see [`estimate`]).
pub(crate) struct EmStop {
    pub max_rounds: usize,
    pub tolerance: f64,
    pub likelihood_tolerance: f64,
}

/// The state of an estimation: the model (whose `Qc` each round sets), the system (laid out,
/// and symbolically factorised, once) and the estimates each round starts from.
struct Em<'a> {
    options: &'a SmootherOptions,
    base: Model<'a>,
    layout: Layout,
    sys: Option<SparseSystem>,
    est: Estimates,
    rounds: usize,
    /// Each axis' smallest `q` ([`floors`]).
    floor: [f64; 3],
}

impl Em<'_> {
    /// One EM round from `qc`: smooth (the E-step), then the M-step; the M-step's `Qc`, and
    /// the E-step with the log-likelihood of `qc` ([`log_evidence`]).
    fn round(&mut self, qc: [f64; 3]) -> Result<([f64; 3], (Solved, f64)), SequenceError> {
        let model = Model {
            qc,
            ..self.base.clone()
        };
        let n = model.times_s.len();
        let sys = match &mut self.sys {
            Some(sys) => sys,
            none => none.insert(SparseSystem::new(&model, &self.layout, n)?),
        };
        // From the last round's solution, kept should this one fail.
        let (est, marginals, (cost, stop)) =
            solve_with_marginals(&model, self.est.clone(), sys, &self.layout, self.options)?;
        let next = match model.prior {
            MotionPrior::WhiteAcceleration => m_step::<6, 4, 12>(&model, &est, &marginals),
            MotionPrior::WhiteJerk => m_step::<9, 6, 18>(&model, &est, &marginals),
        };
        let next = std::array::from_fn(|a| next[a].max(self.floor[a]));
        let order = model.prior.order();
        let evidence = log_evidence(&qc, order, n - 1, cost, marginals.log_det_h);
        self.est.clone_from(&est);
        self.rounds += 1;
        let solved = Solved {
            qc,
            est,
            marginals,
            stop,
            cost,
        };
        Ok((next, (solved, evidence)))
    }
}

/// The M-step: for each axis, `q = (1/OK) Σ_k tr(A_k⁻¹ E[e_k e_kᵀ])` over the K priors, where
/// `e_k` is the axis' residual (position and velocity, and acceleration under white noise on
/// jerk: O = `R/3` of them), `A_k` its covariance per unit `q` ([`factors::a_inverse`]) and
/// `E[e eᵀ] = ē ēᵀ + F Σ Fᵀ` with F the residual's Jacobian (`B` blocks, `J = 2R` columns) and
/// Σ the joint marginal of scans k and k+1. Unfloored: the caller floors each axis
/// ([`floors`]).
fn m_step<const R: usize, const B: usize, const J: usize>(
    model: &Model<'_>,
    est: &Estimates,
    marginals: &Marginals,
) -> [f64; 3] {
    let order = R / 3;
    let (own, cross) = (&marginals.own, &marginals.cross);
    let n = est.poses.len();
    let part = |m: &StateMarginal| m.fixed_view::<R, R>(0, 0).into_owned();
    let mut sum = [0.0; 3];
    for k in 0..n - 1 {
        let lin = model.linearise_prior::<R, B>(est, k);
        let mut f = SMatrix::<f64, R, J>::zeros();
        for (i, j) in lin.jacobians.iter().enumerate() {
            f.fixed_view_mut::<R, 3>(0, 3 * i).copy_from(j);
        }
        let mut joint = SMatrix::<f64, J, J>::zeros();
        joint.fixed_view_mut::<R, R>(0, 0).copy_from(&part(&own[k]));
        joint
            .fixed_view_mut::<R, R>(0, R)
            .copy_from(&part(&cross[k]));
        joint
            .fixed_view_mut::<R, R>(R, 0)
            .copy_from(&part(&cross[k]).transpose());
        joint
            .fixed_view_mut::<R, R>(R, R)
            .copy_from(&part(&own[k + 1]));
        let e = lin.residual;
        let m = e * e.transpose() + f * joint * f.transpose();
        let dt = model.dt_s(k);
        for (axis, s) in sum.iter_mut().enumerate() {
            // The trace over the upper triangle, an off-diagonal entry counted twice.
            let mut trace = 0.0;
            for i in 0..order {
                for j in i..order {
                    let scale = if i == j { 1.0 } else { 2.0 };
                    trace += factors::a_inverse(order, dt, i, j, scale)
                        * m[(axis + 3 * i, axis + 3 * j)];
                }
            }
            *s += trace;
        }
    }
    sum.map(|s| s / (order as f64 * (n - 1) as f64))
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{weaving_model, weaving_run};
    use super::*;

    /// The estimation keeps the likelier start's `Qc`, and runs the second start only where
    /// the first climbed: each start's answer is what it gives alone.
    #[test]
    fn the_likelier_start_is_kept_and_a_start_from_above_is_run_alone() {
        let (times_s, regs) = weaving_run();
        let options = SmootherOptions::default();
        let model = weaving_model(&times_s, &regs, [1.0; 3]);
        let stop = EmStop {
            max_rounds: 50,
            tolerance: 1e-3,
            likelihood_tolerance: 1e-5,
        };
        let start = super::super::initial_estimates(Geometry::Se2, &times_s, &regs);
        let alone = |qc0: [f64; 3]| {
            let mut em = Em {
                options: &options,
                base: model.clone(),
                layout: model.layout(0, times_s.len()),
                sys: None,
                est: start.clone(),
                rounds: 0,
                floor: floors(&model),
            };
            let (last, evidence) = from_start(&mut em, qc0, &stop).unwrap().unwrap();
            (last.qc, evidence, em.rounds)
        };
        let (low, high) = ([1e-6; 3], [10.0; 3]);
        let (from_low, low_evidence, low_rounds) = alone(low);
        let (from_high, high_evidence, high_rounds) = alone(high);
        // Two fixed points (where each start stopped): the choice is one.
        assert_ne!(from_low, from_high);
        assert!(from_low.iter().zip(&low).any(|(q, q0)| q > q0));
        assert!(from_high.iter().zip(&high).all(|(q, q0)| q < q0));
        let both = estimate(&options, &model, start.clone(), (low, Some(high)), &stop).unwrap();
        let likelier = if high_evidence > low_evidence {
            from_high
        } else {
            from_low
        };
        assert_eq!(both.last.qc, likelier);
        assert_eq!(both.rounds, low_rounds + high_rounds);
        let from_above = estimate(&options, &model, start, (high, Some(low)), &stop).unwrap();
        assert_eq!(
            (from_above.last.qc, from_above.rounds),
            (from_high, high_rounds)
        );
    }
}
