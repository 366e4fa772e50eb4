//! `--estimates` end to end: another tool's results enter `compare` (a verdict against a
//! built-in variant) and the gate (a worse file under the same name is a regression). Bad
//! `--estimates` options are in the bad-input matrix.

mod common;
use common::icp_eval;

use std::path::{Path, PathBuf};
use std::process::Output;

fn ok(o: Output) -> Output {
    assert!(
        o.status.success(),
        "icp-eval failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

const DATA: [&str; 5] = ["--dataset", "synthetic:paper", "--scans", "30", "--quiet"];

/// The reference trajectory of the run, written by a first run.
fn reference_tum(dir: &Path) -> PathBuf {
    let out = dir.join("first");
    let mut args = vec!["run", "--variants", "HD_ICP", "--no-plots", "--out"];
    args.push(out.to_str().unwrap());
    args.extend(DATA);
    ok(icp_eval(&args));
    out.join("reference.tum")
}

/// The TUM file `reference` with every position moved by `offset_m` along a slow wave: a
/// deterministic estimator that errs by up to `offset_m`.
fn degraded(reference: &Path, offset_m: f64, to: &Path) -> PathBuf {
    let text = std::fs::read_to_string(reference).unwrap();
    let lines: String = text
        .lines()
        .enumerate()
        .map(|(k, l)| {
            let mut v: Vec<f64> = l.split_whitespace().map(|c| c.parse().unwrap()).collect();
            v[1] += offset_m * (k as f64 * 0.7).sin();
            v[2] += offset_m * (k as f64 * 1.3).cos();
            let cells: Vec<String> = v.iter().map(|x| format!("{x:.9}")).collect();
            cells.join(" ") + "\n"
        })
        .collect();
    std::fs::write(to, lines).unwrap();
    to.to_path_buf()
}

fn compare(dir: &Path, name: &str, estimates: &[String]) -> PathBuf {
    let out = dir.join(name);
    let mut args = vec!["compare", "--variants", "HD_ICP", "--bootstrap", "300"];
    args.extend(DATA);
    for e in estimates {
        args.extend(["--estimates", e.as_str()]);
    }
    args.extend(["--out", out.to_str().unwrap()]);
    ok(icp_eval(&args));
    out
}

#[test]
fn external_estimators_get_compare_verdicts_and_are_gated() {
    let dir = common::scratch_dir("external_compare_gate");
    let reference = reference_tum(&dir);
    let small = degraded(&reference, 0.002, &dir.join("small.tum"));
    let large = degraded(&reference, 0.05, &dir.join("large.tum"));
    let truth = format!("TRUTH={}", reference.display());
    let base = compare(
        &dir,
        "base",
        &[truth.clone(), format!("MINE={}", small.display())],
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(base.join("compare.json")).unwrap()).unwrap();
    let verdict = |a: &str, b: &str, metric: &str| -> String {
        json["comparisons"]
            .as_array()
            .unwrap()
            .iter()
            .find(|c| c["a"] == a && c["b"] == b && c["metric"] == metric)
            .unwrap_or_else(|| panic!("no {a} vs {b} {metric}"))["verdict"]
            .as_str()
            .unwrap()
            .to_owned()
    };
    // The truth beats a registration, a 2 mm wobble beats it too (HD_ICP errs by ~1 cm).
    assert_eq!(verdict("HD_ICP", "TRUTH", "sog_err_mps"), "TRUTH better");
    assert_eq!(verdict("HD_ICP", "MINE", "sog_err_mps"), "MINE better");
    assert_eq!(verdict("TRUTH", "MINE", "sog_err_mps"), "TRUTH better");
    // Each external has its trajectory and evo results like a variant.
    for f in ["trajectory_MINE.tum", "evo/MINE_sog.zip", "sog_error.png"] {
        assert!(base.join(f).is_file(), "{f}");
    }
    let table = std::fs::read_to_string(base.join("table.md")).unwrap();
    assert!(table.contains("- MINE: ") && table.contains("an estimate for 29 of the 29 pairs"));

    // The gate: the same run passes; MINE's file swapped for a worse one is a regression of
    // MINE's, and of nothing else.
    let tolerance =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../reports/baseline/tolerance.json");
    let gate = |current: &Path| {
        icp_eval(&[
            "gate",
            "--baseline",
            base.join("summary.json").to_str().unwrap(),
            "--current",
            current.join("summary.json").to_str().unwrap(),
            "--tolerance",
            tolerance.to_str().unwrap(),
        ])
    };
    ok(gate(&base));
    let worse = compare(
        &dir,
        "worse",
        &[truth.clone(), format!("MINE={}", large.display())],
    );
    let o = gate(&worse);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let text = String::from_utf8_lossy(&o.stdout);
    let rows: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("| "))
        .skip(2)
        .collect();
    assert!(!rows.is_empty(), "{text}");
    assert!(rows.iter().all(|l| l.starts_with("| MINE |")), "{text}");
    assert!(
        text.contains("note: external estimator MINE: its file changed"),
        "{text}"
    );
    assert!(!text.contains("populations differ"), "{text}");
    // A file without scan 10's pose: pairs 9→10 and 10→11 are MINE's failures and leave
    // every variant's statistics; the gate says so.
    let cut: String = std::fs::read_to_string(&small)
        .unwrap()
        .lines()
        .enumerate()
        .filter(|(k, _)| *k != 10)
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    let cut_path = dir.join("cut.tum");
    std::fs::write(&cut_path, cut).unwrap();
    let fewer = compare(
        &dir,
        "fewer",
        &[
            format!("TRUTH={}", reference.display()),
            format!("MINE={}", cut_path.display()),
        ],
    );
    let o = gate(&fewer);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("note: the populations differ (29 pairs in the baseline, 27 now)"),
        "{text}"
    );
}
