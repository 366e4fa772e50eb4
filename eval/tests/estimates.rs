//! External estimates files: read back from our own writers against the truth, a scan
//! missing, and every kind of bad file refused with a typed error naming file and line.

mod common;

use datasets::synthetic::{generate, Scenario};
use datasets::{Dataset, ScanPair};
use eval::error::EstimatesError;
use eval::pipeline::evaluate;
use eval::render::outdir::OutputDir;
use eval::render::write_outputs;
use eval::run::estimates::load;
use eval::run::estimates::parse_spec;
use eval::run::estimates::EstimatesSpec;
use eval::run::setup::EvalSetup;
use eval::run::setup::OffsetChoice;
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
        .map(|k| eval::data::scan_time_s(ds, k))
        .collect()
}

fn truth(ds: &Dataset, p: ScanPair) -> Isometry2<f64> {
    eval::data::motion(ds, p.source, p.reference, ds.pair_dt_s(p))
        .unwrap()
        .t_ref_src
        .unwrap()
}

/// One line of a per-pair CSV: `t_ref_src` of `p`.
fn csv_row(p: ScanPair, t: &Isometry2<f64>) -> String {
    format!(
        "{},{},{},{},{}\n",
        p.source,
        p.reference,
        t.translation.x,
        t.translation.y,
        t.rotation.angle().to_degrees()
    )
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

/// A trajectory of the whole log read for a run on its first scans: the poses beyond the
/// run are left unused and counted, every pair of the run has its estimate.
#[test]
fn tum_poses_outside_the_run_are_counted_and_left_unused() {
    let ds = dataset();
    let dir = written(&ds, "estimates_outside");
    let short = generate(&Scenario {
        n_scans: 8,
        ..Scenario::paper()
    })
    .unwrap();
    let (pairs, _) = short.consecutive_pairs();
    let e = load("REF", &dir.join("reference.tum"), &times(&short), &pairs).unwrap();
    assert_eq!(e.source.unused, ds.scans.len() - short.scans.len());
    assert_eq!(e.source.pairs_estimated, pairs.len());
    for (p, m) in pairs.iter().zip(&e.per_pair) {
        assert_same(&m.unwrap(), &truth(&short, *p));
    }
}

/// Roll and pitch are dropped (the run is planar), and a pose tilted beyond 1° is counted with
/// the largest tilt: a 3D estimator gone wrong shows in the report.
#[test]
fn tilted_tum_poses_are_counted() {
    let ds = dataset();
    let (pairs, _) = ds.consecutive_pairs();
    let t = times(&ds);
    // Scan 0 level and turned 30°, scan 1 pitched 10° (about y), scan 2 rolled 0.5°.
    let (s30, c30) = 15f64.to_radians().sin_cos();
    let (s10, c10) = 5f64.to_radians().sin_cos();
    let (s05, c05) = 0.25f64.to_radians().sin_cos();
    let text = format!(
        "{} 0 0 0 0 0 {s30} {c30}\n{} 1 0 0 0 {s10} 0 {c10}\n{} 2 0 0 {s05} 0 0 {c05}\n",
        t[0], t[1], t[2]
    );
    let path = common::scratch_dir("estimates_tilt").join("tilt.tum");
    std::fs::write(&path, text).unwrap();
    let e = load("T", &path, &t, &pairs).unwrap();
    assert_eq!(e.source.tilted_poses, 1);
    assert!(
        (e.source.max_tilt_deg - 10.0).abs() < 1e-9,
        "{}",
        e.source.max_tilt_deg
    );
    // The yaws: 30°, 0 (a pitch has none), 0.
    let m01 = e.per_pair[0].unwrap();
    assert!(
        (m01.rotation.angle().to_degrees() - 30.0).abs() < 1e-9,
        "{m01}"
    );
    assert_eq!(e.source.pairs_estimated, 2);
}

#[test]
fn a_pair_csv_gives_its_rows_and_leaves_pairs_without_one_empty() {
    let ds = dataset();
    let dir = written(&ds, "estimates_csv");
    let (pairs, _) = ds.consecutive_pairs();
    let mut csv = String::from("source,reference,tx_m,ty_m,theta_deg\n");
    for p in pairs.iter().filter(|p| p.source != 3) {
        csv += &csv_row(*p, &truth(&ds, *p));
    }
    csv += "2,4,1,2,3\n"; // a pair this run does not register: unused
    let path = dir.join("motions.csv");
    std::fs::write(&path, csv).unwrap();
    let e = load("CSV", &path, &times(&ds), &pairs).unwrap();
    assert_eq!(e.source.unused, 1, "the row of pair 2 → 4");
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
            "line 1, fields: 7 fields",
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
            format!("# c\n{} 1 2 0 0 0 0 1\n", t1 + 0.05),
            "line 2: the pose at t = ",
        ),
        (
            "outside.tum",
            "1000 1 2 0 0 0 0 1\n".into(),
            "no estimates for the pairs of this run",
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
            "line 2, fields: 3 cells",
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
            "one-based.csv",
            "source,reference,tx_m,ty_m,theta_deg\n11,12,1,2,3\n".into(),
            "line 2, reference: scan 12, but the dataset has 12 scans (0 to 11): is the file 1-based",
        ),
        (
            "other-header.csv",
            "k,k1,dx,dy,dtheta\n0,1,1,2,3\n".into(),
            "line 1, header: \"k,k1,dx,dy,dtheta\", expected",
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

/// A per-pair CSV of `rows`' motions (pairs.csv columns), leaving out the pairs `skip`.
fn motions_csv(rows: &[&eval::measure::record::PairRecord], skip: &[usize]) -> String {
    let mut csv = String::from("source,reference,tx_m,ty_m,theta_deg\n");
    for r in rows.iter().filter(|r| !skip.contains(&r.pair)) {
        csv += &format!(
            "{},{},{},{},{}\n",
            r.source,
            r.reference,
            r.tx_m.unwrap(),
            r.ty_m.unwrap(),
            r.theta_deg.unwrap()
        );
    }
    csv
}

fn spec(name: &str, path: &std::path::Path) -> EstimatesSpec {
    format!("{name}={}", path.display()).parse().unwrap()
}

fn with_estimates(setup: EvalSetup, ds: &Dataset, specs: &[EstimatesSpec]) -> EvalSetup {
    let (pairs, _) = ds.consecutive_pairs();
    setup.with_estimates(specs.iter().map(|s| s.load(ds, &pairs).unwrap()).collect())
}

/// An external estimator that repeats HD_PL_ICP's motions gets HD_PL_ICP's errors pair by
/// pair; the pair its file lacks is its failure, counted in its failure rate and left out of
/// every variant's statistics (equal populations); it has no iterations, timing or
/// covariance, and the file's hash is in the configuration.
#[test]
fn an_external_copy_of_a_variant_gets_its_errors_and_a_missing_pair_is_its_failure() {
    let ds = dataset();
    let setup = || {
        EvalSetup::from_specs(&[builtin("HD_PL_ICP").unwrap()], OffsetChoice::Fixed(0))
            .unwrap()
            .with_covariance(eval::run::covariance::CovarianceMode::ClosedForm)
            .with_global(Default::default(), eval::run::setup::GlobalChecks::On)
            .with_reference_checks(eval::run::setup::ReferenceChecks::Off)
    };
    let alone = evaluate(&ds, &setup(), &ProgressBar::hidden()).unwrap();
    let rows: Vec<&eval::measure::record::PairRecord> = alone.pairs.iter().collect();
    let dir = common::scratch_dir("estimates_copy");
    let path = dir.join("copy.csv");
    std::fs::write(&path, motions_csv(&rows, &[3])).unwrap();
    let both = with_estimates(setup(), &ds, &[spec("COPY", &path)]);
    let r = evaluate(&ds, &both, &ProgressBar::hidden()).unwrap();
    let names: Vec<&str> = r.variants.iter().map(|v| v.name.as_str()).collect();
    assert_eq!(names, ["HD_PL_ICP", "COPY"]);
    let copy = &r.variants[1];
    assert_eq!(copy.failures.len(), 1);
    assert_eq!(copy.failures[0].pair, 3);
    assert!(
        copy.failures[0].reason.contains("no estimate")
            && copy.failures[0].reason.contains("3 → 4"),
        "{}",
        copy.failures[0].reason
    );
    let n = alone.pairs.len();
    assert_eq!(copy.failure_rate, 1.0 / n as f64);
    assert_eq!(r.population.left_out, vec![3]);
    assert_eq!(copy.all_pairs.pairs, n - 1);
    assert_eq!(r.variants[0].all_pairs.pairs, n - 1);
    // Pair by pair, the same errors (to the rounding of theta through degrees).
    let ext: Vec<_> = r.pairs.iter().filter(|p| p.variant == "COPY").collect();
    for (a, b) in rows.iter().zip(&ext) {
        if a.pair == 3 {
            assert!(b.tx_m.is_none() && b.status == eval::run::status::StatusKind::Failed);
            continue;
        }
        let close = |x: Option<f64>, y: Option<f64>| (x.unwrap() - y.unwrap()).abs() < 1e-9;
        assert!(close(a.trans_err_m, b.trans_err_m), "pair {}", a.pair);
        assert!(close(a.rot_err_deg, b.rot_err_deg), "pair {}", a.pair);
        assert!(close(a.sog_err_mps, b.sog_err_mps), "pair {}", a.pair);
        assert!(close(a.dcog_err_deg, b.dcog_err_deg), "pair {}", a.pair);
        // Good poses on the harbour: assessed and checked, nothing flagged.
        assert_eq!(
            b.status,
            eval::run::status::StatusKind::Ok,
            "pair {}",
            a.pair
        );
        assert!(b.global_result_score.is_some() && b.overlap.unwrap() > 0.5);
        assert!(b.init.is_none() && b.iterations.is_none() && b.converged.is_none());
        assert!(b.time_us.is_none() && b.cov_status.is_empty() && b.nees.is_none());
        assert_eq!(b.init_attempts, 0);
    }
    assert!(copy.iterations_mean.is_none() && copy.converged_fraction.is_none());
    assert!(copy.timing.is_none() && copy.consistency.is_none());
    assert!(r.variants[0].timing.is_some() && r.variants[0].consistency.is_some());
    let source = &r.config.estimates[0];
    assert_eq!(
        (source.name.as_str(), source.pairs_estimated),
        ("COPY", n - 1)
    );
    assert_eq!(source.sha256, spec("COPY", &path).sha256);
    assert_eq!(
        source.format,
        eval::run::estimates::EstimatesFormat::PairCsv
    );
    // HD_PL_ICP's own rows are those of the run without the external.
    let mine: Vec<_> = r
        .pairs
        .iter()
        .filter(|p| p.variant == "HD_PL_ICP")
        .collect();
    for (a, b) in rows.iter().zip(&mine) {
        assert_eq!((a.tx_m, a.ty_m, a.theta_deg), (b.tx_m, b.ty_m, b.theta_deg));
    }
}

/// An external estimate is flagged by the same rules as a registration: a pose 60 m off
/// overlaps nothing, a pose 2.5 m and 25° off is suspect (a global search finds a far
/// better pose), the true poses are not flagged; the flags count as the estimator's failures and the
/// wrong numbers stay in its statistics.
#[test]
fn external_estimates_are_flagged_like_registrations() {
    let ds = dataset();
    let (pairs, _) = ds.consecutive_pairs();
    let mut csv = String::from("source,reference,tx_m,ty_m,theta_deg\n");
    for p in &pairs {
        let mut t = truth(&ds, *p);
        match p.source {
            2 => t = Isometry2::new(nalgebra::Vector2::new(60.0, 0.0), 0.0) * t,
            5 => t = Isometry2::new(nalgebra::Vector2::new(2.0, -1.5), 25f64.to_radians()) * t,
            _ => {}
        }
        csv += &csv_row(*p, &t);
    }
    let dir = common::scratch_dir("estimates_flags");
    let path = dir.join("bad.csv");
    std::fs::write(&path, csv).unwrap();
    let setup = EvalSetup::from_specs(&[builtin("HD_ICP").unwrap()], OffsetChoice::Fixed(0))
        .unwrap()
        .with_global(Default::default(), eval::run::setup::GlobalChecks::On);
    let r = evaluate(
        &ds,
        &with_estimates(setup, &ds, &[spec("BAD", &path)]),
        &ProgressBar::hidden(),
    )
    .unwrap();
    let bad = &r.variants[1];
    assert_eq!(bad.no_overlap_pairs, vec![2], "{bad:?}");
    assert_eq!(bad.suspect_pairs, vec![5], "{bad:?}");
    assert_eq!(bad.pairs_ok, pairs.len() - 2);
    assert_eq!(bad.failure_rate, 2.0 / pairs.len() as f64);
    // Flagged, not dropped: the 60 m error is in the statistics.
    assert!(bad.all_pairs.trans_err_m.as_ref().unwrap().p95_abs > 10.0);
    assert_eq!(
        bad.success_rate,
        Some((pairs.len() - 2) as f64 / pairs.len() as f64)
    );
}

/// The file is hashed when the option is read; reading another file under the same name
/// later (a shard, a merge) is refused.
#[test]
fn a_file_changed_after_the_option_was_read_is_refused() {
    let ds = dataset();
    let (pairs, _) = ds.consecutive_pairs();
    let dir = common::scratch_dir("estimates_changed");
    let path = dir.join("m.csv");
    std::fs::write(&path, "source,reference,tx_m,ty_m,theta_deg\n0,1,1,0,0\n").unwrap();
    let s = spec("M", &path);
    assert!(s.load(&ds, &pairs).is_ok());
    std::fs::write(&path, "source,reference,tx_m,ty_m,theta_deg\n0,1,2,0,0\n").unwrap();
    let err = s.load(&ds, &pairs).unwrap_err();
    assert!(
        matches!(err, EstimatesError::Changed { .. }) && err.to_string().contains("m.csv"),
        "{err}"
    );
}
