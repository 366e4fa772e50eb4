//! The prior's process noise `Qc` from the data: expectation–maximisation (Wong, Yoon,
//! Schoellig & Barfoot 2020, "Variational inference with parameter learning applied to vehicle
//! trajectory estimation"), with the batch smoother as the E-step.

use nalgebra::SMatrix;

use super::batch::{self, Marginals, SparseSystem};
use super::factors::{self, Matrix6};
use super::system::{Estimates, Layout, Model, Reg};
use super::{Geometry, SequenceError, SmootherOptions, SolveStop};

/// Smallest `q` an axis may take, so that `Q` stays invertible when an axis does not move.
const Q_FLOOR: f64 = 1e-12;

/// The batch solve at `model`'s `Qc` from `init`, with every scan's marginal covariance and
/// the cross-covariance of consecutive scans, and how the solve stopped.
pub(crate) fn batch_with_marginals(
    model: &Model<'_>,
    est: Estimates,
    options: &SmootherOptions,
) -> Result<(Estimates, Marginals, SolveStop), SequenceError> {
    let layout = model.layout(0, est.poses.len());
    let mut sys = SparseSystem::new(model, &layout, est.poses.len())?;
    let (est, marginals, (_, stop)) = solve_with_marginals(model, est, &mut sys, &layout, options)?;
    Ok((est, marginals, stop))
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
/// covariances, whose `ln det` is `2 Σ_axis ln q` plus what does not depend on `Qc`.
fn log_evidence(qc: &[f64; 3], priors: usize, cost: f64, log_det_h: f64) -> f64 {
    -cost - 0.5 * log_det_h - priors as f64 * qc.iter().map(|q| q.ln()).sum::<f64>()
}

/// A first `Qc` from the data: per axis, the mean squared change of the lag-1 registrations'
/// twists over the time between them (measurement noise included, so it starts high).
pub(crate) fn initial_qc(geometry: Geometry, times_s: &[f64], regs: &[Reg]) -> [f64; 3] {
    let n = times_s.len();
    let mut twist = vec![None; n];
    for r in regs.iter().filter(|r| r.reference == r.source + 1) {
        let motion = super::inverse_params(geometry, &r.z);
        let xi = super::log_from_origin(geometry, &motion);
        twist[r.source] = Some(xi / (times_s[r.reference] - times_s[r.source]));
    }
    let mut sum = [0.0; 3];
    let mut count = 0usize;
    for k in 0..n.saturating_sub(2) {
        if let (Some(a), Some(b)) = (twist[k], twist[k + 1]) {
            let dt = 0.5 * (times_s[k + 2] - times_s[k]);
            for (axis, s) in sum.iter_mut().enumerate() {
                *s += (b[axis] - a[axis]).powi(2) / dt;
            }
            count += 1;
        }
    }
    if count == 0 {
        return [1.0; 3];
    }
    sum.map(|s| (s / count as f64).max(Q_FLOOR))
}

/// Expectation–maximisation of `Qc` from `qc0`, accelerated by SQUAREM (Varadhan & Roland
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
/// for 0 never settles in `q`, but the likelihood does), or after `max_rounds` EM rounds;
/// returns `Qc`, the EM rounds taken and the last round's solution (a start for the solve at
/// the returned `Qc`, close to its minimum).
pub(crate) fn estimate(
    options: &SmootherOptions,
    base: &Model<'_>,
    est: Estimates,
    qc0: [f64; 3],
    stop: &EmStop,
) -> Result<([f64; 3], usize, Estimates), SequenceError> {
    let times_s = base.times_s;
    let mut em = Em {
        options,
        base: base.clone(),
        layout: base.layout(0, times_s.len()),
        sys: None,
        est,
        rounds: 0,
    };
    let tolerance = stop.tolerance;
    let settled =
        |a: &[f64; 3], b: &[f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tolerance * y);
    let per_scan = (times_s.len() - 1) as f64;
    // A round that lowered the likelihood says the approximation (Huber weights, a nonlinear
    // model) is off there, not that EM settled: only a small gain stops.
    let flat =
        |from: f64, to: f64| (0.0..=stop.likelihood_tolerance * per_scan).contains(&(to - from));
    let mut q0 = qc0;
    while em.rounds < stop.max_rounds {
        let (q1, e0) = em.round(q0)?;
        if settled(&q1, &q0) || em.rounds + 2 > stop.max_rounds {
            return Ok((q1, em.rounds, em.est));
        }
        let (q2, e1) = em.round(q1)?;
        if settled(&q2, &q1) || flat(e0, e1) {
            return Ok((q2, em.rounds, em.est));
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
                .max(Q_FLOOR)
        });
        if !jump.iter().all(|q| q.is_finite()) {
            q0 = q2;
            continue;
        }
        // An extrapolation the smoother cannot solve, or that lost likelihood: EM's q2.
        match em.round(jump) {
            Ok((q3, e_jump)) if e_jump >= e1 => {
                if settled(&q3, &q2) {
                    return Ok((q3, em.rounds, em.est));
                }
                q0 = q3;
            }
            _ => q0 = q2,
        }
    }
    Ok((q0, em.rounds, em.est))
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
}

impl Em<'_> {
    /// One EM round from `qc`: smooth (the E-step), then the M-step; also the log-likelihood
    /// of `qc` ([`log_evidence`]).
    fn round(&mut self, qc: [f64; 3]) -> Result<([f64; 3], f64), SequenceError> {
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
        let (smoothed, marginals, (cost, _)) =
            solve_with_marginals(&model, self.est.clone(), sys, &self.layout, self.options)?;
        let next = m_step(&model, &smoothed, &marginals.own, &marginals.cross);
        let evidence = log_evidence(&qc, n - 1, cost, marginals.log_det_h);
        self.est = smoothed;
        self.rounds += 1;
        Ok((next, evidence))
    }
}

/// The M-step: for each axis, `q = (1/2K) Σ_k tr(A_k⁻¹ E[e_k e_kᵀ])` over the K priors, where
/// `e_k` is the axis' (position, velocity) residual, `A_k = [[Δt³/3, Δt²/2], [Δt²/2, Δt]]` and
/// `E[e eᵀ] = ē ēᵀ + F Σ Fᵀ` with F the residual's Jacobian and Σ the joint marginal of scans k
/// and k+1.
fn m_step(model: &Model<'_>, est: &Estimates, own: &[Matrix6], cross: &[Matrix6]) -> [f64; 3] {
    let n = est.poses.len();
    let mut sum = [0.0; 3];
    for k in 0..n - 1 {
        let lin = factors::prior(
            model.geometry,
            &est.poses[k],
            &est.twists[k],
            &est.poses[k + 1],
            &est.twists[k + 1],
            model.dt_s(k),
        );
        let mut f = SMatrix::<f64, 6, 12>::zeros();
        for (i, j) in lin.jacobians.iter().enumerate() {
            f.fixed_view_mut::<6, 3>(0, 3 * i).copy_from(j);
        }
        let mut joint = SMatrix::<f64, 12, 12>::zeros();
        joint.fixed_view_mut::<6, 6>(0, 0).copy_from(&own[k]);
        joint.fixed_view_mut::<6, 6>(0, 6).copy_from(&cross[k]);
        joint
            .fixed_view_mut::<6, 6>(6, 0)
            .copy_from(&cross[k].transpose());
        joint.fixed_view_mut::<6, 6>(6, 6).copy_from(&own[k + 1]);
        let e = lin.residual;
        let m = e * e.transpose() + f * joint * f.transpose();
        let dt = model.dt_s(k);
        for (axis, s) in sum.iter_mut().enumerate() {
            let (pp, pv, vv) = (
                m[(axis, axis)],
                m[(axis, axis + 3)],
                m[(axis + 3, axis + 3)],
            );
            *s += 12.0 / dt.powi(3) * pp - 12.0 / dt.powi(2) * pv + 4.0 / dt * vv;
        }
    }
    sum.map(|s| (s / (2.0 * (n - 1) as f64)).max(Q_FLOOR))
}
