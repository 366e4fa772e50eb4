use datasets::synthetic::{generate, Scenario};
use icp_core::spec::VariantSpec;
use icp_core::variants::builtin;
use icp_core::{IcpError, Prepared, Registration, Scan, SurfaceParams, Workspace};
use nalgebra::{Isometry2, Vector2};

use super::again::{again, Masked};
use super::*;
use crate::run::pair_search::assess_alone;
use crate::run::setup::EvalSetup;
use crate::run::status::StatusKind;
use icp_core::global::GlobalParams;

/// PL_ICP, but every registration lands this many metres to the side of where PL_ICP would:
/// a second registration that wanders (into another basin, at a metre), whatever its start.
struct Wanders(Icp, f64);

impl Registrar for Wanders {
    fn name(&self) -> &str {
        "WANDERS"
    }

    fn spec(&self) -> VariantSpec {
        self.0.spec()
    }

    fn surface_params(&self) -> SurfaceParams {
        self.0.surface_params()
    }

    fn register_prepared(
        &self,
        workspace: &mut Workspace,
        source: Prepared<'_>,
        reference: Prepared<'_>,
        init: Isometry2<f64>,
    ) -> Result<Registration, IcpError> {
        let mut r = self
            .0
            .register_prepared(workspace, source, reference, init)?;
        r.t_ref_src = Isometry2::translation(self.1, 0.0) * r.t_ref_src;
        Ok(r)
    }
}

/// A pair's run without a result, flagged `status`.
fn run(status: PairStatus) -> PairRun {
    PairRun {
        result: Err(IcpError::NonFiniteTransform),
        status,
        check: None,
        ambiguity: None,
        init: None,
        attempts: 0,
        time_us: None,
        left_out: None,
    }
}

/// A detection leaving out the first `n` returns of `scan`.
fn leaving_first(scan: &Scan, n: usize) -> Detection {
    let left_out = (0..scan.len()).map(|i| i < n).collect();
    Detection::new(scan, left_out, n, 0.5)
}

/// A jump of the second registration is flagged `dynamic` only when the kept returns pull
/// away from the start: from PL_ICP's own result (which they fit) the pair keeps its result
/// and status; from a start 0.1 m off it is flagged, the start kept.
#[test]
fn a_jump_from_a_start_the_kept_returns_fit_is_not_dynamic() {
    let ds = generate(&Scenario {
        n_scans: 2,
        ..Scenario::paper()
    })
    .unwrap();
    let pair = ScanPair {
        source: 0,
        reference: 1,
    };
    let pl = builtin("PL_ICP").unwrap().build().unwrap();
    let right = pl
        .register(&ds.scans[0], &ds.scans[1], Isometry2::identity())
        .unwrap();
    let wanders = Wanders(pl, 1.0);
    let found = (
        leaving_first(&ds.scans[0], 5),
        leaving_first(&ds.scans[1], 5),
    );
    let params = wanders.surface_params();
    let masked = (
        Masked::new(&ds.scans[pair.source], &found.0, &params),
        Masked::new(&ds.scans[pair.reference], &found.1, &params),
    );
    let after = |t_ref_src: Isometry2<f64>| {
        let result = Ok(Registration { t_ref_src, ..right });
        let mut run = PairRun {
            status: PairStatus::of(&result, None, None),
            result,
            ..PairRun::ok_for_test(t_ref_src, None)
        };
        let before = run.status.clone();
        again(
            (
                &wanders,
                &EvalSetup::checking_plan(&GlobalParams::default()),
            ),
            &mut Workspace::default(),
            (&found.0, &found.1),
            (masked.0.prepared(), masked.1.prepared()),
            (&ds.scans[pair.source], &ds.scans[pair.reference]),
            &mut run,
        );
        let kept = run.result.as_ref().unwrap().t_ref_src;
        assert_eq!(kept, t_ref_src, "the start is kept");
        (before, run.status)
    };
    let (before, status) = after(right.t_ref_src);
    assert_eq!(status, before);
    assert!(!matches!(status, PairStatus::Dynamic { .. }), "{status}");
    let off = Isometry2::new(Vector2::new(0.1, 0.0), 0.0) * right.t_ref_src;
    let (_, status) = after(off);
    assert!(matches!(status, PairStatus::Dynamic { .. }), "{status}");
}

/// A second registration that stays in its basin but leaves the first result's peak is
/// checked at its own pose; one within the peak keeps the first result's check.
#[test]
fn a_second_result_off_the_first_ones_peak_is_checked_again() {
    let ds = generate(&Scenario {
        n_scans: 2,
        ..Scenario::paper()
    })
    .unwrap();
    let (source, reference) = (&ds.scans[0], &ds.scans[1]);
    let global = GlobalParams::default();
    let found = (leaving_first(source, 5), leaving_first(reference, 5));
    let params = SurfaceParams::default();
    let masked = (
        Masked::new(source, &found.0, &params),
        Masked::new(reference, &found.1, &params),
    );
    let pl = || builtin("PL_ICP").unwrap().build().unwrap();
    let right = pl()
        .register(source, reference, Isometry2::identity())
        .unwrap();
    let (first_check, _) = assess_alone((source, reference), &global, (true, true), &right);
    let second = |aside_m: f64| {
        let result = Ok(right);
        let mut run = PairRun {
            status: PairStatus::of(&result, first_check.as_ref(), None),
            result,
            check: first_check,
            ..PairRun::ok_for_test(right.t_ref_src, None)
        };
        again(
            (&Wanders(pl(), aside_m), &EvalSetup::checking_plan(&global)),
            &mut Workspace::default(),
            (&found.0, &found.1),
            (masked.0.prepared(), masked.1.prepared()),
            (source, reference),
            &mut run,
        );
        let now = run.result.as_ref().unwrap().t_ref_src;
        assert!((now.translation.x - right.t_ref_src.translation.x - aside_m).abs() < 0.02);
        run
    };
    let within = second(0.1);
    assert_eq!(within.check, first_check);
    let beyond = second(0.25);
    let now = beyond.result.as_ref().unwrap();
    let (expected, ambiguity) = assess_alone((source, reference), &global, (true, true), now);
    assert_eq!(beyond.check, expected);
    assert_eq!(beyond.check.unwrap().result_t_ref_src, now.t_ref_src);
    assert_eq!(beyond.ambiguity, ambiguity);
    assert_eq!(
        beyond.status,
        PairStatus::of(&beyond.result, expected.as_ref(), ambiguity.as_ref())
    );
}

/// A scan whose placing registrations on both sides see another scene (no overlap onto it,
/// suspect from it) fits neither neighbour; a variant's `ok` pair with it is flagged
/// `isolated` where the variant's own registration on its other side is flagged too, and kept
/// where the variant registered both sides `ok`. Weak geometry (degenerate) on one side is
/// not another scene. (The end-to-end case, `tests/failures.rs`, is now flagged by the
/// variant's own global check before this rule speaks.)
#[test]
fn a_scan_both_placing_registrations_lose_is_isolated_where_the_variant_agrees() {
    let pairs: Vec<ScanPair> = (0..4)
        .map(|k| ScanPair {
            source: k,
            reference: k + 1,
        })
        .collect();
    let suspect = || PairStatus::Suspect {
        check: crate::run::status::GlobalCheck {
            best_t_ref_src: Some(Isometry2::translation(5.0, 0.0)),
            best_score: 0.6,
            result_t_ref_src: Isometry2::identity(),
            result_score: 0.2,
        },
    };
    let no_overlap = || PairStatus::NoOverlap { overlap: 0.03 };
    let chain = |onto: PairStatus| {
        vec![
            run(PairStatus::Ok),
            run(onto),
            run(suspect()),
            run(PairStatus::Ok),
        ]
    };
    let weak = isolated(&pairs, &chain(PairStatus::Degenerate { cond_ratio: 1e-3 }));
    assert!(weak.is_empty(), "degenerate is weak geometry: {weak:?}");
    let lost = isolated(&pairs, &chain(no_overlap()));
    assert_eq!(lost.keys().copied().collect::<Vec<_>>(), vec![2]);
    let PairStatus::Isolated {
        scan,
        before,
        after,
    } = &lost[&2]
    else {
        panic!("{:?}", lost[&2]);
    };
    assert_eq!(*scan, 2);
    assert!(before.starts_with("no_overlap"), "{before}");
    assert!(after.starts_with("suspect"), "{after}");

    // Variant 0 flagged its own 2 → 3; variant 1 registered every pair `ok`.
    let mut runs = Runs {
        per_variant: vec![
            vec![
                run(PairStatus::Ok),
                run(PairStatus::Ok),
                run(suspect()),
                run(PairStatus::Ok),
            ],
            (0..4).map(|_| run(PairStatus::Ok)).collect(),
        ],
        prepare_us: Vec::new(),
        searches: Vec::new(),
    };
    let unjudged = confirmed(&pairs, vec![lost.clone(), lost], &runs);
    flag_isolated(&pairs, &unjudged, &mut runs);
    let kinds = |v: usize| -> Vec<StatusKind> {
        runs.per_variant[v]
            .iter()
            .map(|r| r.status.kind())
            .collect()
    };
    assert_eq!(
        kinds(0),
        vec![
            StatusKind::Ok,
            StatusKind::Isolated,
            StatusKind::Suspect,
            StatusKind::Ok
        ],
        "its ok pair onto the scan is flagged, its own flag kept"
    );
    assert_eq!(
        kinds(1),
        vec![StatusKind::Ok; 4],
        "the variant saw one scene"
    );
}

/// The steps a chain may predict are the consecutive pairs flagged `dynamic`: not those flagged
/// otherwise, not an `ok` one, not a lag pair's.
#[test]
fn the_split_steps_are_the_consecutive_dynamic_ones() {
    let dynamic = || PairStatus::Dynamic {
        source_share: 0.1,
        reference_share: 0.1,
        without: Isometry2::identity(),
        with: Isometry2::identity(),
    };
    let pair = |source: usize, reference: usize| ScanPair { source, reference };
    let pairs = [pair(0, 1), pair(1, 2), pair(2, 3), pair(3, 5), pair(4, 5)];
    let runs = [
        run(PairStatus::Ok),
        run(dynamic()),
        run(PairStatus::Degenerate { cond_ratio: 1e-3 }),
        run(dynamic()),
        run(dynamic()),
    ];
    assert_eq!(
        splits(6, &pairs, &runs),
        vec![false, true, false, false, true, false]
    );
}
