//! A pair that cannot be registered is kept, flagged with its reason and counted; the run
//! carries on.

use datasets::synthetic::{generate, Scenario};
use eval::measure::report::RunReport;
use eval::pipeline::evaluate;
use eval::run::setup::EvalSetup;
use eval::run::setup::OffsetChoice;
use eval::run::status::StatusKind;
use icp_core::variants::builtin;
use icp_core::Scan;
use indicatif::ProgressBar;

#[test]
fn a_degenerate_scan_fails_its_pairs_without_stopping_the_run() {
    let mut ds = generate(&Scenario {
        n_scans: 6,
        ..Scenario::paper()
    })
    .unwrap();
    // Scan 3 sees only one straight wall: translation along it is not observable.
    let wall: Vec<[f64; 2]> = (0..100).map(|i| [5.0, -10.0 + 0.2 * i as f64]).collect();
    ds.scans[3] = Scan::from_cartesian(&wall)
        .unwrap()
        .with_timestamp(0.6)
        .unwrap();
    let specs: Vec<_> = ["H_ICP", "HD_ICP"]
        .iter()
        .map(|n| builtin(n).unwrap())
        .collect();
    let setup = EvalSetup::from_specs(&specs, OffsetChoice::Fixed(0)).unwrap();
    let report = evaluate(&ds, &setup, &ProgressBar::hidden()).unwrap();
    assert_eq!(report.dataset.pairs, 5);
    for v in &report.variants {
        assert_eq!(v.pairs_ok, 3, "{}", v.name);
        let failed: Vec<usize> = v.failures.iter().map(|f| f.pair).collect();
        assert_eq!(failed, vec![2, 3], "{}", v.name);
        assert!(
            v.failures.iter().all(|f| f.reason.contains("collinear")),
            "{:?}",
            v.failures
        );
        assert_eq!(
            v.all_pairs.pairs, 3,
            "statistics count only registered pairs"
        );
        assert_eq!(v.all_pairs.sog_err_mps.unwrap().n, 3);
        assert_eq!(v.trajectory.gaps, 2);
    }
    let rows: Vec<_> = report
        .pairs
        .iter()
        .filter(|r| r.variant == "HD_ICP")
        .collect();
    assert_eq!(rows.len(), 5, "failed pairs stay in pairs.csv");
    assert!(
        rows[2].status == StatusKind::Failed
            && rows[2].status_reason.contains("collinear")
            && rows[2].sog_est_mps.is_none()
            && rows[2].converged.is_none()
    );
    assert_eq!(rows[4].status, StatusKind::Ok);
    assert!(rows[4].status_reason.is_empty());
    assert!(
        (v_rate(&report, "HD_ICP") - 0.4).abs() < 1e-12,
        "2 of 5 pairs failed"
    );
    let table = eval::render::markdown::table_md(&report);
    assert!(
        table.contains("| HD_ICP | 3 | 2 | 0 | 0 | 0 | 0 | 40.0 % | 60.0 % |"),
        "{table}"
    );
}

fn v_rate(report: &RunReport, name: &str) -> f64 {
    report
        .variants
        .iter()
        .find(|v| v.name == name)
        .unwrap()
        .failure_rate
}

/// Two scans of a straight corridor register to numbers, but the motion along the corridor is
/// not observable: the pair is flagged degenerate by its conditioning and counted as a failure
/// of the variant, not reported as a precise motion; its number stays in the statistics.
#[test]
fn a_corridor_pair_is_flagged_degenerate() {
    let mut ds = generate(&Scenario {
        n_scans: 5,
        ..Scenario::paper()
    })
    .unwrap();
    let corridor = |shift: f64, t: f64| {
        let mut pts = Vec::new();
        for y in [3.0, -3.0] {
            for i in 0..200 {
                pts.push([-20.0 + 0.2 * i as f64 + shift, y]);
            }
        }
        Scan::from_cartesian(&pts)
            .unwrap()
            .with_timestamp(t)
            .unwrap()
    };
    ds.scans[2] = corridor(0.0, 0.4);
    ds.scans[3] = corridor(-0.07, 0.6);
    let setup =
        EvalSetup::from_specs(&[builtin("HD_ICP").unwrap()], OffsetChoice::Fixed(0)).unwrap();
    let report = evaluate(&ds, &setup, &ProgressBar::hidden()).unwrap();
    let v = &report.variants[0];
    // Pair 2 (corridor onto corridor) is matched against the corridor's two walls. Pairs 1
    // (harbour onto corridor) and 3 (corridor onto harbour) see different surfaces and are
    // flagged for that first.
    assert_eq!(v.degenerate_pairs, vec![2]);
    assert_eq!(v.no_overlap_pairs, vec![1, 3]);
    assert_eq!(v.pairs_ok, 1);
    let row = &report.pairs[2];
    assert_eq!(row.status, StatusKind::Degenerate);
    assert!(
        row.status_reason.starts_with("conditioning ratio"),
        "{}",
        row.status_reason
    );
    assert!(row.cond_ratio.unwrap() < icp_core::quality::DEGENERATE_RATIO);
    let ratios: Vec<f64> = report.pairs.iter().map(|r| r.cond_ratio.unwrap()).collect();
    assert!(ratios[0] > 0.05 && ratios[3] > 0.05, "{ratios:?}");
    // Every pair was registered: the flagged ones are failures, and stay in the statistics.
    assert_eq!(v.all_pairs.pairs, 4);
    assert_eq!(report.population.pairs, 4);
    assert!((v.failure_rate - 0.75).abs() < 1e-12, "{}", v.failure_rate);
}

/// HD_ICP, except that it gives up on the pair whose source scan was taken at `fail_at_s`.
struct GivesUpOnce {
    inner: icp_core::Icp,
    fail_at_s: f64,
}

impl icp_core::Registrar for GivesUpOnce {
    fn name(&self) -> &str {
        "GIVES_UP"
    }
    fn spec(&self) -> icp_core::variants::VariantSpec {
        self.inner.spec()
    }
    fn surface_params(&self) -> icp_core::SurfaceParams {
        self.inner.surface_params()
    }
    fn register_prepared(
        &self,
        workspace: &mut icp_core::Workspace,
        source: icp_core::Prepared<'_>,
        reference: icp_core::Prepared<'_>,
        init: nalgebra::Isometry2<f64>,
    ) -> Result<icp_core::Registration, icp_core::IcpError> {
        if source.scan.timestamp_s() == Some(self.fail_at_s) {
            return Err(icp_core::IcpError::NonFiniteTransform);
        }
        self.inner
            .register_prepared(workspace, source, reference, init)
    }
}

/// Equal populations: a pair one variant did not register leaves every variant's statistics
/// (so none is judged on pairs another could not do), and it is charged as a failure to the
/// variant that failed only.
#[test]
fn a_pair_one_variant_fails_leaves_every_variants_statistics_and_charges_that_variant() {
    let ds = generate(&Scenario {
        n_scans: 8,
        ..Scenario::paper()
    })
    .unwrap();
    let fail_at_s = ds.scans[3].timestamp_s().unwrap();
    let setup = EvalSetup {
        variants: vec![
            Box::new(builtin("HD_ICP").unwrap().build().unwrap()),
            Box::new(GivesUpOnce {
                inner: builtin("HD_ICP").unwrap().build().unwrap(),
                fail_at_s,
            }),
        ],
        offset: OffsetChoice::Fixed(0),
        reference_checks: eval::run::setup::ReferenceChecks::On,
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
    assert_eq!(report.population.pairs, 6);
    assert_eq!(report.population.left_out, vec![3]);
    let (plain, gives_up) = (&report.variants[0], &report.variants[1]);
    assert_eq!(
        plain.all_pairs.pairs, 6,
        "pair 3 leaves HD_ICP's statistics too"
    );
    assert_eq!(gives_up.all_pairs.pairs, 6);
    assert_eq!(
        plain.all_pairs, gives_up.all_pairs,
        "same method, same pairs: same figures"
    );
    assert_eq!(plain.failure_rate, 0.0);
    assert!((gives_up.failure_rate - 1.0 / 7.0).abs() < 1e-12);
    let row = |v: &str| {
        report
            .pairs
            .iter()
            .find(|r| r.variant == v && r.pair == 3)
            .unwrap()
    };
    assert_eq!(row("HD_ICP").status, StatusKind::Ok);
    assert!(!row("HD_ICP").all_registered && !row("GIVES_UP").all_registered);
    assert_eq!(row("GIVES_UP").status, StatusKind::Failed);
}

/// A scan most of whose scene moves (runs of returns pulled in to half their range, where the
/// neighbouring scans saw the harbour's walls behind them): the variants with a detector of
/// moving returns flag its pairs with the reason, and no pair gives a silent gross number.
#[test]
fn a_scan_whose_scene_mostly_moves_flags_its_pairs() {
    let mut ds = generate(&Scenario {
        n_scans: 40,
        ..Scenario::paper()
    })
    .unwrap();
    let k = 20;
    let scan = &ds.scans[k];
    let pulled: Vec<[f64; 2]> = scan
        .returns()
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let f = if (i / 40) % 4 == 3 { 1.0 } else { 0.5 };
            [f * r.point.x, f * r.point.y]
        })
        .collect();
    ds.scans[k] = Scan::from_cartesian(&pulled)
        .unwrap()
        .with_timestamp(scan.timestamp_s().unwrap())
        .unwrap();
    let specs: Vec<_> = ["PL_ICP", "GICP"]
        .iter()
        .map(|n| builtin(n).unwrap())
        .collect();
    let setup = EvalSetup::from_specs(&specs, OffsetChoice::Fixed(0))
        .unwrap()
        .with_covariance(eval::run::covariance::CovarianceMode::Extended)
        .with_global(
            icp_core::global::GlobalParams::default(),
            eval::run::setup::GlobalChecks::On,
        );
    let report = evaluate(&ds, &setup, &ProgressBar::hidden()).unwrap();
    for r in &report.pairs {
        let touches = r.source == k || r.reference == k;
        assert_eq!(
            r.status != StatusKind::Ok,
            touches,
            "{} pair {}: {:?} {}",
            r.variant,
            r.pair,
            r.status,
            r.status_reason
        );
        if r.status == StatusKind::Ok {
            let e = r.sog_err_mps.expect("a rigid reference");
            assert!(
                e.abs() < 0.5,
                "{} pair {}: silent {e} m/s",
                r.variant,
                r.pair
            );
        }
        if r.status == StatusKind::Isolated {
            assert!(
                r.status_reason.contains("scan 20 fits neither neighbour"),
                "{}",
                r.status_reason
            );
        }
    }
    // GICP's registration of the pulled-in scan onto its successor (10 m off) was once `ok`
    // by its own check, and flagged `isolated` from the placing registrations; the check's
    // relative bar now flags it `suspect` itself (a pose scoring 0.18 against its 0.15). Either
    // way it says the scan does not fit; the `isolated` rule is tested in `run::moving`'s
    // unit tests.
    let gicp = report
        .pairs
        .iter()
        .find(|r| r.variant == "GICP" && r.source == k && r.reference == k + 1)
        .expect("GICP's pair from the pulled-in scan");
    assert!(
        matches!(gicp.status, StatusKind::Suspect | StatusKind::Isolated),
        "{:?} {}",
        gicp.status,
        gicp.status_reason
    );
}
