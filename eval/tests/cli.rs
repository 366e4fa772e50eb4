//! Runs the `icp-eval` binary on a small synthetic dataset and checks what it writes.

mod common;
use common::icp_eval;

use std::path::Path;

use eval::measure::record::PairRecord;
use eval::measure::report::RunReport;

fn run_small(out: &Path, threads: &str, plots: bool) {
    let mut args = vec![
        "run",
        "--dataset",
        "synthetic:marina-like",
        "--scans",
        "24",
        "--quiet",
        "--threads",
        threads,
        "--out",
    ];
    args.push(out.to_str().unwrap());
    if !plots {
        args.push("--no-plots");
    }
    let o = icp_eval(&args);
    assert!(
        o.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn read_pairs(dir: &Path) -> Vec<PairRecord> {
    csv::Reader::from_path(dir.join("pairs.csv"))
        .unwrap()
        .deserialize()
        .collect::<Result<_, _>>()
        .unwrap()
}

#[test]
fn every_output_exists_parses_and_agrees_with_the_csv() {
    let dir = common::scratch_dir("cli_outputs");
    run_small(&dir, "2", true);
    let summary: RunReport =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(
        summary.schema_version,
        eval::measure::report::SCHEMA_VERSION
    );
    assert_eq!(summary.dataset.pairs, 23);
    let rows = read_pairs(&dir);
    assert_eq!(rows.len(), 4 * 23);
    for v in &summary.variants {
        let mine: Vec<&PairRecord> = rows.iter().filter(|r| r.variant == v.name).collect();
        assert_eq!(mine.len(), 23);
        // The summary's figures are the CSV columns' statistics, recomputed here by hand.
        let sog: Vec<f64> = mine.iter().filter_map(|r| r.sog_err_mps).collect();
        let mean = sog.iter().sum::<f64>() / sog.len() as f64;
        let s = v.all_pairs.sog_err_mps.unwrap();
        assert_eq!(s.n, sog.len());
        assert!(
            (s.mean - mean).abs() < 1e-12,
            "{} {} vs {}",
            v.name,
            s.mean,
            mean
        );
        let rms = (sog.iter().map(|e| e * e).sum::<f64>() / sog.len() as f64).sqrt();
        assert!((s.rmse - rms).abs() < 1e-12);
        let dcog_max = mine
            .iter()
            .filter_map(|r| r.dcog_err_deg)
            .fold(0.0f64, |m, e| if e.abs() > m.abs() { e } else { m });
        assert_eq!(v.all_pairs.dcog_err_deg.unwrap().max_signed, dcog_max);
        let trans: Vec<f64> = mine.iter().filter_map(|r| r.trans_err_m).collect();
        assert_eq!(trans.len(), 23, "the synthetic reference is a rigid pose");
        let it_max = mine.iter().map(|r| r.iterations).max().unwrap();
        assert_eq!(v.iterations_max, it_max);
        // SOG error is estimate minus reference, row by row.
        for r in &mine {
            assert!(
                (r.sog_est_mps.unwrap() - r.sog_ref_mps.unwrap() - r.sog_err_mps.unwrap()).abs()
                    < 1e-12
            );
        }
        let tum = std::fs::read_to_string(dir.join(format!("trajectory_{}.tum", v.name))).unwrap();
        let lines: Vec<&str> = tum.lines().collect();
        assert_eq!(lines.len(), 24);
        assert!(lines
            .iter()
            .all(|l| l.split(' ').count() == 8 && l.split(' ').all(|f| f.parse::<f64>().is_ok())));
    }
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    assert!(table.contains("| HD_ICP |") && table.contains("SOG median"));
    let config: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("config.json")).unwrap()).unwrap();
    let names: Vec<&str> = config["variants"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["K_ICP", "H_ICP", "HM_ICP", "HD_ICP"]);
    assert_eq!(config["variants"][3]["matcher"]["kind"], "grid");
    assert_eq!(config["variants"][3]["weighting"]["kind"], "directional");
    for stem in [
        "sog_error",
        "dcog_error",
        "sog_error_hist",
        "dcog_error_hist",
        "trajectory",
        "map",
    ] {
        let png = std::fs::read(dir.join(format!("{stem}.png"))).unwrap();
        assert!(png.starts_with(b"\x89PNG\r\n\x1a\n"), "{stem}.png");
        let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg"))).unwrap();
        assert!(
            svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"),
            "{stem}.svg"
        );
    }
    assert!(
        !dir.join("summary.json.tmp").exists(),
        "no temporary file is left behind"
    );
}

/// Drops the timing fields, the only ones allowed to differ between runs.
fn without_timing(dir: &Path) -> (String, serde_json::Value) {
    let csv = std::fs::read_to_string(dir.join("pairs.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    assert!(header.ends_with(",time_us"), "timing is the last column");
    let csv: String = csv
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_owned() + "\n")
        .collect();
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    for v in json["variants"].as_array_mut().unwrap() {
        v.as_object_mut().unwrap().remove("timing");
    }
    if let Some(search) = json["global_search"].as_object_mut() {
        assert!(search.remove("timing").is_some());
    }
    let preparation = json.as_object_mut().unwrap().remove("preparation");
    assert!(preparation.is_some_and(|p| p["median_us"].as_f64().unwrap() > 0.0));
    (csv, json)
}

#[test]
fn one_two_and_eight_threads_give_identical_results() {
    let (a, b) = (common::scratch_dir("det_1"), common::scratch_dir("det_2"));
    run_small(&a, "1", false);
    run_small(&b, "2", false);
    let (csv_a, json_a) = without_timing(&a);
    let (csv_b, json_b) = without_timing(&b);
    assert_eq!(csv_a, csv_b);
    assert_eq!(json_a, json_b);
    assert_eq!(
        std::fs::read(a.join("table.md")).unwrap(),
        std::fs::read(b.join("table.md")).unwrap()
    );
}

#[test]
fn bad_arguments_exit_2_with_a_message() {
    let dir = common::scratch_dir("cli_bad");
    let out = dir.to_str().unwrap();
    // An unwritable output directory: eval/tests/bad_input_matrix.rs.
    let o = icp_eval(&["run", "--dataset", "nowhere", "--out", out]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown dataset"));
    let o = icp_eval(&[
        "run",
        "--dataset",
        "marina",
        "--data-dir",
        "/nonexistent",
        "--out",
        out,
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("/nonexistent/marina") && err.contains("fetch-marina.sh"),
        "{err}"
    );
    let o = icp_eval(&[
        "run",
        "--dataset",
        "synthetic",
        "--sensor",
        "sigma_alpha_deg=-1",
        "--out",
        out,
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--sensor: sigma_alpha_deg = -1"));
    let o = icp_eval(&[
        "run",
        "--dataset",
        "synthetic",
        "--variants",
        "X_ICP",
        "--out",
        out,
    ]);
    assert_eq!(o.status.code(), Some(2), "an unknown variant is refused");
}

#[test]
fn reproduce_without_data_runs_the_synthetic_scenario_and_says_how_to_get_the_data() {
    let dir = common::scratch_dir("reproduce_no_data");
    let o = common::icp_eval_command()
        .args(["reproduce", "--quiet", "--no-plots", "--out", "out"])
        .current_dir(&dir)
        .env_remove(datasets::marina::DATA_DIR_ENV)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let (stdout, stderr) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(
        stderr.contains("skipping the marina data") && stderr.contains("fetch-marina.sh"),
        "{stderr}"
    );
    assert!(
        stdout.contains("# synthetic:paper") && stdout.contains("| HD_ICP |"),
        "{stdout}"
    );
    assert!(dir.join("out/synthetic-paper/summary.json").is_file());
    assert!(!dir.join("out/marina").exists());
}

/// `icp-eval synth` with `args` into `data`, which must succeed, read back.
fn synth_and_load(data: &Path, args: &[&str]) -> datasets::Dataset {
    let mut all = vec!["synth", "--out", data.to_str().unwrap()];
    all.extend(args);
    let o = icp_eval(&all);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["scans.csv", "poses.csv", "dataset.json"] {
        assert!(data.join(f).is_file(), "{f}");
    }
    datasets::csvdir::load(data).unwrap()
}

/// `icp-eval run` of HD_ICP on the dataset `spec` into `out`, which must succeed.
fn run_hd_icp(spec: &str, out: &Path) {
    let o = icp_eval(&[
        "run",
        "--dataset",
        spec,
        "--variants",
        "HD_ICP",
        "--quiet",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn synth_writes_a_dataset_that_run_reads_back() {
    let dir = common::scratch_dir("synth_then_run");
    let data = dir.join("data");
    let back = synth_and_load(&data, &["--scenario", "marina-like", "--scans", "12"]);
    let fresh = datasets::synthetic::generate(&datasets::synthetic::Scenario {
        n_scans: 12,
        ..datasets::synthetic::Scenario::marina_like()
    })
    .unwrap();
    assert_eq!(back.scans, fresh.scans, "bit for bit");
    let out = dir.join("out");
    run_hd_icp(&format!("csv:{}", data.display()), &out);
    assert_eq!(read_pairs(&out).len(), 11);
}

/// `synth --scenario rough --boats FILE` writes the moving labels and a description naming the
/// boats and their file; `run` on `synthetic:rough?boats=FILE` lists the file in summary.json;
/// `--boats` is refused for a scenario without boats.
#[test]
fn synth_rough_with_a_boats_file_labels_the_returns_and_names_the_boats() {
    let dir = common::scratch_dir("synth_boats");
    // A boat sailing from the start (the built-in ones lie still for the first 13 s).
    let boats = dir.join("boats.json");
    std::fs::write(
        &boats,
        r#"[{"length_m": 6.0, "beam_m": 2.4, "lane_m": -4.0, "start_s": 0.5, "rate": 1.5}]"#,
    )
    .unwrap();
    let boats = boats.to_str().unwrap();
    let back = synth_and_load(
        &dir.join("data"),
        &["--scenario", "rough", "--scans", "5", "--boats", boats],
    );
    let rough = datasets::synthetic::Scenario {
        n_scans: 5,
        ..datasets::synthetic::Scenario::rough()
    };
    let fresh = datasets::synthetic::generate_with_boats(&rough, Some(boats)).unwrap();
    assert_eq!(
        back.scans, fresh.scans,
        "bit for bit, moving labels included"
    );
    assert!(back
        .scans
        .iter()
        .any(|s| s.moving().unwrap().contains(&true)));
    assert_eq!(back.provenance.description, fresh.provenance.description);
    assert!(
        back.provenance
            .description
            .contains("1 moving boat (6 × 2.4 m in lane -4 m")
            && back.provenance.description.contains(&format!(
                "boats from {boats} (sha256 {})",
                fresh.provenance.files[0].sha256
            )),
        "{}",
        back.provenance.description
    );
    let out = dir.join("out");
    run_hd_icp(&format!("synthetic:rough?scans=3&boats={boats}"), &out);
    let summary: RunReport =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary.dataset.files, fresh.provenance.files);
    let o = icp_eval(&[
        "synth",
        "--scenario",
        "paper",
        "--boats",
        "none",
        "--out",
        dir.join("paper").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("the \"paper\" scenario has no moving boats to replace"),
        "{stderr}"
    );
}

#[test]
fn compare_writes_paired_statistics_and_a_sweep() {
    let dir = common::scratch_dir("compare");
    let cfg = dir.join("tukey.toml");
    std::fs::write(
        &cfg,
        "[[variants]]\nname = \"TD_ICP\"\nweighting = { kind = \"directional\" }\nrobust = { kind = \"median_scaled\", kernel = \"tukey\", c = 4.685 }\n",
    )
    .unwrap();
    let out = dir.join("out");
    let o = icp_eval(&[
        "compare",
        "--dataset",
        "synthetic:marina-like",
        "--scans",
        "30",
        "--variants",
        "H_ICP,HD_ICP",
        "--config",
        cfg.to_str().unwrap(),
        "--bootstrap",
        "500",
        "--sweep",
        "huber_c=1.5,3",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("compare.json")).unwrap()).unwrap();
    // 3 variants: 3 pairs of variants x 2 errors.
    let rows = json["comparisons"].as_array().unwrap();
    assert_eq!(rows.len(), 6);
    assert_eq!(
        (rows[0]["a"].as_str(), rows[0]["b"].as_str()),
        (Some("H_ICP"), Some("HD_ICP"))
    );
    assert!(rows.iter().all(|r| r["n"] == 29
        && r["p_holm"].as_f64().unwrap() >= r["wilcoxon"]["p_value"].as_f64().unwrap()));
    let md = std::fs::read_to_string(out.join("compare.md")).unwrap();
    assert!(md.contains("| HD_ICP | TD_ICP | SOG | 29 |"), "{md}");
    let sweep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(sweep["param"], "huber_c");
    assert_eq!(sweep["points"].as_array().unwrap().len(), 6);
    assert!(out.join("sweep.png").is_file() && out.join("sweep.svg").is_file());
    assert!(
        out.join("summary.json").is_file(),
        "compare also writes the run's own reports"
    );
}

#[test]
fn list_names_the_variants_and_bad_configs_exit_2() {
    let o = icp_eval(&["list"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success() && text.contains("IR_ICP") && text.contains("geman_mcclure"),
        "{text}"
    );
    let dir = common::scratch_dir("bad_config");
    let cfg = dir.join("bad.json");
    let run_config = |cfg: &Path| {
        let out = dir.join("out");
        icp_eval(&[
            "run",
            "--dataset",
            "synthetic",
            "--scans",
            "5",
            "--config",
            cfg.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    std::fs::write(&cfg, r#"{"name": "X", "weighting": {"kind": "uniform"}, "robust": {"kind": "median_scaled", "kernel": "huber", "c": -2}}"#).unwrap();
    let o = run_config(&cfg);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr)
            .contains("robust \"median_scaled\": c = -2: must be finite and positive"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::write(&cfg, r#"{"name": "X", "weighting": {"kind": "uniform"}}"#).unwrap();
    let o = run_config(&cfg);
    assert_eq!(
        o.status.code(),
        Some(2),
        "a spec without its robust stage is refused"
    );
    let o = icp_eval(&[
        "run",
        "--dataset",
        "synthetic",
        "--scans",
        "5",
        "--variants",
        "HD_ICP,HD_ICP",
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("two variants are named HD_ICP"));
}

/// `--sensor` sets the run's sensor model over the dataset's, for the built-in variants and in
/// the reports; the dataset's reference kind, odometry and load warnings reach `summary.json`
/// and `table.md`.
#[test]
fn sensor_model_reference_kind_and_warnings_reach_the_reports() {
    let dir = common::scratch_dir("cli_sensor");
    let mut ds = datasets::synthetic::generate(&datasets::synthetic::Scenario {
        n_scans: 8,
        ..datasets::synthetic::Scenario::marina_like()
    })
    .unwrap();
    // An odometry channel that is a copy of the reference: no independent odometry.
    ds.odometry = ds.reference.as_ref().map(|r| {
        r.iter()
            .map(|p| datasets::Pose2 {
                x_m: p.x_m,
                y_m: p.y_m,
                yaw_rad: p.scan_yaw_rad.unwrap(),
            })
            .collect()
    });
    let data = dir.join("data");
    datasets::csvdir::write(&data, &ds).unwrap();
    let out = dir.join("out");
    let spec = format!("csv:{}", data.display());
    let o = icp_eval(&[
        "run",
        "--dataset",
        &spec,
        "--variants",
        "HD_ICP",
        "--sensor",
        "sigma_r_const_m=0.01,sigma_alpha_deg=0.25",
        "--quiet",
        "--no-plots",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let expected = icp_core::SensorModel {
        sigma_r_const_m: 0.01,
        sigma_r_per_m: icp_core::SensorModel::SWEEP_SIGMA_R_PER_M,
        sigma_alpha_rad: 0.25f64.to_radians(),
    };
    let summary: RunReport =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let d = &summary.dataset;
    assert_eq!(d.sensor, Some(expected));
    assert_eq!(summary.config.variants[0].sensor, expected);
    assert_eq!(d.reference_kind, Some(datasets::ReferenceKind::GroundTruth));
    assert_eq!(
        d.warnings,
        vec![datasets::LoadWarning::OdometryEqualsReference { steps: 7 }]
    );
    assert!(d.odometry);
    assert_eq!(d.scanner_offset, Some(datasets::Pose2::IDENTITY));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(
        json["dataset"]["warnings"][0]["kind"],
        "odometry_equals_reference"
    );
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        table.contains(
            "\n\nReference: ground truth (exact). Sensor model: σ_r = 0.01 m + 0.004258·r, \
             σ_α = 0.25°.\n\nLoad warnings:\n\n- the odometry equals the reference (all 7 \
             steps within 1 mm and 0.05°): no independent odometry\n\n"
        ),
        "{table}"
    );
}

/// Data without a sensor model (a dataset.json without one): the assumed model is a load
/// warning; a partial `--sensor` keeps it with the values the run used, a whole one ends it.
#[test]
fn an_assumed_sensor_model_is_said_until_sensor_gives_the_whole_model() {
    let dir = common::scratch_dir("cli_assumed_sensor");
    let ds = datasets::synthetic::generate(&datasets::synthetic::Scenario {
        n_scans: 4,
        ..datasets::synthetic::Scenario::paper()
    })
    .unwrap();
    let data = dir.join("data");
    datasets::csvdir::write(&data, &ds).unwrap();
    let meta_path = data.join("dataset.json");
    let mut meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&meta_path).unwrap()).unwrap();
    meta.as_object_mut().unwrap().remove("sensor").unwrap();
    std::fs::write(&meta_path, meta.to_string()).unwrap();
    let spec = format!("csv:{}", data.display());
    let warnings = |name: &str, sensor: Option<&str>| -> Vec<datasets::LoadWarning> {
        let out = dir.join(name);
        let mut args = vec!["run", "--dataset", &spec, "--variants", "HD_ICP", "--quiet"];
        args.extend(["--no-plots", "--out", out.to_str().unwrap()]);
        if let Some(s) = sensor {
            args.extend(["--sensor", s]);
        }
        let o = icp_eval(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let summary: RunReport =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        summary.dataset.warnings
    };
    let assumed = |sensor, of: &str| datasets::LoadWarning::AssumedSensorModel {
        sensor,
        of: of.to_owned(),
    };
    let sweep = "the Scanse Sweep (the paper's scanner)";
    assert_eq!(
        warnings("none", None),
        vec![assumed(icp_core::SensorModel::sweep(), sweep)]
    );
    let partly = icp_core::SensorModel {
        sigma_alpha_rad: 0.1f64.to_radians(),
        ..icp_core::SensorModel::sweep()
    };
    assert_eq!(
        warnings("partial", Some("sigma_alpha_deg=0.1")),
        vec![assumed(partly, &format!("{sweep}, with --sensor's values"))]
    );
    let whole = "sigma_r_const_m=0.02,sigma_r_per_m=0,sigma_alpha_deg=0.1";
    assert_eq!(warnings("whole", Some(whole)), vec![]);
}

/// A summary written before the dataset's sensor model, reference kind, warnings, odometry and
/// scanner offset were recorded still reads, with those fields empty.
#[test]
fn summaries_without_the_new_dataset_fields_still_read() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let text = std::fs::read_to_string(root.join("reports/baseline/synthetic-paper.json")).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let dataset = json["dataset"].as_object_mut().unwrap();
    for field in [
        "reference_kind",
        "warnings",
        "sensor",
        "odometry",
        "scanner_offset",
    ] {
        dataset.remove(field);
    }
    let old: RunReport = serde_json::from_value(json).unwrap();
    assert_eq!(
        (
            old.dataset.reference_kind,
            old.dataset.sensor,
            old.dataset.odometry
        ),
        (None, None, false)
    );
    assert!(old.dataset.warnings.is_empty() && old.dataset.scanner_offset.is_none());
}

/// A CSV directory of `n` marina-like synthetic scans, with `poses.csv` or without.
fn csv_data(dir: &Path, n: usize, with_reference: bool) -> String {
    let mut ds = datasets::synthetic::generate(&datasets::synthetic::Scenario {
        n_scans: n,
        ..datasets::synthetic::Scenario::marina_like()
    })
    .unwrap();
    if !with_reference {
        ds.reference = None;
        ds.reference_kind = None;
    }
    let data = dir.join("data");
    datasets::csvdir::write(&data, &ds).unwrap();
    format!("csv:{}", data.display())
}

/// `icp-eval ARGS --quiet --no-plots --out OUT`: its stdout and stderr, failing when it fails.
fn run_ok(args: &[&str], out: &Path) -> (String, String) {
    let mut all = args.to_vec();
    all.extend(["--quiet", "--no-plots", "--out", out.to_str().unwrap()]);
    let o = icp_eval(&all);
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{stderr}");
    (String::from_utf8_lossy(&o.stdout).into_owned(), stderr)
}

/// Issue 33: `--scans N` applied to synthetic data only and was silently ignored elsewhere.
/// It keeps the first N scans of any dataset and the reports say so; more than there are
/// keeps them all and says that too.
#[test]
fn scans_keeps_the_first_scans_of_a_file_dataset_and_the_reports_say_so() {
    let dir = common::scratch_dir("cli_first_scans");
    let spec = csv_data(&dir, 12, true);
    let out = dir.join("first");
    let (stdout, _) = run_ok(
        &[
            "run",
            "--dataset",
            &spec,
            "--scans",
            "5",
            "--variants",
            "HD_ICP",
        ],
        &out,
    );
    let summary: RunReport =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!((summary.dataset.scans, summary.dataset.pairs), (5, 4));
    assert_eq!(
        summary.dataset.first_scans,
        Some(datasets::FirstScans {
            requested: 5,
            available: 12
        })
    );
    assert_eq!(read_pairs(&out).len(), 4);
    let tum = std::fs::read_to_string(out.join("reference.tum")).unwrap();
    assert_eq!(tum.lines().count(), 5);
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        table.starts_with(&format!(
            "# {} — 4 pairs of 5 scans (the first 5 of 12 scans: `--scans 5`), Δt = 1 s\n",
            summary.dataset.name
        )),
        "{table}"
    );
    assert!(stdout.starts_with(&table[..40]), "{stdout}");
    let out = dir.join("all");
    let (_, stderr) = run_ok(
        &[
            "run",
            "--dataset",
            &spec,
            "--scans",
            "40",
            "--variants",
            "HD_ICP",
        ],
        &out,
    );
    assert!(
        stderr.contains("all 12 scans: `--scans 40` asks for more than the data have"),
        "{stderr}"
    );
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(
        table.contains("11 pairs of 12 scans (all 12 scans: `--scans 40` asks for more"),
        "{table}"
    );
    let out = dir.join("basin");
    let (stdout, _) = run_ok(
        &[
            "basin",
            "--dataset",
            &spec,
            "--scans",
            "4",
            "--variants",
            "HD_ICP",
            "--perturbations",
            "1",
        ],
        &out,
    );
    assert!(
        stdout.contains(" (the first 4 of 12 scans: `--scans 4`)\n\n3 pairs × 1 starts"),
        "{stdout}"
    );
    let basin: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("basin.json")).unwrap()).unwrap();
    assert_eq!(
        basin["first_scans"],
        serde_json::json!({"requested": 4, "available": 12})
    );
}

/// Issue 33: a run without a reference ended with rc 0 and tables of "–" and no word why.
/// table.md, compare.md and the console say that nothing could be scored and where the
/// estimates are; the exit code stays 0.
#[test]
fn a_run_without_a_reference_says_nothing_could_be_scored_and_where_the_motions_are() {
    let dir = common::scratch_dir("cli_no_reference");
    let spec = csv_data(&dir, 6, false);
    let sentence = "Nothing could be scored: synthetic:marina-like has no reference to measure \
                    the estimates against, so every error, statistic and comparison here is \
                    empty (–); the estimated motions are in `pairs.csv` (`tx_m`, `ty_m`, \
                    `theta_deg`, `sog_est_mps`, `dcog_est_deg` per variant and pair) and the \
                    chained trajectories in `trajectory_<variant>.tum`.";
    let out = dir.join("run");
    let (stdout, _) = run_ok(&["run", "--dataset", &spec, "--variants", "HD_ICP"], &out);
    assert!(stdout.contains(sentence), "{stdout}");
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(table.contains(sentence), "{table}");
    assert!(read_pairs(&out)
        .iter()
        .all(|r| r.sog_est_mps.is_some() && r.sog_err_mps.is_none()));
    assert!(out.join("trajectory_HD_ICP.tum").is_file());
    let out = dir.join("compare");
    let (stdout, _) = run_ok(
        &["compare", "--dataset", &spec, "--variants", "K_ICP,HD_ICP"],
        &out,
    );
    assert!(stdout.contains(sentence), "{stdout}");
    let compare = std::fs::read_to_string(out.join("compare.md")).unwrap();
    assert!(compare.contains(sentence), "{compare}");
    // With a reference, not a word of it.
    let spec = csv_data(&dir, 6, true);
    let out = dir.join("scored");
    let (stdout, _) = run_ok(&["run", "--dataset", &spec, "--variants", "HD_ICP"], &out);
    assert!(!stdout.contains("Nothing could be scored"), "{stdout}");
}
