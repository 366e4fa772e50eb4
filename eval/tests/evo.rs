//! evo interop on a small synthetic run: `reference.tum` beside the trajectories, the ATE in
//! summary.json recomputed from the written files, and the evo result zips read back (their
//! `.npy` arrays parsed here by hand, their JSON by serde) against pairs.csv. The comparison
//! with the real evo is scripts/check-evo.sh (CI).

mod common;

use std::io::Read;

use datasets::synthetic::{generate, Scenario};
use datasets::Dataset;
use eval::measure::report::RunReport;
use eval::measure::trajectory::ReferenceTum;
use eval::measure::trajectory_metrics::ate;
use eval::measure::trajectory_metrics::EvoStats;
use eval::pipeline::evaluate;
use eval::render::outdir::OutputDir;
use eval::render::write_outputs;
use eval::run::setup::EvalSetup;
use eval::run::setup::OffsetChoice;
use icp_core::variants::builtin;
use indicatif::ProgressBar;
use nalgebra::{Isometry2, Vector2};

fn dataset() -> Dataset {
    generate(&Scenario {
        n_scans: 25,
        ..Scenario::paper()
    })
    .unwrap()
}

fn run(ds: &Dataset, name: &str) -> (std::path::PathBuf, RunReport) {
    let setup = EvalSetup::from_specs(
        &[builtin("HD_ICP").unwrap(), builtin("PL_ICP").unwrap()],
        OffsetChoice::Fixed(0),
    )
    .unwrap();
    let report = evaluate(ds, &setup, &ProgressBar::hidden()).unwrap();
    let dir = common::scratch_dir(name);
    let mut out = OutputDir::open(&dir, false).unwrap();
    write_outputs(&mut out, ds, &report, false).unwrap();
    (dir, report)
}

/// `timestamp x y z qx qy qz qw` lines, parsed.
fn read_tum(path: &std::path::Path) -> Vec<(String, Isometry2<f64>)> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(' ').collect();
            assert_eq!(f.len(), 8, "{l}");
            let v: Vec<f64> = f[1..].iter().map(|x| x.parse().unwrap()).collect();
            assert_eq!((v[2], v[3], v[4]), (0.0, 0.0, 0.0), "planar: {l}");
            let yaw = 2.0 * v[5].atan2(v[6]);
            (
                f[0].to_owned(),
                Isometry2::new(Vector2::new(v[0], v[1]), yaw),
            )
        })
        .collect()
}

/// A 1-D '<f8' .npy array, parsed from its bytes (magic, v1.0 header dict, data).
fn parse_npy(bytes: &[u8]) -> Vec<f64> {
    assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    assert_eq!((10 + header_len) % 64, 0, "header padded to 64 bytes");
    let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
    assert!(header.ends_with('\n'));
    assert!(header.contains("'descr': '<f8'") && header.contains("'fortran_order': False"));
    let shape = header.split("'shape': (").nth(1).unwrap();
    let n: usize = shape.split(',').next().unwrap().parse().unwrap();
    let data = &bytes[10 + header_len..];
    assert_eq!(data.len(), 8 * n);
    data.chunks(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

fn zip_entries(path: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut z = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
    (0..z.len())
        .map(|i| {
            let mut f = z.by_index(i).unwrap();
            let mut bytes = Vec::new();
            f.read_to_end(&mut bytes).unwrap();
            (f.name().unwrap().into_owned(), bytes)
        })
        .collect()
}

#[test]
fn reference_tum_and_ate_come_from_the_written_files() {
    let ds = dataset();
    let (dir, report) = run(&ds, "evo_reference_tum");
    assert_eq!(
        report.reference.reference_tum,
        Some(ReferenceTum::RigidPose)
    );
    let reference = read_tum(&dir.join("reference.tum"));
    // The reference poses are the dataset's scanner poses at the scans the chain visits.
    assert_eq!(reference.len(), ds.scans.len());
    for (k, (_, pose)) in reference.iter().enumerate() {
        let truth = ds.reference.as_ref().unwrap()[k].scan_pose().unwrap();
        assert!((pose.translation.vector - truth.translation.vector).norm() < 1e-12);
        assert!((pose.rotation.angle_to(&truth.rotation)).abs() < 1e-12);
    }
    for v in &report.variants {
        let est = read_tum(&dir.join(format!("trajectory_{}.tum", v.name)));
        let stamps =
            |t: &[(String, Isometry2<f64>)]| t.iter().map(|p| p.0.clone()).collect::<Vec<_>>();
        assert_eq!(
            stamps(&est),
            stamps(&reference),
            "same timestamps, to the character"
        );
        let e: Vec<Isometry2<f64>> = est.iter().map(|p| p.1).collect();
        let r: Vec<Isometry2<f64>> = reference.iter().map(|p| p.1).collect();
        let (_, errors) = ate(&e, &r).unwrap();
        let from_files = EvoStats::of(&errors.trans_m).unwrap().rmse;
        let reported = v.trajectory.ate_rmse_m.unwrap();
        // The files hold round-trip decimals: only the quaternion's trigonometry differs.
        assert!(
            (from_files - reported).abs() <= 1e-12 * reported.max(1.0),
            "{from_files} vs {reported}"
        );
        let evo = v.trajectory.evo.as_ref().unwrap();
        assert_eq!(evo.poses, ds.scans.len());
        assert_eq!(evo.ate_trans_m.rmse, reported);
        // Pose 0 starts on the reference, the chain drifts from there: a positive ATE, and
        // (the estimate being the registrations chained) below the last pose's raw drift.
        assert!(reported > 0.0 && reported < 0.5, "{reported}");
        assert!(evo.rpe_trans_m.unwrap().rmse > 0.0);
    }
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    assert!(table.contains("## Trajectory errors against `reference.tum` (evo)"));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["reference"]["reference_tum"], "rigid_pose");
    assert!(
        summary["variants"][0]["trajectory"]["ate_rmse_m"]
            .as_f64()
            .unwrap()
            > 0.0
    );
}

/// A per-pair error column of pairs.csv.
type Column = fn(&eval::measure::record::PairRecord) -> Option<f64>;

#[test]
fn evo_zips_read_back_as_the_pairs_errors_and_are_byte_identical_on_a_rerun() {
    let ds = dataset();
    let (dir, report) = run(&ds, "evo_zips");
    let (again, _) = run(&ds, "evo_zips_again");
    let columns: [(&str, Column); 4] = [
        ("sog", |r| r.sog_err_mps),
        ("dcog", |r| r.dcog_err_deg),
        ("translation", |r| r.trans_err_m),
        ("rotation", |r| r.rot_err_deg),
    ];
    for v in &report.variants {
        for (stem, column) in columns {
            let name = format!("evo/{}_{stem}.zip", v.name);
            let path = dir.join(&name);
            assert_eq!(
                std::fs::read(&path).unwrap(),
                std::fs::read(again.join(&name)).unwrap(),
                "{name} differs between two identical runs"
            );
            let entries = zip_entries(&path);
            let names: Vec<&str> = entries.iter().map(|e| e.0.as_str()).collect();
            assert_eq!(
                names,
                [
                    "info.json",
                    "stats.json",
                    "error_array.npy",
                    "timestamps.npy",
                    "seconds_from_start.npy"
                ]
            );
            let get = |n: &str| &entries.iter().find(|e| e.0 == n).unwrap().1;
            let info: serde_json::Value = serde_json::from_slice(get("info.json")).unwrap();
            assert_eq!(info["est_name"], v.name.as_str());
            for key in ["title", "ref_name", "label"] {
                assert!(info[key].as_str().is_some_and(|s| !s.is_empty()), "{key}");
            }
            let rows: Vec<_> = report
                .pairs
                .iter()
                .filter(|r| r.variant == v.name && r.all_registered)
                .filter(|r| column(r).is_some())
                .collect();
            let errors = parse_npy(get("error_array.npy"));
            let want: Vec<f64> = rows.iter().map(|r| column(r).unwrap()).collect();
            assert_eq!(errors, want, "{name}");
            let stamps = parse_npy(get("timestamps.npy"));
            let want_stamps: Vec<f64> = rows
                .iter()
                .map(|r| ds.scans[r.reference].timestamp_s().unwrap())
                .collect();
            assert_eq!(stamps, want_stamps);
            let from_start = parse_npy(get("seconds_from_start.npy"));
            assert_eq!(from_start[0], 0.0);
            // evo's statistics of the array, by hand: numpy's population std, even-count median.
            let stats: serde_json::Value = serde_json::from_slice(get("stats.json")).unwrap();
            let n = errors.len() as f64;
            let mean = errors.iter().sum::<f64>() / n;
            let sse: f64 = errors.iter().map(|e| e * e).sum();
            let std = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / n).sqrt();
            let mut sorted = errors.clone();
            sorted.sort_by(f64::total_cmp);
            let m = sorted.len();
            let median = if m % 2 == 1 {
                sorted[m / 2]
            } else {
                0.5 * (sorted[m / 2 - 1] + sorted[m / 2])
            };
            for (key, want) in [
                ("rmse", (sse / n).sqrt()),
                ("mean", mean),
                ("median", median),
                ("std", std),
                ("min", sorted[0]),
                ("max", sorted[m - 1]),
                ("sse", sse),
            ] {
                let got = stats[key].as_f64().unwrap();
                assert!(
                    (got - want).abs() <= 1e-12 * want.abs().max(1e-300),
                    "{name} {key}: {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn a_positions_only_reference_gives_identity_orientations_and_no_ate_or_rpe() {
    let mut ds = dataset();
    for p in ds.reference.as_mut().unwrap() {
        p.scan_yaw_rad = None;
    }
    assert!(!ds.rigid_reference());
    let (dir, report) = run(&ds, "evo_positions_only");
    assert_eq!(
        report.reference.reference_tum,
        Some(ReferenceTum::PositionsOnly)
    );
    let text = std::fs::read_to_string(dir.join("reference.tum")).unwrap();
    for (k, line) in text.lines().enumerate() {
        let f: Vec<&str> = line.split(' ').collect();
        assert_eq!(
            &f[3..],
            ["0", "0", "0", "0", "1"],
            "identity orientation: {line}"
        );
        let r = ds.reference.as_ref().unwrap()[k];
        assert_eq!(
            (f[1].parse::<f64>().unwrap(), f[2].parse::<f64>().unwrap()),
            (r.x_m, r.y_m)
        );
    }
    // Positions and heading that are not one rigid frame: nothing aligns to them, so no ATE
    // or RPE (issue 21: marina's read ~21 m), and table.md says why.
    for v in &report.variants {
        assert!(v.trajectory.evo.is_none() && v.trajectory.ate_rmse_m.is_none());
        assert!(v
            .trajectory
            .note
            .as_deref()
            .unwrap()
            .contains("no drift, ATE or RPE"));
    }
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    assert!(table.contains("not one rigid frame"), "table.md says so");
    // No rigid reference: no translation/rotation errors per pair, so no zips for them.
    assert!(!dir.join("evo/HD_ICP_translation.zip").exists());
    assert!(dir.join("evo/HD_ICP_sog.zip").exists());
}

#[test]
fn no_reference_no_reference_tum() {
    let mut ds = dataset();
    ds.reference = None;
    ds.reference_kind = None;
    let (dir, report) = run(&ds, "evo_no_reference");
    assert_eq!(report.reference.reference_tum, None);
    assert!(!dir.join("reference.tum").exists());
    assert!(report
        .variants
        .iter()
        .all(|v| v.trajectory.ate_rmse_m.is_none()));
    assert!(!dir.join("evo").join("HD_ICP_sog.zip").exists());
}
