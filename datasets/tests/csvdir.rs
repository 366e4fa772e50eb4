//! Our CSV format: a synthetic dataset written and read back is the same bit for bit, and
//! broken files are typed errors naming the file and line.

use std::path::{Path, PathBuf};

use datasets::csvdir::{self, DatasetMeta};
use datasets::synthetic::{generate, Scenario};
use datasets::{DatasetError, LoadWarning, Pose2, ReferenceKind};
use icp_core::Scan;
use nalgebra::Vector2;

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn written_and_read_back_bit_for_bit() {
    // The rough harbour's first boat lies still for its first 13.3 s (66 scans): its returns
    // are labelled moving from then on.
    for (scenario, n_scans) in [(Scenario::paper(), 8), (Scenario::rough(), 70)] {
        round_trip(Scenario {
            n_scans,
            ..scenario
        });
    }
}

/// `scenario`'s dataset written and read back: the same bit for bit, true normals and moving
/// labels included.
fn round_trip(scenario: Scenario) {
    let ds = generate(&scenario).unwrap();
    let dir = tmp(&format!("csv_roundtrip_{}", scenario.name));
    csvdir::write(&dir, &ds).unwrap();
    let back = csvdir::load(&dir).unwrap();
    assert_eq!(back.scans, ds.scans);
    assert_eq!(back.reference, ds.reference);
    assert_eq!(back.dt_s, ds.dt_s);
    assert_eq!(back.sweep_s, ds.sweep_s);
    assert_eq!(back.sensor, ds.sensor);
    assert_eq!(
        (back.bearing_sense, back.reference_heading_sense),
        (ds.bearing_sense, ds.reference_heading_sense)
    );
    assert_eq!(back.provenance.name, ds.provenance.name);
    assert_eq!(back.provenance.description, ds.provenance.description);
    assert_eq!(back.provenance.files.len(), 3);
    assert_eq!(back.reference_kind, Some(ReferenceKind::GroundTruth));
    assert_eq!(back.scanner_offset, Some(Pose2::IDENTITY));
    assert_eq!((&back.odometry, &back.warnings), (&None, &vec![]));
    assert!(
        ds.scans.iter().all(|s| s.no_returns() > 0),
        "the round trip covers no-returns"
    );
    // The true normals come back bit for bit, unknown ones (spurious returns) included.
    let text = std::fs::read_to_string(dir.join("scans.csv")).unwrap();
    assert!(text
        .starts_with("scan,timestamp_s,range_m,bearing_rad,true_normal_x,true_normal_y,moving\n"));
    let bits = |ds: &datasets::Dataset| -> Vec<Option<[u64; 2]>> {
        ds.scans
            .iter()
            .flat_map(|s| s.true_normals().unwrap())
            .map(|n| n.map(|n| [n.x.to_bits(), n.y.to_bits()]))
            .collect()
    };
    let written = bits(&ds);
    assert_eq!(bits(&back), written);
    assert_eq!(
        written.len(),
        ds.scans.iter().map(|s| s.len()).sum::<usize>()
    );
    assert!(
        written.contains(&None),
        "the round trip covers unknown normals"
    );
    // Every scan is labelled; only the rough harbour's boats move.
    let moving = |ds: &datasets::Dataset| -> Vec<bool> {
        ds.scans
            .iter()
            .flat_map(|s| s.moving().unwrap().iter().copied())
            .collect()
    };
    assert_eq!(moving(&back), moving(&ds));
    let n_moving = moving(&ds).iter().filter(|&&m| m).count();
    assert_eq!(n_moving > 0, scenario.rough.is_some(), "{n_moving}");
}

fn parse(scans: &str, poses: Option<&str>) -> Result<datasets::Dataset, DatasetError> {
    parse_with(scans, poses, None, &DatasetMeta::default())
}

fn parse_with(
    scans: &str,
    poses: Option<&str>,
    odometry: Option<&str>,
    meta: &DatasetMeta,
) -> Result<datasets::Dataset, DatasetError> {
    csvdir::parse(
        (Path::new("scans.csv"), scans.as_bytes()),
        poses.map(|p| (Path::new("poses.csv"), p.as_bytes())),
        odometry.map(|p| (Path::new("odometry.csv"), p.as_bytes())),
        meta,
        "test",
    )
}

const GOOD: &str = "scan,timestamp_s,range_m,bearing_rad\n0,0.0,5,0\n0,0.0,6,1\n0,0.0,,\n1,0.5,5.1,0\n1,0.5,6.1,1\n1,0.5,7,2\n";

#[test]
fn minimal_files_parse_with_defaults() {
    let ds = parse(
        GOOD,
        Some("scan,x_m,y_m,heading_rad,scan_yaw_rad\n0,0,0,0,\n1,0.5,0,0.1,0.1\n"),
    )
    .unwrap();
    assert_eq!(ds.scans.len(), 2);
    assert_eq!((ds.scans[0].len(), ds.scans[0].no_returns()), (2, 1));
    assert_eq!(ds.scans[1].timestamp_s(), Some(0.5));
    assert_eq!(ds.dt_s, 0.5);
    let r = ds.reference.unwrap();
    assert_eq!((r[0].scan_yaw_rad, r[1].scan_yaw_rad), (None, Some(0.1)));
    assert_eq!(ds.provenance.name, "test");
}

/// A file without the true-normal columns reads as before, and is written again without them.
#[test]
fn files_without_true_normals_read_and_write_as_before() {
    let ds = parse(GOOD, None).unwrap();
    let expected = [
        Scan::from_polar(&[5.0, 6.0, f64::NAN], &[0.0, 1.0, f64::NAN]),
        Scan::from_polar(&[5.1, 6.1, 7.0], &[0.0, 1.0, 2.0]),
    ];
    for ((scan, expected), t) in ds.scans.iter().zip(expected).zip([0.0, 0.5]) {
        assert_eq!(*scan, expected.unwrap().with_timestamp(t).unwrap());
        assert_eq!(scan.true_normals(), None);
    }
    let dir = tmp("csv_without_normals");
    csvdir::write(&dir, &ds).unwrap();
    let text = std::fs::read_to_string(dir.join("scans.csv")).unwrap();
    assert_eq!(
        text,
        "scan,timestamp_s,range_m,bearing_rad\n0,0,5,0\n0,0,6,1\n0,0,,\n1,0.5,5.1,0\n1,0.5,6.1,1\n1,0.5,7,2\n"
    );
}

/// The true-normal columns, in any order: empty cells are unknown normals, the given ones are
/// scaled to unit length and follow the returns (a no-return row's normal is dropped with it).
#[test]
fn true_normals_are_read_beside_the_returns() {
    let ds = parse(
        "scan,true_normal_y,timestamp_s,range_m,bearing_rad,true_normal_x\n\
         0,0,0,5,0,-2\n0,,0,6,1,\n0,1,0,,,0\n0,4,0,7,2,3\n1,,1,5,0,\n1,,1,6,1,\n1,,1,7,2,\n",
        None,
    )
    .unwrap();
    let v = |x: f64, y: f64| Some(Vector2::new(x, y));
    assert_eq!((ds.scans[0].len(), ds.scans[0].no_returns()), (3, 1));
    assert_eq!(
        ds.scans[0].true_normals(),
        Some(&[v(-1.0, 0.0), None, v(0.6, 0.8)][..])
    );
    assert_eq!(
        ds.scans[1].true_normals(),
        None,
        "no normal known in scan 1"
    );
}

/// The `moving` column, anywhere in the header: 0 and 1 on the returns, empty (or either) on
/// the no-returns, whose labels are dropped with them; all 0 is a labelled scan, unlike a file
/// without the column.
#[test]
fn moving_labels_are_read_beside_the_returns() {
    let ds = parse(
        "moving,scan,timestamp_s,range_m,bearing_rad\n\
         0,0,0,5,0\n1,0,0,6,1\n,0,0,,\n1,0,0,0,2\n0,1,1,5,0\n0,1,1,6,1\n",
        None,
    )
    .unwrap();
    assert_eq!((ds.scans[0].len(), ds.scans[0].no_returns()), (2, 2));
    assert_eq!(ds.scans[0].moving(), Some(&[false, true][..]));
    assert_eq!(ds.scans[1].moving(), Some(&[false, false][..]));
    assert_eq!(parse(GOOD, None).unwrap().scans[0].moving(), None);
    // Written back as read.
    let dir = tmp("csv_moving");
    csvdir::write(&dir, &ds).unwrap();
    assert_eq!(
        std::fs::read_to_string(dir.join("scans.csv")).unwrap(),
        "scan,timestamp_s,range_m,bearing_rad,moving\n0,0,5,0,0\n0,0,6,1,1\n0,0,,,\n0,0,,,\n\
         1,1,5,0,0\n1,1,6,1,0\n"
    );
    assert_eq!(csvdir::load(&dir).unwrap().scans, ds.scans);
}

/// A bad `moving` cell is a parse error naming the file, the line and the field.
#[test]
fn bad_moving_labels_name_the_file_line_and_field() {
    const HEADER: &str = "scan,timestamp_s,range_m,bearing_rad,moving\n";
    for (rows, expected) in [
        ("0,0,5,0,0\n0,0,6,1,2\n", "moving must be 0 or 1, not \"2\""),
        ("0,0,5,0,yes\n", "moving must be 0 or 1, not \"yes\""),
        ("0,0,5,0,-1\n", "moving must be 0 or 1, not \"-1\""),
        (
            "0,0,5,0,\n",
            "moving is empty on a return (expected 0 or 1)",
        ),
        ("0,0,,,\n0,0,5,0,\n", "moving is empty on a return"),
    ] {
        let e = parse(&format!("{HEADER}{rows}"), None).unwrap_err();
        let DatasetError::Parse { path, line, what } = &e else {
            panic!("{e:?}");
        };
        assert_eq!(path, Path::new("scans.csv"));
        assert_eq!(*line, rows.lines().count() + 1, "{e}");
        assert!(what.contains(expected), "{e} (expected {expected:?})");
    }
    let e = parse(
        "scan,timestamp_s,range_m,bearing_rad,moving,moving\n0,0,5,0,1,1\n",
        None,
    )
    .unwrap_err();
    assert!(matches!(e, DatasetError::Parse { line: 2, .. }), "{e}");
}

#[test]
fn broken_files_are_errors_naming_the_file_and_line() {
    const NORMALS: &str = "scan,timestamp_s,range_m,bearing_rad,true_normal_x,true_normal_y\n";
    let bad_normals = [
        (
            "scan,timestamp_s,range_m,bearing_rad,true_normal_y\n0,0,5,0,1\n".to_owned(),
            "scans.csv:1: column \"true_normal_y\" without \"true_normal_x\"",
        ),
        (
            format!("{NORMALS}0,0,5,0,1,0\n0,0,6,1,NaN,0\n"),
            "scans.csv:3: non-finite true_normal_x: NaN",
        ),
        (
            format!("{NORMALS}0,0,5,0,0,-inf\n"),
            "scans.csv:2: non-finite true_normal_y: -inf",
        ),
        (
            format!("{NORMALS}0,0,5,0,0,0\n"),
            "scans.csv:2: zero-length true normal: true_normal_x and true_normal_y are both 0",
        ),
        (
            format!("{NORMALS}0,0,5,0,1,\n"),
            "scans.csv:2: true_normal_y is empty but true_normal_x is not",
        ),
        (
            format!("{NORMALS}0,0,,,,1\n"),
            "scans.csv:2: true_normal_x is empty but true_normal_y is not",
        ),
    ];
    for (scans, expected) in bad_normals {
        let e = parse(&scans, None).unwrap_err();
        assert!(matches!(e, DatasetError::Parse { .. }), "{e:?}");
        assert!(
            e.to_string().starts_with(expected),
            "{e} (expected {expected:?})"
        );
    }
    let cases: [(&str, Option<&str>, &str); 8] = [
        (
            "scan,timestamp_s,range_m\n0,0,5\n",
            None,
            "missing column \"bearing_rad\"",
        ),
        (
            "scan,timestamp_s,range_m,bearing_rad\n0,0,five,0\n",
            None,
            "scans.csv:2",
        ),
        (
            "scan,timestamp_s,range_m,bearing_rad\n0,0,5,0\n2,0,5,0\n",
            None,
            "scan 2 follows scan 0",
        ),
        (
            "scan,timestamp_s,range_m,bearing_rad\n1,0,5,0\n",
            None,
            "first scan id must be 0",
        ),
        (
            "scan,timestamp_s,range_m,bearing_rad\n0,0,5,0\n0,1,5,0\n",
            None,
            "two timestamps",
        ),
        (
            "scan,timestamp_s,range_m,bearing_rad\n0,0,-5,0\n",
            None,
            "negative range",
        ),
        (
            GOOD,
            Some("scan,x_m,y_m,heading_rad,scan_yaw_rad\n0,0,0,0,\n"),
            "poses.csv has 1 pose rows but scans.csv has 2 scans: one pose row per scan",
        ),
        (
            GOOD,
            Some("scan,x_m,y_m,heading_rad,scan_yaw_rad\n0,0,0,0,\n1,inf,0,0,\n"),
            "non-finite pose",
        ),
    ];
    for (scans, poses, expected) in cases {
        let e = parse(scans, poses).unwrap_err();
        assert!(
            e.to_string().contains(expected),
            "{e} (expected {expected:?})"
        );
    }
    let dir = tmp("csv_bad_meta");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("scans.csv"), GOOD).unwrap();
    std::fs::write(dir.join("dataset.json"), "{\"dt_s\": 0.1, \"colour\": 3}").unwrap();
    let e = csvdir::load(&dir).unwrap_err();
    assert!(
        matches!(e, DatasetError::Parse { .. }) && e.to_string().contains("colour"),
        "{e}"
    );
    std::fs::write(dir.join("dataset.json"), "{\"dt_s\": -1}").unwrap();
    assert!(matches!(
        csvdir::load(&dir),
        Err(DatasetError::InvalidParameter { name: "dt_s", .. })
    ));
    assert!(matches!(
        csvdir::load(&tmp("csv_missing")),
        Err(DatasetError::Io { .. })
    ));
}

/// A synthetic run of `n` scans with an odometry channel of its own: the reference scaled,
/// drifting sideways and in yaw (independent: no `odometry_equals_reference`).
fn with_odometry(n: usize) -> datasets::Dataset {
    let mut ds = generate(&Scenario {
        n_scans: n,
        ..Scenario::paper()
    })
    .unwrap();
    ds.odometry = Some(
        ds.reference
            .as_ref()
            .unwrap()
            .iter()
            .enumerate()
            .map(|(k, p)| Pose2 {
                x_m: p.x_m * 1.02 + 0.1,
                y_m: p.y_m - 0.003 * k as f64,
                yaw_rad: p.scan_yaw_rad.unwrap() + 0.001 * k as f64,
            })
            .collect(),
    );
    ds
}

/// `odometry.csv` is optional: written when the dataset has odometry and read back bit for
/// bit, with the reference kind and scanner offset of `dataset.json`.
#[test]
fn odometry_and_reference_metadata_round_trip() {
    let mut ds = with_odometry(5);
    ds.reference_kind = Some(ReferenceKind::SlamCorrected);
    ds.scanner_offset = Some(Pose2 {
        x_m: 0.25,
        y_m: -0.1,
        yaw_rad: 0.01,
    });
    let dir = tmp("csv_odometry");
    csvdir::write(&dir, &ds).unwrap();
    let text = std::fs::read_to_string(dir.join("odometry.csv")).unwrap();
    assert!(text.starts_with("scan,x_m,y_m,yaw_rad\n0,"), "{text}");
    let back = csvdir::load(&dir).unwrap();
    assert_eq!(back.odometry, ds.odometry);
    assert_eq!(back.reference_kind, ds.reference_kind);
    assert_eq!(back.scanner_offset, ds.scanner_offset);
    assert_eq!(back.provenance.files.len(), 4);
    assert_eq!(back.warnings, vec![], "independent odometry, small steps");
}

/// Without `reference_kind` (files written before it existed) the poses are of unknown kind;
/// without poses there is no kind, and naming one is refused.
#[test]
fn reference_kind_defaults_and_refusals() {
    let poses = "scan,x_m,y_m,heading_rad,scan_yaw_rad\n0,0,0,0,0\n1,0.5,0,0.1,0.1\n";
    assert_eq!(
        parse(GOOD, Some(poses)).unwrap().reference_kind,
        Some(ReferenceKind::Unknown)
    );
    assert_eq!(parse(GOOD, None).unwrap().reference_kind, None);
    let odometry_kind = DatasetMeta {
        reference_kind: Some(ReferenceKind::Odometry),
        ..DatasetMeta::default()
    };
    assert_eq!(
        parse_with(GOOD, Some(poses), None, &odometry_kind)
            .unwrap()
            .reference_kind,
        Some(ReferenceKind::Odometry)
    );
    assert_eq!(
        parse_with(GOOD, None, None, &odometry_kind)
            .unwrap_err()
            .to_string(),
        "dataset.json: reference_kind is \"odometry\" but there is no poses.csv"
    );
    for (sweep_s, ok) in [(0.2, true), (0.0, true), (-0.1, false), (f64::NAN, false)] {
        let meta = DatasetMeta {
            sweep_s: Some(sweep_s),
            ..DatasetMeta::default()
        };
        match parse_with(GOOD, None, None, &meta) {
            Ok(ds) => assert!(ok && ds.sweep_s == Some(sweep_s), "{sweep_s}"),
            Err(e) => assert!(
                !ok && e.to_string().starts_with("dataset.json: sweep_s"),
                "{sweep_s}: {e}"
            ),
        }
    }
    assert_eq!(parse(GOOD, None).unwrap().sweep_s, None);
    let nan_offset = DatasetMeta {
        scanner_offset: Some(Pose2 {
            x_m: f64::NAN,
            ..Pose2::IDENTITY
        }),
        ..DatasetMeta::default()
    };
    assert!(parse_with(GOOD, None, None, &nan_offset)
        .unwrap_err()
        .to_string()
        .starts_with("dataset.json: non-finite scanner_offset"));
    // A dataset.json of the old layout reads; the new fields parse by name.
    let dir = tmp("csv_meta_fields");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("scans.csv"), GOOD).unwrap();
    std::fs::write(dir.join("poses.csv"), poses).unwrap();
    std::fs::write(
        dir.join("dataset.json"),
        "{\"name\": \"old\", \"dt_s\": 0.5}",
    )
    .unwrap();
    let old = csvdir::load(&dir).unwrap();
    assert_eq!(
        (old.reference_kind, old.scanner_offset),
        (Some(ReferenceKind::Unknown), None)
    );
    std::fs::write(
        dir.join("dataset.json"),
        "{\"reference_kind\": \"gnss_positions\", \"scanner_offset\": {\"x_m\": 1, \"y_m\": 0, \"yaw_rad\": 0}}",
    )
    .unwrap();
    let new = csvdir::load(&dir).unwrap();
    assert_eq!(new.reference_kind, Some(ReferenceKind::GnssPositions));
    assert_eq!(new.scanner_offset.map(|o| o.x_m), Some(1.0));
}

#[test]
fn broken_odometry_files_name_the_file_line_and_problem() {
    let odometry = |text: &str| {
        parse_with(GOOD, None, Some(text), &DatasetMeta::default())
            .unwrap_err()
            .to_string()
    };
    assert_eq!(
        odometry("scan,x_m,y_m,yaw_rad\n0,0,0,0\n"),
        "odometry.csv has 1 odometry pose rows but scans.csv has 2 scans: one odometry pose \
         row per scan"
    );
    assert_eq!(
        odometry("scan,x_m,y_m,yaw_rad\n0,0,0,0\n1,0,nan,0\n"),
        "odometry.csv:3: non-finite odometry pose for scan 1"
    );
    assert_eq!(
        odometry("scan,x_m,y_m,yaw_rad\n1,0,0,0\n"),
        "odometry.csv:2: odometry pose rows must run 0, 1, 2, …: expected scan 0, found 1"
    );
    assert_eq!(
        odometry("scan,x_m,y_m,heading_rad\n0,0,0,0\n"),
        "odometry.csv:1: missing column \"yaw_rad\" (expected scan,x_m,y_m,yaw_rad)"
    );
}

/// Scans without timestamps and no `dt_s`: 1 s is assumed; no sensor model: the Sweep's is
/// assumed; the dataset says both. Given in dataset.json, neither is said.
#[test]
fn an_assumed_spacing_and_sensor_model_are_warnings() {
    let untimed =
        "scan,timestamp_s,range_m,bearing_rad\n0,,5,0\n0,,6,1\n0,,7,2\n1,,5,0\n1,,6,1\n1,,7,2\n";
    let ds = parse(untimed, None).unwrap();
    assert_eq!(ds.dt_s, 1.0);
    // The hint names dt_s for the scans it acts on: stamped scans refuse it (they keep their
    // own time steps).
    assert_eq!(
        ds.warnings[0].to_string(),
        "no usable timestamps and no dt_s given: 1 s between scans assumed (the speeds and turn \
         rates of scans without a timestamp scale with it: give dt_s or --dt; stamped scans \
         keep their own time steps)"
    );
    assert_eq!(
        ds.warnings,
        vec![
            LoadWarning::AssumedScanSpacing { dt_s: 1.0 },
            LoadWarning::AssumedSensorModel {
                sensor: icp_core::SensorModel::sweep(),
                of: "the Scanse Sweep (the paper's scanner)".to_owned()
            }
        ]
    );
    let given = DatasetMeta {
        dt_s: Some(0.25),
        sensor: Some(icp_core::SensorModel::sweep()),
        ..DatasetMeta::default()
    };
    let ds = parse_with(untimed, None, None, &given).unwrap();
    assert_eq!((ds.dt_s, ds.warnings), (0.25, vec![]));
}

/// A synthetic run of `n` scans with independent odometry, written as a CSV directory named `name`.
fn written_with_odometry(name: &str, n: usize) -> (datasets::Dataset, PathBuf) {
    let ds = with_odometry(n);
    let dir = tmp(name);
    csvdir::write(&dir, &ds).unwrap();
    (ds, dir)
}

/// `scans.csv` with its last `rows` rows dropped (a file cut at a line boundary).
fn cut_scans_file(dir: &Path, rows: usize) {
    let path = dir.join("scans.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    std::fs::write(&path, lines[..lines.len() - rows].join("\n") + "\n").unwrap();
}

/// Issue 33: a `scans.csv` cut at a line boundary inside its last scan loaded without a word.
/// It warns now, naming the scan and its readings against its neighbour's; cut before the
/// last scan, the poses no longer match the scans and the error says so in plain words.
#[test]
fn a_cut_scans_file_is_named() {
    let (ds, dir) = written_with_odometry("csv_cut", 6);
    let readings: Vec<usize> = ds.scans.iter().map(|s| s.len() + s.no_returns()).collect();
    assert!(readings.iter().all(|&r| r == readings[0]), "{readings:?}");
    let full = readings[0];
    cut_scans_file(&dir, 300);
    let back = csvdir::load(&dir).unwrap();
    assert_eq!(back.scans.len(), 6);
    let warning = LoadWarning::ShortScan {
        scan: 5,
        readings: full - 300,
        neighbour_readings: vec![full],
        usual_readings: full,
        scans: 1,
    };
    assert_eq!(back.warnings, vec![warning.clone()]);
    assert_eq!(
        warning.to_string(),
        format!(
            "scan 5 has {} readings where its neighbour has {full} (scan 4) and more than half \
             the scans {full}: was the file cut inside it?",
            full - 300
        )
    );
    // Two scans and a half gone: 4 scans left, against 6 pose rows.
    cut_scans_file(&dir, 2 * full);
    assert_eq!(
        csvdir::load(&dir).unwrap_err().to_string(),
        format!(
            "{} has 6 pose rows but {} has 4 scans: one pose row per scan",
            dir.join("poses.csv").display(),
            dir.join("scans.csv").display()
        )
    );
}

/// A short scan inside the run names both neighbours and counts the others.
#[test]
fn short_scans_inside_a_run_name_both_neighbours() {
    let row = |k: usize, n: usize| -> String {
        (0..n)
            .map(|i| format!("{k},{k},{},{}\n", 5.0 + i as f64, 0.1 * i as f64))
            .collect()
    };
    let counts = [4, 4, 3, 4, 2, 4];
    let text = "scan,timestamp_s,range_m,bearing_rad\n".to_owned()
        + &counts
            .iter()
            .enumerate()
            .map(|(k, &n)| row(k, n))
            .collect::<String>();
    let ds = parse(&text, None).unwrap();
    let short = ds
        .warnings
        .iter()
        .find(|w| matches!(w, LoadWarning::ShortScan { .. }))
        .unwrap();
    assert_eq!(
        short.to_string(),
        "scan 2 has 3 readings where its neighbours have 4 (scan 1) and 4 (scan 3) and more \
         than half the scans 4: was the file cut inside it? (1 more scan(s) have fewer than 4)"
    );
    // No count shared by more than half the scans (readings vary, as where no-returns are not
    // written): nothing to tell a cut from.
    let varied = "scan,timestamp_s,range_m,bearing_rad\n".to_owned()
        + &[4, 5, 3, 6]
            .iter()
            .enumerate()
            .map(|(k, &n)| row(k, n))
            .collect::<String>();
    let ds = parse(&varied, None).unwrap();
    assert!(
        !ds.warnings
            .iter()
            .any(|w| matches!(w, LoadWarning::ShortScan { .. })),
        "{:?}",
        ds.warnings
    );
}

/// `?scans=N` keeps the first N scans of a file dataset, their poses, odometry and
/// timestamps with them, and records how many of how many; more than there are keeps all.
#[test]
fn the_scans_option_keeps_the_first_scans_and_says_so() {
    let (ds, dir) = written_with_odometry("csv_first", 6);
    let first = datasets::open(&format!("csv:{}?scans=3", dir.display())).unwrap();
    assert_eq!(first.scans, ds.scans[..3]);
    assert_eq!(
        first.reference.as_deref(),
        Some(&ds.reference.as_ref().unwrap()[..3])
    );
    assert_eq!(
        first.odometry.as_deref(),
        Some(&ds.odometry.as_ref().unwrap()[..3])
    );
    assert_eq!(
        first.first_scans,
        Some(datasets::FirstScans {
            requested: 3,
            available: 6
        })
    );
    assert_eq!(first.consecutive_pairs().0.len(), 2);
    let all = datasets::open(&format!("csv:{}?scans=100", dir.display())).unwrap();
    assert_eq!(all.scans, ds.scans);
    assert_eq!(
        all.first_scans,
        Some(datasets::FirstScans {
            requested: 100,
            available: 6
        })
    );
    // The checks are made again on the scans kept: a cut scan after them is not theirs.
    cut_scans_file(&dir, 300);
    let cut = datasets::open(&format!("csv:{}", dir.display())).unwrap();
    assert!(matches!(cut.warnings[..], [LoadWarning::ShortScan { .. }]));
    let kept = datasets::open(&format!("csv:{}?scans=5", dir.display())).unwrap();
    assert_eq!(kept.warnings, vec![]);
}

/// `dt_s` changes nothing where every scan has a timestamp (a pair's time step is theirs):
/// refused, saying so; applied to scans without timestamps.
#[test]
fn dt_s_is_refused_where_every_scan_has_a_timestamp() {
    let (_, dir) = written_with_odometry("csv_dt", 3);
    assert_eq!(
        datasets::open(&format!("csv:{}?dt_s=0.5", dir.display()))
            .unwrap_err()
            .to_string(),
        "dataset csv: option dt_s (--dt) does not apply: every scan of synthetic:paper has a \
         timestamp, and the time between two scans is the difference of theirs"
    );
    let untimed = tmp("csv_untimed");
    std::fs::create_dir_all(&untimed).unwrap();
    std::fs::write(
        untimed.join("scans.csv"),
        "scan,timestamp_s,range_m,bearing_rad\n0,,5,0\n0,,6,1\n0,,7,2\n1,,5,0\n1,,6,1\n1,,7,2\n",
    )
    .unwrap();
    let ds = datasets::open(&format!("csv:{}?dt_s=0.5", untimed.display())).unwrap();
    assert_eq!(ds.dt_s, 0.5);
}
