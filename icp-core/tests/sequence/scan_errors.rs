//! Scan errors (`icp_core::sequence::ScanErrors`): registrations that share a scan share its
//! error. Against independent truth: a dense generalised least-squares solution with the
//! registrations' joint covariance written out (the scans' errors marginalised by hand), and
//! runs drawn from the model itself, whose share the loops must recover and whose fused σ
//! must hold.

use icp_core::sequence::{smooth, Mode, MotionPrior, ScanErrors, SmootherOptions, TwistPrior};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use crate::sim::{
    assert_last_scans_equal, linear_options, params, q_matrix, scan_error_covariances,
    simulate_shared, Run,
};

/// The posterior mean and covariance of `[p_1 … p_n−1, v_0 … v_n−1]` for the linear model
/// with the registrations' joint covariance `R = E S Eᵀ + (1 − share) Σ`: every registration
/// `a → b` sees `e_a − e_b`, so two that share a scan are correlated through its `S_k`.
fn generalised_least_squares(
    run: &Run,
    qc: &[f64; 3],
    v0: &TwistPrior,
    share: f64,
) -> (DVector<f64>, DMatrix<f64>) {
    let n = run.times_s.len();
    let dim = 3 * (n - 1) + 3 * n;
    let p = |k: usize| (k >= 1).then(|| 3 * (k - 1));
    let v = |k: usize| 3 * (n - 1) + 3 * k;
    let mut info = DMatrix::zeros(dim, dim);
    let mut eta = DVector::zeros(dim);
    let eye = Matrix3::<f64>::identity();
    for k in 0..n - 1 {
        let dt = run.times_s[k + 1] - run.times_s[k];
        let mut a = DMatrix::zeros(6, dim);
        a.view_mut((0, p(k + 1).unwrap()), (3, 3)).copy_from(&eye);
        if let Some(pk) = p(k) {
            a.view_mut((0, pk), (3, 3)).copy_from(&(-eye));
        }
        a.view_mut((0, v(k)), (3, 3)).copy_from(&(-eye * dt));
        a.view_mut((3, v(k + 1)), (3, 3)).copy_from(&eye);
        a.view_mut((3, v(k)), (3, 3)).copy_from(&(-eye));
        let q = q_matrix(qc, dt).try_inverse().unwrap();
        let q = DMatrix::from_iterator(6, 6, q.iter().copied());
        info += a.transpose() * q * &a;
    }
    let p0 = v0.cov.try_inverse().unwrap();
    let mut block = info.view_mut((v(0), v(0)), (3, 3));
    block += p0;
    eta.rows_mut(v(0), 3).copy_from(&(p0 * v0.mean));
    let m = run.regs.len();
    let spans: Vec<_> = run
        .regs
        .iter()
        .map(|r| (r.source, r.reference, r.cov))
        .collect();
    let s = scan_error_covariances(&run.poses, &spans, share, true);
    let mut h = DMatrix::zeros(3 * m, dim);
    let mut r = DMatrix::zeros(3 * m, 3 * m);
    let mut z = DVector::zeros(3 * m);
    let sign = |reg: &(usize, usize, Matrix3<f64>), k: usize| {
        if k == reg.0 {
            1.0
        } else if k == reg.1 {
            -1.0
        } else {
            0.0
        }
    };
    for (i, reg) in spans.iter().enumerate() {
        if let Some(pa) = p(reg.0) {
            h.view_mut((3 * i, pa), (3, 3)).copy_from(&eye);
        }
        h.view_mut((3 * i, p(reg.1).unwrap()), (3, 3))
            .copy_from(&(-eye));
        z.rows_mut(3 * i, 3)
            .copy_from(&params(&run.regs[i].t_ref_src));
        let mut own = r.view_mut((3 * i, 3 * i), (3, 3));
        own += reg.2 * (1.0 - share);
        for (j, other) in spans.iter().enumerate() {
            for k in [reg.0, reg.1] {
                let c = sign(reg, k) * sign(other, k);
                if c != 0.0 {
                    let mut cross = r.view_mut((3 * i, 3 * j), (3, 3));
                    cross += s[k] * c;
                }
            }
        }
    }
    let r_inv = r.try_inverse().unwrap();
    info += h.transpose() * &r_inv * &h;
    eta += h.transpose() * &r_inv * z;
    let cov = info.try_inverse().unwrap();
    (&cov * eta, cov)
}

#[test]
fn linear_gaussian_with_scan_errors_equals_generalised_least_squares() {
    let qc = [0.02, 0.01, 1e-4];
    let share = 0.6;
    let run = simulate_shared(
        35_101,
        40,
        3,
        qc,
        true,
        share,
        MotionPrior::WhiteAcceleration,
    );
    let v0 = TwistPrior {
        mean: Vector3::new(1.5, 0.0, 0.0),
        cov: Matrix3::from_diagonal(&Vector3::new(1.0, 0.5, 0.01)),
    };
    let options = SmootherOptions {
        scan_errors: ScanErrors::Share(share),
        ..linear_options(qc, v0)
    };
    let out = smooth(&run.times_s, &run.regs, Mode::Batch, &options).unwrap();
    assert_eq!(out.scan_share.share, share);
    let (mean, cov) = generalised_least_squares(&run, &qc, &v0, share);
    let n = run.times_s.len();
    // Rows of scan k's [p; v] in the oracle's state (scan 0's pose is the frame).
    let rows = |k: usize| -> Vec<Option<usize>> {
        (0..6)
            .map(|i| match i {
                0..3 => (k >= 1).then(|| 3 * (k - 1) + i),
                _ => Some(3 * (n - 1) + 3 * k + i - 3),
            })
            .collect()
    };
    let mut worst: f64 = 0.0;
    for (k, s) in out.scans.iter().enumerate() {
        let rk = rows(k);
        for i in 0..6 {
            let est = if i < 3 { s.pose[i] } else { s.twist[i - 3] };
            worst = worst.max((est - rk[i].map_or(0.0, |r| mean[r])).abs());
            for j in 0..6 {
                let oracle = match (rk[i], rk[j]) {
                    (Some(a), Some(b)) => cov[(a, b)],
                    _ => 0.0,
                };
                worst = worst.max((s.cov[(i, j)] - oracle).abs());
            }
        }
    }
    for (k, s) in out.steps.iter().enumerate() {
        // Linear t_ref_src of k → k+1 is p_k − p_k+1.
        let (a, b) = (rows(k), rows(k + 1));
        let at = |r: &Vec<Option<usize>>, i: usize| r[i].map_or(0.0, |x| mean[x]);
        let c =
            |r: &Vec<Option<usize>>, s: &Vec<Option<usize>>, i: usize, j: usize| match (r[i], s[j])
            {
                (Some(x), Some(y)) => cov[(x, y)],
                _ => 0.0,
            };
        for i in 0..3 {
            worst = worst.max((params(&s.t_ref_src)[i] - (at(&a, i) - at(&b, i))).abs());
            for j in 0..3 {
                let oracle = c(&a, &a, i, j) - c(&a, &b, i, j) - c(&b, &a, i, j) + c(&b, &b, i, j);
                worst = worst.max((s.cov[(i, j)] - oracle).abs());
            }
        }
    }
    assert!(
        worst < 1e-9,
        "largest difference from the dense solution: {worst:e}"
    );

    // The causal mode's window and marginal carry the scans' errors too: at the last scan
    // it is the batch solution.
    let causal = smooth(
        &run.times_s,
        &run.regs,
        Mode::Causal { lag_scans: 0 },
        &options,
    )
    .unwrap();
    assert_last_scans_equal(&out, &causal);
}

/// ANEES/3 of the fused steps against the truth, and the RMSE of their surge.
fn fused_figures(run: &Run, options: &SmootherOptions) -> (f64, f64, f64) {
    let out = smooth(&run.times_s, &run.regs, Mode::Batch, options).unwrap();
    let (mut nees, mut se) = (0.0, 0.0);
    for (k, s) in out.steps.iter().enumerate() {
        let truth = params(&(run.poses[k + 1].inverse() * run.poses[k]));
        let mut d = params(&s.t_ref_src) - truth;
        d.z = (d.z + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        nees += d.dot(&(s.cov.try_inverse().unwrap() * d));
        se += d.x * d.x;
    }
    let steps = out.steps.len() as f64;
    (
        nees / steps / 3.0,
        (se / steps).sqrt(),
        out.scan_share.share,
    )
}

#[test]
fn the_share_is_recovered_from_the_loops_and_the_fused_sigma_holds() {
    let qc = [0.05, 0.01, 2e-4];
    let run = simulate_shared(
        35_102,
        865,
        3,
        qc,
        false,
        0.8,
        MotionPrior::WhiteAcceleration,
    );
    let shared = SmootherOptions::default();
    let (anees, rmse, share) = fused_figures(&run, &shared);
    assert!((share - 0.8).abs() < 0.03, "share estimated {share}");
    assert!((0.85..=1.15).contains(&anees), "ANEES/3 {anees}");
    // Taken as independent, the same registrations give a σ that does not hold and a worse
    // fused motion.
    let independent = SmootherOptions {
        scan_errors: ScanErrors::Independent,
        ..shared
    };
    let (anees_ind, rmse_ind, _) = fused_figures(&run, &independent);
    assert!(
        !(0.7..=1.4).contains(&anees_ind),
        "independent ANEES/3 {anees_ind}"
    );
    assert!(
        rmse < rmse_ind,
        "surge RMSE {rmse} m (independent {rmse_ind} m)"
    );
}

#[test]
fn independent_registrations_give_them_no_share() {
    let qc = [0.05, 0.01, 2e-4];
    let run = simulate_shared(
        35_103,
        865,
        3,
        qc,
        false,
        0.0,
        MotionPrior::WhiteAcceleration,
    );
    let out = smooth(
        &run.times_s,
        &run.regs,
        Mode::Batch,
        &SmootherOptions::default(),
    )
    .unwrap();
    assert!(
        out.scan_share.loops > 1700,
        "{} loops",
        out.scan_share.loops
    );
    assert!(
        out.scan_share.share < 0.03,
        "share estimated {}",
        out.scan_share.share
    );
}
