//! A pair that cannot be registered is kept, flagged with its reason and counted; the run
//! carries on.

use datasets::synthetic::{generate, Scenario};
use eval::{evaluate, EvalSetup, OffsetChoice};
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
        rows[2].status.starts_with("failed: ")
            && rows[2].sog_est_mps.is_none()
            && !rows[2].converged
    );
    assert_eq!(rows[4].status, "ok");
    let table = eval::output::table_md(&report);
    assert!(table.contains("Failed registrations: 4."), "{table}");
}

/// Two scans of a straight corridor register to numbers, but the motion along the corridor is
/// not observable: the pair is flagged degenerate by its conditioning and kept out of the
/// statistics, not reported as a precise motion.
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
    assert!(
        row.status.starts_with("degenerate: conditioning ratio"),
        "{}",
        row.status
    );
    assert!(row.cond_ratio.unwrap() < icp_core::quality::DEGENERATE_RATIO);
    let ratios: Vec<f64> = report.pairs.iter().map(|r| r.cond_ratio.unwrap()).collect();
    assert!(ratios[0] > 0.05 && ratios[3] > 0.05, "{ratios:?}");
    assert_eq!(v.all_pairs.pairs, 1);
}
