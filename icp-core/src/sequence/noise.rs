//! The prior's process noise `Qc` from the data: expectation–maximisation (Wong, Yoon,
//! Schoellig & Barfoot 2020, "Variational inference with parameter learning applied to vehicle
//! trajectory estimation"), with the batch smoother as the E-step.

use nalgebra::SMatrix;

use super::batch::{self, SparseSystem};
use super::factors::{self, Matrix6};
use super::system::{Estimates, Model, Reg};
use super::{full_layout, Geometry, SequenceError, SmootherOptions};

/// Smallest `q` an axis may take, so that `Q` stays invertible when an axis does not move.
const Q_FLOOR: f64 = 1e-12;

/// The batch solve at `model`'s `Qc` from `init`, with every scan's marginal covariance and
/// the cross-covariance of consecutive scans.
pub(crate) fn batch_with_marginals(
    model: &Model<'_>,
    mut est: Estimates,
    options: &SmootherOptions,
) -> Result<(Estimates, Vec<Matrix6>, Vec<Matrix6>), SequenceError> {
    let n = est.poses.len();
    let layout = full_layout(n);
    let mut sys = SparseSystem::new(model, &layout, n)?;
    let (llt, _) = batch::solve(
        model,
        &mut est,
        &mut sys,
        &layout,
        options.max_iterations,
        options.tolerance,
    )?;
    let (own, cross) = batch::marginals(&llt, &layout, n);
    Ok((est, own, cross))
}

/// A first `Qc` from the data: per axis, the mean squared change of the lag-1 registrations'
/// twists over the time between them (measurement noise included, so it starts high).
pub(crate) fn initial_qc(geometry: Geometry, times_s: &[f64], regs: &[Reg]) -> [f64; 3] {
    let n = times_s.len();
    let mut twist = vec![None; n];
    for r in regs.iter().filter(|r| r.reference == r.source + 1) {
        let motion = super::inverse_params(geometry, &r.z);
        let (xi, _, _) = factors::log_between(geometry, &nalgebra::Vector3::zeros(), &motion);
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

/// Expectation–maximisation of `Qc` from `qc0`: returns `Qc` and the rounds taken.
pub(crate) fn estimate(
    options: &SmootherOptions,
    times_s: &[f64],
    regs: &[Reg],
    mut est: Estimates,
    qc0: [f64; 3],
    max_iterations: usize,
    tolerance: f64,
) -> Result<([f64; 3], usize), SequenceError> {
    let mut qc = qc0;
    for round in 1..=max_iterations {
        let model = Model {
            geometry: options.geometry,
            times_s,
            regs,
            qc,
            huber_k: options.huber_k,
            twist0: super::twist0(options)?,
        };
        let (smoothed, own, cross) = batch_with_marginals(&model, est, options)?;
        let next = m_step(&model, &smoothed, &own, &cross);
        est = smoothed;
        let settled = next
            .iter()
            .zip(&qc)
            .all(|(a, b)| (a - b).abs() <= tolerance * b);
        qc = next;
        if settled {
            return Ok((qc, round));
        }
    }
    Ok((qc, max_iterations))
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
