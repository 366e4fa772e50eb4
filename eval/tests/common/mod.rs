//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The data not in the repository (`marina_dir`, ...): the datasets crate's test helper.
#[path = "../../../datasets/tests/common/data.rs"]
pub mod data;

/// The variables that shard a run (Slurm arrays, Kubernetes indexed Jobs): inherited from a
/// developer's job, they would shard the runs a test means whole.
pub const SHARD_VARS: [&str; 4] = [
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_COUNT",
    "JOB_COMPLETION_INDEX",
];

/// `command` with the [`SHARD_VARS`] removed from its environment, so that it runs the same
/// inside a Slurm array task or an indexed Job; a test that means to shard sets them again
/// with `.env`.
pub fn unsharded(mut command: Command) -> Command {
    for v in SHARD_VARS {
        command.env_remove(v);
    }
    command
}

/// The `icp-eval` binary, [`unsharded`]: every test that runs it starts here.
pub fn icp_eval_command() -> Command {
    unsharded(Command::new(env!("CARGO_BIN_EXE_icp-eval")))
}

/// Runs `icp-eval ARGS` ([`icp_eval_command`]) and returns what it did, whatever it did.
pub fn icp_eval<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> std::process::Output {
    icp_eval_command()
        .args(args)
        .output()
        .expect("the binary runs")
}

/// A fresh, empty directory under the target dir.
pub fn scratch_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `icp-eval ARGS --quiet` from the workspace root (so relative paths in the arguments are
/// read and written as given), failing with its stderr.
pub fn icp_eval_ok(args: &[&str]) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("eval sits in the workspace");
    let out = icp_eval_command()
        .current_dir(root)
        .args(args)
        .arg("--quiet")
        .output()
        .expect("icp-eval runs");
    assert!(
        out.status.success(),
        "icp-eval {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}
