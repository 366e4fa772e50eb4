//! The smoother under white noise on jerk (`MotionPrior::WhiteJerk`) against independent
//! truth: the dense Kalman/RTS smoother of the linear-Gaussian case on a state with the
//! acceleration, the causal mode against the batch one at the last scan, and `Qc` recovered
//! from motion drawn from that prior itself.

use icp_core::sequence::{
    smooth, Mode, MotionPrior, PriorChoice, ProcessNoise, SequenceError, SmootherOptions,
    TwistPrior,
};
use nalgebra::{Matrix3, Vector3};

use super::sim::{
    assert_last_scans_equal, assert_last_steps_equal, batch_and_causal, kalman_rts_of,
    largest_difference, linear_options, simulate, simulate_shared, surge_rmse, Run,
};

/// Scan 0's twist and acceleration as the linear runs' oracle takes them.
fn initial() -> [TwistPrior; 2] {
    [
        TwistPrior {
            mean: Vector3::new(1.5, 0.0, 0.0),
            cov: Matrix3::from_diagonal(&Vector3::new(1.0, 0.5, 0.01)),
        },
        TwistPrior {
            mean: Vector3::zeros(),
            cov: Matrix3::from_diagonal(&Vector3::new(0.04, 0.01, 1e-4)),
        },
    ]
}

fn jerk_linear_options(qc: [f64; 3]) -> SmootherOptions {
    let [v0, a0] = initial();
    SmootherOptions {
        motion_prior: PriorChoice::Given(MotionPrior::WhiteJerk),
        initial_acceleration: Some(a0),
        ..linear_options(qc, v0)
    }
}

#[test]
fn linear_gaussian_batch_under_white_noise_on_jerk_equals_kalman_rts() {
    let qc = [0.02, 0.01, 1e-4];
    let lags = 3;
    let run = simulate_shared(35_101, 60, lags, qc, true, 0.0, MotionPrior::WhiteJerk);
    let out = smooth(
        &run.times_s,
        &run.regs,
        Mode::Batch,
        &jerk_linear_options(qc),
    )
    .unwrap();
    let worst = largest_difference(&out, &kalman_rts_of(&run, lags, &qc, &initial()));
    assert!(
        worst < 1e-9,
        "largest difference from the Kalman/RTS smoother: {worst:e}"
    );
    // The same run under white noise on acceleration is another model: far from the oracle.
    let other = smooth(
        &run.times_s,
        &run.regs,
        Mode::Batch,
        &linear_options(qc, initial()[0]),
    )
    .unwrap();
    let apart = (other.scans[30].twist - out.scans[30].twist).abs().max();
    assert!(apart > 1e-4, "{apart:e}");
}

/// The smoother's log-likelihood of the registrations (Laplace's approximation with every
/// constant) is exact for a linear-Gaussian model: the Kalman filter's, over its innovations,
/// under either prior.
#[test]
fn the_log_likelihood_of_a_linear_gaussian_run_is_the_kalman_filters() {
    let qc = [0.02, 0.01, 1e-4];
    let [v0, _] = initial();
    for prior in [MotionPrior::WhiteAcceleration, MotionPrior::WhiteJerk] {
        let run = simulate_shared(35_105, 60, 3, qc, true, 0.0, prior);
        let (options, oracle) = match prior {
            MotionPrior::WhiteAcceleration => (
                linear_options(qc, v0),
                kalman_rts_of(&run, 3, &qc, &initial()[..1]),
            ),
            MotionPrior::WhiteJerk => (
                jerk_linear_options(qc),
                kalman_rts_of(&run, 3, &qc, &initial()),
            ),
        };
        let out = smooth(&run.times_s, &run.regs, Mode::Batch, &options).unwrap();
        let ll = out.log_likelihood.unwrap();
        assert!(
            (ll - oracle.3).abs() < 1e-6,
            "{prior:?}: smoother {ll}, Kalman filter {}",
            oracle.3
        );
        // Not a constant that would pass anywhere: a tenth of the q is another likelihood.
        let other = SmootherOptions {
            process_noise: ProcessNoise::Fixed(qc.map(|q| q / 10.0)),
            ..options
        };
        let off = smooth(&run.times_s, &run.regs, Mode::Batch, &other).unwrap();
        assert!((off.log_likelihood.unwrap() - ll).abs() > 1.0);
    }
}

/// Each prior drawn from is the one chosen: on a run drawn from white noise on jerk the
/// registrations beyond the first scans are likelier under it, and on one drawn from white
/// noise on acceleration under that.
#[test]
fn the_likelier_prior_is_the_one_the_motion_was_drawn_from() {
    let likelier = SmootherOptions {
        motion_prior: PriorChoice::Likelier,
        ..SmootherOptions::default()
    };
    let drawn = [
        (MotionPrior::WhiteJerk, [1e-4, 1e-5, 1e-9]),
        (MotionPrior::WhiteAcceleration, [0.05, 0.01, 2e-4]),
    ];
    for (prior, qc) in drawn {
        let run = simulate_shared(35_106, 865, 3, qc, false, 0.0, prior);
        let out = smooth(&run.times_s, &run.regs, Mode::Batch, &likelier).unwrap();
        let [acceleration, jerk] = out.prior_evidence.unwrap();
        assert_eq!(
            out.motion_prior, prior,
            "predictive log-likelihood: white noise on acceleration {acceleration}, on jerk {jerk}"
        );
        // The chosen prior's solution is the one given that prior alone.
        let given = SmootherOptions {
            motion_prior: PriorChoice::Given(prior),
            ..SmootherOptions::default()
        };
        let alone = smooth(&run.times_s, &run.regs, Mode::Batch, &given).unwrap();
        assert_eq!((out.qc, out.scans), (alone.qc, alone.scans));
    }
}

#[test]
fn causal_under_white_noise_on_jerk_equals_batch_at_the_last_scan() {
    let qc = [0.02, 0.01, 1e-4];
    let run = simulate_shared(35_102, 50, 3, qc, true, 0.0, MotionPrior::WhiteJerk);
    let opts = jerk_linear_options(qc);
    let (batch, causal) = batch_and_causal(&run, &opts);
    assert_last_scans_equal(&batch, &causal);
    assert_last_steps_equal(&batch, &causal);
    assert!((batch.scans[10].twist - causal.scans[10].twist).abs().max() > 1e-6);
}

/// The RMS error of the batch solution's surge speed against the run's truth, and its `Qc`.
fn batch_surge_rmse(run: &Run, options: &SmootherOptions) -> (f64, [f64; 3]) {
    let out = smooth(&run.times_s, &run.regs, Mode::Batch, options).unwrap();
    (surge_rmse(run, &out), out.qc)
}

#[test]
fn qc_under_white_noise_on_jerk_is_recovered_from_motion_drawn_from_it() {
    // The acceleration is a random walk, so the twist wanders as time to the power 3/2: a
    // yaw q of 1e-9 rad²/s⁵ keeps the yaw rate within 0.52 rad/s over the 865 s (a registration
    // at lag 3 then turns by less than π), and the surge and sway q make each step's position
    // noise from the jerk (√(q/20) m: 2.2 and 0.7 mm) small beside the registrations' 30 mm,
    // as at the harbour's scan rate.
    let qc = [1e-4, 1e-5, 1e-9];
    let run = simulate_shared(35_103, 865, 3, qc, false, 0.0, MotionPrior::WhiteJerk);
    let jerk = SmootherOptions {
        motion_prior: PriorChoice::Given(MotionPrior::WhiteJerk),
        ..SmootherOptions::default()
    };
    let (jerk_rmse, estimated) = batch_surge_rmse(&run, &jerk);
    for (a, q) in qc.iter().enumerate() {
        let ratio = estimated[a] / q;
        assert!(
            (0.7..=1.3).contains(&ratio),
            "axis {a}: estimated {} true {} (×{ratio:.3})",
            estimated[a],
            q
        );
    }
    // On a motion whose acceleration wanders smoothly, the prior that holds it estimates the
    // speed better than a constant velocity with its own `Qc` estimated.
    let (velocity_rmse, _) = batch_surge_rmse(&run, &SmootherOptions::default());
    assert!(
        jerk_rmse < 0.8 * velocity_rmse,
        "white noise on jerk {jerk_rmse}, on acceleration {velocity_rmse}"
    );
}

#[test]
fn options_a_prior_cannot_take_are_refused() {
    let run = simulate(35_104, 10, 2, [0.02, 0.01, 1e-4], false);
    let bad = SmootherOptions {
        initial_acceleration: Some(initial()[1]),
        process_noise: ProcessNoise::Fixed([0.02, 0.01, 1e-4]),
        ..SmootherOptions::default()
    };
    assert!(matches!(
        smooth(&run.times_s, &run.regs, Mode::Batch, &bad),
        Err(SequenceError::BadOption {
            name: "initial_acceleration",
            ..
        })
    ));
    // A Qc given is one prior's: the choice between them estimates each one's.
    let bad = SmootherOptions {
        motion_prior: PriorChoice::Likelier,
        process_noise: ProcessNoise::Fixed([0.02, 0.01, 1e-4]),
        ..SmootherOptions::default()
    };
    assert!(matches!(
        smooth(&run.times_s, &run.regs, Mode::Batch, &bad),
        Err(SequenceError::BadOption {
            name: "motion_prior",
            ..
        })
    ));
}
