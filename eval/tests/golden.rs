//! The files a run writes, against committed copies (`eval/tests/golden/<case>/`): every
//! JSON, CSV, Markdown and TUM file of `run`, `compare --sweep`, `basin` and merged shards, on
//! the synthetic harbour, marina and aces, byte for byte once the timings are blanked (JSON keys
//! and CSV columns ending in `_us`) and the path of the data's folder is written `$DATA_DIR`.
//!
//! A change that means to move an output (a fixed bug, a new field) rewrites them with
//! `ICP_UPDATE_GOLDEN=1 cargo test -p eval --test golden -- --include-ignored` and its commit
//! says what moved and why; a change that does not (a refactor) must leave them as they are.
//! Merged shards are compared with the single run's copies, so they also show that sharding
//! changes nothing.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::{data, icp_eval_ok, scratch_dir};

const UPDATE_ENV: &str = "ICP_UPDATE_GOLDEN";

fn golden_dir(case: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(case)
}

/// `value` with every number under a key ending in `_us` replaced by null.
fn blank_timings(value: &mut serde_json::Value) {
    match value {
        serde_json::Value::Object(map) => {
            for (key, v) in map.iter_mut() {
                if key.ends_with("_us") {
                    *v = serde_json::Value::Null;
                } else {
                    blank_timings(v);
                }
            }
        }
        serde_json::Value::Array(items) => items.iter_mut().for_each(blank_timings),
        _ => {}
    }
}

/// The CSV text with the cells of every column whose header ends in `_us` emptied.
fn blank_csv_timings(text: &str) -> String {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .from_reader(text.as_bytes());
    let mut writer = csv::Writer::from_writer(Vec::new());
    let mut timed = Vec::new();
    for (i, row) in reader.records().enumerate() {
        let row = row.expect("our CSV files parse");
        if i == 0 {
            timed = row.iter().map(|h| h.ends_with("_us")).collect();
            writer.write_record(&row).unwrap();
        } else {
            let cells =
                row.iter()
                    .enumerate()
                    .map(|(j, c)| if timed.get(j) == Some(&true) { "" } else { c });
            writer.write_record(cells).unwrap();
        }
    }
    String::from_utf8(writer.into_inner().unwrap()).unwrap()
}

/// The comparable text of every JSON, CSV, Markdown and TUM file below `dir` (but the
/// manifest, which names files rather than holding results), keyed by relative path.
fn outputs(dir: &Path, data_root: &str) -> BTreeMap<String, String> {
    let mut files = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            let rel = path
                .strip_prefix(dir)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
            if rel == "manifest.json" || !["json", "csv", "md", "tum"].contains(&ext) {
                continue;
            }
            let raw = std::fs::read_to_string(&path).unwrap();
            let raw = if data_root.is_empty() {
                raw
            } else {
                raw.replace(data_root, "$DATA_DIR")
            };
            let text = match ext {
                "json" => {
                    let mut v: serde_json::Value = serde_json::from_str(&raw)
                        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                    blank_timings(&mut v);
                    serde_json::to_string_pretty(&v).unwrap() + "\n"
                }
                "csv" => blank_csv_timings(&raw),
                _ => raw,
            };
            files.insert(rel, text);
        }
    }
    files
}

/// Compares the outputs in `dir` with the committed copies of `case` (or rewrites them under
/// [`UPDATE_ENV`]).
fn check(case: &str, dir: &Path, data_root: &str) {
    let got = outputs(dir, data_root);
    assert!(
        !got.is_empty(),
        "{case}: no output file in {}",
        dir.display()
    );
    let golden = golden_dir(case);
    if std::env::var_os(UPDATE_ENV).is_some() {
        let _ = std::fs::remove_dir_all(&golden);
        for (rel, text) in &got {
            let path = golden.join(rel);
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(path, text).unwrap();
        }
        return;
    }
    let want = outputs(&golden, "");
    let names = |m: &BTreeMap<String, String>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(
        names(&got),
        names(&want),
        "{case}: the files written differ from {} ({UPDATE_ENV}=1 rewrites them)",
        golden.display()
    );
    for (rel, text) in &got {
        if text != &want[rel] {
            let line = text
                .lines()
                .zip(want[rel].lines())
                .position(|(a, b)| a != b)
                .unwrap_or_else(|| text.lines().count().min(want[rel].lines().count()));
            panic!(
                "{case}: {rel} differs from the committed copy from line {} on:\n got: {}\nwant: {}\n\
                 ({UPDATE_ENV}=1 rewrites the copies when the change is meant to move them)",
                line + 1,
                text.lines().nth(line).unwrap_or("<end>"),
                want[rel].lines().nth(line).unwrap_or("<end>"),
            );
        }
    }
}

/// Runs `args` whole into one directory and (with `shards` > 1) in `shards` parts merged into
/// another, and compares both with `case` (the merge with the single run's copies).
fn whole_and_sharded(case: &str, args: &[&str], shards: usize) {
    let dir = scratch_dir(&format!("golden-{case}"));
    let whole = dir.join("whole");
    let mut run: Vec<&str> = args.to_vec();
    let whole_s = whole.to_string_lossy().into_owned();
    run.extend(["--no-plots", "--out", &whole_s]);
    icp_eval_ok(&run);
    check(case, &whole, "");
    if shards < 2 || std::env::var_os(UPDATE_ENV).is_some() {
        return;
    }
    let mut parts = Vec::new();
    for k in 0..shards {
        let part = dir.join(format!("part-{k}"));
        let (part_s, shard) = (part.to_string_lossy().into_owned(), format!("{k}/{shards}"));
        let mut run: Vec<&str> = args.to_vec();
        run.extend(["--no-plots", "--shard", &shard, "--out", &part_s]);
        icp_eval_ok(&run);
        parts.push(part_s);
    }
    let merged = dir.join("merged").to_string_lossy().into_owned();
    let mut merge: Vec<&str> = vec!["merge"];
    merge.extend(parts.iter().map(String::as_str));
    merge.extend(["--no-plots", "--out", &merged]);
    icp_eval_ok(&merge);
    check(case, Path::new(&merged), "");
}

#[test]
fn synthetic_run_with_constant_velocity_starts() {
    whole_and_sharded(
        "synthetic-run",
        &[
            "run",
            "--dataset",
            "synthetic",
            "--scans",
            "60",
            "--variants",
            "K_ICP,HD_ICP,PL_ICP,HD_GICP",
            "--init",
            "constant-velocity",
        ],
        3,
    );
}

#[test]
fn synthetic_run_with_sampled_covariances() {
    whole_and_sharded(
        "synthetic-sampled",
        &[
            "run",
            "--dataset",
            "synthetic",
            "--scans",
            "25",
            "--variants",
            "HD_ICP,PL_ICP",
            "--covariance",
            "sampled",
            "--global-check",
            "off",
        ],
        // A sampled covariance run is not sharded (yet): it is refused.
        1,
    );
}

#[test]
fn synthetic_compare_with_a_sweep() {
    whole_and_sharded(
        "synthetic-compare",
        &[
            "compare",
            "--dataset",
            "synthetic",
            "--scans",
            "40",
            "--variants",
            "K_ICP,HD_ICP,PL_ICP",
            "--sweep",
            "sigma_alpha_deg=0.25,1",
        ],
        3,
    );
}

#[test]
fn synthetic_run_across_lags() {
    // Identity starts 2 s apart: some registrations fail and the loops flag them, two of
    // them (pairs 9 and 10) across the first shard's edge (units 0..10 of 39).
    whole_and_sharded(
        "synthetic-lags",
        &[
            "run",
            "--dataset",
            "synthetic",
            "--scans",
            "40",
            "--dt",
            "2",
            "--variants",
            "K_ICP,HD_ICP,PL_ICP",
            "--lags",
            "2",
        ],
        4,
    );
}

#[test]
fn synthetic_compare_across_lags_with_chained_starts() {
    // A chained start cuts the plan by variants; the sweep's runs register no lag.
    whole_and_sharded(
        "synthetic-lags-chained",
        &[
            "compare",
            "--dataset",
            "synthetic",
            "--scans",
            "30",
            "--dt",
            "2",
            "--variants",
            "K_ICP,HD_ICP,PL_ICP",
            "--init",
            "constant-velocity,identity",
            "--lags",
            "3",
            "--sweep",
            "huber_c=1,3",
            "--bootstrap",
            "200",
        ],
        4,
    );
}

#[test]
fn synthetic_basin() {
    whole_and_sharded(
        "synthetic-basin",
        &[
            "basin",
            "--dataset",
            "synthetic",
            "--scans",
            "20",
            "--variants",
            "HD_ICP,PL_ICP",
            "--perturbations",
            "3",
        ],
        2,
    );
}

#[test]
#[ignore = "needs the marina data: run with --include-ignored"]
fn marina_run_with_external_estimates() {
    let marina = data::marina_dir();
    let dir = scratch_dir("golden-marina");
    let out = dir.join("run").to_string_lossy().into_owned();
    let uri = format!("marina?data_dir={}", marina.display());
    icp_eval_ok(&[
        "run",
        "--dataset",
        &uri,
        "--variants",
        "K_ICP,H_ICP,HD_ICP,PL_ICP,HD_GICP",
        "--estimates",
        "SG_GICP=reports/external/marina/estimates/SG_GICP.csv",
        "--estimates",
        "KISS_ICP=reports/external/marina/estimates/KISS_ICP.tum",
        "--no-plots",
        "--out",
        &out,
    ]);
    check("marina-run", Path::new(&out), &marina.to_string_lossy());
}

#[test]
#[ignore = "needs the CARMEN aces log: run with --include-ignored"]
fn aces_run_from_the_global_search() {
    let log = data::aces_log();
    let dir = scratch_dir("golden-aces");
    let out = dir.join("run").to_string_lossy().into_owned();
    let uri = format!("carmen:{}", log.display());
    icp_eval_ok(&[
        "run",
        "--dataset",
        &uri,
        "--variants",
        "HD_ICP,PL_ICP,HD_GICP",
        "--init",
        "global",
        "--estimates",
        "SG_GICP=reports/external/aces/estimates/SG_GICP.csv",
        "--no-plots",
        "--out",
        &out,
    ]);
    check(
        "aces-run",
        Path::new(&out),
        &log.parent().expect("a file").to_string_lossy(),
    );
}
