//! The synthetic harbour: determinism, the paper scenario's shape, the noise it draws, ICP
//! recovering its exact ground truth, and the rough harbour's boats: their moving labels and
//! their JSON files.

use std::path::{Path, PathBuf};

use datasets::synthetic::rough::Boat;
use datasets::synthetic::{
    generate, generate_with_boats, read_boats, BoatsError, Scanner, ScannerConfig, Scenario,
    Segment, Turn, NO_BOATS,
};
use datasets::{Dataset, DatasetError};
use icp_core::variants::builtin;
use icp_core::Registrar;
use icp_core::{SensorModel, Termination};
use nalgebra::{Isometry2, Point2, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

fn short(n_scans: usize) -> Scenario {
    Scenario {
        n_scans,
        turns: vec![Turn {
            start_scan: 5,
            end_scan: n_scans - 5,
            heading_change_deg: 20.0,
        }],
        ..Scenario::paper()
    }
}

/// The estimate of `reg` from the identity and the true `t_ref_src`, for every consecutive
/// pair of `ds` (which has a rigid reference).
fn estimates_and_truth(reg: &dyn Registrar, ds: &Dataset) -> Vec<(Isometry2<f64>, Isometry2<f64>)> {
    let r = ds.reference.as_ref().unwrap();
    ds.consecutive_pairs()
        .0
        .iter()
        .map(|pair| {
            let (source, reference) = (&ds.scans[pair.source], &ds.scans[pair.reference]);
            let out = reg
                .register(source, reference, Isometry2::identity())
                .unwrap();
            let truth = (r[pair.source].scan_pose().unwrap().inverse()
                * r[pair.reference].scan_pose().unwrap())
            .inverse();
            (out.t_ref_src, truth)
        })
        .collect()
}

#[test]
fn generation_is_deterministic_and_seeded() {
    let a = generate(&short(12)).unwrap();
    let b = generate(&short(12)).unwrap();
    assert_eq!(a.scans, b.scans);
    assert_eq!(a.reference, b.reference);
    let c = generate(&Scenario {
        seed: 7,
        ..short(12)
    })
    .unwrap();
    assert_ne!(a.scans, c.scans);
}

#[test]
fn paper_scenario_has_the_papers_shape() {
    let ds = generate(&Scenario::paper()).unwrap();
    assert_eq!(ds.scans.len(), 865);
    assert_eq!(ds.dt_s, 0.2);
    let r = ds.reference.as_ref().unwrap();
    let length: f64 = r
        .windows(2)
        .map(|w| (w[1].x_m - w[0].x_m).hypot(w[1].y_m - w[0].y_m))
        .sum();
    assert!((200.0..215.0).contains(&length), "track length {length} m");
    let hdg = |k: usize| r[k].heading_rad.to_degrees();
    // Turns: +85° over scans 220-365, -68° over 720-825 (plus a 0.6° wobble).
    assert!((icp_core::motion::wrap_deg(hdg(365) - hdg(220)) - 85.0).abs() < 1.5);
    assert!((icp_core::motion::wrap_deg(hdg(825) - hdg(720)) + 68.0).abs() < 1.5);
    assert!((icp_core::motion::wrap_deg(hdg(200) - hdg(20))).abs() < 1.5);
    let counts: Vec<usize> = ds.scans.iter().map(|s| s.len()).collect();
    let mean = counts.iter().sum::<usize>() as f64 / counts.len() as f64;
    // Measured: 580-704 returns per scan, like the public data's 141-706.
    assert!((550.0..720.0).contains(&mean), "mean returns {mean}");
    assert_eq!(ds.consecutive_pairs().0.len(), 864);
    // Exact poses of the scanner itself, no odometry, and motion an identity start handles
    // (median 0.24 m / 0.08° per scan): nothing to warn about.
    assert_eq!(
        ds.reference_kind,
        Some(datasets::ReferenceKind::GroundTruth)
    );
    assert_eq!(ds.scanner_offset, Some(datasets::Pose2::IDENTITY));
    assert_eq!(ds.odometry, None);
    assert_eq!(ds.warnings, vec![]);
}

#[test]
fn marina_like_scenario_samples_the_same_track_every_second() {
    let ds = generate(&Scenario::marina_like()).unwrap();
    assert_eq!(ds.scans.len(), 177);
    let r = ds.reference.as_ref().unwrap();
    let step = (r[11].x_m - r[10].x_m).hypot(r[11].y_m - r[10].y_m);
    assert!((1.1..1.3).contains(&step), "step {step} m");
    // 1.2 m per scan is within an identity start's reach in the harbour.
    assert_eq!(ds.warnings, vec![]);
}

/// A static square room, scanned many times: the scatter of the returns about the true walls
/// must fit the configured σ_r and σ_α. Along the wall normal the variance of a return is
/// eq. 9: `k² r² cos²φ + σ_α² r² sin²φ` (φ between beam and normal), linear in (k², σ_α²).
#[test]
fn generated_noise_fits_the_sensor_model() {
    let half = 15.0;
    let c = [[-half, -half], [half, -half], [half, half], [-half, half]]
        .map(|[x, y]| Point2::new(x, y));
    let world: Vec<Segment> = (0..4)
        .map(|i| Segment {
            a: c[i],
            b: c[(i + 1) % 4],
        })
        .collect();
    let sensor = SensorModel {
        sigma_r_const_m: 0.0,
        sigma_r_per_m: 0.004258,
        sigma_alpha_rad: 0.5f64.to_radians(),
    };
    let config = ScannerConfig {
        sensor,
        dropout_prob: 0.0,
        gross_error_fraction: 0.0,
        ..ScannerConfig::default()
    };
    let scanner = Scanner::new(&config, &world);
    let pose = Isometry2::new(Vector2::new(2.0, -3.0), 0.3);
    let (mut noise, mut events) = (ChaCha8Rng::seed_from_u64(1), ChaCha8Rng::seed_from_u64(2));
    // Normal equations of d² = a·x1 + b·x2, x1 = r² cos²φ, x2 = r² sin²φ.
    let (mut s11, mut s12, mut s22, mut t1, mut t2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut n = 0;
    for _ in 0..300 {
        let rev = scanner.scan(&|_| pose, 0.0, &mut noise, &mut events);
        for (&r, &a) in rev.ranges_m.iter().zip(&rev.bearings_rad) {
            let u = pose.rotation * Vector2::new(a.cos(), a.sin());
            let p = pose * Point2::new(r * a.cos(), r * a.sin());
            // The wall hit: the one nearest the return; keep away from the corners.
            let (wall, d) = world
                .iter()
                .map(|s| (s, s.distance_to(&p)))
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .unwrap();
            if p.x.abs() > half - 1.0 && p.y.abs() > half - 1.0 {
                continue;
            }
            let e = (wall.b - wall.a).normalize();
            let cos_phi = (u.x * -e.y + u.y * e.x).abs();
            let (x1, x2) = (r * r * cos_phi * cos_phi, r * r * (1.0 - cos_phi * cos_phi));
            s11 += x1 * x1;
            s12 += x1 * x2;
            s22 += x2 * x2;
            t1 += x1 * d * d;
            t2 += x2 * d * d;
            n += 1;
        }
    }
    let det = s11 * s22 - s12 * s12;
    let k_sq = (t1 * s22 - t2 * s12) / det;
    let alpha_sq = (s11 * t2 - s12 * t1) / det;
    let (k, alpha_deg) = (k_sq.sqrt(), alpha_sq.sqrt().to_degrees());
    eprintln!("fitted from {n} returns: k = {k:.6} m/m, sigma_alpha = {alpha_deg:.4} deg");
    // 225,000 returns: the fitted σ are within about 1 % of the truth by sampling error; 4 %
    // still catches a σ_α off by the degree/radian confusion or a σ_r missing its range factor.
    assert!((k / 0.004258 - 1.0).abs() < 0.04, "k = {k}");
    assert!(
        (alpha_deg / 0.5 - 1.0).abs() < 0.04,
        "sigma_alpha = {alpha_deg} deg"
    );
}

/// Noise-free returns from a dense scanner (0.025° beams): HD_ICP recovers every step of the
/// exact ground truth to sub-millimetre. (At the Sweep's 0.48° the walls are sampled at
/// different places in consecutive scans and point-to-point ICP is limited to about 1.5 cm by
/// that resampling, noise or not.)
#[test]
fn hd_icp_recovers_noise_free_motion_to_sub_millimetre() {
    let scenario = Scenario {
        scanner: ScannerConfig {
            noise: false,
            dropout_prob: 0.0,
            gross_error_fraction: 0.0,
            sample_rate_hz: 72_000.0, // 14,400 beams per revolution at 5 Hz: 0.025°
            ..ScannerConfig::default()
        },
        ..short(16)
    };
    let ds = generate(&scenario).unwrap();
    let mut spec = builtin("HD_ICP").unwrap();
    spec.termination = Termination {
        max_iterations: 500,
        mean_residual_change_eps_m: 1e-10,
        ..Termination::default()
    };
    let hd = spec.build().unwrap();
    for (k, (estimate, truth)) in estimates_and_truth(&hd, &ds).into_iter().enumerate() {
        let dt = (estimate.translation.vector - truth.translation.vector).norm();
        let dr = (estimate.rotation.angle() - truth.rotation.angle())
            .abs()
            .to_degrees();
        assert!(dt < 1e-3, "pair {k}: translation error {dt} m");
        assert!(dr < 0.01, "pair {k}: rotation error {dr} deg");
    }
}

#[test]
fn bad_scenarios_are_refused() {
    let bad = [
        Scenario {
            n_scans: 1,
            ..Scenario::paper()
        },
        Scenario {
            dt_s: 0.0,
            ..Scenario::paper()
        },
        Scenario {
            speed_mps: f64::NAN,
            ..Scenario::paper()
        },
        Scenario {
            turns: vec![Turn {
                start_scan: 5,
                end_scan: 5,
                heading_change_deg: 1.0,
            }],
            ..Scenario::paper()
        },
        Scenario {
            scanner: ScannerConfig {
                dropout_prob: 1.5,
                ..ScannerConfig::default()
            },
            ..Scenario::paper()
        },
        Scenario {
            scanner: ScannerConfig {
                sample_rate_hz: 10.0,
                ..ScannerConfig::default()
            },
            ..Scenario::paper()
        },
    ];
    for s in bad {
        assert!(matches!(
            generate(&s),
            Err(DatasetError::InvalidParameter { .. } | DatasetError::BadValue { .. })
        ));
    }
}

/// With motion distortion each beam is taken from where the vessel is at that moment: the
/// last beam of a revolution is displaced by about speed × rotation period.
#[test]
fn motion_distortion_moves_late_beams_by_the_travel_during_the_revolution() {
    let base = Scenario {
        n_scans: 3,
        turns: vec![],
        yaw_wobble_deg: 0.0,
        speed_wobble_mps: 0.0,
        scanner: ScannerConfig {
            noise: false,
            dropout_prob: 0.0,
            gross_error_fraction: 0.0,
            rotation_hz: 1.0, // a slow head: 1.2 m of travel per revolution
            sample_rate_hz: 750.0,
            ..ScannerConfig::default()
        },
        ..Scenario::paper()
    };
    let still = generate(&base).unwrap();
    let moving = generate(&Scenario {
        scanner: ScannerConfig {
            motion_distortion: true,
            ..base.scanner
        },
        ..base.clone()
    })
    .unwrap();
    let (a, b) = (&still.scans[1], &moving.scans[1]);
    assert_eq!(a.len(), b.len(), "the same beams hit");
    let first = (a.returns()[0].point - b.returns()[0].point).norm();
    let last_a = a.returns().last().unwrap();
    let last_b = b.returns().last().unwrap();
    // The first beam is taken at the scan's start pose; the last one ~1 s later, 1.2 m along.
    assert!(first < 1e-9, "{first}");
    let shift = (last_a.point - last_b.point).norm();
    assert!(shift > 0.3 && shift < 2.5, "last beam moved by {shift} m");
}

/// Every generated return carries the true normal of its surface: unit, in the scan frame,
/// facing the sensor (`nᵀ(0 − p) > 0` for the return `p`). Only spurious returns have none.
#[test]
fn generated_returns_carry_true_normals_facing_the_sensor() {
    let exact = ScannerConfig {
        noise: false,
        gross_error_fraction: 0.0,
        ..ScannerConfig::default()
    };
    for (gross_error_fraction, unknown) in [(0.0, 0..1), (0.05, 350..550)] {
        let ds = generate(&Scenario {
            scanner: ScannerConfig {
                gross_error_fraction,
                ..exact
            },
            ..short(12)
        })
        .unwrap();
        let mut without = 0;
        for scan in &ds.scans {
            let normals = scan.true_normals().expect("a synthetic scan has normals");
            assert_eq!(normals.len(), scan.len());
            for (ret, n) in scan.returns().iter().zip(normals) {
                let Some(n) = n else {
                    without += 1;
                    continue;
                };
                assert!((n.norm() - 1.0).abs() < 1e-15, "{n}");
                assert!(
                    n.dot(&ret.point.coords) < 0.0,
                    "{n} faces away from {}",
                    ret.point
                );
            }
        }
        // 12 revolutions of 750 beams, 5 % of them spurious: about 450 ± 21.
        assert!(
            unknown.contains(&without),
            "{without} returns without normal"
        );
    }
}

/// On noise-free scans at the default 0.48° spacing, the surface metrics recover a step to a
/// fraction of a millimetre (median), while point-to-point is limited by the sampling:
/// consecutive scans sample the walls at different places, and nearest-neighbour pairs are not
/// the same points. Not every step: GICP recovers all but one of these 119 steps to under
/// 1 mm (the other at 4.9 mm: part of the scene has no counterpart in the other scan, and the
/// Huber factor only softens those pairs); the other surface variants' worst steps reach
/// 3–4.5 mm, at corners whose neighbourhoods pass the line-likeness threshold chosen for noisy
/// scans.
#[test]
fn surface_metrics_recover_noise_free_steps_far_below_point_to_point() {
    let scenario = Scenario {
        n_scans: 120,
        scanner: ScannerConfig {
            noise: false,
            gross_error_fraction: 0.0,
            ..ScannerConfig::default()
        },
        ..Scenario::paper()
    };
    let ds = generate(&scenario).unwrap();
    let errors = |name: &str| -> Vec<f64> {
        let reg = builtin(name).unwrap().build().unwrap();
        let mut e: Vec<f64> = estimates_and_truth(&reg, &ds)
            .iter()
            .map(|(estimate, truth)| {
                (estimate.translation.vector - truth.translation.vector).norm()
            })
            .collect();
        e.sort_by(f64::total_cmp);
        e
    };
    let median = |e: &[f64]| e[e.len() / 2];
    let p2p = errors("HD_ICP");
    assert!(median(&p2p) > 5e-3, "HD_ICP median {} m", median(&p2p));
    for name in ["PL_ICP", "HD_PL_ICP", "GICP", "HD_GICP"] {
        let e = errors(name);
        eprintln!(
            "{name}: median {:.2} mm, max {:.2} mm (HD_ICP: median {:.1} mm)",
            1e3 * median(&e),
            1e3 * e[e.len() - 1],
            1e3 * median(&p2p)
        );
        assert!(median(&e) < 1e-3, "{name}: median {} m", median(&e));
        assert!(median(&e) < median(&p2p) / 5.0, "{name}");
    }
    // Not every step: see the doc comment for the one that is not.
    let gicp = errors("GICP");
    let under = gicp.iter().filter(|&&e| e < 1e-3).count();
    assert!(
        under + 1 >= gicp.len(),
        "GICP: {under} of {} steps under 1 mm",
        gicp.len()
    );
}

/// The rough harbour is deterministic by seed, is not the paper's harbour, and its error
/// sources show in the data: more returns without a true surface (water, mixed pixels,
/// heavy-tailed spurious ones) and a reference that yaws with the waves.
#[test]
fn rough_harbour_is_seeded_and_rougher() {
    let short = |s: Scenario| Scenario { n_scans: 40, ..s };
    let a = generate(&short(Scenario::rough())).unwrap();
    let b = generate(&short(Scenario::rough())).unwrap();
    assert_eq!(a.scans, b.scans);
    assert_eq!(a.reference, b.reference);
    let c = generate(&Scenario {
        seed: 5,
        ..short(Scenario::rough())
    })
    .unwrap();
    assert_ne!(a.scans, c.scans);
    assert_eq!(
        a.sensor,
        SensorModel::sweep(),
        "the nominal model is stated"
    );
    let paper = generate(&short(Scenario::paper())).unwrap();
    let without_surface = |ds: &Dataset| {
        let (mut none, mut all) = (0, 0);
        for s in &ds.scans {
            let normals = s.true_normals().expect("synthetic scans carry them");
            none += normals.iter().filter(|n| n.is_none()).count();
            all += normals.len();
        }
        none as f64 / all as f64
    };
    let (rough_share, paper_share) = (without_surface(&a), without_surface(&paper));
    assert!(
        rough_share > 2.0 * paper_share,
        "{rough_share} vs {paper_share}"
    );
    // The paper scenario's heading wobbles by 0.6°; the waves yaw the hull by up to 3°.
    let yaw_swing = |ds: &Dataset| {
        let r = ds.reference.as_ref().unwrap();
        r.windows(2)
            .map(|w| {
                let d = w[1].scan_yaw_rad.unwrap() - w[0].scan_yaw_rad.unwrap();
                d.sin().atan2(d.cos()).to_degrees().abs()
            })
            .fold(0.0, f64::max)
    };
    assert!(
        yaw_swing(&a) > 3.0 * yaw_swing(&paper),
        "{} {}",
        yaw_swing(&a),
        yaw_swing(&paper)
    );
}

/// The rough harbour, `n_scans` long.
fn rough(n_scans: usize) -> Scenario {
    Scenario {
        n_scans,
        ..Scenario::rough()
    }
}

/// How many returns of `ds` are labelled moving (every scan must be labelled).
fn moving_returns(ds: &Dataset) -> usize {
    ds.scans
        .iter()
        .map(|s| {
            let labels = s.moving().expect("synthetic scans are labelled");
            assert_eq!(labels.len(), s.len());
            labels.iter().filter(|&&m| m).count()
        })
        .sum()
}

/// A file in the test's scratch directory holding `text`.
fn scratch_file(name: &str, text: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("boats");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// The example file is the built-in traffic, so it cannot drift from it: read, it is
/// `Boat::harbour()`, and the rough harbour generated from it is the default one, its file
/// (path and sha256) added to the provenance and the description.
#[test]
fn the_example_boats_file_is_the_built_in_traffic() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs/boats/harbour.json");
    let (boats, file) = read_boats(&path).unwrap();
    assert_eq!(boats, Boat::harbour());
    assert_eq!(
        (file.path.as_path(), file.sha256.len()),
        (path.as_path(), 64)
    );
    let default = generate(&rough(6)).unwrap();
    let from_file = generate_with_boats(&rough(6), path.to_str()).unwrap();
    assert_eq!(from_file.scans, default.scans);
    // In the first 6 scans every boat lies still (the first until 13.3 s): part of the static
    // scene, nothing is labelled moving.
    assert_eq!(moving_returns(&default), 0);
    assert_eq!(from_file.provenance.files, vec![file.clone()]);
    assert_eq!(
        from_file.provenance.description,
        format!(
            "{}; boats from {} (sha256 {})",
            default.provenance.description,
            path.display(),
            file.sha256
        )
    );
    assert!(
        default.provenance.description.contains(
            "3 moving boats (6 × 2.4 m in lane -4 m, start -20 s, rate 1.5; 8 × 2.8 m in lane \
             4.5 m, start 120 s, rate -1.2; 5 × 2.2 m in lane -4 m, start 15 s, rate 0.6)"
        ),
        "{}",
        default.provenance.description
    );
    // The same through the dataset string.
    let opened =
        datasets::open(&format!("synthetic:rough?scans=6&boats={}", path.display())).unwrap();
    assert_eq!(opened.scans, default.scans);
}

/// Boats written as JSON read back bit for bit, whatever their values.
#[test]
fn boats_round_trip_through_json() {
    let mut boats = Boat::harbour();
    boats.push(Boat {
        length_m: 0.1 + 0.2,
        beam_m: 1e-300,
        lane_m: -0.0,
        start_s: f64::MAX,
        rate: -std::f64::consts::PI,
    });
    let path = scratch_file(
        "round_trip.json",
        &serde_json::to_string_pretty(&boats).unwrap(),
    );
    let (back, _) = read_boats(&path).unwrap();
    let bits = |b: &[Boat]| -> Vec<[u64; 5]> {
        b.iter()
            .map(|b| [b.length_m, b.beam_m, b.lane_m, b.start_s, b.rate].map(f64::to_bits))
            .collect()
    };
    assert_eq!(bits(&back), bits(&boats));
}

/// `none` and an empty list both give the rough harbour without boats: no return is labelled
/// moving, the rest of the harbour is there (water, mixed pixels), the description says so,
/// and the same seed gives the same data.
#[test]
fn a_rough_harbour_without_boats_has_no_moving_returns() {
    let none = generate_with_boats(&rough(30), Some(NO_BOATS)).unwrap();
    assert_eq!(moving_returns(&none), 0);
    assert!(none.provenance.description.contains("no moving boats"));
    let empty = generate_with_boats(&rough(30), scratch_file("empty.json", "[]").to_str()).unwrap();
    assert_eq!(empty.scans, none.scans);
    assert_eq!(
        generate_with_boats(&rough(30), Some(NO_BOATS))
            .unwrap()
            .scans,
        none.scans,
        "deterministic"
    );
    // The built-in first boat waits 4 m to starboard of the start until 13 s, lying still: its
    // returns are static then. Sailing from the start, the same boat passes the vessel: 15 %
    // of the returns over the first 30 scans.
    let still = generate(&rough(30)).unwrap();
    assert_eq!(moving_returns(&still), 0);
    let sailing = scratch_file(
        "sailing.json",
        r#"[{"length_m": 6.0, "beam_m": 2.4, "lane_m": -4.0, "start_s": 0.5, "rate": 1.5}]"#,
    );
    let with = generate_with_boats(&rough(30), sailing.to_str()).unwrap();
    let share =
        moving_returns(&with) as f64 / with.scans.iter().map(|s| s.len()).sum::<usize>() as f64;
    assert!(
        (0.1..0.3).contains(&share),
        "{share} of the returns off the boats"
    );
    assert_eq!(
        generate_with_boats(&rough(30), sailing.to_str())
            .unwrap()
            .scans,
        with.scans,
        "deterministic"
    );
}

/// Every bad boats file or value is a typed error naming the file, and the boat and field
/// where one is wrong; nothing panics.
#[test]
fn bad_boats_are_typed_errors_naming_the_file_and_field() {
    let boat = r#"{"length_m": 6, "beam_m": 2.4, "lane_m": -4, "start_s": 0, "rate": 1}"#;
    let run = |name: &str, text: &str| {
        let path = scratch_file(name, text);
        (
            generate_with_boats(&rough(3), path.to_str()).unwrap_err(),
            path,
        )
    };
    for (name, text, expected) in [
        ("not_json.json", "boats: 3", "expected value"),
        (
            "object.json",
            boat,
            "invalid type: map, expected a sequence",
        ),
        (
            "colour.json",
            &format!("[{}]", boat.replace('}', r#", "colour": 1}"#)),
            "unknown field `colour`",
        ),
        (
            "missing.json",
            &format!("[{}]", boat.replace(r#", "rate": 1"#, "")),
            "missing field `rate`",
        ),
        (
            "nan.json",
            &format!("[{}]", boat.replace("2.4", "NaN")),
            "expected value",
        ),
        (
            "huge.json",
            &format!("[{}]", boat.replace("2.4", "1e999")),
            "number out of range",
        ),
        (
            "text.json",
            &format!("[{}]", boat.replace("2.4", r#""wide""#)),
            "invalid type: string",
        ),
    ] {
        let (e, path) = run(name, text);
        let DatasetError::Boats(BoatsError::Json { path: p, what, .. }) = &e else {
            panic!("{name}: {e:?}");
        };
        assert_eq!(p, &path);
        assert!(what.contains(expected), "{name}: {e}");
        assert!(
            e.to_string().starts_with(&path.display().to_string()),
            "{e}"
        );
    }
    for (text, index, field, value) in [
        (
            format!("[{boat}, {}]", boat.replace("2.4", "-2.4")),
            1,
            "beam_m",
            -2.4,
        ),
        (
            format!("[{}]", boat.replace(r#""length_m": 6"#, r#""length_m": 0"#)),
            0,
            "length_m",
            0.0,
        ),
    ] {
        let (e, path) = run("invalid.json", &text);
        let DatasetError::Boats(BoatsError::Invalid {
            path: p,
            index: i,
            field: f,
            value: v,
            ..
        }) = &e
        else {
            panic!("{e:?}");
        };
        assert_eq!((p, *i, *f, *v), (&path, index, field, value), "{e}");
    }
    let (e, path) = run(
        "invalid.json",
        &format!("[{}]", boat.replace("2.4", "-2.4")),
    );
    assert_eq!(
        e.to_string(),
        format!(
            "{}: boats[0].beam_m = -2.4: must be finite and positive",
            path.display()
        )
    );
    let missing = Path::new(env!("CARGO_TARGET_TMPDIR")).join("boats/nowhere.json");
    assert!(matches!(
        generate_with_boats(&rough(3), missing.to_str()),
        Err(DatasetError::Boats(BoatsError::Io { path, .. })) if path == missing
    ));
    // Boats apply to the rough harbour only.
    for scenario in [Scenario::paper(), Scenario::marina_like()] {
        let e = generate_with_boats(&scenario, Some(NO_BOATS)).unwrap_err();
        assert!(
            matches!(&e, DatasetError::Boats(BoatsError::NotRough { scenario: s }) if *s == scenario.name),
            "{e:?}"
        );
    }
    let e = datasets::open("synthetic:paper?scans=3&boats=none").unwrap_err();
    assert_eq!(
        e.to_string(),
        "boats: the \"paper\" scenario has no moving boats to replace (boats apply to the rough \
         scenario only)"
    );
    // A scenario built in code is checked too, naming the field.
    let mut bad = rough(3);
    bad.rough.as_mut().unwrap().boats[2].rate = f64::NAN;
    assert!(matches!(
        generate(&bad),
        Err(DatasetError::InvalidParameter { name: "rate", .. })
    ));
}
