//! A variant written only in user code runs through the harness like a built-in one, and its
//! report says what it is (not the chain it started from under another name).

use datasets::synthetic::{generate, Scenario};
use eval::measure::compare::compare;
use eval::measure::compare::CompareOptions;
use eval::pipeline::evaluate;
use eval::run::setup::EvalSetup;
use eval::run::setup::OffsetChoice;
use eval::run::setup::ReferenceChecks;
use icp_core::variants::{builtin, h_icp};
use icp_core::weighting::{PairView, PairWeighting};
use indicatif::ProgressBar;

/// Weights by how well the two ranges agree.
struct RangeAgreement;

impl PairWeighting for RangeAgreement {
    fn weight(&self, pair: &PairView<'_>) -> f64 {
        1.0 / (0.5 + (pair.src.range_m - pair.dst.range_m).abs())
    }
}

#[test]
fn a_user_variant_runs_compares_and_describes_itself() {
    let ds = generate(&Scenario {
        n_scans: 12,
        ..Scenario::marina_like()
    })
    .unwrap();
    let mine = h_icp().with_weighting(RangeAgreement).named("RA_ICP");
    let setup = EvalSetup {
        variants: vec![
            Box::new(builtin("H_ICP").unwrap().build().unwrap()),
            Box::new(mine),
        ],
        offset: OffsetChoice::Fixed(0),
        reference_checks: ReferenceChecks::On,
        init: Default::default(),
        global: Default::default(),
        global_check: Default::default(),
        start_gate: Default::default(),
        covariance: Default::default(),
        estimates: Vec::new(),
        lags: 1,
        sequence: Default::default(),
    };
    let report = evaluate(&ds, &setup, &ProgressBar::hidden()).unwrap();
    assert_eq!(report.variants[1].name, "RA_ICP");
    assert_eq!(report.variants[1].pairs_ok, 11);
    let spec = &report.config.variants[1];
    assert_eq!(spec.name, "RA_ICP");
    assert!(
        spec.weighting.kind.starts_with("user:") && spec.weighting.kind.contains("RangeAgreement"),
        "{}",
        spec.weighting
    );
    assert_eq!(spec.source, None, "not H_ICP's citation");
    assert_eq!(spec.robust, report.config.variants[0].robust);
    // It differs from the chain it came from, and `compare` takes it.
    assert_ne!(report.pairs[0].tx_m, report.pairs[11].tx_m);
    let rows = compare(
        &report,
        &CompareOptions {
            resamples: 200,
            seed: 0,
        },
    );
    assert!(rows.iter().any(|r| r.a == "H_ICP" && r.b == "RA_ICP"));
}
