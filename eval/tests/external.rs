//! `--estimates` end to end: another tool's results enter `compare` (a verdict against a
//! built-in variant) and the gate (a worse file under the same name is a regression), and bad
//! options are refused with a message naming what is wrong.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn icp_eval(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_icp-eval"))
        .args(args)
        .output()
        .expect("the binary runs")
}

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
    let worse = compare(&dir, "worse", &[truth, format!("MINE={}", large.display())]);
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
}

/// `run --estimates ARG` on three scans: the exit code and the first stderr line.
fn run_with(dir: &Path, name: &str, estimates: &str) -> (Option<i32>, String) {
    let out = dir.join(name);
    let o = icp_eval(&[
        "run",
        "--dataset",
        "synthetic",
        "--scans",
        "3",
        "--variants",
        "HD_ICP",
        "--quiet",
        "--no-plots",
        "--estimates",
        estimates,
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    (
        o.status.code(),
        err.lines().next().unwrap_or_default().to_owned(),
    )
}

#[test]
fn bad_estimates_options_are_refused() {
    let dir = common::scratch_dir("external_bad");
    let file = dir.join("m.csv");
    std::fs::write(&file, "source,reference,tx_m,ty_m,theta_deg\n0,1,0.1,0,0\n").unwrap();
    let f = file.display();
    let cases = [
        ("noequals", "m.csv".to_owned(), "expected NAME=FILE"),
        (
            "absent",
            "X=/nonexistent/m.tum".to_owned(),
            "/nonexistent/m.tum",
        ),
        (
            "clash",
            format!("HD_ICP={f}"),
            "two variants are named HD_ICP",
        ),
        ("badname", format!("a/b={f}"), "variant name \"a/b\""),
    ];
    for (name, arg, want) in cases {
        let (code, line) = run_with(&dir, name, &arg);
        assert_eq!(code, Some(2), "{name}: {line}");
        assert!(line.contains(want), "{name}: {line}");
    }
    // A file for another run's scans: a TUM pose near no scan names the file and line.
    let tum = dir.join("other.tum");
    std::fs::write(&tum, "500.0 1 2 0 0 0 0 1\n").unwrap();
    let (code, line) = run_with(&dir, "other", &format!("X={}", tum.display()));
    assert_eq!(code, Some(2));
    assert!(
        line.contains("other.tum, line 1") && line.contains("within 0.001 s of no scan"),
        "{line}"
    );
}
