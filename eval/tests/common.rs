//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};

/// The marina data directory from `ICP_DATA_DIR` (a relative value is taken from the
/// workspace root, since cargo runs tests from the crate folder), or `None` after saying on
/// the terminal, past the harness's capture, that the test is skipped.
pub fn marina_dir() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let env = std::env::var_os(datasets::marina::DATA_DIR_ENV).map(|d| root.join(d));
    match datasets::marina::find_in(datasets::marina::candidate_dirs(None, env.as_deref())) {
        Ok(d) => Some(d),
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "SKIPPED (marina data absent): {e}");
            None
        }
    }
}

/// A fresh, empty directory under the target dir.
pub fn scratch_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
