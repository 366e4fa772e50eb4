//! The CARMEN loader on a small log written here in the format, and on broken ones.

use std::io::Write;
use std::path::Path;

use datasets::carmen::{self, CarmenOptions};
use datasets::DatasetError;

/// A square room 10 m wide seen by a 181-beam, 180° laser at pose (x, y, θ).
fn flaser(x: f64, y: f64, theta: f64, t: f64) -> String {
    let n = 181;
    let mut ranges = Vec::new();
    for k in 0..n {
        let a = theta + (-90.0 + k as f64).to_radians();
        let (c, s) = (a.cos(), a.sin());
        // Distance to the walls x = ±5, y = ±5 along (c, s).
        let mut r = f64::INFINITY;
        for (d, wall) in [(c, 5.0 - x), (c, -5.0 - x), (s, 5.0 - y), (s, -5.0 - y)] {
            if d.abs() > 1e-12 && wall / d > 0.0 {
                r = r.min(wall / d);
            }
        }
        ranges.push(format!("{r:.3}"));
    }
    format!(
        "FLASER {n} {} {x} {y} {theta} {x} {y} {theta} {t} localhost {t}",
        ranges.join(" ")
    )
}

fn small_log() -> String {
    [
        "# a comment".to_owned(),
        "PARAM robot_front_laser_max 50".to_owned(),
        flaser(0.0, 0.0, 0.0, 100.0),
        "ODOM 0 0 0 0 0 0 100.05 localhost 100.05".to_owned(),
        flaser(0.3, 0.1, 0.05, 100.2),
        flaser(0.6, 0.15, 0.1, 100.4),
    ]
    .join("\n")
}

#[test]
fn a_small_log_parses_with_its_layout_and_reference() {
    let (ds, counts) = carmen::parse(
        Path::new("room.log"),
        small_log().as_bytes(),
        &CarmenOptions::default(),
    )
    .unwrap();
    assert_eq!(counts.scans, 3);
    assert_eq!(counts.skipped_lines, 3);
    assert_eq!(ds.scans.len(), 3);
    assert_eq!(ds.scans[0].len(), 181);
    let first = ds.scans[0].returns()[0];
    assert!(
        (first.bearing_rad + std::f64::consts::FRAC_PI_2).abs() < 1e-12,
        "first beam at -90°"
    );
    assert!((first.range_m - 5.0).abs() < 1e-9);
    let r = ds.reference.as_ref().unwrap();
    assert_eq!(
        (r[1].x_m, r[1].y_m, r[1].scan_yaw_rad),
        (0.3, 0.1, Some(0.05))
    );
    assert!((ds.dt_s - 0.2).abs() < 1e-9);
    assert_eq!(ds.scans[2].timestamp_s(), Some(100.4));
    // HD_ICP recovers the logged motion from the room's walls (ranges rounded to 1 mm).
    let hd = icp_core::variants::hd_icp(icp_core::SensorModel::sweep());
    let reg = icp_core::Registrar::register(
        &hd,
        &ds.scans[0],
        &ds.scans[1],
        nalgebra::Isometry2::identity(),
    )
    .unwrap();
    let truth = (r[0].scan_pose().unwrap().inverse() * r[1].scan_pose().unwrap()).inverse();
    assert!((reg.t_ref_src.translation.vector - truth.translation.vector).norm() < 0.01);
}

#[test]
fn max_range_readings_are_no_returns() {
    let log = flaser(0.0, 0.0, 0.0, 1.0);
    let opts = CarmenOptions {
        max_range_m: 6.0,
        ..CarmenOptions::default()
    };
    let (ds, _) = carmen::parse(Path::new("a.log"), log.as_bytes(), &opts).unwrap();
    // Beams towards the corners see the walls beyond 6 m.
    assert!(ds.scans[0].no_returns() > 0);
    assert_eq!(ds.scans[0].len() + ds.scans[0].no_returns(), 181);
}

#[test]
fn gzipped_log_loads_like_the_plain_one() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("carmen_gz");
    std::fs::create_dir_all(&dir).unwrap();
    let plain = dir.join("room.log");
    std::fs::write(&plain, small_log()).unwrap();
    let gz = dir.join("room.log.gz");
    let mut enc = flate2::write::GzEncoder::new(
        std::fs::File::create(&gz).unwrap(),
        flate2::Compression::default(),
    );
    enc.write_all(small_log().as_bytes()).unwrap();
    enc.finish().unwrap();
    let a = carmen::load(&plain, &CarmenOptions::default()).unwrap();
    let b = carmen::load(&gz, &CarmenOptions::default()).unwrap();
    assert_eq!(a.scans, b.scans);
    assert_eq!(a.provenance.files[0].sha256.len(), 64);
    assert!(matches!(
        carmen::load(&dir.join("missing.log"), &CarmenOptions::default()),
        Err(DatasetError::Io { .. })
    ));
}

fn parse_err(log: &str) -> DatasetError {
    carmen::parse(
        Path::new("bad.log"),
        log.as_bytes(),
        &CarmenOptions::default(),
    )
    .unwrap_err()
}

#[test]
fn broken_lines_name_the_file_line_and_field() {
    let good = flaser(0.0, 0.0, 0.0, 1.0);
    let cases = [
        (
            good.replacen("FLASER 181 5.000", "FLASER 181 five", 1),
            "reading 0 is not a number",
        ),
        (
            good.replacen("FLASER 181", "FLASER 18x", 1),
            "the reading count is not a number",
        ),
        (
            good.replacen("FLASER 181", "FLASER 2.5", 1),
            "is not a count",
        ),
        (
            good.replacen("FLASER 181 5.000", "FLASER 181 -5.000", 1),
            "reading 0 is negative",
        ),
        (
            good.replacen("FLASER 181 5.000", "FLASER 181 inf", 1),
            "reading 0 is not finite",
        ),
        (
            good.rsplitn(4, ' ').last().unwrap().to_owned(),
            "fields after the count",
        ),
        (
            good.replacen("0 0 0 0 0 0 1 localhost", "0 0 nan 0 0 0 1 localhost", 1),
            "theta is not finite",
        ),
    ];
    for (log, expected) in cases {
        let e = parse_err(&format!("# header\n{log}"));
        let msg = e.to_string();
        assert!(matches!(e, DatasetError::Parse { line: 2, .. }), "{msg}");
        assert!(
            msg.starts_with("bad.log:2: ") && msg.contains(expected),
            "{msg} (expected {expected:?})"
        );
    }
    assert!(matches!(
        carmen::parse(
            Path::new("x"),
            &b""[..],
            &CarmenOptions {
                fov_deg: 0.0,
                ..Default::default()
            }
        ),
        Err(DatasetError::InvalidParameter {
            name: "fov_deg",
            ..
        })
    ));
    assert!(matches!(
        carmen::parse(Path::new("e.log"), &b""[..], &CarmenOptions::default()),
        Err(DatasetError::BadValue { .. })
    ));
    let invalid_utf8 = carmen::parse(
        Path::new("u.log"),
        &b"# ok\nFLASER 1 \xff\n"[..],
        &CarmenOptions::default(),
    );
    assert!(matches!(
        invalid_utf8,
        Err(DatasetError::Parse { line: 2, .. })
    ));
}
