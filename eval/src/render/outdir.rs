//! An output directory that knows what it holds. Every file a run writes is named in the
//! directory's `manifest.json`; the next run into the same directory first removes the files
//! the last one listed, so no figure or table of an earlier run survives beside the new ones.
//! A directory that holds files icp-eval did not list is refused unless forced, and then
//! those files are left alone.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::EvalError;

/// The manifest's file name.
pub const MANIFEST: &str = "manifest.json";

/// What `manifest.json` holds.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
struct Manifest {
    /// The tool that wrote the files.
    tool: String,
    /// The files written, relative to the directory, sorted.
    files: BTreeSet<String>,
}

/// An output directory being written: its files are recorded as they are named.
#[derive(Debug)]
pub struct OutputDir {
    dir: PathBuf,
    written: Manifest,
}

impl OutputDir {
    /// Opens `dir` for a new run: creates it, or removes the files its manifest lists. A
    /// directory with other entries and no manifest is refused unless `force` (its entries are
    /// then kept).
    pub fn open(dir: &Path, force: bool) -> Result<Self, EvalError> {
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| EvalError::Io { path, source }
        };
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let manifest_path = dir.join(MANIFEST);
        let previous: Option<Manifest> = match std::fs::read_to_string(&manifest_path) {
            Ok(text) => Some(
                serde_json::from_str(&text).map_err(|e| EvalError::OutputDir {
                    dir: dir.to_path_buf(),
                    why: format!("its {MANIFEST} is not icp-eval's: {e}"),
                })?,
            ),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(io(&manifest_path)(e)),
        };
        match previous {
            Some(m) => {
                for name in &m.files {
                    let path = dir.join(checked_name(dir, name)?);
                    match std::fs::remove_file(&path) {
                        Ok(()) => {}
                        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                        Err(e) => return Err(io(&path)(e)),
                    }
                }
                std::fs::remove_file(&manifest_path).map_err(io(&manifest_path))?;
            }
            None if !force => {
                let mut entries: Vec<String> = std::fs::read_dir(dir)
                    .map_err(io(dir))?
                    .filter_map(|e| e.ok())
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .collect();
                entries.sort();
                if let Some(first) = entries.first() {
                    return Err(EvalError::OutputDir {
                        dir: dir.to_path_buf(),
                        why: format!(
                            "it holds {} entries icp-eval did not list (e.g. {first}): choose \
                             an empty or new directory, or pass --force to write beside them",
                            entries.len()
                        ),
                    });
                }
            }
            None => {}
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            written: Manifest {
                tool: format!("icp-eval {}", env!("CARGO_PKG_VERSION")),
                files: BTreeSet::new(),
            },
        })
    }

    /// The directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The path of file `name` in the directory, recorded in the manifest first (so a run
    /// that stops half-way still leaves a manifest of everything it may have written).
    pub fn file(&mut self, name: &str) -> Result<PathBuf, EvalError> {
        if self.written.files.insert(name.to_owned()) {
            let json = serde_json::to_string_pretty(&self.written)
                .map_err(|e| EvalError::Serialize(e.to_string()))?
                + "\n";
            write_atomic(&self.dir.join(MANIFEST), json.as_bytes())?;
        }
        Ok(self.dir.join(name))
    }

    /// Writes `bytes` to file `name` atomically and records it.
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> Result<(), EvalError> {
        let path = self.file(name)?;
        write_atomic(&path, bytes)
    }
}

/// `name` when it is a plain file name inside the directory (a manifest naming `../x` or an
/// absolute path is not icp-eval's, and nothing outside the directory is ever removed).
fn checked_name<'a>(dir: &Path, name: &'a str) -> Result<&'a str, EvalError> {
    let plain = Path::new(name)
        .components()
        .all(|c| matches!(c, std::path::Component::Normal(_)));
    if plain && !name.is_empty() {
        Ok(name)
    } else {
        Err(EvalError::OutputDir {
            dir: dir.to_path_buf(),
            why: format!("its {MANIFEST} names {name:?}, which is not a file inside it"),
        })
    }
}

/// Writes `bytes` to `path` atomically (temporary file in the same directory, then rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), EvalError> {
    let tmp = tmp_path(path);
    std::fs::write(&tmp, bytes).map_err(|source| EvalError::Io {
        path: tmp.clone(),
        source,
    })?;
    std::fs::rename(&tmp, path).map_err(|source| EvalError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The temporary name `write_atomic` uses for `path`.
pub fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".tmp");
    path.with_file_name(name)
}
