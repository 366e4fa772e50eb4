//! The convergence-basin protocol: seeded starts around the truth, the same for every
//! variant and thread count; a dataset without a rigid reference and bad options are refused.

use datasets::synthetic::{generate, Scenario};
use eval::error::EvalError;
use eval::measure::basin::BasinOptions;
use eval::run::setup::EvalSetup;
use eval::run::setup::OffsetChoice;
use eval::studies::basin::{check_lags, run};
use icp_core::variants::builtin;
use indicatif::ProgressBar;

fn setup(names: &[&str]) -> EvalSetup {
    let specs: Vec<_> = names.iter().map(|n| builtin(n).unwrap()).collect();
    EvalSetup::from_specs(&specs, OffsetChoice::Fixed(0)).unwrap()
}

#[test]
fn the_new_metrics_succeed_from_starts_within_a_third_of_a_metre_and_ten_degrees() {
    let ds = generate(&Scenario {
        n_scans: 9,
        ..Scenario::paper()
    })
    .unwrap();
    let options = BasinOptions {
        perturbations: 6,
        ..BasinOptions::default()
    };
    let variants = setup(&["HD_PL_ICP", "HD_GICP"]).variants;
    let in_pool = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run(&ds, &variants, &options, &ProgressBar::hidden()).unwrap())
    };
    let report = in_pool(2);
    assert_eq!(report.pairs, 8);
    assert_eq!(report.rows.len(), 8 * 6 * 2);
    for v in &report.variants {
        assert!(v.success_rate >= 0.95, "{}: {}", v.name, v.success_rate);
        let binned: usize = v.by_translation_m.iter().map(|b| b.trials).sum();
        assert_eq!(binned, v.trials, "every start falls in one bin");
    }
    // The same starts for every variant, within the limits.
    for pair in report.rows.chunks(2) {
        assert_eq!(pair[0].start_trans_m, pair[1].start_trans_m);
        assert!(pair[0].start_trans_m <= 0.3 && pair[0].start_rot_deg.abs() <= 10.0);
    }
    assert_eq!(
        in_pool(1).rows,
        report.rows,
        "thread count changed a result"
    );
}

#[test]
fn the_basin_needs_a_rigid_reference_and_valid_options() {
    let mut ds = generate(&Scenario {
        n_scans: 3,
        ..Scenario::paper()
    })
    .unwrap();
    let variants = setup(&["HD_ICP"]).variants;
    let bad = BasinOptions {
        max_rotation_deg: 200.0,
        ..BasinOptions::default()
    };
    let e = run(&ds, &variants, &bad, &ProgressBar::hidden()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "invalid option max_rotation_deg = 200: must be within [0, 180]"
    );
    ds.reference = None;
    let e = run(
        &ds,
        &variants,
        &BasinOptions::default(),
        &ProgressBar::hidden(),
    )
    .unwrap_err();
    assert!(matches!(e, EvalError::NeedsRigidReference { .. }), "{e}");
}

#[test]
fn the_basin_refuses_lags_beyond_one() {
    assert!(check_lags(1).is_ok());
    let e = check_lags(2).unwrap_err();
    assert!(matches!(e, EvalError::Lags { lags: 2, .. }), "{e}");
    assert!(e.to_string().contains("run --lags"), "{e}");
}
