//! The ROS 2 bag loader on bags the tests write in both storages (MCAP and sqlite3), checked
//! against truth: a synthetic harbour written into a bag and read back, reference poses on
//! known motions interpolated to the scan stamps, no-return counts, and the errors of
//! missing topics, truncated files and messages that do not decode. A bag written by an
//! independent writer (the Python `rosbags` package, `scripts/write-test-bag.py`) is read from
//! `ICP_ROSBAG_DIR` by an ignored test (CI sets it and runs `--include-ignored`).
#![cfg(all(feature = "rosbag-mcap", feature = "rosbag-sqlite"))]

#[path = "common/bagwriter.rs"]
mod bagwriter;
#[path = "common/data.rs"]
mod data;

use std::f64::consts::TAU;
use std::path::Path;

use bagwriter::*;
use datasets::synthetic::{generate, Scenario};
use datasets::{Dataset, DatasetError, LoadWarning, ReferenceKind};

const SCAN: &str = "sensor_msgs/msg/LaserScan";
const ODOM: &str = "nav_msgs/msg/Odometry";

fn open(path: &Path, query: &str) -> Result<Dataset, DatasetError> {
    datasets::open(&format!("rosbag:{}{query}", path.display()))
}

fn t_ns(t_s: f64) -> u64 {
    (t_s * 1e9).round() as u64
}

/// A synthetic scenario's dataset and its bag messages: each scan as a `LaserScan` on topic 0
/// (the first return's bearing is `angle_min`, the scenario's beam step the increment, beams
/// without a return NaN) and the reference pose as an `Odometry` on topic 1, at the scan stamp.
fn harbour_bag(scenario: &Scenario) -> (Dataset, Vec<Msg>) {
    let ds = generate(scenario).unwrap();
    let step = TAU / scenario.scanner.beams_per_rev() as f64;
    let range_max = (scenario.scanner.max_range_m + 5.0) as f32;
    let reference = ds.reference.as_ref().unwrap();
    let mut messages = Vec::new();
    for (s, p) in ds.scans.iter().zip(reference) {
        let r = s.returns();
        let b0 = r[0].bearing_rad;
        let index = |b: f64| ((b - b0) / step).round() as usize;
        let mut ranges = vec![f32::NAN; index(r[r.len() - 1].bearing_rad) + 1];
        for ret in r {
            ranges[index(ret.bearing_rad)] = ret.range_m as f32;
        }
        let t = s.timestamp_s().unwrap();
        let yaw = p.scan_yaw_rad.unwrap();
        messages.push((1, t_ns(t), odometry(t, p.x_m, p.y_m, yaw)));
        let scan = LaserScanMsg {
            t_s: t,
            angle_min: b0 as f32,
            angle_increment: step as f32,
            time_increment: 0.0,
            range_min: 0.0,
            range_max,
            ranges: &ranges,
        };
        messages.push((0, t_ns(t), laser_scan(&scan)));
    }
    (ds, messages)
}

/// The synthetic harbour written into a bag (LaserScan + Odometry at the scan stamps) and
/// read back gives the same scans, to float32 rounding of ranges and bearings, the same
/// stamps to the nanosecond, and the same reference poses.
#[test]
fn synthetic_harbour_round_trips_through_both_storages() {
    let scenario = Scenario {
        n_scans: 60,
        ..Scenario::paper()
    };
    let (ds, messages) = harbour_bag(&scenario);
    let step32 = (TAU / scenario.scanner.beams_per_rev() as f64) as f32;
    let reference = ds.reference.as_ref().unwrap();
    let dir = scratch("roundtrip");
    for storage in STORAGES {
        let path = write(
            &dir,
            "harbour",
            storage,
            &[("/scan", SCAN), ("/odom", ODOM)],
            &messages,
        );
        let back = open(&path, "?reference_kind=ground_truth").unwrap();
        assert_eq!(back.scans.len(), ds.scans.len(), "{storage:?}");
        assert_eq!(back.reference_kind, Some(ReferenceKind::GroundTruth));
        assert!(back.rigid_reference());
        assert_eq!(back.provenance.files.len(), 1);
        for (k, (a, b)) in ds.scans.iter().zip(&back.scans).enumerate() {
            let (ta, tb) = (a.timestamp_s().unwrap(), b.timestamp_s().unwrap());
            assert!(
                (ta - tb).abs() <= 1e-9,
                "{storage:?} scan {k}: {ta} vs {tb}"
            );
            assert_eq!(a.len(), b.len(), "{storage:?} scan {k}");
            let b0 = f64::from(a.returns()[0].bearing_rad as f32);
            for (ra, rb) in a.returns().iter().zip(b.returns()) {
                // Exactly what float32 storage gives...
                assert_eq!(rb.range_m, f64::from(ra.range_m as f32));
                let j = ((ra.bearing_rad - a.returns()[0].bearing_rad) / f64::from(step32)).round();
                assert_eq!(rb.bearing_rad, b0 + j * f64::from(step32));
                // ...and within float32 rounding of the truth.
                assert!((rb.range_m - ra.range_m).abs() <= ra.range_m * 6e-8);
                assert!((rb.bearing_rad - ra.bearing_rad).abs() <= 2e-6, "scan {k}");
            }
            let (p, q) = (reference[k], back.reference.as_ref().unwrap()[k]);
            let (ya, yb) = (p.scan_yaw_rad.unwrap(), q.scan_yaw_rad.unwrap());
            assert!((p.x_m - q.x_m).abs() < 1e-12 && (p.y_m - q.y_m).abs() < 1e-12);
            assert!((ya - yb).abs() < 1e-12, "yaw {ya} vs {yb}");
            // The synthetic heading is navigational: 90° − yaw.
            let nav = icp_core::motion::wrap_360(90.0 - q.heading_rad.to_degrees());
            assert!((nav - p.heading_rad.to_degrees()).abs() < 1e-9);
        }
        assert!((back.dt_s - ds.dt_s).abs() < 1e-9);
        assert_eq!(
            back.consecutive_pairs().0.len(),
            ds.consecutive_pairs().0.len()
        );
    }
}

/// Scans every 0.1 s from t = 100 s; a reference on a known motion sampled every 0.25 s from
/// t = 100.05 s: x = 2 t', y = −t', yaw = 0.3 t' − 3 (t' = t − 100, wrapping through ±π), all
/// linear in time, so linear / shortest-arc interpolation is exact.
fn line_motion(t_s: f64) -> (f64, f64, f64) {
    let t = t_s - 100.0;
    let yaw = (0.3 * t - 3.0 + std::f64::consts::PI).rem_euclid(TAU) - std::f64::consts::PI;
    (2.0 * t, -t, yaw)
}

fn small_scan(t_s: f64) -> Vec<u8> {
    small_scan_timed(t_s, 0.0)
}

/// [`small_scan`] with its readings `time_increment_s` apart.
fn small_scan_timed(t_s: f64, time_increment_s: f32) -> Vec<u8> {
    let ranges: Vec<f32> = (0..90).map(|k| 5.0 + (k as f32 * 0.1).sin()).collect();
    laser_scan(&LaserScanMsg {
        t_s,
        angle_min: -1.5,
        angle_increment: 0.033,
        time_increment: time_increment_s,
        range_min: 0.1,
        range_max: 30.0,
        ranges: &ranges,
    })
}

fn scan_stamps() -> Vec<f64> {
    (0..40).map(|k| 100.0 + 0.1 * k as f64).collect()
}

#[test]
fn each_rigid_reference_type_is_interpolated_to_the_scan_stamps() {
    type Encode = fn(f64, f64, f64, f64) -> Vec<u8>;
    let types: [(&str, Encode, ReferenceKind); 3] = [
        (ODOM, odometry, ReferenceKind::Odometry),
        (
            "geometry_msgs/msg/PoseStamped",
            pose_stamped,
            ReferenceKind::Unknown,
        ),
        (
            "geometry_msgs/msg/PoseWithCovarianceStamped",
            pose_with_covariance_stamped,
            ReferenceKind::Unknown,
        ),
    ];
    let dir = scratch("rigid_types");
    for (ty, encode, kind) in types {
        let mut messages: Vec<Msg> = scan_stamps()
            .into_iter()
            .map(|t| (0, t_ns(t), small_scan(t)))
            .collect();
        // Poses from 100.05 s to 103.55 s: the scan at 100.0 s is before, 103.6 s .. 103.9 s after.
        for k in 0..15 {
            let t = 100.05 + 0.25 * k as f64;
            let (x, y, yaw) = line_motion(t);
            messages.push((1, t_ns(t), encode(t, x, y, yaw)));
        }
        for storage in STORAGES {
            let stem = ty.replace('/', "_");
            let path = write(
                &dir,
                &stem,
                storage,
                &[("/scan", SCAN), ("/pose", ty)],
                &messages,
            );
            let ds = open(&path, "").unwrap();
            assert_eq!(ds.reference_kind, Some(kind), "{ty}");
            assert!(
                ds.warnings.contains(&LoadWarning::ScansOutsideReference {
                    before: 1,
                    after: 4
                }),
                "{ty} {storage:?}: {:?}",
                ds.warnings
            );
            assert_eq!(ds.scans.len(), 35);
            for (scan, p) in ds.scans.iter().zip(ds.reference.as_ref().unwrap()) {
                let t = scan.timestamp_s().unwrap();
                let (x, y, yaw) = line_motion(t);
                let dyaw = (p.scan_yaw_rad.unwrap() - yaw + 3.0 * std::f64::consts::PI)
                    .rem_euclid(TAU)
                    - std::f64::consts::PI;
                assert!(
                    (p.x_m - x).abs() < 1e-6 && (p.y_m - y).abs() < 1e-6,
                    "{ty} at {t}"
                );
                assert!(
                    dyaw.abs() < 1e-6,
                    "{ty} at {t}: {} vs {yaw}",
                    p.scan_yaw_rad.unwrap()
                );
            }
            // The kind can be said.
            let ds = open(&path, "?reference_kind=slam_corrected").unwrap();
            assert_eq!(ds.reference_kind, Some(ReferenceKind::SlamCorrected));
        }
    }
}

/// GNSS fixes along a known track (east 3 m/s, north 4 m/s: 5 m/s on a course 53.13° from east)
/// become local positions about the first fix, with SOG and COG only.
/// The sweep is `|time_increment| · (readings − 1)` when every scan states its
/// `time_increment` (reversed readings count alike), unknown when one leaves it 0 or not
/// finite; `scan_time` (the time between scans) plays no part.
#[test]
fn the_sweep_comes_from_time_increment() {
    let dir = scratch("sweep");
    let bag = |name: &str, increment: &dyn Fn(usize) -> f32| {
        let mut messages: Vec<Msg> = scan_stamps()
            .into_iter()
            .enumerate()
            .map(|(k, t)| (0, t_ns(t), small_scan_timed(t, increment(k))))
            .collect();
        for k in 0..20 {
            let t = 99.95 + 0.25 * k as f64;
            let (x, y, yaw) = line_motion(t);
            messages.push((1, t_ns(t), odometry(t, x, y, yaw)));
        }
        let path = write(
            &dir,
            name,
            STORAGES[0],
            &[("/scan", SCAN), ("/odom", ODOM)],
            &messages,
        );
        open(&path, "").unwrap().sweep_s
    };
    // 90 readings 1/900 s apart: a 10 Hz scanner's quarter turn.
    let dt = 1.0f32 / 900.0;
    let expected = f64::from(dt) * 89.0;
    assert_eq!(bag("stated", &|_| dt), Some(expected));
    assert_eq!(
        bag("reversed", &|k| if k % 2 == 0 { -dt } else { dt }),
        Some(expected)
    );
    assert_eq!(bag("one_unknown", &|k| if k == 7 { 0.0 } else { dt }), None);
    assert_eq!(bag("nan", &|k| if k == 3 { f32::NAN } else { dt }), None);
    assert_eq!(bag("unstated", &|_| 0.0), None);
}

#[test]
fn nav_sat_fix_gives_local_positions_and_course_over_ground() {
    let (lat0, lon0) = (54.52f64, 18.55f64);
    // Local radii at lat0 (WGS 84): metres per radian north (M) and east (N cos φ).
    let (a, f) = (6_378_137.0f64, 1.0 / 298.257_223_563);
    let e2 = f * (2.0 - f);
    let phi = lat0.to_radians();
    let w = 1.0 - e2 * phi.sin().powi(2);
    let (m, n) = (a * (1.0 - e2) / w.powf(1.5), a / w.sqrt());
    let fix_at = |t: f64| {
        let t0 = t - 100.0;
        (
            lat0 + (4.0 * t0 / m).to_degrees(),
            lon0 + (3.0 * t0 / (n * phi.cos())).to_degrees(),
        )
    };
    let mut messages: Vec<Msg> = scan_stamps()
        .into_iter()
        .map(|t| (0, t_ns(t), small_scan(t)))
        .collect();
    for k in 0..=8 {
        let t = 100.0 + 0.5 * k as f64;
        let (lat, lon) = fix_at(t);
        messages.push((1, t_ns(t), nav_sat_fix(t, 2, lat, lon, 12.0)));
    }
    // A fix without a position fix is skipped and counted.
    messages.push((1, t_ns(101.3), nav_sat_fix(101.3, -1, 0.0, 0.0, 0.0)));
    let dir = scratch("gnss");
    for storage in STORAGES {
        let path = write(
            &dir,
            "gnss",
            storage,
            &[("/scan", SCAN), ("/fix", "sensor_msgs/msg/NavSatFix")],
            &messages,
        );
        let ds = open(&path, "").unwrap();
        assert_eq!(ds.reference_kind, Some(ReferenceKind::GnssPositions));
        assert!(!ds.rigid_reference());
        assert!(ds
            .warnings
            .contains(&LoadWarning::UnusableReferenceMessages { messages: 1 }));
        assert!(!ds
            .warnings
            .iter()
            .any(|w| matches!(w, LoadWarning::ScansOutsideReference { .. })));
        let reference = ds.reference.as_ref().unwrap();
        assert_eq!(reference.len(), 40);
        for (scan, p) in ds.scans.iter().zip(reference) {
            let t0 = scan.timestamp_s().unwrap() - 100.0;
            // First-order local radii: exact to well under a millimetre over 20 m.
            assert!(
                (p.x_m - 3.0 * t0).abs() < 2e-3 && (p.y_m - 4.0 * t0).abs() < 2e-3,
                "{t0}: {p:?}"
            );
            assert!((p.heading_rad.to_degrees() - 4f64.atan2(3.0).to_degrees()).abs() < 1e-3);
            assert_eq!(p.scan_yaw_rad, None);
        }
        let bad = open(&path, "?reference_kind=ground_truth")
            .unwrap_err()
            .to_string();
        assert!(bad.contains("only gnss_positions fits"), "{bad}");
    }
}

#[test]
fn stamps_out_of_order_are_sorted_and_said() {
    let stamps = scan_stamps();
    let ordered: Vec<Msg> = stamps
        .iter()
        .map(|&t| (0, t_ns(t), small_scan(t)))
        .collect();
    let mut shuffled = ordered.clone();
    shuffled.swap(3, 17);
    shuffled.swap(20, 21);
    // Receive times follow the storage order, as a late message's would.
    for (k, m) in shuffled.iter_mut().enumerate() {
        m.1 = t_ns(200.0 + 0.1 * k as f64);
    }
    let dir = scratch("order");
    for storage in STORAGES {
        let a = open(
            &write(&dir, "ordered", storage, &[("/scan", SCAN)], &ordered),
            "",
        )
        .unwrap();
        let b = open(
            &write(&dir, "shuffled", storage, &[("/scan", SCAN)], &shuffled),
            "",
        )
        .unwrap();
        assert_eq!(a.scans, b.scans, "{storage:?}");
        assert!(!a
            .warnings
            .iter()
            .any(|w| matches!(w, LoadWarning::ScansReordered { .. })));
        assert!(
            b.warnings
                .contains(&LoadWarning::ScansReordered { scans: 3 }),
            "{:?}",
            b.warnings
        );
        assert_eq!(a.reference, None);
        assert!((a.dt_s - 0.1).abs() < 1e-9);
    }
}

#[test]
fn missing_and_ambiguous_topics_are_typed_errors() {
    let t = 100.0;
    let dir = scratch("topics");
    let two: Vec<Msg> = vec![
        (0, 1, small_scan(t)),
        (1, 1, small_scan(t)),
        (2, 1, odometry(t, 0.0, 0.0, 0.0)),
    ];
    for storage in STORAGES {
        let path = write(
            &dir,
            "two",
            storage,
            &[("/front", SCAN), ("/rear", SCAN), ("/odom", ODOM)],
            &two,
        );
        let e = open(&path, "").unwrap_err();
        assert!(matches!(e, DatasetError::BagTopic { .. }), "{e}");
        assert!(
            e.to_string()
                .contains("2 LaserScan topics: /front (sensor_msgs/msg/LaserScan), /rear"),
            "{e}"
        );
        assert!(e.to_string().contains("?scan=/topic"), "{e}");
        assert_eq!(open(&path, "?scan=/rear").unwrap().scans.len(), 1);
        let e = open(&path, "?scan=/top").unwrap_err().to_string();
        assert!(
            e.contains("no topic \"/top\" (given as ?scan=/topic); the bag has: /front"),
            "{e}"
        );
        let e = open(&path, "?scan=/odom").unwrap_err().to_string();
        assert!(
            e.contains(
                "topic \"/odom\" has type nav_msgs/msg/Odometry, not sensor_msgs/msg/LaserScan"
            ),
            "{e}"
        );
        let e = open(&path, "?scan=/front&reference=/rear")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("topic \"/rear\" has type sensor_msgs/msg/LaserScan, not nav_msgs"),
            "{e}"
        );
        let ds = open(&path, "?scan=/front&reference=none").unwrap();
        assert_eq!(ds.reference, None);

        // Topics of other types are listed but their messages are not kept (nor decoded).
        let path = write(
            &dir,
            "with_images",
            storage,
            &[("/camera", "sensor_msgs/msg/Image"), ("/scan", SCAN)],
            &[
                (0, 1, vec![7; 5000]),
                (1, 1, small_scan(t)),
                (0, 2, vec![1]),
            ],
        );
        let bag = datasets::rosbag::storage::read(&path).unwrap();
        assert_eq!(bag.topics.len(), 2);
        assert_eq!(bag.messages.len(), 1, "{storage:?}");
        assert_eq!(open(&path, "").unwrap().scans.len(), 1);

        // A topic without messages is still a topic (the MCAP summary, the sqlite topics table).
        let path = write(
            &dir,
            "empty_topic",
            storage,
            &[("/front", SCAN), ("/rear", SCAN)],
            &[(0, 1, small_scan(t))],
        );
        let e = open(&path, "").unwrap_err().to_string();
        assert!(e.contains("2 LaserScan topics"), "{storage:?}: {e}");
        let e = open(&path, "?scan=/rear").unwrap_err().to_string();
        assert!(e.contains("no scan to use on /rear"), "{storage:?}: {e}");

        let path = write(
            &dir,
            "no_scan",
            storage,
            &[("/odom", ODOM)],
            &[(0, 1, odometry(t, 0.0, 0.0, 0.0))],
        );
        let e = open(&path, "").unwrap_err().to_string();
        assert!(
            e.contains("no LaserScan topic (sensor_msgs/msg/LaserScan); the bag has: /odom"),
            "{e}"
        );
    }
    let e = datasets::open("rosbag:/nonexistent/bag.mcap")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("cannot read /nonexistent/bag.mcap"), "{e}");
}

#[test]
fn truncated_and_foreign_files_are_typed_errors() {
    let messages: Vec<Msg> = scan_stamps()
        .iter()
        .map(|&t| (0, t_ns(t), small_scan(t)))
        .collect();
    let dir = scratch("truncated");
    for storage in STORAGES {
        let path = write(&dir, "whole", storage, &[("/scan", SCAN)], &messages);
        let bytes = std::fs::read(&path).unwrap();
        for keep in [bytes.len() / 2, 20, 5] {
            let cut = dir.join(format!(
                "cut_{keep}.{}",
                path.extension().unwrap().to_string_lossy()
            ));
            std::fs::write(&cut, &bytes[..keep]).unwrap();
            let e = open(&cut, "").unwrap_err();
            assert!(
                matches!(e, DatasetError::BagStorage { .. }),
                "{storage:?} {keep}: {e}"
            );
            assert!(e.to_string().starts_with(&cut.display().to_string()), "{e}");
        }
    }
    let other = dir.join("notes.mcap");
    std::fs::write(&other, "just text, not a bag").unwrap();
    let e = open(&other, "").unwrap_err().to_string();
    assert!(
        e.contains("neither an MCAP file nor an sqlite3 database"),
        "{e}"
    );
}

#[test]
fn a_topic_whose_messages_do_not_decode_names_the_message_and_field() {
    let t = 100.0;
    let dir = scratch("schema");
    // A LaserScan topic carrying Odometry-sized bytes of another layout, and one cut short.
    let short = {
        let mut m = small_scan(t);
        m.truncate(60);
        m
    };
    for storage in STORAGES {
        let path = write(
            &dir,
            "short",
            storage,
            &[("/scan", SCAN)],
            &[(0, 1, small_scan(t)), (0, 2, short.clone())],
        );
        let e = open(&path, "").unwrap_err();
        assert!(
            matches!(e, DatasetError::BagMessage { index: 1, .. }),
            "{e}"
        );
        assert!(
            e.to_string()
                .contains("message 1 of topic /scan: field ranges"),
            "{e}"
        );
        let path = write(
            &dir,
            "pose",
            storage,
            &[("/scan", SCAN)],
            &[(0, 1, pose_stamped(t, 1.0, 2.0, 0.5))],
        );
        let e = open(&path, "").unwrap_err().to_string();
        assert!(
            e.contains("message 0 of topic /scan: 20 bytes left after the last field"),
            "{e}"
        );
        let xcdr2 = [&[0u8, 0x07, 0, 0][..], &small_scan(t)[4..]].concat();
        let path = write(&dir, "xcdr2", storage, &[("/scan", SCAN)], &[(0, 1, xcdr2)]);
        let e = open(&path, "").unwrap_err().to_string();
        assert!(e.contains("encapsulation 0x0007 is not plain CDR"), "{e}");
    }
}

#[test]
fn nan_infinite_and_out_of_range_readings_are_counted_no_returns() {
    let ranges = [
        1.0,
        f32::NAN,
        2.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        0.05,
        35.0,
        3.0,
        29.9,
        0.1,
        30.0,
    ];
    let mut all = ranges.to_vec();
    all.extend((0..20).map(|k| 4.0 + k as f32 * 0.01));
    let msgs: Vec<Msg> = (0..2)
        .map(|k| {
            let t = 100.0 + k as f64;
            let m = LaserScanMsg {
                t_s: t,
                angle_min: -1.0,
                angle_increment: 0.05,
                time_increment: 0.0,
                range_min: 0.1,
                range_max: 30.0,
                ranges: &all,
            };
            (0, t_ns(t), laser_scan(&m))
        })
        .collect();
    let dir = scratch("no_returns");
    for storage in STORAGES {
        let ds = open(&write(&dir, "nr", storage, &[("/scan", SCAN)], &msgs), "").unwrap();
        // Per scan: NaN, +∞, −∞ non-finite; 0.05 below; 35 above; 0.1 and 30 are inside.
        assert!(
            ds.warnings.contains(&LoadWarning::NoReturnReadings {
                readings: 2 * all.len(),
                non_finite: 6,
                below_range_min: 2,
                above_range_max: 2,
            }),
            "{:?}",
            ds.warnings
        );
        for s in &ds.scans {
            assert_eq!(s.len(), all.len() - 5);
            assert_eq!(s.no_returns(), 5);
            // Bearings keep their beam: the reading 2.0 is beam 2.
            let r = s.returns().iter().find(|r| r.range_m == 2.0).unwrap();
            assert_eq!(r.bearing_rad, f64::from(-1.0f32) + 2.0 * f64::from(0.05f32));
        }
        let text = ds
            .warnings
            .iter()
            .map(|w| w.to_string())
            .collect::<Vec<_>>()
            .join("\n");
        assert!(text.contains("10 of 62 readings are no-returns: 6 NaN or ±∞, 2 below range_min, 2 above range_max"), "{text}");
    }
}

/// A `LaserScan` with fewer readings than the others is named (issue 33); `?scans=N` keeps
/// the first N and checks them again.
#[test]
fn a_scan_with_fewer_readings_is_named_and_scans_keeps_the_first() {
    let full: Vec<f32> = (0..90).map(|k| 5.0 + (k as f32 * 0.1).sin()).collect();
    let msgs: Vec<Msg> = (0..5)
        .map(|k| {
            let t = 100.0 + 0.1 * k as f64;
            let m = LaserScanMsg {
                t_s: t,
                angle_min: -1.5,
                angle_increment: 0.033,
                time_increment: 0.0,
                range_min: 0.1,
                range_max: 30.0,
                ranges: if k == 3 { &full[..60] } else { &full },
            };
            (0, t_ns(t), laser_scan(&m))
        })
        .collect();
    let dir = scratch("short_scan");
    for storage in STORAGES {
        let path = write(&dir, "short", storage, &[("/scan", SCAN)], &msgs);
        let ds = open(&path, "").unwrap();
        assert!(
            ds.warnings.contains(&LoadWarning::ShortScan {
                scan: 3,
                readings: 60,
                neighbour_readings: vec![90, 90],
                usual_readings: 90,
                scans: 1,
            }),
            "{:?}",
            ds.warnings
        );
        let first = open(&path, "?scans=3").unwrap();
        assert_eq!(first.scans, ds.scans[..3]);
        assert_eq!(
            first.first_scans,
            Some(datasets::FirstScans {
                requested: 3,
                available: 5
            })
        );
        assert!(!first
            .warnings
            .iter()
            .any(|w| matches!(w, LoadWarning::ShortScan { .. })));
    }
}

#[test]
fn a_bag_directory_is_read_through_its_metadata_yaml() {
    let dir = scratch("directory");
    let bag = dir.join("run");
    let stamps = scan_stamps();
    let (first, second) = stamps.split_at(15);
    let part = |ts: &[f64]| {
        ts.iter()
            .map(|&t| (0, t_ns(t), small_scan(t)))
            .collect::<Vec<Msg>>()
    };
    write(
        &bag,
        "run_0",
        Storage::Mcap,
        &[("/scan", SCAN)],
        &part(first),
    );
    write(
        &bag,
        "run_1",
        Storage::Mcap,
        &[("/scan", SCAN)],
        &part(second),
    );
    std::fs::write(
        bag.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n  \
         relative_file_paths:\n    - run_0.mcap\n    - run_1.mcap\n  duration:\n    nanoseconds: 1\n",
    )
    .unwrap();
    let ds = open(&bag, "").unwrap();
    assert_eq!(ds.scans.len(), 40);
    assert_eq!(ds.provenance.files.len(), 2);
    assert_eq!(ds.provenance.name, "rosbag:run");
    std::fs::remove_file(bag.join("metadata.yaml")).unwrap();
    let e = open(&bag, "").unwrap_err().to_string();
    assert!(e.contains("metadata.yaml"), "{e}");
}

/// Loading time of the 865-scan `paper` scenario written into a bag (printed, not asserted).
#[test]
fn loading_a_paper_sized_bag_is_timed() {
    let scenario = Scenario::paper();
    let (_, messages) = harbour_bag(&scenario);
    let dir = scratch("timing");
    for storage in STORAGES {
        let path = write(
            &dir,
            "paper",
            storage,
            &[("/scan", SCAN), ("/odom", ODOM)],
            &messages,
        );
        let size = std::fs::metadata(&path).unwrap().len();
        let start = std::time::Instant::now();
        let back = open(&path, "").unwrap();
        let elapsed = start.elapsed();
        assert_eq!(back.scans.len(), 865);
        eprintln!(
            "loaded {} scans from a {:.1} MB {storage:?} bag in {:.3} s",
            back.scans.len(),
            size as f64 / 1e6,
            elapsed.as_secs_f64()
        );
    }
}

/// Bags written by `scripts/write-test-bag.py` with the Python `rosbags` package (an
/// independent writer), in both storages: 50 scans of 360 beams every 0.1 s on a circle of
/// radius 10 m around the scanner, beam k reading NaN when k % 10 == 0, and Odometry at the
/// same stamps moving at 1 m/s along x while turning 0.1 rad/s, the pose of base_link; the
/// laser 0.5 m ahead of it and turned 90° through the two links of /tf_static, so the
/// reference (the laser's pose) is x = t' + 0.5 cos ψ, y = 0.5 sin ψ, yaw ψ + 90° (ψ = 0.1 t').
#[test]
#[ignore = "needs bags from scripts/write-test-bag.py (ICP_ROSBAG_DIR): run with --include-ignored"]
fn bags_written_by_rosbags_are_read() {
    let root = data::rosbag_dir();
    for name in ["mcap", "sqlite3"] {
        let bag = root.join(name);
        let ds = open(&bag, "").unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(ds.scans.len(), 50, "{name}");
        assert_eq!(ds.reference_kind, Some(ReferenceKind::Odometry));
        assert!(
            ds.warnings.contains(&LoadWarning::NoReturnReadings {
                readings: 50 * 360,
                non_finite: 50 * 36,
                below_range_min: 0,
                above_range_max: 0,
            }),
            "{name}: {:?}",
            ds.warnings
        );
        for (k, (s, p)) in ds
            .scans
            .iter()
            .zip(ds.reference.as_ref().unwrap())
            .enumerate()
        {
            assert_eq!(s.len(), 324);
            assert!(s.returns().iter().all(|r| (r.range_m - 10.0).abs() < 1e-6));
            let t = 0.1 * k as f64;
            assert!((s.timestamp_s().unwrap() - (1_700_000_000.0 + t)).abs() < 1e-6);
            let psi = 0.1 * t;
            assert!(
                (p.x_m - (t + 0.5 * psi.cos())).abs() < 1e-9
                    && (p.y_m - 0.5 * psi.sin()).abs() < 1e-9,
                "{name} {k}: {p:?}"
            );
            assert!((p.scan_yaw_rad.unwrap() - (psi + std::f64::consts::FRAC_PI_2)).abs() < 1e-9);
        }
        // time_increment 0.1 s / 360 as float32, over 359 steps.
        assert_eq!(
            ds.sweep_s,
            Some(f64::from((0.1f64 / 360.0) as f32) * 359.0),
            "{name}"
        );
        let o = ds.scanner_offset.expect("the offset from /tf_static");
        assert!(
            (o.x_m - 0.5).abs() < 1e-12
                && o.y_m.abs() < 1e-12
                && (o.yaw_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12,
            "{name}: {o:?}"
        );
        assert_eq!(offset_unknown_reason(&ds), None, "{name}");
        assert!((ds.dt_s - 0.1).abs() < 1e-6);
    }
}

const TF: &str = "tf2_msgs/msg/TFMessage";

/// A body turning while it moves: x = 1.5 t', y = 0.2 t'², yaw = 0.35 t' − 1 (t' = t − 100 s):
/// 2° between the 0.1 s scans.
fn turning_body(t_s: f64) -> (f64, f64, f64) {
    let t = t_s - 100.0;
    (1.5 * t, 0.2 * t * t, 0.35 * t - 1.0)
}

/// The laser 0.5 m ahead of `base_link` and turned 90° (0.4 m up), through `mount`.
const LASER_IN_BASE: (f64, f64, f64) = (0.5, 0.0, std::f64::consts::FRAC_PI_2);

/// The static transforms of [`LASER_IN_BASE`] as two links, each its own TFMessage (two
/// static broadcasters): `base_link → mount` at (0.3, 0, 0.2) turned 30°, `/mount → laser` at
/// (0.2 cos 30°, −0.2 sin 30°, 0.2) turned 60°; and an unrelated `base_link → imu`.
fn two_link_tf() -> [Vec<u8>; 2] {
    let d30 = 30f64.to_radians();
    [
        tf_message(
            99.0,
            &[
                ("base_link", "mount", [0.3, 0.0, 0.2], yaw_quaternion(d30)),
                ("base_link", "imu", [-0.4, 0.1, 0.0], yaw_quaternion(0.0)),
            ],
        ),
        tf_message(
            99.0,
            &[(
                "/mount",
                "laser",
                [0.2 * d30.cos(), -0.2 * d30.sin(), 0.2],
                yaw_quaternion(2.0 * d30),
            )],
        ),
    ]
}

/// Scans (topic 0) and body poses of [`turning_body`] (topic 1, encoded by `encode`) at the
/// scan stamps, then `extra` messages on topic 2, received first.
fn body_bag(encode: fn(f64, f64, f64, f64) -> Vec<u8>, extra: &[Vec<u8>]) -> Vec<Msg> {
    let mut messages: Vec<Msg> = extra.iter().map(|m| (2, t_ns(99.0), m.clone())).collect();
    for t in scan_stamps() {
        let (x, y, yaw) = turning_body(t);
        messages.push((1, t_ns(t), encode(t, x, y, yaw)));
        messages.push((0, t_ns(t), small_scan(t)));
    }
    messages
}

fn iso(x: f64, y: f64, yaw: f64) -> nalgebra::Isometry2<f64> {
    nalgebra::Isometry2::new(nalgebra::Vector2::new(x, y), yaw)
}

fn reference_isometries(ds: &Dataset) -> Vec<nalgebra::Isometry2<f64>> {
    ds.reference
        .as_ref()
        .unwrap()
        .iter()
        .map(|p| p.scan_pose().unwrap())
        .collect()
}

fn offset_unknown_reason(ds: &Dataset) -> Option<&str> {
    ds.warnings.iter().find_map(|w| match w {
        LoadWarning::ScannerOffsetUnknown { reason } => Some(reason.as_str()),
        _ => None,
    })
}

/// The reference poses are the body's at the scan stamps, as today, when the offset is unknown.
fn assert_body_poses(ds: &Dataset, what: &str) {
    assert_eq!(ds.scanner_offset, None, "{what}");
    for (scan, p) in ds.scans.iter().zip(reference_isometries(ds)) {
        let (x, y, yaw) = turning_body(scan.timestamp_s().unwrap());
        let d = iso(x, y, yaw).inverse() * p;
        assert!(d.translation.vector.norm() < 1e-9 && d.rotation.angle().abs() < 1e-9);
    }
}

/// The laser 0.5 m ahead of base_link and turned 90° through a two-link /tf_static chain: the
/// loaded reference is the laser's true pose at every scan (body pose ∘ offset, in closed
/// form), and, registration-free, the reference motion between consecutive scans is the
/// laser's true motion `T⁻¹ · ΔT_body · T`, whose displacement differs from the body's by
/// 1.7 cm per 2° turn. Both storages; Odometry (child_frame_id base_link) and PoseStamped (base_link by
/// default, or `?body_frame=`).
#[test]
fn the_scanner_offset_from_tf_static_moves_the_reference_to_the_laser() {
    let dir = scratch("tf_chain");
    let (ox, oy, oyaw) = LASER_IN_BASE;
    let t_body_laser = iso(ox, oy, oyaw);
    type Encode = fn(f64, f64, f64, f64) -> Vec<u8>;
    let types: [(&str, Encode); 2] = [
        (ODOM, odometry),
        ("geometry_msgs/msg/PoseStamped", pose_stamped),
    ];
    for (ty, encode) in types {
        let messages = body_bag(encode, &two_link_tf());
        for storage in STORAGES {
            let topics = [("/scan", SCAN), ("/pose", ty), ("/tf_static", TF)];
            let path = write(&dir, &ty.replace('/', "_"), storage, &topics, &messages);
            let what = format!("{ty} {storage:?}");
            let ds = open(&path, "").unwrap_or_else(|e| panic!("{what}: {e}"));
            assert_eq!(offset_unknown_reason(&ds), None, "{what}");
            let o = ds.scanner_offset.expect("a known offset");
            assert!(
                (o.x_m - ox).abs() < 1e-12 && (o.y_m - oy).abs() < 1e-12,
                "{what}: {o:?}"
            );
            assert!((o.yaw_rad - oyaw).abs() < 1e-12, "{what}: {o:?}");
            let poses = reference_isometries(&ds);
            assert_eq!(poses.len(), 40);
            for (k, (scan, p)) in ds.scans.iter().zip(&poses).enumerate() {
                let (x, y, yaw) = turning_body(scan.timestamp_s().unwrap());
                let (truth_x, truth_y) = (x + ox * yaw.cos(), y + ox * yaw.sin());
                let q = ds.reference.as_ref().unwrap()[k];
                assert!(
                    (q.x_m - truth_x).abs() < 1e-9 && (q.y_m - truth_y).abs() < 1e-9,
                    "{what} scan {k}: {q:?}"
                );
                let truth_yaw = yaw + oyaw;
                assert!(
                    (iso(0.0, 0.0, truth_yaw).inverse() * p)
                        .rotation
                        .angle()
                        .abs()
                        < 1e-9
                );
                if k + 1 < poses.len() {
                    let (x1, y1, yaw1) = turning_body(ds.scans[k + 1].timestamp_s().unwrap());
                    let body_motion = iso(x, y, yaw).inverse() * iso(x1, y1, yaw1);
                    let laser_motion = t_body_laser.inverse() * body_motion * t_body_laser;
                    let measured = p.inverse() * poses[k + 1];
                    let d = laser_motion.inverse() * measured;
                    assert!(d.translation.vector.norm() < 1e-9, "{what} pair {k}");
                    assert!(d.rotation.angle().abs() < 1e-9, "{what} pair {k}");
                    // The check has teeth: the laser's displacement differs from the body's
                    // by the lever arm turned through Δψ = 2.0°, 2 · 0.5 m · sin(Δψ/2) = 1.7 cm.
                    let laser_step = poses[k + 1].translation.vector - p.translation.vector;
                    let body_step = nalgebra::Vector2::new(x1 - x, y1 - y);
                    let lever_m = 2.0 * ox * ((yaw1 - yaw) / 2.0).sin();
                    assert!(((laser_step - body_step).norm() - lever_m).abs() < 1e-9);
                    assert!(lever_m > 0.017, "{lever_m}");
                }
            }
        }
    }
    // ?body_frame= names another frame of the tree: the offset from it.
    let messages = body_bag(pose_stamped, &two_link_tf());
    let topics = [
        ("/scan", SCAN),
        ("/pose", "geometry_msgs/msg/PoseStamped"),
        ("/tf_static", TF),
    ];
    let path = write(&dir, "body_frame", STORAGES[0], &topics, &messages);
    let ds = open(&path, "?body_frame=imu").unwrap();
    let o = ds.scanner_offset.unwrap();
    assert!(
        (o.x_m - 0.9).abs() < 1e-12 && (o.y_m + 0.1).abs() < 1e-12,
        "{o:?}"
    );
    // The poses are then taken as imu's, moved by (0.9, −0.1) turned 90°: both components of
    // the lever arm turn with the body.
    for (scan, p) in ds.scans.iter().zip(reference_isometries(&ds)) {
        let (x, y, yaw) = turning_body(scan.timestamp_s().unwrap());
        let truth = iso(x, y, yaw) * iso(0.9, -0.1, oyaw);
        let d = truth.inverse() * p;
        assert!(d.translation.vector.norm() < 1e-9 && d.rotation.angle().abs() < 1e-9);
    }
}

/// Without /tf_static (or with only a dynamic /tf), with ?tf=off, with a tree that joins no
/// path from the body to the laser, or with a pose reference and no base_link: the poses are
/// the body's, as before, and the warning says why, naming the frames.
#[test]
fn without_a_tf_path_the_offset_is_unknown_and_said() {
    let dir = scratch("tf_missing");
    let no_path = tf_message(
        99.0,
        &[
            ("base_link", "imu", [0.1, 0.0, 0.0], yaw_quaternion(0.0)),
            ("map", "laser", [0.0; 3], yaw_quaternion(0.0)),
        ],
    );
    /// Bag stem, tf topic name, tf messages, query, the reason's expected text.
    type Case<'a> = (&'a str, &'a str, Vec<Vec<u8>>, &'a str, &'a str);
    let cases: [Case<'_>; 5] = [
        ("none", "/other", vec![], "", "the bag has no /tf_static"),
        (
            "dynamic",
            "/tf",
            two_link_tf().to_vec(),
            "",
            "no /tf_static (dynamic tf is not read",
        ),
        (
            "off",
            "/tf_static",
            two_link_tf().to_vec(),
            "?tf=off",
            "?tf=off",
        ),
        (
            "no_path",
            "/tf_static",
            vec![no_path.clone()],
            "",
            "no path from frame \"base_link\" to frame \"laser\" in /tf_static \
             (its frames: base_link, imu, laser, map)",
        ),
        (
            "no_path_named",
            "/tf_static",
            vec![no_path],
            "?body_frame=imu",
            "no path from frame \"imu\" to frame \"laser\"",
        ),
    ];
    for (stem, tf_topic, extra, query, reason) in cases {
        let messages = body_bag(odometry, &extra);
        for storage in STORAGES {
            let topics = [("/scan", SCAN), ("/odom", ODOM), (tf_topic, TF)];
            let path = write(&dir, stem, storage, &topics, &messages);
            let what = format!("{stem} {storage:?}");
            let ds = open(&path, query).unwrap_or_else(|e| panic!("{what}: {e}"));
            let said = offset_unknown_reason(&ds).unwrap_or_else(|| panic!("{what}"));
            assert!(said.contains(reason), "{what}: {said}");
            assert_body_poses(&ds, &what);
        }
    }
    // A PoseStamped names only its parent frame: base_link is assumed only if tf has it.
    let messages = body_bag(
        pose_stamped,
        &[tf_message(
            99.0,
            &[("car", "laser", [1.0; 3], yaw_quaternion(0.0))],
        )],
    );
    let topics = [
        ("/scan", SCAN),
        ("/pose", "geometry_msgs/msg/PoseStamped"),
        ("/tf_static", TF),
    ];
    let path = write(&dir, "no_base_link", STORAGES[1], &topics, &messages);
    let ds = open(&path, "").unwrap();
    let said = offset_unknown_reason(&ds).unwrap();
    assert!(
        said.contains("names no body frame and /tf_static has no base_link; give ?body_frame="),
        "{said}"
    );
    assert_body_poses(&ds, "no base_link");
    let ds = open(&path, "?body_frame=car").unwrap();
    assert_eq!(ds.scanner_offset.map(|o| o.x_m), Some(1.0));
    let e = open(&path, "?tf=maybe").unwrap_err().to_string();
    assert!(
        e.contains("option tf = \"maybe\": expected on or off"),
        "{e}"
    );
}

/// A TFMessage cut short is an error naming the topic, the message and the field; a laser
/// pitched 2° from the body's plane is refused, naming the frames and the tilt.
#[test]
fn truncated_tf_messages_and_tilted_lasers_are_typed_errors() {
    let dir = scratch("tf_errors");
    let [first, mut second] = two_link_tf();
    second.truncate(second.len() - 12);
    let tilted = tf_message(
        99.0,
        &[(
            "base_link",
            "laser",
            [0.5, 0.0, 0.4],
            [
                0.0,
                (1f64.to_radians()).sin(),
                0.0,
                (1f64.to_radians()).cos(),
            ],
        )],
    );
    for storage in STORAGES {
        let topics = [("/scan", SCAN), ("/odom", ODOM), ("/tf_static", TF)];
        let path = write(
            &dir,
            "short",
            storage,
            &topics,
            &body_bag(odometry, &[first.clone(), second.clone()]),
        );
        let e = open(&path, "").unwrap_err();
        assert!(
            matches!(e, DatasetError::BagMessage { index: 1, .. }),
            "{e}"
        );
        assert!(
            e.to_string().contains(
                "message 1 of topic /tf_static: field transforms.transform.rotation.z: needs 8 bytes"
            ),
            "{e}"
        );
        // ?tf=off does not read it.
        assert!(open(&path, "?tf=off").is_ok());
        let path = write(
            &dir,
            "tilted",
            storage,
            &topics,
            &body_bag(odometry, std::slice::from_ref(&tilted)),
        );
        let e = open(&path, "").unwrap_err();
        assert!(matches!(e, DatasetError::BagTf { .. }), "{e}");
        assert!(
            e.to_string().contains(
                "/tf_static: frame \"laser\" is tilted 2.00° from the plane of \"base_link\""
            ),
            "{e}"
        );
    }
}
