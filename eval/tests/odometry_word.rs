//! Odometry's word on the wrong registrations (`variants[].odometry_on_wrong`), end to end: an
//! external estimator wrong by design on three pairs of the synthetic harbour, odometry written
//! to confirm one failure, side with one estimate and leave one undecided, and every verdict
//! counted where the flags put it.

mod common;

use datasets::synthetic::{generate, Scenario};
use datasets::{Dataset, LoadWarning, Pose2};
use eval::pipeline::evaluate;
use eval::run::estimates::EstimatesSpec;
use eval::run::setup::{EvalSetup, GlobalChecks, OffsetChoice, ReferenceChecks};
use icp_core::variants::builtin;
use indicatif::ProgressBar;
use nalgebra::{Isometry2, Vector2};

/// Pair 2: the estimate 0.8 m off, odometry 5 cm from the truth (confirmed). Pair 5: the
/// estimate 0.6 m off, odometry 2 cm from it (sides with the estimate). Pair 8: the estimate
/// 0.5 m off, odometry half-way (undecided). Elsewhere both are the truth.
fn offsets(pair: usize) -> (Vector2<f64>, Vector2<f64>) {
    match pair {
        2 => (Vector2::new(0.8, 0.0), Vector2::new(0.05, 0.0)),
        5 => (Vector2::new(0.0, 0.6), Vector2::new(0.0, 0.62)),
        8 => (Vector2::new(0.5, 0.0), Vector2::new(0.25, 0.0)),
        _ => (Vector2::zeros(), Vector2::zeros()),
    }
}

fn moved(t: &Isometry2<f64>, by: Vector2<f64>) -> Isometry2<f64> {
    Isometry2::new(t.translation.vector + by, t.rotation.angle())
}

#[test]
fn odometry_confirms_sides_and_abstains_as_written() {
    let mut ds: Dataset = generate(&Scenario {
        n_scans: 12,
        ..Scenario::paper()
    })
    .unwrap();
    let (pairs, _) = ds.consecutive_pairs();
    let truth: Vec<Isometry2<f64>> = pairs
        .iter()
        .map(|&p| {
            eval::data::motion(&ds, p.source, p.reference, ds.pair_dt_s(p))
                .unwrap()
                .t_ref_src
                .unwrap()
        })
        .collect();
    // Odometry poses whose pair k gives `t_ref_src` = truth moved by its odometry offset
    // (`odometry_motion`: the reference's pose inverse times the source's).
    let mut odometry = vec![Isometry2::identity()];
    for (k, t) in truth.iter().enumerate() {
        let step = moved(t, offsets(k).1);
        odometry.push(odometry[k] * step.inverse());
    }
    ds.odometry = Some(
        odometry
            .iter()
            .map(|o| Pose2 {
                x_m: o.translation.x,
                y_m: o.translation.y,
                yaw_rad: o.rotation.angle(),
            })
            .collect(),
    );
    let ds = ds.checked();
    assert!(ds.independent_odometry().is_some(), "{:?}", ds.warnings);

    let dir = common::scratch_dir("odometry_word");
    let path = dir.join("wrong.csv");
    let rows: String = pairs
        .iter()
        .zip(&truth)
        .enumerate()
        .map(|(k, (p, t))| {
            let e = moved(t, offsets(k).0);
            format!(
                "{},{},{},{},{}\n",
                p.source,
                p.reference,
                e.translation.x,
                e.translation.y,
                e.rotation.angle().to_degrees()
            )
        })
        .collect();
    std::fs::write(
        &path,
        format!("source,reference,tx_m,ty_m,theta_deg\n{rows}"),
    )
    .unwrap();
    let spec: EstimatesSpec = format!("WRONG={}", path.display()).parse().unwrap();
    let setup = EvalSetup::from_specs(&[builtin("HD_PL_ICP").unwrap()], OffsetChoice::Fixed(0))
        .unwrap()
        .with_global(Default::default(), GlobalChecks::On)
        .with_reference_checks(ReferenceChecks::Off)
        .with_estimates(vec![spec.load(&ds, &pairs).unwrap()]);
    let report = evaluate(&ds, &setup, &ProgressBar::hidden()).unwrap();

    let wrong = &report.variants[1];
    assert_eq!(wrong.name, "WRONG");
    let word = wrong.odometry_on_wrong.expect("independent odometry");
    let total = |f: fn(&eval::measure::odometry_word::Verdicts) -> usize| {
        f(&word.flagged) + f(&word.unflagged)
    };
    assert_eq!(total(|v| v.wrong), 3, "{word:?}");
    assert_eq!(total(|v| v.confirmed), 1, "{word:?}");
    assert_eq!(total(|v| v.sides_with_estimate), 1, "{word:?}");
    assert_eq!(total(|v| v.undecided), 1, "{word:?}");
    // Counted where the flags put them: as many flagged wrong ones as the flags' quality says.
    let quality = wrong.flag_quality.unwrap();
    assert_eq!(quality.wrong, 3);
    assert_eq!(
        word.flagged.wrong, quality.wrong_flagged,
        "{word:?} {quality:?}"
    );
    // HD_PL_ICP registers the harbour right: nothing wrong, nothing to judge.
    let hd = report.variants[0].odometry_on_wrong.unwrap();
    assert_eq!((hd.flagged.wrong, hd.unflagged.wrong), (0, 0));

    // The same odometry flagged as a copy of the reference: no word.
    let mut copied = ds.clone();
    copied
        .warnings
        .push(LoadWarning::OdometryEqualsReference { steps: 11 });
    let report = evaluate(&copied, &setup, &ProgressBar::hidden()).unwrap();
    assert!(report
        .variants
        .iter()
        .all(|v| v.odometry_on_wrong.is_none()));
}
