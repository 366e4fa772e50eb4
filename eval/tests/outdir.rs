//! An output directory lists what a run wrote; the next run removes its own stale files and
//! refuses a directory holding files it did not write, unless forced.

mod common;
use common::icp_eval;

use eval::error::EvalError;
use eval::render::outdir::OutputDir;

#[test]
fn a_new_run_removes_the_files_of_the_last_and_nothing_else() {
    let dir = common::scratch_dir("outdir_stale");
    let out = dir.join("run");
    let run = |variants: &str, extra: &[&str]| {
        let mut args = vec![
            "run",
            "--dataset",
            "synthetic",
            "--scans",
            "4",
            "--variants",
            variants,
            "--quiet",
            "--no-plots",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        icp_eval(&args)
    };
    let o = run("H_ICP,HD_ICP", &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("trajectory_H_ICP.tum").exists());
    let manifest = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    assert!(manifest.contains("\"trajectory_H_ICP.tum\""), "{manifest}");

    // A second run with other variants: H_ICP's trajectory is stale and goes.
    let o = run("HD_ICP", &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        !out.join("trajectory_H_ICP.tum").exists(),
        "stale file kept"
    );
    assert!(out.join("trajectory_HD_ICP.tum").exists());

    // A file the user put there is not icp-eval's: the directory is refused...
    std::fs::remove_file(out.join("manifest.json")).unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let o = run("HD_ICP", &[]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("icp-eval did not list") && err.contains("--force"),
        "{err}"
    );
    // ...unless forced, and then it is left alone.
    let o = run("HD_ICP", &["--force"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "mine"
    );
    let manifest = std::fs::read_to_string(out.join("manifest.json")).unwrap();
    assert!(!manifest.contains("notes.txt"), "{manifest}");
}

#[test]
fn a_manifest_never_reaches_outside_its_directory() {
    let dir = common::scratch_dir("outdir_escape");
    let outside = dir.join("precious.txt");
    std::fs::write(&outside, "keep").unwrap();
    let out = dir.join("run");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(
        out.join("manifest.json"),
        r#"{"tool": "icp-eval", "files": ["../precious.txt"]}"#,
    )
    .unwrap();
    let e = OutputDir::open(&out, false).unwrap_err();
    assert!(
        matches!(&e, EvalError::OutputDir { why, .. } if why.contains("not a file inside it")),
        "{e}"
    );
    assert!(outside.exists());
    std::fs::write(out.join("manifest.json"), "not json").unwrap();
    assert!(
        OutputDir::open(&out, true).is_err(),
        "a broken manifest is not ignored"
    );
}
