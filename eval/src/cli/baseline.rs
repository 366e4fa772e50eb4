//! `icp-eval baseline`: a run's summary.json, checked and written as a baseline for `gate`, with
//! the built-in tolerances beside it unless a tolerance file is there.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::Args;
use eval::measure::gate::{baseline_of, BUILTIN_TOLERANCE};
use eval::render::json::{summary_json, SUMMARY_FILE};

use crate::cli::gate::{read_report, tolerance_beside};

#[derive(Args)]
pub(crate) struct BaselineArgs {
    /// The run: the output directory of `run`, `compare` or `merge`, one dataset's directory of
    /// `reproduce` (e.g. OUT/marina), or its summary.json.
    #[arg(long, value_name = "RUN_DIR")]
    pub(crate) from: PathBuf,
    /// The baseline file to write (e.g. reports/baseline/mine.json). It is replaced if it
    /// exists, and its folder is made if needed.
    #[arg(long, value_name = "FILE")]
    pub(crate) out: PathBuf,
    /// Keep only these variants, comma-separated (default: every variant of the run). A later
    /// run's other variants are then not gated, and the gate says so.
    #[arg(long, value_delimiter = ',', value_name = "A,B")]
    pub(crate) variants: Vec<String>,
}

/// The summary.json of `from` (a run's directory or the file itself), or why there is none.
fn summary_of(from: &Path) -> Result<PathBuf> {
    if from.is_file() {
        return Ok(from.to_owned());
    }
    if !from.is_dir() {
        bail!("{}: no such run directory or file", from.display());
    }
    let summary = from.join(SUMMARY_FILE);
    if summary.exists() {
        return Ok(summary);
    }
    let entries: Vec<PathBuf> = std::fs::read_dir(from)
        .with_context(|| format!("reading {}", from.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .collect();
    let mut runs: Vec<String> = entries
        .iter()
        .filter(|p| p.join(SUMMARY_FILE).is_file())
        .map(|p| p.display().to_string())
        .collect();
    runs.sort();
    let parts = entries.iter().any(|p| {
        p.file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with("part-") && n.ends_with(".cbor"))
    });
    let hint = if !runs.is_empty() {
        format!(": it holds runs, give one of them: {}", runs.join(", "))
    } else if parts {
        ": it holds a sharded run's part files; merge them first (icp-eval merge PARTS --out DIR)"
            .to_owned()
    } else {
        ": not the output directory of a run".to_owned()
    };
    bail!("{}: no {SUMMARY_FILE} in it{hint}", from.display())
}

/// Writes the built-in tolerances to `path` unless a file is there; says which.
fn write_tolerance(path: &Path) -> Result<()> {
    let created = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path);
    match created {
        Ok(mut file) => {
            file.write_all(BUILTIN_TOLERANCE.as_bytes())
                .with_context(|| format!("writing {}", path.display()))?;
            println!("wrote {} (the built-in tolerances)", path.display());
        }
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
            println!("kept {} (already there, not overwritten)", path.display());
        }
        Err(e) => return Err(e).with_context(|| format!("writing {}", path.display())),
    }
    Ok(())
}

pub(crate) fn baseline_cmd(args: BaselineArgs) -> Result<ExitCode> {
    let summary = summary_of(&args.from)?;
    let report = baseline_of(read_report(&summary)?, &args.variants)
        .with_context(|| format!("{} cannot be a baseline", summary.display()))?;
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(&args.out, summary_json(&report)?)
        .with_context(|| format!("writing {}", args.out.display()))?;
    let names: Vec<&str> = report.variants.iter().map(|v| v.name.as_str()).collect();
    println!(
        "wrote {} (baseline of {}: {})",
        args.out.display(),
        report.dataset.name,
        names.join(", ")
    );
    write_tolerance(&tolerance_beside(&args.out))?;
    Ok(ExitCode::SUCCESS)
}
