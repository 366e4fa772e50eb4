//! The reference-noise estimator against known noise: the synthetic harbour's exact reference
//! perturbed by white and by step-correlated noise of known size, the truth being the realised
//! step errors themselves (not the formula the estimator assumes).

use datasets::synthetic::{generate, Scenario};
use eval::measure::reference_noise::{estimate, ReferenceNoise, TimedPose};
use icp_core::motion::wrap_deg;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// The exact reference poses of `scenario`, timed.
fn exact(scenario: Scenario) -> Vec<TimedPose> {
    let ds = generate(&scenario).unwrap();
    ds.reference
        .as_ref()
        .unwrap()
        .iter()
        .enumerate()
        .map(|(k, p)| TimedPose {
            t_s: k as f64 * ds.dt_s,
            x_m: p.x_m,
            y_m: p.y_m,
            heading_rad: p.heading_rad,
        })
        .collect()
}

/// AR(1) noise of standard deviation `sigma` and lag-1 correlation `rho`, `n` values.
fn ar1(rng: &mut ChaCha8Rng, n: usize, sigma: f64, rho: f64) -> Vec<f64> {
    let w = Normal::new(0.0, sigma).unwrap();
    let mut v = Vec::with_capacity(n);
    let mut prev = w.sample(rng);
    v.push(prev);
    for _ in 1..n {
        prev = rho * prev + (1.0 - rho * rho).sqrt() * w.sample(rng);
        v.push(prev);
    }
    v
}

/// The poses perturbed by AR(1) noise (`sigma_m` per coordinate, `sigma_deg` in heading).
fn perturbed(poses: &[TimedPose], sigma_m: f64, sigma_deg: f64, rho: f64) -> Vec<TimedPose> {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let n = poses.len();
    let (nx, ny) = (
        ar1(&mut rng, n, sigma_m, rho),
        ar1(&mut rng, n, sigma_m, rho),
    );
    let nh = ar1(&mut rng, n, sigma_deg.to_radians(), rho);
    poses
        .iter()
        .enumerate()
        .map(|(k, p)| TimedPose {
            x_m: p.x_m + nx[k],
            y_m: p.y_m + ny[k],
            heading_rad: p.heading_rad + nh[k],
            ..*p
        })
        .collect()
}

/// The realised RMS step errors of `noisy` against `exact`: translation m, rotation deg, SOG
/// m/s (speed = step length over time).
fn realised(exact: &[TimedPose], noisy: &[TimedPose]) -> (f64, f64, f64) {
    let step = |p: &[TimedPose], k: usize| {
        let (a, b) = (p[k], p[k + 1]);
        (
            b.x_m - a.x_m,
            b.y_m - a.y_m,
            wrap_deg((b.heading_rad - a.heading_rad).to_degrees()),
            (b.x_m - a.x_m).hypot(b.y_m - a.y_m) / (b.t_s - a.t_s),
        )
    };
    let n = exact.len() - 1;
    let (mut t2, mut r2, mut s2) = (0.0, 0.0, 0.0);
    for k in 0..n {
        let (e, m) = (step(exact, k), step(noisy, k));
        t2 += (m.0 - e.0).powi(2) + (m.1 - e.1).powi(2);
        r2 += (m.2 - e.2).powi(2);
        s2 += (m.3 - e.3).powi(2);
    }
    let rms = |v: f64| (v / n as f64).sqrt();
    (rms(t2), rms(r2), rms(s2))
}

fn assert_within(estimate: &ReferenceNoise, truth: (f64, f64, f64), tol: f64) {
    let ratio = [
        estimate.step_trans_m / truth.0,
        estimate.step_rot_deg / truth.1,
        estimate.sog_mps / truth.2,
        estimate.dcog_deg / truth.1,
    ];
    assert!(
        ratio.iter().all(|r| (r - 1.0).abs() <= tol),
        "estimate/truth {ratio:?}: {estimate:?} against {truth:?}"
    );
}

#[test]
fn white_and_correlated_noise_are_recovered_where_steps_are_small() {
    // The paper's harbour: 0.2 s steps of about 0.24 m.
    let poses = exact(Scenario::paper());
    for (sigma_m, sigma_deg, rho) in [(0.01, 0.2, 0.0), (0.02, 0.5, 0.0), (0.01, 0.2, 0.5)] {
        let noisy = perturbed(&poses, sigma_m, sigma_deg, rho);
        let est = estimate(&noisy).unwrap();
        assert!(!est.upper_bound, "{sigma_m} {sigma_deg} {rho}: {est:?}");
        // Noise alone: 2nd differences correlate about −2/3 (−0.55 at ρ = 0.5).
        let expected = if rho == 0.0 { -2.0 / 3.0 } else { -0.55 };
        assert!(
            est.lag1_correlation
                .iter()
                .all(|c| (c - expected).abs() < 0.08),
            "{est:?}"
        );
        assert_within(&est, realised(&poses, &noisy), 0.2);
    }
}

#[test]
fn coarse_steps_give_an_upper_bound() {
    // The same track every 1 s: its yaw in the chop (0.6° over 8 s) and its turns dominate
    // noise of 1 mm and 0.005°.
    let poses = exact(Scenario::marina_like());
    let noisy = perturbed(&poses, 0.001, 0.005, 0.0);
    let est = estimate(&noisy).unwrap();
    assert!(est.upper_bound, "{est:?}");
    assert!(est.why_upper_bound.is_some());
    // An upper bound: never below the truth.
    let truth = realised(&poses, &noisy);
    assert!(est.step_rot_deg >= truth.1, "{est:?} {truth:?}");
    assert!(est.step_trans_m >= truth.0, "{est:?} {truth:?}");
    // With noise the size of a GNSS fix's (2 cm, 0.2°) the chop's yaw still makes up much of
    // the heading's 2nd differences at 1 s (they correlate about −0.2, not −2/3): an upper
    // bound, though order 3 lands within 20 % here.
    let noisy = perturbed(&poses, 0.02, 0.2, 0.0);
    let est = estimate(&noisy).unwrap();
    assert!(est.upper_bound, "{est:?}");
    assert!(est.lag1_correlation[2] > -0.45, "{est:?}");
    assert_within(&est, realised(&poses, &noisy), 0.2);
}

#[test]
fn random_accelerations_give_an_upper_bound() {
    // A robot that turns and speeds up at random between scans 1 s apart (white
    // accelerations of 0.3 m/s² and 20°/s²: aces-like), its poses with 1 cm and 0.2° of
    // noise: the orders agree (random motion looks like noise to both), but the 2nd
    // differences do not correlate like noise.
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (acc, yaw_acc) = (
        Normal::new(0.0, 0.3).unwrap(),
        Normal::new(0.0, 20.0).unwrap(),
    );
    let (mut x, mut y, mut h, mut v, mut w) = (0.0, 0.0, 0.0f64, 0.5, 0.0);
    let exact: Vec<TimedPose> = (0..400)
        .map(|k| {
            let p = TimedPose {
                t_s: k as f64,
                x_m: x,
                y_m: y,
                heading_rad: h.to_radians(),
            };
            v = f64::clamp(v + acc.sample(&mut rng), 0.0, 1.5);
            w += yaw_acc.sample(&mut rng);
            w *= 0.5;
            h += w;
            x += v * h.to_radians().cos();
            y += v * h.to_radians().sin();
            p
        })
        .collect();
    let noisy = perturbed(&exact, 0.01, 0.2, 0.0);
    let est = estimate(&noisy).unwrap();
    assert!(est.upper_bound, "{est:?}");
    let truth = realised(&exact, &noisy);
    assert!(est.step_rot_deg >= truth.1 && est.step_trans_m >= truth.0);
}

#[test]
fn exact_ground_truth_has_no_noise_to_estimate() {
    let ds = generate(&Scenario {
        n_scans: 40,
        ..Scenario::paper()
    })
    .unwrap();
    assert!(eval::measure::reference_noise::of_dataset(&ds).is_none());
}

#[test]
fn a_measured_reference_too_short_for_its_noise_says_so() {
    let mut ds = generate(&Scenario {
        n_scans: 12,
        ..Scenario::paper()
    })
    .unwrap();
    ds.reference_kind = Some(datasets::ReferenceKind::SlamCorrected);
    let setup = eval::EvalSetup::from_specs(
        &[icp_core::variants::builtin("PL_ICP").unwrap()],
        eval::OffsetChoice::Fixed(0),
    )
    .unwrap();
    let report = eval::evaluate(&ds, &setup, &indicatif::ProgressBar::hidden()).unwrap();
    assert_eq!(report.reference.noise, None);
    let note = report.reference.noise_note.as_deref().unwrap();
    assert!(
        note.contains("12 poses") && note.contains("at least 23"),
        "{note}"
    );
    let md = eval::render::markdown::table_md(&report);
    assert!(
        md.contains("The reference's own noise is not estimated"),
        "{md}"
    );
}
