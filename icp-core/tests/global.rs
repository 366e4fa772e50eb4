//! The global initial-guess search: large motions found in both rotation modes, degenerate
//! inputs, parameter errors and determinism.

mod common;

use common::{seen_from, Owned};
use icp_core::error::ScanRole;
use icp_core::global::{
    score_at, GlobalGuess, GlobalMatcher, GlobalParams, GlobalWorkspace, RotationMode,
};
use icp_core::{ConfigError, IcpError, Prepared, Scan};
use nalgebra::{Isometry2, Point2, Vector2};

/// The walls of an L-shaped room with a pillar, sampled every 5 cm from `phase` metres along
/// each wall, so that two samplings do not share points.
fn room(phase: f64) -> Vec<Point2<f64>> {
    let corners = [
        [-4.0, -3.0],
        [6.0, -3.0],
        [6.0, 1.5],
        [2.0, 1.5],
        [2.0, 5.0],
        [-4.0, 5.0],
        [-4.0, -3.0],
    ];
    let pillar = [
        [3.5, -1.0],
        [4.2, -1.0],
        [4.2, -0.3],
        [3.5, -0.3],
        [3.5, -1.0],
    ];
    let mut points = Vec::new();
    for outline in [&corners[..], &pillar[..]] {
        for pair in outline.windows(2) {
            let (a, b) = (Point2::from(pair[0]), Point2::from(pair[1]));
            let length = (b - a).norm();
            let mut s = phase;
            while s < length {
                points.push(a + (b - a) * (s / length));
                s += 0.05;
            }
        }
    }
    points
}

fn search(
    params: &GlobalParams,
    source: &Owned,
    reference: &Owned,
    centre: Isometry2<f64>,
) -> Result<GlobalGuess, IcpError> {
    GlobalMatcher::new(reference.prepared(), params)?.search(
        &mut GlobalWorkspace::default(),
        source.prepared(),
        centre,
    )
}

/// The pose error: translation, metres, and rotation, radians.
fn error(a: &Isometry2<f64>, b: &Isometry2<f64>) -> (f64, f64) {
    let d = (a.inverse() * b).rotation.angle().abs();
    ((a.translation.vector - b.translation.vector).norm(), d)
}

#[test]
fn a_room_moved_by_1_2_m_and_60_degrees_is_found_in_both_modes() {
    let truth = Isometry2::new(Vector2::new(0.85, -0.85), 60f64.to_radians());
    assert!((truth.translation.vector.norm() - 1.2).abs() < 0.01);
    let reference = Owned::new(seen_from(&room(0.0), &Isometry2::identity()));
    let source = Owned::new(seen_from(&room(0.025), &truth));
    for rotation in [RotationMode::Full, RotationMode::Histogram] {
        let params = GlobalParams {
            rotation,
            ..GlobalParams::default()
        };
        let guess = search(&params, &source, &reference, Isometry2::identity()).unwrap();
        // The farthest return, about 9 m away, sets the angular step.
        let farthest = source
            .scan
            .returns()
            .iter()
            .map(|r| r.range_m)
            .fold(0.0, f64::max);
        let step = 2.0 * (0.5 * params.resolution_m / farthest).asin();
        let (dt, da) = error(&guess.t_ref_src, &truth);
        assert!(dt <= params.resolution_m, "{rotation:?}: {dt} m");
        assert!(da <= step, "{rotation:?}: {da} rad, step {step}");
        assert!(guess.score > 0.8, "{rotation:?}: {guess:?}");
        assert!(guess.grid_lookups > 0 && guess.rotations > 0);
        // A fine result scored on the same grid: the truth itself is about as good.
        let matcher = GlobalMatcher::new(reference.prepared(), &params).unwrap();
        let at_truth = score_at(matcher.grid(), &source.scan, &truth);
        assert!(
            (at_truth - guess.score).abs() < 0.1,
            "{at_truth} vs {guess:?}"
        );
        // The guess scored again: the same cells, up to returns on a cell border.
        let again = score_at(matcher.grid(), &source.scan, &guess.t_ref_src);
        assert!((again - guess.score).abs() < 0.02, "{again} vs {guess:?}");
    }
}

#[test]
fn a_featureless_corridor_is_flagged_ambiguous_and_a_room_is_not() {
    // Two parallel walls 2 m apart and 30 m long, seen 1 m further along: every shift along
    // the corridor fits as well as the true one.
    let corridor: Vec<Point2<f64>> = (0..600)
        .map(|i| {
            Point2::new(
                -15.0 + (i / 2) as f64 * 0.1,
                if i % 2 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    let truth = Isometry2::new(Vector2::new(1.0, 0.0), 0.0);
    let reference = Owned::new(seen_from(&corridor, &Isometry2::identity()));
    let source = Owned::new(seen_from(&corridor[..560], &truth));
    let params = GlobalParams::default();
    let along = search(&params, &source, &reference, Isometry2::identity()).unwrap();
    let runner_up = along.runner_up_score.expect("a corridor is ambiguous");
    assert!(runner_up > 0.95 * along.score, "{along:?}");
    // The room: no distinct translation comes close; with the ratio at 1, nothing is searched.
    let room_ref = Owned::new(seen_from(&room(0.0), &Isometry2::identity()));
    let room_src = Owned::new(seen_from(&room(0.025), &truth));
    let guess = search(&params, &room_src, &room_ref, Isometry2::identity()).unwrap();
    assert_eq!(guess.runner_up_score, None, "{guess:?}");
    let ratio = |r: f64| GlobalParams {
        ambiguity_ratio: r,
        ..params
    };
    let loose = search(&ratio(0.0), &room_src, &room_ref, Isometry2::identity()).unwrap();
    assert!(
        loose.runner_up_score.unwrap() < 0.8 * loose.score,
        "{loose:?}"
    );
    let off = search(&ratio(1.0), &source, &reference, Isometry2::identity()).unwrap();
    assert_eq!(off.runner_up_score, None);
    assert_eq!((off.t_ref_src, off.score), (along.t_ref_src, along.score));
    assert!(off.grid_lookups < along.grid_lookups);
}

#[test]
fn the_histogram_mode_searches_far_fewer_rotations() {
    let truth = Isometry2::new(Vector2::new(-0.4, 0.9), -100f64.to_radians());
    let reference = Owned::new(seen_from(&room(0.0), &Isometry2::identity()));
    let source = Owned::new(seen_from(&room(0.025), &truth));
    let full = search(
        &GlobalParams {
            rotation: RotationMode::Full,
            ..GlobalParams::default()
        },
        &source,
        &reference,
        Isometry2::identity(),
    )
    .unwrap();
    let histogram = search(
        &GlobalParams {
            rotation: RotationMode::Histogram,
            ..GlobalParams::default()
        },
        &source,
        &reference,
        Isometry2::identity(),
    )
    .unwrap();
    assert_eq!(full.t_ref_src, histogram.t_ref_src);
    assert_eq!(full.score, histogram.score);
    assert!(
        histogram.rotations * 5 < full.rotations,
        "{histogram:?} vs {full:?}"
    );
    assert!(histogram.grid_lookups < full.grid_lookups);
}

#[test]
fn the_window_and_rotation_limits_hold_around_the_centre() {
    // The truth is 1.2 m and 60° away; a window of 0.5 m around a centre near the truth
    // finds it, one around the identity cannot reach it, and a rotation limit of 10° around a
    // centre turned by 55° reaches 60°.
    let truth = Isometry2::new(Vector2::new(0.85, -0.85), 60f64.to_radians());
    let reference = Owned::new(seen_from(&room(0.0), &Isometry2::identity()));
    let source = Owned::new(seen_from(&room(0.025), &truth));
    let params = GlobalParams {
        window_m: 0.5,
        max_rotation_deg: 10.0,
        rotation: RotationMode::Full,
        ..GlobalParams::default()
    };
    let near = Isometry2::new(Vector2::new(0.5, -0.6), 55f64.to_radians());
    let found = search(&params, &source, &reference, near).unwrap();
    let (dt, da) = error(&found.t_ref_src, &truth);
    assert!(dt <= 0.1 && da <= 1f64.to_radians(), "{found:?}");
    let away = search(&params, &source, &reference, Isometry2::identity()).unwrap();
    let (dt, _) = error(&away.t_ref_src, &Isometry2::identity());
    assert!(dt <= 0.5 * 2f64.sqrt() + 1e-9, "{away:?}");
    assert!(away.t_ref_src.rotation.angle().abs() <= 10f64.to_radians() + 1e-9);
    assert!(away.score < found.score);
}

#[test]
fn same_input_same_output_bit_for_bit() {
    let truth = Isometry2::new(Vector2::new(0.3, 1.1), 2.5);
    let reference = Owned::new(seen_from(&room(0.0), &Isometry2::identity()));
    let source = Owned::new(seen_from(&room(0.01), &truth));
    for rotation in [RotationMode::Full, RotationMode::Histogram] {
        let params = GlobalParams {
            rotation,
            ..GlobalParams::default()
        };
        let matcher = GlobalMatcher::new(reference.prepared(), &params).unwrap();
        let mut workspace = GlobalWorkspace::default();
        let centre = Isometry2::new(Vector2::new(0.1, 0.2), 0.3);
        let a = matcher
            .search(&mut workspace, source.prepared(), centre)
            .unwrap();
        // Reused buffers, after another search, and a fresh matcher.
        matcher
            .search(&mut workspace, reference.prepared(), centre)
            .unwrap();
        let b = matcher
            .search(&mut workspace, source.prepared(), centre)
            .unwrap();
        let c = search(&params, &source, &reference, centre).unwrap();
        for other in [b, c] {
            assert_eq!(a.score.to_bits(), other.score.to_bits());
            assert_eq!(a.grid_lookups, other.grid_lookups);
            assert_eq!(
                a.t_ref_src.translation.vector.map(f64::to_bits),
                other.t_ref_src.translation.vector.map(f64::to_bits)
            );
            assert_eq!(
                a.t_ref_src.rotation.angle().to_bits(),
                other.t_ref_src.rotation.angle().to_bits()
            );
        }
    }
}

#[test]
fn degenerate_inputs_give_typed_errors_or_a_zero_score() {
    let params = GlobalParams::default();
    let reference = Owned::new(seen_from(&room(0.0), &Isometry2::identity()));
    let empty = Owned::new(Scan::from_cartesian(&[[0.0, 0.0]]).unwrap());
    assert!(matches!(
        GlobalMatcher::new(empty.prepared(), &params),
        Err(IcpError::TooFewPoints {
            role: ScanRole::Reference,
            got: 0,
            ..
        })
    ));
    assert!(matches!(
        search(&params, &empty, &reference, Isometry2::identity()),
        Err(IcpError::TooFewPoints {
            role: ScanRole::Source,
            got: 0,
            ..
        })
    ));
    // Every source point far outside the grid, whatever the pose: score 0 at the centre.
    let far =
        Owned::new(Scan::from_cartesian(&[[500.0, 0.0], [501.0, 3.0], [502.0, -1.0]]).unwrap());
    let centre = Isometry2::new(Vector2::new(0.2, 0.1), 0.05);
    for rotation in [RotationMode::Full, RotationMode::Histogram] {
        let p = GlobalParams { rotation, ..params };
        let guess = search(&p, &far, &reference, centre).unwrap();
        assert_eq!((guess.score, guess.t_ref_src), (0.0, centre));
    }
    // A single reference point and a single source point; huge but finite coordinates.
    let one = Owned::new(Scan::from_cartesian(&[[1.0, 2.0]]).unwrap());
    let guess = search(&params, &one, &one, Isometry2::identity()).unwrap();
    assert!(guess.score > 0.6 && guess.score <= 1.0, "{guess:?}");
    // A return 1e300 m away makes the derived angular step vanish: too many rotations. (Its
    // spread is along x only: the surface estimates of a scan spread along both axes would
    // allocate a cell index of 2^30 cells.)
    let huge = Owned::new(Scan::from_cartesian(&[[1e300, 0.5], [2.0, 1.0]]).unwrap());
    assert!(matches!(
        search(&params, &huge, &reference, Isometry2::identity()),
        Err(IcpError::GlobalSearchTooLarge {
            what: "rotation candidates",
            ..
        })
    ));
    let stepped = GlobalParams {
        angular_step_deg: Some(1.0),
        ..params
    };
    let guess = search(&stepped, &huge, &reference, Isometry2::identity()).unwrap();
    assert!((0.0..=1.0).contains(&guess.score));
    assert!(matches!(
        GlobalMatcher::new(huge.prepared(), &params),
        Err(IcpError::GlobalSearchTooLarge { .. })
    ));
    // A centre that is not finite.
    let nan = Isometry2::new(Vector2::new(f64::NAN, 0.0), 0.0);
    assert!(matches!(
        search(&params, &reference, &reference, nan),
        Err(IcpError::NonFinite {
            what: "centre pose",
            ..
        })
    ));
    // Surface estimates of another scan, in histogram mode.
    let histogram = GlobalParams {
        rotation: RotationMode::Histogram,
        ..params
    };
    let other = Prepared::new(&reference.scan, &one.surfaces);
    assert!(matches!(
        GlobalMatcher::new(other, &histogram),
        Err(IcpError::SurfacesMismatch {
            role: ScanRole::Reference,
            ..
        })
    ));
    // A grid over the cell limit, and rotation candidates over theirs.
    let small = GlobalParams {
        max_grid_cells: 1000,
        ..params
    };
    assert!(matches!(
        GlobalMatcher::new(reference.prepared(), &small),
        Err(IcpError::GlobalSearchTooLarge { .. })
    ));
    let fine = GlobalParams {
        angular_step_deg: Some(1e-4),
        rotation: RotationMode::Full,
        ..params
    };
    assert!(matches!(
        search(&fine, &reference, &reference, Isometry2::identity()),
        Err(IcpError::GlobalSearchTooLarge {
            what: "rotation candidates",
            ..
        })
    ));
}

#[test]
fn invalid_parameters_are_named() {
    let bad = |p: GlobalParams| match p.validate() {
        Err(e) => e.parameter,
        Ok(()) => "",
    };
    let d = GlobalParams::default;
    assert_eq!(d().validate(), Ok(()));
    for (p, name) in [
        (
            GlobalParams {
                resolution_m: 0.0,
                ..d()
            },
            "resolution_m",
        ),
        (
            GlobalParams {
                resolution_m: f64::NAN,
                ..d()
            },
            "resolution_m",
        ),
        (
            GlobalParams {
                sigma_m: -1.0,
                ..d()
            },
            "sigma_m",
        ),
        (
            GlobalParams {
                window_m: -0.1,
                ..d()
            },
            "window_m",
        ),
        (
            GlobalParams {
                window_m: 1000.0,
                ..d()
            },
            "window_m",
        ),
        (
            GlobalParams {
                max_rotation_deg: 181.0,
                ..d()
            },
            "max_rotation_deg",
        ),
        (
            GlobalParams {
                angular_step_deg: Some(0.0),
                ..d()
            },
            "angular_step_deg",
        ),
        (
            GlobalParams {
                histogram_bin_deg: 100.0,
                ..d()
            },
            "histogram_bin_deg",
        ),
        (
            GlobalParams {
                histogram_bin_deg: 0.01,
                ..d()
            },
            "histogram_bin_deg",
        ),
        (
            GlobalParams {
                histogram_peaks: 0,
                ..d()
            },
            "histogram_peaks",
        ),
        (
            GlobalParams {
                histogram_window_deg: f64::NAN,
                ..d()
            },
            "histogram_window_deg",
        ),
        (
            GlobalParams {
                max_grid_cells: 0,
                ..d()
            },
            "max_grid_cells",
        ),
    ] {
        assert_eq!(bad(p), name);
    }
    // The matcher reports them as a section of the configuration.
    let reference = Owned::new(seen_from(&room(0.0), &Isometry2::identity()));
    let err = GlobalMatcher::new(
        reference.prepared(),
        &GlobalParams {
            sigma_m: 0.0,
            ..d()
        },
    )
    .unwrap_err();
    assert!(matches!(
        err,
        IcpError::Config(ConfigError::Section {
            section: "global",
            ..
        })
    ));
    assert_eq!(
        err.to_string(),
        "global.sigma_m = 0: must be finite and positive"
    );
}

#[test]
fn parameters_read_from_configuration_with_defaults() {
    let p: GlobalParams =
        serde_json::from_str(r#"{"rotation": "histogram", "window_m": 1.5}"#).unwrap();
    assert_eq!(
        p,
        GlobalParams {
            rotation: RotationMode::Histogram,
            window_m: 1.5,
            ..GlobalParams::default()
        }
    );
    assert!(serde_json::from_str::<GlobalParams>(r#"{"window": 1.5}"#).is_err());
    let docs = icp_core::registry::param_docs::<GlobalParams>();
    let rotation = docs.iter().find(|d| d.name == "rotation").unwrap();
    assert_eq!(rotation.type_name, "full | histogram");
    assert!(docs.iter().all(|d| !d.description.is_empty()), "{docs:?}");
}
