//! The sequence smoother (`icp_core::sequence`) against independent truth: a dense Kalman
//! filter and RTS smoother on an augmented state for the linear-Gaussian case, the causal mode
//! against the batch one at the last scan, `Qc` recovered from motion drawn from the prior
//! itself, and bad input refused with typed errors.

mod jerk;
mod scan_errors;
mod sim;

use icp_core::sequence::{
    smooth, Mode, ProcessNoise, SequenceError, SequenceRegistration, SmootherOptions, SolveStop,
    TwistPrior,
};
use nalgebra::{Isometry2, Matrix3, Vector2, Vector3};
use sim::{
    assert_last_scans_equal, assert_last_steps_equal, batch_and_causal, kalman_rts,
    largest_difference, linear_options, params, simulate, surge_rmse,
};

#[test]
fn linear_gaussian_batch_equals_kalman_rts() {
    let qc = [0.02, 0.01, 1e-4];
    let lags = 3;
    let run = simulate(35_001, 60, lags, qc, true);
    let v0 = TwistPrior {
        mean: Vector3::new(1.5, 0.0, 0.0),
        cov: Matrix3::from_diagonal(&Vector3::new(1.0, 0.5, 0.01)),
    };
    let out = smooth(
        &run.times_s,
        &run.regs,
        Mode::Batch,
        &linear_options(qc, v0),
    )
    .unwrap();
    let worst = largest_difference(&out, &kalman_rts(&run, lags, &qc, &v0));
    assert!(
        worst < 1e-9,
        "largest difference from the Kalman/RTS smoother: {worst:e}"
    );
}

#[test]
fn causal_equals_batch_at_the_last_scan() {
    let qc = [0.02, 0.01, 1e-4];
    let v0 = TwistPrior {
        mean: Vector3::new(1.5, 0.0, 0.0),
        cov: Matrix3::from_diagonal(&Vector3::new(1.0, 0.5, 0.01)),
    };
    // Linear: exact.
    let run = simulate(35_002, 50, 3, qc, true);
    let opts = linear_options(qc, v0);
    let (batch, causal) = batch_and_causal(&run, &opts);
    assert_last_scans_equal(&batch, &causal);
    assert_last_steps_equal(&batch, &causal);
    // Earlier scans differ: the causal estimate has not seen their future.
    assert!((batch.scans[10].twist - causal.scans[10].twist).abs().max() > 1e-6);

    // SE(2): the window's marginal is linearised where the scan left it, so the last scan
    // agrees to a small fraction of its σ rather than exactly.
    let run = simulate(35_003, 80, 3, qc, false);
    let opts = SmootherOptions {
        process_noise: ProcessNoise::Fixed(qc),
        ..SmootherOptions::default()
    };
    let (batch, causal) = batch_and_causal(&run, &opts);
    let (b, c) = (batch.scans.last().unwrap(), causal.scans.last().unwrap());
    for i in 0..3 {
        let sigma = b.cov[(i + 3, i + 3)].sqrt();
        assert!(
            (b.twist[i] - c.twist[i]).abs() < 0.01 * sigma,
            "axis {i}: batch {} causal {} σ {sigma}",
            b.twist[i],
            c.twist[i]
        );
        let ratio = c.cov[(i + 3, i + 3)] / b.cov[(i + 3, i + 3)];
        assert!(
            (ratio - 1.0).abs() < 0.01,
            "axis {i}: variance ratio {ratio}"
        );
    }
}

#[test]
fn fixed_lag_sits_between_filter_and_batch() {
    let qc = [0.02, 0.01, 1e-4];
    let run = simulate(35_004, 200, 3, qc, false);
    let opts = SmootherOptions {
        process_noise: ProcessNoise::Fixed(qc),
        ..SmootherOptions::default()
    };
    let rmse = |mode| surge_rmse(&run, &smooth(&run.times_s, &run.regs, mode, &opts).unwrap());
    let (filter, lagged, batch) = (
        rmse(Mode::Causal { lag_scans: 0 }),
        rmse(Mode::Causal { lag_scans: 3 }),
        rmse(Mode::Batch),
    );
    assert!(
        batch < lagged && lagged < filter,
        "{batch} {lagged} {filter}"
    );
}

#[test]
fn qc_is_recovered_from_motion_drawn_from_the_prior() {
    let qc = [0.05, 0.01, 2e-4];
    let run = simulate(35_005, 865, 3, qc, false);
    let out = smooth(
        &run.times_s,
        &run.regs,
        Mode::Batch,
        &SmootherOptions::default(),
    )
    .unwrap();
    for (a, q) in qc.iter().enumerate() {
        let ratio = out.qc[a] / q;
        assert!(
            (0.7..=1.3).contains(&ratio),
            "axis {a}: estimated {} true {} (×{ratio:.3}) after {} rounds",
            out.qc[a],
            q,
            out.em_iterations
        );
    }
    // And the smoothed surge beats the lag-1 registrations' own.
    let pairwise: f64 = run
        .regs
        .iter()
        .filter(|r| r.reference == r.source + 1)
        .map(|r| {
            let dt = run.times_s[r.reference] - run.times_s[r.source];
            let v = r.t_ref_src.inverse().translation.vector.norm() / dt;
            let truth = (run.poses[r.reference].translation.vector
                - run.poses[r.source].translation.vector)
                .norm()
                / dt;
            (v - truth).powi(2)
        })
        .sum::<f64>();
    let fused: f64 = out
        .steps
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let dt = run.times_s[k + 1] - run.times_s[k];
            let v = s.t_ref_src.inverse().translation.vector.norm() / dt;
            let truth =
                (run.poses[k + 1].translation.vector - run.poses[k].translation.vector).norm() / dt;
            (v - truth).powi(2)
        })
        .sum::<f64>();
    assert!(fused < 0.5 * pairwise, "fused {fused} pairwise {pairwise}");
}

/// An axis that does not move (the sway of a vessel that does not drift) sends its `q`
/// towards 0, which EM approaches sublinearly, so `q` never settles: the estimation stops on
/// the likelihood, before its cap, with the moving axes' `Qc` recovered.
#[test]
fn an_axis_that_does_not_move_stops_the_estimation_on_the_likelihood() {
    let qc = [0.05, 1e-12, 2e-4];
    let run = simulate(35_006, 865, 3, qc, false);
    let options = SmootherOptions::default();
    let out = smooth(&run.times_s, &run.regs, Mode::Batch, &options).unwrap();
    let ProcessNoise::Estimate { max_iterations, .. } = options.process_noise else {
        panic!("the default estimates Qc");
    };
    // The rounds of both starts (the second where the first climbed): had either run to its
    // cap, the total would reach it.
    assert!(
        out.em_iterations < max_iterations,
        "{} rounds (cap {max_iterations} a start), Qc {:?}",
        out.em_iterations,
        out.qc
    );
    for a in [0, 2] {
        let ratio = out.qc[a] / qc[a];
        assert!(
            (0.7..=1.3).contains(&ratio),
            "axis {a}: estimated {} true {} (×{ratio:.3}) after {} rounds",
            out.qc[a],
            qc[a],
            out.em_iterations
        );
    }
    // The still axis: its q far below the moving ones' (in the same units as the surge's).
    assert!(out.qc[1] < 1e-3 * qc[0], "sway q {}", out.qc[1]);
}

#[test]
fn bad_input_is_refused_with_typed_errors() {
    let run = simulate(35_006, 10, 2, [0.02, 0.01, 1e-4], false);
    let opts = SmootherOptions::default();
    let mut times = run.times_s.clone();
    times[4] = times[3];
    assert!(matches!(
        smooth(&times, &run.regs, Mode::Batch, &opts),
        Err(SequenceError::NonMonotonicTime { index: 4, .. })
    ));
    times[4] = times[3] - 0.5;
    assert!(matches!(
        smooth(&times, &run.regs, Mode::Causal { lag_scans: 0 }, &opts),
        Err(SequenceError::NonMonotonicTime { index: 4, .. })
    ));
    times[4] = f64::NAN;
    assert!(matches!(
        smooth(&times, &run.regs, Mode::Batch, &opts),
        Err(SequenceError::NonFiniteTime { index: 4, .. })
    ));
    assert!(matches!(
        smooth(&run.times_s[..1], &[], Mode::Batch, &opts),
        Err(SequenceError::TooFewScans { scans: 1 })
    ));
    assert!(matches!(
        smooth(&run.times_s, &[], Mode::Batch, &opts),
        Err(SequenceError::NoRegistrations)
    ));
    let mut regs = run.regs.clone();
    regs[2].cov[(1, 1)] = -1.0;
    assert!(matches!(
        smooth(&run.times_s, &regs, Mode::Batch, &opts),
        Err(SequenceError::BadRegistration { index: 2, .. })
    ));
    let mut regs = run.regs.clone();
    regs[3].reference = regs[3].source;
    assert!(matches!(
        smooth(&run.times_s, &regs, Mode::Batch, &opts),
        Err(SequenceError::BadRegistration { index: 3, .. })
    ));
    let mut regs = run.regs.clone();
    regs[0].t_ref_src.translation.vector.x = f64::INFINITY;
    assert!(matches!(
        smooth(&run.times_s, &regs, Mode::Batch, &opts),
        Err(SequenceError::BadRegistration { index: 0, .. })
    ));
    let bad = SmootherOptions {
        process_noise: ProcessNoise::Fixed([0.1, 0.0, 0.1]),
        ..opts
    };
    assert!(matches!(
        smooth(&run.times_s, &run.regs, Mode::Batch, &bad),
        Err(SequenceError::BadOption { .. })
    ));
}

#[test]
fn a_step_no_registration_spans_rests_on_the_prior_and_says_so() {
    let run = simulate(35_007, 30, 1, [0.02, 0.01, 1e-4], false);
    // Lag 1 only; drop the registration of 12 → 13, as if flagged.
    let regs: Vec<_> = run
        .regs
        .iter()
        .filter(|r| r.source != 12)
        .copied()
        .collect();
    for mode in [Mode::Batch, Mode::Causal { lag_scans: 0 }] {
        let out = smooth(&run.times_s, &regs, mode, &SmootherOptions::default()).unwrap();
        for (k, s) in out.steps.iter().enumerate() {
            assert_eq!(s.supported, k != 12, "step {k} in {mode:?}");
            assert!(s.cov.iter().all(|v| v.is_finite()));
        }
        assert!(out.steps[12].cov[(0, 0)] > 2.0 * out.steps[11].cov[(0, 0)]);
    }
}

/// `t_ref_src` of scans `a → b` from their poses `t_world_scan`, with covariance `cov`.
fn registration(
    poses: &[Isometry2<f64>],
    a: usize,
    b: usize,
    cov: Matrix3<f64>,
) -> SequenceRegistration {
    SequenceRegistration {
        source: a,
        reference: b,
        t_ref_src: poses[b].inverse() * poses[a],
        cov,
    }
}

#[test]
fn a_turn_reversed_where_every_registration_out_of_two_scans_is_flagged_is_recovered() {
    // Turning at 1.2 rad per 1 s scan, then the other way from scan 8 on: the two scans where
    // the turn reverses have no registration of their own (all flagged), only those across lags
    // from scans 6 and 7 span them. Both solvers end on the truth (the start itself is checked
    // in `sequence::tests`: it lands where the registrations spanning the gap say).
    let n = 20;
    let times_s: Vec<f64> = (0..n).map(|k| k as f64).collect();
    let mut poses = vec![Isometry2::identity()];
    for k in 0..n - 1 {
        let yaw = if k < 8 { 1.2 } else { -1.2 };
        poses.push(poses[k] * Isometry2::new(Vector2::new(1.5, 0.1), yaw));
    }
    let cov = Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1e-6));
    let regs: Vec<SequenceRegistration> = (1..=3)
        .flat_map(|lag| (0..n - lag).map(move |a| (a, a + lag)))
        .filter(|&(a, _)| a != 8 && a != 9)
        .map(|(a, b)| registration(&poses, a, b, cov))
        .collect();
    let options = SmootherOptions {
        process_noise: ProcessNoise::Fixed([0.5, 0.5, 2.0]),
        ..SmootherOptions::default()
    };
    for mode in [Mode::Batch, Mode::Causal { lag_scans: 0 }] {
        let out = smooth(&times_s, &regs, mode, &options).unwrap();
        for (k, (s, truth)) in out.scans.iter().zip(&poses).enumerate() {
            let e = s.pose - params(truth);
            let e_rad = (e.z + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            assert!(
                e.xy().norm() < 0.05 && e_rad.abs() < 0.005,
                "scan {k} in {mode:?}: {e:?}"
            );
        }
    }
}

#[test]
fn a_solve_cut_short_says_so() {
    let qc = [0.02, 0.01, 1e-4];
    let run = simulate(35_011, 40, 2, qc, false);
    let options = SmootherOptions {
        process_noise: ProcessNoise::Fixed(qc),
        ..SmootherOptions::default()
    };
    let short = SmootherOptions {
        max_iterations: 1,
        ..options
    };
    for mode in [Mode::Batch, Mode::Causal { lag_scans: 0 }] {
        let out = smooth(&run.times_s, &run.regs, mode, &options).unwrap();
        assert_ne!(out.stop, SolveStop::IterationCap, "{mode:?}");
        let out = smooth(&run.times_s, &run.regs, mode, &short).unwrap();
        assert_eq!(out.stop, SolveStop::IterationCap, "{mode:?}");
    }
}
