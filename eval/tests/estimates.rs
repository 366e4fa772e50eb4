//! External estimates files: read back from our own writers against the truth, a scan
//! missing, and every kind of bad file refused with a typed error naming file and line.

mod common;

use datasets::synthetic::{generate, Scenario};
use datasets::{Dataset, ScanPair};
use eval::estimates::{load, parse_spec, EstimatesError};
use eval::{evaluate, write_outputs, EvalSetup, OffsetChoice, OutputDir};
use icp_core::variants::builtin;
use indicatif::ProgressBar;
use nalgebra::Isometry2;

fn dataset() -> Dataset {
    generate(&Scenario {
        n_scans: 12,
        ..Scenario::paper()
    })
    .unwrap()
}

fn times(ds: &Dataset) -> Vec<f64> {
    (0..ds.scans.len())
        .map(|k| eval::report::scan_time_s(ds, k))
        .collect()
}

fn truth(ds: &Dataset, p: ScanPair) -> Isometry2<f64> {
    eval::reference::motion(ds, p.source, p.reference, ds.pair_dt_s(p))
        .unwrap()
        .t_ref_src
        .unwrap()
}

fn assert_same(a: &Isometry2<f64>, b: &Isometry2<f64>) {
    assert!(
        (a.translation.vector - b.translation.vector).norm() < 1e-12,
        "{a} vs {b}"
    );
    assert!(a.rotation.angle_to(&b.rotation).abs() < 1e-12, "{a} vs {b}");
}

/// Our run's `reference.tum` and `pairs.csv`, written by icp-eval itself.
fn written(ds: &Dataset, name: &str) -> std::path::PathBuf {
    let setup =
        EvalSetup::from_specs(&[builtin("HD_ICP").unwrap()], OffsetChoice::Fixed(0)).unwrap();
    let report = evaluate(ds, &setup, &ProgressBar::hidden()).unwrap();
    let dir = common::scratch_dir(name);
    let mut out = OutputDir::open(&dir, false).unwrap();
    write_outputs(&mut out, ds, &report, false).unwrap();
    dir
}

#[test]
fn a_tum_file_of_the_reference_gives_the_true_motions_and_a_missing_scan_fails_its_pairs() {
    let ds = dataset();
    let dir = written(&ds, "estimates_tum");
    let (pairs, _) = ds.consecutive_pairs();
    let path = dir.join("reference.tum");
    let e = load("REF", &path, &times(&ds), &pairs).unwrap();
    assert_eq!(e.per_pair.len(), pairs.len());
    for (p, m) in pairs.iter().zip(&e.per_pair) {
        assert_same(&m.unwrap(), &truth(&ds, *p));
    }
    assert_eq!(e.source.sha256.len(), 64);
    // Scan 5's line removed: pairs 4→5 and 5→6 have no estimate, every other pair keeps its.
    let text = std::fs::read_to_string(&path).unwrap();
    let cut: String = text
        .lines()
        .enumerate()
        .filter(|(k, _)| *k != 5)
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    let cut_path = dir.join("cut.tum");
    std::fs::write(&cut_path, cut).unwrap();
    let e = load("CUT", &cut_path, &times(&ds), &pairs).unwrap();
    for (p, m) in pairs.iter().zip(&e.per_pair) {
        assert_eq!(m.is_none(), p.source == 5 || p.reference == 5, "{p:?}");
    }
}

#[test]
fn a_pair_csv_gives_its_rows_and_leaves_pairs_without_one_empty() {
    let ds = dataset();
    let dir = written(&ds, "estimates_csv");
    let (pairs, _) = ds.consecutive_pairs();
    let mut csv = String::from("source,reference,tx_m,ty_m,theta_deg\n");
    for p in pairs.iter().filter(|p| p.source != 3) {
        let t = truth(&ds, *p);
        csv += &format!(
            "{},{},{},{},{}\n",
            p.source,
            p.reference,
            t.translation.x,
            t.translation.y,
            t.rotation.angle().to_degrees()
        );
    }
    csv += "100,101,1,2,3\n"; // a pair this run does not have: unused
    let path = dir.join("motions.csv");
    std::fs::write(&path, csv).unwrap();
    let e = load("CSV", &path, &times(&ds), &pairs).unwrap();
    for (p, m) in pairs.iter().zip(&e.per_pair) {
        match m {
            Some(m) => assert_same(m, &truth(&ds, *p)),
            None => assert_eq!(p.source, 3),
        }
    }
}

#[test]
fn bad_files_are_refused_with_the_file_line_and_field() {
    let ds = dataset();
    let dir = common::scratch_dir("estimates_bad");
    let (pairs, _) = ds.consecutive_pairs();
    let t1 = times(&ds)[1];
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "fields.tum",
            "0 1 2 0 0 0 1\n".into(),
            "line 1, line: 7 fields",
        ),
        (
            "nan.tum",
            "0 NaN 2 0 0 0 0 1\n".into(),
            "line 1, x: \"NaN\" is not finite",
        ),
        (
            "word.tum",
            "0 1 two 0 0 0 0 1\n".into(),
            "line 1, y: \"two\" is not a number",
        ),
        (
            "quat.tum",
            "0 1 2 0 0 0 0 2\n".into(),
            "not a unit quaternion",
        ),
        (
            "clock.tum",
            "# c\n1000 1 2 0 0 0 0 1\n".into(),
            "line 2: the pose at t = 1000 s",
        ),
        (
            "twice.tum",
            format!("{t1} 1 2 0 0 0 0 1\n{t1} 1 2 0 0 0 0 1\n"),
            "line 2: a second estimate for scan 1",
        ),
        ("empty.tum", "# nothing\n".into(), "no estimates"),
        (
            "header.csv",
            "source,reference,tx,ty,theta\n".into(),
            "line 1, header",
        ),
        (
            "cells.csv",
            "source,reference,tx_m,ty_m,theta_deg\n0,1,2\n".into(),
            "line 2, line: 3 cells",
        ),
        (
            "index.csv",
            "source,reference,tx_m,ty_m,theta_deg\n0,x,1,2,3\n".into(),
            "line 2, reference",
        ),
        (
            "dup.csv",
            "source,reference,tx_m,ty_m,theta_deg\n0,1,1,2,3\n0,1,1,2,3\n".into(),
            "line 3: a second estimate for pair 0 → 1",
        ),
        (
            "none.csv",
            "source,reference,tx_m,ty_m,theta_deg\n".into(),
            "no estimates",
        ),
    ];
    for (name, text, want) in cases {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let err = load("X", &path, &times(&ds), &pairs).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains(name) && msg.contains(want), "{name}: {msg}");
    }
    let missing = load("X", &dir.join("absent.tum"), &times(&ds), &pairs).unwrap_err();
    assert!(matches!(missing, EstimatesError::Io { .. }), "{missing}");
    assert!(matches!(
        parse_spec("novalue"),
        Err(EstimatesError::Spec(_))
    ));
    assert!(matches!(parse_spec("=f"), Err(EstimatesError::Spec(_))));
    assert_eq!(
        parse_spec("KISS=a=b.tum").unwrap().1,
        std::path::PathBuf::from("a=b.tum")
    );
}
