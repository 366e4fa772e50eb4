//! The bad-input matrix: every kind of broken input a user can point the harness at, one test
//! each, pinned to the exact error or flag the user sees. Loaders name the file and the
//! line/variable; the core names the scan and the problem; the harness flags and counts a
//! pair it cannot trust and carries on. Nothing panics and nothing turns into silent numbers.

mod common;

use std::fmt::Display;
use std::path::Path;

use datasets::carmen::{self, CarmenOptions};
use datasets::csvdir::{self, DatasetMeta};
use datasets::marina::{self, MarinaOptions};
use datasets::matv5::write_doubles;
use datasets::synthetic::{generate, Scenario};
use eval::pipeline::evaluate;
use eval::run::setup::EvalSetup;
use eval::run::setup::OffsetChoice;
use icp_core::variants::{builtin, hd_icp};
use icp_core::{Registrar, Scan, SensorModel};
use indicatif::ProgressBar;
use nalgebra::{Isometry2, Point2, Vector2};

/// The message of an error, or what went through instead.
fn error_of<T: std::fmt::Debug, E: Display>(r: Result<T, E>) -> String {
    match r {
        Ok(v) => format!("no error: {v:?}"),
        Err(e) => e.to_string(),
    }
}

// ---- The marina MATLAB loader -------------------------------------------------------------

/// A small well-formed file set (4 beams × 3 scans) with `ranges.mat` and the poses given.
fn marina_files(
    ranges: &[u8],
    pose: &[f64; 9],
) -> Result<datasets::Dataset, datasets::DatasetError> {
    let angles: Vec<f64> = (0..12).map(|i| (i % 4) as f64 * 0.5).collect();
    marina::parse(
        [
            (
                Path::new("angles.mat"),
                &write_doubles(&[("angles_baza", 4, 3, &angles)]).unwrap()[..],
            ),
            (Path::new("ranges.mat"), ranges),
            (
                Path::new("gps.mat"),
                &write_doubles(&[("slam_pose", 3, 3, pose)]).unwrap()[..],
            ),
        ],
        &MarinaOptions::default(),
    )
}

/// The small file set with `ranges.mat` replaced.
fn marina_with_ranges(ranges: &[u8]) -> Result<datasets::Dataset, datasets::DatasetError> {
    marina_files(ranges, &[0.0, 1.0, 2.0, 0.0, 0.1, 0.2, 0.0, 0.0, 0.0])
}

fn ranges_mat(values: &[f64; 12]) -> Vec<u8> {
    write_doubles(&[("ranges_baza", 4, 3, values)]).unwrap()
}

const GOOD_RANGES: [f64; 12] = [5.0, 6.0, 7.0, 8.0, 5.1, 6.1, 7.1, 8.1, 5.2, 6.2, 7.2, 8.2];

#[test]
fn marina_empty_file() {
    assert_eq!(
        error_of(marina_with_ranges(b"")),
        "ranges.mat is not a readable MATLAB v5 file: 0 bytes, shorter than the 128-byte MATLAB v5 header"
    );
}

#[test]
fn marina_truncated_file() {
    let bytes = ranges_mat(&GOOD_RANGES);
    assert_eq!(
        error_of(marina_with_ranges(&bytes[..bytes.len() - 20])),
        "ranges.mat is not a readable MATLAB v5 file: truncated: the data element at byte 128 declares 160 bytes, 140 remain"
    );
}

#[test]
fn marina_corrupt_compressed_element() {
    // A compressed element (type 15) whose zlib stream is garbage.
    let mut bytes = ranges_mat(&GOOD_RANGES)[..128].to_vec();
    bytes.extend_from_slice(&15u32.to_le_bytes());
    bytes.extend_from_slice(&16u32.to_le_bytes());
    bytes.extend_from_slice(&[0xA5; 16]);
    assert_eq!(
        error_of(marina_with_ranges(&bytes)),
        "ranges.mat is not a readable MATLAB v5 file: the compressed data element at byte 128 does not inflate: corrupt deflate stream"
    );
}

#[test]
fn marina_wrong_magic() {
    let mut zip = b"PK\x03\x04 this is a zip archive".to_vec();
    zip.resize(300, 0);
    assert_eq!(
        error_of(marina_with_ranges(&zip)),
        "ranges.mat is not a readable MATLAB v5 file: the header does not start with \"MATLAB 5.0 MAT-file\""
    );
}

#[test]
fn marina_wrong_variable_name() {
    let bytes = write_doubles(&[("ranges", 4, 3, &GOOD_RANGES)]).unwrap();
    assert_eq!(
        error_of(marina_with_ranges(&bytes)),
        "ranges.mat has no variable \"ranges_baza\" (found: [\"ranges\"])"
    );
}

#[test]
fn marina_mismatched_shape() {
    let bytes = write_doubles(&[("ranges_baza", 4, 2, &GOOD_RANGES[..8])]).unwrap();
    assert_eq!(
        error_of(marina_with_ranges(&bytes)),
        "\"ranges_baza\" in ranges.mat has shape [4, 2], expected 4 x 3 like angles_baza"
    );
}

#[test]
fn marina_negative_range() {
    let mut r = GOOD_RANGES;
    r[5] = -1.0;
    assert_eq!(
        error_of(marina_with_ranges(&ranges_mat(&r))),
        "ranges.mat: scan 1: negative range at index 1: -1 m"
    );
}

#[test]
fn marina_infinite_range() {
    let mut r = GOOD_RANGES;
    r[2] = f64::INFINITY;
    assert_eq!(
        error_of(marina_with_ranges(&ranges_mat(&r))),
        "ranges.mat: scan 0: non-finite range at index 2: inf"
    );
}

#[test]
fn marina_non_numeric_variable() {
    // The 4 x 3 matrix rewritten as MATLAB int8 (class 8, data type 1): 12 bytes of data.
    let mut bytes = ranges_mat(&GOOD_RANGES);
    bytes[132..136].copy_from_slice(&80u32.to_le_bytes()); // the matrix element's size
    bytes[144] = 8; // array class: int8
    bytes[192..200].copy_from_slice(&[1, 0, 0, 0, 12, 0, 0, 0]); // data: int8 x 12
    bytes.truncate(200);
    bytes.extend([5, 6, 7, 8, 5, 6, 7, 8, 5, 6, 7, 8, 0, 0, 0, 0]);
    assert_eq!(
        error_of(marina_with_ranges(&bytes)),
        "variable \"ranges_baza\" in ranges.mat is not a real double matrix"
    );
}

#[test]
fn marina_nan_pose() {
    let pose = [0.0, 1.0, f64::NAN, 0.0, 0.1, 0.2, 0.0, 0.0, 0.0];
    let r = marina_files(&ranges_mat(&GOOD_RANGES), &pose);
    assert_eq!(
        error_of(r),
        "gps.mat: non-finite reference pose in row 2: (NaN, 0.2, 0)"
    );
}

/// NaN (and 0) is the files' own no-return marker: dropped and counted, not an error.
#[test]
fn marina_nan_range_is_a_counted_no_return() {
    let mut r = GOOD_RANGES;
    r[1] = f64::NAN;
    let ds = marina_with_ranges(&ranges_mat(&r)).unwrap();
    let counts: Vec<(usize, usize)> = ds.scans.iter().map(|s| (s.len(), s.no_returns())).collect();
    assert_eq!(counts, vec![(3, 1), (4, 0), (4, 0)]);
}

// ---- CARMEN and CSV text logs -------------------------------------------------------------

fn carmen_log(text: &str) -> String {
    error_of(carmen::parse(
        Path::new("robot.log"),
        text.as_bytes(),
        &CarmenOptions::default(),
    ))
}

#[test]
fn carmen_empty_file() {
    assert_eq!(
        carmen_log("# a log without laser lines\n"),
        "robot.log: no FLASER line in 1 lines: not a CARMEN laser log"
    );
}

#[test]
fn carmen_non_numeric_field() {
    assert_eq!(
        carmen_log("FLASER 3 1.0 abc 2.0 0 0 0 0 0 0 1.0 host 1.0\n"),
        "robot.log:1: reading 1 is not a number: \"abc\""
    );
}

#[test]
fn carmen_truncated_line() {
    assert_eq!(
        carmen_log("FLASER 5 1.0 2.0 3.0\n"),
        "robot.log:1: 3 fields after the count, 14 expected for 5 readings"
    );
}

#[test]
fn carmen_negative_range() {
    assert_eq!(
        carmen_log("FLASER 3 1.0 -2.0 2.0 0 0 0 0 0 0 1.0 host 1.0\n"),
        "robot.log:1: reading 1 is negative: -2"
    );
}

fn csv_scans(text: &str) -> String {
    error_of(csvdir::parse(
        (Path::new("scans.csv"), text.as_bytes()),
        None,
        None,
        &DatasetMeta::default(),
        "test",
    ))
}

#[test]
fn csv_empty_file() {
    assert_eq!(
        csv_scans(""),
        "scans.csv:1: missing column \"scan\" (expected scan,timestamp_s,range_m,bearing_rad[,true_normal_x,true_normal_y][,moving])"
    );
}

#[test]
fn csv_non_numeric_field() {
    assert_eq!(
        csv_scans("scan,timestamp_s,range_m,bearing_rad\n0,0.0,five,0\n"),
        "scans.csv:2: CSV deserialize error: record 1 (line: 2, byte: 37): field 2: invalid float literal"
    );
}

#[test]
fn csv_infinite_bearing() {
    assert_eq!(
        csv_scans("scan,timestamp_s,range_m,bearing_rad\n0,0.0,5,inf\n"),
        "scans.csv: scan 0: non-finite bearing at index 0: inf"
    );
}

#[test]
fn csv_wrong_header() {
    assert_eq!(
        csv_scans("id,t,r,a\n0,0.0,5,0\n"),
        "scans.csv:1: missing column \"scan\" (expected scan,timestamp_s,range_m,bearing_rad[,true_normal_x,true_normal_y][,moving])"
    );
}

#[test]
fn csv_one_true_normal_column() {
    assert_eq!(
        csv_scans("scan,timestamp_s,range_m,bearing_rad,true_normal_x\n0,0.0,5,0,1\n"),
        "scans.csv:1: column \"true_normal_x\" without \"true_normal_y\" (expected scan,timestamp_s,range_m,bearing_rad[,true_normal_x,true_normal_y][,moving])"
    );
}

#[test]
fn csv_non_finite_true_normal() {
    assert_eq!(
        csv_scans(
            "scan,timestamp_s,range_m,bearing_rad,true_normal_x,true_normal_y\n0,0.0,5,0,0,1\n0,0.0,6,1,inf,1\n"
        ),
        "scans.csv:3: non-finite true_normal_x: inf"
    );
}

#[test]
fn csv_zero_true_normal() {
    assert_eq!(
        csv_scans(
            "scan,timestamp_s,range_m,bearing_rad,true_normal_x,true_normal_y\n0,0.0,5,0,0,-0\n"
        ),
        "scans.csv:2: zero-length true normal: true_normal_x and true_normal_y are both 0"
    );
}

#[test]
fn csv_bad_moving_label() {
    assert_eq!(
        csv_scans("scan,timestamp_s,range_m,bearing_rad,moving\n0,0.0,5,0,0\n0,0.0,6,1,true\n"),
        "scans.csv:3: CSV deserialize error: record 2 (line: 3, byte: 56): moving must be 0 or 1, not \"true\""
    );
}

#[test]
fn csv_empty_moving_label_on_a_return() {
    assert_eq!(
        csv_scans("scan,timestamp_s,range_m,bearing_rad,moving\n0,0.0,,,\n0,0.0,6,1,\n"),
        "scans.csv:3: moving is empty on a return (expected 0 or 1)"
    );
}

#[test]
fn csv_half_a_true_normal() {
    assert_eq!(
        csv_scans(
            "scan,timestamp_s,range_m,bearing_rad,true_normal_x,true_normal_y\n0,0.0,5,0,,0.5\n"
        ),
        "scans.csv:2: true_normal_x is empty but true_normal_y is not"
    );
}

#[test]
fn csv_non_finite_odometry() {
    let r = csvdir::parse(
        (
            Path::new("scans.csv"),
            "scan,timestamp_s,range_m,bearing_rad\n0,0.0,5,0\n1,1.0,5,0\n".as_bytes(),
        ),
        None,
        Some((
            Path::new("odometry.csv"),
            "scan,x_m,y_m,yaw_rad\n0,0,0,0\n1,0.5,0,inf\n".as_bytes(),
        )),
        &DatasetMeta::default(),
        "test",
    );
    assert_eq!(
        error_of(r),
        "odometry.csv:3: non-finite odometry pose for scan 1"
    );
}

// ---- ROS 2 bags and the dataset string ------------------------------------------------------

/// The exit code and first stderr line of `icp-eval ARGS --quiet --no-plots --out DIR`, DIR a
/// fresh scratch directory named `name`.
fn run_cli(name: &str, args: &[&str]) -> (Option<i32>, String) {
    let out = common::scratch_dir(name);
    let o = common::icp_eval_command()
        .args(args)
        .args(["--quiet", "--no-plots", "--out"])
        .arg(out.join("out"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    (
        o.status.code(),
        err.lines().next().unwrap_or_default().to_owned(),
    )
}

/// The exit code and first stderr line of `run --dataset <dataset>`.
fn run_with_dataset(name: &str, dataset: &str) -> (Option<i32>, String) {
    run_cli(name, &["run", "--dataset", dataset])
}

#[test]
fn rosbag_missing_file() {
    assert_eq!(
        run_with_dataset("matrix_rosbag_missing", "rosbag:/nonexistent/run.mcap"),
        (
            Some(2),
            "error: cannot read /nonexistent/run.mcap: No such file or directory (os error 2)"
                .to_owned()
        )
    );
}

#[test]
fn rosbag_unknown_option() {
    assert_eq!(
        run_with_dataset("matrix_rosbag_option", "rosbag:run.mcap?topic=/scan"),
        (
            Some(2),
            "error: dataset rosbag: unknown option \"topic\": expected one of scan, reference, \
             reference_kind, body_frame, tf, scans"
                .to_owned()
        )
    );
}

#[test]
fn rosbag_two_laser_scan_topics_without_scan_option() {
    let dir = common::scratch_dir("matrix_rosbag_two_scans");
    let path = dir.join("two.mcap");
    let mut w = mcap::Writer::new(std::io::BufWriter::new(
        std::fs::File::create(&path).unwrap(),
    ))
    .unwrap();
    for topic in ["/front/scan", "/rear/scan"] {
        let schema = w
            .add_schema("sensor_msgs/msg/LaserScan", "ros2msg", b"")
            .unwrap();
        w.add_channel(schema, topic, "cdr", &Default::default())
            .unwrap();
    }
    w.finish().unwrap();
    drop(w);
    assert_eq!(
        run_with_dataset(
            "matrix_rosbag_two_scans_run",
            &format!("rosbag:{}", path.display())
        ),
        (
            Some(2),
            format!(
                "error: {}: 2 LaserScan topics: /front/scan (sensor_msgs/msg/LaserScan), \
                 /rear/scan (sensor_msgs/msg/LaserScan); choose one with ?scan=/topic",
                path.display()
            )
        )
    );
}

#[test]
fn dataset_option_given_by_string_and_flag_differently() {
    assert_eq!(
        run_cli(
            "matrix_dataset_twice",
            &["run", "--dataset", "synthetic?scans=3", "--scans", "4"]
        ),
        (
            Some(2),
            "error: dataset synthetic: option scans given twice (\"3\" and \"4\")".to_owned()
        )
    );
}

// ---- Options that do not apply to the dataset (issue 33) -----------------------------------

/// A CSV directory of three synthetic scans, with `poses.csv` or without (no reference).
fn csv_dataset(name: &str, with_reference: bool) -> String {
    let dir = common::scratch_dir(name).join("data");
    let mut ds = generate(&Scenario {
        n_scans: 3,
        ..Scenario::paper()
    })
    .unwrap();
    if !with_reference {
        ds.reference = None;
        ds.reference_kind = None;
    }
    csvdir::write(&dir, &ds).unwrap();
    format!("csv:{}", dir.display())
}

#[test]
fn a_flag_of_another_dataset_kind_is_refused() {
    let csv = csv_dataset("matrix_flag_kind_data", true);
    assert_eq!(
        run_cli(
            "matrix_flag_kind",
            &["run", "--dataset", &csv, "--scenario-seed", "7"]
        ),
        (
            Some(2),
            "error: --scenario-seed does not apply to a csv dataset: it sets ?seed= of synthetic \
             datasets only: seed of the scenario (default: its own)"
                .to_owned()
        )
    );
    assert_eq!(
        run_cli(
            "matrix_flag_carmen",
            &["basin", "--dataset", "synthetic", "--carmen-fov-deg", "270"]
        ),
        (
            Some(2),
            "error: --carmen-fov-deg does not apply to a synthetic dataset: it sets ?fov_deg= of \
             carmen datasets only: field of view of the laser, degrees (default 180)"
                .to_owned()
        )
    );
    let (code, line) = run_cli(
        "matrix_flag_dt",
        &["compare", "--dataset", "carmen:aces.log.gz", "--dt", "0.5"],
    );
    assert_eq!(code, Some(2));
    assert!(
        line.starts_with(
            "error: --dt does not apply to a carmen dataset: it sets ?dt_s= of marina, \
             synthetic and csv datasets only"
        ),
        "{line}"
    );
}

#[test]
fn dt_on_scans_that_all_have_timestamps() {
    let csv = csv_dataset("matrix_dt_timestamps_data", true);
    assert_eq!(
        run_cli(
            "matrix_dt_timestamps",
            &["run", "--dataset", &csv, "--dt", "0.5"]
        ),
        (
            Some(2),
            "error: dataset csv: option dt_s (--dt) does not apply: every scan of \
             synthetic:paper has a timestamp, and the time between two scans is the difference \
             of theirs"
                .to_owned()
        )
    );
}

#[test]
fn scans_that_leave_no_pair() {
    for n in ["0", "1"] {
        assert_eq!(
            run_cli(
                "matrix_scans_no_pair",
                &["run", "--dataset", "carmen:aces.log.gz", "--scans", n]
            ),
            (
                Some(2),
                format!(
                    "error: dataset carmen: option scans = \"{n}\": at least 2: a run registers \
                     pairs of consecutive scans"
                )
            )
        );
    }
}

#[test]
fn reference_options_on_a_dataset_without_a_reference() {
    let csv = csv_dataset("matrix_no_reference_data", false);
    for (option, value) in [
        ("--reference-offset", "auto"),
        ("--reference-checks", "off"),
    ] {
        assert_eq!(
            run_cli(
                "matrix_no_reference",
                &["run", "--dataset", &csv, option, value]
            ),
            (
                Some(2),
                format!(
                    "error: {option} does not apply to synthetic:paper: it has no reference to \
                     align in time or check"
                )
            )
        );
    }
}

// ---- The sensor model of a run (`--sensor`) ---------------------------------------------------

/// The first line the harness prints on stderr for `run --sensor <text>`, and its exit code.
fn run_with_sensor(name: &str, text: &str) -> (Option<i32>, String) {
    run_cli(
        name,
        &[
            "run",
            "--dataset",
            "synthetic",
            "--scans",
            "3",
            "--sensor",
            text,
        ],
    )
}

#[test]
fn sensor_with_a_negative_sigma() {
    assert_eq!(
        run_with_sensor("matrix_sensor_negative", "sigma_alpha_deg=-0.5"),
        (
            Some(2),
            "error: --sensor: sigma_alpha_deg = -0.5: must be finite and non-negative".to_owned()
        )
    );
}

#[test]
fn sensor_with_an_unknown_key() {
    assert_eq!(
        run_with_sensor("matrix_sensor_key", "sigma_alpha_rad=0.01"),
        (
            Some(2),
            "error: invalid value 'sigma_alpha_rad=0.01' for '--sensor <SENSOR>': unknown key \
             \"sigma_alpha_rad\": expected one of sigma_r_const_m, sigma_r_per_m, sigma_alpha_deg"
                .to_owned()
        )
    );
}

#[test]
fn sensor_with_garbage() {
    assert_eq!(
        run_with_sensor("matrix_sensor_garbage", "sigma_r_per_m=0.01;x"),
        (
            Some(2),
            "error: invalid value 'sigma_r_per_m=0.01;x' for '--sensor <SENSOR>': sigma_r_per_m = \
             \"0.01;x\" is not a number"
                .to_owned()
        )
    );
    assert_eq!(
        run_with_sensor(
            "matrix_sensor_twice",
            "sigma_r_per_m=0.01,sigma_r_per_m=0.02"
        )
        .1,
        "error: invalid value 'sigma_r_per_m=0.01,sigma_r_per_m=0.02' for '--sensor <SENSOR>': \
         sigma_r_per_m is given twice"
    );
}

// ---- The covariance of a run (`--covariance`) --------------------------------------------------

#[test]
fn covariance_with_an_unknown_mode() {
    assert_eq!(
        run_with_args("matrix_covariance_mode", &["--covariance", "closed_form"]),
        (
            Some(2),
            "error: invalid value 'closed_form' for '--covariance <COVARIANCE>': --covariance \
             \"closed_form\": unknown mode (known: closed-form, sampled, extended, restarts, off)"
                .to_owned()
        )
    );
}

// ---- Registration (the core) --------------------------------------------------------------

fn register(source: &[[f64; 2]], reference: &[[f64; 2]]) -> String {
    let (s, r) = match (
        Scan::from_cartesian(source),
        Scan::from_cartesian(reference),
    ) {
        (Ok(s), Ok(r)) => (s, r),
        (Err(e), _) | (_, Err(e)) => return e.to_string(),
    };
    error_of(hd_icp(SensorModel::sweep()).register(&s, &r, Isometry2::identity()))
}

/// Three walls seen from the origin.
fn harbour() -> Vec<[f64; 2]> {
    (0..150)
        .map(|i| {
            let s = (i / 3) as f64 * 0.3;
            match i % 3 {
                0 => [12.0, -7.0 + s],
                1 => [-4.0 + s, 9.0],
                _ => [-4.0 + 0.5 * s, -8.0 - 0.2 * s],
            }
        })
        .collect()
}

#[test]
fn scan_with_zero_points() {
    assert_eq!(
        register(&[], &harbour()),
        "source scan has 0 usable points, at least 3 are needed"
    );
}

#[test]
fn scan_with_one_point() {
    assert_eq!(
        register(&harbour(), &[[1.0, 2.0]]),
        "reference scan has 1 usable points, at least 3 are needed"
    );
}

#[test]
fn scan_with_two_points() {
    assert_eq!(
        register(&[[1.0, 2.0], [3.0, 1.0]], &harbour()),
        "source scan has 2 usable points, at least 3 are needed"
    );
}

#[test]
fn nan_coordinate() {
    assert_eq!(
        register(&[[1.0, f64::NAN]], &harbour()),
        "non-finite coordinate at index 0: NaN"
    );
}

#[test]
fn all_points_collinear() {
    let corridor: Vec<[f64; 2]> = (0..100).map(|i| [0.2 * i as f64, 3.0]).collect();
    assert_eq!(
        register(&harbour(), &corridor),
        "reference scan is ill-conditioned: all points are collinear"
    );
}

#[test]
fn all_points_identical() {
    assert_eq!(
        register(&[[4.0, 4.0]; 50], &harbour()),
        "source scan is ill-conditioned: all points coincide"
    );
}

/// Zero motion comes out as exactly zero, not as a rounding-sized motion.
#[test]
fn two_identical_scans_give_exactly_the_identity() {
    let scan = Scan::from_cartesian(&harbour()).unwrap();
    for name in icp_core::variants::builtin_names() {
        let reg = builtin(&name)
            .unwrap()
            .build()
            .unwrap()
            .register(&scan, &scan, Isometry2::identity())
            .unwrap();
        assert_eq!(reg.t_ref_src, Isometry2::identity(), "{name}");
        assert_eq!(reg.mean_residual_m, 0.0, "{name}");
        assert!(reg.converged() && !reg.no_overlap(), "{name}");
    }
}

/// Scans a billion metres from the sensor register as they do near it: the same displacement
/// of the scanned points at their centroid (uniform weights; the range-based ones change with
/// the ranges).
#[test]
fn huge_coordinates() {
    let displacement = |offset: f64| {
        let at = |dx: f64| -> Vec<[f64; 2]> {
            harbour()
                .iter()
                .map(|p| [p[0] + offset + dx, p[1] - offset])
                .collect()
        };
        let reg = builtin("H_ICP")
            .unwrap()
            .build()
            .unwrap()
            .register(
                &Scan::from_cartesian(&at(0.0)).unwrap(),
                &Scan::from_cartesian(&at(-0.05)).unwrap(),
                Isometry2::identity(),
            )
            .unwrap();
        let pts = at(0.0);
        let n = pts.len() as f64;
        let c = Point2::new(
            pts.iter().map(|p| p[0]).sum::<f64>() / n,
            pts.iter().map(|p| p[1]).sum::<f64>() / n,
        );
        reg.t_ref_src * c - c
    };
    let (near, far) = (displacement(0.0), displacement(1e9));
    assert!((near - Vector2::new(-0.05, 0.0)).norm() < 0.01, "{near}");
    assert!((far - near).norm() < 1e-4, "{far} vs {near}");
}

/// Two scans of different places: the registration runs, and is flagged, not trusted.
#[test]
fn scan_pair_with_no_overlap() {
    let ring: Vec<[f64; 2]> = (0..200)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 200.0;
            [25.0 * a.cos(), 25.0 * a.sin()]
        })
        .collect();
    let reg = hd_icp(SensorModel::sweep())
        .register(
            &Scan::from_cartesian(&harbour()).unwrap(),
            &Scan::from_cartesian(&ring).unwrap(),
            Isometry2::identity(),
        )
        .unwrap();
    assert!(reg.no_overlap(), "{reg:?}");
}

// ---- External estimates (`--estimates NAME=FILE`) -------------------------------------------

/// `run --estimates ARG` on three synthetic scans: the exit code and first stderr line.
fn run_with_estimates(name: &str, estimates: &str) -> (Option<i32>, String) {
    let args = ["--variants", "HD_ICP", "--estimates", estimates];
    run_with_args(name, &args)
}

/// A per-pair motions file for the three-scan runs.
fn motions_file(name: &str) -> String {
    let path = common::scratch_dir(name).join("m.csv");
    std::fs::write(&path, "source,reference,tx_m,ty_m,theta_deg\n0,1,0.1,0,0\n").unwrap();
    path.display().to_string()
}

#[test]
fn estimates_without_a_name() {
    let (code, line) = run_with_estimates("matrix_estimates_noname", "m.csv");
    assert_eq!(code, Some(2));
    assert!(
        line.contains("--estimates \"m.csv\": expected NAME=FILE"),
        "{line}"
    );
}

#[test]
fn estimates_file_missing() {
    let (code, line) = run_with_estimates("matrix_estimates_absent", "X=/nonexistent/m.tum");
    assert_eq!(code, Some(2));
    assert!(line.contains("/nonexistent/m.tum: No such file"), "{line}");
}

#[test]
fn estimates_named_like_a_variant() {
    let file = motions_file("matrix_estimates_clash_file");
    let (code, line) = run_with_estimates("matrix_estimates_clash", &format!("HD_ICP={file}"));
    assert_eq!(code, Some(2));
    assert!(line.contains("two variants are named HD_ICP"), "{line}");
}

#[test]
fn estimates_with_a_bad_name() {
    let file = motions_file("matrix_estimates_badname_file");
    let (code, line) = run_with_estimates("matrix_estimates_badname", &format!("a/b={file}"));
    assert_eq!(code, Some(2));
    assert!(line.contains("variant name \"a/b\""), "{line}");
}

#[test]
fn estimates_of_another_run() {
    // A TUM pose within the run's time span and near no scan (another clock) names the file
    // and the line; the scans are 0.2 s apart.
    let path = common::scratch_dir("matrix_estimates_other_file").join("other.tum");
    std::fs::write(&path, "0.1 1 2 0 0 0 0 1\n").unwrap();
    let (code, line) =
        run_with_estimates("matrix_estimates_other", &format!("X={}", path.display()));
    assert_eq!(code, Some(2));
    assert!(
        line.contains("other.tum, line 1: the pose at t = 0.1 s is within 0.001 s of no scan"),
        "{line}"
    );
}

// ---- Initial guesses (`--init`, `--start-gate`) -------------------------------------------

/// The exit code and first stderr line of `run <args>` on three synthetic scans.
fn run_with_args(name: &str, args: &[&str]) -> (Option<i32>, String) {
    let mut all = vec!["run", "--dataset", "synthetic", "--scans", "3"];
    all.extend_from_slice(args);
    run_cli(name, &all)
}

#[test]
fn init_odometry_without_an_odometry_channel() {
    assert_eq!(
        run_with_args("matrix_init_odometry", &["--init", "identity,odometry"]),
        (
            Some(2),
            "error: --init odometry cannot be used on synthetic:paper: it has no odometry channel"
                .to_owned()
        )
    );
}

#[test]
fn init_with_an_unknown_mode() {
    let (code, line) = run_with_args("matrix_init_unknown", &["--init", "odometer"]);
    assert_eq!(code, Some(2));
    assert!(
        line.contains("unknown init mode \"odometer\": expected one of identity, constant-velocity, global, odometry, reference"),
        "{line}"
    );
}

#[test]
fn start_gate_that_is_not_a_distance() {
    let (code, line) = run_with_args("matrix_start_gate", &["--start-gate=-0.2"]);
    assert_eq!(code, Some(2));
    assert!(
        line.contains("expected auto, off or a positive distance in metres, got \"-0.2\""),
        "{line}"
    );
}

#[test]
fn init_reference_without_a_rigid_reference() {
    // GNSS-like positions with a separate heading (the marina kind): no rigid pose to start at.
    let mut ds = generate(&Scenario {
        n_scans: 3,
        ..Scenario::paper()
    })
    .unwrap();
    for p in ds.reference.as_mut().unwrap() {
        p.scan_yaw_rad = None;
    }
    let setup = EvalSetup::from_specs(&[builtin("HD_ICP").unwrap()], OffsetChoice::Fixed(0))
        .unwrap()
        .with_init("reference".parse().unwrap());
    assert_eq!(
        error_of(evaluate(&ds, &setup, &ProgressBar::hidden()).map(|r| r.dataset.pairs)),
        "--init reference cannot be used on synthetic:paper: its reference is not a rigid 2D \
         pose of the scanner"
    );
}

// ---- The harness --------------------------------------------------------------------------

/// A run over a synthetic dataset with scan 2 replaced by `scan`.
fn run_with_scan_2(scan: Scan) -> eval::measure::report::RunReport {
    let mut ds = generate(&Scenario {
        n_scans: 5,
        ..Scenario::paper()
    })
    .unwrap();
    ds.scans[2] = scan.with_timestamp(0.4).unwrap();
    let setup =
        EvalSetup::from_specs(&[builtin("HD_ICP").unwrap()], OffsetChoice::Fixed(0)).unwrap();
    evaluate(&ds, &setup, &ProgressBar::hidden()).unwrap()
}

#[test]
fn harness_skips_and_counts_a_pair_with_an_empty_scan() {
    let report = run_with_scan_2(Scan::from_polar(&[0.0, f64::NAN], &[0.0, 0.1]).unwrap());
    let skipped: Vec<String> = report
        .dataset
        .skipped_pairs
        .iter()
        .map(|s| s.reason.clone())
        .collect();
    assert_eq!(skipped, vec!["scan 2 has 0 valid returns (< 3)"; 2]);
    assert_eq!(report.variants[0].pairs_ok, 2);
}

#[test]
fn harness_refuses_a_dataset_without_pairs() {
    let one_scan = csvdir::parse(
        (
            Path::new("scans.csv"),
            "scan,timestamp_s,range_m,bearing_rad\n0,0.0,5,0\n0,0.0,6,1\n0,0.0,7,2\n".as_bytes(),
        ),
        None,
        None,
        &DatasetMeta::default(),
        "one-scan",
    )
    .unwrap();
    let setup =
        EvalSetup::from_specs(&[builtin("HD_ICP").unwrap()], OffsetChoice::Fixed(0)).unwrap();
    assert_eq!(
        error_of(evaluate(&one_scan, &setup, &ProgressBar::hidden()).map(|r| r.dataset.pairs)),
        "one-scan has 1 scan(s): no pair of consecutive scans to register"
    );
}

#[test]
fn harness_flags_and_counts_a_pair_with_no_overlap() {
    let ring: Vec<[f64; 2]> = (0..300)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 300.0;
            [400.0 + 3.0 * a.cos(), 3.0 * a.sin()]
        })
        .collect();
    let report = run_with_scan_2(Scan::from_cartesian(&ring).unwrap());
    let v = &report.variants[0];
    assert_eq!(v.no_overlap_pairs, vec![1, 2]);
    let status: Vec<String> = report
        .pairs
        .iter()
        .map(|r| format!("{:?} {}", r.status, r.status_reason))
        .collect();
    assert_eq!(
        status,
        vec![
            "Ok ",
            "NoOverlap 0 % of the pairs within 0.5 m (< 10 %)",
            "NoOverlap 2 % of the pairs within 0.5 m (< 10 %)",
            "Ok "
        ]
    );
    assert_eq!(v.pairs_ok, 2);
    assert!(
        (v.failure_rate - 0.5).abs() < 1e-12,
        "flagged pairs are failures of the variant"
    );
    assert_eq!(v.all_pairs.pairs, 4, "flagged pairs stay in the statistics");
    let table = eval::render::markdown::table_md(&report);
    assert!(
        table.contains("| HD_ICP | 2 | 0 | 2 | 0 | 0 | 0 | 50.0 % |"),
        "{table}"
    );
}

#[test]
fn unwritable_output_directory() {
    let dir = common::scratch_dir("matrix_unwritable");
    std::fs::write(dir.join("file"), "x").unwrap();
    let out = dir.join("file").join("out");
    let o = common::icp_eval_command()
        .args([
            "run",
            "--dataset",
            "synthetic",
            "--scans",
            "3",
            "--quiet",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        err.trim_end(),
        format!(
            "error: opening the output directory: {}: Not a directory (os error 20)",
            out.display()
        )
    );
}

// ---- Variant configurations -----------------------------------------------------------------

/// The error of building the variant a JSON configuration describes.
fn config_error(json: &str) -> String {
    match serde_json::from_str::<icp_core::variants::VariantSpec>(json) {
        Ok(spec) => error_of(spec.build().map(|_| ())),
        Err(e) => e.to_string(),
    }
}

#[test]
fn config_unknown_stage_kind() {
    assert_eq!(
        config_error(r#"{"name": "X", "metric": "point_to_plane", "weighting": "uniform", "robust": "none"}"#),
        "unknown metric kind \"point_to_plane\": expected one of point_to_point, point_to_line, plane_to_plane"
    );
}

#[test]
fn config_misspelt_parameter() {
    assert!(config_error(
        r#"{"name": "X", "metric": {"kind": "point_to_line", "max_pair_distance": 1}, "weighting": "uniform", "robust": "none"}"#
    )
    .starts_with("metric \"point_to_line\": unknown field `max_pair_distance`, expected"));
}

#[test]
fn config_parameter_out_of_range() {
    assert_eq!(
        config_error(
            r#"{"name": "X", "weighting": {"kind": "normal_directional", "power": -1}, "robust": "none"}"#
        ),
        "weighting \"normal_directional\": power = -1: must be finite and positive"
    );
}

#[test]
fn config_minimiser_that_cannot_minimise_the_metric() {
    assert_eq!(
        config_error(r#"{"name": "X", "metric": "plane_to_plane", "minimizer": "weighted_kabsch", "weighting": "uniform", "robust": "none"}"#),
        "minimizer weighted_kabsch solves the point-to-point cost only; metric plane_to_plane needs gauss_newton"
    );
}

#[test]
fn config_stage_without_a_kind() {
    assert!(
        config_error(r#"{"name": "X", "weighting": {"power": 1}, "robust": "none"}"#)
            .starts_with("a stage needs a \"kind\"")
    );
}

#[test]
fn config_variant_name_with_a_path_separator() {
    assert_eq!(
        config_error(r#"{"name": "PL/ICP", "weighting": "uniform", "robust": "none"}"#),
        "variant name \"PL/ICP\": only letters, digits and _ - + . (it names the run's files)"
    );
}
