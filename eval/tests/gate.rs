//! `icp-eval gate` and `icp-eval baseline`: identical results pass, a worse variant fails
//! naming the metrics, a variant on one side only is one line, incomparable or broken input is
//! refused, and a baseline made by `baseline` gates from any directory with the tolerances
//! beside it or the built-in ones.

mod common;
use common::{icp_eval, icp_eval_command};

use std::path::{Path, PathBuf};
use std::process::Output;

use serde_json::Value;

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

/// `summary`'s JSON, changed by `edit`, written to `to`; returns `to`.
fn edited(summary: &Path, to: &Path, edit: impl FnOnce(&mut Vec<Value>)) -> PathBuf {
    let mut json = read_json(summary);
    edit(json["variants"].as_array_mut().unwrap());
    std::fs::write(to, serde_json::to_string_pretty(&json).unwrap()).unwrap();
    to.to_owned()
}

/// A copy of `summary` at `to` with K_ICP's results registered under HD_ICP's name: HD_ICP
/// got worse.
fn worsened(summary: &Path, to: &Path) -> PathBuf {
    edited(summary, to, |variants| {
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
    })
}

/// `icp-eval run ARGS --quiet --no-plots --out OUT`, which must succeed; returns OUT.
fn run(out: &Path, args: &[&str]) -> PathBuf {
    let o = icp_eval_command()
        .arg("run")
        .args(args)
        .args(["--quiet", "--no-plots", "--out", out.to_str().unwrap()])
        .output()
        .expect("the binary runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out.to_owned()
}

/// A small synthetic run of the four variants; returns its summary.json.
fn small_run(dir: &Path) -> PathBuf {
    run(
        dir,
        &["--dataset", "synthetic:marina-like", "--scans", "60"],
    )
    .join("summary.json")
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

    let worse = worsened(&summary, &dir.join("worse.json"));
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
}

#[test]
fn unusable_input_exits_2() {
    let dir = common::scratch_dir("gate_bad");
    let a = small_run(&dir.join("a"));
    let b = run(
        &dir.join("b"),
        &[
            "--dataset",
            "synthetic:marina-like",
            "--scans",
            "30",
            "--variants",
            "HD_ICP",
        ],
    )
    .join("summary.json");
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

/// `icp-eval ARGS` run in `cwd`.
fn icp_eval_in(cwd: &Path, args: &[&str]) -> Output {
    icp_eval_command()
        .current_dir(cwd)
        .args(args)
        .output()
        .expect("the binary runs")
}

fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The 20-scan synthetic `paper` run of the four variants; returns its directory.
fn tiny_run(dir: &Path) -> PathBuf {
    run(dir, &["--dataset", "synthetic", "--scans", "20"])
}

/// `icp-eval baseline --from FROM --out OUT [EXTRA]`.
fn baseline(from: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "baseline",
        "--from",
        from.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    icp_eval(&args)
}

/// `icp-eval gate` without `--tolerance`, run in `cwd`.
fn gate_default(cwd: &Path, baseline: &Path, current: &Path) -> Output {
    icp_eval_in(
        cwd,
        &[
            "gate",
            "--baseline",
            baseline.to_str().unwrap(),
            "--current",
            current.to_str().unwrap(),
        ],
    )
}

#[test]
fn a_baseline_made_by_baseline_gates_from_any_directory() {
    let dir = common::scratch_dir("gate_baseline");
    let run = tiny_run(&dir.join("run"));
    let base = dir.join("committed/mine.json");
    let o = baseline(&run, &base, &[]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let beside = dir.join("committed/tolerance.json");
    assert_eq!(
        stdout(&o),
        format!(
            "wrote {} (baseline of synthetic:paper: K_ICP, H_ICP, HM_ICP, HD_ICP)\nwrote {} (the built-in tolerances)\n",
            base.display(),
            beside.display()
        )
    );
    assert_eq!(
        std::fs::read(run.join("summary.json")).unwrap(),
        std::fs::read(&base).unwrap(),
        "a run's summary is its baseline as it is"
    );
    let committed =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../reports/baseline/tolerance.json");
    assert_eq!(
        std::fs::read_to_string(&beside).unwrap(),
        std::fs::read_to_string(committed).unwrap(),
        "the built-in tolerances are the committed ones"
    );

    // From a directory with no reports/baseline/ in it.
    let elsewhere = dir.join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let summary = run.join("summary.json");
    let o = gate_default(&elsewhere, &base, &summary);
    assert_eq!(o.status.code(), Some(0), "{}{}", stdout(&o), stderr(&o));
    assert!(
        stdout(&o).starts_with(&format!(
            "synthetic:paper: tolerance {} (beside the baseline)\nsynthetic:paper: 180 metrics checked, 0 regressed\n",
            beside.display()
        )),
        "{}",
        stdout(&o)
    );
    let worse = worsened(&summary, &dir.join("worse.json"));
    let o = gate_default(&elsewhere, &base, &worse);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(stdout(&o).contains("| HD_ICP | all_pairs.sog_err_mps.std |"));

    // The tolerance beside the baseline is the one used: loose enough, the worse run passes.
    std::fs::write(&beside, r#"{"default": {"abs": 1000, "rel": 1000}}"#).unwrap();
    let o = gate_default(&elsewhere, &base, &worse);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
    // A second `baseline` leaves it in place, and says so.
    let o = baseline(&run, &base, &[]);
    assert!(stdout(&o).ends_with(&format!(
        "kept {} (already there, not overwritten)\n",
        beside.display()
    )));
    assert!(std::fs::read_to_string(&beside).unwrap().contains("1000"));

    // None beside it: the built-in tolerances.
    std::fs::remove_file(&beside).unwrap();
    let o = gate_default(&elsewhere, &base, &worse);
    assert_eq!(o.status.code(), Some(1), "{}", stdout(&o));
    assert!(stdout(&o).starts_with(
        "synthetic:paper: tolerance built-in (no tolerance.json beside the baseline)\n"
    ));
    let o = gate_default(&elsewhere, &base, &summary);
    assert_eq!(o.status.code(), Some(0), "{}", stdout(&o));
}

#[test]
fn a_variant_on_one_side_only_is_one_line() {
    let dir = common::scratch_dir("gate_one_side");
    let run = tiny_run(&dir.join("run"));
    let summary = run.join("summary.json");
    // A scheme of the user's beside the built-ins, not in the baseline: a note, exit 0.
    let extra = edited(&summary, &dir.join("extra.json"), |variants| {
        let mut mine = variants[3].clone();
        mine["name"] = "MY_ICP".into();
        variants.push(mine);
    });
    let o = gate(&summary, &extra, &tolerance());
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(out.contains("180 metrics checked, 0 regressed"), "{out}");
    assert_eq!(out.matches("MY_ICP").count(), 1, "{out}");
    assert!(
        out.contains(&format!(
            "\nMY_ICP: in the current run only, not gated (add it to the baseline: icp-eval baseline --from {} --out {})\n",
            extra.display(),
            summary.display()
        )),
        "{out}"
    );

    // A built-in the current run lacks: one line, and a failure.
    let missing = edited(&summary, &dir.join("missing.json"), |variants| {
        variants.retain(|v| v["name"] != "H_ICP")
    });
    let o = gate(&summary, &missing, &tolerance());
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(out.contains("135 metrics checked, 0 regressed"), "{out}");
    assert_eq!(out.matches("H_ICP").count(), 1, "{out}");
    assert!(
        out.contains("\nH_ICP: in the baseline only, missing from the current run\n"),
        "{out}"
    );
    assert!(!out.contains("missing |"), "no per-metric rows: {out}");

    // A baseline of some variants gates those, and names the others once each.
    let base = dir.join("hd.json");
    let o = baseline(&run, &base, &["--variants", "HD_ICP"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = gate_default(&dir, &base, &summary);
    let out = stdout(&o);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(out.contains("45 metrics checked, 0 regressed"), "{out}");
    for v in ["K_ICP", "H_ICP", "HM_ICP"] {
        assert!(
            out.contains(&format!("\n{v}: in the current run only, not gated (add it to the baseline: icp-eval baseline --from {} --out {})\n", run.display(), base.display())),
            "{out}"
        );
    }
}

/// A folder `dir/name` holding `files` (path, text); returns it.
fn folder(dir: &Path, name: &str, files: &[(&str, &str)]) -> PathBuf {
    let at = dir.join(name);
    std::fs::create_dir_all(&at).unwrap();
    for (path, text) in files {
        let path = at.join(path);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
    at
}

/// A run of HD_ICP on synthetic data with no reference (its poses.csv removed); returns its
/// directory.
fn run_without_reference(dir: &Path) -> PathBuf {
    let data = dir.join("data");
    let o = icp_eval(&["synth", "--scans", "8", "--out", data.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::remove_file(data.join("poses.csv")).unwrap();
    let meta = data.join("dataset.json");
    let mut json = read_json(&meta);
    json.as_object_mut().unwrap().remove("reference_kind");
    std::fs::write(&meta, json.to_string()).unwrap();
    run(
        &dir.join("no-reference"),
        &[
            "--dataset",
            &format!("csv:{}", data.display()),
            "--variants",
            "HD_ICP",
        ],
    )
}

#[test]
fn baseline_refuses_what_cannot_be_gated() {
    let dir = common::scratch_dir("gate_baseline_bad");
    let nowhere = dir.join("nowhere");
    let empty = folder(&dir, "empty", &[]);
    let garbage = folder(&dir, "garbage", &[("summary.json", "{\"variants\": [")]);
    // A reproduce-like folder of runs, and a sharded run's parts not merged yet.
    let runs = folder(&dir, "runs", &[("a/summary.json", "{}")]);
    let parts = folder(&dir, "parts", &[("part-0-of-2.cbor", "")]);
    let no_reference = run_without_reference(&dir);
    let run = tiny_run(&dir.join("run"));
    let mut json = read_json(&run.join("summary.json"));
    json["schema_version"] = 3.into();
    let old = dir.join("old.json");
    std::fs::write(&old, json.to_string()).unwrap();

    let cases: [(&Path, &[&str], String); 8] = [
        (
            &nowhere,
            &[],
            format!("{}: no such run directory or file", nowhere.display()),
        ),
        (
            &empty,
            &[],
            format!("{}: no summary.json in it", empty.display()),
        ),
        (
            &garbage,
            &[],
            format!(
                "{} is not a summary.json of this schema",
                garbage.join("summary.json").display()
            ),
        ),
        (
            &runs,
            &[],
            format!("it holds runs, give one of them: {}", runs.join("a").display()),
        ),
        (
            &parts,
            &[],
            "a sharded run's part files; merge them first".to_owned(),
        ),
        (
            &no_reference,
            &[],
            format!(
                "{} cannot be a baseline: synthetic:paper has no reference, so the run has no error statistics to gate",
                no_reference.join("summary.json").display()
            ),
        ),
        (
            &run,
            &["--variants", "HD_ICP,NOPE"],
            "it has no variant NOPE; its variants are K_ICP, H_ICP, HM_ICP, HD_ICP".to_owned(),
        ),
        (
            &old,
            &[],
            "it is of summary.json schema 3, this icp-eval writes schema 4".to_owned(),
        ),
    ];
    for (from, extra, why) in cases {
        let o = baseline(from, &dir.join("base/b.json"), extra);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(&why), "{}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
        assert!(stdout(&o).is_empty());
        assert!(!dir.join("base").exists(), "nothing written");
    }
}
