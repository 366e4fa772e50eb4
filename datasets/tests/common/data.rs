//! Where the tests find the data that is not in the repository, one function per kind.
//!
//! Every test that calls one of these is `#[ignore = "needs ... : run with
//! --include-ignored"]`, so that a fresh clone's `cargo test --workspace` counts it as
//! ignored. Once it is run (`cargo test --workspace -- --include-ignored`) a missing file is
//! a failure naming the variable and the paths looked at, never a silent pass.
//!
//! Shared by `datasets/tests` and `eval/tests` (through `#[path]`): both crates sit one
//! folder below the workspace root, and both call the loader crate `datasets`.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use datasets::marina::{self, DATA_DIR_ENV};

/// Variable naming the folder of ROS 2 bags written by `scripts/write-test-bag.py` (the Python
/// `rosbags` package, an independent writer): `mcap/` and `sqlite3/` below it.
pub const ROSBAG_DIR_ENV: &str = "ICP_ROSBAG_DIR";

/// The workspace root: a relative path in a variable is read from here, since cargo runs each
/// test from its crate's folder.
fn workspace_root() -> PathBuf {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    crate_dir.parent().unwrap_or(crate_dir).to_path_buf()
}

/// The folder the data is read from, and how it was chosen (for the failure message):
/// `$ICP_DATA_DIR` (a relative value taken from [`workspace_root`]), else the workspace's
/// `datasets/` (where `scripts/fetch-marina.sh` puts the marina files).
fn data_root() -> (PathBuf, String) {
    let root = workspace_root();
    match std::env::var_os(DATA_DIR_ENV) {
        Some(dir) => (
            root.join(&dir),
            format!("{DATA_DIR_ENV}={}", dir.to_string_lossy()),
        ),
        None => (root.join("datasets"), format!("{DATA_DIR_ENV} unset")),
    }
}

/// The folder holding the marina files (`angles.mat`, `ranges.mat`, `gps.mat`), directly or
/// in a `marina/` folder of [`data_root`]. Panics, naming the variable and every path looked
/// at, when they are not there.
pub fn marina_dir() -> PathBuf {
    let (root, chosen) = data_root();
    marina::find_in(marina::candidate_dirs(Some(&root), None)).unwrap_or_else(|e| {
        panic!(
            "this test needs the marina data ({chosen}): {e}\nSet {DATA_DIR_ENV} to an \
             absolute path, or run `cargo test` without --include-ignored to skip it."
        )
    })
}

/// The public CARMEN `aces` log, `carmen/aces.log.gz` in [`data_root`]. Panics, naming the
/// variable and the path looked at, when it is not there.
pub fn aces_log() -> PathBuf {
    let (root, chosen) = data_root();
    let path = root.join("carmen").join("aces.log.gz");
    assert!(
        path.is_file(),
        "this test needs the CARMEN aces log ({chosen}): no file {}\nSet {DATA_DIR_ENV} to an \
         absolute path holding carmen/aces.log.gz, or run `cargo test` without \
         --include-ignored to skip it.",
        path.display()
    );
    path
}

/// The folder of bags from an independent writer, `$ICP_ROSBAG_DIR` (a relative value taken
/// from [`workspace_root`]), with a bag (its
/// `metadata.yaml`) in each of `mcap/` and `sqlite3/`. Panics, naming the variable and the
/// path looked at, when it is unset or a bag is missing.
pub fn rosbag_dir() -> PathBuf {
    let how = "write them with `python3 scripts/write-test-bag.py DIR` (needs the Python \
               rosbags package) and set ICP_ROSBAG_DIR=DIR, or run `cargo test` without \
               --include-ignored to skip this test.";
    let Some(dir) = std::env::var_os(ROSBAG_DIR_ENV) else {
        panic!(
            "this test needs ROS 2 bags from an independent writer ({ROSBAG_DIR_ENV} unset): {how}"
        )
    };
    let dir = workspace_root().join(dir);
    for storage in ["mcap", "sqlite3"] {
        let metadata = dir.join(storage).join("metadata.yaml");
        assert!(
            metadata.is_file(),
            "this test needs ROS 2 bags from an independent writer ({ROSBAG_DIR_ENV}={}): no \
             file {}; {how}",
            dir.display(),
            metadata.display()
        );
    }
    dir
}
