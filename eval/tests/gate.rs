//! `icp-eval gate`: identical results pass, a worse variant fails naming the metrics, and
//! incomparable or broken input is refused.

mod common;
use common::icp_eval;

use std::path::{Path, PathBuf};
use std::process::Output;

fn tolerance() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../reports/baseline/tolerance.json")
}

fn gate(baseline: &Path, current: &Path, tol: &Path) -> Output {
    icp_eval(&[
        "gate",
        "--baseline",
        baseline.to_str().unwrap(),
        "--current",
        current.to_str().unwrap(),
        "--tolerance",
        tol.to_str().unwrap(),
    ])
}

/// A small synthetic run of the four variants; returns its summary.json.
fn small_run(dir: &Path) -> PathBuf {
    let o = icp_eval(&[
        "run",
        "--dataset",
        "synthetic:marina-like",
        "--scans",
        "60",
        "--quiet",
        "--no-plots",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    dir.join("summary.json")
}

#[test]
fn identical_passes_and_a_worse_variant_fails_naming_its_metrics() {
    let dir = common::scratch_dir("gate");
    let summary = small_run(&dir);
    let o = gate(&summary, &summary, &tolerance());
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(String::from_utf8_lossy(&o.stdout).contains("0 regressed"));

    // K_ICP's results registered under HD_ICP's name.
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
    let variants = json["variants"].as_array_mut().unwrap();
    let k = variants
        .iter()
        .find(|v| v["name"] == "K_ICP")
        .unwrap()
        .clone();
    let hd = variants.iter_mut().find(|v| v["name"] == "HD_ICP").unwrap();
    for key in [
        "all_pairs",
        "plausible_reference",
        "trajectory",
        "converged_fraction",
    ] {
        hd[key] = k[key].clone();
    }
    let worse = dir.join("worse.json");
    std::fs::write(&worse, serde_json::to_string_pretty(&json).unwrap()).unwrap();
    let o = gate(&summary, &worse, &tolerance());
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(
        out.contains("| HD_ICP | all_pairs.sog_err_mps.std |"),
        "{out}"
    );
    assert!(
        out.contains("| HD_ICP | all_pairs.trans_err_m.rmse |"),
        "{out}"
    );
    assert!(
        !out.contains("| K_ICP |") && !out.contains("| H_ICP |"),
        "only HD_ICP changed: {out}"
    );

    // A variant missing from the current run is a regression too.
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
    json["variants"]
        .as_array_mut()
        .unwrap()
        .retain(|v| v["name"] != "H_ICP");
    let missing = dir.join("missing.json");
    std::fs::write(&missing, serde_json::to_string(&json).unwrap()).unwrap();
    let o = gate(&summary, &missing, &tolerance());
    assert_eq!(o.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("| H_ICP | pairs_ok | 59.000000 | missing |")
    );
}

#[test]
fn unusable_input_exits_2() {
    let dir = common::scratch_dir("gate_bad");
    let a = small_run(&dir.join("a"));
    let o = icp_eval(&[
        "run",
        "--dataset",
        "synthetic:marina-like",
        "--scans",
        "30",
        "--variants",
        "HD_ICP",
        "--quiet",
        "--no-plots",
        "--out",
        dir.join("b").to_str().unwrap(),
    ]);
    assert!(o.status.success());
    let b = dir.join("b/summary.json");
    let o = gate(&a, &b, &tolerance());
    assert_eq!(o.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("cannot be compared"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let truncated = dir.join("truncated.json");
    let text = std::fs::read_to_string(&a).unwrap();
    std::fs::write(&truncated, &text[..text.len() / 2]).unwrap();
    assert_eq!(gate(&a, &truncated, &tolerance()).status.code(), Some(2));
    let bad_tol = dir.join("tol.json");
    std::fs::write(&bad_tol, r#"{"default": {"abs": -1, "rel": 0}}"#).unwrap();
    assert_eq!(gate(&a, &a, &bad_tol).status.code(), Some(2));
    assert_eq!(
        gate(&a, &dir.join("nope.json"), &tolerance()).status.code(),
        Some(2)
    );
}
