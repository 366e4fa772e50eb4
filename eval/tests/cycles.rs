//! Loops across lags (`--lags`) on the synthetic harbour: consistent registrations close their
//! loops and are not flagged, a corrupted middle one is (but not by a lag-2 registration whose
//! scans fit twice), and bad lags are typed errors.

use datasets::synthetic::{generate, Scenario};
use datasets::Dataset;
use eval::measure::cycles;
use eval::run::init::InitChain;
use eval::run::lags::{self, LagRuns};
use eval::run::runner::{run_all, Methods, PairSearch, RunPlan, Runs};
use eval::run::setup::{EvalSetup, OffsetChoice, ReferenceChecks};
use eval::run::status::{PairStatus, StatusKind};
use eval::{evaluate, EvalError};
use icp_core::global::{GlobalGuess, GlobalParams};
use icp_core::variants::builtin;
use indicatif::ProgressBar;

fn dataset() -> Dataset {
    generate(&Scenario {
        n_scans: 14,
        ..Scenario::paper()
    })
    .unwrap()
}

fn setup(lags: usize) -> EvalSetup {
    let specs = [builtin("HD_ICP").unwrap(), builtin("PL_ICP").unwrap()];
    EvalSetup::from_specs(&specs, OffsetChoice::Fixed(0))
        .unwrap()
        .with_reference_checks(ReferenceChecks::Off)
        .with_lags(lags)
}

#[test]
fn consistent_registrations_close_their_loops_and_are_not_flagged() {
    let ds = dataset();
    let report = evaluate(&ds, &setup(3), &ProgressBar::hidden()).unwrap();
    // 13 pairs: 12 triangles and 11 loops of three steps per variant.
    assert_eq!(report.cycles.len(), 2 * (12 + 11));
    for v in &report.variants {
        let c = v.cycles.as_ref().unwrap();
        assert_eq!((c.triangles, c.inconsistent), (12, 0), "{}", v.name);
        assert!(c.median_trans_m.unwrap() < 0.02, "{c:?}");
        assert!(v.inconsistent_pairs.is_empty());
    }
    assert!(
        report.cycles.iter().all(|r| r.status == "closed"),
        "{:?}",
        report.cycles
    );
    assert!(report
        .pairs
        .iter()
        .all(|r| r.status != StatusKind::Inconsistent));
    let md = eval::render::markdown::table_md(&report);
    assert!(
        md.contains("## Loops across lags") && md.contains("| HD_ICP | 12 |"),
        "{md}"
    );
    // Lag 1 changes nothing: no loops, no cycles field, no section.
    let plain = evaluate(&ds, &setup(1), &ProgressBar::hidden()).unwrap();
    assert!(plain.cycles.is_empty() && plain.variants.iter().all(|v| v.cycles.is_none()));
    assert!(!eval::render::markdown::table_md(&plain).contains("Loops across lags"));
    // The wall times aside.
    let untimed = |rows: &[eval::measure::record::PairRecord]| {
        let mut rows = rows.to_vec();
        rows.iter_mut().for_each(|r| r.time_us = None);
        rows
    };
    assert!(
        untimed(&plain.pairs) == untimed(&report.pairs),
        "the lag-1 records do not move with --lags"
    );
}

/// HD_ICP's registrations of `ds`'s consecutive pairs and across lag 2, from the identity.
fn registered(ds: &Dataset) -> (Runs, LagRuns) {
    let (pairs, _) = ds.consecutive_pairs();
    let registrars: Vec<Box<dyn icp_core::Registrar>> =
        vec![Box::new(builtin("HD_ICP").unwrap().build().unwrap())];
    let chain = InitChain::default();
    let plan = RunPlan {
        chain: &chain,
        global: &GlobalParams::default(),
        check: false,
        ambiguity: false,
    };
    let methods = Methods::registrars(&registrars);
    let progress = ProgressBar::hidden();
    let runs = run_all(ds, &pairs, methods, &plan, &progress);
    let lag_pairs = lags::lag_pairs(&pairs, 2).unwrap();
    let lagged = lags::run(ds, lag_pairs, 2, methods, &plan, &progress).unwrap();
    (runs, lagged)
}

/// Pair 6 of `runs` moved into a wrong minimum: half a metre along and 2° off.
fn corrupt_pair_6(runs: &mut Runs) {
    let reg = runs.per_variant[0][6].result.as_mut().unwrap();
    reg.t_ref_src.translation.vector.x += 0.5;
    reg.t_ref_src.rotation *= nalgebra::UnitComplex::new(2f64.to_radians());
}

/// The position in `lagged` of the registration across lag 2 from pair `first`.
fn across(lagged: &LagRuns, first: usize) -> usize {
    lagged
        .pairs
        .iter()
        .position(|p| p.lag == 2 && p.first == first)
        .unwrap()
}

#[test]
fn a_corrupted_middle_registration_is_flagged_and_its_neighbours_are_not() {
    let ds = dataset();
    let (mut runs, lagged) = registered(&ds);
    let clean = cycles::inconsistent(&runs.per_variant[0], &lagged, &lagged.runs.per_variant[0]);
    assert!(clean.iter().all(Option::is_none), "{clean:?}");
    corrupt_pair_6(&mut runs);
    let flags = cycles::inconsistent(&runs.per_variant[0], &lagged, &lagged.runs.per_variant[0]);
    let flagged: Vec<usize> = (0..flags.len()).filter(|&i| flags[i].is_some()).collect();
    assert_eq!(flagged, vec![6], "{flags:?}");
    let Some(PairStatus::Inconsistent {
        apart_m,
        alternatives_agree,
        ..
    }) = &flags[6]
    else {
        panic!("{flags:?}")
    };
    assert!((apart_m - 0.5).abs() < 0.05, "{apart_m}");
    assert!(
        alternatives_agree,
        "its neighbours' loops agree: pair 6 alone is wrong"
    );
    // A flagged registration is no evidence: with pair 7 flagged, pair 6 is judged by the
    // one loop left (through pair 5), and still flagged; with the lag-2 registration 5 → 7
    // flagged too, no trusted loop is left and the loops say nothing.
    let degenerate = PairStatus::Degenerate { cond_ratio: 1e-4 };
    runs.per_variant[0][7].status = degenerate.clone();
    let flags = cycles::inconsistent(&runs.per_variant[0], &lagged, &lagged.runs.per_variant[0]);
    let Some(PairStatus::Inconsistent { alternatives, .. }) = &flags[6] else {
        panic!("{flags:?}")
    };
    assert_eq!(*alternatives, 1, "{flags:?}");
    let mut lagged_runs = lagged.runs.per_variant[0].clone();
    lagged_runs[across(&lagged, 5)].status = degenerate;
    let flags = cycles::inconsistent(&runs.per_variant[0], &lagged, &lagged_runs);
    assert!(flags[6].is_none(), "{flags:?}");
    runs.per_variant[0][7].status = PairStatus::Ok;
    // A smaller error (0.2 m, 1°) is not wrong by the field's thresholds: not flagged.
    let reg = runs.per_variant[0][6].result.as_mut().unwrap();
    reg.t_ref_src.translation.vector.x -= 0.3;
    reg.t_ref_src.rotation *= nalgebra::UnitComplex::new(-1f64.to_radians());
    let flags = cycles::inconsistent(&runs.per_variant[0], &lagged, &lagged.runs.per_variant[0]);
    assert!(flags.iter().all(Option::is_none), "{flags:?}");
    assert!(PairStatus::Inconsistent {
        apart_m: 0.5,
        apart_deg: 2.0,
        alternatives: 2,
        alternatives_apart_m: Some(0.01),
        alternatives_apart_deg: Some(0.1),
        alternatives_agree: true,
    }
    .is_failure());
}

#[test]
fn a_lag_two_registration_that_fits_twice_accuses_no_neighbour() {
    let ds = dataset();
    let (mut runs, mut lagged) = registered(&ds);
    corrupt_pair_6(&mut runs);
    // Every lag-2 pair searched, each fitting once: pair 6 is flagged by both its loops.
    let searched = |runner_up_score| PairSearch {
        result: Ok(Some(GlobalGuess {
            t_ref_src: nalgebra::Isometry2::identity(),
            score: 0.6,
            runner_up_score,
            rotations: 1,
            grid_lookups: 1,
        })),
        time_us: 0.0,
    };
    lagged.runs.searches = vec![searched(None); lagged.pairs.len()];
    let alternatives = |lagged: &LagRuns| {
        let flags = cycles::inconsistent(&runs.per_variant[0], lagged, &lagged.runs.per_variant[0]);
        match &flags[6] {
            Some(PairStatus::Inconsistent { alternatives, .. }) => Some(*alternatives),
            None => None,
            other => panic!("{other:?}"),
        }
    };
    assert_eq!(alternatives(&lagged), Some(2));
    // The search across 5 → 7 found a second place almost as good: that loop is no evidence,
    // and pair 6 is judged by the one through pair 7 alone.
    let across_5 = across(&lagged, 5);
    lagged.runs.searches[across_5] = searched(Some(0.55));
    assert_eq!(alternatives(&lagged), Some(1));
    // Both lag-2 registrations through pair 6 fit twice: nothing accuses it.
    let across_6 = across(&lagged, 6);
    lagged.runs.searches[across_6] = searched(Some(0.5));
    assert_eq!(alternatives(&lagged), None);
}

#[test]
fn bad_lags_are_typed_errors() {
    let ds = dataset();
    for lags in [0, 14] {
        let err = evaluate(&ds, &setup(lags), &ProgressBar::hidden()).unwrap_err();
        assert!(matches!(err, EvalError::Lags { .. }), "{err}");
        assert!(
            err.to_string().starts_with(&format!("--lags {lags}:")),
            "{err}"
        );
    }
}
